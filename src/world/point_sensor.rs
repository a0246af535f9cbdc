//! Range-bearing sensor for point landmarks ([FT] Eq. 7.21; the [PF]/[EV] worlds): every landmark
//! within the range limits and the field of view, and not hidden behind a wall, is observed with
//! Gaussian range and bearing noise, tagged with its true index (for known-association filters
//! and for scoring).

use super::RangeNoise;
use crate::config::{Checks, Violation};
use crate::geom::{Point2, Pose2, Segment, wrap_angle};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Bump when the point-landmark sensor's output changes for the same inputs. It is part of the
/// content hash of the runs that read this sensor only (laser runs are unaffected). points-3:
/// stored point maps carry the landmark identities of known association.
pub const POINT_SENSOR_CODE_VERSION: &str = "points-3";

/// `[base.landmark_sensor]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PointSensorParams {
    /// Observation range d_max [m]: landmarks farther away are not seen ([PF] §V).
    pub max_range_m: f64,
    /// Landmarks nearer than this [m] are not seen ([EV]: the webcam ranges from 0.13 m).
    pub min_range_m: f64,
    /// Field of view [deg], centred on the heading.
    pub fov_deg: f64,
    /// Observations per second [Hz]; 1/(rate·Δt) must be a whole number of odometry steps.
    pub rate_hz: f64,
    /// Range noise model: `constant` (σ), `proportional` (σ₁·r) or `quadratic` (σ₁·r²).
    pub range_noise: RangeNoise,
    /// σr [m] for `constant`; σ₁, the σ at 1 m, for `proportional` [m/m] and `quadratic` [1/m].
    pub range_sigma_m: f64,
    /// σb [rad].
    pub bearing_sigma_rad: f64,
    /// Walls hide the landmarks behind them ([PF] §V: "not occluded by walls").
    pub occlusion: bool,
    /// At most this many observations per reading, the nearest first ([EV]: 5 per frame);
    /// 0 = no limit.
    pub max_observations: u32,
}

impl Default for PointSensorParams {
    fn default() -> Self {
        Self {
            max_range_m: 8.0,
            min_range_m: 0.0,
            fov_deg: 360.0,
            rate_hz: 5.0,
            range_noise: RangeNoise::Constant,
            range_sigma_m: 0.1,
            bearing_sigma_rad: 1f64.to_radians(),
            occlusion: true,
            max_observations: 0,
        }
    }
}

