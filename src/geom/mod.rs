//! Planar geometry shared by every layer: poses on SE(2), angle wrapping, wall segments, infinite
//! lines in Hessian normal form (ρ, θ) and ray casting. Pure: no IO, no randomness.

use serde::{Deserialize, Serialize};
use std::f64::consts::{PI, TAU};

/// Wraps an angle to (−π, π]. Angles already in range (nearly all of them) pass untouched.
pub fn wrap_angle(a: f64) -> f64 {
    if a > -PI && a <= PI {
        return a;
    }
    let w = a - TAU * (a / TAU).round(); // now in [−π, π]
    if w <= -PI {
        w + TAU
    } else if w > PI {
        w - TAU
    } else {
        w
    }
}

/// A 2-D point [m].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Point2 {
    pub x: f64,
    pub y: f64,
}

impl Point2 {
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }
    pub fn distance(self, other: Point2) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }
}

/// A robot pose (x [m], y [m], θ [rad]) — an element of SE(2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

impl Pose2 {
    pub const IDENTITY: Pose2 = Pose2 { x: 0.0, y: 0.0, theta: 0.0 };

    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    pub fn position(self) -> Point2 {
        Point2::new(self.x, self.y)
    }

    /// `self ⊕ delta`: applies a body-frame increment to this pose.
    pub fn compose(self, delta: Pose2) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2 {
            x: self.x + c * delta.x - s * delta.y,
            y: self.y + s * delta.x + c * delta.y,
            theta: wrap_angle(self.theta + delta.theta),
        }
    }

    /// `self ⊖ other`: the body-frame increment that takes `other` to `self`,
    /// so that `other.compose(self.relative_to(other)) == self`.
    pub fn relative_to(self, other: Pose2) -> Pose2 {
        let (s, c) = other.theta.sin_cos();
        let dx = self.x - other.x;
        let dy = self.y - other.y;
        Pose2 {
            x: c * dx + s * dy,
            y: -s * dx + c * dy,
            theta: wrap_angle(self.theta - other.theta),
        }
    }

    /// Maps a point from this pose's body frame to the world frame.
    pub fn transform_point(self, p: Point2) -> Point2 {
        let (s, c) = self.theta.sin_cos();
        Point2::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }

    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }
}

/// Body-frame increment of the unicycle (velocity) motion model over Δt:
/// the exact arc for constant (v, ω), with the straight-line limit for |ω| → 0.
/// Composing a pose with it is the deterministic part of [FT] Eq. 7.18:
/// x' = x − (v/ω) sin θ + (v/ω) sin(θ + ωΔt), y' = y + (v/ω) cos θ − (v/ω) cos(θ + ωΔt), θ' = θ + ωΔt.
pub fn unicycle_increment(v_mps: f64, omega_radps: f64, dt_s: f64) -> Pose2 {
    let dtheta = omega_radps * dt_s;
    if omega_radps.abs() < STRAIGHT_LINE_OMEGA_RADPS {
        // Straight-line limit of the arc ([FT] §10 gap "ω ≈ 0"): second-order accurate.
        let d = v_mps * dt_s;
        return Pose2::new(d * (0.5 * dtheta).cos(), d * (0.5 * dtheta).sin(), dtheta);
    }
    let r = v_mps / omega_radps;
    // 1 − cos(Δθ) = 2 sin²(Δθ/2): no cancellation for small turns.
    Pose2::new(r * dtheta.sin(), r * 2.0 * (0.5 * dtheta).sin().powi(2), dtheta)
}

/// Below this turn rate [rad/s] the arc formula loses precision (v/ω blows up) and the
/// straight-line limit is used instead ([FT] §10 suggests 1e-6).
pub const STRAIGHT_LINE_OMEGA_RADPS: f64 = 1e-6;

/// A wall segment between two points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    pub a: Point2,
    pub b: Point2,
}

