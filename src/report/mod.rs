//! Stored results → `reports/`: an index page, and per study a self-contained HTML page (inline
//! SVG), a LaTeX document with pgfplots figures, the figures as files, and `summary.csv`.
//! Reads only the store. Output is byte-identical for identical results: no timestamps, no
//! absolute paths, explicit ordering, fixed significant figures.

pub mod figure;
pub mod latex;
pub mod pgf;
pub mod stats;
pub mod view;

use crate::store::{self, StoreError};
use minijinja::{AutoEscape, Environment, UndefinedBehavior};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("template {template}: {message}")]
    Template { template: String, message: String },
}

/// LaTeX auto-escaping, applied to every `{{ … }}` in a `.tex` template.
const TEX: AutoEscape = AutoEscape::Custom("tex");

fn environment() -> Environment<'static> {
    let mut env = Environment::new();
    env.set_undefined_behavior(UndefinedBehavior::Strict);
    env.set_auto_escape_callback(|name| {
        if name.ends_with(".html") {
            AutoEscape::Html
        } else if name.ends_with(".tex") {
            TEX
        } else {
            AutoEscape::None
        }
    });
    env.set_formatter(|out, state, value| {
        let text = || value.as_str().map(str::to_string).unwrap_or_else(|| value.to_string());
        match state.auto_escape() {
            _ if value.is_safe() => minijinja::escape_formatter(out, state, value),
            TEX => out.write_str(&latex::escape(&text())).map_err(minijinja::Error::from),
            // The five characters that matter in text and quoted attributes; `/` stays readable
            // (minijinja's default escapes it, which clutters report diffs).
            AutoEscape::Html => out.write_str(&html_escape(&text())).map_err(minijinja::Error::from),
            _ => minijinja::escape_formatter(out, state, value),
        }
    });
    for (name, source) in [
        ("index.html", include_str!("../../templates/index.html.j2")),
        ("study.html", include_str!("../../templates/study.html.j2")),
        ("study.tex", include_str!("../../templates/study.tex.j2")),
    ] {
        env.add_template(name, source).expect("bundled templates parse");
    }
    env
}

fn html_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

fn render(env: &Environment<'_>, template: &str, ctx: minijinja::Value) -> Result<String, ReportError> {
    env.get_template(template)
        .and_then(|t| t.render(ctx))
        .map_err(|e| ReportError::Template { template: template.to_string(), message: format!("{e:#}") })
}

/// What was rendered.
#[derive(Debug, Clone, PartialEq)]
pub struct ReportSummary {
    pub studies: Vec<String>,
}

/// Renders every study under `results_dir` into `reports_dir` (replaced atomically as a whole).
pub fn render_all(results_dir: &Path, reports_dir: &Path) -> Result<ReportSummary, ReportError> {
    let env = environment();
    let mut pages = Vec::new();
    for dir in store::list_studies(results_dir)? {
        let data = store::read_study(&dir)?;
        let trace_error = std::cell::RefCell::new(None);
        let traces = |ids: &[String]| match store::read_traces(&dir, &|id| ids.iter().any(|i| i == id)) {
            Ok(t) => t,
            Err(e) => {
                trace_error.borrow_mut().get_or_insert(e);
                Vec::new()
            }
        };
        let built = view::build(&data, &traces);
        if let Some(e) = trace_error.into_inner() {
            return Err(e.into());
        }
        pages.push(built);
    }
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    let palette = pgf::palette_definitions();
    for p in &pages {
        let id = &p.view.id;
        let ctx = minijinja::context! { study => &p.view, palette => minijinja::Value::from_safe_string(palette.clone()) };
        files.push((format!("{id}/index.html"), render(&env, "study.html", ctx.clone())?.into_bytes()));
        files.push((format!("{id}/{id}.tex"), render(&env, "study.tex", ctx)?.into_bytes()));
        files.push((format!("{id}/summary.csv"), p.csv.clone().into_bytes()));
        for f in p.view.groups.iter().flat_map(|g| &g.figures).chain(&p.view.trajectories) {
            files.push((format!("{id}/figures/{}.svg", f.file), f.svg.clone().into_bytes()));
            files.push((format!("{id}/figures/{}.tex", f.file), f.pgf.clone().into_bytes()));
        }
    }
    let index: Vec<&view::IndexEntry> = pages.iter().map(|p| &p.index).collect();
    files.push(("index.html".into(), render(&env, "index.html", minijinja::context! { studies => index })?.into_bytes()));

    store::write_dir_atomically(reports_dir, |tmp| {
        for (rel, bytes) in &files {
            let path = tmp.join(rel);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| StoreError::Io { path: parent.to_path_buf(), source: e })?;
            }
            std::fs::write(&path, bytes).map_err(|e| StoreError::Io { path: path.clone(), source: e })?;
        }
        Ok(())
    })?;
    Ok(ReportSummary { studies: pages.iter().map(|p| p.view.id.clone()).collect() })
}
