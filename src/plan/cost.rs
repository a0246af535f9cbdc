//! The expected cost of a run, from its plan alone: what `run --shard` balances shards by, what
//! `plan --shards` reports, and what the progress line's remaining time starts from.
//!
//! It never reads the cache, timings or the clock, so every task of a Slurm array computes the
//! same partition. It does not need to be exact, only proportional enough to balance: a run's
//! work is counted in a few terms — extracting features, the filter's
//! updates, the scan matches — each from the spec's sizes (path length, laser rate and beams,
//! particles, landmarks, matches, evaluations), and weighted by seconds per unit of work fitted
//! to the compute times of every run of `make report` on the reference machine (one core of
//! the 2-core CI machine; docs/src/guide/cluster.md). An error of the fit moves no result.

use super::{ExperimentPlan, RunSpec};
use crate::algo::RunSize;
pub use crate::algo::Work;
use crate::world::WorldKind;

/// Seconds per unit of each [`Work`] term: non-negative least squares (rows weighted by
/// 1/√time) over the 8 174 runs computed by `make report` from scratch on the reference machine
/// (2-core AMD EPYC, the CI machine; measured 2026-11-25). Per algorithm the fit's total is within
/// a factor 2.2 of the measured one for all but odometry (over-estimated: its runs take ~2 ms);
/// the median run within a factor 1.45. Refit (docs/src/guide/cluster.md) when an algorithm's
/// speed changes a lot: balance, never a result, depends on these.
pub mod seconds_per_unit {
    pub const EXTRACTED_BEAM: f64 = 9.8e-8;
    pub const FILTER: f64 = 6.3e-8;
    pub const FILTER_POINTS: f64 = 1.5e-8;
    /// A beam of one evaluation of the scan-matching objective.
    pub const MATCHING: f64 = 2.3e-8;
    pub const LOG_STEP: f64 = 1.8e-6;
    /// Every run: its world (ray casting fitted no weight of its own), metrics, caching.
    pub const RUN: f64 = 1.0e-2;
}

impl Work {
    /// Expected seconds on one core of the reference machine.
    pub fn seconds(&self) -> f64 {
        use seconds_per_unit as s;
        s::RUN
            + s::EXTRACTED_BEAM * self.extraction
            + s::FILTER * self.filter
            + s::FILTER_POINTS * self.filter_points
            + s::MATCHING * self.matching
            + s::LOG_STEP * self.log_steps
            + self.external_s
    }
}

/// A real log's length when the plan cannot know it without reading the files [steps].
const LOG_STEPS: f64 = 50_000.0;

/// The work of `run`.
pub fn work(plan: &ExperimentPlan, run: &RunSpec) -> Work {
    let params = &plan.points[run.point].params;
    let entry = &plan.maps[run.map];
    let map = &entry.map;
    let kind = entry.world_kind();
    let algorithm = plan.algorithm(run);
    let sensors = algorithm.sensors(kind);
    let mut w = Work::default();
    let Some(route) = &map.trajectory else {
        w.log_steps = LOG_STEPS;
        return w;
    };
    // Path length of the route (as `world::trajectory::drive` measures a lap) over the speed.
    let lap: f64 = std::iter::once([map.start.x, map.start.y])
        .chain(route.waypoints.iter().copied())
        .collect::<Vec<_>>()
        .windows(2)
        .map(|p| (p[1][0] - p[0][0]).hypot(p[1][1] - p[0][1]))
        .sum();
    let path_m = lap * f64::from(route.laps);
    let duration_s = path_m / route.max_speed_mps.max(1e-3);
    w.steps = duration_s / params.sim.dt_s;
    let landmarks = (map.lines.len() + map.corners.len() + map.point_landmarks.len()) as f64;
    let laser = &params.laser;
    let (scans, beams) = if sensors.laser {
        (duration_s * laser.rate_hz, (laser.fov_deg / laser.resolution_deg).floor() + 1.0)
    } else {
        (0.0, 0.0)
    };
    let updates = if kind == WorldKind::Laser {
        scans
    } else {
        w.steps * params.landmark_sensor.rate_hz * params.sim.dt_s
    };
    let size = RunSize { kind, steps: w.steps, path_m, scans, beams, updates, landmarks };
    Work { steps: w.steps, ..algorithm.work(params, &size) }
}

/// Expected seconds of `run` on one core of the reference machine.
pub fn expected_s(plan: &ExperimentPlan, run: &RunSpec) -> f64 {
    work(plan, run).seconds()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(spec: &str) -> ExperimentPlan {
        crate::plan::build(
            crate::spec::load(std::path::Path::new(spec), &Default::default()).expect("spec loads"),
            std::path::Path::new("data/maps"),
        )
        .expect("spec plans")
    }

    /// The cost of the run of `plan` on `map` at the point whose label contains `point`.
    fn cost(plan: &ExperimentPlan, map: &str, point: &str, algorithm: &str) -> f64 {
        let r = plan
            .runs
            .iter()
            .find(|r| {
                plan.maps[r.map].name == map
                    && plan.points[r.point].label.contains(point)
                    && r.algorithm.as_str() == algorithm
                    && r.replicate == 0
            })
            .expect("such a run");
        expected_s(plan, r)
    }

    #[test]
    fn more_particles_and_longer_paths_cost_more() {
        let p = plan("experiments/ft-particles.toml");
        let (few, many) = (
            cost(&p, "bigloop2", "particles=5", "fastslam1"),
            cost(&p, "bigloop2", "particles=500", "fastslam1"),
        );
        // measured: 2.35 s against 0.136 s (17×)
        assert!(many > 10.0 * few, "500 particles {many} s against 5: {few} s");
        // Complex's route (285 m) is longer than Recinto básico's
        assert!(
            cost(&p, "complex", "particles=100", "fastslam1")
                > cost(&p, "recinto_basico", "particles=100", "fastslam1")
        );
    }

    #[test]
    fn the_exhaustive_brute_force_dwarfs_e_psm_and_psm() {
        let p = plan("experiments/ep-cost.toml");
        let (psm, epsm, brute) = (
            cost(&p, "ep_rect_column", "none", "psm"),
            cost(&p, "ep_rect_column", "none", "epsm"),
            cost(&p, "ep_rect_column", "none", "brute_force"),
        );
        assert!(psm < epsm && 100.0 * epsm < brute, "psm {psm}, epsm {epsm}, brute force {brute}");
        // measured here: about 45 s per run (10 matches of 6 561 cells × 121 evaluations)
        assert!((10.0..200.0).contains(&brute), "{brute}");
    }
}
