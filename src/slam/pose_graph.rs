//! Laser pose-graph SLAM (Lu & Milios 1997; the graph of Grisetti et al.'s "A tutorial on
//! graph-based SLAM", 2010): a [`World`]'s scans → the optimised trajectory, its scan-matching
//! edges and its loop closures. Pure: the caller passes the front end and the clock.
//!
//! The graph's nodes are the poses of the scans a scan-matching run matches (the same pairs as
//! `scanmatch::track`, so the consecutive edges are exactly the front end's own matches), and its
//! edges are scan matches, each a measured pose of one scan in another's frame:
//! - **consecutive edges**: each scan matched against the previous matched one, from the
//!   odometry's guess (a match that fails keeps the guess, as the front end's chaining does);
//! - **loop closures**: after each scan is added, the `loop_candidates` nearest earlier nodes at
//!   least `loop_min_separation` nodes back, within `loop_radius_m` and `loop_max_turn_deg` of
//!   the current estimate, are matched against it from the estimate's relative pose, and a match
//!   is kept when at least `min_inlier_fraction` of the scan's returns lie within
//!   `inlier_distance_m` of the other scan's surface (the polyline through its returns) — an
//!   overlap test on the raw returns, the same for every front end;
//! - every match edge has the covariance diag(σxy², σxy², σθ²) and Cauchy's kernel of width
//!   `cauchy_width` σ, so that a wrong closure (or a gross consecutive match) that the others
//!   contradict loses its pull instead of bending the map;
//! - **odometry edges** (`odometry_edges`, default on): the odometry increment between
//!   consecutive nodes, with the noise of the motion model the filters are told (`[motion_model]`)
//!   as a body-frame diagonal — for `proportional`, σ = k_translation·d + floor on each axis and
//!   k_rotation·|φ| + floor in heading per step, summed over the steps between the nodes; for
//!   `pose`, its σx, σy, σθ per step — without a kernel. A gross consecutive match then has
//!   something to disagree with: without it, the chain has no other path between two
//!   consecutive scans, and a gross match shifts everything after it (on the Intel log, a match
//!   near the end left the last hundred scans 2–10 m off where no closure reached them);
//! - a prior pins the first node at the front end's own start.
//!
//! The graph is re-solved (Levenberg–Marquardt on the sparse normal equations, `slam::graph`)
//! after every scan that added a closure, so that later candidates are sought around corrected
//! poses, and once more at the end; the trajectory is that last solve's: scan poses from the
//! graph, the steps between them by odometry from the last scan (as the front end's chaining).

use super::graph::{Graph, GraphParams};
use super::motion::MotionModel;
use crate::config::{Checks, Violation};
use crate::geom::{Point2, Pose2, wrap_angle};
use crate::scanmatch::search::Optimizer;
use crate::scanmatch::track::{
    Matcher, Pair, ScanMatchingParams, match_seed, pairs, preparation, prepared, record,
    run_matcher,
};
use crate::trace::{SlamError, Trace};
use crate::world::World;
use crate::world::laser::{LaserGeometry, Scan};
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// Part of every pose-graph run's content hash: bump when its output changes.
pub const CODE_VERSION: &str = "pose-graph-1";

/// Two returns of adjacent beams farther apart than this are not one surface (a depth jump), so
/// the overlap test does not join them [m]: 0.5 m is the spacing of 1° beams on a wall about
/// 28 m away, beyond the rooms and corridors of an indoor log.
const SURFACE_GAP_M: f64 = 0.5;

/// `[pose_graph]`: the laser pose graph's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PoseGraphParams {
    /// The built-in scan matcher that makes every edge ([`FRONT_ENDS`]). Default `pl_icp`.
    pub front_end: String,
    /// σ of an edge's translation, per axis [m]. Default 0.05.
    pub sigma_xy_m: f64,
    /// σ of an edge's rotation [deg]. Default 1.
    pub sigma_theta_deg: f64,
    /// Width of every edge's Cauchy kernel, in σ (whitened units). Default 3.
    pub cauchy_width: f64,
    /// Loop-closure candidates lie within this distance of the scan's estimate [m]. Default 3.
    pub loop_radius_m: f64,
    /// … and within this heading of it [deg]. Default 60.
    pub loop_max_turn_deg: f64,
    /// … and at least this many nodes back. Default 30.
    pub loop_min_separation: u32,
    /// The nearest this many candidates are matched per scan. Default 3.
    pub loop_candidates: u32,
    /// A return is an inlier within this distance of the other scan's surface [m]. Default 0.05.
    pub inlier_distance_m: f64,
    /// A closure is kept when at least this fraction of the scan's returns are inliers. Default 0.5.
    pub min_inlier_fraction: f64,
    /// Odometry edges between consecutive nodes, with the motion model's noise. Default true.
    pub odometry_edges: bool,
}

