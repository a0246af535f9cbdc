//! The built-in estimators: dead reckoning, the odometry map, FastSLAM 1.0 and 2.0, EKF-SLAM.
//! Each delegates to its core in `slam/`; which observations it reads (laser features or point
//! landmarks) follows the world's kind.

use super::{Algorithm, Choice, Listing, Output, Role, RunInput, RunSize, Topic, Work};
use crate::params::Params;
use crate::scanmatch::track::Matcher;
use crate::slam::observations::{Source, StepObservations, stream};
use crate::slam::{self, ekf, fastslam, fastslam2, odometry};
use crate::trace::SlamError;
use crate::world::{Sensors, WorldKind};
use nalgebra::Matrix2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::borrow::Cow;

/// The odometry map shares FastSLAM's code; its own version covers the one-particle setup.
pub const ODOMETRY_MAP_CODE_VERSION: &str = "odometry-map-1";

/// Dead reckoning: integrate odometry, use no sensor ([FT] claim 15: the reference every SLAM
/// result is compared against).
pub struct Odometry;

/// Dead reckoning plus landmark mapping along the odometry path: the "odometry map" of [FT]
/// (FastSLAM's extraction, association and landmark EKFs with one particle and no motion noise).
pub struct OdometryMap;

/// FastSLAM 1.0 ([FT] Table 6.3): line and corner landmarks from the laser, or point landmarks
/// ([PF]).
pub struct Fastslam1;

/// FastSLAM 2.0 (Montemerlo et al. 2003): the pose proposal includes the observations.
pub struct Fastslam2;

/// EKF-SLAM: one joint Gaussian over the pose and every landmark ([EV]; Thrun et al. 2005).
pub struct EkfSlam;

/// The landmark sensor of a world of `kind`: the laser's features or the point sensor.
fn landmark_sensor(kind: WorldKind) -> Sensors {
    match kind {
        WorldKind::Laser => Sensors::LASER,
        WorldKind::Points => Sensors::LANDMARKS,
    }
}

fn sections(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

/// FastSLAM's covariance of line features (ρ, θ), which it also uses for corners.
fn fastslam_line_r(p: &Params) -> Matrix2<f64> {
    Matrix2::new(p.fastslam.obs_var_rho_m2, 0.0, 0.0, p.fastslam.obs_var_theta_rad2)
}

/// The observations of every step: the scans' features (extracted once per world) with
/// covariance `line_r` on a laser world, the point sensor's readings on a point world.
fn observations(
    input: &RunInput<'_>,
    line_r: Matrix2<f64>,
) -> Result<Vec<StepObservations>, SlamError> {
    match input.kind {
        WorldKind::Laser => {
            let features = (input.features)(&input.params.features)?;
            stream(input.world, Source::Extracted { features: &features, line_r })
        }
        WorldKind::Points => stream(input.world, Source::Points),
    }
}

/// A filter's work: extraction of every scan on a laser world, then updates × particles ×
/// landmarks (× 2 for a proposal that samples twice).
fn filter_work(size: &RunSize, particles: f64, proposal: f64) -> Work {
    let mut w = Work::default();
    if size.kind == WorldKind::Laser {
        w.extraction = size.scans * size.beams;
    }
    let filter = size.updates * particles * size.landmarks.max(1.0) * proposal;
    if size.kind == WorldKind::Laser {
        w.filter = filter;
    } else {
        w.filter_points = filter;
    }
    w
}

fn rng(input: &RunInput<'_>) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(input.seed)
}

fn estimate(trace: slam::Trace) -> Output {
    Output { trace, steps: None }
}

/// The sentences every FastSLAM variant shares: extraction and [FT]'s FastSLAM on laser worlds.
fn fastslam_on_lasers(p: &Params, study: &Listing<'_>) -> Vec<Choice> {
    if !study.has(WorldKind::Laser) {
        return Vec::new();
    }
    vec![
        Choice { topic: Topic::Features, text: p.features.describe() },
        Choice { topic: Topic::FastslamOnLasers, text: p.fastslam.describe_on_lasers() },
    ]
}

/// FastSLAM on point worlds and 2.0 share one sentence.
fn fastslam_on_points(p: &Params, study: &Listing<'_>) -> Choice {
    Choice {
        topic: Topic::FastslamOnPoints,
        text: p.fastslam.describe_on_points(study.lists("fastslam2")),
    }
}

fn motion_model(p: &Params) -> Choice {
    Choice { topic: Topic::MotionModel, text: p.motion_model.describe() }
}

impl Algorithm for Odometry {
    fn name(&self) -> &str {
        "odometry"
    }
    fn title(&self) -> &str {
        "Odometry only"
    }
    fn summary(&self) -> Cow<'_, str> {
        "dead reckoning: the odometry increments composed from the true start pose".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        odometry::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::Estimator
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::NONE
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        Vec::new()
    }
    fn describe(&self, _: &Params, _: &Listing<'_>) -> Vec<Choice> {
        // the world's odometry sentence says all there is
        Vec::new()
    }
    fn work(&self, _: &Params, _: &RunSize) -> Work {
        Work::default()
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        Ok(estimate(odometry::run(input.world)))
    }
}

