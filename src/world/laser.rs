//! 2-D laser range finder: ray casting from the true pose against the walls, with a field of view,
//! angular resolution, maximum range, scan rate and range noise (constant σ, or σ proportional to
//! range given as "σ at 1 m" as in [EP]). Mounted at the robot's centre, facing forward.

use super::RangeNoise;
use crate::config::{Checks, Violation};
use crate::geom::{Point2, Pose2, Segment, wrap_angle};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;
use std::fmt::Write;

/// `[base.laser]`. Defaults fill [FT] §10's gaps for a SICK LMS-200 as simulated by Stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct LaserParams {
    /// Field of view [deg], centred on the heading (LMS-200: 180°).
    pub fov_deg: f64,
    /// Angle between beams [deg] (LMS-200: 0.25/0.5/1°). [FT]'s Pmin depends on it.
    pub resolution_deg: f64,
    /// Maximum range [m] ([FT]: 8 m implied); beams with no wall within it return nothing.
    pub max_range_m: f64,
    /// Scans per second [Hz]; 1/(rate·Δt) must be a whole number of odometry steps.
    pub rate_hz: f64,
    /// Range noise model: `constant` (σ), `proportional` (σ₁·r) or `quadratic` (σ₁·r²).
    pub range_noise: RangeNoise,
    /// σ [m] for `constant`; σ₁, the σ at 1 m, for `proportional` [m/m] and `quadratic` [1/m].
    pub range_sigma_m: f64,
    /// Thickness [m] of the walls as the laser sees them: solid bars around the map's (zero-width)
    /// centrelines. [FT]'s Stage maps were bitmaps with walls 2–3 px thick (≈ 5 cm), while its
    /// reference landmarks are the centrelines — a bias the thesis puts at 7–14 cm. 0 = exact.
    pub wall_thickness_m: f64,
    /// The same thickness in pixels of the map's source bitmap (the map file's `bitmap_m_per_px`):
    /// [FT] §10.3.1 draws its walls 2–3 px thick at 1.8 cm/px (20 × 10 m maps) or 3.2 cm/px
    /// (Complex). 0 = use `wall_thickness_m`; set one of the two.
    pub wall_thickness_px: f64,
    /// Ranges are rounded to multiples of this [m] before noise: the raster of a grid ray tracer
    /// (Stage: 2 cm). 0 = exact.
    pub range_quantum_m: f64,
}

impl Default for LaserParams {
    fn default() -> Self {
        Self {
            fov_deg: 180.0,
            resolution_deg: 1.0,
            max_range_m: 8.0,
            rate_hz: 5.0,
            range_noise: RangeNoise::Constant,
            range_sigma_m: 0.01,
            wall_thickness_m: 0.0,
            wall_thickness_px: 0.0,
            range_quantum_m: 0.0,
        }
    }
}

/// The beams of one scan: bearing of beam i is `angle_min_rad + i·angle_increment_rad` (robot frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LaserGeometry {
    pub angle_min_rad: f64,
    pub angle_increment_rad: f64,
    pub beams: usize,
    pub max_range_m: f64,
}

impl LaserGeometry {
    pub fn bearing(&self, beam: usize) -> f64 {
        self.angle_min_rad + beam as f64 * self.angle_increment_rad
    }
}

/// One scan taken at the pose of odometry step `step`; `None` = no return within range.
#[derive(Debug, Clone, PartialEq)]
pub struct Scan {
    pub step: usize,
    pub ranges_m: Vec<Option<f64>>,
}

/// `scans.txt` of a world's laser scans: one scan a line,
/// `step n_beams angle_min_rad angle_increment_rad r_0 … r_{n−1}` (`inf` = no return), reals in
/// Rust's shortest round-trip form (`slamlab export-scans`, external algorithms).
pub fn scans_text(geometry: &LaserGeometry, scans: &[Scan]) -> String {
    let mut s = String::from(
        "# step n_beams angle_min_rad angle_increment_rad ranges_m (inf = no return)\n",
    );
    for scan in scans {
        let _ = write!(
            s,
            "{} {} {} {}",
            scan.step,
            scan.ranges_m.len(),
            geometry.angle_min_rad,
            geometry.angle_increment_rad
        );
        for r in &scan.ranges_m {
            match r {
                Some(r) => {
                    let _ = write!(s, " {r}");
                }
                None => s.push_str(" inf"),
            }
        }
        s.push('\n');
    }
    s
}