impl Default for PoseGraphParams {
    fn default() -> Self {
        Self {
            front_end: "pl_icp".into(),
            sigma_xy_m: 0.05,
            sigma_theta_deg: 1.0,
            cauchy_width: 3.0,
            loop_radius_m: 3.0,
            loop_max_turn_deg: 60.0,
            loop_min_separation: 30,
            loop_candidates: 3,
            inlier_distance_m: 0.05,
            min_inlier_fraction: 0.5,
            odometry_edges: true,
        }
    }
}

/// The scan matchers that can be the front end: every built-in one (a test checks the list
/// against the algorithm registry).
pub fn front_ends() -> Vec<&'static str> {
    let mut names = vec!["psm", "psm_original", "epsm", "brute_force", "pl_icp"];
    names.extend(Optimizer::ALL.iter().map(|o| o.name()));
    names
}

impl PoseGraphParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        let names = front_ends();
        c.require(names.contains(&self.front_end.as_str()), "front_end", || {
            format!(
                "`{}` is not a built-in scan matcher; one of: {}",
                self.front_end,
                names.join(", ")
            )
        });
        c.positive("sigma_xy_m", self.sigma_xy_m);
        c.positive("sigma_theta_deg", self.sigma_theta_deg);
        c.positive("cauchy_width", self.cauchy_width);
        c.non_negative("loop_radius_m", self.loop_radius_m);
        c.non_negative("loop_max_turn_deg", self.loop_max_turn_deg);
        c.require(self.loop_min_separation >= 2, "loop_min_separation", || {
            "must be at least 2 (the previous node is the consecutive edge's)".into()
        });
        c.positive("inlier_distance_m", self.inlier_distance_m);
        c.require(
            self.min_inlier_fraction > 0.0 && self.min_inlier_fraction <= 1.0,
            "min_inlier_fraction",
            || format!("must be in (0, 1], got {}", self.min_inlier_fraction),
        );
        c.finish()
    }

    /// The report's sentence on the pose graph.
    pub fn describe(&self) -> String {
        format!(
            "Laser pose graph (Lu & Milios; Grisetti et al. 2010): the matched scans' poses are the nodes; the edges are the front end's ({}) matches of consecutive scans, from the odometry's guess, and loop closures — after each scan, its {} nearest earlier nodes at least {} nodes back, within {} m and {}° of its estimate, matched from the estimate and kept when at least {} % of its returns lie within {} m of the other scan's surface. Every match edge has σ = {} m per axis and {}° and Cauchy's kernel of width {} σ{}; the graph is re-solved by Levenberg–Marquardt after every scan that closed a loop and once at the end, whose solution is the trajectory (steps between scans by odometry).",
            self.front_end,
            self.loop_candidates,
            self.loop_min_separation,
            self.loop_radius_m,
            self.loop_max_turn_deg,
            self.min_inlier_fraction * 100.0,
            self.inlier_distance_m,
            self.sigma_xy_m,
            self.sigma_theta_deg,
            self.cauchy_width,
            if self.odometry_edges {
                ", and odometry edges join consecutive nodes with the motion model's noise (a body-frame diagonal: per step σ = k·d plus the floor on each axis, k·|φ| plus the floor in heading), without a kernel"
            } else {
                "; no odometry edges"
            },
        )
    }

    fn covariance(&self) -> Matrix3<f64> {
        let (s, t) = (self.sigma_xy_m, self.sigma_theta_deg.to_radians());
        Matrix3::from_diagonal(&nalgebra::Vector3::new(s * s, s * s, t * t))
    }
}

/// A pose-graph run's output: the trace (the optimised trajectory over `steps` steps, the
/// consecutive matches and the loop closures) — as a scan matcher's.
#[derive(Debug, Clone)]
pub struct PoseGraphRun {
    pub trace: Trace,
    pub steps: usize,
}