impl PointSensorParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.positive("max_range_m", self.max_range_m);
        c.non_negative("min_range_m", self.min_range_m);
        c.require(!(self.min_range_m >= self.max_range_m), "min_range_m", || {
            format!("must be below max_range_m = {}, got {}", self.max_range_m, self.min_range_m)
        });
        c.in_range("fov_deg", self.fov_deg, f64::MIN_POSITIVE, 360.0);
        c.positive("rate_hz", self.rate_hz);
        c.non_negative("range_sigma_m", self.range_sigma_m);
        c.non_negative("bearing_sigma_rad", self.bearing_sigma_rad);
        c.finish()
    }

    /// The report's sentence on the landmark sensor: range limits, field of view, rate,
    /// occlusion, observation cap and noise.
    pub fn describe(&self) -> String {
        format!(
            "Landmark sensor: range-bearing to point landmarks from {} to {} m in a {}° field of view at {} Hz{}{}; range noise {}{} σ = {} m, σb = {} rad; the filters are told this model, at the measured range.",
            self.min_range_m,
            self.max_range_m,
            self.fov_deg,
            self.rate_hz,
            if self.occlusion { ", hidden by walls" } else { "" },
            if self.max_observations > 0 {
                format!(", at most {} per reading (the nearest)", self.max_observations)
            } else {
                String::new()
            },
            self.range_noise.describe(),
            if self.range_noise == RangeNoise::Constant { "," } else { ":" },
            self.range_sigma_m,
            self.bearing_sigma_rad
        )
    }

    /// The noise model filters are told.
    pub fn noise(&self) -> PointNoise {
        PointNoise {
            range_noise: self.range_noise,
            range_sigma_m: self.range_sigma_m,
            bearing_sigma_rad: self.bearing_sigma_rad,
        }
    }

    /// Observes `landmarks` from `pose`. Two standard normals are drawn for every landmark,
    /// visible or not, so each landmark's noise is the same draw at every sweep point.
    pub fn observe(
        &self,
        landmarks: &[Point2],
        walls: &[Segment],
        pose: Pose2,
        step: usize,
        rng: &mut ChaCha8Rng,
    ) -> PointScan {
        let half_fov = self.fov_deg.to_radians() / 2.0;
        let mut seen: Vec<(f64, PointObservation)> = landmarks
            .iter()
            .enumerate()
            .filter_map(|(i, m)| {
                let (zr, zb): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
                let r = pose.position().distance(*m);
                let b = wrap_angle((m.y - pose.y).atan2(m.x - pose.x) - pose.theta); // Eq. 7.21
                let visible = r <= self.max_range_m
                    && r >= self.min_range_m
                    && b.abs() <= half_fov
                    && !(self.occlusion && hidden(walls, pose.position(), *m));
                visible.then(|| {
                    let o = PointObservation {
                        landmark: i,
                        range_m: (r + self.range_noise.sigma(self.range_sigma_m, r) * zr).max(0.0),
                        bearing_rad: wrap_angle(b + self.bearing_sigma_rad * zb),
                    };
                    (r, o)
                })
            })
            .collect();
        if self.max_observations > 0 && seen.len() > self.max_observations as usize {
            // the nearest ones (stable on ties: landmark order)
            seen.sort_by(|a, b| a.0.total_cmp(&b.0));
            seen.truncate(self.max_observations as usize);
            seen.sort_by_key(|(_, o)| o.landmark);
        }
        PointScan { step, observations: seen.into_iter().map(|(_, o)| o).collect() }
    }
}

/// Whether a wall crosses the sight line from `from` to `to` (a landmark on a wall's end is not
/// hidden by that wall: only crossings strictly between the two points count).
fn hidden(walls: &[Segment], from: Point2, to: Point2) -> bool {
    let d = to.distance(from);
    if d == 0.0 {
        return false;
    }
    let (c, s) = ((to.x - from.x) / d, (to.y - from.y) / d);
    walls.iter().any(|w| {
        w.ray_intersection(from, c, s)
            .is_some_and(|t| t > OCCLUSION_EPS_M && t < d - OCCLUSION_EPS_M)
    })
}

/// Landmarks closer than this [m] to a wall along the sight line are not hidden by it (a
/// landmark mounted on a wall is seen).
const OCCLUSION_EPS_M: f64 = 1e-6;

/// A range-bearing sensor's noise: R(r) = diag(σ(r)², σb²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointNoise {
    pub range_noise: RangeNoise,
    pub range_sigma_m: f64,
    pub bearing_sigma_rad: f64,
}

impl PointNoise {
    /// R for a measurement at `range_m` (filters evaluate it at the measured range, the only
    /// one they know).
    pub fn covariance(&self, range_m: f64) -> nalgebra::Matrix2<f64> {
        let sr = self.range_noise.sigma(self.range_sigma_m, range_m);
        nalgebra::Matrix2::new(sr * sr, 0.0, 0.0, self.bearing_sigma_rad * self.bearing_sigma_rad)
    }
}

/// `PointObservation::landmark` of a sensor that cannot tell landmarks apart (Victoria Park's
/// trees): never a valid index into the map's points, so known association must refuse it.
pub const UNKNOWN_LANDMARK: usize = usize::MAX;

/// A range-bearing measurement of landmark `landmark` (index into the map's point list, or
/// [`UNKNOWN_LANDMARK`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointObservation {
    pub landmark: usize,
    pub range_m: f64,
    pub bearing_rad: f64,
}