/// Finest angular resolution [deg] accepted (0.01° = 36 000 beams per turn; real scanners stop
/// near 0.1°): bounds the memory of a scan.
const MIN_RESOLUTION_DEG: f64 = 0.01;

/// Thickest walls [m] and coarsest range raster [m] accepted (beyond, a map is no longer the map).
const MAX_WALL_THICKNESS_M: f64 = 0.5;
const MAX_RANGE_QUANTUM_M: f64 = 0.5;
/// Thickest walls accepted in bitmap pixels.
const MAX_WALL_THICKNESS_PX: f64 = 20.0;

/// Relative tolerance for "a whole number" in FOV/resolution and scan-period checks.
const WHOLE_NUMBER_TOL: f64 = 1e-9;

impl LaserParams {
    /// The report's sentence on the simulated laser: field of view, resolution, beams, range,
    /// rate and range noise.
    pub fn describe(&self) -> String {
        format!(
            "Laser: ray casting from the robot centre against the exact wall segments; {}° field of view at {}° resolution ({} beams), {} m maximum range, {} Hz, range noise {} σ = {} m.",
            self.fov_deg,
            self.resolution_deg,
            self.geometry().beams,
            self.max_range_m,
            self.rate_hz,
            self.range_noise.describe(),
            self.range_sigma_m
        )
    }

    /// The report's sentence on the Stage-like artefacts (wall thickness, range raster), `None`
    /// when both are off.
    pub fn describe_artefacts(&self) -> Option<String> {
        let walls = if self.wall_thickness_px > 0.0 {
            format!(
                "{} px of each map's source bitmap (its bitmap_m_per_px)",
                self.wall_thickness_px
            )
        } else {
            format!("{} m", self.wall_thickness_m)
        };
        (self.wall_thickness_m > 0.0 || self.wall_thickness_px > 0.0 || self.range_quantum_m > 0.0).then(|| {
            format!(
                "Stage-like laser artefacts: walls seen as {walls} thick bars around the map's centrelines (the ground truth), ranges rounded to a {} m raster.",
                self.range_quantum_m
            )
        })
    }

    /// The wall thickness [m] on a map whose source bitmap has `bitmap_m_per_px` (`None`: the map
    /// states none, an error only when the thickness is given in pixels).
    pub fn wall_thickness_on(&self, bitmap_m_per_px: Option<f64>) -> Option<f64> {
        if self.wall_thickness_px > 0.0 {
            bitmap_m_per_px.map(|s| self.wall_thickness_px * s)
        } else {
            Some(self.wall_thickness_m)
        }
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.in_range("fov_deg", self.fov_deg, f64::MIN_POSITIVE, 360.0);
        c.in_range("resolution_deg", self.resolution_deg, MIN_RESOLUTION_DEG, 360.0);
        c.positive("max_range_m", self.max_range_m);
        c.positive("rate_hz", self.rate_hz);
        c.non_negative("range_sigma_m", self.range_sigma_m);
        c.in_range("wall_thickness_m", self.wall_thickness_m, 0.0, MAX_WALL_THICKNESS_M);
        c.in_range("range_quantum_m", self.range_quantum_m, 0.0, MAX_RANGE_QUANTUM_M);
        c.in_range("wall_thickness_px", self.wall_thickness_px, 0.0, MAX_WALL_THICKNESS_PX);
        c.require(
            !(self.wall_thickness_px > 0.0 && self.wall_thickness_m > 0.0),
            "wall_thickness_px",
            || {
                format!(
                    "set wall_thickness_m ({}) or wall_thickness_px ({}), not both",
                    self.wall_thickness_m, self.wall_thickness_px
                )
            },
        );
        if self.fov_deg > 0.0 && self.resolution_deg > 0.0 {
            let n = self.fov_deg / self.resolution_deg;
            c.require(
                (n - n.round()).abs() < WHOLE_NUMBER_TOL * n.max(1.0),
                "resolution_deg",
                || {
                    format!(
                        "must divide fov_deg = {} into a whole number of intervals, got {}",
                        self.fov_deg, self.resolution_deg
                    )
                },
            );
        }
        c.finish()
    }

