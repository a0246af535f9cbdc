//! Figure models → pgfplots code for the LaTeX reports (`\input{figures/<name>.tex}`), drawn
//! natively by LaTeX so fonts match the document and no image conversion is needed.

use super::figure::{
    ContourFigure, LineFigure, PALETTE, ScanMapFigure, TrajectoryFigure, XAxis, decimate,
};
use super::latex::escape;
use std::fmt::Write;

/// Most cells an incremental map keeps in a pgfplots figure.
const PGF_MAP_POINTS: usize = 1000;
/// Most points a path keeps in a pgfplots figure (TeX memory is limited).
const PGF_PATH_POINTS: usize = 400;

/// `\definecolor` lines for the series palette (for the document preamble).
pub fn palette_definitions() -> String {
    PALETTE
        .iter()
        .enumerate()
        .map(|(i, hex)| format!("\\definecolor{{slamlab{i}}}{{HTML}}{{{}}}\n", hex.to_uppercase()))
        .collect()
}

/// Significant figures of coordinates: far below what a printed figure resolves, and last-digit
/// floating-point noise then cannot change the file (committed reports diff cleanly).
const PGF_DIGITS: usize = 6;

/// Legend columns that fit the text width above a plot: as many as entries of the longest label
/// fit (a \footnotesize character ≈ 4.4 pt, a swatch and gap ≈ 30 pt), 1 to 3.
fn legend_columns<'a>(labels: impl Iterator<Item = &'a str>) -> usize {
    let longest = labels.map(|l| l.chars().count()).max().unwrap_or(0) as f64;
    ((440.0 / (longest * 5.2 + 36.0)).floor() as usize).clamp(1, 3)
}

fn num(v: f64) -> String {
    crate::stats::sig_ascii(v, PGF_DIGITS)
}

/// Series longer than this are drawn without marks (TeX's memory is shared by a document's
/// figures)…
const PGF_MARKED_POINTS: usize = 60;
/// …and thinned to about this many points: per bucket of consecutive points, the first and the
/// largest, so that a trace keeps its spikes.
const PGF_SERIES_POINTS: usize = 400;

fn thin(points: Vec<&super::figure::SeriesPoint>) -> Vec<&super::figure::SeriesPoint> {
    if points.len() <= PGF_SERIES_POINTS {
        return points;
    }
    let bucket = points.len().div_ceil(PGF_SERIES_POINTS / 2);
    let mut out = Vec::new();
    for chunk in points.chunks(bucket) {
        let first = chunk[0];
        let top = chunk
            .iter()
            .copied()
            .max_by(|a, b| a.mean.total_cmp(&b.mean))
            .expect("a chunk is not empty");
        out.push(first);
        if !std::ptr::eq(top, first) {
            out.push(top);
        }
    }
    if let (Some(last), Some(end)) = (points.last(), out.last()) {
        if !std::ptr::eq(*last, *end) {
            out.push(last);
        }
    }
    out
}

