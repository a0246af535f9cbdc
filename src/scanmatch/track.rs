//! Laser odometry by scan matching: a [`World`]'s scans → a chained trajectory and one
//! [`MatchRecord`] per match ([EP] ch. 3, Fig. 1). Pure: the caller passes the clock that times
//! each match.
//!
//! The procedure ([EP] §3 and its gaps filled, each a `[scan_matching]` parameter):
//! - **Trigger** ([EP] §3: "when odometry reports a significant pose change, or after a fixed
//!   time"): a scan is matched against the reference scan (the scan of the previous match) once
//!   the odometry since the reference has moved `trigger_distance_m` or turned
//!   `trigger_angle_deg`, or `trigger_timeout_s` has passed.
//! - **Initial guess**: the odometry increment since the reference (or the identity).
//! - **Chaining**: the estimate of the matched scan's pose is the reference's estimate composed
//!   with the match; between matches the estimate follows the odometry. A match whose estimate is
//!   not finite keeps the odometry's guess (and counts as failed).
//! - **Run length**: the run stops after `max_matches` matches ([EP]: 100 per run); the trajectory
//!   metrics cover the steps up to the last match.
//! - **Errors** ([EP] §5): a match's error is its estimated pose change minus the true one, in the
//!   reference frame: ax, ay [mm], aθ [deg].

use super::MatchResult;
use super::objective::{Objective, ObjectiveParams};
use super::search::Optimizer;
use super::segment::{Segmentation, SegmentationParams, prepare};
use crate::config::{Checks, Violation};
use crate::geom::Pose2;
use crate::trace::{MatchRecord, SlamError, Trace};
use crate::world::World;
use crate::world::laser::{LaserGeometry, Scan};
use serde::{Deserialize, Serialize};

/// Part of every scan-matching run's content hash: bump when a matcher's output changes.
pub const CODE_VERSION: &str = "scanmatch-3";

/// Where a match starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum InitialGuess {
    /// The odometry increment since the reference scan ([EP]).
    Odometry,
    /// No motion (pure laser odometry, no prior).
    Identity,
}

/// `[base.scan_matching]`: what every scan matcher shares.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct ScanMatchingParams {
    /// Match once the odometry since the reference scan has moved this far [m].
    pub trigger_distance_m: f64,
    /// … or turned this much [deg].
    pub trigger_angle_deg: f64,
    /// … or this much time has passed [s] (0 = never on time alone).
    pub trigger_timeout_s: f64,
    /// Stop after this many matches ([EP] ran 100 per run); 0 = match until the end of the path
    /// (the [EP] studies: their paths give about 100 matches, and every algorithm, dead
    /// reckoning included, is scored over the same steps).
    pub max_matches: u32,
    pub initial_guess: InitialGuess,
    /// Preprocessing of every scan (`psm_original` always uses PSM's own heuristics).
    pub segmentation: SegmentationParams,
    /// The objective f every matcher is scored by.
    pub objective: ObjectiveParams,
}

impl Default for ScanMatchingParams {
    fn default() -> Self {
        Self {
            trigger_distance_m: 0.5,
            trigger_angle_deg: 30.0,
            trigger_timeout_s: 0.0,
            max_matches: 0,
            initial_guess: InitialGuess::Odometry,
            segmentation: SegmentationParams::default(),
            objective: ObjectiveParams::default(),
        }
    }
}

