//! Diagnostics of single matches, the figures [EP] uses to show *why* a matcher lands where it
//! does, and the incremental maps of its appendix. Pure: (scans, initial guess, matchers) → data;
//! the run stage picks the match and stores the result, the report draws it.
//!
//! For one match (reference scan, current scan, initial guess, truth):
//! - **E-PSM's first orientation search** (Figs 25/33/50): f(θ) at the initial guess's position
//!   on the coarse grid (with its expansions) and on the fine grid, and Diosi's parabola through
//!   the coarse minimum and its neighbours (the "aproximación parabólica" drawn in cyan).
//! - **PSM's orientation criterion** (the quantity its parabola is fitted to): the mean absolute
//!   range residual e(di) of every shift of the range array, at the initial guess (its first
//!   pass) and at its estimate (the pass it converged with), with the heading change it picks.
//! - **f contours in x–y** (Figs 26/34/51) at the true heading around the true position, with
//!   every matcher's path: PSM's and E-PSM's poses after each (half-)iteration, the best pose so
//!   far of the others.
//! - **f per half-iteration** (Fig 27) and the best f against evaluations spent.
//!
//! Each diagnosed match is re-run with observers that cannot change the result; the record says
//! whether the re-run reproduced the stored estimate bit for bit.

use super::objective::{Objective, ObjectiveParams};
use super::psm::{PsmParams, orientation_profile};
use super::scan::PolarScan;
use super::track::Matcher;
use super::{Cost, MatchResult, epsm};
use crate::geom::Pose2;
use serde::{Deserialize, Serialize};

/// Points per side of the contour grid.
pub const CONTOUR_POINTS: usize = 41;
/// Smallest and largest half-width of the contour grid [m].
const CONTOUR_HALF_MIN_M: f64 = 0.05;
const CONTOUR_HALF_MAX_M: f64 = 1.0;
/// Size of an incremental map's cells [m].
pub const MAP_CELL_M: f64 = 0.02;

/// A study's diagnostics: which run they come from, the diagnosed matches, and the incremental
/// map of every algorithm of that run's cell.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    pub map: String,
    /// Sweep point label and replicate (the run the report's trajectory figure shows).
    pub point: String,
    pub replicate: u32,
    pub matches: Vec<MatchDiagnostic>,
    pub maps: Vec<IncrementalMap>,
}

/// One diagnosed match.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MatchDiagnostic {
    /// Match number, from 1.
    pub number: usize,
    /// Why this match: e.g. "the largest final f of E-PSM in this run".
    pub why: String,
    pub reference_step: usize,
    pub current_step: usize,
    /// True pose and initial guess of the current scan in the reference frame.
    pub truth: Pose2,
    pub initial: Pose2,
    /// E-PSM's first orientation search (when the study has E-PSM).
    pub orientation: Option<OrientationSlices>,
    /// PSM's criterion at the initial guess and at its estimate (when the study has PSM).
    pub psm: Vec<PsmProfile>,
    pub contour: Contour,
    pub paths: Vec<MatcherPath>,
}

/// f(θ) at fixed (x, y) as E-PSM's orientation search evaluates it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrientationSlices {
    /// The position the search runs at (the initial guess's) and its start heading.
    pub at: Pose2,
    /// (θ [rad], f [cm²]) of the coarse grid with its expansions, sorted by θ; f `None` = no pairs.
    pub coarse: Vec<(f64, Option<f64>)>,
    /// The fine grid around the coarse minimum, sorted by θ.
    pub fine: Vec<(f64, Option<f64>)>,
    /// Diosi's parabola through the coarse minimum and its two neighbours: (a, b, c) of
    /// f ≈ a·(θ − θ₀)² + b·(θ − θ₀) + c with θ₀ the coarse minimum; `None` at the grid's edge.
    pub parabola: Option<(f64, f64, f64, f64)>,
    /// The heading the search returns [rad].
    pub pick: f64,
}

/// PSM's orientation criterion at one pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PsmProfile {
    /// Algorithm name (`psm` or `psm_original`) and where: "initial guess" or "estimate".
    pub algorithm: String,
    pub at_label: String,
    pub at: Pose2,
    /// (heading at the shift [rad], e [cm]) per shift; e `None` = no pair.
    pub errors: Vec<(f64, Option<f64>)>,
    /// The heading the pass moves to [rad], and whether the parabola refined it.
    pub pick: Option<f64>,
    pub refined: bool,
}

