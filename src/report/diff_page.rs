//! The diff report (`slamlab diff BASE NEW --report DIR`): the diff's parameter changes and table,
//! and, for every study and metric that changed, its error-vs-parameter plots with BASE (dashed)
//! and NEW (solid) overlaid — as a self-contained HTML page and a LaTeX document with pgfplots.

use super::ReportError;
use super::figure::{self, LineFigure, LineSeries, SeriesPoint, XAxis};
use super::model::{FigureView, TableView};
use crate::diff::Diff;
use crate::judge::change::Verdict;
use crate::stats::{self, sig};
use crate::store::{self, RunStatus, StudyData};
use serde::Serialize;
use std::path::Path;

#[derive(Debug, Clone, Serialize)]
struct DiffView {
    summary: String,
    spec_changes: Vec<(String, Vec<String>)>,
    only: Vec<String>,
    table: TableView,
    rates: Vec<String>,
    figures: Vec<FigureView>,
}

/// Mean and CI of `metric` over a cell's successful runs.
fn cell(s: &StudyData, map: &str, algorithm: &str, point: &str, metric: &str) -> stats::Summary {
    let v: Vec<f64> = s
        .runs
        .iter()
        .filter(|r| {
            r.map == map
                && r.algorithm == algorithm
                && r.point == point
                && r.status == RunStatus::Ok
        })
        .filter_map(|r| r.metric(metric))
        .filter(|v| v.is_finite())
        .collect();
    stats::summarize_nonnegative(&v)
}

/// BASE-vs-NEW figures of one study: per plot group with a swept parameter and per metric with a
/// non-identical row, one figure with a (dashed BASE, solid NEW) pair of series per map/algorithm.
fn study_figures(id: &str, a: &StudyData, b: &StudyData, changed: &[&str]) -> Vec<FigureView> {
    let mut out = Vec::new();
    let spec = &b.resolved.spec;
    for (gi, group) in b.resolved.groups.iter().enumerate() {
        // a study without sweeps has one group, of its base point: plotted by its label
        let x_param = group.params.first().cloned().unwrap_or_else(|| "configuration".to_string());
        let x_param = &x_param;
        let categorical = group.named || group.params.is_empty();
        let points: Vec<&crate::store::PointRecord> =
            b.resolved.points.iter().filter(|p| p.groups.contains(&gi)).collect();
        // x: the swept value when every point has a number, else one position per point (named cells)
        let numeric: Option<Vec<f64>> = if categorical {
            None
        } else {
            points
                .iter()
                .map(|p| {
                    p.assignments
                        .get(x_param)
                        .and_then(|v| store::ParamValue::from_toml(v).as_f64())
                })
                .collect()
        };
        let (axis, xs, ticks): (XAxis, Vec<f64>, Vec<(f64, String)>) = match numeric {
            Some(xs) => {
                let ticks = xs.iter().map(|&x| (x, sig(x, 3))).collect();
                (XAxis::Linear, xs, ticks)
            }
            None => {
                let names: Vec<String> = points.iter().map(|p| p.label.clone()).collect();
                let xs = (0..points.len()).map(|i| i as f64).collect();
                let ticks = names.iter().enumerate().map(|(i, n)| (i as f64, n.clone())).collect();
                (XAxis::Categorical(names), xs, ticks)
            }
        };
        for metric in changed {
            let mut series = Vec::new();
            for map in &spec.maps {
                for algorithm in &spec.algorithms {
                    for (side, data, dashed) in [("BASE", a, true), ("NEW", b, false)] {
                        let mut pts: Vec<SeriesPoint> = points
                            .iter()
                            .zip(&xs)
                            .map(|(p, &x)| {
                                let s = cell(data, map, algorithm.as_str(), &p.label, metric);
                                SeriesPoint {
                                    x,
                                    mean: s.mean,
                                    lo: if dashed { f64::NAN } else { s.ci_low },
                                    hi: if dashed { f64::NAN } else { s.ci_high },
                                }
                            })
                            .collect();
                        pts.sort_by(|p, q| p.x.total_cmp(&q.x));
                        let color = series.len() / 2;
                        series.push(LineSeries {
                            label: format!("{map} / {algorithm} ({side})"),
                            color,
                            points: pts,
                            dashed,
                            scatter: false,
                        });
                    }
                }
            }
            let unit = crate::metrics::metric_def(metric).map_or("", |m| m.unit);
            let fig = LineFigure {
                x_label: if group.named { "cell".into() } else { x_param.clone() },
                y_label: format!("{metric} [{unit}]"),
                x_axis: axis.clone(),
                x_ticks: ticks.clone(),
                series,
            };
            out.push(FigureView {
                panel: false,
                file: format!("{id}--g{gi}--{metric}").replace(['_', '.'], "-"),
                caption: format!(
                    "{id}: {metric} against {}, BASE dashed, NEW solid with its 95 % CI band.",
                    if group.named { "the named cell" } else { x_param.as_str() }
                ),
                svg: figure::line_svg(&fig),
                pgf: super::pgf::line_pgf(&fig),
            });
        }
    }
    out
}

