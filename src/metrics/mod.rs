//! Run metrics: (World, Trace) → named numbers. Trajectory error follows evo's APE definition
//! (translation part, no alignment: both trajectories start at the same pose), with evo's names
//! (rmse, mean, median, max).

use crate::geom::{Line, Point2, Pose2, wrap_angle};
use crate::slam::{LandmarkMap, Trace};
use crate::world::World;

/// Bump when a metric's definition changes (part of every run's content hash).
pub const METRICS_VERSION: &str = "metrics-3";

/// A metric's documentation, shown in reports and the book.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MetricDef {
    pub name: &'static str,
    pub title: &'static str,
    pub unit: &'static str,
    pub description: &'static str,
    pub lower_is_better: bool,
}

pub const ATE_RMSE: &str = "ate_rmse_m";

/// Every metric the pipeline can produce, in display order.
pub const METRICS: &[MetricDef] = &[
    MetricDef {
        name: ATE_RMSE,
        title: "ATE RMSE",
        unit: "m",
        description: "root mean square of the position error over all steps (evo APE, translation; no alignment, except a rigid one where the truth is positions only: see the modelling choices)",
        lower_is_better: true,
    },
    MetricDef {
        name: "ate_x_rmse_m",
        title: "ATE RMSE in x",
        unit: "m",
        description: "root mean square of the x component of the position error over all steps (the map frame's x axis)",
        lower_is_better: true,
    },
    MetricDef {
        name: "ate_y_rmse_m",
        title: "ATE RMSE in y",
        unit: "m",
        description: "root mean square of the y component of the position error over all steps",
        lower_is_better: true,
    },
    MetricDef {
        name: "ate_x_share",
        title: "x share of the squared error",
        unit: "fraction",
        description: "Σ Δx² / Σ (Δx² + Δy²) over all steps (absent when the trajectory has no error): above 0.5 when the drift is mostly along x ([FT] claim 14: Complex's 40 m corridor along x)",
        lower_is_better: false,
    },
    MetricDef {
        name: "ate_mean_m",
        title: "ATE mean",
        unit: "m",
        description: "mean position error over all steps",
        lower_is_better: true,
    },
    MetricDef {
        name: "ate_median_m",
        title: "ATE median",
        unit: "m",
        description: "median position error over all steps",
        lower_is_better: true,
    },
    MetricDef {
        name: "ate_max_m",
        title: "ATE max",
        unit: "m",
        description: "largest position error over all steps",
        lower_is_better: true,
    },
    MetricDef {
        name: "final_position_error_m",
        title: "Final position error",
        unit: "m",
        description: "position error at the last step",
        lower_is_better: true,
    },
    MetricDef {
        name: "final_heading_error_deg",
        title: "Final heading error",
        unit: "deg",
        description: "absolute heading error at the last step, wrapped to [0, 180]",
        lower_is_better: true,
    },
    MetricDef {
        name: "path_length_m",
        title: "Path length",
        unit: "m",
        description: "length of the true trajectory",
        lower_is_better: false,
    },
    MetricDef {
        name: "numerical_failures",
        title: "Numerical failures",
        unit: "count",
        description: "numerical problems the algorithm met and survived",
        lower_is_better: true,
    },
    MetricDef {
        name: LANDMARK_ERROR,
        title: "Landmark error",
        unit: "m",
        description: "[FT] §5: mean, over the landmarks of the final map, of the distance to the nearest same-type true landmark (lines compared by their foot point (ρ cos θ, ρ sin θ)); ∞ when nothing is detected",
        lower_is_better: true,
    },
    MetricDef {
        name: LANDMARKS_DETECTED,
        title: "Landmarks detected",
        unit: "count",
        description: "landmarks (lines + corners) in the final map ([FT]'s \"hitos detectados\")",
        lower_is_better: false,
    },
    MetricDef {
        name: "lines_detected",
        title: "Lines detected",
        unit: "count",
        description: "lines in the final map",
        lower_is_better: false,
    },
    MetricDef {
        name: "corners_detected",
        title: "Corners detected",
        unit: "count",
        description: "corners in the final map",
        lower_is_better: false,
    },
    MetricDef {
        name: "landmarks_true",
        title: "True landmarks",
        unit: "count",
        description: "landmarks of the map's ground truth (8, 9, 16, 22, 26 for the [FT] maps)",
        lower_is_better: false,
    },
    MetricDef {
        name: "landmark_count_ratio",
        title: "Detected / true landmarks",
        unit: "ratio",
        description: "landmarks detected divided by the true count (1 = as many as there are)",
        lower_is_better: false,
    },
    MetricDef {
        name: "landmark_precision",
        title: "Landmark precision",
        unit: "fraction",
        description: "share of detected landmarks within 0.5 m of a same-type true landmark",
        lower_is_better: false,
    },
    MetricDef {
        name: "landmark_recall",
        title: "Landmark recall",
        unit: "fraction",
        description: "share of true landmarks with a same-type detected landmark within 0.5 m",
        lower_is_better: false,
    },
    MetricDef {
        name: MAP_RMSE,
        title: "Map RMS error",
        unit: "m",
        description: "[PF] Fig. 8b: root mean square, over the point landmarks of the final map, of the distance to their true landmark (the one they were created from under known association, else the nearest)",
        lower_is_better: true,
    },
    MetricDef {
        name: NEES_MEAN,
        title: "Mean pose NEES",
        unit: "",
        description: "normalised estimation error squared eᵀP⁻¹e of the filter's own pose belief — its mean (x, y, θ) against its covariance (particle filters: the weighted mean pose and the weighted spread about it) — averaged over the steps with truth and an invertible covariance (expected value 3 for a consistent filter)",
        lower_is_better: false,
    },
    MetricDef {
        name: NEES_IN_BOUNDS,
        title: "NEES within 95 % bounds",
        unit: "fraction",
        description: "share of steps whose pose NEES lies within the two-sided 95 % χ² interval for 3 degrees of freedom [0.216, 9.35] (0.95 for a consistent filter); a step with a singular covariance and a non-zero error counts as out of bounds",
        lower_is_better: false,
    },
    MetricDef {
        name: KALMAN_GAIN,
        title: "Mean pose Kalman gain",
        unit: "",
        description: "EKF-SLAM: the Frobenius norm of the pose rows of the Kalman gain K = P Hᵀ S⁻¹, averaged over every landmark update of the run (mixed units: m and rad per m and rad of innovation); how far the observations move the pose ([EV] C004-4)",
        lower_is_better: false,
    },
    MetricDef {
        name: NEES_SINGULAR,
        title: "Singular-covariance steps",
        unit: "count",
        description: "steps whose pose covariance is singular while the error is not zero (a particle set collapsed onto fewer than four poses): out of bounds for the NEES share, left out of the NEES mean",
        lower_is_better: true,
    },
    MetricDef {
        name: "neff_mean",
        title: "Mean N̂eff",
        unit: "particles",
        description: "effective sample size 1/Σw², averaged over the steps that weighted the particles",
        lower_is_better: false,
    },
    MetricDef {
        name: "resamples",
        title: "Resamples",
        unit: "count",
        description: "how many times the particles were resampled",
        lower_is_better: false,
    },
    // Scan matching ([EP] §5): errors of each match's estimated pose change in the reference frame.
    MetricDef {
        name: "ax_mean_mm",
        title: "Mean |ax|",
        unit: "mm",
        description: "[EP] ax: mean over the matches of |x error| of the estimated pose change, in the reference frame",
        lower_is_better: true,
    },
    MetricDef {
        name: "ax_max_mm",
        title: "Max |ax|",
        unit: "mm",
        description: "largest |x error| of a match's pose change",
        lower_is_better: true,
    },
    MetricDef {
        name: "ay_mean_mm",
        title: "Mean |ay|",
        unit: "mm",
        description: "[EP] ay: mean over the matches of |y error| of the estimated pose change, in the reference frame",
        lower_is_better: true,
    },
    MetricDef {
        name: "ay_max_mm",
        title: "Max |ay|",
        unit: "mm",
        description: "largest |y error| of a match's pose change",
        lower_is_better: true,
    },
    MetricDef {
        name: "atheta_mean_deg",
        title: "Mean |aθ|",
        unit: "deg",
        description: "[EP] atheta: mean over the matches of |heading error| of the estimated pose change",
        lower_is_better: true,
    },
    MetricDef {
        name: "atheta_max_deg",
        title: "Max |aθ|",
        unit: "deg",
        description: "largest |heading error| of a match's pose change",
        lower_is_better: true,
    },
    MetricDef {
        name: "match_trans_rmse_mm",
        title: "Match translation RMSE",
        unit: "mm",
        description: "root mean square over the matches of the position error √(ax² + ay²)",
        lower_is_better: true,
    },
    MetricDef {
        name: "match_rot_rmse_deg",
        title: "Match rotation RMSE",
        unit: "deg",
        description: "root mean square over the matches of the heading error",
        lower_is_better: true,
    },
    MetricDef {
        name: "initial_trans_mean_mm",
        title: "Mean initial-guess error",
        unit: "mm",
        description: "mean over the matches of the position error of the initial guess (the odometry): what the matcher had to correct",
        lower_is_better: true,
    },
    MetricDef {
        name: "f_mean",
        title: "Mean f",
        unit: "cm²",
        description: "[EP] Eq. 4 at the final pose, mean over the matches: mean squared range residual of the valid pairs (units: the book, docs/src/findings/ep.md)",
        lower_is_better: true,
    },
    MetricDef {
        name: "f_max",
        title: "Max f",
        unit: "cm²",
        description: "largest final f of a match",
        lower_is_better: true,
    },
    MetricDef {
        name: "evals_mean",
        title: "Evaluations per match",
        unit: "count",
        description: "objective evaluations (projections of the current scan) per match: the deterministic cost measure (times are in `make bench`)",
        lower_is_better: true,
    },
    MetricDef {
        name: "pairs_mean",
        title: "Valid pairs",
        unit: "count",
        description: "valid (reference, current) range pairs at the final pose, mean over the matches",
        lower_is_better: false,
    },
    MetricDef {
        name: "match_failure_rate",
        title: "Failed matches",
        unit: "fraction",
        description: "share of matches without a finite estimate or f (too few pairs, singular systems)",
        lower_is_better: true,
    },
    MetricDef {
        name: "fallback_rate",
        title: "f-check fallbacks",
        unit: "fraction",
        description: "share of matches where the f-check kept the odometry guess ([EP] §6.4)",
        lower_is_better: false,
    },
    MetricDef {
        name: "matches",
        title: "Matches",
        unit: "count",
        description: "scan matches in the run",
        lower_is_better: false,
    },
    MetricDef {
        name: "loop_closures",
        title: "Loop closures",
        unit: "count",
        description: "loop closures the laser pose graph kept (revisited scans matched and passing its overlap test)",
        lower_is_better: false,
    },
    MetricDef {
        name: "loop_closures_wrong",
        title: "Wrong loop closures",
        unit: "count",
        description: "kept loop closures whose relative pose is more than 0.2 m or 5° off the truth's (the gross-error gate of the PL-ICP comparison with CSM)",
        lower_is_better: true,
    },
    MetricDef {
        name: MAP_WALL_RMS,
        title: "Incremental-map RMS",
        unit: "mm",
        description: "the incremental map's sharpness ([EP] Figs 52–59): every return of every matched scan placed at the run's estimate of the scan's pose, RMS of its distance to the nearest wall of the map file (simulated maps only; noise-free scans at the true poses give 0)",
        lower_is_better: true,
    },
    MetricDef {
        name: LANDMARK_ERROR_GROWTH,
        title: "Landmark error growth along the path",
        unit: "m",
        description: "derived when a study is read, from its stored final maps, not when it runs (adding it left every cached run valid): the mean distance of a run's estimates of the true point landmarks after the first three, in the map's order (the order the robot meets them), minus that of the first three ([EV] C004-1); point-landmark worlds with known association; the one metric that can be negative",
        lower_is_better: false,
    },
];

