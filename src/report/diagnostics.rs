//! The stored match diagnostics ([`crate::scanmatch::diagnose`]) → figures and sentences: [EP]'s
//! orientation-search plots with Diosi's parabola (Figs 25/33/50), PSM's own criterion, f contours
//! with every matcher's path (Figs 26/34/51), f per half-iteration (Fig 27) and the incremental
//! maps (Figs 52–59).

use super::figure::{
    self, ContourFigure, LineFigure, LineSeries, PathSeries, ScanMapFigure, SeriesPoint, XAxis,
};
use super::model::FigureView;
use crate::algo::Catalogue;
use crate::scanmatch::diagnose::{
    Diagnostics, MatchDiagnostic, OrientationSlices, diosi_parabola, vertex,
};
use crate::spec::ExperimentSpec;
use crate::stats::sig;
use crate::world::map::Map;

/// Palette slots of the marks that are not an algorithm (tab10's cyan, as [EP]'s parabola, and gray).
const PARABOLA: usize = 9;
const TRUTH: usize = 7;
/// Contour levels: these quantiles of f on the grid (denser near the minimum).
const LEVEL_QUANTILES: [f64; 8] = [0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9];
/// Incremental maps are drawn with at most this many cells across their extent.
const MAP_CELLS_ACROSS: f64 = 220.0;
/// … and at most this many cells (an SVG element each).
const MAP_MAX_POINTS: usize = 4000;

/// The section's sentences and figures.
pub struct DiagnosticViews {
    pub intro: Vec<String>,
    pub figures: Vec<FigureView>,
}

/// The report's name of a re-run matcher (built-in: slamlab re-runs only its own matchers).
fn title(name: &str) -> String {
    Catalogue::builtin().get(name).map_or(name.to_string(), |a| a.title().to_string())
}

/// Colour of an algorithm: its position in the spec (as in every other figure of the report).
fn color(spec: &ExperimentSpec, name: &str) -> usize {
    spec.algorithms.iter().position(|a| a.as_str() == name).unwrap_or(0)
}

fn deg(rad: f64) -> f64 {
    rad.to_degrees()
}

pub fn build(
    d: &Diagnostics,
    spec: &ExperimentSpec,
    catalogue: &Catalogue,
    map: Option<&Map>,
) -> DiagnosticViews {
    // every algorithm of the cell has a map, external programs too
    let title =
        |name: &str| catalogue.get(name).map_or(name.to_string(), |a| a.title().to_string());
    let map_title = map.map_or(d.map.clone(), |m| m.title.clone());
    let mut intro = vec![format!(
        "The run shown: {map_title} ({}), replicate {} at {} (the trajectory figure's run). Each diagnosed match is re-run with observers that cannot change its result; {}",
        d.map,
        d.replicate,
        d.point,
        reproduction(d)
    )];
    let mut figures = Vec::new();
    for m in &d.matches {
        intro.push(match_sentence(m));
        let prefix = format!("diagnostic-{}", m.number);
        let head = format!(
            "Match {} ({}, steps {} → {})",
            m.number, m.why, m.reference_step, m.current_step
        );
        if let Some(o) = &m.orientation {
            figures.extend(orientation_views(spec, o, m, &prefix, &head));
        }
        if let Some(f) = psm_view(spec, m, &prefix, &head) {
            figures.push(f);
        }
        figures.push(contour_view(spec, m, &prefix, &head));
        figures.extend(iteration_views(spec, m, &prefix, &head));
    }
    if let Some(map) = map {
        for im in &d.maps {
            let (cell, points) = drawn_cells(im, map_cell(map, im));
            let fig = ScanMapFigure {
                walls: map.walls.iter().map(|s| ((s.a.x, s.a.y), (s.b.x, s.b.y))).collect(),
                points,
                path: im.path.clone(),
                color: color(spec, &im.algorithm),
                label: format!("{} map", title(&im.algorithm)),
            };
            figures.push(FigureView {
                panel: false,
                file: format!("incremental-map-{}", im.algorithm.replace('_', "-")),
                caption: format!(
                    "Incremental map of {} ([EP] Figs 52–59): every return of the {} matched scans of the run shown, placed at {}'s estimate of the scan's pose (chained matches; dead reckoning between them), drawn on a {} cm grid (stored at {} cm); gray: the true walls.",
                    title(&im.algorithm),
                    im.scans,
                    title(&im.algorithm),
                    sig(cell * 100.0, 2),
                    sig(im.cell_m * 100.0, 2)
                ),
                svg: figure::scan_map_svg(&fig),
                pgf: super::pgf::scan_map_pgf(&fig),
            });
        }
    }
    DiagnosticViews { intro, figures }
}

