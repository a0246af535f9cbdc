//! Laser scan → line and corner features in the robot frame ([FT] Ch. 4).
//!
//! 1. Split & Merge, Iterative-End-Point-Fit variant ([FT] Table 4.3): a point set is dropped if it
//!    has fewer than Pmin points or its end-point chord is shorter than Lmin (both checks *before*
//!    the split test, as the thesis places them); otherwise it is split at the point farthest from
//!    the chord while that distance is ≥ Dmax (the split point belongs to both halves).
//! 2. Collinear merge ([FT] Table 4.4): lines within ρmax and θmax of each other are merged (union
//!    of points, line refitted).
//! 3. Corners ([FT] Table 4.2): intersections of two lines of the same scan that lie within Emax of
//!    a scan point of each line; near-parallel pairs are skipped.
//!
//! Pure: points in, features out.

use crate::config::{Checks, Violation};
use crate::geom::{Line, Point2, wrap_angle};
use crate::world::laser::{LaserGeometry, Scan};
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Which features a filter uses ([FT] §4: points, lines or both; the thesis's experiments use both).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum FeatureKind {
    Lines,
    Corners,
    Both,
}

/// How a line's (ρ, θ) is fitted to its points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum LineFit {
    /// The chord through the first and last point ([FT]'s Iterative-End-Point-Fit).
    Endpoints,
    /// Orthogonal (total) least squares over all points.
    LeastSquares,
}

/// `[base.features]`: the extraction thresholds. Defaults: [FT] Table 10.2 / §4.4.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct FeatureParams {
    /// Dmax [m]: split while the farthest point is at least this far from the chord.
    pub dmax_m: f64,
    /// Lmin [m]: minimum segment length (distance between its end points).
    pub lmin_m: f64,
    /// Pmin: minimum number of points of a segment.
    pub pmin: u32,
    /// ρmax [m]: collinear merge threshold on ρ.
    pub rho_max_m: f64,
    /// θmax [rad]: collinear merge threshold on θ.
    pub theta_max_rad: f64,
    /// Emax [m]: a line intersection is a corner if it lies within Emax of a point of each line.
    pub emax_m: f64,
    /// Line pairs closer to parallel than this [rad] are not intersected ([FT] §10: θmax).
    pub corner_min_angle_rad: f64,
    /// Lines, corners, or both.
    pub kind: FeatureKind,
    /// Fit of split segments ([FT]: end points).
    pub split_fit: LineFit,
    /// Refit of merged lines ([FT] leaves it open; least squares uses every point).
    pub merge_fit: LineFit,
    /// Split the scan at range jumps before Split & Merge. [FT] describes none; without it a line
    /// can take in a point of another wall that happens to lie on its extension across a gap
    /// (a range cut-off or an occlusion), and its intersections become fictitious corners.
    pub breakpoints: bool,
    /// λ [deg] of the adaptive breakpoint detector (Borges & Aldon 2004): consecutive points
    /// farther apart than r·sin Δφ / sin(λ − Δφ) + margin are on different surfaces — the gap a
    /// wall seen at incidence λ would leave.
    pub breakpoint_lambda_deg: f64,
    /// Margin [m] added to the breakpoint distance (≈ 3σ of the range noise).
    pub breakpoint_margin_m: f64,
}

impl FeatureParams {
    /// The extractor and its thresholds in one sentence, for the reports' modelling choices.
    pub fn describe(&self) -> String {
        format!(
            "Feature extraction ([FT] Ch. 4): Split & Merge (iterative end-point fit) with Dmax = {} m, Lmin = {} m, Pmin = {}; collinear merge within ρmax = {} m, θmax = {} rad; corners within Emax = {} m; {}.",
            self.dmax_m,
            self.lmin_m,
            self.pmin,
            self.rho_max_m,
            self.theta_max_rad,
            self.emax_m,
            if self.breakpoints {
                "the scan is first split at breakpoints (missed returns, adaptive distance)"
            } else {
                "no breakpoint detection, as in [FT]"
            }
        )
    }
}