pub const MAP_WALL_RMS: &str = "map_wall_rms_mm";

pub const LANDMARK_ERROR: &str = "landmark_error_m";
/// Derived when a study is read ([`landmark_error_growth`]), never stored with the runs.
pub const LANDMARK_ERROR_GROWTH: &str = "landmark_error_growth_m";
/// The landmarks [`landmark_error_growth`] counts as "the first": [EV]'s Tables 4.1–4.3 give its
/// first three landmarks, seen before any motion, the 1–4 cm of C004-1.
pub const GROWTH_FIRST_LANDMARKS: usize = 3;

/// [EV] C004-1's contrast for one run: the mean error of the true landmarks after the first
/// `first` (in the map's order) minus that of the first `first`, over the landmarks the run
/// mapped (`errors[i]` is None for a true landmark it did not map). NaN when a group is empty.
pub fn landmark_error_growth(errors: &[Option<f64>], first: usize) -> f64 {
    let mean = |s: &[Option<f64>]| {
        let v: Vec<f64> = s.iter().flatten().copied().collect();
        if v.is_empty() { f64::NAN } else { v.iter().sum::<f64>() / v.len() as f64 }
    };
    let k = first.min(errors.len());
    mean(&errors[k..]) - mean(&errors[..k])
}
pub const MAP_RMSE: &str = "map_rmse_m";
pub const NEES_MEAN: &str = "nees_mean";
pub const NEES_IN_BOUNDS: &str = "nees_in_bounds";
pub const NEES_SINGULAR: &str = "nees_singular_steps";
pub const KALMAN_GAIN: &str = "kalman_gain_mean";