pub fn line_pgf(fig: &LineFigure) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "\\begin{{tikzpicture}}");
    let mut opts = vec![
        "width=0.95\\linewidth".to_string(),
        "height=0.55\\linewidth".to_string(),
        format!("xlabel={{{}}}", escape(&fig.x_label)),
        // a long swept-parameter list wraps instead of running into the margin
        "xlabel style={align=center, text width=0.8\\linewidth}".to_string(),
        format!("ylabel={{{}}}", escape(&fig.y_label)),
        // the legend above the plot, never over its data
        format!("legend columns={}", legend_columns(fig.series.iter().map(|s| s.label.as_str()))),
        "legend cell align=left".to_string(),
        "legend style={font=\\footnotesize, at={(0.5,1.03)}, anchor=south, draw=none}".to_string(),
        "tick label style={font=\\footnotesize}".to_string(),
        "scaled ticks=false".to_string(),
    ];
    let all_nonneg = fig
        .series
        .iter()
        .flat_map(|s| &s.points)
        .filter(|p| p.mean.is_finite())
        .all(|p| p.mean >= 0.0 && (!p.lo.is_finite() || p.lo >= 0.0));
    if all_nonneg {
        opts.push("ymin=0".into());
    }
    match &fig.x_axis {
        XAxis::Linear => {}
        XAxis::Log => {
            opts.push("xmode=log".into());
            opts.push("log basis x=10".into());
            // reach the outermost ticks (decades), as the SVG does
            let ticks: Vec<f64> =
                fig.x_ticks.iter().map(|(x, _)| *x).filter(|x| x.is_finite() && *x > 0.0).collect();
            let data: Vec<f64> = fig
                .series
                .iter()
                .flat_map(|s| &s.points)
                .map(|p| p.x)
                .filter(|x| x.is_finite() && *x > 0.0)
                .collect();
            let all = || ticks.iter().chain(&data).copied();
            if !ticks.is_empty() {
                opts.push(format!("xmin={}", num(all().fold(f64::INFINITY, f64::min))));
                opts.push(format!("xmax={}", num(all().fold(f64::NEG_INFINITY, f64::max))));
            }
        }
        XAxis::Categorical(_) => {}
    }
    if !matches!(fig.x_axis, XAxis::Linear) {
        // a swept ∞ (e.g. "always resample") has no place on a numeric axis, as in the SVG
        let finite: Vec<&(f64, String)> =
            fig.x_ticks.iter().filter(|(x, _)| x.is_finite()).collect();
        let ticks: Vec<String> = finite.iter().map(|(x, _)| num(*x)).collect();
        let labels: Vec<String> =
            finite.iter().map(|(_, l)| format!("{{{}}}", escape(l))).collect();
        opts.push(format!("xtick={{{}}}", ticks.join(",")));
        opts.push(format!("xticklabels={{{}}}", labels.join(",")));
        opts.push("xticklabel style={rotate=0}".into());
    }
    let _ = writeln!(s, "\\begin{{axis}}[\n  {}\n]", opts.join(",\n  "));
    for (i, series) in fig.series.iter().enumerate() {
        let color = format!("slamlab{}", series.color % PALETTE.len());
        let pts: Vec<_> =
            series.points.iter().filter(|p| p.mean.is_finite() && p.x.is_finite()).collect();
        let many = pts.len() > PGF_MARKED_POINTS;
        let pts = thin(pts);
        let band: Vec<_> = pts
            .iter()
            .filter(|p| p.lo.is_finite() && p.hi.is_finite() && !series.dashed && !series.scatter)
            .collect();
        if band.len() >= 2 {
            let coords = |f: &dyn Fn(&&&super::figure::SeriesPoint) -> f64| {
                band.iter()
                    .map(|p| format!("({},{})", num(p.x), num(f(p))))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            let _ = writeln!(
                s,
                "\\addplot[name path=hi{i}, draw=none, forget plot] coordinates {{{}}};",
                coords(&|p| p.hi)
            );
            let _ = writeln!(
                s,
                "\\addplot[name path=lo{i}, draw=none, forget plot] coordinates {{{}}};",
                coords(&|p| p.lo)
            );
            let _ = writeln!(
                s,
                "\\addplot[fill={color}, fill opacity=0.18, draw=none, forget plot] fill between[of=hi{i} and lo{i}];"
            );
        }
        let bars = series.dashed && pts.iter().any(|p| p.lo.is_finite() && p.hi.is_finite());
        let coords: Vec<String> = pts
            .iter()
            .map(|p| {
                if bars && p.lo.is_finite() && p.hi.is_finite() {
                    format!(
                        "({},{}) += (0,{}) -= (0,{})",
                        num(p.x),
                        num(p.mean),
                        num(p.hi - p.mean),
                        num(p.mean - p.lo)
                    )
                } else if bars {
                    format!("({},{}) += (0,0) -= (0,0)", num(p.x), num(p.mean))
                } else {
                    format!("({},{})", num(p.x), num(p.mean))
                }
            })
            .collect();
        let style = if many && !series.scatter && !series.dashed {
            // a long trace (every match of a run): a line without marks
            if super::figure::dotted(series.color) { "thick, densely dotted" } else { "thick" }
        } else if series.scatter {
            "only marks, mark=*, mark size=2pt"
        } else if bars {
            "dashed, thick, mark=o, mark size=1.5pt, error bars/.cd, y dir=both, y explicit, error bar style={solid, thin}"
        } else if series.dashed {
            "dashed, thick, mark=o, mark size=1.5pt"
        } else if super::figure::dotted(series.color) {
            "thick, densely dotted, mark=square*, mark size=1.5pt, mark options={solid}"
        } else {
            "thick, mark=*, mark size=1.5pt"
        };
        let _ =
            writeln!(s, "\\addplot[color={color}, {style}] coordinates {{{}}};", coords.join(" "));
        let _ = writeln!(s, "\\addlegendentry{{{}}}", escape(&series.label));
    }
    let _ = writeln!(s, "\\end{{axis}}\n\\end{{tikzpicture}}");
    s
}

