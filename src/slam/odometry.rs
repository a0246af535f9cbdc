//! Odometry-only baseline (dead reckoning): World → Trace by composing the measured increments
//! from the known start pose. No sensor, no randomness. [FT] §11 claim 15: "an odometry-only map
//! is clearly wrong in every case" — the baseline every SLAM error is read against.

use super::Trace;
use crate::world::World;

pub const CODE_VERSION: &str = "odometry-1";

/// Integrates the odometry: x̂₀ = x₀ (both trajectories start at the same pose), x̂ₖ₊₁ = x̂ₖ ⊕ uₖ.
pub fn run(world: &World) -> Trace {
    let mut pose = world.truth[0];
    let mut estimate = Vec::with_capacity(world.odometry.len() + 1);
    estimate.push(pose);
    for delta in &world.odometry {
        pose = pose.compose(*delta);
        estimate.push(pose);
    }
    Trace { estimate, ..Trace::default() }
}

/// The odometry map: FastSLAM's mapping (extraction, ML association, landmark EKFs) along the
/// dead-reckoned path — one particle, no motion noise, so its pose is exactly the odometry.
pub fn run_with_map(
    world: &World,
    fastslam: &super::fastslam::FastSlamParams,
    features: &crate::features::FeatureParams,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Trace, super::SlamError> {
    let line_r =
        nalgebra::Matrix2::new(fastslam.obs_var_rho_m2, 0.0, 0.0, fastslam.obs_var_theta_rad2);
    run_with_map_on(
        world,
        fastslam,
        &super::observations::stream(
            world,
            super::observations::Source::LaserFeatures { features, line_r },
        )?,
        rng,
    )
}

/// [`run_with_map`] on an observation stream of laser features.
pub fn run_with_map_on(
    world: &World,
    fastslam: &super::fastslam::FastSlamParams,
    observations: &[super::observations::StepObservations],
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Trace, super::SlamError> {
    let params = super::fastslam::FastSlamParams {
        particles: 1,
        motion_x: 0.0,
        motion_y: 0.0,
        motion_theta: 0.0,
        ..fastslam.clone()
    };
    super::fastslam::run_on(world, &params, None, observations, true, rng)
}

/// The odometry map of a point-landmark world: one particle driven by the odometry alone.
pub fn run_with_point_map(
    world: &World,
    fastslam: &super::fastslam::FastSlamParams,
    observations: &[super::observations::StepObservations],
    rng: &mut rand_chacha::ChaCha8Rng,
) -> Result<Trace, super::SlamError> {
    let params = super::fastslam::FastSlamParams { particles: 1, ..fastslam.clone() };
    let still =
        super::motion::MotionModel::Pose { sigma_x_m: 0.0, sigma_y_m: 0.0, sigma_theta_rad: 0.0 };
    let mut trace =
        super::fastslam::run_on(world, &params, Some(&still), observations, false, rng)?;
    trace.pose_belief.clear(); // one particle has no spread: no NEES
    Ok(trace)
}