/// Two-sided 95 % interval of χ² with 3 degrees of freedom (the pose NEES of a consistent
/// filter): χ²₃(0.025) and χ²₃(0.975).
pub const NEES_BOUNDS_3DOF: (f64, f64) = (0.215_795_3, 9.348_403_6);
pub const LANDMARKS_DETECTED: &str = "landmarks_detected";

/// Distance [m] within which a detected landmark counts as finding a true one (precision, recall).
/// The [FT] metric itself has no gate; half a metre separates the nearest distinct landmarks of
/// the [FT] maps (≥ 2 m apart) from their estimates comfortably.
pub const LANDMARK_GATE_M: f64 = 0.5;

pub fn metric_def(name: &str) -> Option<&'static MetricDef> {
    METRICS.iter().find(|m| m.name == name)
}

/// Named metric values of one run, in [`METRICS`] order.
pub type RunMetrics = Vec<(&'static str, f64)>;

/// The range every stored metric has: none can be negative (errors, counts, rates and lengths; +∞ is a
/// legitimate value, e.g. f where a match has no pairs, and NaN means "does not apply"). Returns
/// the first metric outside it.
pub fn out_of_range<'a>(
    metrics: impl IntoIterator<Item = (&'a str, f64)>,
) -> Option<(&'a str, f64)> {
    metrics.into_iter().find(|(_, v)| *v < 0.0)
}

/// Computes every metric that applies to this run.
pub fn compute(world: &World, trace: &Trace) -> RunMetrics {
    let mut out = if positions_only(&world.truth) {
        // GPS-like truth: positions in its own frame, no heading. Align the estimate to it first.
        trajectory_metrics(&world.truth, &align_to(&world.truth, &trace.estimate))
    } else {
        trajectory_metrics(&world.truth, &trace.estimate)
    };
    out.push(("numerical_failures", trace.numerical_failures as f64));
    if let Some(map) = &trace.map {
        if world.truth_points.is_empty() && map.points.is_empty() {
            out.extend(landmark_metrics(map, &world.truth_lines, &world.truth_corners));
        } else {
            out.extend(point_landmark_metrics(map, &world.truth_points));
        }
    }
    if !trace.pose_belief.is_empty() {
        out.extend(nees_metrics(&world.truth, &trace.pose_belief));
    }
    if !trace.matches.is_empty() {
        out.extend(match_metrics(&trace.matches));
    }
    if let Some(closures) = &trace.loop_closures {
        out.extend(loop_closure_metrics(closures));
    }
    if !trace.kalman_gain.is_empty() {
        out.push((
            KALMAN_GAIN,
            trace.kalman_gain.iter().sum::<f64>() / trace.kalman_gain.len() as f64,
        ));
    }
    let neff: Vec<f64> = trace.neff.iter().flatten().copied().collect();
    if !neff.is_empty() {
        out.push(("neff_mean", neff.iter().sum::<f64>() / neff.len() as f64));
        out.push(("resamples", trace.resamples as f64));
    }
    out
}

/// [EP] §5's per-match errors, aggregated as its tables (mean and max of absolute values), plus
/// RMS errors, cost and failure counts. Failed matches count in the failure rate only.
pub fn match_metrics(matches: &[crate::trace::MatchRecord]) -> RunMetrics {
    let ok: Vec<&crate::trace::MatchRecord> = matches.iter().filter(|m| m.succeeded()).collect();
    let errors: Vec<(f64, f64, f64)> = ok.iter().map(|m| m.error()).collect();
    let mean = |v: &mut dyn Iterator<Item = f64>| {
        let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
        if n == 0 { f64::NAN } else { s / n as f64 }
    };
    let max = |v: &mut dyn Iterator<Item = f64>| v.fold(f64::NAN, f64::max);
    const MM: f64 = 1e3;
    let n = matches.len() as f64;
    vec![
        ("ax_mean_mm", mean(&mut errors.iter().map(|e| e.0.abs() * MM))),
        ("ax_max_mm", max(&mut errors.iter().map(|e| e.0.abs() * MM))),
        ("ay_mean_mm", mean(&mut errors.iter().map(|e| e.1.abs() * MM))),
        ("ay_max_mm", max(&mut errors.iter().map(|e| e.1.abs() * MM))),
        ("atheta_mean_deg", mean(&mut errors.iter().map(|e| e.2.abs().to_degrees()))),
        ("atheta_max_deg", max(&mut errors.iter().map(|e| e.2.abs().to_degrees()))),
        (
            "match_trans_rmse_mm",
            mean(&mut errors.iter().map(|e| e.0 * e.0 + e.1 * e.1)).sqrt() * MM,
        ),
        ("match_rot_rmse_deg", mean(&mut errors.iter().map(|e| e.2 * e.2)).sqrt().to_degrees()),
        (
            "initial_trans_mean_mm",
            mean(
                &mut matches
                    .iter()
                    .map(|m| (m.initial.x - m.truth.x).hypot(m.initial.y - m.truth.y) * MM),
            ),
        ),
        ("f_mean", mean(&mut ok.iter().map(|m| m.f))),
        ("f_max", max(&mut ok.iter().map(|m| m.f))),
        // an external program's evaluations are its own, uncounted: none rather than 0
        (
            "evals_mean",
            mean(
                &mut matches
                    .iter()
                    .filter(|m| m.stop != crate::trace::EXTERNAL_STOP)
                    .map(|m| m.evaluations as f64),
            ),
        ),
        ("pairs_mean", mean(&mut ok.iter().map(|m| m.pairs as f64))),
        ("match_failure_rate", (matches.len() - ok.len()) as f64 / n),
        ("fallback_rate", matches.iter().filter(|m| m.fallback).count() as f64 / n),
        ("matches", n),
    ]
}

/// A loop closure is wrong when its relative pose is off the truth's by more than this
/// translation [m] or rotation [deg]: the gross-error gate of the PL-ICP comparison with CSM
/// (`tests/it/csm_reference.rs`), chosen there before any closure was made.
pub const WRONG_CLOSURE: (f64, f64) = (0.2, 5.0);

/// The laser pose graph's loop closures: how many it kept, and how many of them were wrong
/// ([`WRONG_CLOSURE`]).
pub fn loop_closure_metrics(closures: &[crate::trace::MatchRecord]) -> RunMetrics {
    let wrong = closures
        .iter()
        .filter(|m| {
            let (ax, ay, at) = m.error();
            ax.hypot(ay) > WRONG_CLOSURE.0 || at.abs().to_degrees() > WRONG_CLOSURE.1
        })
        .count();
    vec![("loop_closures", closures.len() as f64), ("loop_closures_wrong", wrong as f64)]
}

/// [`MAP_WALL_RMS`]: the returns of the scans taken at `steps`, placed at the estimated poses of
/// those steps (the laser sits at the robot's pose), against the walls; NaN when no return is
/// placed (no estimate, or no wall).
pub fn map_wall_rms(
    world: &World,
    estimate: &[crate::geom::Pose2],
    steps: &[usize],
    walls: &[crate::geom::Segment],
) -> f64 {
    let Some(geometry) = world.laser else { return f64::NAN };
    let (mut sum, mut n) = (0.0, 0usize);
    for scan in world.scans.iter().filter(|s| steps.binary_search(&s.step).is_ok()) {
        let Some(pose) = estimate.get(scan.step).filter(|p| p.is_finite()) else { continue };
        for (beam, r) in scan.ranges_m.iter().enumerate() {
            let Some(r) = r.filter(|r| r.is_finite()) else { continue };
            let b = geometry.bearing(beam);
            let p = pose.transform_point(Point2::new(r * b.cos(), r * b.sin()));
            let d = walls.iter().map(|w| w.distance_to_point(p)).fold(f64::INFINITY, f64::min);
            if d.is_finite() {
                sum += d * d;
                n += 1;
            }
        }
    }
    if n == 0 { f64::NAN } else { (sum / n as f64).sqrt() * 1e3 }
}

/// The [FT] §5 landmark metrics and their extensions, for a final map against the truth.
pub fn landmark_metrics(
    map: &LandmarkMap,
    true_lines: &[Line],
    true_corners: &[Point2],
) -> RunMetrics {
    // Every landmark as a point: lines by their foot point ([FT] Eqs. 10.1–10.3).
    let est_lines: Vec<Point2> = map.lines.iter().map(Line::foot_point).collect();
    let ref_lines: Vec<Point2> = true_lines.iter().map(Line::foot_point).collect();
    let nearest = |p: &Point2, refs: &[Point2]| {
        refs.iter().map(|r| r.distance(*p)).fold(f64::INFINITY, f64::min)
    };
    // Many-to-one: every detected landmark is matched to the nearest true one of its type.
    let errors: Vec<f64> = est_lines
        .iter()
        .map(|p| nearest(p, &ref_lines))
        .chain(map.corners.iter().map(|p| nearest(p, true_corners)))
        .collect();
    let detected = errors.len();
    let truth = true_lines.len() + true_corners.len();
    let error =
        if detected == 0 { f64::INFINITY } else { errors.iter().sum::<f64>() / detected as f64 };
    let precision = if detected == 0 {
        f64::NAN
    } else {
        errors.iter().filter(|&&e| e <= LANDMARK_GATE_M).count() as f64 / detected as f64
    };
    let found = ref_lines.iter().filter(|r| nearest(r, &est_lines) <= LANDMARK_GATE_M).count()
        + true_corners.iter().filter(|r| nearest(r, &map.corners) <= LANDMARK_GATE_M).count();
    let recall = if truth == 0 { f64::NAN } else { found as f64 / truth as f64 };
    vec![
        (LANDMARK_ERROR, error),
        (LANDMARKS_DETECTED, detected as f64),
        ("lines_detected", map.lines.len() as f64),
        ("corners_detected", map.corners.len() as f64),
        ("landmarks_true", truth as f64),
        (
            "landmark_count_ratio",
            if truth == 0 { f64::NAN } else { detected as f64 / truth as f64 },
        ),
        ("landmark_precision", precision),
        ("landmark_recall", recall),
    ]
}

/// Truth that has positions but no heading after the start pose (GPS fixes): it lives in its
/// own frame. (`truth[0]` is the start pose every algorithm is given, not a fix.)
pub fn positions_only(truth: &[Pose2]) -> bool {
    let fixes = truth.get(1..).unwrap_or(&[]);
    fixes.iter().any(|t| t.x.is_finite() && t.y.is_finite())
        && fixes.iter().all(|t| !t.theta.is_finite())
}

/// The estimate moved by the rigid 2-D transform (rotation + translation, no scale) that best
/// fits its positions to the truth's known positions in the least-squares sense (Umeyama 1991
/// without scale; evo's `--align`). Headings are rotated with it.
pub fn align_to(truth: &[Pose2], estimate: &[Pose2]) -> Vec<Pose2> {
    // the fixes only (position without heading): not the given start pose
    let pairs: Vec<(Point2, Point2)> = truth
        .iter()
        .zip(estimate)
        .filter(|(t, e)| {
            t.x.is_finite() && t.y.is_finite() && !t.theta.is_finite() && e.is_finite()
        })
        .map(|(t, e)| (t.position(), e.position()))
        .collect();
    if pairs.len() < 2 {
        return estimate.to_vec();
    }
    let n = pairs.len() as f64;
    let (mut mt, mut me) = (Point2::new(0.0, 0.0), Point2::new(0.0, 0.0));
    for (t, e) in &pairs {
        mt = Point2::new(mt.x + t.x / n, mt.y + t.y / n);
        me = Point2::new(me.x + e.x / n, me.y + e.y / n);
    }
    // rotation angle maximising Σ tᵢ·R eᵢ (centred): atan2(Σ e×t, Σ e·t)
    let (mut dot, mut cross) = (0.0, 0.0);
    for (t, e) in &pairs {
        let (tx, ty, ex, ey) = (t.x - mt.x, t.y - mt.y, e.x - me.x, e.y - me.y);
        dot += ex * tx + ey * ty;
        cross += ex * ty - ey * tx;
    }
    let phi = cross.atan2(dot);
    let (s, c) = phi.sin_cos();
    estimate
        .iter()
        .map(|e| {
            let (dx, dy) = (e.x - me.x, e.y - me.y);
            Pose2::new(mt.x + c * dx - s * dy, mt.y + s * dx + c * dy, wrap_angle(e.theta + phi))
        })
        .collect()
}

/// Landmark metrics of a point-landmark map: the [FT] error (mean distance to the nearest true
/// landmark), [PF]'s map RMS error (to the landmark each was created from when known), counts,
/// precision and recall within [`LANDMARK_GATE_M`].
pub fn point_landmark_metrics(map: &LandmarkMap, truth: &[Point2]) -> RunMetrics {
    let nearest = |p: &Point2, refs: &[Point2]| {
        refs.iter().map(|r| r.distance(*p)).fold(f64::INFINITY, f64::min)
    };
    let errors: Vec<f64> = map.points.iter().map(|p| nearest(p, truth)).collect();
    let own: Vec<f64> = map
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| match map.point_ids.get(i).copied().flatten().and_then(|id| truth.get(id)) {
            Some(t) => t.distance(*p),
            None => nearest(p, truth),
        })
        .collect();
    let detected = errors.len();
    let mean = |v: &[f64]| {
        if v.is_empty() { f64::INFINITY } else { v.iter().sum::<f64>() / v.len() as f64 }
    };
    let rmse = if own.is_empty() {
        f64::INFINITY
    } else {
        (own.iter().map(|e| e * e).sum::<f64>() / own.len() as f64).sqrt()
    };
    let precision = if detected == 0 {
        f64::NAN
    } else {
        errors.iter().filter(|&&e| e <= LANDMARK_GATE_M).count() as f64 / detected as f64
    };
    let found = truth.iter().filter(|t| nearest(t, &map.points) <= LANDMARK_GATE_M).count();
    let ratio = |n: f64| if truth.is_empty() { f64::NAN } else { n / truth.len() as f64 };
    vec![
        (LANDMARK_ERROR, mean(&errors)),
        (LANDMARKS_DETECTED, detected as f64),
        ("landmarks_true", truth.len() as f64),
        ("landmark_count_ratio", ratio(detected as f64)),
        ("landmark_precision", precision),
        ("landmark_recall", ratio(found as f64)),
        (MAP_RMSE, rmse),
    ]
}