impl Segment {
    pub const fn new(a: Point2, b: Point2) -> Self {
        Self { a, b }
    }

    pub fn length(&self) -> f64 {
        self.a.distance(self.b)
    }

    /// Unit direction a → b.
    pub fn direction(&self) -> (f64, f64) {
        let l = self.length();
        ((self.b.x - self.a.x) / l, (self.b.y - self.a.y) / l)
    }

    /// The infinite line through this segment, in normalised Hessian form.
    pub fn line(&self) -> Line {
        Line::through(self.a, self.b)
    }

    /// Euclidean distance from `p` to the closest point of the segment.
    pub fn distance_to_point(&self, p: Point2) -> f64 {
        let (vx, vy) = (self.b.x - self.a.x, self.b.y - self.a.y);
        let len2 = vx * vx + vy * vy;
        let t = if len2 > 0.0 {
            (((p.x - self.a.x) * vx + (p.y - self.a.y) * vy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        p.distance(Point2::new(self.a.x + t * vx, self.a.y + t * vy))
    }

    /// Distance along the ray from `origin` in direction (cos φ, sin φ) to this segment,
    /// if the ray hits it (endpoints included).
    pub fn ray_intersection(&self, origin: Point2, cos_phi: f64, sin_phi: f64) -> Option<f64> {
        // Solve origin + t·d = a + s·(b − a), t ≥ 0, s ∈ [0, 1] (Cramer's rule).
        let (ex, ey) = (self.b.x - self.a.x, self.b.y - self.a.y);
        let denom = cos_phi * ey - sin_phi * ex;
        if denom.abs() < PARALLEL_EPS {
            return None; // parallel (or degenerate): a grazing ray sees no wall surface
        }
        let (wx, wy) = (self.a.x - origin.x, self.a.y - origin.y);
        let t = (wx * ey - wy * ex) / denom;
        let s = (wx * sin_phi - wy * cos_phi) / denom;
        (t >= 0.0 && (0.0..=1.0).contains(&s)).then_some(t)
    }
}

/// Determinant magnitude below which a ray and a segment count as parallel.
const PARALLEL_EPS: f64 = 1e-12;

/// An infinite line ρ = x cos θ + y sin θ ([FT] Eq. 7.24), normalised to ρ ≥ 0, θ ∈ (−π, π].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Line {
    pub rho: f64,
    pub theta: f64,
}

impl Line {
    /// Normalises (ρ, θ): a negative ρ flips to (−ρ, θ + π) ([FT] §10 gap "line normalisation").
    pub fn normalised(rho: f64, theta: f64) -> Line {
        if rho < 0.0 {
            Line { rho: -rho, theta: wrap_angle(theta + PI) }
        } else {
            Line { rho, theta: wrap_angle(theta) }
        }
    }

    /// The foot of the perpendicular from the origin, (ρ cos θ, ρ sin θ) — the point [FT] Eqs.
    /// 10.1–10.2 use to compare lines.
    pub fn foot_point(&self) -> Point2 {
        Point2::new(self.rho * self.theta.cos(), self.rho * self.theta.sin())
    }

    /// The line through two distinct points.
    pub fn through(a: Point2, b: Point2) -> Line {
        // The normal (cos θ, sin θ) is perpendicular to b − a.
        let theta = (b.y - a.y).atan2(b.x - a.x) + PI / 2.0;
        Line::normalised(a.x * theta.cos() + a.y * theta.sin(), theta)
    }

    /// Perpendicular distance from `p` to the line.
    pub fn distance(&self, p: Point2) -> f64 {
        (p.x * self.theta.cos() + p.y * self.theta.sin() - self.rho).abs()
    }

    /// The intersection point, or `None` for parallel lines.
    pub fn intersection(&self, other: &Line) -> Option<Point2> {
        let (s1, c1) = self.theta.sin_cos();
        let (s2, c2) = other.theta.sin_cos();
        let det = c1 * s2 - s1 * c2; // sin(θ2 − θ1)
        (det.abs() > PARALLEL_EPS).then(|| {
            Point2::new(
                (self.rho * s2 - other.rho * s1) / det,
                (c1 * other.rho - c2 * self.rho) / det,
            )
        })
    }

    /// Whether two normalised lines coincide within the given tolerances.
    pub fn coincides(&self, other: &Line, rho_tol_m: f64, theta_tol_rad: f64) -> bool {
        (self.rho - other.rho).abs() <= rho_tol_m
            && wrap_angle(self.theta - other.theta).abs() <= theta_tol_rad
            // ρ ≈ 0 lines are ambiguous up to θ + π
            || (self.rho + other.rho) <= rho_tol_m
                && wrap_angle(self.theta - other.theta + PI).abs() <= theta_tol_rad
    }
}

/// Casts a ray against every segment and returns the nearest hit within `max_range_m`.
pub fn cast_ray(segments: &[Segment], origin: Point2, phi: f64, max_range_m: f64) -> Option<f64> {
    let (sin_phi, cos_phi) = phi.sin_cos();
    segments
        .iter()
        .filter_map(|s| s.ray_intersection(origin, cos_phi, sin_phi))
        .filter(|&t| t <= max_range_m)
        .min_by(f64::total_cmp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_range_and_identity() {
        for k in -20..=20 {
            let a = k as f64 * 0.37;
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} → {w}");
            assert!(
                ((a - w) / (2.0 * PI)).fract().abs() < 1e-9
                    || ((a - w) / (2.0 * PI)).fract().abs() > 1.0 - 1e-9
            );
        }
        assert_eq!(wrap_angle(PI), PI);
        assert_eq!(wrap_angle(-PI), PI);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
    }

    #[test]
    fn compose_and_relative_are_inverse() {
        let a = Pose2::new(1.0, -2.0, 2.5);
        let d = Pose2::new(0.3, 0.2, -0.4);
        let b = a.compose(d);
        let back = b.relative_to(a);
        assert!((back.x - d.x).abs() < 1e-12 && (back.y - d.y).abs() < 1e-12);
        assert!((back.theta - d.theta).abs() < 1e-12);
    }

    #[test]
    fn unicycle_arc_matches_velocity_model_equation() {
        // [FT] Eq. 7.18 written out in the world frame.
        let (v, w, dt) = (0.4, 0.7, 0.5);
        let p = Pose2::new(2.0, 1.0, 0.3);
        let q = p.compose(unicycle_increment(v, w, dt));
        let r = v / w;
        let x = p.x - r * p.theta.sin() + r * (p.theta + w * dt).sin();
        let y = p.y + r * p.theta.cos() - r * (p.theta + w * dt).cos();
        assert!((q.x - x).abs() < 1e-12 && (q.y - y).abs() < 1e-12);
        assert!((q.theta - (p.theta + w * dt)).abs() < 1e-12);
    }

    #[test]
    fn unicycle_straight_line_limit_is_continuous() {
        let straight = unicycle_increment(0.5, 0.0, 0.1);
        assert!((straight.x - 0.05).abs() < 1e-15 && straight.y == 0.0);
        // just below (straight-line branch) and just above (arc) the threshold agree
        let below = unicycle_increment(0.5, 0.999 * STRAIGHT_LINE_OMEGA_RADPS, 0.1);
        let above = unicycle_increment(0.5, 1.001 * STRAIGHT_LINE_OMEGA_RADPS, 0.1);
        // (y differs by the 0.2 % change of ω itself, ≈ 5e-12 m)
        assert!(
            (below.x - above.x).abs() < 1e-15 && (below.y - above.y).abs() < 1e-11,
            "{below:?} {above:?}"
        );
        // and a small turn is accurate: y = r(1 − cos Δθ) without cancellation
        let small = unicycle_increment(0.5, 1e-3, 0.1);
        let r = 0.5 / 1e-3;
        let dth = 1e-4f64;
        assert!((small.y - r * (dth.powi(2) / 2.0 - dth.powi(4) / 24.0)).abs() < 1e-18);
    }

    #[test]
    fn segment_lines_are_normalised_like_the_thesis_lists() {
        // [FT] §3.2: y = −1 is (1, −90°), x = −1 is (1, 180°), x = 19 is (19, 0°), y = 9 is (9, 90°).
        let cases = [
            ((-1.0, -1.0), (19.0, -1.0), 1.0, -90.0_f64),
            ((-1.0, 9.0), (-1.0, -1.0), 1.0, 180.0),
            ((19.0, -1.0), (19.0, 9.0), 19.0, 0.0),
            ((19.0, 9.0), (-1.0, 9.0), 9.0, 90.0),
        ];
        for ((ax, ay), (bx, by), rho, theta_deg) in cases {
            // either direction of travel gives the same line
            for seg in [
                Segment::new(Point2::new(ax, ay), Point2::new(bx, by)),
                Segment::new(Point2::new(bx, by), Point2::new(ax, ay)),
            ] {
                let l = seg.line();
                assert!((l.rho - rho).abs() < 1e-12, "{seg:?} → {l:?}");
                assert!(
                    wrap_angle(l.theta - theta_deg.to_radians()).abs() < 1e-12,
                    "{seg:?} → {l:?}"
                );
            }
        }
    }

    #[test]
    fn line_distance_and_intersection() {
        let l = Line::through(Point2::new(0.0, 2.0), Point2::new(4.0, 2.0)); // y = 2
        assert!((l.rho - 2.0).abs() < 1e-12 && (l.theta - PI / 2.0).abs() < 1e-12);
        assert!((l.distance(Point2::new(1.0, 5.0)) - 3.0).abs() < 1e-12);
        let m = Line::through(Point2::new(3.0, -1.0), Point2::new(3.0, 7.0)); // x = 3
        let p = l.intersection(&m).unwrap();
        assert!(p.distance(Point2::new(3.0, 2.0)) < 1e-12);
        assert_eq!(l.intersection(&Line::normalised(5.0, PI / 2.0)), None);
        // a line through the origin side: ρ stays ≥ 0 whatever the direction of travel
        let d = Line::through(Point2::new(1.0, -1.0), Point2::new(-1.0, 1.0));
        assert!(d.rho.abs() < 1e-12 && d.distance(Point2::new(2.0, -2.0)) < 1e-12);
    }

    #[test]
    fn ray_hits_nearest_wall() {
        let walls = [
            Segment::new(Point2::new(2.0, -1.0), Point2::new(2.0, 1.0)),
            Segment::new(Point2::new(5.0, -1.0), Point2::new(5.0, 1.0)),
        ];
        let hit = cast_ray(&walls, Point2::new(0.0, 0.0), 0.0, 8.0).unwrap();
        assert!((hit - 2.0).abs() < 1e-12);
        // 45°: hits x = 2 at y = 2 — outside the first wall, and x = 5 at y = 5 — outside too
        assert_eq!(cast_ray(&walls, Point2::new(0.0, 0.0), PI / 4.0, 8.0), None);
        // behind the robot: nothing
        assert_eq!(cast_ray(&walls, Point2::new(0.0, 0.0), PI, 8.0), None);
        // out of range
        assert_eq!(cast_ray(&walls, Point2::new(0.0, 0.0), 0.0, 1.5), None);
    }

    #[test]
    fn point_to_segment_distance() {
        let s = Segment::new(Point2::new(0.0, 0.0), Point2::new(4.0, 0.0));
        assert!((s.distance_to_point(Point2::new(2.0, 3.0)) - 3.0).abs() < 1e-12);
        assert!((s.distance_to_point(Point2::new(7.0, 4.0)) - 5.0).abs() < 1e-12);
    }
}
