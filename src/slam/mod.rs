//! SLAM algorithms: ([`World`](crate::world::World), filter RNG) → [`Trace`]. Each algorithm is
//! pure, reads only its own parameters, and declares the sensors it needs so the world simulates
//! nothing more.

pub mod ekf;
pub mod fastslam;
pub mod fastslam2;
pub mod motion;
pub mod observations;
pub mod odometry;

pub use fastslam::models;

use crate::geom::{Line, Point2, Pose2};
use crate::scanmatch::search::Optimizer;
use crate::world::WorldKind;
use serde::{Deserialize, Serialize};

/// The algorithms a study can list under `algorithms = [...]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum AlgorithmKind {
    /// Dead reckoning: integrate odometry, use no sensor ([FT] claim 15: the reference every SLAM
    /// result is compared against).
    Odometry,
    /// Dead reckoning plus landmark mapping along the odometry path: the "odometry map" of [FT]
    /// (FastSLAM's extraction, association and landmark EKFs with one particle and no motion
    /// noise).
    OdometryMap,
    /// FastSLAM 1.0 ([FT] Table 6.3): line and corner landmarks from the laser, or point
    /// landmarks ([PF]).
    Fastslam1,
    /// FastSLAM 2.0 (Montemerlo et al. 2003): the pose proposal includes the observations.
    Fastslam2,
    /// EKF-SLAM: one joint Gaussian over the pose and every landmark ([EV]; Thrun et al. 2005).
    EkfSlam,
    /// Polar Scan Matching (Diosi & Kleeman) on scans prepared by the study's
    /// `[scan_matching.segmentation]` ([EP]'s "Diosi": PSM on segmented scans).
    Psm,
    /// PSM with its own preprocessing heuristics, whatever the study's segmentation ([EP]
    /// Table 4's "Diosi Original").
    PsmOriginal,
    /// E-PSM's alternating orientation/position search ([EP] §5.3.1).
    Epsm,
    /// The brute-force reference: a translation grid with E-PSM's orientation search ([EP] §6.1).
    BruteForce,
    /// Simultaneous (x, y, θ) search with one of NLopt's optimisers ([EP] §5.3.2); listed by the
    /// optimiser's name (`crs2`, `direct_l`, …).
    PoseSearch(Optimizer),
}

impl Serialize for AlgorithmKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for AlgorithmKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        AlgorithmKind::from_name(&name).ok_or_else(|| {
            let known: Vec<&str> = AlgorithmKind::ALL.iter().map(|a| a.name()).collect();
            serde::de::Error::custom(format!(
                "unknown algorithm `{name}`, expected one of: {}",
                known.join(", ")
            ))
        })
    }
}

/// Which simulated sensors an algorithm reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sensors {
    pub laser: bool,
    pub landmarks: bool,
}

impl Sensors {
    /// The sensors any of `algorithms` reads in any of the world kinds `kinds`.
    pub fn union(algorithms: &[AlgorithmKind], kinds: &[WorldKind]) -> Sensors {
        let mut out = Sensors::default();
        for a in algorithms {
            for &k in kinds {
                out.laser |= a.sensors(k).laser;
                out.landmarks |= a.sensors(k).landmarks;
            }
        }
        out
    }
}

/// Code version of TNEWTON runs: the scan matchers' plus the deterministic heap fill.
pub const TNEWTON_CODE_VERSION: &str = "scanmatch-3+heap-fill-1";

