//! Figure models (what a figure shows) and their SVG rendering with plotters. The same model is
//! rendered for LaTeX by [`super::pgf`], so HTML and PDF show the same data.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// tab10: distinguishable, colour-blind-tolerant series colours (hex RGB).
pub const PALETTE: [&str; 10] = [
    "1f77b4", "ff7f0e", "2ca02c", "d62728", "9467bd", "8c564b", "e377c2", "7f7f7f", "bcbd22",
    "17becf",
];

/// Series past the palette's 10 colours reuse them dotted, with square markers, so that no two
/// series of one figure look alike (up to 20).
pub fn dotted(index: usize) -> bool {
    index % (2 * PALETTE.len()) >= PALETTE.len()
}

fn rgb(index: usize) -> RGBColor {
    let hex = PALETTE[index % PALETTE.len()];
    let c = |i: usize| u8::from_str_radix(&hex[i..i + 2], 16).expect("palette is hex");
    RGBColor(c(0), c(2), c(4))
}

const FONT: &str = "sans-serif";
const WIDTH: u32 = 720;
const HEIGHT: u32 = 380;
/// Left edge of the plotting area [px] (margin + y label area), where legends start.
const LEFT_PX: u32 = 78;

/// Gray of the ground-truth path (walls are black).
const TRUTH: RGBColor = RGBColor(110, 110, 110);
const CORNER: RGBColor = RGBColor(200, 0, 0);

/// One legend entry: a line or a dot in a colour, and its label.
struct LegendEntry<'s> {
    label: &'s str,
    color: RGBColor,
    dot: bool,
    dashed: bool,
    /// A dotted line with a square marker (series past the tenth).
    dotted: bool,
}

