//! What landmark filters observe: a world's sensor data → per-step lists of [`Observation`]s with
//! their measurement covariance R, whatever the source:
//! - laser worlds: line and corner features extracted from each scan ([FT] Ch. 4), R from the
//!   filter's stated line/corner noise;
//! - point-landmark worlds and datasets: range-bearing readings, R from the sensor's noise model
//!   at the measured range, and the true landmark index (for known association).

use super::SlamError;
use super::fastslam::models::Model;
use crate::features::{self, FeatureParams, ScanFeatures};
use crate::world::World;
use crate::world::point_sensor::UNKNOWN_LANDMARK;
use nalgebra::{Matrix2, Vector2};

/// One measurement of one landmark.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation {
    pub model: Model,
    /// Lines: (ρ', θ') in the robot frame; points: (range, bearing).
    pub z: Vector2<f64>,
    /// Measurement covariance R.
    pub r: Matrix2<f64>,
    /// The true landmark index when the sensor reports it (simulated point sensors, MRCLAM's
    /// barcodes): what "known association" uses.
    pub landmark: Option<usize>,
}

/// The observations of one odometry step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepObservations {
    pub step: usize,
    pub observations: Vec<Observation>,
}

/// Walks a step-ordered observation stream alongside the filter's steps: every filter reads its
/// observations the same way.
pub struct Cursor<'a> {
    next: std::iter::Peekable<std::slice::Iter<'a, StepObservations>>,
    z: Vec<Observation>,
    fuse_identities: bool,
}

impl<'a> Cursor<'a> {
    /// `known_association`: the filter associates by the sensor's identities, so several readings
    /// of one identity in a step are fused into one ([`fuse`]); otherwise each reading stays.
    pub fn new(stream: &'a [StepObservations], known_association: bool) -> Self {
        Self { next: stream.iter().peekable(), z: Vec::new(), fuse_identities: known_association }
    }

    /// The observations of step `k`: every entry for that step merged in stream order (a stream
    /// may hold several); entries of earlier steps not yet read (out of order) are skipped.
    pub fn at(&mut self, k: usize) -> &[Observation] {
        self.z.clear();
        while let Some(s) = self.next.next_if(|s| s.step <= k) {
            if s.step == k {
                self.z.extend_from_slice(&s.observations);
            }
        }
        if self.fuse_identities {
            fuse_repeated_identities(&mut self.z);
        }
        &self.z
    }
}

/// Replaces every group of readings of one identity (and model) by their fusion, in place, at the
/// group's first position.
fn fuse_repeated_identities(z: &mut Vec<Observation>) {
    let mut i = 0;
    while i < z.len() {
        if z[i].landmark.is_some() {
            let mut j = i + 1;
            while j < z.len() {
                if z[j].landmark == z[i].landmark && z[j].model == z[i].model {
                    if let Some(f) = fuse(&z[i], &z[j]) {
                        z[i] = f;
                        z.remove(j);
                        continue;
                    }
                }
                j += 1;
            }
        }
        i += 1;
    }
}

/// Two readings a, b of one landmark from one pose as one: both measure the same h(x, m), so
/// N(a; h, R_a)·N(b; h, R_b) = N(z̄; h, R̄)·N(b − a; 0, R_a + R_b) with R̄ = (R_a⁻¹ + R_b⁻¹)⁻¹ and
/// z̄ = a + R̄ R_b⁻¹ (b − a), exactly. The second factor depends on neither pose nor map — the same
/// for every particle — so a filter that sees z̄ once weighs and updates as with both readings,
/// and never creates one identity twice. b − a is taken in a's parameterisation (a line's
/// (ρ, θ) → (−ρ, θ + π) flip negates R_b's cross term). `None` when an R is singular.
pub fn fuse(a: &Observation, b: &Observation) -> Option<Observation> {
    let flipped = a.model == Model::Line
        && crate::geom::wrap_angle(b.z[1] - a.z[1]).abs() > std::f64::consts::FRAC_PI_2;
    let mut rb = b.r;
    if flipped {
        rb[(0, 1)] = -rb[(0, 1)];
        rb[(1, 0)] = -rb[(1, 0)];
    }
    let (ia, ib) = (a.r.try_inverse()?, rb.try_inverse()?);
    let r = (ia + ib).try_inverse()?;
    let mut r = 0.5 * (r + r.transpose());
    let mut z = a.z + r * ib * a.model.innovation(&b.z, &a.z);
    z[1] = crate::geom::wrap_angle(z[1]);
    a.model.normalise(&mut z, &mut r);
    (z.iter().chain(r.iter()).all(|v| v.is_finite())).then_some(Observation { z, r, ..*a })
}