impl ScanMatchingParams {
    /// The report's sentence on the procedure every matcher shares: trigger, initial guess,
    /// chaining and run length.
    pub fn describe(&self) -> String {
        format!(
            "Scan matching: a scan is matched against the scan of the previous match once the odometry since it has moved {} m or turned {}°{}; the initial guess is {}; between matches the estimate follows the odometry, and each match resets it to the reference's estimate ⊕ the match ({}).",
            self.trigger_distance_m,
            self.trigger_angle_deg,
            if self.trigger_timeout_s > 0.0 {
                format!(" or {} s have passed", self.trigger_timeout_s)
            } else {
                String::new()
            },
            match self.initial_guess {
                InitialGuess::Odometry => "the odometry increment since the reference scan",
                InitialGuess::Identity => "no motion",
            },
            if self.max_matches > 0 {
                format!("at most {} matches per run", self.max_matches)
            } else {
                "matching to the end of the path".to_string()
            }
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.non_negative("trigger_distance_m", self.trigger_distance_m);
        c.non_negative("trigger_angle_deg", self.trigger_angle_deg);
        c.non_negative("trigger_timeout_s", self.trigger_timeout_s);
        c.require(self.trigger_distance_m > 0.0 || self.trigger_angle_deg > 0.0 || self.trigger_timeout_s > 0.0, "trigger_distance_m", || {
            "at least one of trigger_distance_m, trigger_angle_deg and trigger_timeout_s must be > 0".to_string()
        });
        c.nested("segmentation", self.segmentation.validate());
        c.nested("objective", self.objective.validate());
        c.finish()
    }
}

/// The report's sentence on how matches are scored: the per-match errors ax, ay, aθ and the cost
/// in objective evaluations.
pub fn describe_errors() -> &'static str {
    "Errors ([EP] §5): ax, ay [mm] and aθ [deg] are the estimated minus the true pose change of each match, in the reference frame; tables give the mean and max of their absolute values over a run's matches. Cost is counted in objective evaluations (deterministic); times per match depend on the machine and are on the timing page `slamlab report` writes beside the results (`data/results/<study>/timings.html`), not in this report."
}