/// The covariance of the odometry increment over `steps` (one per odometry step) under
/// `motion`, as a body-frame diagonal (see the module doc): the steps' variances summed.
pub fn odometry_covariance(motion: &MotionModel, steps: &[Pose2]) -> Matrix3<f64> {
    let mut v = nalgebra::Vector3::zeros();
    for u in steps {
        let (st, sr) = match *motion {
            MotionModel::Proportional {
                k_translation,
                k_rotation,
                floor_translation_m,
                floor_rotation_rad,
                ..
            } => (
                k_translation * u.x.hypot(u.y) + floor_translation_m,
                k_rotation * u.theta.abs() + floor_rotation_rad,
            ),
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                (sigma_x_m.max(sigma_y_m), sigma_theta_rad)
            }
        };
        v += nalgebra::Vector3::new(st * st, st * st, sr * sr);
    }
    Matrix3::from_diagonal(&v)
}

/// The seed of the closure matching node `b` against node `a` (the stochastic optimisers).
fn closure_seed(seed: u64, a: usize, b: usize) -> u64 {
    match_seed(seed ^ 0x5EED_C105_u64.rotate_left(17), a.wrapping_mul(1 << 20) ^ b)
}

/// The returns of a raw scan, in the laser's frame.
fn returns(scan: &Scan, geometry: &LaserGeometry) -> Vec<Option<Point2>> {
    scan.ranges_m
        .iter()
        .enumerate()
        .map(|(i, r)| {
            r.filter(|r| r.is_finite()).map(|r| {
                let b = geometry.bearing(i);
                Point2::new(r * b.cos(), r * b.sin())
            })
        })
        .collect()
}

/// The fraction of `current`'s returns, placed at `pose` in `reference`'s frame, that lie within
/// `distance` of `reference`'s surface: the polyline through its returns, adjacent beams joined
/// unless farther apart than [`SURFACE_GAP_M`] (lone returns count as points). 0 when `current`
/// has no return.
pub fn inlier_fraction(
    reference: &[Option<Point2>],
    current: &[Option<Point2>],
    pose: &Pose2,
    distance: f64,
) -> f64 {
    let mut pieces: Vec<(Point2, Point2)> = Vec::new();
    for (i, p) in reference.iter().enumerate() {
        let Some(p) = p else { continue };
        let next =
            reference.get(i + 1).copied().flatten().filter(|q| q.distance(*p) <= SURFACE_GAP_M);
        let prev =
            i.checked_sub(1).and_then(|j| reference[j]).filter(|q| q.distance(*p) <= SURFACE_GAP_M);
        match next {
            Some(q) => pieces.push((*p, q)),
            None if prev.is_none() => pieces.push((*p, *p)),
            None => {}
        }
    }
    let points: Vec<Point2> = current.iter().flatten().map(|q| pose.transform_point(*q)).collect();
    if points.is_empty() {
        return 0.0;
    }
    let near = |q: &Point2| pieces.iter().any(|(a, b)| segment_distance(q, a, b) <= distance);
    points.iter().filter(|q| near(q)).count() as f64 / points.len() as f64
}

