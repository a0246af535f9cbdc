//! SLAM algorithms: ([`World`](crate::world::World), filter RNG) → [`Trace`]. Each algorithm is
//! pure, reads only its own parameters, and declares the sensors it needs so the world simulates
//! nothing more.

pub mod odometry;

use crate::geom::Pose2;
use serde::{Deserialize, Serialize};

/// The algorithms a study can list under `algorithms = [...]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AlgorithmKind {
    /// Dead reckoning: integrate odometry, use no sensor ([FT] claim 15: the reference every SLAM
    /// result is compared against).
    Odometry,
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
    pub const ALL: &'static [AlgorithmKind] = &[AlgorithmKind::Odometry];

    pub fn name(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => "odometry",
        }
    }

    pub fn from_name(name: &str) -> Option<AlgorithmKind> {
        Self::ALL.iter().copied().find(|a| a.name() == name)
    }

    /// Human-readable name for reports.
    pub fn title(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => "Odometry only",
        }
    }

    /// Part of every run's content hash: bump when the algorithm's output changes.
    pub fn code_version(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => odometry::CODE_VERSION,
        }
    }

    pub fn sensors(self) -> Sensors {
        match self {
            AlgorithmKind::Odometry => Sensors::default(),
        }
    }

    /// The `[base]` sections holding this algorithm's own parameters (besides the world's).
    pub fn param_sections(self) -> &'static [&'static str] {
        match self {
            AlgorithmKind::Odometry => &[],
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

/// What an algorithm produced: its pose estimate at every odometry step (same length as the
/// world's truth) and counters of numerical trouble it met and survived.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    pub estimate: Vec<Pose2>,
    /// Singular matrices, all-zero weights, …: counted, never a panic.
    pub numerical_failures: u64,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SlamError {
    #[error("the world has no {0} data, which this algorithm needs")]
    MissingSensor(&'static str),
}