    /// The surfaces the laser sees: the walls themselves, or, with a thickness [m], the outlines
    /// of bars around them (extended by half the thickness at both ends, so corners close).
    pub fn surfaces(thickness_m: f64, walls: &[Segment]) -> Vec<Segment> {
        if thickness_m <= 0.0 {
            return walls.to_vec();
        }
        let h = thickness_m / 2.0;
        walls
            .iter()
            .flat_map(|w| {
                let (dx, dy) = w.direction();
                let (nx, ny) = (-dy * h, dx * h);
                let a = Point2::new(w.a.x - dx * h, w.a.y - dy * h);
                let b = Point2::new(w.b.x + dx * h, w.b.y + dy * h);
                let c = [
                    Point2::new(a.x + nx, a.y + ny),
                    Point2::new(b.x + nx, b.y + ny),
                    Point2::new(b.x - nx, b.y - ny),
                    Point2::new(a.x - nx, a.y - ny),
                ];
                [
                    Segment::new(c[0], c[1]),
                    Segment::new(c[1], c[2]),
                    Segment::new(c[2], c[3]),
                    Segment::new(c[3], c[0]),
                ]
            })
            .collect()
    }

    pub fn geometry(&self) -> LaserGeometry {
        let intervals = (self.fov_deg / self.resolution_deg).round() as usize;
        // A full circle would repeat its first beam at +180°.
        let beams = if self.fov_deg >= 360.0 { intervals } else { intervals + 1 };
        LaserGeometry {
            angle_min_rad: -self.fov_deg.to_radians() / 2.0,
            angle_increment_rad: self.resolution_deg.to_radians(),
            beams,
            max_range_m: self.max_range_m,
        }
    }

    /// One scan from `pose`. A standard normal is drawn for every beam, hit or not, so the
    /// noise of beam i is the same draw at every sweep point.
    pub fn scan(
        &self,
        geometry: &LaserGeometry,
        walls: &[Segment],
        pose: Pose2,
        step: usize,
        rng: &mut ChaCha8Rng,
    ) -> Scan {
        let hits = cast_beams(geometry, walls, pose);
        let ranges_m = hits
            .into_iter()
            .map(|hit| {
                let z: f64 = rng.sample(StandardNormal);
                hit.map(|r| {
                    if self.range_quantum_m > 0.0 {
                        (r / self.range_quantum_m).round() * self.range_quantum_m
                    } else {
                        r
                    }
                })
                .map(|r| (r + self.range_noise.sigma(self.range_sigma_m, r) * z).max(0.0))
            })
            .collect();
        Scan { step, ranges_m }
    }
}