/// Which of a world's sensors a landmark filter reads.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// Laser scans → line and corner features; R = `line_r` for lines (ρ, θ) and for corners
    /// (range, bearing) ([FT]'s single laser covariance).
    LaserFeatures { features: &'a FeatureParams, line_r: Matrix2<f64> },
    /// The features of every laser scan, already extracted ([`extract_all`]), in scan order.
    Extracted { features: &'a [ScanFeatures], line_r: Matrix2<f64> },
    /// The point-landmark sensor with its stated noise model.
    Points,
}

/// The features of every laser scan of `world`, in scan order ([FT] Ch. 4).
pub fn extract_all(world: &World, params: &FeatureParams) -> Result<Vec<ScanFeatures>, SlamError> {
    let geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
    Ok(world.scans.iter().map(|scan| features::extract(scan, &geometry, params)).collect())
}

/// Every step's observations, in step order (steps without a reading are absent).
pub fn stream(world: &World, source: Source<'_>) -> Result<Vec<StepObservations>, SlamError> {
    match source {
        Source::LaserFeatures { features: params, line_r } => {
            stream(world, Source::Extracted { features: &extract_all(world, params)?, line_r })
        }
        Source::Extracted { features, line_r } => {
            if features.len() != world.scans.len() {
                return Err(SlamError::MissingSensor("laser"));
            }
            Ok(world
                .scans
                .iter()
                .zip(features)
                .map(|(scan, f)| StepObservations {
                    step: scan.step,
                    observations: from_features(f, line_r),
                })
                .collect())
        }
        Source::Points => {
            let noise = world.point_noise.ok_or(SlamError::MissingSensor("landmark sensor"))?;
            Ok(world
                .point_scans
                .iter()
                .map(|scan| StepObservations {
                    step: scan.step,
                    observations: scan
                        .observations
                        .iter()
                        .map(|o| Observation {
                            model: Model::Point,
                            z: Vector2::new(o.range_m, o.bearing_rad),
                            r: noise.covariance(o.range_m),
                            landmark: (o.landmark != UNKNOWN_LANDMARK).then_some(o.landmark),
                        })
                        .collect(),
                })
                .collect())
        }
    }
}

/// A scan's features as observations: lines first, then corners as range and bearing (Eq. 7.21).
pub fn from_features(f: &ScanFeatures, line_r: Matrix2<f64>) -> Vec<Observation> {
    let lines = f.lines.iter().map(|l| Observation {
        model: Model::Line,
        z: Vector2::new(l.line.rho, l.line.theta),
        r: line_r,
        landmark: None,
    });
    let corners = f.corners.iter().map(|c| Observation {
        model: Model::Point,
        z: Vector2::new(c.x.hypot(c.y), c.y.atan2(c.x)),
        r: line_r,
        landmark: None,
    });
    lines.chain(corners).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two readings with equal R fuse to their mean with R/2; a line read across the ρ' = 0 flip
    /// fuses in the first reading's parameterisation; different identities stay apart.
    #[test]
    fn readings_of_one_identity_fuse_exactly() {
        let r = Matrix2::new(0.04, 0.0, 0.0, 0.01);
        let o = |z: [f64; 2], id| Observation {
            model: Model::Point,
            z: Vector2::new(z[0], z[1]),
            r,
            landmark: Some(id),
        };
        let f = fuse(&o([2.0, 0.1], 3), &o([2.2, 0.3], 3)).unwrap();
        assert!(
            (f.z - Vector2::new(2.1, 0.2)).norm() < 1e-12 && (f.r - r / 2.0).abs().max() < 1e-15
        );
        // bearings either side of ±π average across it
        let f = fuse(&o([2.0, 3.1], 3), &o([2.0, -3.1], 3)).unwrap();
        assert!((f.z[1].abs() - std::f64::consts::PI).abs() < 1e-9, "{}", f.z[1]);
        // a line (ρ, θ) and its flipped twin (−ρ, θ + π) are one reading
        let line = |rho: f64, theta: f64| Observation {
            model: Model::Line,
            z: Vector2::new(rho, theta),
            r,
            landmark: Some(1),
        };
        let f = fuse(&line(0.02, 0.5), &line(-0.04, 0.5 + std::f64::consts::PI)).unwrap();
        assert!((f.z - Vector2::new(0.03, 0.5)).norm() < 1e-12, "{}", f.z);

        let stream = [
            StepObservations { step: 4, observations: vec![o([2.0, 0.1], 3), o([5.0, 1.0], 7)] },
            StepObservations { step: 4, observations: vec![o([2.2, 0.3], 3)] },
        ];
        let fused = Cursor::new(&stream, true).at(4).to_vec();
        assert_eq!(fused.iter().map(|o| o.landmark).collect::<Vec<_>>(), [Some(3), Some(7)]);
        assert!((fused[0].z - Vector2::new(2.1, 0.2)).norm() < 1e-12);
        assert_eq!(
            Cursor::new(&stream, false).at(4).len(),
            3,
            "without known association every reading stays"
        );
    }
}