/// Pose NEES eᵀP⁻¹e of the filter's belief (its own mean with its own covariance) at every step
/// with finite truth: the mean over the steps with an invertible covariance, the share within the
/// 95 % χ²₃ bounds, and the steps whose covariance is singular while the error is not zero. Those
/// are the most over-confident steps (a particle set collapsed onto fewer than four poses): they
/// count as out of bounds, never dropped; the mean, which they would make infinite, leaves them
/// out and the count says how many. A singular covariance with zero error (the known start) is
/// skipped.
pub fn nees_metrics(
    truth: &[Pose2],
    belief: &[Option<(Pose2, nalgebra::Matrix3<f64>)>],
) -> RunMetrics {
    let scored: Vec<Nees> = truth
        .iter()
        .zip(belief)
        .filter_map(|(t, b)| b.as_ref().map(|(m, p)| nees(t, m, p)))
        .collect();
    let values: Vec<f64> = scored
        .iter()
        .filter_map(|s| if let Nees::Value(v) = s { Some(*v) } else { None })
        .collect();
    let singular = scored.iter().filter(|s| matches!(s, Nees::Singular)).count();
    let counted = values.len() + singular;
    let (lo, hi) = NEES_BOUNDS_3DOF;
    let mean =
        if values.is_empty() { f64::NAN } else { values.iter().sum::<f64>() / values.len() as f64 };
    let in_bounds = if counted == 0 {
        f64::NAN
    } else {
        values.iter().filter(|&&v| v >= lo && v <= hi).count() as f64 / counted as f64
    };
    vec![(NEES_MEAN, mean), (NEES_IN_BOUNDS, in_bounds), (NEES_SINGULAR, singular as f64)]
}