impl Default for FeatureParams {
    fn default() -> Self {
        Self {
            dmax_m: 0.02,
            lmin_m: 0.4,
            pmin: 9,
            rho_max_m: 0.1,
            theta_max_rad: 0.07,
            emax_m: 0.1,
            corner_min_angle_rad: 0.07,
            kind: FeatureKind::Both,
            split_fit: LineFit::Endpoints,
            merge_fit: LineFit::LeastSquares,
            breakpoints: true,
            breakpoint_lambda_deg: 10.0,
            breakpoint_margin_m: 0.03,
        }
    }
}

impl FeatureParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.non_negative("dmax_m", self.dmax_m);
        c.non_negative("lmin_m", self.lmin_m);
        c.require(self.pmin >= 2, "pmin", || {
            format!("a line needs at least 2 points, got {}", self.pmin)
        });
        c.non_negative("rho_max_m", self.rho_max_m);
        c.in_range("theta_max_rad", self.theta_max_rad, 0.0, std::f64::consts::PI);
        c.non_negative("emax_m", self.emax_m);
        c.in_range(
            "corner_min_angle_rad",
            self.corner_min_angle_rad,
            0.0,
            std::f64::consts::FRAC_PI_2,
        );
        c.in_range("breakpoint_lambda_deg", self.breakpoint_lambda_deg, f64::MIN_POSITIVE, 90.0);
        c.non_negative("breakpoint_margin_m", self.breakpoint_margin_m);
        c.finish()
    }
}

/// A line observed in one scan, in the robot frame.
#[derive(Debug, Clone, PartialEq)]
pub struct LineFeature {
    pub line: Line,
    /// End points of the supporting points (first and last in scan order).
    pub first: Point2,
    pub last: Point2,
    /// Number of supporting scan points.
    pub points: usize,
}

/// The features of one scan, robot frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ScanFeatures {
    pub lines: Vec<LineFeature>,
    pub corners: Vec<Point2>,
}

impl ScanFeatures {
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty() && self.corners.is_empty()
    }
}

/// One return of a scan: its point in the robot frame, its range and its beam index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanPoint {
    pub p: Point2,
    pub range_m: f64,
    pub beam: usize,
}

/// The returns of a scan as points in the robot frame, in beam order.
pub fn scan_points(scan: &Scan, geometry: &LaserGeometry) -> Vec<ScanPoint> {
    scan.ranges_m
        .iter()
        .enumerate()
        .filter_map(|(i, r)| r.map(|r| (i, r, geometry.bearing(i))))
        .map(|(beam, r, phi)| ScanPoint {
            p: Point2::new(r * phi.cos(), r * phi.sin()),
            range_m: r,
            beam,
        })
        .collect()
}

/// Extracts the features of one scan.
pub fn extract(scan: &Scan, geometry: &LaserGeometry, params: &FeatureParams) -> ScanFeatures {
    extract_points(&scan_points(scan, geometry), geometry.angle_increment_rad, params)
}

/// Extracts features from ordered scan points (robot frame) of a laser with the given angle
/// between beams.
pub fn extract_points(
    scan: &[ScanPoint],
    increment_rad: f64,
    params: &FeatureParams,
) -> ScanFeatures {
    let points: Vec<Point2> = scan.iter().map(|s| s.p).collect();
    let points = points.as_slice();
    let mut segments = Vec::new();
    for set in point_sets(scan, increment_rad, params) {
        split_and_merge(points, set, params, &mut segments);
    }
    let lines = merge_collinear(points, segments, params);
    let corners = if params.kind == FeatureKind::Lines {
        Vec::new()
    } else {
        corners(points, &lines, params)
    };
    let lines = if params.kind == FeatureKind::Corners {
        Vec::new()
    } else {
        lines
            .into_iter()
            .map(|s| {
                let first = points[s.ranges[0].start];
                let last = points[s.ranges.last().expect("a segment has points").end - 1];
                LineFeature {
                    line: s.line,
                    first,
                    last,
                    points: s.ranges.iter().map(|r| r.len()).sum(),
                }
            })
            .collect()
    };
    ScanFeatures { lines, corners }
}