impl Algorithm for OdometryMap {
    fn name(&self) -> &str {
        "odometry_map"
    }
    fn title(&self) -> &str {
        "Odometry map"
    }
    fn summary(&self) -> Cow<'_, str> {
        "dead reckoning plus mapping: FastSLAM's extraction, association and landmark EKFs along the odometry path (one particle, no motion noise). It quantifies [FT]'s \"the odometry map is always wrong\"".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        ODOMETRY_MAP_CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::Estimator
    }
    fn sensors(&self, kind: WorldKind) -> Sensors {
        landmark_sensor(kind)
    }
    fn sections(&self, kind: WorldKind) -> Vec<String> {
        match kind {
            WorldKind::Laser => sections(&["features", "fastslam"]),
            WorldKind::Points => sections(&["fastslam"]),
        }
    }
    fn describe(&self, p: &Params, study: &Listing<'_>) -> Vec<Choice> {
        fastslam_on_lasers(p, study)
    }
    fn work(&self, _: &Params, size: &RunSize) -> Work {
        filter_work(size, 1.0, 1.0)
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        let observations = observations(&input, fastslam_line_r(p))?;
        let trace = match input.kind {
            WorldKind::Laser => {
                odometry::run_with_map_on(input.world, &p.fastslam, &observations, &mut rng(&input))
            }
            WorldKind::Points => odometry::run_with_point_map(
                input.world,
                &p.fastslam,
                &observations,
                &mut rng(&input),
            ),
        }?;
        Ok(estimate(trace))
    }
}

impl Algorithm for Fastslam1 {
    fn name(&self) -> &str {
        "fastslam1"
    }
    fn title(&self) -> &str {
        "FastSLAM 1.0"
    }
    fn summary(&self) -> Cow<'_, str> {
        "FastSLAM 1.0, [FT] Table 6.3: on laser line and corner landmarks, or on point landmarks ([PF])".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        fastslam::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::Estimator
    }
    fn sensors(&self, kind: WorldKind) -> Sensors {
        landmark_sensor(kind)
    }
    fn sections(&self, kind: WorldKind) -> Vec<String> {
        match kind {
            // [FT]'s FastSLAM keeps its own motion noise on laser worlds
            WorldKind::Laser => sections(&["features", "fastslam"]),
            WorldKind::Points => sections(&["fastslam", "motion_model"]),
        }
    }
    fn describe(&self, p: &Params, study: &Listing<'_>) -> Vec<Choice> {
        let mut out = fastslam_on_lasers(p, study);
        if study.has(WorldKind::Points) {
            out.extend([motion_model(p), fastslam_on_points(p, study)]);
        }
        out
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        filter_work(size, f64::from(p.fastslam.particles), 1.0)
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        let observations = observations(&input, fastslam_line_r(p))?;
        // [FT]'s own motion noise on laser worlds (corners as point landmarks), the study's
        // motion model on point worlds
        let (motion, corners) = match input.kind {
            WorldKind::Laser => (None, true),
            WorldKind::Points => (Some(&p.motion_model), false),
        };
        let trace = fastslam::run_on(
            input.world,
            &p.fastslam,
            motion,
            &observations,
            corners,
            &mut rng(&input),
        )?;
        Ok(estimate(trace))
    }
}

impl Algorithm for Fastslam2 {
    fn name(&self) -> &str {
        "fastslam2"
    }
    fn title(&self) -> &str {
        "FastSLAM 2.0"
    }
    fn summary(&self) -> Cow<'_, str> {
        "FastSLAM 2.0 (Montemerlo et al. 2003): the pose is sampled from a proposal that includes the step's observations".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        fastslam2::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::Estimator
    }
    fn sensors(&self, kind: WorldKind) -> Sensors {
        landmark_sensor(kind)
    }
    fn sections(&self, kind: WorldKind) -> Vec<String> {
        match kind {
            WorldKind::Laser => sections(&["features", "fastslam", "motion_model"]),
            WorldKind::Points => sections(&["fastslam", "motion_model"]),
        }
    }
    fn describe(&self, p: &Params, study: &Listing<'_>) -> Vec<Choice> {
        let mut out = fastslam_on_lasers(p, study);
        out.extend([motion_model(p), fastslam_on_points(p, study)]);
        out
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        // it samples its proposal once per particle per observation: about twice 1.0
        filter_work(size, f64::from(p.fastslam.particles), 2.0)
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        let observations = observations(&input, fastslam_line_r(p))?;
        let trace = fastslam2::run(
            input.world,
            &p.fastslam,
            &p.motion_model,
            &observations,
            input.kind == WorldKind::Laser,
            &mut rng(&input),
        )?;
        Ok(estimate(trace))
    }
}