/// The NEES of one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Nees {
    Value(f64),
    /// The covariance is singular and the error is not zero: unboundedly over-confident.
    Singular,
    /// No truth, or a singular covariance with zero error (the known start): not scored.
    Skipped,
}

/// eᵀP⁻¹e of one pose.
pub fn nees(truth: &Pose2, estimate: &Pose2, cov: &nalgebra::Matrix3<f64>) -> Nees {
    if !truth.is_finite() {
        return Nees::Skipped;
    }
    let e = nalgebra::Vector3::new(
        truth.x - estimate.x,
        truth.y - estimate.y,
        wrap_angle(truth.theta - estimate.theta),
    );
    let Some(chol) = nalgebra::Cholesky::new(*cov) else {
        return if e.iter().all(|v| *v == 0.0) { Nees::Skipped } else { Nees::Singular };
    };
    let v = e.dot(&chol.solve(&e));
    if v.is_finite() { Nees::Value(v) } else { Nees::Singular }
}

/// ATE statistics, final errors and path length. Pairs poses by step index; a shorter estimate is
/// a bug upstream, so the pairing stops at the shorter one and `final_*` use the last pair.
///
/// Real datasets lack truth at some steps (NaN poses): those steps are skipped, the final errors
/// use the last step with a true position, and the path length sums the known stretches.
pub fn trajectory_metrics(truth: &[Pose2], estimate: &[Pose2]) -> RunMetrics {
    let known = |t: &Pose2| t.x.is_finite() && t.y.is_finite();
    let pairs: Vec<(&Pose2, &Pose2)> =
        truth.iter().zip(estimate).filter(|(t, _)| known(t)).collect();
    let errors: Vec<f64> = pairs.iter().map(|(t, e)| t.position().distance(e.position())).collect();
    let n = errors.len() as f64;
    let rmse = (errors.iter().map(|e| e * e).sum::<f64>() / n).sqrt();
    let sq_x: f64 = pairs.iter().map(|(t, e)| (t.x - e.x).powi(2)).sum();
    let sq_y: f64 = pairs.iter().map(|(t, e)| (t.y - e.y).powi(2)).sum();
    let mean = errors.iter().sum::<f64>() / n;
    let max = errors.iter().copied().fold(f64::NAN, f64::max);
    let (final_pos, final_heading) = match pairs.last() {
        Some((t, e)) => {
            (t.position().distance(e.position()), wrap_angle(t.theta - e.theta).abs().to_degrees())
        }
        None => (f64::NAN, f64::NAN),
    };
    // consecutive known positions (sparse truth such as GPS: the path through its fixes)
    let known_positions: Vec<Point2> =
        truth.iter().filter(|t| known(t)).map(|t| t.position()).collect();
    let path_length = known_positions.windows(2).map(|w| w[0].distance(w[1])).sum();
    let mut out = vec![
        (ATE_RMSE, rmse),
        ("ate_x_rmse_m", (sq_x / n).sqrt()),
        ("ate_y_rmse_m", (sq_y / n).sqrt()),
        ("ate_mean_m", mean),
        ("ate_median_m", median(&errors)),
        ("ate_max_m", max),
        ("final_position_error_m", final_pos),
        ("final_heading_error_deg", final_heading),
        ("path_length_m", path_length),
    ];
    // undefined without any position error (then absent, as a metric the run does not have)
    if sq_x + sq_y > 0.0 {
        out.push(("ate_x_share", sq_x / (sq_x + sq_y)));
    }
    out
}

