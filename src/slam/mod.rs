//! SLAM algorithms: ([`World`](crate::world::World), filter RNG) → [`Trace`]. Each algorithm is
//! pure, reads only its own parameters, and declares the sensors it needs so the world simulates
//! nothing more.

pub mod fastslam;
pub mod motion;
pub mod observations;
pub mod odometry;

pub use fastslam::models;

use crate::geom::{Line, Point2, Pose2};
use serde::{Deserialize, Serialize};

/// The algorithms a study can list under `algorithms = [...]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlgorithmKind {
    /// Dead reckoning: integrate odometry, use no sensor ([FT] claim 15: the reference every SLAM
    /// result is compared against).
    Odometry,
    /// Dead reckoning plus landmark mapping along the odometry path: the "odometry map" of [FT]
    /// (FastSLAM's extraction, association and landmark EKFs with one particle and no motion
    /// noise).
    OdometryMap,
    /// FastSLAM 1.0 on laser line and corner landmarks ([FT] Table 6.3).
    Fastslam1,
}

/// Which simulated sensors an algorithm reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sensors {
    pub laser: bool,
    pub landmarks: bool,
}

impl Sensors {
    /// The sensors any of `algorithms` reads.
    pub fn union(algorithms: &[AlgorithmKind]) -> Sensors {
        algorithms.iter().fold(Sensors::default(), |a, k| Sensors { laser: a.laser || k.sensors().laser, landmarks: a.landmarks || k.sensors().landmarks })
    }
}

impl AlgorithmKind {
    pub const ALL: &'static [AlgorithmKind] = &[AlgorithmKind::Odometry, AlgorithmKind::OdometryMap, AlgorithmKind::Fastslam1];

    pub fn name(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => "odometry",
            AlgorithmKind::OdometryMap => "odometry_map",
            AlgorithmKind::Fastslam1 => "fastslam1",
        }
    }

    pub fn from_name(name: &str) -> Option<AlgorithmKind> {
        Self::ALL.iter().copied().find(|a| a.name() == name)
    }

    /// Human-readable name for reports.
    pub fn title(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => "Odometry only",
            AlgorithmKind::OdometryMap => "Odometry map",
            AlgorithmKind::Fastslam1 => "FastSLAM 1.0",
        }
    }

    /// Part of every run's content hash: bump when the algorithm's output changes.
    pub fn code_version(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => odometry::CODE_VERSION,
            AlgorithmKind::OdometryMap => ODOMETRY_MAP_CODE_VERSION,
            AlgorithmKind::Fastslam1 => fastslam::CODE_VERSION,
        }
    }

    pub fn sensors(self) -> Sensors {
        match self {
            AlgorithmKind::Odometry => Sensors::default(),
            AlgorithmKind::OdometryMap | AlgorithmKind::Fastslam1 => Sensors { laser: true, landmarks: false },
        }
    }

    /// The `[base]` sections holding this algorithm's own parameters (besides the world's).
    pub fn param_sections(self) -> &'static [&'static str] {
        match self {
            AlgorithmKind::Odometry => &[],
            AlgorithmKind::OdometryMap | AlgorithmKind::Fastslam1 => &["features", "fastslam"],
        }
    }

    /// Every `[base]` section a run of this algorithm reads: the clock and odometry, the sensors
    /// it uses, and its own sections.
    pub fn sections_read(self) -> Vec<&'static str> {
        let mut s = vec!["sim", "odometry"];
        if self.sensors().laser {
            s.push("laser");
        }
        if self.sensors().landmarks {
            s.push("landmark_sensor");
        }
        s.extend(self.param_sections());
        s
    }
}

/// The odometry map shares FastSLAM's code; its own version covers the one-particle setup.
pub const ODOMETRY_MAP_CODE_VERSION: &str = "odometry-map-1";

/// A landmark map in the world frame.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LandmarkMap {
    pub lines: Vec<Line>,
    pub corners: Vec<Point2>,
    /// Point landmarks (point-landmark worlds and datasets).
    pub points: Vec<Point2>,
    /// For each point landmark, the true landmark it was created from when the filter knew it
    /// (known association); `None` otherwise.
    pub point_ids: Vec<Option<usize>>,
}

/// What an algorithm produced.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// Pose estimate at every odometry step (same length as the world's truth).
    pub estimate: Vec<Pose2>,
    /// Singular matrices, all-zero weights, …: counted, never a panic.
    pub numerical_failures: u64,
    /// The final map, for algorithms that build one (FastSLAM: the best particle's).
    pub map: Option<LandmarkMap>,
    /// N̂eff at every step that weighted particles (`None` elsewhere); empty for non-particle
    /// algorithms.
    pub neff: Vec<Option<f64>>,
    /// How many times the particles were resampled.
    pub resamples: u64,
    /// Steps with an observation that weighted the particles.
    pub weighted_steps: u64,
    /// The filter's own pose covariance at every step (EKF: P_rr; particle filters: the
    /// weighted spread of the particles), for NEES. Empty when the algorithm has none.
    pub pose_cov: Vec<Option<nalgebra::Matrix3<f64>>>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SlamError {
    #[error("the world has no {0} data, which this algorithm needs")]
    MissingSensor(&'static str),
}
