//! Figure models (what a figure shows) and their SVG rendering with plotters. The same model is
//! rendered for LaTeX by [`super::pgf`], so HTML and PDF show the same data.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// tab10: distinguishable, colour-blind-tolerant series colours (hex RGB).
pub const PALETTE: [&str; 10] = ["1f77b4", "ff7f0e", "2ca02c", "d62728", "9467bd", "8c564b", "e377c2", "7f7f7f", "bcbd22", "17becf"];

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
}

/// Legend layout in rows above the plot: (entry index, x, row) and the strip's height [px].
fn legend_layout(entries: &[LegendEntry<'_>], width: u32, left: u32) -> (Vec<(usize, u32, u32)>, u32) {
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

fn draw_legend(area: &DrawingArea<SVGBackend<'_>, Shift>, entries: &[LegendEntry<'_>], left: u32) -> Result<(), String> {
    let (placed, _) = legend_layout(entries, area.dim_in_pixel().0, left);
    let style = TextStyle::from((FONT, 12).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    for (i, x, row) in placed {
        let e = &entries[i];
        let (x, y) = (x as i32, 12 + 18 * row as i32);
        if e.dot {
            area.draw(&Circle::new((x + 9, y), 4, e.color.filled())).map_err(|e| e.to_string())?;
        } else if e.dashed {
            for (a, b) in [(0, 5), (8, 13), (16, 18)] {
                area.draw(&PathElement::new(vec![(x + a, y), (x + b, y)], e.color.stroke_width(2))).map_err(|e| e.to_string())?;
            }
        } else {
            area.draw(&PathElement::new(vec![(x, y), (x + 18, y)], e.color.stroke_width(2))).map_err(|e| e.to_string())?;
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
            _ => self.series.iter().flat_map(|s| Self::drawable(&s.points)).map(|p| self.position(p.x)).collect(),
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
    let entries: Vec<LegendEntry<'_>> = fig.series.iter().map(|s| LegendEntry { label: &s.label, color: rgb(s.color), dot: false, dashed: s.dashed }).collect();
    let (_, legend_px) = legend_layout(&entries, WIDTH, LEFT_PX);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT + legend_px)).into_drawing_area();
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
    let mut chart = ChartBuilder::on(root).margin(14).x_label_area_size(46).y_label_area_size(LEFT_PX - 14).build_cartesian_2d(x0..x1, y0..y1).map_err(|e| e.to_string())?;
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(fig.x_label.as_str()).y_desc(fig.y_label.as_str()).label_style((FONT, 13)).axis_desc_style((FONT, 14)).light_line_style(WHITE.mix(0.0));
    if manual_ticks {
        mesh.disable_x_mesh().x_labels(0);
    }
    mesh.draw().map_err(|e| e.to_string())?;

    for s in &fig.series {
        let color = rgb(s.color);
        let pts: Vec<&SeriesPoint> = LineFigure::drawable(&s.points).collect();
        if s.scatter {
            chart.draw_series(pts.iter().map(|p| Circle::new((fig.position(p.x), p.mean), 4, color.filled()))).map_err(|e| e.to_string())?;
            continue;
        }
        if s.dashed {
            let line: Vec<(f64, f64)> = pts.iter().map(|p| (fig.position(p.x), p.mean)).collect();
            chart.draw_series(plotters::series::DashedLineSeries::new(line.clone(), 6, 4, color.stroke_width(2))).map_err(|e| e.to_string())?;
            chart.draw_series(line.into_iter().map(|p| Circle::new(p, 3, color.stroke_width(1)))).map_err(|e| e.to_string())?;
            // The published dispersion, where printed: vertical error bars.
            let bars = pts.iter().filter(|p| p.lo.is_finite() && p.hi.is_finite()).map(|p| PathElement::new(vec![(fig.position(p.x), p.lo), (fig.position(p.x), p.hi)], color.stroke_width(1)));
            chart.draw_series(bars).map_err(|e| e.to_string())?;
            continue;
        }
        let band: Vec<&SeriesPoint> = pts.iter().copied().filter(|p| p.lo.is_finite() && p.hi.is_finite()).collect();
        if band.len() >= 2 {
            let mut poly: Vec<(f64, f64)> = band.iter().map(|p| (fig.position(p.x), p.hi)).collect();
            poly.extend(band.iter().rev().map(|p| (fig.position(p.x), p.lo)));
            chart.draw_series(std::iter::once(Polygon::new(poly, color.mix(0.18).filled()))).map_err(|e| e.to_string())?;
        }
        let line: Vec<(f64, f64)> = pts.iter().map(|p| (fig.position(p.x), p.mean)).collect();
        chart.draw_series(plotters::series::LineSeries::new(line.clone(), color.stroke_width(2))).map_err(|e| e.to_string())?;
        chart.draw_series(line.into_iter().map(|p| Circle::new(p, 3, color.filled()))).map_err(|e| e.to_string())?;
    }
    if manual_ticks {
        let style = TextStyle::from((FONT, 12).into_font()).pos(Pos::new(HPos::Center, VPos::Top));
        // backend_coord is in whole-SVG pixels; `root` starts below the legend strip.
        let (bx, by) = root.get_base_pixel();
        for (x, label) in &fig.x_ticks {
            let (px, py) = chart.backend_coord(&(fig.position(*x), y0));
            let (px, py) = (px - bx, py - by);
            root.draw(&PathElement::new(vec![(px, py), (px, py + 4)], BLACK)).map_err(|e| e.to_string())?;
            root.draw(&Text::new(label.as_str(), (px, py + 6), style.clone())).map_err(|e| e.to_string())?;
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
pub fn clip_line(rho: f64, theta: f64, ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64))) -> Option<((f64, f64), (f64, f64))> {
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
        let points = || self.paths.iter().flat_map(|p| p.points.iter().copied()).chain(self.corners.iter().copied());
        let xs: Vec<f64> = self.walls.iter().flat_map(|(a, b)| [a.0, b.0]).chain(points().map(|q| q.0)).filter(|v| v.is_finite()).collect();
        let ys: Vec<f64> = self.walls.iter().flat_map(|(a, b)| [a.1, b.1]).chain(points().map(|q| q.1)).filter(|v| v.is_finite()).collect();
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

/// Most points a path keeps in an SVG figure.
const SVG_PATH_POINTS: usize = 1500;

pub fn trajectory_svg(fig: &TrajectoryFigure) -> String {
    let ((x0, x1), (y0, y1)) = fig.bounds();
    // Equal scale on both axes: size the drawing to the map's aspect ratio.
    let (label_x, label_y, margin) = (40u32, 52u32, 14u32);
    let plot_w = (WIDTH - label_y - 2 * margin) as f64;
    let plot_h = (plot_w * (y1 - y0) / (x1 - x0)).clamp(160.0, 640.0);
    let (plot_w, height) = (plot_h * (x1 - x0) / (y1 - y0), plot_h as u32 + label_x + 2 * margin + 8);
    let width = (plot_w as u32 + label_y + 2 * margin).min(WIDTH);
    let mut entries: Vec<LegendEntry<'_>> = fig.paths.iter().map(|p| LegendEntry { label: &p.label, color: p.color.map(rgb).unwrap_or(TRUTH), dot: false, dashed: false }).collect();
    if !fig.corners.is_empty() {
        entries.push(LegendEntry { label: if fig.point_landmarks { "true landmarks" } else { "true corners" }, color: CORNER, dot: true, dashed: false });
    }
    if !fig.est_lines.is_empty() || !fig.est_corners.is_empty() {
        let label = if fig.point_landmarks { "mapped landmarks (×)" } else { "mapped lines (dashed) and corners (×)" };
        entries.push(LegendEntry { label, color: RGBColor(100, 100, 100), dot: false, dashed: !fig.point_landmarks });
    }
    let (_, legend_px) = legend_layout(&entries, width, label_y + margin);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height + legend_px)).into_drawing_area();
        root.fill(&WHITE).expect("drawing an SVG into memory");
        let (top, plot) = root.split_vertically(legend_px);
        draw_legend(&top, &entries, label_y + margin).expect("drawing an SVG into memory");
        draw_trajectory(&plot, fig, ((x0, x1), (y0, y1)), (label_x, label_y, margin)).expect("drawing an SVG into memory");
        root.present().expect("finishing an SVG in memory");
    }
    svg
}

type Bounds = ((f64, f64), (f64, f64));

fn draw_trajectory(root: &DrawingArea<SVGBackend<'_>, Shift>, fig: &TrajectoryFigure, ((x0, x1), (y0, y1)): Bounds, (label_x, label_y, margin): (u32, u32, u32)) -> Result<(), String> {
    let e = |e: plotters::drawing::DrawingAreaErrorKind<_>| e.to_string();
    let mut chart = ChartBuilder::on(root).margin(margin).x_label_area_size(label_x).y_label_area_size(label_y).build_cartesian_2d(x0..x1, y0..y1).map_err(e)?;
    chart.configure_mesh().x_desc("x [m]").y_desc("y [m]").label_style((FONT, 12)).light_line_style(WHITE.mix(0.0)).bold_line_style(BLACK.mix(0.08)).draw().map_err(e)?;
    chart.draw_series(fig.walls.iter().map(|(a, b)| PathElement::new(vec![*a, *b], BLACK.stroke_width(3)))).map_err(e)?;
    for p in &fig.paths {
        let (color, width) = match p.color {
            Some(c) => (rgb(c), 2),
            None => (TRUTH, 1),
        };
        chart.draw_series(std::iter::once(PathElement::new(decimate(&p.points, SVG_PATH_POINTS), color.stroke_width(width)))).map_err(e)?;
    }
    for &(color, rho, theta) in &fig.est_lines {
        if let Some((a, b)) = clip_line(rho, theta, ((x0, x1), (y0, y1))) {
            chart.draw_series(plotters::series::DashedLineSeries::new([a, b], 3, 5, rgb(color).mix(0.6).stroke_width(1))).map_err(e)?;
        }
    }
    chart.draw_series(fig.corners.iter().map(|c| Circle::new(*c, 4, CORNER.filled()))).map_err(e)?;
    // mapped landmarks outside the plotted area are left out rather than pinned to its edge
    let inside = |(x, y): (f64, f64)| x >= x0 && x <= x1 && y >= y0 && y <= y1;
    chart.draw_series(fig.est_corners.iter().filter(|(_, c)| inside(*c)).map(|(color, c)| Cross::new(*c, 4, rgb(*color).stroke_width(2)))).map_err(e)?;
    chart.draw_series(std::iter::once(TriangleMarker::new(fig.start, 7, BLACK.filled()))).map_err(e)?;
    Ok(())
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
    fn decimate_keeps_ends() {
        let pts: Vec<(f64, f64)> = (0..1001).map(|i| (i as f64, 0.0)).collect();
        let d = decimate(&pts, 100);
        assert!(d.len() <= 101);
        assert_eq!(d[0], pts[0]);
        assert_eq!(d.last(), pts.last());
    }
}