/// Median (mean of the two middle values for an even count); NaN when empty or any value is NaN.
pub fn median(values: &[f64]) -> f64 {
    if values.is_empty() || values.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(m: &RunMetrics, name: &str) -> f64 {
        m.iter().find(|(n, _)| *n == name).unwrap().1
    }

    #[test]
    fn landmark_error_growth_compares_later_landmarks_with_the_first() {
        let e = |v: &[f64]| v.iter().map(|x| Some(*x)).collect::<Vec<_>>();
        // the first three at 2 cm, the later ones at 10 and 20 cm: +13 cm
        let g = landmark_error_growth(&e(&[0.02, 0.02, 0.02, 0.10, 0.20]), 3);
        assert!((g - 0.13).abs() < 1e-12);
        // unmapped landmarks are left out; an empty group gives NaN
        let mut v = e(&[0.02, 0.04, 0.03, 0.30]);
        v[3] = None;
        assert!(landmark_error_growth(&v, 3).is_nan());
        assert!((landmark_error_growth(&e(&[0.3, 0.1]), 1) + 0.2).abs() < 1e-12, "can be negative");
    }

    #[test]
    fn identical_trajectories_have_zero_error() {
        let t: Vec<Pose2> = (0..10).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
        let m = trajectory_metrics(&t, &t);
        assert_eq!(get(&m, ATE_RMSE), 0.0);
        assert_eq!(get(&m, "final_heading_error_deg"), 0.0);
        assert_eq!(get(&m, "path_length_m"), 9.0);
    }

    #[test]
    fn ate_statistics_of_known_errors() {
        // position errors 0, 3, 4 (a 3-4-5 offset at the end)
        let truth =
            vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 0.0, 0.0), Pose2::new(2.0, 0.0, 3.0)];
        let est =
            vec![Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 3.0, 0.0), Pose2::new(2.0, 4.0, -3.0)];
        let m = trajectory_metrics(&truth, &est);
        assert!((get(&m, ATE_RMSE) - (25.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert!((get(&m, "ate_mean_m") - 7.0 / 3.0).abs() < 1e-12);
        assert_eq!(get(&m, "ate_median_m"), 3.0);
        assert_eq!(get(&m, "ate_max_m"), 4.0);
        assert_eq!(get(&m, "final_position_error_m"), 4.0);
        // all of the error is along y
        assert_eq!((get(&m, "ate_x_rmse_m"), get(&m, "ate_x_share")), (0.0, 0.0));
        assert!((get(&m, "ate_y_rmse_m") - (25.0f64 / 3.0).sqrt()).abs() < 1e-12);
        // a (3, 4) offset: x carries 9/25 of the squared error
        let mixed = trajectory_metrics(
            &truth[..2],
            &[Pose2::new(0.0, 0.0, 0.0), Pose2::new(4.0, 4.0, 0.0)],
        );
        assert!(
            (get(&mixed, "ate_x_share") - 9.0 / 25.0).abs() < 1e-12
                && (get(&mixed, "ate_x_rmse_m") - 4.5f64.sqrt()).abs() < 1e-12
        );
        // heading 3 vs −3 rad differ by 6 rad ≡ 2π − 6 ≈ 0.283 rad after wrapping
        assert!(
            (get(&m, "final_heading_error_deg") - (2.0 * std::f64::consts::PI - 6.0).to_degrees())
                .abs()
                < 1e-9
        );
    }

    #[test]
    fn thesis_landmark_error_matches_nearest_same_type_and_counts_duplicates() {
        let true_lines =
            [Line::normalised(1.0, -std::f64::consts::FRAC_PI_2), Line::normalised(19.0, 0.0)];
        let true_corners = [Point2::new(-1.0, -1.0), Point2::new(19.0, 9.0)];
        // one line 0.1 m off, a duplicate of it 0.3 m off, one corner 0.2 m off; the second true
        // line and corner are missed
        let map = LandmarkMap {
            lines: vec![
                Line::normalised(1.1, -std::f64::consts::FRAC_PI_2),
                Line::normalised(1.3, -std::f64::consts::FRAC_PI_2),
            ],
            corners: vec![Point2::new(-1.2, -1.0)],
            ..LandmarkMap::default()
        };
        let m = landmark_metrics(&map, &true_lines, &true_corners);
        let get = |n: &str| m.iter().find(|(k, _)| *k == n).unwrap().1;
        assert!((get(LANDMARK_ERROR) - 0.2).abs() < 1e-12); // (0.1 + 0.3 + 0.2) / 3: missed ones do not count
        assert_eq!(get(LANDMARKS_DETECTED), 3.0);
        assert!((get("landmark_precision") - 1.0).abs() < 1e-12);
        assert!((get("landmark_recall") - 0.5).abs() < 1e-12);
        assert!((get("landmark_count_ratio") - 0.75).abs() < 1e-12);
        // nothing detected: the thesis reports ∞
        let empty = landmark_metrics(&LandmarkMap::default(), &true_lines, &true_corners);
        assert_eq!(empty[0].1, f64::INFINITY);
    }

    #[test]
    fn every_computed_metric_is_documented() {
        let truth = vec![Pose2::IDENTITY; 3];
        let mut m = trajectory_metrics(&truth, &truth);
        m.extend(landmark_metrics(&LandmarkMap::default(), &[], &[]));
        m.extend(point_landmark_metrics(&LandmarkMap::default(), &[]));
        m.extend(nees_metrics(&truth, &[None, None, None]));
        for (name, _) in m {
            assert!(metric_def(name).is_some(), "{name} undocumented");
            assert!(!name.contains('.'), "metric names never contain a dot (parameter columns do)");
        }
    }

    #[test]
    fn point_map_rmse_uses_the_known_identity() {
        let truth = [Point2::new(0.0, 0.0), Point2::new(10.0, 0.0)];
        // landmark 1 estimated at x = 4: 4 m from landmark 0, 6 m from itself. The nearest-truth
        // error says 4; the map RMS error, which knows its identity, 6.
        let map = LandmarkMap {
            points: vec![Point2::new(0.3, 0.4), Point2::new(4.0, 0.0)],
            point_ids: vec![Some(0), Some(1)],
            ..LandmarkMap::default()
        };
        let m = point_landmark_metrics(&map, &truth);
        let get = |n: &str| m.iter().find(|(k, _)| *k == n).unwrap().1;
        assert!((get(MAP_RMSE) - ((0.25 + 36.0) / 2.0f64).sqrt()).abs() < 1e-12);
        assert!((get(LANDMARK_ERROR) - 2.25).abs() < 1e-12);
        assert_eq!(get("landmark_recall"), 0.5);
    }

    #[test]
    fn nees_of_a_known_error_and_unknown_truth_is_skipped() {
        let cov = nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(0.25, 1.0, 0.01));
        let truth =
            [Pose2::new(1.0, 0.0, 0.1), Pose2::new(f64::NAN, f64::NAN, f64::NAN), Pose2::IDENTITY];
        let belief = [
            Some((Pose2::new(0.0, 0.0, 0.0), cov)),
            Some((Pose2::IDENTITY, cov)),
            Some((Pose2::IDENTITY, nalgebra::Matrix3::zeros())),
        ];
        let m = nees_metrics(&truth, &belief);
        // 1²/0.25 + 0.1²/0.01 = 5; the NaN step and the known start (singular, no error) are skipped
        assert!((m[0].1 - 5.0).abs() < 1e-9);
        assert_eq!(m[1].1, 1.0);
        assert_eq!(m[2], (NEES_SINGULAR, 0.0));
    }

    /// A collapsed particle set (singular spread) with a non-zero error is counted, out of bounds.
    #[test]
    fn singular_spreads_with_an_error_count_out_of_bounds() {
        let cov = nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(0.25, 1.0, 0.01));
        let truth = [Pose2::new(1.0, 0.0, 0.1), Pose2::new(2.0, 0.0, 0.0)];
        let belief = [
            Some((Pose2::new(0.0, 0.0, 0.0), cov)),
            Some((Pose2::new(2.1, 0.0, 0.0), nalgebra::Matrix3::zeros())),
        ];
        let m = nees_metrics(&truth, &belief);
        assert!((m[0].1 - 5.0).abs() < 1e-9, "the mean leaves the singular step out");
        assert_eq!(m[1].1, 0.5, "the singular step is out of bounds");
        assert_eq!(m[2], (NEES_SINGULAR, 1.0));
    }

    #[test]
    fn steps_without_truth_are_skipped() {
        let nan = Pose2::new(f64::NAN, f64::NAN, f64::NAN);
        let truth = vec![Pose2::IDENTITY, nan, Pose2::new(2.0, 0.0, 0.0), nan];
        let est = vec![
            Pose2::IDENTITY,
            Pose2::new(5.0, 5.0, 0.0),
            Pose2::new(2.0, 1.0, 0.0),
            Pose2::new(9.0, 9.0, 0.0),
        ];
        let m = trajectory_metrics(&truth, &est);
        assert!((get(&m, ATE_RMSE) - 0.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(get(&m, "final_position_error_m"), 1.0);
        assert_eq!(get(&m, "path_length_m"), 2.0, "the path through the known positions");
    }

    #[test]
    fn no_metric_may_be_negative() {
        assert_eq!(
            out_of_range([("ate_rmse_m", 0.3), ("f_mean", f64::INFINITY), ("nees_mean", f64::NAN)]),
            None
        );
        assert_eq!(
            out_of_range([("ate_rmse_m", 0.3), ("landmark_error_m", -3.1e58)]),
            Some(("landmark_error_m", -3.1e58))
        );
        assert_eq!(
            out_of_range([("resamples", f64::NEG_INFINITY)]).map(|(k, _)| k),
            Some("resamples")
        );
    }

    #[test]
    fn alignment_recovers_a_rigid_transform() {
        let est: Vec<Pose2> =
            (0..20).map(|i| Pose2::new(i as f64 * 0.5, (i as f64 * 0.3).sin(), 0.1)).collect();
        let (phi, tx, ty) = (0.7f64, 3.0, -2.0);
        let truth: Vec<Pose2> = est
            .iter()
            .enumerate()
            .map(|(i, e)| {
                if i % 3 == 0 {
                    Pose2::new(
                        e.x * phi.cos() - e.y * phi.sin() + tx,
                        e.x * phi.sin() + e.y * phi.cos() + ty,
                        f64::NAN,
                    )
                } else {
                    Pose2::new(f64::NAN, f64::NAN, f64::NAN)
                }
            })
            .collect();
        assert!(positions_only(&truth));
        let aligned = align_to(&truth, &est);
        let m = trajectory_metrics(&truth, &aligned);
        assert!(get(&m, ATE_RMSE) < 1e-9, "{}", get(&m, ATE_RMSE));
        assert!((aligned[0].theta - 0.8).abs() < 1e-9);
    }
}