pub fn trajectory_pgf(fig: &TrajectoryFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds();
    let mut s = String::new();
    let _ = writeln!(s, "\\begin{{tikzpicture}}");
    let _ = writeln!(
        s,
        "\\begin{{axis}}[\n  axis equal image,\n  width=0.95\\linewidth,\n  xmin={}, xmax={}, ymin={}, ymax={},\n  xlabel={{$x$ [m]}}, ylabel={{$y$ [m]}},\n  legend columns={},\n  legend cell align=left,\n  legend style={{font=\\footnotesize, at={{(0.5,1.03)}}, anchor=south, draw=none}},\n  tick label style={{font=\\footnotesize}}\n]",
        num(x0),
        num(x1),
        num(y0),
        num(y1),
        legend_columns(fig.paths.iter().map(|p| p.label.as_str()).chain(["true corners"]))
    );
    for (a, b) in &fig.walls {
        let _ = writeln!(
            s,
            "\\addplot[black, line width=1.5pt, forget plot] coordinates {{({},{}) ({},{})}};",
            num(a.0),
            num(a.1),
            num(b.0),
            num(b.1)
        );
    }
    for p in fig
        .paths
        .iter()
        .filter(|p| p.color.is_some())
        .chain(fig.paths.iter().filter(|p| p.color.is_none()))
    {
        let style = match p.color {
            Some(c) if super::figure::dotted(c) => {
                format!("color=slamlab{}, thick, densely dotted", c % PALETTE.len())
            }
            Some(c) => format!("color=slamlab{}, thick", c % PALETTE.len()),
            None => "black, thin".to_string(),
        };
        let coords: Vec<String> = decimate(&p.points, PGF_PATH_POINTS)
            .iter()
            .map(|(x, y)| format!("({},{})", num(*x), num(*y)))
            .collect();
        let _ = writeln!(s, "\\addplot[{style}] coordinates {{{}}};", coords.join(" "));
        let _ = writeln!(s, "\\addlegendentry{{{}}}", escape(&p.label));
    }
    for &(color, rho, theta) in &fig.est_lines {
        if let Some((a, b)) = super::figure::clip_line(rho, theta, ((x0, x1), (y0, y1))) {
            let _ = writeln!(
                s,
                "\\addplot[color=slamlab{}, densely dashed, thin, forget plot] coordinates {{({},{}) ({},{})}};",
                color % PALETTE.len(),
                num(a.0),
                num(a.1),
                num(b.0),
                num(b.1)
            );
        }
    }
    if !fig.est_corners.is_empty() {
        for color in
            fig.est_corners.iter().map(|(c, _)| *c).collect::<std::collections::BTreeSet<_>>()
        {
            let coords: Vec<String> = fig
                .est_corners
                .iter()
                .filter(|(c, _)| *c == color)
                .map(|(_, (x, y))| format!("({},{})", num(*x), num(*y)))
                .collect();
            let _ = writeln!(
                s,
                "\\addplot[only marks, mark=x, mark size=2pt, color=slamlab{}, forget plot] coordinates {{{}}};",
                color % PALETTE.len(),
                coords.join(" ")
            );
        }
    }
    if !fig.corners.is_empty() {
        let coords: Vec<String> =
            fig.corners.iter().map(|(x, y)| format!("({},{})", num(*x), num(*y))).collect();
        let _ = writeln!(
            s,
            "\\addplot[only marks, mark=*, mark size=1.5pt, red!80!black] coordinates {{{}}};",
            coords.join(" ")
        );
        let _ = writeln!(
            s,
            "\\addlegendentry{{{}}}",
            if fig.point_landmarks { "true landmarks" } else { "true corners" }
        );
    }
    let _ = writeln!(
        s,
        "\\addplot[only marks, mark=triangle*, mark size=3pt, black, forget plot] coordinates {{({},{})}};",
        num(fig.start.0),
        num(fig.start.1)
    );
    let _ = writeln!(s, "\\end{{axis}}\n\\end{{tikzpicture}}");
    s
}

/// Polylines as one `coordinates` stream, separated by empty lines (pgfplots' jumps).
fn polylines(lines: &[Vec<(f64, f64)>]) -> String {
    lines
        .iter()
        .map(|l| {
            l.iter()
                .map(|(x, y)| format!("({},{})", num(*x), num(*y)))
                .collect::<Vec<_>>()
                .join(" ")
        })
        .collect::<Vec<_>>()
        .join("\n\n")
}