/// Cell size to draw a map at: the stored cell, or coarser so the map's extent spans at most
/// [`MAP_CELLS_ACROSS`] cells (a figure resolves no more).
fn map_cell(map: &Map, im: &crate::scanmatch::diagnose::IncrementalMap) -> f64 {
    let xs = map.walls.iter().flat_map(|s| [s.a.x, s.b.x]);
    let ys = map.walls.iter().flat_map(|s| [s.a.y, s.b.y]);
    let span = |v: &mut dyn Iterator<Item = f64>| {
        v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)))
    };
    let ((x0, x1), (y0, y1)) = (span(&mut xs.into_iter()), span(&mut ys.into_iter()));
    let extent = (x1 - x0).max(y1 - y0);
    if extent.is_finite() && extent > 0.0 {
        (extent / MAP_CELLS_ACROSS).max(im.cell_m)
    } else {
        im.cell_m
    }
}

/// The map's cells re-binned to `cell` (coarser while more than [`MAP_MAX_POINTS`] remain): the
/// cell size used and the cell centres.
fn drawn_cells(
    im: &crate::scanmatch::diagnose::IncrementalMap,
    mut cell: f64,
) -> (f64, Vec<(f64, f64)>) {
    loop {
        let bins = rebinned(&im.cells, im.cell_m, cell);
        if bins.len() <= MAP_MAX_POINTS || !cell.is_finite() {
            return (
                cell,
                bins.into_iter()
                    .map(|(i, j)| ((i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell))
                    .collect(),
            );
        }
        cell *= 1.25;
    }
}

/// The distinct bins of side `cell` holding the centres of `cells` (side `cell_m`), sorted.
/// The cells are stored sorted, and binning is monotone, so the bins come out ordered by their
/// first index: only each column's second indices need sorting.
fn rebinned(cells: &[(i32, i32)], cell_m: f64, cell: f64) -> Vec<(i64, i64)> {
    let bin = |v: i32| (((f64::from(v) + 0.5) * cell_m) / cell).floor() as i64;
    if !cells.is_sorted() {
        let mut bins: Vec<(i64, i64)> = cells.iter().map(|&(i, j)| (bin(i), bin(j))).collect();
        bins.sort_unstable();
        bins.dedup();
        return bins;
    }
    let mut bins = Vec::new();
    let mut column: Vec<i64> = Vec::new();
    let mut at = 0;
    while at < cells.len() {
        let bi = bin(cells[at].0);
        column.clear();
        while at < cells.len() && bin(cells[at].0) == bi {
            column.push(bin(cells[at].1));
            at += 1;
        }
        column.sort_unstable();
        column.dedup();
        bins.extend(column.iter().map(|&bj| (bi, bj)));
    }
    bins
}

fn reproduction(d: &Diagnostics) -> String {
    let bad: Vec<String> = d
        .matches
        .iter()
        .flat_map(|m| {
            m.paths
                .iter()
                .filter(|p| !p.reproduces)
                .map(move |p| format!("{} at match {}", title(&p.algorithm), m.number))
        })
        .collect();
    if bad.is_empty() {
        "every re-run returned the stored estimate bit for bit.".to_string()
    } else {
        format!(
            "these re-runs did NOT return the stored estimate, so their figures may not show what the run did: {}.",
            bad.join(", ")
        )
    }
}

/// The numbers a reader needs to read a match's figures.
fn match_sentence(m: &MatchDiagnostic) -> String {
    let t = m.truth;
    let g = m.initial;
    let mut parts = vec![format!(
        "Match {} ({}): true motion x = {} m, y = {} m, θ = {}°; the initial guess is off by ({} mm, {} mm, {}°)",
        m.number,
        m.why,
        small(t.x, 1e-6),
        small(t.y, 1e-6),
        small(deg(t.theta), 1e-5),
        small((g.x - t.x) * 1e3, 1e-3),
        small((g.y - t.y) * 1e3, 1e-3),
        small(deg(crate::geom::wrap_angle(g.theta - t.theta)), 1e-5)
    )];
    for p in &m.paths {
        let e = p.estimate;
        parts.push(format!(
            "{} ends at ({} mm, {} mm, {}°) from the truth with f = {} cm² after {} {}",
            title(&p.algorithm),
            small((e.x - t.x) * 1e3, 1e-3),
            small((e.y - t.y) * 1e3, 1e-3),
            small(deg(crate::geom::wrap_angle(e.theta - t.theta)), 1e-5),
            p.f_estimate.map_or("—".into(), |f| sig(f, 3)),
            if p.kind == "per half-iteration" {
                p.poses.len().saturating_sub(1)
            } else {
                p.evaluations.last().copied().unwrap_or(0) as usize
            },
            if p.kind == "per half-iteration" {
                "half-iterations"
            } else {
                "evaluations (at its best f)"
            }
        ));
    }
    for p in m.psm.iter().filter(|p| p.at_label == "estimate") {
        if let Some(pick) = p.pick {
            parts.push(format!(
                "at its estimate, {}'s next orientation pass would turn by {}°, while the true heading is {}° away",
                title(&p.algorithm),
                small(deg(pick - p.at.theta), 1e-5),
                small(deg(crate::geom::wrap_angle(t.theta - p.at.theta)), 1e-5)
            ));
        }
    }
    if let Some(o) = &m.orientation {
        let v = o.parabola.and_then(vertex);
        parts.push(format!(
            "E-PSM's first orientation search (at the initial guess's position) picks θ − true θ = {}°{}",
            small(deg(o.pick - t.theta), 1e-5),
            v.map_or(String::new(), |v| format!("; Diosi's parabola through its 1° grid would pick {}°", small(deg(v - t.theta), 1e-5)))
        ));
    }
    parts.join("; ") + "."
}

/// Three significant figures, and 0 below `floor` (rounding noise of a difference of equal poses).
fn small(v: f64, floor: f64) -> String {
    if v.abs() < floor { "0".into() } else { sig(v, 3) }
}

fn point(x: f64, y: f64) -> SeriesPoint {
    SeriesPoint { x, mean: y, lo: f64::NAN, hi: f64::NAN }
}

fn line(label: String, color: usize, points: Vec<SeriesPoint>) -> LineSeries {
    LineSeries { label, color, points, dashed: false, scatter: false }
}

fn marks(label: String, color: usize, points: Vec<SeriesPoint>) -> LineSeries {
    LineSeries { label, color, points, dashed: false, scatter: true }
}

/// A vertical dashed line at x over the values of `series`.
fn vline(label: &str, x: f64, series: &[LineSeries]) -> LineSeries {
    let ys: Vec<f64> =
        series.iter().flat_map(|s| &s.points).map(|p| p.mean).filter(|v| v.is_finite()).collect();
    let (lo, hi) =
        ys.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
    let (lo, hi) = if lo.is_finite() { (lo.min(0.0), hi) } else { (0.0, 1.0) };
    LineSeries {
        label: label.to_string(),
        color: TRUTH,
        points: vec![point(x, lo), point(x, hi)],
        dashed: true,
        scatter: false,
    }
}

fn parabola_series(p: (f64, f64, f64, f64), from: f64, to: f64, truth: f64) -> Vec<SeriesPoint> {
    let (t0, a, b, c) = p;
    (0..=40)
        .map(|k| {
            let t = from + (to - from) * f64::from(k) / 40.0;
            let d = t - t0;
            point(deg(t - truth), a * d * d + b * d + c)
        })
        .collect()
}

/// [EP] Fig 25: E-PSM's coarse and fine orientation grids with Diosi's parabola.
fn orientation_views(
    spec: &ExperimentSpec,
    o: &OrientationSlices,
    m: &MatchDiagnostic,
    prefix: &str,
    head: &str,
) -> Vec<FigureView> {
    let truth = m.truth.theta;
    let epsm = color(spec, "epsm");
    let grid = |v: &[(f64, Option<f64>)]| {
        v.iter().filter_map(|(t, f)| f.map(|f| point(deg(t - truth), f))).collect::<Vec<_>>()
    };
    let f_at = |v: &[(f64, Option<f64>)], theta: f64| {
        v.iter().find(|(t, _)| (t - theta).abs() < 1e-12).and_then(|(_, f)| *f)
    };
    let mut out = Vec::new();
    for (fine, values, suffix) in [(false, &o.coarse, "coarse"), (true, &o.fine, "fine")] {
        if values.is_empty() {
            continue;
        }
        let (lo, hi) = (values[0].0, values[values.len() - 1].0);
        let mut series = vec![line(
            format!("f on E-PSM's {} grid", if fine { "fine" } else { "coarse" }),
            epsm,
            grid(values),
        )];
        if let Some(p) = o.parabola {
            let h = o.coarse.get(1).map_or(0.0, |s| s.0 - o.coarse[0].0);
            let (from, to) = if fine { (lo, hi) } else { (p.0 - 1.5 * h, p.0 + 1.5 * h) };
            series.push(line(
                "Diosi's parabola (coarse minimum and neighbours)".into(),
                PARABOLA,
                parabola_series(p, from, to, truth),
            ));
            if let Some(v) = vertex(p).filter(|v| (lo..=hi).contains(v)) {
                let (t0, a, b, c) = p;
                series.push(marks(
                    "parabola vertex".into(),
                    PARABOLA,
                    vec![point(deg(v - truth), a * (v - t0) * (v - t0) + b * (v - t0) + c)],
                ));
            }
        }
        if let Some(f) = f_at(&o.coarse, o.pick).or_else(|| f_at(&o.fine, o.pick)) {
            series.push(marks("E-PSM's pick".into(), epsm, vec![point(deg(o.pick - truth), f)]));
        }
        if (lo..=hi).contains(&truth) {
            let v = vline("true heading", 0.0, &series);
            series.push(v);
        }
        let fig = LineFigure {
            x_label: "θ − true θ [deg]".into(),
            y_label: "f [cm²]".into(),
            x_axis: XAxis::Linear,
            x_ticks: Vec::new(),
            series,
        };
        out.push(FigureView {
            panel: false,
            file: format!("{prefix}-orientation-{suffix}"),
            caption: format!(
                "{head}: E-PSM's first orientation search ([EP] Fig 25{}), f against the heading at the initial guess's position ({} m, {} m), {}. The cyan curve is Diosi's parabola through the coarse grid's minimum and its neighbours, the refinement PSM would make.",
                if fine { ", right" } else { ", left" },
                sig(o.at.x, 3),
                sig(o.at.y, 3),
                if fine { "on the fine grid around the coarse minimum" } else { "on the coarse grid (with its expansions past the window)" }
            ),
            svg: figure::line_svg(&fig),
            pgf: super::pgf::line_pgf(&fig),
        });
    }
    out
}

/// PSM's criterion e(θ) at its initial guess and at its estimate, with the heading it picks.
fn psm_view(
    spec: &ExperimentSpec,
    m: &MatchDiagnostic,
    prefix: &str,
    head: &str,
) -> Option<FigureView> {
    if m.psm.is_empty() {
        return None;
    }
    let truth = m.truth.theta;
    let mut series = Vec::new();
    for p in &m.psm {
        let c = color(spec, &p.algorithm);
        let at_estimate = p.at_label == "estimate";
        let pts: Vec<SeriesPoint> =
            p.errors.iter().filter_map(|(t, e)| e.map(|e| point(deg(t - truth), e))).collect();
        series.push(LineSeries {
            label: format!("{}: e(θ) at its {}", title(&p.algorithm), p.at_label),
            color: c,
            points: pts,
            dashed: at_estimate,
            scatter: false,
        });
        if let Some(pick) = p.pick {
            // the criterion's value at the pick: Diosi's parabola through the best shift, or the best shift itself
            let e = diosi_parabola(&p.errors)
                .filter(|_| p.refined)
                .map(|(t0, a, b, c)| a * (pick - t0) * (pick - t0) + b * (pick - t0) + c);
            let e = e.or_else(|| p.errors.iter().filter_map(|(_, e)| *e).min_by(f64::total_cmp));
            if let Some(e) = e {
                series.push(marks(
                    format!("{}: pick at its {}", title(&p.algorithm), p.at_label),
                    c,
                    vec![point(deg(pick - truth), e)],
                ));
            }
        }
    }
    let v = vline("true heading", 0.0, &series);
    series.push(v);
    let fig = LineFigure {
        x_label: "θ − true θ [deg]".into(),
        y_label: "e(θ): mean |range residual| [cm]".into(),
        x_axis: XAxis::Linear,
        x_ticks: Vec::new(),
        series,
    };
    Some(FigureView {
        panel: false,
        file: format!("{prefix}-psm-criterion"),
        caption: format!(
            "{head}: PSM's orientation criterion, the mean absolute range residual of each shift of the range array (one beam per point), at its initial guess (its first pass, solid) and at its estimate (dashed), with the heading each pass picks (Diosi's parabola through the best shift and its neighbours). Where PSM converged, the pick at its estimate is the estimate's own heading, and its distance from the true heading is PSM's error on this match."
        ),
        svg: figure::line_svg(&fig),
        pgf: super::pgf::line_pgf(&fig),
    })
}

/// [EP] Fig 26: f contours at the true heading around the true position, with every path.
fn contour_view(
    spec: &ExperimentSpec,
    m: &MatchDiagnostic,
    prefix: &str,
    head: &str,
) -> FigureView {
    let c = &m.contour;
    let mut values: Vec<f64> = c.f.iter().filter_map(|f| *f).collect();
    values.sort_by(f64::total_cmp);
    let mut levels: Vec<f64> = LEVEL_QUANTILES
        .iter()
        .filter_map(|q| {
            values.get(((values.len().saturating_sub(1)) as f64 * q).round() as usize).copied()
        })
        .collect();
    levels.dedup();
    let contours: Vec<(f64, Vec<Vec<(f64, f64)>>)> =
        levels.iter().map(|&l| (l, figure::contour_lines(&c.xs, &c.ys, &c.f, l))).collect();
    let paths: Vec<PathSeries> = m
        .paths
        .iter()
        .map(|p| PathSeries {
            label: format!("{} ({})", title(&p.algorithm), p.kind),
            color: Some(color(spec, &p.algorithm)),
            points: p.poses.iter().filter(|q| q.is_finite()).map(|q| (q.x, q.y)).collect(),
        })
        .collect();
    let bounds = ((c.xs[0], c.xs[c.xs.len() - 1]), (c.ys[0], c.ys[c.ys.len() - 1]));
    let fig = ContourFigure {
        levels: contours,
        bounds,
        paths,
        truth: (m.truth.x, m.truth.y),
        initial: (m.initial.x, m.initial.y),
    };
    FigureView {
        panel: false,
        file: format!("{prefix}-contour"),
        caption: format!(
            "{head}: contours of f in x–y at the true heading ([EP] Fig 26), levels {} cm² (the {} quantiles of f on the {}×{} grid, darker = lower), with each matcher's path (PSM and E-PSM: the pose after every half-iteration; the others: their best pose so far), ringed at its end. Red square: the true position; triangle: the initial guess. The paths also move in θ, which this slice does not show.",
            levels.iter().map(|l| sig(*l, 2)).collect::<Vec<_>>().join(", "),
            LEVEL_QUANTILES
                .iter()
                .map(|q| format!("{}", (q * 100.0).round()))
                .collect::<Vec<_>>()
                .join("/")
                + " %",
            c.xs.len(),
            c.ys.len()
        ),
        svg: figure::contour_svg(&fig),
        pgf: super::pgf::contour_pgf(&fig),
    }
}

/// [EP] Fig 27: f per half-iteration (PSM, E-PSM); and the best f against evaluations (the others).
fn iteration_views(
    spec: &ExperimentSpec,
    m: &MatchDiagnostic,
    prefix: &str,
    head: &str,
) -> Vec<FigureView> {
    let mut out = Vec::new();
    let per: Vec<LineSeries> = m
        .paths
        .iter()
        .filter(|p| p.kind == "per half-iteration")
        .map(|p| {
            line(
                title(&p.algorithm),
                color(spec, &p.algorithm),
                p.f.iter().enumerate().filter_map(|(k, f)| f.map(|f| point(k as f64, f))).collect(),
            )
        })
        .collect();
    if !per.is_empty() {
        let fig = LineFigure {
            x_label: "half-iteration (0 = initial guess)".into(),
            y_label: "f [cm²]".into(),
            x_axis: XAxis::Linear,
            x_ticks: Vec::new(),
            series: per,
        };
        out.push(FigureView {
            panel: false,
            file: format!("{prefix}-iterations"),
            caption: format!("{head}: f after each half-iteration ([EP] Fig 27; PSM: each pass, scored by the common f, which PSM itself does not minimise)."),
            svg: figure::line_svg(&fig),
            pgf: super::pgf::line_pgf(&fig),
        });
    }
    let best: Vec<LineSeries> = m
        .paths
        .iter()
        .filter(|p| p.kind != "per half-iteration")
        .map(|p| {
            line(
                title(&p.algorithm),
                color(spec, &p.algorithm),
                p.f.iter()
                    .zip(&p.evaluations)
                    .filter_map(|(f, e)| f.map(|f| point((*e).max(1) as f64, f)))
                    .collect(),
            )
        })
        .filter(|s| !s.points.is_empty())
        .collect();
    if !best.is_empty() {
        let max = best.iter().flat_map(|s| &s.points).map(|p| p.x).fold(1.0, f64::max);
        let ticks: Vec<(f64, String)> = (0..=max.log10().floor() as i32)
            .map(|e| (10f64.powi(e), sig(10f64.powi(e), 1)))
            .collect();
        let fig = LineFigure {
            x_label: "objective evaluations".into(),
            y_label: "best f so far [cm²]".into(),
            x_axis: XAxis::Log,
            x_ticks: ticks,
            series: best,
        };
        out.push(FigureView {
            panel: false,
            file: format!("{prefix}-evaluations"),
            caption: format!("{head}: the best f found against the evaluations spent, for the matchers that search (x, y, θ) at once or by brute force."),
            svg: figure::line_svg(&fig),
            pgf: super::pgf::line_pgf(&fig),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// Column-wise re-binning equals binning every cell, sorting and removing repeats.
    #[test]
    fn rebinning_by_columns_equals_a_full_sort() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for _ in 0..50 {
            let mut cells: Vec<(i32, i32)> = (0..2000)
                .map(|_| (rng.random_range(-300..300), rng.random_range(-300..300)))
                .collect();
            let cell_m = 0.01 * rng.random_range(1..6) as f64;
            let cell = cell_m * rng.random_range(1.0..40.0);
            let naive = |cells: &[(i32, i32)]| {
                let bin = |v: i32| (((f64::from(v) + 0.5) * cell_m) / cell).floor() as i64;
                let mut b: Vec<(i64, i64)> = cells.iter().map(|&(i, j)| (bin(i), bin(j))).collect();
                b.sort_unstable();
                b.dedup();
                b
            };
            assert_eq!(rebinned(&cells, cell_m, cell), naive(&cells), "unsorted input");
            cells.sort_unstable();
            cells.dedup();
            assert_eq!(rebinned(&cells, cell_m, cell), naive(&cells), "sorted input");
        }
    }
}