/// The point sets Split & Merge starts from: the whole scan, or the runs between breakpoints.
/// A breakpoint is a beam without return between two points (nothing connects them), or two
/// adjacent returns farther apart than the adaptive distance r·sin Δφ / sin(λ − Δφ) + margin
/// (Borges & Aldon 2004).
fn point_sets(scan: &[ScanPoint], increment_rad: f64, params: &FeatureParams) -> Vec<Range<usize>> {
    if !params.breakpoints {
        return vec![0..scan.len()];
    }
    let lambda = params.breakpoint_lambda_deg.to_radians();
    let dphi = increment_rad.abs();
    let factor = if dphi < lambda { dphi.sin() / (lambda - dphi).sin() } else { f64::INFINITY };
    let mut sets = Vec::new();
    let mut start = 0;
    for i in 1..scan.len() {
        let (a, b) = (&scan[i - 1], &scan[i]);
        let missed_between = b.beam > a.beam + 1;
        if missed_between || a.p.distance(b.p) > a.range_m * factor + params.breakpoint_margin_m {
            sets.push(start..i);
            start = i;
        }
    }
    sets.push(start..scan.len());
    sets
}

/// A fitted line with the index ranges of its points (several after a merge).
#[derive(Debug, Clone)]
struct Segment {
    line: Line,
    ranges: Vec<Range<usize>>,
}

/// [FT] Table 4.3, recursive: appends the accepted segments of `set` in scan order.
fn split_and_merge(
    points: &[Point2],
    set: Range<usize>,
    params: &FeatureParams,
    out: &mut Vec<Segment>,
) {
    let n = set.len();
    if n == 0 || n < params.pmin as usize {
        return; // |S| < Pmin
    }
    let (a, b) = (points[set.start], points[set.end - 1]);
    if a.distance(b) < params.lmin_m {
        return; // Length(R) < Lmin — checked before the split test
    }
    // Pmax = argmax dist(P, R) over the interior points (the end points lie on the chord).
    let chord = Line::through(a, b);
    let farthest = (set.start + 1..set.end - 1)
        .map(|i| (i, chord.distance(points[i])))
        .max_by(|x, y| x.1.total_cmp(&y.1));
    match farthest {
        Some((i, d)) if d >= params.dmax_m => {
            // Split at Pmax; it belongs to both halves (the usual IEPF convention).
            split_and_merge(points, set.start..i + 1, params, out);
            split_and_merge(points, i..set.end, params, out);
        }
        _ => out.push(Segment {
            line: fit(points, std::slice::from_ref(&set), params.split_fit),
            ranges: vec![set],
        }),
    }
}

/// [FT] Table 4.4: each line in turn absorbs every later line within (ρmax, θmax) of it.
fn merge_collinear(
    points: &[Point2],
    segments: Vec<Segment>,
    params: &FeatureParams,
) -> Vec<Segment> {
    let mut remaining: Vec<Option<Segment>> = segments.into_iter().map(Some).collect();
    let mut out = Vec::new();
    for i in 0..remaining.len() {
        let Some(mut ri) = remaining[i].take() else { continue };
        let reference = ri.line;
        let mut merged = false;
        for slot in remaining.iter_mut().skip(i + 1) {
            if slot.as_ref().is_some_and(|rj| {
                reference.coincides(&rj.line, params.rho_max_m, params.theta_max_rad)
            }) {
                ri.ranges.extend(slot.take().expect("checked").ranges);
                merged = true;
            }
        }
        if merged {
            ri.ranges.sort_by_key(|r| r.start);
            ri.line = fit(points, &ri.ranges, params.merge_fit);
        }
        out.push(ri);
    }
    out
}