/// f on a square grid at a fixed heading.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Contour {
    pub theta: f64,
    /// x and y of the grid's columns and rows [m].
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    /// f [cm²], row-major (`f[row * xs.len() + col]`); `None` = no pairs.
    pub f: Vec<Option<f64>>,
}

/// A matcher's path through one match.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MatcherPath {
    pub algorithm: String,
    /// How `poses` were taken: "per half-iteration" (PSM, E-PSM) or "best so far".
    pub kind: String,
    /// Poses (after each half-iteration, or each improvement of the best f), with f at each
    /// [cm²] and the evaluations spent to reach it.
    pub poses: Vec<Pose2>,
    pub f: Vec<Option<f64>>,
    pub evaluations: Vec<u64>,
    /// The re-run's estimate and f.
    pub estimate: Pose2,
    pub f_estimate: Option<f64>,
    /// Whether the re-run returned the stored estimate bit for bit.
    pub reproduces: bool,
}

/// The map an algorithm's chained poses build: every return of every matched scan placed at the
/// algorithm's estimate of its pose, as occupied cells of [`MAP_CELL_M`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IncrementalMap {
    pub algorithm: String,
    pub cell_m: f64,
    /// Occupied cells (i, j): the cell's centre is ((i + ½)·cell, (j + ½)·cell); sorted.
    pub cells: Vec<(i32, i32)>,
    /// The estimated poses of the scans (x, y), in order.
    pub path: Vec<(f64, f64)>,
    pub scans: usize,
}

/// A matcher with the name the diagnostics give it, its seed and the scans it matched (the
/// preparation can differ between matchers: `psm_original` uses PSM's own heuristics).
pub struct Subject<'a> {
    pub algorithm: String,
    pub matcher: Matcher<'a>,
    pub seed: u64,
    pub reference: &'a PolarScan,
    pub current: &'a PolarScan,
    /// The estimate the run stored for this match.
    pub stored: Pose2,
}

/// Diagnoses one match. `common` is the scan pair prepared with the study's segmentation (the
/// one f every matcher is scored by), on which the slices and the contour are computed.
pub fn diagnose(
    number: usize,
    why: String,
    steps: (usize, usize),
    (reference, current): (&PolarScan, &PolarScan),
    truth: Pose2,
    initial: Pose2,
    subjects: &[Subject<'_>],
    objective: &ObjectiveParams,
) -> MatchDiagnostic {
    let mut paths = Vec::new();
    let mut psm_profiles = Vec::new();
    let mut orientation = None;
    for s in subjects {
        let (result, path) = observe(s, initial, objective);
        match s.matcher {
            Matcher::Psm { params, .. } => psm_profiles.extend(psm_criterion(
                &s.algorithm,
                s.reference,
                s.current,
                initial,
                result.pose,
                params,
            )),
            Matcher::Epsm(params) if orientation.is_none() => {
                orientation = Some(orientation_slices(
                    &mut Objective::new(reference, current, objective),
                    initial,
                    &params.orientation,
                ))
            }
            _ => {}
        }
        paths.push(MatcherPath {
            algorithm: s.algorithm.clone(),
            kind: if matches!(s.matcher, Matcher::Psm { .. } | Matcher::Epsm(_)) {
                "per half-iteration"
            } else {
                "best so far"
            }
            .to_string(),
            poses: path.iter().map(|p| p.0).collect(),
            f: path.iter().map(|p| finite(p.1)).collect(),
            evaluations: path.iter().map(|p| p.2).collect(),
            estimate: result.pose,
            f_estimate: finite(result.f),
            reproduces: same_pose(result.pose, s.stored),
        });
    }
    let contour = contour(
        &mut Objective::new(reference, current, objective),
        truth,
        std::iter::once(initial).chain(paths.iter().map(|p| p.estimate)),
    );
    MatchDiagnostic {
        number,
        why,
        reference_step: steps.0,
        current_step: steps.1,
        truth,
        initial,
        orientation,
        psm: psm_profiles,
        contour,
        paths,
    }
}

fn finite(f: f64) -> Option<f64> {
    f.is_finite().then_some(f)
}

/// Bitwise equality (NaN equals NaN): a re-run reproduces a match exactly or not at all.
fn same_pose(a: Pose2, b: Pose2) -> bool {
    a.x.to_bits() == b.x.to_bits()
        && a.y.to_bits() == b.y.to_bits()
        && a.theta.to_bits() == b.theta.to_bits()
}

/// A cost that logs its f evaluations (pose, f, evaluations so far): every one, or only those
/// that improve the best f.
struct Logged<'c, C: Cost> {
    inner: &'c mut C,
    improvements_only: bool,
    seen: Vec<(Pose2, f64, u64)>,
}