/// Legend layout in rows above the plot: (entry index, x, row) and the strip's height [px].
fn legend_layout(
    entries: &[LegendEntry<'_>],
    width: u32,
    left: u32,
) -> (Vec<(usize, u32, u32)>, u32) {
    const ROW_PX: u32 = 18;
    const SWATCH_PX: u32 = 26;
    const GAP_PX: u32 = 18;
    const CHAR_PX: u32 = 7; // ≈ width of a 12 px sans-serif character
    let mut placed = Vec::new();
    let (mut x, mut row) = (left, 0);
    for (i, e) in entries.iter().enumerate() {
        let w = SWATCH_PX + CHAR_PX * e.label.chars().count() as u32 + GAP_PX;
        if x + w > width && x > left {
            row += 1;
            x = left;
        }
        placed.push((i, x, row));
        x += w;
    }
    let rows = if entries.is_empty() { 0 } else { row + 1 };
    (placed, rows * ROW_PX + 10)
}

fn draw_legend(
    area: &DrawingArea<SVGBackend<'_>, Shift>,
    entries: &[LegendEntry<'_>],
    left: u32,
) -> Result<(), String> {
    let (placed, _) = legend_layout(entries, area.dim_in_pixel().0, left);
    let style = TextStyle::from((FONT, 12).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (i, x, row) in placed {
        let e = &entries[i];
        let (x, y) = (x as i32, 12 + 18 * row as i32);
        if e.dot {
            area.draw(&Circle::new((x + 9, y), 4, e.color.filled())).map_err(|e| e.to_string())?;
        } else if e.dotted {
            for a in [0, 5, 10, 15] {
                area.draw(&PathElement::new(
                    vec![(x + a, y), (x + a + 2, y)],
                    e.color.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
            }
            area.draw(&Rectangle::new([(x + 6, y - 3), (x + 12, y + 3)], e.color.filled()))
                .map_err(|e| e.to_string())?;
        } else if e.dashed {
            for (a, b) in [(0, 5), (8, 13), (16, 18)] {
                area.draw(&PathElement::new(vec![(x + a, y), (x + b, y)], e.color.stroke_width(2)))
                    .map_err(|e| e.to_string())?;
            }
        } else {
            area.draw(&PathElement::new(vec![(x, y), (x + 18, y)], e.color.stroke_width(2)))
                .map_err(|e| e.to_string())?;
        }
        area.draw(&Text::new(e.label, (x + 24, y), style.clone())).map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// How x values are placed.
#[derive(Debug, Clone, PartialEq)]
pub enum XAxis {
    Linear,
    /// Positions are log10(x); ticks at the swept values.
    Log,
    /// Positions 0, 1, …; ticks labelled with these names.
    Categorical(Vec<String>),
}

/// Mean and confidence interval at one x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeriesPoint {
    pub x: f64,
    pub mean: f64,
    pub lo: f64,
    pub hi: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct LineSeries {
    pub label: String,
    pub color: usize,
    pub points: Vec<SeriesPoint>,
    /// Published values: dashed, with error bars (lo, hi) where the publication prints a spread.
    pub dashed: bool,
    /// Markers only (no line, no band): a scatter of separate cells.
    pub scatter: bool,
}

/// Error (or any metric) against a swept parameter: mean line with a CI band per series.
#[derive(Debug, Clone, PartialEq)]
pub struct LineFigure {
    pub x_label: String,
    pub y_label: String,
    pub x_axis: XAxis,
    /// Values of the swept parameter where ticks go (Linear uses automatic ticks).
    pub x_ticks: Vec<(f64, String)>,
    pub series: Vec<LineSeries>,
}

impl LineFigure {
    /// Position of an x value on the drawn axis.
    pub fn position(&self, x: f64) -> f64 {
        match self.x_axis {
            XAxis::Log => x.log10(),
            _ => x,
        }
    }

    /// Finite points only (∞ means and NaN are not drawable; tables show them).
    fn drawable(points: &[SeriesPoint]) -> impl Iterator<Item = &SeriesPoint> {
        points.iter().filter(|p| p.mean.is_finite() && p.x.is_finite())
    }

    fn ranges(&self) -> ((f64, f64), (f64, f64)) {
        let xs: Vec<f64> = match &self.x_axis {
            XAxis::Categorical(names) => vec![-0.5, names.len() as f64 - 0.5],
            // a log axis reaches its outermost ticks (decades), which are otherwise cut off
            XAxis::Log => self
                .series
                .iter()
                .flat_map(|s| Self::drawable(&s.points))
                .map(|p| self.position(p.x))
                .chain(
                    self.x_ticks.iter().map(|(x, _)| self.position(*x)).filter(|v| v.is_finite()),
                )
                .collect(),
            _ => self
                .series
                .iter()
                .flat_map(|s| Self::drawable(&s.points))
                .map(|p| self.position(p.x))
                .collect(),
        };
        let ys: Vec<f64> = self
            .series
            .iter()
            .flat_map(|s| Self::drawable(&s.points))
            .flat_map(|p| [p.mean, p.lo, p.hi])
            .filter(|v| v.is_finite())
            .collect();
        (padded(&xs, 0.05, false), padded(&ys, 0.08, true))
    }
}

/// [min, max] of `v` widened by `frac` of its span; from 0 when all values are ≥ 0 and `from_zero`.
fn padded(v: &[f64], frac: f64, from_zero: bool) -> (f64, f64) {
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    let span = if hi > lo { hi - lo } else { hi.abs().max(1.0) };
    let lo = if from_zero && lo >= 0.0 { 0.0 } else { lo - frac * span };
    (lo, hi + frac * span)
}

/// Renders a line figure to an SVG document string.
pub fn line_svg(fig: &LineFigure) -> String {
    let entries: Vec<LegendEntry<'_>> = fig
        .series
        .iter()
        .map(|s| LegendEntry {
            label: &s.label,
            color: rgb(s.color),
            dot: s.scatter,
            dashed: s.dashed,
            dotted: dotted(s.color) && !s.scatter && !s.dashed,
        })
        .collect();
    let (_, legend_px) = legend_layout(&entries, WIDTH, LEFT_PX);
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT + legend_px)).into_drawing_area();
        // Drawing into a String cannot fail for IO reasons; errors here would be layout bugs.
        root.fill(&WHITE).expect("drawing an SVG into memory");
        let (top, plot) = root.split_vertically(legend_px);
        draw_legend(&top, &entries, LEFT_PX).expect("drawing an SVG into memory");
        draw_line(&plot, fig).expect("drawing an SVG into memory");
        root.present().expect("finishing an SVG in memory");
    }
    svg
}

fn draw_line(root: &DrawingArea<SVGBackend<'_>, Shift>, fig: &LineFigure) -> Result<(), String> {
    let ((x0, x1), (y0, y1)) = fig.ranges();
    let manual_ticks = !matches!(fig.x_axis, XAxis::Linear);
    let mut chart = ChartBuilder::on(root)
        .margin(14)
        .x_label_area_size(46)
        .y_label_area_size(LEFT_PX - 14)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| e.to_string())?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(fig.x_label.as_str())
        .y_desc(fig.y_label.as_str())
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .light_line_style(WHITE.mix(0.0));
    if manual_ticks {
        mesh.disable_x_mesh().x_labels(0);
    }
    mesh.draw().map_err(|e| e.to_string())?;

    for s in &fig.series {
        let color = rgb(s.color);
        let pts: Vec<&SeriesPoint> = LineFigure::drawable(&s.points).collect();
        if s.scatter {
            chart
                .draw_series(
                    pts.iter().map(|p| Circle::new((fig.position(p.x), p.mean), 4, color.filled())),
                )
                .map_err(|e| e.to_string())?;
            continue;
        }
        if s.dashed {
            let line: Vec<(f64, f64)> = pts.iter().map(|p| (fig.position(p.x), p.mean)).collect();
            chart
                .draw_series(plotters::series::DashedLineSeries::new(
                    line.clone(),
                    6,
                    4,
                    color.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(line.into_iter().map(|p| Circle::new(p, 3, color.stroke_width(1))))
                .map_err(|e| e.to_string())?;
            // The published dispersion, where printed: vertical error bars.
            let bars = pts.iter().filter(|p| p.lo.is_finite() && p.hi.is_finite()).map(|p| {
                PathElement::new(
                    vec![(fig.position(p.x), p.lo), (fig.position(p.x), p.hi)],
                    color.stroke_width(1),
                )
            });
            chart.draw_series(bars).map_err(|e| e.to_string())?;
            continue;
        }
        let band: Vec<&SeriesPoint> =
            pts.iter().copied().filter(|p| p.lo.is_finite() && p.hi.is_finite()).collect();
        if band.len() >= 2 {
            let mut poly: Vec<(f64, f64)> =
                band.iter().map(|p| (fig.position(p.x), p.hi)).collect();
            poly.extend(band.iter().rev().map(|p| (fig.position(p.x), p.lo)));
            chart
                .draw_series(std::iter::once(Polygon::new(poly, color.mix(0.18).filled())))
                .map_err(|e| e.to_string())?;
        }
        let line: Vec<(f64, f64)> = pts.iter().map(|p| (fig.position(p.x), p.mean)).collect();
        // a long trace (every match of a run) is a line without marks: marks would hide it and
        // make the file several times larger
        let marked = line.len() <= MARKED_POINTS;
        if dotted(s.color) {
            chart
                .draw_series(plotters::series::DashedLineSeries::new(
                    line.clone(),
                    2,
                    4,
                    color.stroke_width(2),
                ))
                .map_err(|e| e.to_string())?;
            if marked {
                chart
                    .draw_series(line.into_iter().map(|p| {
                        EmptyElement::at(p) + Rectangle::new([(-3, -3), (3, 3)], color.filled())
                    }))
                    .map_err(|e| e.to_string())?;
            }
        } else {
            chart
                .draw_series(plotters::series::LineSeries::new(line.clone(), color.stroke_width(2)))
                .map_err(|e| e.to_string())?;
            if marked {
                chart
                    .draw_series(line.into_iter().map(|p| Circle::new(p, 3, color.filled())))
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    if manual_ticks {
        let style = TextStyle::from((FONT, 12).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
        // backend_coord is in whole-SVG pixels; `root` starts below the legend strip.
        let (bx, by) = root.get_base_pixel();
        for (x, label) in &fig.x_ticks {
            let (px, py) = chart.backend_coord(&(fig.position(*x), y0));
            let (px, py) = (px - bx, py - by);
            root.draw(&PathElement::new(vec![(px, py), (px, py + 4)], BLACK))
                .map_err(|e| e.to_string())?;
            root.draw(&Text::new(label.as_str(), (px, py + 6), style.clone()))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}

/// A path drawn on a map figure; `color: None` draws the ground truth in black.
#[derive(Debug, Clone, PartialEq)]
pub struct PathSeries {
    pub label: String,
    pub color: Option<usize>,
    pub points: Vec<(f64, f64)>,
}

/// A map with walls, ground-truth corners and trajectories, drawn to scale, with the final
/// landmark maps of the algorithms that build one (colour index as their path).
#[derive(Debug, Clone, PartialEq)]
pub struct TrajectoryFigure {
    pub walls: Vec<((f64, f64), (f64, f64))>,
    /// True landmarks drawn as dots: the walls' corners (laser worlds) or the point landmarks.
    pub corners: Vec<(f64, f64)>,
    /// Whether `corners` are point landmarks (legend wording).
    pub point_landmarks: bool,
    pub paths: Vec<PathSeries>,
    pub start: (f64, f64),
    /// Estimated corners: (colour, point).
    pub est_corners: Vec<(usize, (f64, f64))>,
    /// Estimated infinite lines: (colour, ρ, θ).
    pub est_lines: Vec<(usize, f64, f64)>,
}

/// The part of the line ρ = x cos θ + y sin θ inside a rectangle, if any.
pub fn clip_line(
    rho: f64,
    theta: f64,
    ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64)),
) -> Option<((f64, f64), (f64, f64))> {
    let (s, c) = theta.sin_cos();
    let mut pts: Vec<(f64, f64)> = Vec::new();
    if s.abs() > 1e-12 {
        for x in [x0, x1] {
            let y = (rho - x * c) / s;
            if (y0..=y1).contains(&y) {
                pts.push((x, y));
            }
        }
    }
    if c.abs() > 1e-12 {
        for y in [y0, y1] {
            let x = (rho - y * s) / c;
            if (x0..=x1).contains(&x) {
                pts.push((x, y));
            }
        }
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    pts.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9);
    (pts.len() >= 2).then(|| (pts[0], pts[pts.len() - 1]))
}

impl TrajectoryFigure {
    /// Bounds of walls, paths and true landmarks with a margin [m].
    pub fn bounds(&self) -> ((f64, f64), (f64, f64)) {
        let points = || {
            self.paths
                .iter()
                .flat_map(|p| p.points.iter().copied())
                .chain(self.corners.iter().copied())
        };
        let xs: Vec<f64> = self
            .walls
            .iter()
            .flat_map(|(a, b)| [a.0, b.0])
            .chain(points().map(|q| q.0))
            .filter(|v| v.is_finite())
            .collect();
        let ys: Vec<f64> = self
            .walls
            .iter()
            .flat_map(|(a, b)| [a.1, b.1])
            .chain(points().map(|q| q.1))
            .filter(|v| v.is_finite())
            .collect();
        let (x0, x1) = padded(&xs, 0.04, false);
        let (y0, y1) = padded(&ys, 0.04, false);
        ((x0, x1), (y0, y1))
    }
}

/// Keeps at most `max` points of a path (evenly spaced, always the last one).
pub fn decimate(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 2 {
        return points.to_vec();
    }
    let step = points.len().div_ceil(max - 1);
    let mut out: Vec<(f64, f64)> = points.iter().step_by(step).copied().collect();
    if out.last() != points.last() {
        out.push(*points.last().expect("non-empty"));
    }
    out
}

/// Series longer than this are drawn without marks.
const MARKED_POINTS: usize = 60;

/// Most points a path keeps in an SVG figure.
const SVG_PATH_POINTS: usize = 1500;

pub fn trajectory_svg(fig: &TrajectoryFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds();
    // Equal scale on both axes: size the drawing to the map's aspect ratio.
    let (label_x, label_y, margin) = (40u32, 52u32, 14u32);
    let plot_w = (WIDTH - label_y - 2 * margin) as f64;
    let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(160.0, 640.0);
    let (plot_w, height) =
        (plot_h * (x1 - x0) / (y1 - y0), plot_h as u32 + label_x + 2 * margin + 8);
    let width = (plot_w as u32 + label_y + 2 * margin).min(WIDTH);
    let mut entries: Vec<LegendEntry<'_>> = fig
        .paths
        .iter()
        .map(|p| LegendEntry {
            label: &p.label,
            color: p.color.map(rgb).unwrap_or(BLACK),
            dot: false,
            dashed: false,
            dotted: p.color.is_some_and(dotted),
        })
        .collect();
    if !fig.corners.is_empty() {
        entries.push(LegendEntry {
            label: if fig.point_landmarks { "true landmarks" } else { "true corners" },
            color: CORNER,
            dot: true,
            dashed: false,
            dotted: false,
        });
    }
    if !fig.est_lines.is_empty() || !fig.est_corners.is_empty() {
        let label = if fig.point_landmarks {
            "mapped landmarks (×)"
        } else {
            "mapped lines (dashed) and corners (×)"
        };
        entries.push(LegendEntry {
            label,
            color: RGBColor(100, 100, 100),
            dot: false,
            dashed: !fig.point_landmarks,
            dotted: false,
        });
    }
    let (_, legend_px) = legend_layout(&entries, width, label_y + margin);
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (width, height + legend_px)).into_drawing_area();
        root.fill(&WHITE).expect("drawing an SVG into memory");
        let (top, plot) = root.split_vertically(legend_px);
        draw_legend(&top, &entries, label_y + margin).expect("drawing an SVG into memory");
        draw_trajectory(&plot, fig, ((x0, x1), (y0, y1)), (label_x, label_y, margin))
            .expect("drawing an SVG into memory");
        root.present().expect("finishing an SVG in memory");
    }
    svg
}

pub type Bounds = ((f64, f64), (f64, f64));

fn draw_trajectory(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    fig: &TrajectoryFigure,
    ((x0, x1), (y0, y1)): Bounds,
    (label_x, label_y, margin): (u32, u32, u32),
) -> Result<(), String> {
    let e = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
    let mut chart = ChartBuilder::on(root)
        .margin(margin)
        .x_label_area_size(label_x)
        .y_label_area_size(label_y)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FONT, 12))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.08))
        .draw()
        .map_err(e)?;
    chart
        .draw_series(
            fig.walls.iter().map(|(a, b)| PathElement::new(vec![*a, *b], BLACK.stroke_width(3))),
        )
        .map_err(e)?;
    // the ground truth last, thin and dark, so that no estimate hides it (sparse GPS truth was
    // invisible under the estimates)
    for p in fig
        .paths
        .iter()
        .filter(|p| p.color.is_some())
        .chain(fig.paths.iter().filter(|p| p.color.is_none()))
    {
        let (color, width) = match p.color {
            Some(c) => (rgb(c), 2),
            None => (BLACK, 1),
        };
        let points = decimate(&p.points, SVG_PATH_POINTS);
        if p.color.is_some_and(dotted) {
            chart
                .draw_series(plotters::series::DashedLineSeries::new(
                    points,
                    2,
                    4,
                    color.stroke_width(width),
                ))
                .map_err(e)?;
        } else {
            chart
                .draw_series(std::iter::once(PathElement::new(points, color.stroke_width(width))))
                .map_err(e)?;
        }
    }
    for &(color, rho, theta) in &fig.est_lines {
        if let Some((a, b)) = clip_line(rho, theta, ((x0, x1), (y0, y1))) {
            chart
                .draw_series(plotters::series::DashedLineSeries::new(
                    [a, b],
                    3,
                    5,
                    rgb(color).mix(0.6).stroke_width(1),
                ))
                .map_err(e)?;
        }
    }
    chart
        .draw_series(fig.corners.iter().map(|c| Circle::new(*c, 4, CORNER.filled())))
        .map_err(e)?;
    // mapped landmarks outside the plotted area are left out rather than pinned to its edge
    let inside = |(x, y): (f64, f64)| x >= x0 && x <= x1 && y >= y0 && y <= y1;
    chart
        .draw_series(
            fig.est_corners
                .iter()
                .filter(|(_, c)| inside(*c))
                .map(|(color, c)| Cross::new(*c, 4, rgb(*color).stroke_width(2))),
        )
        .map_err(e)?;
    chart
        .draw_series(std::iter::once(TriangleMarker::new(fig.start, 7, BLACK.filled())))
        .map_err(e)?;
    Ok(())
}

/// f on a grid at one heading, drawn as contour lines, with matcher paths through it
/// ([EP] Figs 26/34/51).
#[derive(Debug, Clone, PartialEq)]
pub struct ContourFigure {
    /// Contour lines per level, darker for lower levels: (level, polylines).
    pub levels: Vec<(f64, Vec<Vec<(f64, f64)>>)>,
    pub bounds: Bounds,
    /// Paths: label, colour, points (the first is the start).
    pub paths: Vec<PathSeries>,
    /// The true position (red square) and the initial guess (black triangle).
    pub truth: (f64, f64),
    pub initial: (f64, f64),
}

/// Contour lines of a row-major grid `f[row * xs.len() + col]` at `level` by marching squares
/// (saddles resolved by the cell's mean), joined into polylines; cells with a missing corner are
/// skipped. Deterministic: segments are produced and joined in grid order.
pub fn contour_lines(
    xs: &[f64],
    ys: &[f64],
    f: &[Option<f64>],
    level: f64,
) -> Vec<Vec<(f64, f64)>> {
    let (nx, ny) = (xs.len(), ys.len());
    if nx < 2 || ny < 2 || f.len() != nx * ny {
        return Vec::new();
    }
    let at = |c: usize, r: usize| f[r * nx + c];
    // the crossing on the edge between two grid nodes, computed from the lower-index node so that
    // both cells sharing the edge compute the same point
    let cross = |a: (usize, usize), b: (usize, usize)| {
        let (a, b) = if (a.1, a.0) <= (b.1, b.0) { (a, b) } else { (b, a) };
        let (fa, fb) = (at(a.0, a.1).unwrap_or(0.0), at(b.0, b.1).unwrap_or(0.0));
        let t = if fb != fa { (level - fa) / (fb - fa) } else { 0.5 };
        (xs[a.0] + t * (xs[b.0] - xs[a.0]), ys[a.1] + t * (ys[b.1] - ys[a.1]))
    };
    let mut segments: Vec<((f64, f64), (f64, f64))> = Vec::new();
    for r in 0..ny - 1 {
        for c in 0..nx - 1 {
            let corners = [(c, r), (c + 1, r), (c + 1, r + 1), (c, r + 1)];
            let Some(v) = corners.iter().map(|&(x, y)| at(x, y)).collect::<Option<Vec<f64>>>()
            else {
                continue;
            };
            let case = v
                .iter()
                .enumerate()
                .fold(0usize, |acc, (k, &x)| acc | (usize::from(x > level) << k));
            // edges: 0 bottom (0-1), 1 right (1-2), 2 top (2-3), 3 left (3-0)
            let edge = |e: usize| cross(corners[e], corners[(e + 1) % 4]);
            let centre_above = v.iter().sum::<f64>() / 4.0 > level;
            let pairs: &[(usize, usize)] = match case {
                0 | 15 => &[],
                1 | 14 => &[(3, 0)],
                2 | 13 => &[(0, 1)],
                3 | 12 => &[(3, 1)],
                4 | 11 => &[(1, 2)],
                6 | 9 => &[(0, 2)],
                7 | 8 => &[(3, 2)],
                5 => {
                    if centre_above {
                        &[(3, 2), (0, 1)]
                    } else {
                        &[(3, 0), (1, 2)]
                    }
                }
                10 => {
                    if centre_above {
                        &[(3, 0), (1, 2)]
                    } else {
                        &[(3, 2), (0, 1)]
                    }
                }
                _ => &[],
            };
            segments.extend(pairs.iter().map(|&(a, b)| (edge(a), edge(b))));
        }
    }
    join_segments(segments)
}

/// Joins segments that share end points into polylines (exact equality of the end points).
fn join_segments(segments: Vec<((f64, f64), (f64, f64))>) -> Vec<Vec<(f64, f64)>> {
    use std::collections::BTreeMap;
    let key = |p: (f64, f64)| (p.0.to_bits(), p.1.to_bits());
    let mut by_end: BTreeMap<(u64, u64), Vec<usize>> = BTreeMap::new();
    for (i, (a, b)) in segments.iter().enumerate() {
        by_end.entry(key(*a)).or_default().push(i);
        by_end.entry(key(*b)).or_default().push(i);
    }
    let mut used = vec![false; segments.len()];
    let mut lines = Vec::new();
    for start in 0..segments.len() {
        if used[start] {
            continue;
        }
        used[start] = true;
        let mut line = std::collections::VecDeque::from([segments[start].0, segments[start].1]);
        // extend at the back, then at the front
        for front in [false, true] {
            loop {
                let end = if front { line[0] } else { line[line.len() - 1] };
                let next =
                    by_end.get(&key(end)).and_then(|ids| ids.iter().copied().find(|&i| !used[i]));
                let Some(i) = next else { break };
                used[i] = true;
                let (a, b) = segments[i];
                let other = if key(a) == key(end) { b } else { a };
                if front {
                    line.push_front(other);
                } else {
                    line.push_back(other);
                }
            }
        }
        lines.push(line.into_iter().collect());
    }
    lines
}

pub fn contour_svg(fig: &ContourFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds;
    let side = 430u32;
    let (label_x, label_y, margin) = (40u32, 60u32, 14u32);
    let width = side + label_y + 2 * margin;
    let height = side + label_x + 2 * margin;
    let mut entries: Vec<LegendEntry<'_>> = fig
        .paths
        .iter()
        .map(|p| LegendEntry {
            label: &p.label,
            color: p.color.map(rgb).unwrap_or(TRUTH),
            dot: false,
            dashed: false,
            dotted: p.color.is_some_and(dotted),
        })
        .collect();
    entries.push(LegendEntry {
        label: "true position",
        color: CORNER,
        dot: true,
        dashed: false,
        dotted: false,
    });
    entries.push(LegendEntry {
        label: "initial guess",
        color: BLACK,
        dot: true,
        dashed: false,
        dotted: false,
    });
    let (_, legend_px) = legend_layout(&entries, width.max(WIDTH), label_y + margin);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width.max(WIDTH), height + legend_px))
            .into_drawing_area();
        root.fill(&WHITE).expect("drawing an SVG into memory");
        let (top, plot) = root.split_vertically(legend_px);
        draw_legend(&top, &entries, label_y + margin).expect("drawing an SVG into memory");
        // a square plot at the left, the rest of the width for the legend above
        let (plot, _) = plot.split_horizontally(width);
        draw_contour(&plot, fig, ((x0, x1), (y0, y1)), (label_x, label_y, margin))
            .expect("drawing an SVG into memory");
        root.present().expect("finishing an SVG in memory");
    }
    svg
}