/// Fits a normalised line to the points in `ranges`.
fn fit(points: &[Point2], ranges: &[Range<usize>], how: LineFit) -> Line {
    match how {
        LineFit::Endpoints => Line::through(
            points[ranges[0].start],
            points[ranges.last().expect("non-empty").end - 1],
        ),
        LineFit::LeastSquares => {
            let pts = || ranges.iter().flat_map(|r| &points[r.clone()]);
            let n = pts().count() as f64;
            let (mx, my) = pts().fold((0.0, 0.0), |(x, y), p| (x + p.x / n, y + p.y / n));
            let (sxx, syy, sxy) = pts().fold((0.0, 0.0, 0.0), |(a, b, c), p| {
                let (dx, dy) = (p.x - mx, p.y - my);
                (a + dx * dx, b + dy * dy, c + dx * dy)
            });
            // Normal angle of the orthogonal-regression line (minimises Σ distance²).
            let alpha = 0.5 * (-2.0 * sxy).atan2(syy - sxx);
            Line::normalised(mx * alpha.cos() + my * alpha.sin(), alpha)
        }
    }
}

/// [FT] Table 4.2: real corners among the pairwise intersections of a scan's lines.
fn corners(points: &[Point2], lines: &[Segment], params: &FeatureParams) -> Vec<Point2> {
    let mut out = Vec::new();
    for (i, a) in lines.iter().enumerate() {
        for b in &lines[i + 1..] {
            // Angle between the (undirected) lines, in [0, π/2].
            let d = wrap_angle(a.line.theta - b.line.theta).abs();
            if d.min(std::f64::consts::PI - d) < params.corner_min_angle_rad {
                continue;
            }
            let Some(p) = a.line.intersection(&b.line) else { continue };
            let near = |s: &Segment| {
                s.ranges
                    .iter()
                    .flat_map(|r| &points[r.clone()])
                    .any(|q| q.distance(p) <= params.emax_m)
            };
            if near(a) && near(b) {
                out.push(p);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn description_names_the_thresholds() {
        let f = FeatureParams { dmax_m: 0.025, pmin: 15, ..FeatureParams::default() };
        let d = f.describe();
        assert!(d.contains("Dmax = 0.025 m") && d.contains("Pmin = 15"), "{d}");
    }

    /// Points every `step` m along a → b (both ends included).
    fn wall(a: (f64, f64), b: (f64, f64), step: f64) -> Vec<Point2> {
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let n = (len / step).round() as usize;
        (0..=n)
            .map(|i| i as f64 / n as f64)
            .map(|t| Point2::new(a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1)))
            .collect()
    }

    /// Test points as consecutive beams of a 1° laser.
    fn beams(points: &[Point2]) -> Vec<ScanPoint> {
        points
            .iter()
            .enumerate()
            .map(|(beam, p)| ScanPoint { p: *p, range_m: p.x.hypot(p.y), beam })
            .collect()
    }

    fn extract_points(points: &[Point2], params: &FeatureParams) -> ScanFeatures {
        super::extract_points(&beams(points), 1f64.to_radians(), params)
    }

    /// The faithful [FT] variant (no breakpoints) with small thresholds for short test walls.
    fn params() -> FeatureParams {
        FeatureParams { pmin: 5, lmin_m: 0.5, breakpoints: false, ..FeatureParams::default() }
    }

    #[test]
    fn an_l_shaped_wall_gives_two_lines_and_their_corner() {
        // wall along x = 3 from y = −2 to 2, then along y = 2 back to x = 0
        let mut pts = wall((3.0, -2.0), (3.0, 2.0), 0.05);
        pts.extend(wall((3.0, 2.0), (0.0, 2.0), 0.05).into_iter().skip(1));
        let f = extract_points(&pts, &params());
        assert_eq!(f.lines.len(), 2, "{:?}", f.lines);
        let l0 = f.lines[0].line;
        assert!((l0.rho - 3.0).abs() < 1e-9 && l0.theta.abs() < 1e-9, "{l0:?}");
        let l1 = f.lines[1].line;
        assert!(
            (l1.rho - 2.0).abs() < 1e-9 && (l1.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-9,
            "{l1:?}"
        );
        assert_eq!(f.corners.len(), 1);
        assert!(f.corners[0].distance(Point2::new(3.0, 2.0)) < 1e-9);
    }

    #[test]
    fn pmin_and_lmin_drop_short_sets_before_splitting() {
        let pts = wall((2.0, -0.3), (2.0, 0.3), 0.1); // 7 points, 0.6 m
        assert_eq!(
            extract_points(&pts, &FeatureParams { pmin: 8, lmin_m: 0.1, ..params() }).lines.len(),
            0
        );
        assert_eq!(
            extract_points(&pts, &FeatureParams { pmin: 3, lmin_m: 0.7, ..params() }).lines.len(),
            0
        );
        assert_eq!(
            extract_points(&pts, &FeatureParams { pmin: 3, lmin_m: 0.5, ..params() }).lines.len(),
            1
        );
        // Lmin is checked before the split test: a short *bent* set is dropped, not split
        let mut bent = wall((2.0, -0.2), (2.2, 0.0), 0.05);
        bent.extend(wall((2.2, 0.0), (2.0, 0.2), 0.05).into_iter().skip(1));
        assert!(
            extract_points(&bent, &FeatureParams { pmin: 3, lmin_m: 0.5, ..params() })
                .lines
                .is_empty()
        );
    }

    #[test]
    fn dmax_decides_whether_a_bend_is_split() {
        // a 4 m wall with a 3 cm kink in the middle
        let mut pts = wall((2.0, -2.0), (2.03, 0.0), 0.05);
        pts.extend(wall((2.03, 0.0), (2.0, 2.0), 0.05).into_iter().skip(1));
        let coarse = extract_points(&pts, &FeatureParams { dmax_m: 0.05, ..params() });
        let fine = extract_points(
            &pts,
            &FeatureParams { dmax_m: 0.01, theta_max_rad: 0.001, rho_max_m: 0.001, ..params() },
        );
        assert_eq!(coarse.lines.len(), 1);
        assert_eq!(fine.lines.len(), 2);
    }

    #[test]
    fn collinear_pieces_are_merged_across_a_gap() {
        // one wall seen in two pieces (an obstacle hides the middle), with points beyond the gap
        let mut pts = wall((3.0, -2.0), (3.0, -0.5), 0.05);
        pts.extend(wall((1.5, -0.3), (1.5, 0.3), 0.05)); // the obstacle
        pts.extend(wall((3.0, 0.5), (3.0, 2.0), 0.05));
        let f = extract_points(&pts, &params());
        let walls: Vec<_> = f.lines.iter().filter(|l| (l.line.rho - 3.0).abs() < 0.01).collect();
        assert_eq!(walls.len(), 1, "{:?}", f.lines);
        assert!(walls[0].points > 55);
    }

    #[test]
    fn parallel_lines_make_no_corner_and_emax_rejects_fictitious_ones() {
        // two parallel walls: no corner
        let mut pts = wall((3.0, -2.0), (3.0, 2.0), 0.05);
        pts.extend(wall((-3.0, 2.0), (-3.0, -2.0), 0.05));
        assert!(extract_points(&pts, &params()).corners.is_empty());
        // two perpendicular walls that do not meet: the intersection is 1 m from both
        let mut pts = wall((3.0, -2.0), (3.0, 1.0), 0.05);
        pts.extend(wall((2.0, 2.0), (-1.0, 2.0), 0.05));
        assert!(extract_points(&pts, &params()).corners.is_empty());
        assert_eq!(
            extract_points(&pts, &FeatureParams { emax_m: 1.5, ..params() }).corners.len(),
            1
        );
    }

    #[test]
    fn feature_kind_selects_the_output() {
        let mut pts = wall((3.0, -2.0), (3.0, 2.0), 0.05);
        pts.extend(wall((3.0, 2.0), (0.0, 2.0), 0.05).into_iter().skip(1));
        let lines = extract_points(&pts, &FeatureParams { kind: FeatureKind::Lines, ..params() });
        let corners =
            extract_points(&pts, &FeatureParams { kind: FeatureKind::Corners, ..params() });
        assert_eq!((lines.lines.len(), lines.corners.len()), (2, 0));
        assert_eq!((corners.lines.len(), corners.corners.len()), (0, 1));
    }

    #[test]
    fn least_squares_fit_recovers_a_noisy_line() {
        // points on ρ = 2, θ = 30° with alternating ±1 cm offsets
        let th = 30f64.to_radians();
        let pts: Vec<Point2> = (0..41)
            .map(|i| {
                let t = -1.0 + i as f64 * 0.05;
                let off = if i % 2 == 0 { 0.01 } else { -0.01 };
                Point2::new(
                    (2.0 + off) * th.cos() - t * th.sin(),
                    (2.0 + off) * th.sin() + t * th.cos(),
                )
            })
            .collect();
        let l = fit(&pts, &[0..pts.len()], LineFit::LeastSquares);
        assert!((l.rho - 2.0).abs() < 0.001 && (l.theta - th).abs() < 1e-3, "{l:?}");
    }

    #[test]
    fn breakpoints_keep_a_far_collinear_point_out_of_a_line() {
        // regression: a 1° laser at the origin sees a far wall x = 12 up to the 12.7 m range
        // limit, which it reaches at (12, 4.02) — on the extension of a near wall y = 4 (x from
        // 8 to 4), seen after eight beams without return. Without breakpoints the far point joins
        // the near wall's line, whose intersection with x = 12 then passes the Emax test as a
        // fictitious corner (what Lineamedia and Bigloop2 showed).
        let far: Vec<ScanPoint> = (0..=18)
            .map(|b| {
                let p = if b == 18 {
                    Point2::new(12.0, 4.02)
                } else {
                    Point2::new(12.0, 12.0 * (b as f64).to_radians().tan())
                };
                ScanPoint { p, range_m: p.x.hypot(p.y), beam: b }
            })
            .collect();
        let near = (27..=45).map(|b| {
            let p = Point2::new(4.0 / (b as f64).to_radians().tan(), 4.0);
            ScanPoint { p, range_m: p.x.hypot(p.y), beam: b }
        });
        let pts: Vec<ScanPoint> = far.into_iter().chain(near).collect();
        let faithful = super::extract_points(&pts, 1f64.to_radians(), &params());
        assert_eq!(faithful.corners.len(), 1, "the artefact exists without breakpoints");
        let with = super::extract_points(
            &pts,
            1f64.to_radians(),
            &FeatureParams { breakpoints: true, ..params() },
        );
        assert!(with.corners.is_empty(), "{:?}", with.corners);
        assert_eq!(with.lines.len(), 2);
    }

    #[test]
    fn breakpoints_do_not_cut_a_continuous_wall_but_do_cut_a_jump() {
        // a wall at 5 m sampled every degree is one point set
        let wall_5m: Vec<Point2> =
            (-30..=30).map(|d| Point2::new(5.0, 5.0 * (d as f64).to_radians().tan())).collect();
        assert_eq!(
            point_sets(&beams(&wall_5m), 1f64.to_radians(), &FeatureParams::default()).len(),
            1
        );
        // adjacent beams that land 1 m apart in depth are on different surfaces
        let mut jump = wall_5m.clone();
        jump.extend((31..=40).map(|d| Point2::new(6.0, 6.0 * (d as f64).to_radians().tan())));
        assert_eq!(
            point_sets(&beams(&jump), 1f64.to_radians(), &FeatureParams::default()).len(),
            2
        );
    }
}
