//! Range-bearing sensor for point landmarks ([FT] Eq. 7.21; the [PF]/[EV] worlds): every landmark
//! within the maximum range and field of view is observed with Gaussian range and bearing noise,
//! tagged with its true index (for known-association filters and for scoring).

use super::RangeNoise;
use crate::config::{Checks, Violation};
use crate::geom::{wrap_angle, Point2, Pose2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// `[base.landmark_sensor]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PointSensorParams {
    /// Observation range d_max [m]: landmarks farther away are not seen.
    pub max_range_m: f64,
    /// Field of view [deg], centred on the heading.
    pub fov_deg: f64,
    /// Observations per second [Hz]; 1/(rate·Δt) must be a whole number of odometry steps.
    pub rate_hz: f64,
    /// Range noise model: `constant` (σ) or `proportional` (σ·r).
    pub range_noise: RangeNoise,
    /// σr [m] for `constant`; σ at 1 m [m/m] for `proportional`.
    pub range_sigma_m: f64,
    /// σb [rad].
    pub bearing_sigma_rad: f64,
}

impl Default for PointSensorParams {
    fn default() -> Self {
        Self { max_range_m: 8.0, fov_deg: 360.0, rate_hz: 5.0, range_noise: RangeNoise::Constant, range_sigma_m: 0.1, bearing_sigma_rad: 1f64.to_radians() }
    }
}

impl PointSensorParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.positive("max_range_m", self.max_range_m);
        c.in_range("fov_deg", self.fov_deg, f64::MIN_POSITIVE, 360.0);
        c.positive("rate_hz", self.rate_hz);
        c.non_negative("range_sigma_m", self.range_sigma_m);
        c.non_negative("bearing_sigma_rad", self.bearing_sigma_rad);
        c.finish()
    }

    /// Observes `landmarks` from `pose`. Two standard normals are drawn for every landmark,
    /// visible or not, so each landmark's noise is the same draw at every sweep point.
    pub fn observe(&self, landmarks: &[Point2], pose: Pose2, step: usize, rng: &mut ChaCha8Rng) -> PointScan {
        let half_fov = self.fov_deg.to_radians() / 2.0;
        let observations = landmarks
            .iter()
            .enumerate()
            .filter_map(|(i, m)| {
                let (zr, zb): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
                let r = pose.position().distance(*m);
                let b = wrap_angle((m.y - pose.y).atan2(m.x - pose.x) - pose.theta); // Eq. 7.21
                (r <= self.max_range_m && b.abs() <= half_fov).then(|| PointObservation {
                    landmark: i,
                    range_m: (r + self.range_noise.sigma(self.range_sigma_m, r) * zr).max(0.0),
                    bearing_rad: wrap_angle(b + self.bearing_sigma_rad * zb),
                })
            })
            .collect();
        PointScan { step, observations }
    }
}

/// A range-bearing measurement of landmark `landmark` (index into the map's point list).
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
        let params = PointSensorParams { max_range_m: 5.0, fov_deg: 180.0, range_sigma_m: 0.0, bearing_sigma_rad: 0.0, ..Default::default() };
        let lms = [Point2::new(3.0, 0.0), Point2::new(0.0, 4.0), Point2::new(-2.0, 0.0), Point2::new(6.0, 0.0)];
        let scan = params.observe(&lms, Pose2::IDENTITY, 0, &mut ChaCha8Rng::seed_from_u64(1));
        let seen: Vec<usize> = scan.observations.iter().map(|o| o.landmark).collect();
        assert_eq!(seen, vec![0, 1]); // behind (2) and too far (3) are not seen
        assert!((scan.observations[1].bearing_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((scan.observations[1].range_m - 4.0).abs() < 1e-12);
    }

    #[test]
    fn noise_has_the_stated_spread() {
        let params = PointSensorParams { range_sigma_m: 0.2, bearing_sigma_rad: 0.05, ..Default::default() };
        let lm = [Point2::new(3.0, 4.0)];
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let n = 10_000;
        let (mut er, mut eb) = (0.0, 0.0);
        for _ in 0..n {
            let o = params.observe(&lm, Pose2::IDENTITY, 0, &mut rng).observations[0];
            er += (o.range_m - 5.0).powi(2);
            eb += (o.bearing_rad - 4f64.atan2(3.0)).powi(2);
        }
        assert!(((er / n as f64).sqrt() - 0.2).abs() < 0.006);
        assert!(((eb / n as f64).sqrt() - 0.05).abs() < 0.0015);
    }
}