/// Gray of contour level k of n: darker for lower f.
fn level_gray(k: usize, n: usize) -> RGBColor {
    let g = (40.0 + 170.0 * k as f64 / n.max(1) as f64) as u8;
    RGBColor(g, g, g)
}

fn draw_contour(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    fig: &ContourFigure,
    ((x0, x1), (y0, y1)): Bounds,
    (label_x, label_y, margin): (u32, u32, u32),
) -> Result<(), String> {
    let e = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
    let mut chart = ChartBuilder::on(root)
        .margin(margin)
        .x_label_area_size(label_x)
        .y_label_area_size(label_y)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("x [m]")
        .y_desc("y [m]")
        .label_style((FONT, 12))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.06))
        .draw()
        .map_err(e)?;
    let n = fig.levels.len();
    for (k, (_, lines)) in fig.levels.iter().enumerate() {
        let color = level_gray(k, n);
        chart
            .draw_series(lines.iter().map(|l| PathElement::new(l.clone(), color.stroke_width(1))))
            .map_err(e)?;
    }
    let inside = |&(x, y): &(f64, f64)| x >= x0 && x <= x1 && y >= y0 && y <= y1;
    for p in &fig.paths {
        let color = p.color.map(rgb).unwrap_or(TRUTH);
        let pts: Vec<(f64, f64)> = p.points.iter().copied().filter(inside).collect();
        if p.color.is_some_and(dotted) {
            chart
                .draw_series(plotters::series::DashedLineSeries::new(
                    pts.clone(),
                    2,
                    4,
                    color.stroke_width(2),
                ))
                .map_err(e)?;
        } else {
            chart
                .draw_series(std::iter::once(PathElement::new(pts.clone(), color.stroke_width(2))))
                .map_err(e)?;
        }
        chart.draw_series(pts.iter().map(|q| Circle::new(*q, 3, color.filled()))).map_err(e)?;
        // the estimate: a ring around the last point
        if let Some(last) = pts.last() {
            chart
                .draw_series(std::iter::once(Circle::new(*last, 6, color.stroke_width(2))))
                .map_err(e)?;
        }
    }
    let d = 0.012 * (x1 - x0);
    let t = fig.truth;
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(t.0 - d, t.1 - d), (t.0 + d, t.1 + d)],
            CORNER.filled(),
        )))
        .map_err(e)?;
    chart
        .draw_series(std::iter::once(TriangleMarker::new(fig.initial, 7, BLACK.filled())))
        .map_err(e)?;
    Ok(())
}