/// Writes `index.html`, `diff.tex` and `figures/` into `out` (created; existing files replaced).
pub fn render_diff(d: &Diff, out: &Path) -> Result<(), ReportError> {
    let mut figures = Vec::new();
    for (id, dir_a, dir_b) in &d.compared {
        let mut changed: Vec<&str> = d
            .rows
            .iter()
            .filter(|r| &r.study == id && r.verdict != Verdict::Identical)
            .map(|r| r.metric.as_str())
            .collect();
        changed.sort();
        changed.dedup();
        if changed.is_empty() {
            continue;
        }
        figures.extend(study_figures(
            id,
            &store::read_study(dir_a)?,
            &store::read_study(dir_b)?,
            &changed,
        ));
    }
    let (header, rows) = crate::diff::table_cells(d);
    let view = DiffView {
        summary: crate::diff::summary(d),
        spec_changes: d.spec_changes.clone(),
        only: [("only in BASE", &d.only_base), ("only in NEW", &d.only_new)]
            .iter()
            .filter(|(_, l)| !l.is_empty())
            .map(|(k, l)| format!("Studies {k}: {}", l.join(", ")))
            .collect(),
        table: TableView {
            align: format!("lll{}", "r".repeat(header.len() - 3)),
            columns: header.iter().map(|h| h.to_string()).collect(),
            rows,
        },
        rates: d
            .rates
            .iter()
            .map(|r| {
                format!(
                    "{} / {}: failures {}/{} → {}/{} (Fisher p = {})",
                    r.study,
                    r.cell,
                    r.base.0,
                    r.base.1,
                    r.new.0,
                    r.new.1,
                    sig(r.p, 3)
                )
            })
            .collect(),
        figures,
    };
    let env = super::environment();
    let palette = minijinja::Value::from_safe_string(super::pgf::palette_definitions());
    let html = super::render(&env, "diff.html", minijinja::context! { diff => &view })?;
    let tex =
        super::render(&env, "diff.tex", minijinja::context! { diff => &view, palette => palette })?;
    let io = |p: &Path, e: std::io::Error| {
        ReportError::Store(store::StoreError::Io { path: p.to_path_buf(), source: e })
    };
    let figs = out.join("figures");
    std::fs::create_dir_all(&figs).map_err(|e| io(&figs, e))?;
    for f in &view.figures {
        for (ext, text) in [("svg", &f.svg), ("tex", &f.pgf)] {
            let p = figs.join(format!("{}.{ext}", f.file));
            std::fs::write(&p, text).map_err(|e| io(&p, e))?;
        }
    }
    for (name, text) in [("index.html", html), ("diff.tex", tex)] {
        let p = out.join(name);
        std::fs::write(&p, text).map_err(|e| io(&p, e))?;
    }
    Ok(())
}