/// Which matcher runs, with its parameters.
#[derive(Debug, Clone, Copy)]
pub enum Matcher<'a> {
    /// PSM on the study's segmentation (`own_heuristics = false`) or on its own heuristics.
    Psm {
        params: &'a super::psm::PsmParams,
        own_heuristics: bool,
    },
    Epsm(&'a super::epsm::EpsmParams),
    BruteForce(&'a super::brute::BruteForceParams),
    PoseSearch {
        optimizer: Optimizer,
        params: &'a super::search::SearchParams,
    },
    PlIcp(&'a super::plicp::PlIcpParams),
}

/// A scan-matching run's output: the trace (estimate over `steps` steps) and its matches.
#[derive(Debug, Clone)]
pub struct Tracked {
    pub trace: Trace,
    /// Steps covered (the world's truth is cut to this length for the metrics).
    pub steps: usize,
}

/// How a matcher's scans are prepared: the study's segmentation and the laser's geometry, except
/// `psm_original`, which preprocesses as v0.3 does (its own heuristics, in its own precision, with
/// readings beyond its range gate, PM_MAX_RANGE, marked bad).
pub fn preparation(
    matcher: Matcher<'_>,
    params: &ScanMatchingParams,
    geometry: LaserGeometry,
) -> (SegmentationParams, LaserGeometry) {
    match matcher {
        Matcher::Psm { own_heuristics: true, params: psm } => {
            let mut segmentation = SegmentationParams {
                method: Segmentation::PsmHeuristics,
                ..params.segmentation.clone()
            };
            segmentation.psm_heuristics.precision = psm.precision;
            (
                segmentation,
                LaserGeometry {
                    max_range_m: geometry.max_range_m.min(psm.max_range_m),
                    ..geometry
                },
            )
        }
        // PL-ICP works on the raw points, as CSM does: no filtering, no line projection
        Matcher::PlIcp(_) => (
            SegmentationParams { method: Segmentation::None, ..params.segmentation.clone() },
            geometry,
        ),
        _ => (params.segmentation.clone(), geometry),
    }
}

/// The seed of a run's `k`-th match (0-based) for the stochastic optimisers.
pub fn match_seed(seed: u64, k: usize) -> u64 {
    seed ^ (k as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// The steps of the scans a run matched: the first reference and every current scan, in order.
pub fn matched_steps(matches: &[MatchRecord]) -> Vec<usize> {
    matches
        .first()
        .map(|m| m.reference_step)
        .into_iter()
        .chain(matches.iter().map(|m| m.current_step))
        .collect()
}

/// Prepares one scan for matching.
pub fn prepared(
    scan: &Scan,
    geometry: &LaserGeometry,
    segmentation: &SegmentationParams,
) -> super::scan::PolarScan {
    prepare(
        &scan.ranges_m,
        geometry.angle_min_rad,
        geometry.angle_increment_rad,
        geometry.max_range_m,
        segmentation,
    )
}

/// One match a run makes: the reference and current scans' steps, and the initial guess of the
/// current scan's pose in the reference frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    pub reference_step: usize,
    pub current_step: usize,
    pub initial: Pose2,
}

/// The matches a run makes, and the steps it covers (the metrics stop after the last match when
/// `max_matches` ends the run). Which scans are paired depends on the odometry alone — the
/// trigger and the initial guess — never on what a matcher estimates, so every matcher of a study
/// matches the same pairs.
pub fn pairs(world: &World, params: &ScanMatchingParams) -> Result<(Vec<Pair>, usize), SlamError> {
    let Some(first) = world.scans.first() else {
        return Err(SlamError::MissingSensor("laser"));
    };
    let mut reference = first.step;
    let mut steps = world.truth.len();
    let mut out = Vec::new();
    for scan in &world.scans[1..] {
        let odometry = world.odometry[reference..scan.step]
            .iter()
            .fold(Pose2::IDENTITY, |acc, d| acc.compose(*d));
        let elapsed_s = (scan.step - reference) as f64 * world.dt_s;
        let moved = odometry.x.hypot(odometry.y) >= params.trigger_distance_m
            && params.trigger_distance_m > 0.0;
        let turned = odometry.theta.abs() >= params.trigger_angle_deg.to_radians()
            && params.trigger_angle_deg > 0.0;
        let timed_out = params.trigger_timeout_s > 0.0 && elapsed_s >= params.trigger_timeout_s;
        if !(moved || turned || timed_out) {
            continue;
        }
        let initial = match params.initial_guess {
            InitialGuess::Odometry => odometry,
            InitialGuess::Identity => Pose2::IDENTITY,
        };
        out.push(Pair { reference_step: reference, current_step: scan.step, initial });
        reference = scan.step;
        if params.max_matches > 0 && out.len() >= params.max_matches as usize {
            steps = scan.step + 1;
            break;
        }
    }
    Ok((out, steps))
}

/// `pairs.txt`: one pair a line, `ref_step cur_step guess_x_m guess_y_m guess_theta_rad` (the
/// current scan's initial pose in the reference scan's frame), reals in Rust's shortest
/// round-trip form (`slamlab export-scans`, external scan matchers).
pub fn pairs_text(pairs: &[Pair]) -> String {
    let mut s = String::from("# ref_step cur_step guess_x_m guess_y_m guess_theta_rad\n");
    for p in pairs {
        s.push_str(&format!(
            "{} {} {} {} {}\n",
            p.reference_step, p.current_step, p.initial.x, p.initial.y, p.initial.theta
        ));
    }
    s
}

/// The trajectory of `steps` poses from the matches ([EP] Fig. 1): a matched scan's pose is its
/// reference's composed with the match (the initial guess where the match is not finite);
/// between matches it follows the odometry.
pub fn chain(world: &World, matches: &[MatchRecord], steps: usize) -> Vec<Pose2> {
    let mut estimate = vec![world.truth[0]];
    let dead_reckon = |estimate: &mut Vec<Pose2>, until: usize| {
        while estimate.len() < until {
            let k = estimate.len() - 1;
            estimate.push(estimate[k].compose(world.odometry[k]));
        }
    };
    for m in matches {
        dead_reckon(&mut estimate, m.current_step + 1);
        let delta = if m.estimate.is_finite() { m.estimate } else { m.initial };
        estimate[m.current_step] = estimate[m.reference_step].compose(delta);
    }
    dead_reckon(&mut estimate, steps);
    estimate.truncate(steps);
    estimate
}

/// Runs `matcher` along the world's scans (see the module doc). `seed` seeds the stochastic
/// optimisers (one derived seed per match); `clock` returns seconds.
pub fn track(
    world: &World,
    matcher: Matcher<'_>,
    params: &ScanMatchingParams,
    seed: u64,
    clock: &mut dyn FnMut() -> f64,
) -> Result<Tracked, SlamError> {
    let geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
    let (segmentation, geometry) = preparation(matcher, params, geometry);
    let (pairs, steps) = pairs(world, params)?;
    let mut scans = world.scans.iter();
    let mut next_scan = |step: usize| scans.find(|s| s.step == step).expect("a pair names scans");
    let mut reference =
        pairs.first().map(|p| prepared(next_scan(p.reference_step), &geometry, &segmentation));
    let mut matches = Vec::with_capacity(pairs.len());
    for (k, pair) in pairs.iter().enumerate() {
        let current = prepared(next_scan(pair.current_step), &geometry, &segmentation);
        let reference_scan = reference.as_ref().expect("the first pair's reference is prepared");
        let start = clock();
        let result = run_matcher(
            matcher,
            reference_scan,
            &current,
            pair.initial,
            &params.objective,
            match_seed(seed, k),
        );
        let time_s = clock() - start;
        matches.push(record(world, pair, &result, time_s));
        reference = Some(current);
    }
    let estimate = chain(world, &matches, steps);
    Ok(Tracked { trace: Trace { estimate, matches, ..Trace::default() }, steps })
}

/// The record of `pair`'s match: its result, scored against the world's truth.
pub fn record(world: &World, pair: &Pair, result: &MatchResult, time_s: f64) -> MatchRecord {
    MatchRecord {
        reference_step: pair.reference_step,
        current_step: pair.current_step,
        truth: world.truth[pair.current_step].relative_to(world.truth[pair.reference_step]),
        initial: pair.initial,
        estimate: result.pose,
        f: result.f,
        f_initial: result.f_initial,
        pairs: result.pairs as u32,
        iterations: result.iterations,
        evaluations: result.evaluations,
        fallback: result.fallback,
        stop: format!("{:?}", result.stop),
        time_s,
    }
}

pub fn run_matcher(
    matcher: Matcher<'_>,
    reference: &super::scan::PolarScan,
    current: &super::scan::PolarScan,
    initial: Pose2,
    objective: &ObjectiveParams,
    seed: u64,
) -> MatchResult {
    let mut cost = Objective::new(reference, current, objective);
    match matcher {
        // Both scans come from one laser, so the geometries always agree.
        Matcher::Psm { params, .. } => {
            super::psm::psm(reference, current, initial, params, &mut cost)
                .expect("scans of one laser share their beam geometry")
        }
        Matcher::Epsm(params) => super::epsm::epsm(&mut cost, initial, params),
        Matcher::BruteForce(params) => super::brute::brute_force(&mut cost, initial, params),
        Matcher::PoseSearch { optimizer, params } => {
            super::search::simultaneous(&mut cost, initial, optimizer, params, seed)
        }
        Matcher::PlIcp(params) => {
            super::plicp::pl_icp(reference, current, initial, params, &mut cost)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn describe_names_the_trigger_guess_and_run_length() {
        let p = ScanMatchingParams {
            trigger_distance_m: 0.3,
            trigger_angle_deg: 15.0,
            trigger_timeout_s: 2.0,
            max_matches: 100,
            ..ScanMatchingParams::default()
        };
        let s = p.describe();
        assert!(
            s.contains("moved 0.3 m or turned 15° or 2 s have passed")
                && s.contains("(at most 100 matches per run)"),
            "{s}"
        );
        let s = ScanMatchingParams {
            initial_guess: InitialGuess::Identity,
            ..ScanMatchingParams::default()
        }
        .describe();
        assert!(
            s.contains("moved 0.5 m or turned 30°;")
                && s.contains("the initial guess is no motion")
                && s.contains("(matching to the end of the path)"),
            "{s}"
        );
    }
}