/// An incremental map ([EP] Figs 52–59): the walls, every occupied cell of the map an
/// algorithm's chained poses build, and those poses.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanMapFigure {
    pub walls: Vec<((f64, f64), (f64, f64))>,
    /// Cell centres [m] and the cell size they were binned to.
    pub points: Vec<(f64, f64)>,
    pub path: Vec<(f64, f64)>,
    pub color: usize,
    pub label: String,
}

impl ScanMapFigure {
    pub fn bounds(&self) -> Bounds {
        let xs: Vec<f64> = self
            .walls
            .iter()
            .flat_map(|(a, b)| [a.0, b.0])
            .chain(self.points.iter().chain(&self.path).map(|p| p.0))
            .filter(|v| v.is_finite())
            .collect();
        let ys: Vec<f64> = self
            .walls
            .iter()
            .flat_map(|(a, b)| [a.1, b.1])
            .chain(self.points.iter().chain(&self.path).map(|p| p.1))
            .filter(|v| v.is_finite())
            .collect();
        (padded(&xs, 0.03, false), padded(&ys, 0.03, false))
    }
}

pub fn scan_map_svg(fig: &ScanMapFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds();
    let (label_x, label_y, margin) = (40u32, 52u32, 14u32);
    let plot_w = (WIDTH - label_y - 2 * margin) as f64;
    let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(160.0, 560.0);
    let (plot_w, height) =
        (plot_h * (x1 - x0) / (y1 - y0), plot_h as u32 + label_x + 2 * margin + 8);
    let width = (plot_w as u32 + label_y + 2 * margin).min(WIDTH);
    let entries = [
        LegendEntry {
            label: &fig.label,
            color: rgb(fig.color),
            dot: true,
            dashed: false,
            dotted: false,
        },
        LegendEntry {
            label: "estimated scan poses",
            color: rgb(fig.color),
            dot: false,
            dashed: false,
            dotted: false,
        },
        LegendEntry { label: "walls", color: BLACK, dot: false, dashed: false, dotted: false },
    ];
    let (_, legend_px) = legend_layout(&entries, width, label_y + margin);
    let mut svg = String::new();
    // the map's cells, as whole pixels of one <path> (an element per cell would make the file
    // ten times larger)
    let mut pixels: Vec<(i32, i32)> = Vec::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (width, height + legend_px)).into_drawing_area();
        root.fill(&WHITE).expect("drawing an SVG into memory");
        let (top, plot) = root.split_vertically(legend_px);
        draw_legend(&top, &entries, label_y + margin).expect("drawing an SVG into memory");
        (|| -> Result<(), String> {
            let e = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
            let mut chart = ChartBuilder::on(&plot)
                .margin(margin)
                .x_label_area_size(label_x)
                .y_label_area_size(label_y)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(e)?;
            chart
                .configure_mesh()
                .x_desc("x [m]")
                .y_desc("y [m]")
                .label_style((FONT, 12))
                .light_line_style(WHITE.mix(0.0))
                .bold_line_style(BLACK.mix(0.06))
                .draw()
                .map_err(e)?;
            chart
                .draw_series(
                    fig.walls.iter().map(|(a, b)| {
                        PathElement::new(vec![*a, *b], BLACK.mix(0.5).stroke_width(1))
                    }),
                )
                .map_err(e)?;
            let color = rgb(fig.color);
            pixels = fig.points.iter().map(|p| chart.backend_coord(p)).collect();
            chart
                .draw_series(std::iter::once(PathElement::new(
                    decimate(&fig.path, SVG_PATH_POINTS),
                    color.mix(0.6).stroke_width(1),
                )))
                .map_err(e)?;
            Ok(())
        })()
        .expect("drawing an SVG into memory");
        root.present().expect("finishing an SVG in memory");
    }
    pixels.sort_unstable();
    pixels.dedup();
    let d: String = pixels.iter().map(|(x, y)| format!("M{} {}h2v2h-2z", x - 1, y - 1)).collect();
    let path = format!(
        "<path fill=\"#{}\" d=\"{d}\"/>\n",
        PALETTE[fig.color % PALETTE.len()].to_uppercase()
    );
    match svg.rfind("</svg>") {
        Some(end) => svg.insert_str(end, &path),
        None => svg.push_str(&path),
    }
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fig(axis: XAxis) -> LineFigure {
        LineFigure {
            x_label: "k".into(),
            y_label: "ATE RMSE [m]".into(),
            x_axis: axis,
            x_ticks: vec![(0.01, "0.01".into()), (0.1, "0.1".into()), (1.0, "1".into())],
            series: vec![LineSeries {
                label: "map & <algo>".into(),
                color: 0,
                points: vec![
                    SeriesPoint { x: 0.01, mean: 1.0, lo: 0.8, hi: 1.2 },
                    SeriesPoint { x: 0.1, mean: 2.0, lo: f64::NAN, hi: f64::NAN },
                    SeriesPoint { x: 1.0, mean: f64::INFINITY, lo: f64::NAN, hi: f64::NAN },
                ],
                dashed: false,
                scatter: false,
            }],
        }
    }

    #[test]
    fn svg_is_deterministic_well_formed_and_escaped() {
        for axis in [XAxis::Linear, XAxis::Log] {
            let a = line_svg(&fig(axis.clone()));
            assert_eq!(a, line_svg(&fig(axis)));
            assert!(a.contains("<svg") && a.trim_end().ends_with("</svg>"));
            assert!(a.contains("map &amp; &lt;algo&gt;"), "legend text must be XML-escaped");
        }
    }

    #[test]
    fn contour_lines_of_a_cone_are_closed_rings_at_the_right_radius() {
        // f = distance from (0, 0) on a 21 × 21 grid over [−1, 1]²
        let axis: Vec<f64> = (0..21).map(|k| -1.0 + 0.1 * k as f64).collect();
        let f: Vec<Option<f64>> =
            axis.iter().flat_map(|&y| axis.iter().map(move |&x| Some(x.hypot(y)))).collect();
        let lines = contour_lines(&axis, &axis, &f, 0.55);
        assert_eq!(lines.len(), 1, "one ring");
        let ring = &lines[0];
        assert_eq!(ring.first(), ring.last(), "closed");
        // linear interpolation of a cone: every point within a grid cell's chord error of r
        assert!(ring.iter().all(|(x, y)| (x.hypot(*y) - 0.55).abs() < 0.01), "{ring:?}");
        // a level above every value, and a missing corner, draw nothing there
        assert!(contour_lines(&axis, &axis, &f, 5.0).is_empty());
        let holes: Vec<Option<f64>> = f.iter().map(|_| None).collect();
        assert!(contour_lines(&axis, &axis, &holes, 0.5).is_empty());
    }

    #[test]
    fn decimate_keeps_ends() {
        let pts: Vec<(f64, f64)> = (0..1001).map(|i| (i as f64, 0.0)).collect();
        let d = decimate(&pts, 100);
        assert!(d.len() <= 101);
        assert_eq!(d[0], pts[0]);
        assert_eq!(d.last(), pts.last());
    }
}