impl AlgorithmKind {
    pub const ALL: &'static [AlgorithmKind] = &[
        AlgorithmKind::Odometry,
        AlgorithmKind::OdometryMap,
        AlgorithmKind::Fastslam1,
        AlgorithmKind::Fastslam2,
        AlgorithmKind::EkfSlam,
        AlgorithmKind::Psm,
        AlgorithmKind::PsmOriginal,
        AlgorithmKind::Epsm,
        AlgorithmKind::BruteForce,
        AlgorithmKind::PoseSearch(Optimizer::DirectL),
        AlgorithmKind::PoseSearch(Optimizer::Crs2),
        AlgorithmKind::PoseSearch(Optimizer::Isres),
        AlgorithmKind::PoseSearch(Optimizer::MlslLds),
        AlgorithmKind::PoseSearch(Optimizer::Cobyla),
        AlgorithmKind::PoseSearch(Optimizer::Bobyqa),
        AlgorithmKind::PoseSearch(Optimizer::Sbplx),
        AlgorithmKind::PoseSearch(Optimizer::Slsqp),
        AlgorithmKind::PoseSearch(Optimizer::Lbfgs),
        AlgorithmKind::PoseSearch(Optimizer::Tnewton),
        AlgorithmKind::PoseSearch(Optimizer::Var2),
    ];

    pub fn name(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => "odometry",
            AlgorithmKind::OdometryMap => "odometry_map",
            AlgorithmKind::Fastslam1 => "fastslam1",
            AlgorithmKind::Fastslam2 => "fastslam2",
            AlgorithmKind::EkfSlam => "ekf_slam",
            AlgorithmKind::Psm => "psm",
            AlgorithmKind::PsmOriginal => "psm_original",
            AlgorithmKind::Epsm => "epsm",
            AlgorithmKind::BruteForce => "brute_force",
            AlgorithmKind::PoseSearch(o) => o.name(),
        }
    }

    /// Whether this is a scan matcher (laser odometry by matching consecutive scans).
    pub fn is_scan_matcher(self) -> bool {
        matches!(
            self,
            AlgorithmKind::Psm
                | AlgorithmKind::PsmOriginal
                | AlgorithmKind::Epsm
                | AlgorithmKind::BruteForce
                | AlgorithmKind::PoseSearch(_)
        )
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
            AlgorithmKind::Fastslam2 => "FastSLAM 2.0",
            AlgorithmKind::EkfSlam => "EKF-SLAM",
            AlgorithmKind::Psm => "PSM",
            AlgorithmKind::PsmOriginal => "PSM (own heuristics)",
            AlgorithmKind::Epsm => "E-PSM",
            AlgorithmKind::BruteForce => "Brute force",
            AlgorithmKind::PoseSearch(o) => o.title(),
        }
    }

    /// Part of every run's content hash: bump when the algorithm's output changes.
    pub fn code_version(self) -> &'static str {
        match self {
            AlgorithmKind::Odometry => odometry::CODE_VERSION,
            AlgorithmKind::OdometryMap => ODOMETRY_MAP_CODE_VERSION,
            AlgorithmKind::Fastslam1 => fastslam::CODE_VERSION,
            AlgorithmKind::Fastslam2 => fastslam2::CODE_VERSION,
            AlgorithmKind::EkfSlam => ekf::CODE_VERSION,
            // TNEWTON's results depended on heap garbage before the fixed malloc fill (src/main.rs)
            AlgorithmKind::PoseSearch(crate::scanmatch::search::Optimizer::Tnewton) => {
                TNEWTON_CODE_VERSION
            }
            _ => crate::scanmatch::track::CODE_VERSION,
        }
    }

    /// The sensors this algorithm reads in a world of `kind`.
    pub fn sensors(self, kind: WorldKind) -> Sensors {
        match (self, kind) {
            (AlgorithmKind::Odometry, _) => Sensors::default(),
            (a, _) if a.is_scan_matcher() => Sensors { laser: true, landmarks: false },
            (_, WorldKind::Laser) => Sensors { laser: true, landmarks: false },
            (_, WorldKind::Points) => Sensors { laser: false, landmarks: true },
        }
    }

    /// The `[base]` sections holding this algorithm's own parameters (besides the world's).
    pub fn param_sections(self, kind: WorldKind) -> &'static [&'static str] {
        match (self, kind) {
            (AlgorithmKind::Odometry, _) => &[],
            // [FT]'s FastSLAM keeps its own motion noise on laser worlds
            (AlgorithmKind::OdometryMap | AlgorithmKind::Fastslam1, WorldKind::Laser) => {
                &["features", "fastslam"]
            }
            (AlgorithmKind::OdometryMap, WorldKind::Points) => &["fastslam"],
            (AlgorithmKind::Fastslam1, WorldKind::Points) => &["fastslam", "motion_model"],
            (AlgorithmKind::Fastslam2, WorldKind::Laser) => {
                &["features", "fastslam", "motion_model"]
            }
            (AlgorithmKind::Fastslam2, WorldKind::Points) => &["fastslam", "motion_model"],
            (AlgorithmKind::EkfSlam, WorldKind::Laser) => &["features", "ekf", "motion_model"],
            (AlgorithmKind::EkfSlam, WorldKind::Points) => &["ekf", "motion_model"],
            (AlgorithmKind::Psm | AlgorithmKind::PsmOriginal, _) => &["scan_matching", "psm"],
            (AlgorithmKind::Epsm, _) => &["scan_matching", "epsm"],
            (AlgorithmKind::BruteForce, _) => &["scan_matching", "brute_force"],
            (AlgorithmKind::PoseSearch(_), _) => &["scan_matching", "pose_search"],
        }
    }

    /// Every `[base]` section a run of this algorithm reads in a world of `kind`: the clock and
    /// odometry, the sensors it uses, and its own sections.
    pub fn sections_read(self, kind: WorldKind) -> Vec<&'static str> {
        let mut s = vec!["sim", "odometry"];
        if self.sensors(kind).laser {
            s.push("laser");
        }
        if self.sensors(kind).landmarks {
            s.push("landmark_sensor");
        }
        s.extend(self.param_sections(kind));
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
    /// The filter's own pose belief at every step, (mean, covariance), for NEES — EKF: (x̂, P_rr);
    /// particle filters: the weighted mean pose (circular mean heading) and the weighted spread
    /// about it. `estimate` may differ (FastSLAM reports its best particle). Empty when the
    /// algorithm has none.
    pub pose_belief: Vec<Option<(Pose2, nalgebra::Matrix3<f64>)>>,
    /// EKF-SLAM: the Frobenius norm of the pose rows of the Kalman gain, ‖K_pose‖, of every
    /// successful update in order — how far the observations move the pose ([EV] C004-4). Empty
    /// for the other algorithms.
    pub kalman_gain: Vec<f64>,
    /// Scan matchers: one record per match, in order. Empty for the other algorithms.
    pub matches: Vec<crate::scanmatch::track::MatchRecord>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SlamError {
    #[error("the world has no {0} data, which this algorithm needs")]
    MissingSensor(&'static str),
    #[error("known data association needs landmark identities, which this sensor does not report")]
    NoIdentities,
    #[error(
        "a particle's map grew past {limit} landmarks at step {step} (fastslam.max_landmarks): the map explodes, the run is stopped"
    )]
    LandmarkCap { limit: u32, step: usize },
}