impl Algorithm for EkfSlam {
    fn name(&self) -> &str {
        "ekf_slam"
    }
    fn title(&self) -> &str {
        "EKF-SLAM"
    }
    fn summary(&self) -> Cow<'_, str> {
        "EKF-SLAM: one Gaussian over the pose and every landmark; known, nearest-neighbour or maximum-likelihood association".into()
    }
    fn code_version(&self) -> Cow<'_, str> {
        ekf::CODE_VERSION.into()
    }
    fn role(&self) -> Role {
        Role::Estimator
    }
    fn sensors(&self, kind: WorldKind) -> Sensors {
        landmark_sensor(kind)
    }
    fn sections(&self, kind: WorldKind) -> Vec<String> {
        match kind {
            WorldKind::Laser => sections(&["features", "ekf", "motion_model"]),
            WorldKind::Points => sections(&["ekf", "motion_model"]),
        }
    }
    fn describe(&self, p: &Params, study: &Listing<'_>) -> Vec<Choice> {
        let mut out = Vec::new();
        if study.has(WorldKind::Laser) {
            out.push(Choice { topic: Topic::Features, text: p.features.describe() });
        }
        out.push(motion_model(p));
        out.push(Choice { topic: Topic::Ekf, text: p.ekf.describe() });
        out
    }
    fn work(&self, _: &Params, size: &RunSize) -> Work {
        // the joint covariance: landmarks² per update
        filter_work(size, size.landmarks.max(1.0), 1.0)
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        let p = input.params;
        let observations = observations(&input, p.ekf.laser_covariance())?;
        let trace = ekf::run(
            input.world,
            &p.motion_model,
            &p.ekf,
            &observations,
            input.kind == WorldKind::Laser,
        )?;
        Ok(estimate(trace))
    }
}

/// Graph-based SLAM on point landmarks: the online estimate (`graph_slam`) or the batch one
/// (`graph_slam_batch`).
pub struct GraphSlam {
    pub batch: bool,
}

impl Algorithm for GraphSlam {
    fn name(&self) -> &str {
        if self.batch { "graph_slam_batch" } else { "graph_slam" }
    }
    fn title(&self) -> &str {
        if self.batch { "Graph SLAM (batch)" } else { "Graph SLAM (online)" }
    }
    fn summary(&self) -> Cow<'_, str> {
        if self.batch {
            "graph-based SLAM, the smoothed estimate: every pose and landmark solved together once, after the last step (Levenberg–Marquardt, sparse Cholesky); known association".into()
        } else {
            "graph-based SLAM, the online estimate: the graph re-solved every few steps, warm-started, each step reporting what the smoother knew then; known association".into()
        }
    }
    fn code_version(&self) -> Cow<'_, str> {
        // the two estimates share their sections: the variant keeps their runs apart
        let variant = if self.batch { "batch" } else { "online" };
        format!("{}:{variant}", slam::graph::CODE_VERSION).into()
    }
    fn role(&self) -> Role {
        Role::Estimator
    }
    fn sensors(&self, _: WorldKind) -> Sensors {
        Sensors::LANDMARKS
    }
    fn sections(&self, _: WorldKind) -> Vec<String> {
        sections(&["graph", "motion_model"])
    }
    fn describe(&self, p: &Params, _: &Listing<'_>) -> Vec<Choice> {
        vec![motion_model(p), Choice { topic: Topic::Graph, text: p.graph.describe() }]
    }
    fn work(&self, p: &Params, size: &RunSize) -> Work {
        // a sparse solve over the whole graph: poses + landmarks per solve, ~10 iterations; online
        // solves every `relinearise_every` steps over a graph that grows with them
        let solves = if self.batch {
            1.0
        } else {
            size.steps / f64::from(p.graph.relinearise_every.max(1)) / 2.0
        };
        let mut w = Work::default();
        w.filter_points = 10.0 * solves.max(1.0) * (size.steps + size.landmarks) * 20.0;
        w
    }
    fn matcher<'p>(&self, _: &'p Params) -> Option<Matcher<'p>> {
        None
    }
    fn run(&self, input: RunInput<'_>) -> Result<Output, SlamError> {
        if input.kind == WorldKind::Laser {
            return Err(SlamError::MissingSensor("landmark sensor"));
        }
        let p = input.params;
        let observations = observations(&input, Matrix2::identity())?;
        let run = if self.batch { slam::graph::run_batch } else { slam::graph::run_online };
        Ok(estimate(run(input.world, &p.motion_model, &p.graph, &observations)?))
    }
}