/// Sobol' indices of one metric: per parameter, S1 and ST bars with their 95 % intervals, and the
/// noise floor (the ST a parameter without effect shows) as a dashed line.
#[derive(Debug, Clone, PartialEq)]
pub struct IndexBarsFigure {
    pub params: Vec<String>,
    /// (value, low, high) per parameter.
    pub s1: Vec<(f64, f64, f64)>,
    pub st: Vec<(f64, f64, f64)>,
    pub noise_floor: Option<f64>,
}

impl IndexBarsFigure {
    /// y range: [min(0, lowest bound), max(1, highest bound)].
    pub fn y_range(&self) -> (f64, f64) {
        let all = self
            .s1
            .iter()
            .chain(&self.st)
            .flat_map(|&(v, l, h)| [v, l, h])
            .filter(|v| v.is_finite());
        let (lo, hi) = all.fold((0.0f64, 1.0f64), |(a, b), v| (a.min(v), b.max(v)));
        (lo - 0.02, hi + 0.02)
    }
}

pub fn index_bars_svg(fig: &IndexBarsFigure) -> String {
    let entries = [
        LegendEntry {
            label: "S1 (first order)",
            color: rgb(0),
            dot: true,
            dashed: false,
            dotted: false,
        },
        LegendEntry { label: "ST (total)", color: rgb(1), dot: true, dashed: false, dotted: false },
        LegendEntry {
            label: "noise floor of ST",
            color: TRUTH,
            dot: false,
            dashed: true,
            dotted: false,
        },
    ];
    let shown = if fig.noise_floor.is_some() { &entries[..] } else { &entries[..2] };
    // room below the plot for the rotated parameter names
    legend_and_plot(shown, 60, |plot| draw_index_bars(plot, fig))
}

