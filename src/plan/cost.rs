//! The expected cost of a run, from its plan alone: what `run --shard` balances shards by, what
//! `plan --shards` reports, and what the progress line's remaining time starts from.
//!
//! It never reads the cache, timings or the clock, so every task of a Slurm array computes the
//! same partition. It does not need to be exact, only proportional enough to balance: a run's
//! work is counted in a few terms — ray casting the world, extracting features, the filter's
//! updates, the scan matches — each from the spec's sizes (path length, laser rate and beams,
//! particles, landmarks, matches, evaluations), and weighted by seconds per unit of work fitted
//! to the compute times of every run of `make report` on the reference machine (one core of
//! the 2-core CI machine; README, "Running on a cluster"). An error of the fit moves no result.

use super::{ExperimentPlan, RunSpec};
use crate::slam::AlgorithmKind;
use crate::world::WorldKind;

/// Sizes of a run's work, in counts (not seconds).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Work {
    /// Odometry steps.
    pub steps: f64,
    /// Beams cast × walls (laser worlds) or steps × landmarks (point worlds).
    pub world: f64,
    /// Beams of the scans whose features are extracted.
    pub extraction: f64,
    /// Filter updates: scans × particles × landmarks (FastSLAM), scans × landmarks² (EKF).
    pub filter: f64,
    /// Matches × beams × (iterations or evaluations) of a scan matcher.
    pub matching: f64,
    /// Steps of a real log (read, not simulated).
    pub log_steps: f64,
}

/// Seconds per unit of each [`Work`] term, fitted by non-negative least squares to the compute
/// times of the runs of `make report` (see the module doc; refit when an algorithm's speed
/// changes a lot — balance, not results, depends on them).
pub mod seconds_per_unit {
    pub const STEP: f64 = 2.0e-6;
    pub const RAY_WALL: f64 = 1.0e-8;
    pub const EXTRACTED_BEAM: f64 = 2.0e-7;
    pub const FILTER: f64 = 2.0e-8;
    pub const MATCHING: f64 = 1.0e-8;
    pub const LOG_STEP: f64 = 2.0e-5;
    /// Every run: planning its world, writing its results.
    pub const RUN: f64 = 2.0e-3;
}

impl Work {
    /// Expected seconds on one core of the reference machine.
    pub fn seconds(&self) -> f64 {
        use seconds_per_unit as s;
        s::RUN + s::STEP * self.steps + s::RAY_WALL * self.world + s::EXTRACTED_BEAM * self.extraction + s::FILTER * self.filter + s::MATCHING * self.matching + s::LOG_STEP * self.log_steps
    }
}

/// A real log's length when the plan cannot know it without reading the files [steps].
const LOG_STEPS: f64 = 50_000.0;

/// The work of `run`.
pub fn work(plan: &ExperimentPlan, run: &RunSpec) -> Work {
    let params = &plan.points[run.point].params;
    let map = &plan.maps[run.map].map;
    let sensors = run.algorithm.sensors(map.world_kind());
    let mut w = Work::default();
    let Some(route) = &map.trajectory else {
        w.log_steps = LOG_STEPS;
        return w;
    };
    // Path length of the route (as `world::trajectory::drive` measures a lap) over the speed.
    let lap: f64 = std::iter::once([map.start.x, map.start.y]).chain(route.waypoints.iter().copied()).collect::<Vec<_>>().windows(2).map(|p| (p[1][0] - p[0][0]).hypot(p[1][1] - p[0][1])).sum();
    let path_m = lap * f64::from(route.laps);
    let duration_s = path_m / route.max_speed_mps.max(1e-3);
    w.steps = duration_s / params.sim.dt_s;
    let landmarks = (map.lines.len() + map.corners.len() + map.point_landmarks.len()) as f64;
    let laser = &params.laser;
    let (scans, beams) = if sensors.laser { (duration_s * laser.rate_hz, (laser.fov_deg / laser.resolution_deg).floor() + 1.0) } else { (0.0, 0.0) };
    if sensors.laser {
        w.world = scans * beams * map.walls.len() as f64;
    }
    if sensors.landmarks {
        w.world = w.steps * map.point_landmarks.len() as f64;
    }
    let kind = map.world_kind();
    let updates = if kind == WorldKind::Laser { scans } else { w.steps * params.landmark_sensor.rate_hz * params.sim.dt_s };
    match run.algorithm {
        AlgorithmKind::Odometry => {}
        AlgorithmKind::OdometryMap | AlgorithmKind::Fastslam1 | AlgorithmKind::Fastslam2 | AlgorithmKind::EkfSlam => {
            if kind == WorldKind::Laser {
                w.extraction = scans * beams;
            }
            let particles = match run.algorithm {
                AlgorithmKind::OdometryMap => 1.0,
                AlgorithmKind::EkfSlam => landmarks.max(1.0),
                _ => f64::from(params.fastslam.particles),
            };
            // FastSLAM 2.0 samples its proposal once per particle per observation: about twice 1.0
            let proposal = if run.algorithm == AlgorithmKind::Fastslam2 { 2.0 } else { 1.0 };
            w.filter = updates * particles * landmarks.max(1.0) * proposal;
        }
        a => {
            let sm = &params.scan_matching;
            let trigger_m = if sm.trigger_distance_m > 0.0 { sm.trigger_distance_m } else { 0.5 };
            let mut matches = (path_m / trigger_m).min(scans);
            if sm.max_matches > 0 {
                matches = matches.min(f64::from(sm.max_matches));
            }
            // evaluations of the objective per match (each over all beams)
            let evaluations = match a {
                AlgorithmKind::Psm | AlgorithmKind::PsmOriginal => f64::from(params.psm.max_iter.min(30)),
                AlgorithmKind::Epsm => f64::from(params.epsm.max_iter.max(1)) * 20.0,
                AlgorithmKind::BruteForce => {
                    let side = 2.0 * params.brute_force.half_window_m / params.brute_force.step_m.max(1e-6) + 1.0;
                    match params.brute_force.mode {
                        crate::scanmatch::brute::BruteForceMode::Nested => side * side,
                        crate::scanmatch::brute::BruteForceMode::Descent => f64::from(params.brute_force.max_moves).min(side * side) * 8.0,
                    }
                }
                _ => f64::from(params.pose_search.maxeval.max(1)),
            };
            w.extraction = matches * beams;
            w.matching = matches * beams * evaluations;
        }
    }
    w
}

/// Expected seconds of `run` on one core of the reference machine.
pub fn expected_s(plan: &ExperimentPlan, run: &RunSpec) -> f64 {
    work(plan, run).seconds()
}