impl<'c, C: Cost> Logged<'c, C> {
    fn new(inner: &'c mut C, improvements_only: bool) -> Self {
        Self { inner, improvements_only, seen: Vec::new() }
    }
}

impl<C: Cost> Cost for Logged<'_, C> {
    fn f(&mut self, pose: Pose2) -> f64 {
        let f = self.inner.f(pose);
        let keep =
            !self.improvements_only || (f.is_finite() && self.seen.last().is_none_or(|b| f < b.1));
        if keep {
            self.seen.push((pose, f, self.inner.evaluations()));
        }
        f
    }
    fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize {
        self.inner.residuals(pose, out)
    }
    fn beams(&self) -> usize {
        self.inner.beams()
    }
    fn evaluations(&self) -> u64 {
        self.inner.evaluations()
    }
}

/// Re-runs one matcher with an observer: its result and its path (pose, f, evaluations).
/// PSM and E-PSM report their iterates (f of each on a separate objective, so the matcher's own
/// evaluation count is untouched); the others their best pose so far.
fn observe(
    s: &Subject<'_>,
    initial: Pose2,
    objective: &ObjectiveParams,
) -> (MatchResult, Vec<(Pose2, f64, u64)>) {
    let mut cost = Objective::new(s.reference, s.current, objective);
    let mut iterates: Vec<Pose2> = Vec::new();
    let mut record = |p: Pose2| iterates.push(p);
    let (result, best) = match s.matcher {
        Matcher::Psm { params, .. } => {
            let r = super::psm::psm_observed(
                s.reference,
                s.current,
                initial,
                params,
                &mut cost,
                &mut record,
            )
            .expect("scans of one laser share their beam geometry");
            (r, None)
        }
        Matcher::Epsm(params) => {
            (epsm::epsm_observed(&mut cost, initial, params, &mut record), None)
        }
        Matcher::BruteForce(params) => {
            let mut rec = Logged::new(&mut cost, true);
            let r = super::brute::brute_force(&mut rec, initial, params);
            (r, Some(rec.seen))
        }
        Matcher::PoseSearch { optimizer, params } => {
            let mut rec = Logged::new(&mut cost, true);
            let r = super::search::simultaneous(&mut rec, initial, optimizer, params, s.seed);
            (r, Some(rec.seen))
        }
        Matcher::PlIcp(params) => {
            let r = super::plicp::pl_icp_observed(
                s.reference,
                s.current,
                initial,
                params,
                &mut cost,
                &mut record,
            );
            (r, None)
        }
    };
    let path = match best {
        Some(best) => best,
        None => {
            let mut scorer = Objective::new(s.reference, s.current, objective);
            std::iter::once(initial)
                .chain(iterates)
                .enumerate()
                .map(|(k, p)| (p, scorer.f(p), k as u64))
                .collect()
        }
    };
    (result, path)
}

/// PSM's criterion at the initial guess (its first pass) and at its estimate.
fn psm_criterion(
    algorithm: &str,
    reference: &PolarScan,
    current: &PolarScan,
    initial: Pose2,
    estimate: Pose2,
    params: &PsmParams,
) -> Vec<PsmProfile> {
    [("initial guess", initial), ("estimate", estimate)]
        .into_iter()
        .filter(|(_, at)| at.is_finite())
        .map(|(label, at)| {
            let p = orientation_profile(reference, current, at, params);
            PsmProfile {
                algorithm: algorithm.to_string(),
                at_label: label.to_string(),
                at,
                errors: p
                    .shifts_rad
                    .iter()
                    .zip(&p.errors_cm)
                    .map(|(s, e)| (at.theta + s, *e))
                    .collect(),
                pick: p.dtheta_rad.map(|d| at.theta + d),
                refined: p.refined,
            }
        })
        .collect()
}