/// An SVG of a legend strip above a plot drawn by `draw` (`extra` px taller than the default).
fn legend_and_plot(
    entries: &[LegendEntry<'_>],
    extra: u32,
    draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String>,
) -> String {
    let (_, legend_px) = legend_layout(entries, WIDTH, LEFT_PX);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT + legend_px + extra))
            .into_drawing_area();
        root.fill(&WHITE).expect("drawing an SVG into memory");
        let (top, plot) = root.split_vertically(legend_px);
        draw_legend(&top, entries, LEFT_PX).expect("drawing an SVG into memory");
        draw(&plot).expect("drawing an SVG into memory");
        root.present().expect("finishing an SVG in memory");
    }
    svg
}

fn draw_index_bars(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    fig: &IndexBarsFigure,
) -> Result<(), String> {
    let d = fig.params.len() as f64;
    let (y0, y1) = fig.y_range();
    let mut chart = ChartBuilder::on(root)
        .margin(14)
        .x_label_area_size(100)
        .y_label_area_size(LEFT_PX - 14)
        .build_cartesian_2d(0.0..d, y0..y1)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_desc("Sobol' index")
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| e.to_string())?;
    for (series, (values, offset)) in [(&fig.s1, 0.18), (&fig.st, 0.52)].into_iter().enumerate() {
        let color = rgb(series);
        for (i, &(v, lo, hi)) in values.iter().enumerate() {
            let x = i as f64 + offset;
            if v.is_finite() {
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x, 0.0), (x + 0.3, v)],
                        color.mix(0.85).filled(),
                    )))
                    .map_err(|e| e.to_string())?;
            }
            if lo.is_finite() && hi.is_finite() {
                let xm = x + 0.15;
                let whisker = vec![(xm, lo), (xm, hi)];
                chart
                    .draw_series([
                        PathElement::new(whisker, BLACK.stroke_width(1)),
                        PathElement::new(
                            vec![(xm - 0.06, lo), (xm + 0.06, lo)],
                            BLACK.stroke_width(1),
                        ),
                        PathElement::new(
                            vec![(xm - 0.06, hi), (xm + 0.06, hi)],
                            BLACK.stroke_width(1),
                        ),
                    ])
                    .map_err(|e| e.to_string())?;
            }
        }
    }
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![(0.0, 0.0), (d, 0.0)],
            BLACK.stroke_width(1),
        )))
        .map_err(|e| e.to_string())?;
    if let Some(f) = fig.noise_floor.filter(|f| f.is_finite()) {
        chart
            .draw_series(plotters::series::DashedLineSeries::new(
                vec![(0.0, f), (d, f)],
                6,
                4,
                TRUTH.stroke_width(1),
            ))
            .map_err(|e| e.to_string())?;
    }
    let style = TextStyle::from((FONT, 12).into_font())
        .pos(Pos::new(HPos::Right, VPos::Center))
        .transform(FontTransform::Rotate270);
    let (bx, by) = root.get_base_pixel();
    for (i, p) in fig.params.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(i as f64 + 0.5, y0));
        root.draw(&Text::new(
            p.as_str(),
            (px - bx, py - by + 6),
            style.clone().pos(Pos::new(HPos::Right, VPos::Center)),
        ))
        .map_err(|e| e.to_string())?;
    }
    Ok(())
}