/// The distance from `q` to the segment a–b.
fn segment_distance(q: &Point2, a: &Point2, b: &Point2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((q.x - a.x) * dx + (q.y - a.y) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (q.x - a.x - t * dx).hypot(q.y - a.y - t * dy)
}

/// The earlier nodes to try closing a loop with node `b` (see the module doc): the nearest
/// `params.loop_candidates` by distance (ties to the earlier node).
fn candidates(poses: &[Pose2], b: usize, params: &PoseGraphParams) -> Vec<usize> {
    let separation = params.loop_min_separation as usize;
    if b < separation {
        return Vec::new();
    }
    let here = poses[b];
    let max_turn = params.loop_max_turn_deg.to_radians();
    let mut near: Vec<(f64, usize)> = (0..=b - separation)
        .filter_map(|j| {
            let d = (poses[j].x - here.x).hypot(poses[j].y - here.y);
            let turn = wrap_angle(poses[j].theta - here.theta).abs();
            (d <= params.loop_radius_m && turn <= max_turn).then_some((d, j))
        })
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    near.into_iter().take(params.loop_candidates as usize).map(|(_, j)| j).collect()
}

/// Runs the pose graph along the world's scans with `front_end` (see the module doc). `seed`
/// seeds the stochastic optimisers; `clock` returns seconds (each match is timed).
pub fn pose_graph(
    world: &World,
    front_end: Matcher<'_>,
    scan_matching: &ScanMatchingParams,
    params: &PoseGraphParams,
    graph_params: &GraphParams,
    motion: &MotionModel,
    seed: u64,
    clock: &mut dyn FnMut() -> f64,
) -> Result<PoseGraphRun, SlamError> {
    let raw_geometry = world.laser.ok_or(SlamError::MissingSensor("laser"))?;
    let (segmentation, geometry) = preparation(front_end, scan_matching, raw_geometry);
    let (pairs, steps) = pairs(world, scan_matching)?;
    let scan_at =
        |step: usize| world.scans.iter().find(|s| s.step == step).expect("a pair names scans");
    let cov = params.covariance();
    let c = params.cauchy_width;

    // the first node: where the front end's chaining has it, dead reckoning from the start
    let dead_reckoned = |from: Pose2, a: usize, b: usize| {
        world.odometry[a..b].iter().fold(from, |acc, d| acc.compose(*d))
    };
    let first_step = pairs.first().map_or(0, |p| p.reference_step);
    let start = dead_reckoned(world.truth[0], 0, first_step);
    let mut graph = Graph::new(start, graph_params);
    let mut node_steps = vec![first_step];
    let mut scans = vec![prepared(scan_at(first_step), &geometry, &segmentation)];
    let mut points = vec![returns(scan_at(first_step), &raw_geometry)];
    let (mut matches, mut closures) = (Vec::with_capacity(pairs.len()), Vec::new());
    for (k, pair) in pairs.iter().enumerate() {
        let (a, b) = (node_steps.len() - 1, node_steps.len());
        let current = prepared(scan_at(pair.current_step), &geometry, &segmentation);
        let t0 = clock();
        let result = run_matcher(
            front_end,
            &scans[a],
            &current,
            pair.initial,
            &scan_matching.objective,
            match_seed(seed, k),
        );
        let time_s = clock() - t0;
        matches.push(record(world, pair, &result, time_s));
        let z = if result.pose.is_finite() { result.pose } else { pair.initial };
        graph.add_pose(graph.poses()[a].compose(z));
        graph.add_relative(a, b, z, cov, c);
        if params.odometry_edges {
            let steps = &world.odometry[pair.reference_step..pair.current_step];
            let u = steps.iter().fold(Pose2::IDENTITY, |acc, d| acc.compose(*d));
            graph.add_relative(a, b, u, odometry_covariance(motion, steps), f64::INFINITY);
        }
        node_steps.push(pair.current_step);
        scans.push(current);
        points.push(returns(scan_at(pair.current_step), &raw_geometry));

        let mut closed = false;
        for j in candidates(graph.poses(), b, params) {
            let guess = graph.poses()[b].relative_to(graph.poses()[j]);
            let t0 = clock();
            let result = run_matcher(
                front_end,
                &scans[j],
                &scans[b],
                guess,
                &scan_matching.objective,
                closure_seed(seed, j, b),
            );
            let time_s = clock() - t0;
            let kept = result.pose.is_finite()
                && inlier_fraction(&points[j], &points[b], &result.pose, params.inlier_distance_m)
                    >= params.min_inlier_fraction;
            if kept {
                let pair = Pair {
                    reference_step: node_steps[j],
                    current_step: node_steps[b],
                    initial: guess,
                };
                closures.push(record(world, &pair, &result, time_s));
                graph.add_relative(j, b, result.pose, cov, c);
                closed = true;
            }
        }
        if closed && !graph.solve_warm() {
            graph.numerical_failures += 1;
        }
    }
    if !graph.solve() {
        graph.numerical_failures += 1;
    }

    // the trajectory: scan poses from the graph, the steps between by odometry
    let mut estimate = vec![world.truth[0]];
    for (node, &step) in node_steps.iter().enumerate() {
        while estimate.len() <= step {
            let k = estimate.len() - 1;
            estimate.push(estimate[k].compose(world.odometry[k]));
        }
        estimate[step] = graph.poses()[node];
    }
    while estimate.len() < steps {
        let k = estimate.len() - 1;
        estimate.push(estimate[k].compose(world.odometry[k]));
    }
    estimate.truncate(steps);
    Ok(PoseGraphRun {
        trace: Trace {
            estimate,
            numerical_failures: graph.numerical_failures,
            matches,
            loop_closures: Some(closures),
            ..Trace::default()
        },
        steps,
    })
}

#[cfg(test)]
mod tests;