/// E-PSM's first orientation search at `at` with every evaluation kept.
pub fn orientation_slices(
    cost: &mut impl Cost,
    at: Pose2,
    params: &epsm::OrientationParams,
) -> OrientationSlices {
    let mut log = Logged::new(cost, false);
    let result = epsm::orientation_search(&mut log, at, params);
    let coarse_count = (2.0 * (params.coarse_half_window_deg / params.coarse_step_deg).round())
        as usize
        + 1
        + result.expansions as usize;
    let unwrap = |theta: f64| at.theta + crate::geom::wrap_angle(theta - at.theta);
    let sorted = |v: &[(Pose2, f64, u64)]| {
        let mut v: Vec<(f64, Option<f64>)> =
            v.iter().map(|&(p, f, _)| (unwrap(p.theta), finite(f))).collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    };
    let coarse = sorted(&log.seen[..coarse_count.min(log.seen.len())]);
    let fine = sorted(&log.seen[coarse_count.min(log.seen.len())..]);
    OrientationSlices {
        at,
        parabola: diosi_parabola(&coarse),
        coarse,
        fine,
        pick: unwrap(result.theta),
    }
}

/// Diosi's parabola through the grid's smallest value and its two neighbours (equal spacing h):
/// (θ₀, a, b, c) with f ≈ a·(θ − θ₀)² + b·(θ − θ₀) + c; `None` at the edge or without values.
pub fn diosi_parabola(grid: &[(f64, Option<f64>)]) -> Option<(f64, f64, f64, f64)> {
    let k = (0..grid.len()).filter(|&k| grid[k].1.is_some()).min_by(|&a, &b| {
        grid[a].1.unwrap_or(f64::INFINITY).total_cmp(&grid[b].1.unwrap_or(f64::INFINITY))
    })?;
    if k == 0 || k + 1 >= grid.len() {
        return None;
    }
    let (em, e0, ep) = (grid[k - 1].1?, grid[k].1?, grid[k + 1].1?);
    let h = grid[k + 1].0 - grid[k].0;
    let a = (em + ep - 2.0 * e0) / (2.0 * h * h);
    let b = (ep - em) / (2.0 * h);
    Some((grid[k].0, a, b, e0))
}

/// The parabola's vertex θ₀ − b/(2a) (when it opens upwards).
pub fn vertex((theta0, a, b, _): (f64, f64, f64, f64)) -> Option<f64> {
    (a > 0.0).then(|| theta0 - b / (2.0 * a))
}

/// f at the true heading on a grid around the true position wide enough to hold `show` (the
/// initial guess and the estimates), between 5 cm and 1 m half-width.
fn contour(cost: &mut impl Cost, truth: Pose2, show: impl Iterator<Item = Pose2>) -> Contour {
    let reach = show
        .filter(|p| p.is_finite())
        .map(|p| (p.x - truth.x).abs().max((p.y - truth.y).abs()))
        .fold(0.0, f64::max);
    let half = (1.3 * reach).clamp(CONTOUR_HALF_MIN_M, CONTOUR_HALF_MAX_M);
    let n = CONTOUR_POINTS;
    let axis = |c: f64| {
        (0..n).map(|k| c - half + 2.0 * half * k as f64 / (n - 1) as f64).collect::<Vec<f64>>()
    };
    let (xs, ys) = (axis(truth.x), axis(truth.y));
    let f = ys
        .iter()
        .flat_map(|&y| xs.iter().map(move |&x| (x, y)))
        .map(|(x, y)| finite(cost.f(Pose2::new(x, y, truth.theta))))
        .collect();
    Contour { theta: truth.theta, xs, ys, f }
}