/// Morris's screening of one metric: μ* against σ per parameter (labelled), the line σ = μ*
/// (above it: non-linear or interacting), and the noise floor of μ* as a dashed vertical line.
#[derive(Debug, Clone, PartialEq)]
pub struct MorrisFigure {
    pub params: Vec<String>,
    pub mu_star: Vec<f64>,
    pub sigma: Vec<f64>,
    pub noise_floor: Option<f64>,
    pub unit: String,
}

impl MorrisFigure {
    pub fn max(&self) -> f64 {
        let m = self
            .mu_star
            .iter()
            .chain(&self.sigma)
            .chain(self.noise_floor.iter())
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        if m > 0.0 { m * 1.12 } else { 1.0 }
    }
}

pub fn morris_svg(fig: &MorrisFigure) -> String {
    let entries = [
        LegendEntry { label: "parameter", color: rgb(0), dot: true, dashed: false, dotted: false },
        LegendEntry { label: "σ = μ*", color: TRUTH, dot: false, dashed: false, dotted: false },
        LegendEntry {
            label: "noise floor of μ*",
            color: rgb(3),
            dot: false,
            dashed: true,
            dotted: false,
        },
    ];
    let shown = if fig.noise_floor.is_some() { &entries[..] } else { &entries[..2] };
    legend_and_plot(shown, 0, |plot| draw_morris(plot, fig))
}