pub fn contour_pgf(fig: &ContourFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds;
    let mut s = String::new();
    let _ = writeln!(s, "\\begin{{tikzpicture}}");
    let _ = writeln!(
        s,
        "\\begin{{axis}}[\n  axis equal image,\n  width=0.7\\linewidth,\n  xmin={}, xmax={}, ymin={}, ymax={},\n  xlabel={{$x$ [m]}}, ylabel={{$y$ [m]}},\n  legend columns={},\n  legend cell align=left,\n  legend style={{font=\\footnotesize, at={{(0.5,1.03)}}, anchor=south, draw=none}},\n  tick label style={{font=\\footnotesize}},\n  scaled ticks=false\n]",
        num(x0),
        num(x1),
        num(y0),
        num(y1),
        legend_columns(
            fig.paths.iter().map(|p| p.label.as_str()).chain(["true position", "initial guess"])
        )
    );
    let n = fig.levels.len().max(1);
    for (k, (_, lines)) in fig.levels.iter().enumerate() {
        if lines.is_empty() {
            continue;
        }
        let _ = writeln!(
            s,
            "\\addplot[black!{}, thin, forget plot] coordinates {{{}}};",
            85 - 60 * k / n,
            polylines(lines)
        );
    }
    let clip = |p: &&(f64, f64)| p.0 >= x0 && p.0 <= x1 && p.1 >= y0 && p.1 <= y1;
    for p in &fig.paths {
        let color =
            p.color.map_or("black!55".to_string(), |c| format!("slamlab{}", c % PALETTE.len()));
        let coords: Vec<String> = p
            .points
            .iter()
            .filter(clip)
            .map(|(x, y)| format!("({},{})", num(*x), num(*y)))
            .collect();
        let _ = writeln!(
            s,
            "\\addplot[color={color}, thick, mark=*, mark size=1pt] coordinates {{{}}};",
            coords.join(" ")
        );
        let _ = writeln!(s, "\\addlegendentry{{{}}}", escape(&p.label));
    }
    let _ = writeln!(
        s,
        "\\addplot[only marks, mark=square*, mark size=2.5pt, red!80!black] coordinates {{({},{})}};",
        num(fig.truth.0),
        num(fig.truth.1)
    );
    let _ = writeln!(s, "\\addlegendentry{{true position}}");
    let _ = writeln!(
        s,
        "\\addplot[only marks, mark=triangle*, mark size=3pt, black] coordinates {{({},{})}};",
        num(fig.initial.0),
        num(fig.initial.1)
    );
    let _ = writeln!(s, "\\addlegendentry{{initial guess}}");
    let _ = writeln!(s, "\\end{{axis}}\n\\end{{tikzpicture}}");
    s
}

pub fn scan_map_pgf(fig: &ScanMapFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds();
    let mut s = String::new();
    let _ = writeln!(s, "\\begin{{tikzpicture}}");
    let _ = writeln!(
        s,
        "\\begin{{axis}}[\n  axis equal image,\n  width=0.8\\linewidth,\n  xmin={}, xmax={}, ymin={}, ymax={},\n  xlabel={{$x$ [m]}}, ylabel={{$y$ [m]}},\n  legend columns={},\n  legend cell align=left,\n  legend style={{font=\\footnotesize, at={{(0.5,1.03)}}, anchor=south, draw=none}},\n  tick label style={{font=\\footnotesize}}\n]",
        num(x0),
        num(x1),
        num(y0),
        num(y1),
        legend_columns([fig.label.as_str(), "estimated scan poses"].into_iter())
    );
    for (a, b) in &fig.walls {
        let _ = writeln!(
            s,
            "\\addplot[black!50, thin, forget plot] coordinates {{({},{}) ({},{})}};",
            num(a.0),
            num(a.1),
            num(b.0),
            num(b.1)
        );
    }
    let color = format!("slamlab{}", fig.color % PALETTE.len());
    // at most PGF_MAP_POINTS cells, evenly thinned (TeX's memory)
    let step = fig.points.len().div_ceil(PGF_MAP_POINTS).max(1);
    let points: Vec<String> = fig
        .points
        .iter()
        .step_by(step)
        .map(|(x, y)| format!("({},{})", num(*x), num(*y)))
        .collect();
    let _ = writeln!(
        s,
        "\\addplot[only marks, mark=*, mark size=0.25pt, color={color}] coordinates {{{}}};",
        points.join(" ")
    );
    let _ = writeln!(s, "\\addlegendentry{{{}}}", escape(&fig.label));
    let path: Vec<String> = decimate(&fig.path, PGF_PATH_POINTS)
        .iter()
        .map(|(x, y)| format!("({},{})", num(*x), num(*y)))
        .collect();
    let _ = writeln!(
        s,
        "\\addplot[color={color}, thin, opacity=0.6] coordinates {{{}}};",
        path.join(" ")
    );
    let _ = writeln!(s, "\\addlegendentry{{estimated scan poses}}");
    let _ = writeln!(s, "\\end{{axis}}\n\\end{{tikzpicture}}");
    s
}