/// All landmarks seen at odometry step `step`.
#[derive(Debug, Clone, PartialEq)]
pub struct PointScan {
    pub step: usize,
    pub observations: Vec<PointObservation>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn range_and_field_of_view_gate_visibility() {
        let params = PointSensorParams {
            max_range_m: 5.0,
            fov_deg: 180.0,
            range_sigma_m: 0.0,
            bearing_sigma_rad: 0.0,
            ..Default::default()
        };
        let lms = [
            Point2::new(3.0, 0.0),
            Point2::new(0.0, 4.0),
            Point2::new(-2.0, 0.0),
            Point2::new(6.0, 0.0),
        ];
        let scan = params.observe(&lms, &[], Pose2::IDENTITY, 0, &mut ChaCha8Rng::seed_from_u64(1));
        let seen: Vec<usize> = scan.observations.iter().map(|o| o.landmark).collect();
        assert_eq!(seen, vec![0, 1]); // behind (2) and too far (3) are not seen
        assert!((scan.observations[1].bearing_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((scan.observations[1].range_m - 4.0).abs() < 1e-12);
    }

    #[test]
    fn noise_has_the_stated_spread() {
        let params =
            PointSensorParams { range_sigma_m: 0.2, bearing_sigma_rad: 0.05, ..Default::default() };
        let lm = [Point2::new(3.0, 4.0)];
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let n = 10_000;
        let (mut er, mut eb) = (0.0, 0.0);
        for _ in 0..n {
            let o = params.observe(&lm, &[], Pose2::IDENTITY, 0, &mut rng).observations[0];
            er += (o.range_m - 5.0).powi(2);
            eb += (o.bearing_rad - 4f64.atan2(3.0)).powi(2);
        }
        assert!(((er / n as f64).sqrt() - 0.2).abs() < 0.006);
        assert!(((eb / n as f64).sqrt() - 0.05).abs() < 0.0015);
    }

    #[test]
    fn walls_hide_landmarks_and_min_range_and_count_limit_apply() {
        let params = PointSensorParams {
            range_sigma_m: 0.0,
            bearing_sigma_rad: 0.0,
            min_range_m: 0.5,
            ..Default::default()
        };
        let lms = [
            Point2::new(3.0, 0.0),
            Point2::new(0.0, 3.0),
            Point2::new(0.3, 0.0),
            Point2::new(2.0, 1.0),
        ];
        let wall = [Segment::new(Point2::new(2.0, -1.0), Point2::new(2.0, 0.5))];
        let scan =
            params.observe(&lms, &wall, Pose2::IDENTITY, 0, &mut ChaCha8Rng::seed_from_u64(1));
        let seen: Vec<usize> = scan.observations.iter().map(|o| o.landmark).collect();
        assert_eq!(seen, vec![1, 3]); // 0 behind the wall, 2 too close; 3 is beyond the wall's end
        let no_occlusion = PointSensorParams { occlusion: false, max_observations: 2, ..params };
        let scan = no_occlusion.observe(
            &lms,
            &wall,
            Pose2::IDENTITY,
            0,
            &mut ChaCha8Rng::seed_from_u64(1),
        );
        let seen: Vec<usize> = scan.observations.iter().map(|o| o.landmark).collect();
        // the two nearest of 0, 1, 3 (3.0, 3.0, 2.24 m): 3, then the 0/1 tie goes to the first
        assert_eq!(seen, vec![0, 3]);
    }

    #[test]
    fn describe_names_limits_cap_and_noise() {
        let p = PointSensorParams {
            min_range_m: 0.13,
            max_range_m: 4.0,
            fov_deg: 60.0,
            rate_hz: 2.0,
            max_observations: 5,
            range_sigma_m: 0.05,
            bearing_sigma_rad: 0.02,
            ..Default::default()
        };
        let s = p.describe();
        assert!(s.contains("from 0.13 to 4 m in a 60° field of view at 2 Hz, hidden by walls, at most 5 per reading (the nearest); range noise constant, σ = 0.05 m, σb = 0.02 rad"), "{s}");
        let s = PointSensorParams { occlusion: false, range_noise: RangeNoise::Quadratic, ..p }
            .describe();
        assert!(
            s.contains("at 2 Hz, at most 5")
                && s.contains("range noise quadratic in range (stereo), at 1 m: σ = 0.05 m"),
            "{s}"
        );
    }
}