fn draw_morris(
    root: &DrawingArea<SVGBackend<'_>, Shift>,
    fig: &MorrisFigure,
) -> Result<(), String> {
    let m = fig.max();
    let mut chart = ChartBuilder::on(root)
        .margin(14)
        .x_label_area_size(46)
        .y_label_area_size(LEFT_PX - 14)
        .build_cartesian_2d(0.0..m, 0.0..m)
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(format!("μ* [{}]", fig.unit))
        .y_desc(format!("σ [{}]", fig.unit))
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 14))
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|e| e.to_string())?;
    chart
        .draw_series(std::iter::once(PathElement::new(
            vec![(0.0, 0.0), (m, m)],
            TRUTH.stroke_width(1),
        )))
        .map_err(|e| e.to_string())?;
    if let Some(f) = fig.noise_floor.filter(|f| f.is_finite()) {
        chart
            .draw_series(plotters::series::DashedLineSeries::new(
                vec![(f, 0.0), (f, m)],
                6,
                4,
                rgb(3).stroke_width(1),
            ))
            .map_err(|e| e.to_string())?;
    }
    let style = TextStyle::from((FONT, 12).into_font()).pos(Pos::new(HPos::Left, VPos::Bottom));
    for ((p, &x), &y) in fig.params.iter().zip(&fig.mu_star).zip(&fig.sigma) {
        if x.is_finite() && y.is_finite() {
            chart
                .draw_series(std::iter::once(Circle::new((x, y), 4, rgb(0).filled())))
                .map_err(|e| e.to_string())?;
            chart
                .draw_series(std::iter::once(Text::new(p.clone(), (x, y), style.clone())))
                .map_err(|e| e.to_string())?;
        }
    }
    Ok(())
}
