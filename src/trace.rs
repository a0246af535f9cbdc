//! What every algorithm returns, whatever its family: the pose estimate at every step with its
//! diagnostics ([`Trace`]), the landmark map it built ([`LandmarkMap`]), the scan matches it made
//! ([`MatchRecord`]), and why it stopped ([`SlamError`]). A leaf over `geom`: the filters in
//! `slam/`, the scan matchers in `scanmatch/`, the algorithm registry in `algo/` and the stores
//! all read these types, and none of them owns them.

use crate::geom::{Line, Point2, Pose2};

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
    pub matches: Vec<MatchRecord>,
    /// The laser pose graph: one record per loop closure it kept, in order (its consecutive
    /// matches are in `matches`); `None` for the other algorithms.
    pub loop_closures: Option<Vec<MatchRecord>>,
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
    /// An external program failed: it exited with an error, ran too long or wrote what cannot be
    /// read (`why` says which, with the tail of its standard error).
    #[error("external algorithm `{name}`: {why}")]
    External { name: String, why: String },
}

/// The stop reason of a match an external program made (`algo::external`): slamlab scores its
/// estimate but counts no evaluations for it.
pub const EXTERNAL_STOP: &str = "external";

/// One match, as stored per match.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchRecord {
    /// Step of the reference scan and of the current scan.
    pub reference_step: usize,
    pub current_step: usize,
    /// True, initial-guess and estimated pose of the current scan in the reference frame.
    pub truth: Pose2,
    pub initial: Pose2,
    pub estimate: Pose2,
    /// f at the estimate and at the initial guess [cm²].
    pub f: f64,
    pub f_initial: f64,
    pub pairs: u32,
    pub iterations: u32,
    pub evaluations: u64,
    /// The f-check kept the initial guess.
    pub fallback: bool,
    /// Why the matcher stopped.
    pub stop: String,
    /// Wall time of the match [s] (not deterministic: kept out of metrics and reports).
    pub time_s: f64,
}

impl MatchRecord {
    /// Estimate minus truth in the reference frame: (ax [m], ay [m], aθ [rad]).
    pub fn error(&self) -> (f64, f64, f64) {
        (
            self.estimate.x - self.truth.x,
            self.estimate.y - self.truth.y,
            crate::geom::wrap_angle(self.estimate.theta - self.truth.theta),
        )
    }

    /// Whether the matcher produced a usable estimate.
    pub fn succeeded(&self) -> bool {
        self.estimate.is_finite() && self.f.is_finite()
    }
}