/// The nearest hit within range of every beam (no noise): the same as casting every beam
/// against every wall ([`cast_ray`]), but each wall in range is tested only against the beams
/// inside the angle it spans from the pose (plus one beam of margin) — identical results.
pub fn cast_beams(geometry: &LaserGeometry, walls: &[Segment], pose: Pose2) -> Vec<Option<f64>> {
    let origin = pose.position();
    let trig: Vec<(f64, f64)> =
        (0..geometry.beams).map(|i| (pose.theta + geometry.bearing(i)).sin_cos()).collect();
    let mut best = vec![f64::INFINITY; geometry.beams];
    let inc = geometry.angle_increment_rad;
    for w in walls.iter().filter(|w| w.distance_to_point(origin) <= geometry.max_range_m) {
        // Bearings of the end points relative to the heading; the wall spans the shorter arc.
        let bearing = |p: Point2| wrap_angle((p.y - origin.y).atan2(p.x - origin.x) - pose.theta);
        let (ba, bb) = (bearing(w.a), bearing(w.b));
        let span = wrap_angle(bb - ba);
        let (lo, hi) = if span >= 0.0 { (ba, ba + span) } else { (bb, bb - span) };
        // The arc can cross ±π: try it shifted by a turn either way.
        for shift in [-TAU, 0.0, TAU] {
            let first = ((lo + shift - geometry.angle_min_rad) / inc).floor() - 1.0;
            let last = ((hi + shift - geometry.angle_min_rad) / inc).ceil() + 1.0;
            if last < 0.0 || first >= geometry.beams as f64 {
                continue;
            }
            let (i0, i1) = (first.max(0.0) as usize, (last as usize).min(geometry.beams - 1));
            for i in i0..=i1 {
                let (sin_phi, cos_phi) = trig[i];
                if let Some(t) = w.ray_intersection(origin, cos_phi, sin_phi)
                    && t <= geometry.max_range_m
                    && t < best[i]
                {
                    best[i] = t;
                }
            }
        }
    }
    best.into_iter().map(|t| t.is_finite().then_some(t)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Point2;
    use rand::SeedableRng;

    fn room() -> Vec<Segment> {
        let p = |x, y| Point2::new(x, y);
        vec![
            Segment::new(p(-1.0, -1.0), p(19.0, -1.0)),
            Segment::new(p(19.0, -1.0), p(19.0, 9.0)),
            Segment::new(p(19.0, 9.0), p(-1.0, 9.0)),
            Segment::new(p(-1.0, 9.0), p(-1.0, -1.0)),
        ]
    }

    #[test]
    fn noise_free_ranges_are_exact() {
        let params =
            LaserParams { range_sigma_m: 0.0, max_range_m: 30.0, ..LaserParams::default() };
        let g = params.geometry();
        assert_eq!(g.beams, 181);
        let scan = params.scan(
            &g,
            &room(),
            Pose2::new(0.0, 0.0, 0.0),
            0,
            &mut ChaCha8Rng::seed_from_u64(1),
        );
        // beam 0 looks right (−90°): wall y = −1 at 1 m; beam 90 ahead: x = 19 at 19 m; beam 180 left: 9 m
        assert!((scan.ranges_m[0].unwrap() - 1.0).abs() < 1e-12);
        assert!((scan.ranges_m[90].unwrap() - 19.0).abs() < 1e-12);
        assert!((scan.ranges_m[180].unwrap() - 9.0).abs() < 1e-12);
        // beam 45 (−45°): y = −1 reached at x = 1, range √2
        assert!((scan.ranges_m[45].unwrap() - 2f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn max_range_gives_no_return() {
        let params = LaserParams { range_sigma_m: 0.0, ..LaserParams::default() };
        let g = params.geometry();
        let scan = params.scan(
            &g,
            &room(),
            Pose2::new(0.0, 0.0, 0.0),
            0,
            &mut ChaCha8Rng::seed_from_u64(1),
        );
        assert_eq!(scan.ranges_m[90], None); // 19 m > 8 m
    }

    #[test]
    fn proportional_noise_scales_with_range() {
        // Beam 90 hits at 19 m and beam 0 at 1 m; σ at 1 m = 0.01 ⇒ σ(19 m) = 0.19 m.
        let params = LaserParams {
            max_range_m: 30.0,
            range_noise: RangeNoise::Proportional,
            range_sigma_m: 0.01,
            ..LaserParams::default()
        };
        let g = params.geometry();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 4000;
        let (mut near, mut far) = (0.0, 0.0);
        for _ in 0..n {
            let s = params.scan(&g, &room(), Pose2::IDENTITY, 0, &mut rng);
            near += (s.ranges_m[0].unwrap() - 1.0).powi(2);
            far += (s.ranges_m[90].unwrap() - 19.0).powi(2);
        }
        let (sn, sf) = ((near / n as f64).sqrt(), (far / n as f64).sqrt());
        assert!((sn - 0.01).abs() < 0.0008, "{sn}");
        assert!((sf - 0.19).abs() < 0.015, "{sf}");
    }

    #[test]
    fn thick_walls_are_seen_half_a_thickness_closer_and_ranges_can_be_quantised() {
        let thick = LaserParams {
            range_sigma_m: 0.0,
            max_range_m: 30.0,
            wall_thickness_m: 0.1,
            ..LaserParams::default()
        };
        let g = thick.geometry();
        let surfaces = LaserParams::surfaces(0.1, &room());
        assert_eq!(surfaces.len(), 16);
        let scan = thick.scan(&g, &surfaces, Pose2::IDENTITY, 0, &mut ChaCha8Rng::seed_from_u64(1));
        assert!((scan.ranges_m[0].unwrap() - 0.95).abs() < 1e-12);
        assert!((scan.ranges_m[90].unwrap() - 18.95).abs() < 1e-12);
        let quantised = LaserParams { range_quantum_m: 0.02, ..thick.clone() };
        let q = quantised.scan(
            &g,
            &surfaces,
            Pose2::new(0.0, 0.003, 0.0),
            0,
            &mut ChaCha8Rng::seed_from_u64(1),
        );
        let r = q.ranges_m[0].unwrap(); // true 0.953
        assert!((r / 0.02 - (r / 0.02).round()).abs() < 1e-9 && (r - 0.96).abs() < 1e-9, "{r}");
    }

    #[test]
    fn wall_major_casting_equals_casting_every_beam() {
        use crate::geom::cast_ray;
        let p = |x, y| Point2::new(x, y);
        let mut walls = LaserParams::surfaces(0.05, &room());
        walls.push(Segment::new(p(2.0, 2.0), p(8.0, 2.0)));
        walls.push(Segment::new(p(4.0, -0.5), p(4.0, 6.0)));
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for fov in [180.0, 270.0, 360.0] {
            let g = LaserParams {
                fov_deg: fov,
                resolution_deg: 0.5,
                max_range_m: 12.0,
                ..LaserParams::default()
            }
            .geometry();
            for _ in 0..300 {
                let pose = Pose2::new(
                    rng.random_range(-0.8..18.8),
                    rng.random_range(-0.8..8.8),
                    rng.random_range(-3.2..3.2),
                );
                let fast = cast_beams(&g, &walls, pose);
                for (i, f) in fast.iter().enumerate() {
                    assert_eq!(
                        *f,
                        cast_ray(&walls, pose.position(), pose.theta + g.bearing(i), g.max_range_m),
                        "fov {fov} beam {i} pose {pose:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn resolution_must_divide_fov() {
        let bad = LaserParams { resolution_deg: 0.7, ..LaserParams::default() };
        assert_eq!(bad.validate()[0].key, "resolution_deg");
        let full = LaserParams { fov_deg: 360.0, ..LaserParams::default() };
        assert_eq!(full.geometry().beams, 360);
    }

    #[test]
    fn describe_names_the_scan_geometry_and_noise() {
        let l = LaserParams {
            fov_deg: 240.0,
            resolution_deg: 0.5,
            max_range_m: 5.6,
            rate_hz: 10.0,
            range_noise: RangeNoise::Proportional,
            range_sigma_m: 0.02,
            ..LaserParams::default()
        };
        let s = l.describe();
        assert!(s.contains("240° field of view at 0.5° resolution (481 beams), 5.6 m maximum range, 10 Hz, range noise proportional to range, at 1 m σ = 0.02 m."), "{s}");
        assert_eq!(l.describe_artefacts(), None);
        let s = LaserParams { wall_thickness_m: 0.05, range_quantum_m: 0.02, ..l }
            .describe_artefacts()
            .unwrap();
        assert!(s.contains("0.05 m thick bars") && s.contains("a 0.02 m raster"), "{s}");
    }

    /// [FT]'s walls are 2–3 px of a bitmap whose scale differs per map: a thickness in pixels
    /// needs the map's scale, and one of the two thickness settings at most.
    #[test]
    fn wall_thickness_in_pixels_follows_the_map_scale() {
        let px = LaserParams { wall_thickness_px: 2.5, ..LaserParams::default() };
        assert_eq!(px.wall_thickness_on(Some(0.032)), Some(2.5 * 0.032));
        assert_eq!(px.wall_thickness_on(None), None);
        let m = LaserParams { wall_thickness_m: 0.05, ..LaserParams::default() };
        assert_eq!(m.wall_thickness_on(None), Some(0.05));
        let both = LaserParams { wall_thickness_m: 0.05, ..px.clone() };
        assert_eq!(both.validate()[0].key, "wall_thickness_px");
        assert!(px.describe_artefacts().unwrap().contains("2.5 px of each map's source bitmap"));
    }
}
