//! What landmark filters observe: a world's sensor data → per-step lists of [`Observation`]s with
//! their measurement covariance R, whatever the source:
//! - laser worlds: line and corner features extracted from each scan ([FT] Ch. 4), R from the
//!   filter's stated line/corner noise;
//! - point-landmark worlds and datasets: range-bearing readings, R from the sensor's noise model
//!   at the measured range, and the true landmark index (for known association).

use super::fastslam::models::Model;
use super::SlamError;
use crate::features::{self, FeatureParams, ScanFeatures};
use crate::world::point_sensor::UNKNOWN_LANDMARK;
use crate::world::World;
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
}

impl<'a> Cursor<'a> {
    pub fn new(stream: &'a [StepObservations]) -> Self {
        Self { next: stream.iter().peekable(), z: Vec::new() }
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
        &self.z
    }
}

/// Which of a world's sensors a landmark filter reads.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a> {
    /// Laser scans → line and corner features; R = `line_r` for lines (ρ, θ) and for corners
    /// (range, bearing) ([FT]'s single laser covariance).
    LaserFeatures { features: &'a FeatureParams, line_r: Matrix2<f64> },
    /// The point-landmark sensor with its stated noise model.
    Points,
}

/// Every step's observations, in step order (steps without a reading are absent).
pub fn stream(world: &World, source: Source<'_>) -> Result<Vec<StepObservations>, SlamError> {
    match source {
        Source::LaserFeatures { features: params, line_r } => {
            let geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
            Ok(world.scans.iter().map(|scan| StepObservations { step: scan.step, observations: from_features(&features::extract(scan, &geometry, params), line_r) }).collect())
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
                        .map(|o| Observation { model: Model::Point, z: Vector2::new(o.range_m, o.bearing_rad), r: noise.covariance(o.range_m), landmark: (o.landmark != UNKNOWN_LANDMARK).then_some(o.landmark) })
                        .collect(),
                })
                .collect())
        }
    }
}

/// A scan's features as observations: lines first, then corners as range and bearing (Eq. 7.21).
pub fn from_features(f: &ScanFeatures, line_r: Matrix2<f64>) -> Vec<Observation> {
    let lines = f.lines.iter().map(|l| Observation { model: Model::Line, z: Vector2::new(l.line.rho, l.line.theta), r: line_r, landmark: None });
    let corners = f.corners.iter().map(|c| Observation { model: Model::Point, z: Vector2::new(c.x.hypot(c.y), c.y.atan2(c.x)), r: line_r, landmark: None });
    lines.chain(corners).collect()
}