/// The occupied cells of the map built by placing each scan's returns at `poses[k]` (the laser
/// sits at the robot's pose).
pub fn incremental_map(
    algorithm: &str,
    scans: &[(&[Option<f64>], Pose2)],
    geometry: &crate::world::laser::LaserGeometry,
) -> IncrementalMap {
    let mut cells: Vec<(i32, i32)> = Vec::new();
    for (ranges, pose) in scans.iter().filter(|(_, p)| p.is_finite()) {
        for (beam, r) in ranges.iter().enumerate() {
            let Some(r) = r.filter(|r| r.is_finite()) else { continue };
            let b = geometry.bearing(beam);
            let p = pose.transform_point(crate::geom::Point2::new(r * b.cos(), r * b.sin()));
            cells.push(((p.x / MAP_CELL_M).floor() as i32, (p.y / MAP_CELL_M).floor() as i32));
        }
    }
    cells.sort_unstable();
    cells.dedup();
    IncrementalMap {
        algorithm: algorithm.to_string(),
        cell_m: MAP_CELL_M,
        cells,
        path: scans.iter().filter(|(_, p)| p.is_finite()).map(|(_, p)| (p.x, p.y)).collect(),
        scans: scans.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scanmatch::brute::BruteForceParams;
    use crate::scanmatch::epsm::EpsmParams;
    use crate::scanmatch::scan::testing::*;
    use crate::scanmatch::search::{Optimizer, SearchParams};

    #[test]
    fn parabola_through_three_points_has_the_known_vertex() {
        // f = 2 (θ − 0.3)² + 1 sampled at −1, 0, 1, 2
        let f = |t: f64| 2.0 * (t - 0.3) * (t - 0.3) + 1.0;
        let grid: Vec<(f64, Option<f64>)> =
            [-1.0, 0.0, 1.0, 2.0].iter().map(|&t| (t, Some(f(t)))).collect();
        let p = diosi_parabola(&grid).expect("interior minimum");
        assert!((vertex(p).unwrap() - 0.3).abs() < 1e-12);
        // the minimum on the edge has no parabola
        assert!(diosi_parabola(&grid[1..3]).is_none());
    }

    #[test]
    fn observed_matchers_reproduce_the_plain_ones_and_paths_end_at_the_estimate() {
        let truth = Pose2::new(0.32, -0.11, 4f64.to_radians());
        let (r, c) = room_pair(truth);
        let objective = ObjectiveParams::default();
        let initial = Pose2::new(0.25, -0.05, 1f64.to_radians());
        let (psm, epsm, brute, search) = (
            PsmParams::default(),
            EpsmParams::default(),
            BruteForceParams::default(),
            SearchParams::default(),
        );
        let matchers: Vec<(&str, Matcher<'_>)> = vec![
            ("psm", Matcher::Psm { params: &psm, own_heuristics: false }),
            ("epsm", Matcher::Epsm(&epsm)),
            ("brute_force", Matcher::BruteForce(&brute)),
            ("bobyqa", Matcher::PoseSearch { optimizer: Optimizer::Bobyqa, params: &search }),
        ];
        let mut subjects = Vec::new();
        for (name, m) in &matchers {
            let plain = super::super::track::run_matcher(*m, &r, &c, initial, &objective, 7);
            subjects.push(Subject {
                algorithm: name.to_string(),
                matcher: *m,
                seed: 7,
                reference: &r,
                current: &c,
                stored: plain.pose,
            });
        }
        let d =
            diagnose(3, "test".into(), (10, 20), (&r, &c), truth, initial, &subjects, &objective);
        assert_eq!(d.paths.len(), 4);
        for p in &d.paths {
            assert!(
                p.reproduces,
                "{}: the observed re-run must return the stored estimate",
                p.algorithm
            );
            let last = *p.poses.last().expect("a path");
            if p.kind == "per half-iteration" {
                assert_eq!(p.poses[0], initial, "{}", p.algorithm);
                assert!(
                    same_pose(last, p.estimate),
                    "{}: the last iterate is the estimate",
                    p.algorithm
                );
            } else {
                // best so far: f never rises
                let f: Vec<f64> = p.f.iter().map(|f| f.unwrap()).collect();
                assert!(f.windows(2).all(|w| w[1] < w[0]), "{}", p.algorithm);
            }
        }
        // a stored estimate that differs is reported as not reproduced
        let other = Subject {
            stored: Pose2::new(9.0, 9.0, 0.0),
            ..Subject {
                algorithm: "psm".into(),
                matcher: matchers[0].1,
                seed: 7,
                reference: &r,
                current: &c,
                stored: initial,
            }
        };
        assert!(
            !diagnose(1, String::new(), (0, 1), (&r, &c), truth, initial, &[other], &objective)
                .paths[0]
                .reproduces
        );
        // E-PSM's slices: the pick lies on the fine grid, whose minimum it is
        let o = d.orientation.as_ref().expect("E-PSM ran");
        assert!(
            o.coarse.len() >= 21 && o.fine.len() == 100,
            "coarse {} fine {}",
            o.coarse.len(),
            o.fine.len()
        );
        let fine_min = o
            .fine
            .iter()
            .filter_map(|(t, f)| f.map(|f| (*t, f)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let coarse_min = o
            .coarse
            .iter()
            .filter_map(|(t, f)| f.map(|f| (*t, f)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        let best = if fine_min.1 < coarse_min.1 { fine_min.0 } else { coarse_min.0 };
        assert!((o.pick - best).abs() < 1e-12, "pick {} vs grid minimum {}", o.pick, best);
        // PSM's criterion: first pass at the initial guess, then at its estimate
        assert_eq!(
            d.psm.iter().map(|p| p.at_label.as_str()).collect::<Vec<_>>(),
            ["initial guess", "estimate"]
        );
        // the contour holds the truth and the initial guess, and f is smallest near the truth
        let c = &d.contour;
        assert_eq!(c.f.len(), CONTOUR_POINTS * CONTOUR_POINTS);
        assert!(c.xs[0] <= initial.x && initial.x <= *c.xs.last().unwrap());
        let (kmin, _) =
            c.f.iter()
                .enumerate()
                .filter_map(|(k, f)| f.map(|f| (k, f)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
        let (x, y) = (c.xs[kmin % CONTOUR_POINTS], c.ys[kmin / CONTOUR_POINTS]);
        let cell = c.xs[1] - c.xs[0];
        assert!(
            (x - truth.x).abs() <= cell && (y - truth.y).abs() <= cell,
            "f is smallest at ({x}, {y}), the truth is ({}, {})",
            truth.x,
            truth.y
        );
    }

    #[test]
    fn psm_profile_picks_the_heading_change_of_psms_first_pass() {
        let truth = Pose2::new(0.1, 0.05, 3f64.to_radians());
        let (r, c) = room_pair(truth);
        let params = PsmParams::default();
        let initial = Pose2::new(0.1, 0.05, 0.0);
        let mut first = None;
        let mut cost = Objective::new(&r, &c, &ObjectiveParams::default());
        super::super::psm::psm_observed(&r, &c, initial, &params, &mut cost, &mut |p| {
            first.get_or_insert(p);
        })
        .unwrap();
        let profile = orientation_profile(&r, &c, initial, &params);
        let pick = initial.theta + profile.dtheta_rad.expect("overlap");
        // the first pass turns the heading only, by the profile's pick (PSM works in single precision)
        let first = first.expect("a pass");
        assert!((first.theta - pick).abs() < 1e-6, "{} vs {}", first.theta, pick);
        assert!((first.x - initial.x).abs() < 1e-6 && (first.y - initial.y).abs() < 1e-6);
        assert!(
            (pick - truth.theta).abs() < 1f64.to_radians(),
            "the pick turns towards the truth: {pick}"
        );
    }

    #[test]
    fn incremental_map_places_returns_at_the_pose() {
        let geometry = crate::world::laser::LaserGeometry {
            angle_min_rad: 0.0,
            angle_increment_rad: std::f64::consts::FRAC_PI_2,
            beams: 2,
            max_range_m: 10.0,
        };
        let ranges = [Some(1.0), None];
        let m = incremental_map(
            "a",
            &[
                (&ranges, Pose2::new(2.0, 3.0, std::f64::consts::FRAC_PI_2)),
                (&ranges, Pose2::new(f64::NAN, 0.0, 0.0)),
            ],
            &geometry,
        );
        // beam 0 (straight ahead) from (2, 3) facing +y lands at (2, 4); beam 1 has no return;
        // the non-finite pose places nothing
        assert_eq!(m.cells.len(), 1);
        let (i, j) = m.cells[0];
        let centre = ((f64::from(i) + 0.5) * MAP_CELL_M, (f64::from(j) + 0.5) * MAP_CELL_M);
        assert!(
            (centre.0 - 2.0).abs() <= MAP_CELL_M && (centre.1 - 4.0).abs() <= MAP_CELL_M,
            "{centre:?}"
        );
        assert_eq!((m.path.len(), m.scans), (1, 2));
    }
}