/// Sobol' indices as grouped bars with their intervals (see [`super::figure::IndexBarsFigure`]).
pub fn index_bars_pgf(fig: &super::figure::IndexBarsFigure) -> String {
    let (y0, y1) = fig.y_range();
    let labels: Vec<String> = fig.params.iter().map(|p| escape(p)).collect();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\\begin{{tikzpicture}}\n\\begin{{axis}}[width=\\linewidth, height=6cm, ybar, bar width=6pt, ymin={}, ymax={}, ylabel={{Sobol' index}}, xtick={{1,...,{}}}, xticklabels={{{}}}, x tick label style={{rotate=45, anchor=east, font=\\footnotesize}}, legend style={{font=\\footnotesize, at={{(0.5,1.02)}}, anchor=south}}, legend columns=3, enlarge x limits=0.06]",
        num(y0),
        num(y1),
        fig.params.len(),
        labels.join(",")
    );
    for (i, (values, name)) in
        [(&fig.s1, "S1 (first order)"), (&fig.st, "ST (total)")].into_iter().enumerate()
    {
        let _ = write!(
            out,
            "\\addplot+[draw=slamlab{i}, fill=slamlab{i}, error bars/.cd, y dir=both, y explicit] coordinates {{"
        );
        for (k, &(v, lo, hi)) in values.iter().enumerate() {
            if v.is_finite() {
                let (plus, minus) =
                    if lo.is_finite() && hi.is_finite() { (hi - v, v - lo) } else { (0.0, 0.0) };
                let _ = write!(
                    out,
                    " ({}, {}) += (0, {}) -= (0, {})",
                    k + 1,
                    num(v),
                    num(plus.max(0.0)),
                    num(minus.max(0.0))
                );
            }
        }
        let _ = writeln!(out, " }};\n\\addlegendentry{{{name}}}");
    }
    if let Some(f) = fig.noise_floor.filter(|f| f.is_finite()) {
        let _ = writeln!(
            out,
            "\\draw[dashed, gray] (axis cs:0.5,{0}) -- (axis cs:{1}.5,{0});",
            num(f),
            fig.params.len()
        );
    }
    out.push_str("\\end{axis}\n\\end{tikzpicture}\n");
    out
}

/// Morris's μ*–σ plane (see [`super::figure::MorrisFigure`]).
pub fn morris_pgf(fig: &super::figure::MorrisFigure) -> String {
    let m = fig.max();
    let mut out = String::new();
    let unit = escape(&fig.unit);
    let _ = writeln!(
        out,
        "\\begin{{tikzpicture}}\n\\begin{{axis}}[width=0.75\\linewidth, height=7cm, xmin=0, ymin=0, xmax={0}, ymax={0}, xlabel={{$\\mu^*$ [{1}]}}, ylabel={{$\\sigma$ [{1}]}}]",
        num(m),
        unit
    );
    let _ = writeln!(out, "\\addplot[gray, domain=0:{0}] {{x}};", num(m));
    if let Some(f) = fig.noise_floor.filter(|f| f.is_finite()) {
        let _ = writeln!(
            out,
            "\\addplot[dashed, slamlab3] coordinates {{({0}, 0) ({0}, {1})}};",
            num(f),
            num(m)
        );
    }
    let _ = write!(
        out,
        "\\addplot[only marks, mark=*, color=slamlab0, nodes near coords, point meta=explicit symbolic, every node near coord/.append style={{font=\\scriptsize, anchor=south west}}] coordinates {{"
    );
    for ((p, &x), &y) in fig.params.iter().zip(&fig.mu_star).zip(&fig.sigma) {
        if x.is_finite() && y.is_finite() {
            let _ = write!(out, " ({}, {}) [{}]", num(x), num(y), escape(p));
        }
    }
    out.push_str(" };\n\\end{axis}\n\\end{tikzpicture}\n");
    out
}
