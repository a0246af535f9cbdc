//! E-PSM's alternating pose search ([EP] §5.3.1, Fig 6; reference §3.5 and the pseudocode of
//! §3.9): ([`Cost`], initial guess) → [`MatchResult`]. Even half-iterations search the
//! orientation by brute force on f, re-projecting the scan for every candidate θ (no
//! shift-invariance assumption, unlike Diosi's PSM); odd half-iterations update the position by
//! unweighted least squares (Eq. 5–6) with a central-difference Jacobian, or — the Fig 7
//! variant of [EP] Table 5 — by minimising f(x, y | θ) with NLopt's BOBYQA. An optional f-check
//! ([EP] §6.4) returns the initial guess when the estimate does not lower f.
//!
//! Choices where [EP] is silent (each an [`EpsmParams`] field; reference §3.5 [ASSUMPTION]s):
//! - A cycle is one orientation + one position half-iteration. It converges when, for
//!   `small_cycles` consecutive cycles, |δx| + |δy| < `tol_xy_m` and |δθ| < `tol_theta_deg`, or
//!   when f after the cycle's orientation search fell by less than `ftol_rel` (relative) since the
//!   previous cycle; either only after `min_iter` half-iterations (8, Fig 27).
//! - The coarse orientation window expands while f keeps falling past its edge, at most
//!   `max_expansion_steps` steps; grid ties go to the candidate nearest the current θ.
//! - The Gauss–Newton step uses only beams valid at the centre and at all four ±h evaluations;
//!   |Hᵀ H| ≤ 1e-10 · trace² is singular ([`Stop::Singular`]).
//! - f after each position half-iteration comes for free as the centre (k = 0) of the next
//!   coarse grid; only the final pose costs two extra evaluations (f and the pair count).
//! - A failure mid-search (no finite f at any θ, no pairs, singular system) keeps the last pose
//!   whose f was finite (or the initial guess) and records why in `stop`.

use super::search::{ScaledCost, pairs_at, seed_nlopt};
use super::{Cost, MatchResult, Stop};
use crate::config::{Checks, Violation};
use crate::geom::{Pose2, wrap_angle};
use nlopt::{Algorithm, FailState, Nlopt, Target};
use serde::{Deserialize, Serialize};

/// |Hᵀ H| ≤ this · trace(Hᵀ H)² ⇒ the 2 × 2 normal equations are singular (a relative test, so it
/// does not depend on how many beams there are; 1e-10 is a condition number of about 4e10).
const SINGULAR_DET_REL: f64 = 1e-10;

/// Relative margin on the θ tolerance: the orientation search moves θ by whole fine-grid steps,
/// so with the default tol_theta = one step a change of exactly one step must count as "not
/// small" whatever the rounding of k·step.
const TOL_THETA_MARGIN: f64 = 1e-9;

/// Seed for NLopt's generator before the BOBYQA position step. BOBYQA draws no random numbers;
/// seeding only stops NLopt from seeding itself from the clock.
const BOBYQA_SEED: u64 = 0;

/// `[scanmatch.epsm.orientation]`: E-PSM's brute-force orientation search ([EP] §5.3.1 step 1–3),
/// shared with the brute-force reference (§6.1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct OrientationParams {
    /// Coarse grid step [deg]. Default 1 ([EP] L151).
    pub coarse_step_deg: f64,
    /// Coarse half-window around the current θ [deg]. Default 10 (21 candidates, [EP] L151).
    pub coarse_half_window_deg: f64,
    /// At most this many coarse steps beyond the window edge while f keeps decreasing ([EP]:
    /// "until a relative minimum"; no cap stated). Default 20, i.e. ±30° in all.
    pub max_expansion_steps: u32,
    /// Fine grid step [deg]. Default 0.01 ([EP] L151).
    pub fine_step_deg: f64,
    /// Fine half-window around the coarse minimum [deg]. Default 0.5 (101 candidates, [EP] L151).
    pub fine_half_window_deg: f64,
}

impl Default for OrientationParams {
    fn default() -> Self {
        Self {
            coarse_step_deg: 1.0,
            coarse_half_window_deg: 10.0,
            max_expansion_steps: 20,
            fine_step_deg: 0.01,
            fine_half_window_deg: 0.5,
        }
    }
}

impl OrientationParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.in_range("coarse_step_deg", self.coarse_step_deg, f64::MIN_POSITIVE, 90.0);
        c.in_range("coarse_half_window_deg", self.coarse_half_window_deg, 0.0, 180.0);
        c.in_range("fine_step_deg", self.fine_step_deg, f64::MIN_POSITIVE, 90.0);
        c.in_range("fine_half_window_deg", self.fine_half_window_deg, 0.0, 180.0);
        if self.coarse_step_deg > 0.0 && self.coarse_half_window_deg.is_finite() {
            c.require(
                self.coarse_half_window_deg / self.coarse_step_deg <= MAX_GRID_HALF,
                "coarse_half_window_deg",
                || format!("must be ≤ {MAX_GRID_HALF} coarse steps"),
            );
        }
        if self.fine_step_deg > 0.0 && self.fine_half_window_deg.is_finite() {
            c.require(
                self.fine_half_window_deg / self.fine_step_deg <= MAX_GRID_HALF,
                "fine_half_window_deg",
                || format!("must be ≤ {MAX_GRID_HALF} fine steps"),
            );
        }
        c.finish()
    }
}

/// Largest grid half-width in steps (a sanity bound: 10⁴ steps = 20 001 evaluations).
const MAX_GRID_HALF: f64 = 1.0e4;

/// How the odd half-iterations update the position.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum PositionStep {
    /// Unweighted least squares, δ = (HᵀH)⁻¹Hᵀr with a central-difference H (Eq. 5–6, Fig 6;
    /// [EP] Tables 2–3).
    #[default]
    GaussNewton,
    /// Minimise f(x, y | θ) with NLopt LN_BOBYQA (Fig 7; [EP] Table 5).
    Bobyqa,
}

/// `[scanmatch.epsm.bobyqa]`: the BOBYQA position step (Fig 7). [EP] gives no tolerances.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct BobyqaParams {
    /// Half-width of the (x, y) box around the current position [m]. Default 0.4 (as the
    /// simultaneous search and the brute force).
    pub half_window_m: f64,
    /// Initial trust-region radius [m]. Default 0.01: odometry errors per match are cm-sized.
    pub initial_step_m: f64,
    /// `xtol_abs` in x and y [m]. Default 1e-5 (0.01 mm), below E-PSM's 0.1 mm cycle tolerance.
    pub xtol_m: f64,
    /// `maxeval` per position step. Default 200.
    pub maxeval: u32,
    /// P [cm²]: BOBYQA sees P·(1 + |u|²) where f = ∞ (see [`super::search`]). Default 1e6.
    pub infeasible_f_cm2: f64,
}

impl Default for BobyqaParams {
    fn default() -> Self {
        Self {
            half_window_m: 0.4,
            initial_step_m: 0.01,
            xtol_m: 1e-5,
            maxeval: 200,
            infeasible_f_cm2: 1e6,
        }
    }
}

impl BobyqaParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.positive("half_window_m", self.half_window_m);
        c.positive("initial_step_m", self.initial_step_m);
        if self.initial_step_m.is_finite() && self.half_window_m.is_finite() {
            c.require(self.initial_step_m <= self.half_window_m, "initial_step_m", || {
                format!(
                    "must be ≤ half_window_m ({}), got {}",
                    self.half_window_m, self.initial_step_m
                )
            });
        }
        c.positive("xtol_m", self.xtol_m);
        c.require(self.maxeval >= 5, "maxeval", || {
            format!("must be ≥ 5 (BOBYQA's 2n + 1 start points), got {}", self.maxeval)
        });
        c.positive("infeasible_f_cm2", self.infeasible_f_cm2);
        c.finish()
    }
}

/// `[scanmatch.epsm]`: E-PSM ([EP] §5.3.1). Defaults: [EP]'s grids, and the reference's
/// [ASSUMPTION]s where the document is silent (§3.5, §9).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct EpsmParams {
    /// The orientation search.
    pub orientation: OrientationParams,
    /// The position update. Default Gauss–Newton (Fig 6); `bobyqa` is Fig 7.
    pub position_step: PositionStep,
    /// Central-difference step h of the Jacobian H [m]. Default 1e-3 ([ASSUMPTION] 1 mm).
    pub fd_step_m: f64,
    /// The BOBYQA position step (used when `position_step = "bobyqa"`).
    pub bobyqa: BobyqaParams,
    /// Half-iterations always run [count]. Default 8 (4 orientation + 4 position, inferred from
    /// Fig 27).
    pub min_iter: u32,
    /// Half-iterations at most [count]. Default 30 (Diosi's PM_MAX_ITER).
    pub max_iter: u32,
    /// A cycle is small when |δx| + |δy| < this [m]. Default 1e-4 (0.1 mm).
    pub tol_xy_m: f64,
    /// … and |δθ| < this [deg]. Default 0.01 (the fine grid step).
    pub tol_theta_deg: f64,
    /// Consecutive small cycles that stop the search [count]. Default 2.
    pub small_cycles: u32,
    /// Or stop when f fell by less than this fraction since the previous cycle [–]; 0 = off.
    /// Default 1e-6.
    pub ftol_rel: f64,
    /// If f(estimate) ≥ f(initial guess), return the initial guess (`fallback`) ([EP] §6.4,
    /// Table 5). Default false ([EP] Tables 2–3).
    pub f_check: bool,
}

impl Default for EpsmParams {
    fn default() -> Self {
        Self {
            orientation: OrientationParams::default(),
            position_step: PositionStep::GaussNewton,
            fd_step_m: 1e-3,
            bobyqa: BobyqaParams::default(),
            min_iter: 8,
            max_iter: 30,
            tol_xy_m: 1e-4,
            tol_theta_deg: 0.01,
            small_cycles: 2,
            ftol_rel: 1e-6,
            f_check: false,
        }
    }
}

impl EpsmParams {
    /// [EP] Table 5's "E-PSM": the BOBYQA position step and the f-check.
    pub fn table5() -> Self {
        Self { position_step: PositionStep::Bobyqa, f_check: true, ..Self::default() }
    }

    /// The report's sentence on E-PSM: orientation grids, position step, iteration bounds,
    /// convergence tolerances and the f-check.
    pub fn describe(&self) -> String {
        format!(
            "E-PSM ([EP] §5.3.1): orientation on a {}° grid over ±{}° (expanded while f falls), then {}° over ±{}°; position by {}; at least {} and at most {} half-iterations, converged when |δx| + |δy| < {} mm and |δθ| < {}° for {} cycles; f-check {}.",
            self.orientation.coarse_step_deg,
            self.orientation.coarse_half_window_deg,
            self.orientation.fine_step_deg,
            self.orientation.fine_half_window_deg,
            match self.position_step {
                PositionStep::GaussNewton => format!(
                    "an unweighted Gauss–Newton step with a central-difference Jacobian ({} mm)",
                    self.fd_step_m * 1e3
                ),
                PositionStep::Bobyqa => "NLopt's BOBYQA on f(x, y | θ) ([EP] Fig. 7)".to_string(),
            },
            self.min_iter,
            self.max_iter,
            self.tol_xy_m * 1e3,
            self.tol_theta_deg,
            self.small_cycles,
            if self.f_check {
                "on: an estimate whose f is not below the initial guess's is replaced by the guess ([EP] §6.4)"
            } else {
                "off"
            }
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.nested("orientation", self.orientation.validate());
        c.nested("bobyqa", self.bobyqa.validate());
        c.positive("fd_step_m", self.fd_step_m);
        c.require(self.max_iter >= 1, "max_iter", || "must be ≥ 1".to_string());
        c.require(self.min_iter <= self.max_iter, "min_iter", || {
            format!("must be ≤ max_iter ({}), got {}", self.max_iter, self.min_iter)
        });
        c.non_negative("tol_xy_m", self.tol_xy_m);
        c.non_negative("tol_theta_deg", self.tol_theta_deg);
        c.require(self.small_cycles >= 1, "small_cycles", || "must be ≥ 1".to_string());
        c.non_negative("ftol_rel", self.ftol_rel);
        c.finish()
    }
}

/// E-PSM ([EP] §5.3.1, Fig 6/7; pseudocode reference §3.9).
pub fn epsm(cost: &mut impl Cost, initial: Pose2, params: &EpsmParams) -> MatchResult {
    epsm_observed(cost, initial, params, &mut |_| {})
}

/// [`epsm`], telling `observe` the pose after every half-iteration that completes (Fig 27's
/// iterates): the path the diagnostics draw. The observer cannot change the result.
pub fn epsm_observed(
    cost: &mut impl Cost,
    initial: Pose2,
    params: &EpsmParams,
    observe: &mut dyn FnMut(Pose2),
) -> MatchResult {
    let evaluations_start = cost.evaluations();
    let tol_theta = params.tol_theta_deg.to_radians() * (1.0 - TOL_THETA_MARGIN);
    let mut buffers = JacobianBuffers::new(cost.beams());

    let mut pose = initial;
    let mut f_initial = f64::INFINITY;
    let mut last_good: Option<(Pose2, f64)> = None;
    let mut f_cycle = f64::INFINITY; // f after this cycle's orientation search
    let mut f_previous_cycle: Option<f64> = None;
    let mut delta_theta = 0.0;
    let mut small = 0;
    let mut iterations = 0;
    let mut stop = Stop::Budget;

    for it in 0..params.max_iter {
        iterations = it + 1;
        if it % 2 == 0 {
            // Orientation half-iteration ([EP] §5.3.1 steps 1–3).
            let o = orientation_search(cost, pose, &params.orientation);
            if it == 0 {
                f_initial = o.f_start;
            }
            if !o.f.is_finite() {
                stop = Stop::TooFewPairs;
                break;
            }
            delta_theta = wrap_angle(o.theta - pose.theta);
            pose.theta = o.theta;
            f_cycle = o.f;
            last_good = Some((pose, o.f));
            observe(pose);
        } else {
            // Position half-iteration: Eq. 5–6, or BOBYQA (Fig 7).
            let step = match params.position_step {
                PositionStep::GaussNewton => {
                    gauss_newton_step(cost, pose, params.fd_step_m, &mut buffers)
                }
                PositionStep::Bobyqa => bobyqa_step(cost, pose, &params.bobyqa),
            };
            let (dx, dy) = match step {
                Ok(d) => d,
                Err(s) => {
                    stop = s;
                    break;
                }
            };
            pose.x += dx;
            pose.y += dy;
            observe(pose);
            // End of a cycle: the convergence test.
            small = if dx.abs() + dy.abs() < params.tol_xy_m && delta_theta.abs() < tol_theta {
                small + 1
            } else {
                0
            };
            let f_stalled =
                f_previous_cycle.is_some_and(|fp| fp - f_cycle <= params.ftol_rel * fp.abs());
            f_previous_cycle = Some(f_cycle);
            if it + 1 >= params.min_iter && (small >= params.small_cycles || f_stalled) {
                stop = Stop::Converged;
                break;
            }
        }
    }

    // The estimate: the final pose, unless the search failed or left it without a finite f.
    let (mut pose, mut f) = match stop {
        Stop::Converged | Stop::Budget => (pose, cost.f(pose)),
        _ => last_good.unwrap_or((initial, f_initial)),
    };
    if !f.is_finite() && matches!(stop, Stop::Converged | Stop::Budget) {
        (pose, f) = last_good.unwrap_or((initial, f_initial));
        stop = Stop::TooFewPairs;
    }
    // The f-check ([EP] §6.4): an estimate that does not lower f is rejected.
    let fallback = params.f_check && f >= f_initial; // both finite or +∞, never NaN
    if fallback {
        (pose, f) = (initial, f_initial);
    }
    let pairs = pairs_at(cost, pose);
    MatchResult {
        pose,
        f,
        f_initial,
        pairs,
        iterations,
        evaluations: cost.evaluations() - evaluations_start,
        fallback,
        stop,
    }
}

/// Outcome of one orientation search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientationResult {
    /// The best θ found [rad] (the start θ when no candidate had a finite f).
    pub theta: f64,
    /// f at `theta` [cm²]; ∞ when no candidate had a finite f.
    pub f: f64,
    /// f at the start pose [cm²] (the coarse grid's centre).
    pub f_start: f64,
    /// Coarse steps taken beyond the window edge.
    pub expansions: u32,
    /// Evaluations of f spent.
    pub evaluations: u32,
}

/// E-PSM's orientation search at fixed (x, y) ([EP] §5.3.1 steps 1–3): f on a coarse grid
/// around `pose.theta` (1° over ±10°); if the minimum is on the window's edge, further 1° steps
/// in that direction while f decreases (a relative minimum), at most `max_expansion_steps`; then
/// a fine grid (0.01° over ±0.5°) around the coarse minimum. f is re-evaluated (re-projected) at
/// every candidate. The coarse minimum is the fine grid's centre and is not evaluated twice.
pub fn orientation_search(
    cost: &mut impl Cost,
    pose: Pose2,
    params: &OrientationParams,
) -> OrientationResult {
    let at = |theta: f64| Pose2::new(pose.x, pose.y, wrap_angle(theta));
    let mut evaluations = 0u32;
    let mut eval = |cost: &mut _, theta: f64| {
        evaluations += 1;
        finite_or_inf(Cost::f(cost, at(theta)))
    };

    // Step 1: the coarse grid.
    let coarse = params.coarse_step_deg.to_radians();
    let n = grid_half(params.coarse_half_window_deg, params.coarse_step_deg);
    let values: Vec<f64> =
        (-n..=n).map(|k| eval(&mut *cost, pose.theta + f64::from(k) * coarse)).collect();
    let f_start = values[n as usize];
    let (mut k_best, mut f_best) = grid_argmin(&values, n);

    // Step 2: expand past the edge while f keeps falling, until a relative minimum.
    let mut expansions = 0;
    if f_best.is_finite() && k_best.abs() == n && n > 0 {
        let direction = k_best.signum();
        while expansions < params.max_expansion_steps {
            let k = k_best + direction;
            let f = eval(&mut *cost, pose.theta + f64::from(k) * coarse);
            expansions += 1;
            if f < f_best {
                (k_best, f_best) = (k, f);
            } else {
                break;
            }
        }
    }
    let theta_coarse = pose.theta + f64::from(k_best) * coarse;

    // Step 3: the fine grid around the coarse minimum.
    let (theta, f) = if f_best.is_finite() {
        let fine = params.fine_step_deg.to_radians();
        let m = grid_half(params.fine_half_window_deg, params.fine_step_deg);
        let values: Vec<f64> =
            (-m..=m)
                .map(|k| {
                    if k == 0 {
                        f_best
                    } else {
                        eval(&mut *cost, theta_coarse + f64::from(k) * fine)
                    }
                })
                .collect();
        let (k_fine, f_fine) = grid_argmin(&values, m);
        (theta_coarse + f64::from(k_fine) * fine, f_fine)
    } else {
        (pose.theta, f64::INFINITY)
    };
    OrientationResult { theta: wrap_angle(theta), f, f_start, expansions, evaluations }
}

/// Number of grid steps in a half-window (rounded: 10°/1° → 10, 0.5°/0.01° → 50).
fn grid_half(half_window_deg: f64, step_deg: f64) -> i32 {
    (half_window_deg / step_deg).round() as i32
}

/// The lowest value on a grid k = −n..=n (`values[k + n]`); ties go to the smallest |k| (then
/// the negative side), so a flat f does not move the estimate. (0, ∞) when none is finite.
fn grid_argmin(values: &[f64], n: i32) -> (i32, f64) {
    let mut best = (0, f64::INFINITY);
    for d in 0..=n {
        for k in [-d, d] {
            let f = values[(k + n) as usize];
            if f < best.1 {
                best = (k, f);
            }
            if d == 0 {
                break;
            }
        }
    }
    best
}

fn finite_or_inf(f: f64) -> f64 {
    if f.is_finite() { f } else { f64::INFINITY }
}

/// The residual vectors of one Gauss–Newton step (centre, ±h in x, ±h in y).
struct JacobianBuffers {
    centre: Vec<f64>,
    x_plus: Vec<f64>,
    x_minus: Vec<f64>,
    y_plus: Vec<f64>,
    y_minus: Vec<f64>,
}

impl JacobianBuffers {
    fn new(beams: usize) -> Self {
        let v = || vec![0.0; beams];
        Self { centre: v(), x_plus: v(), x_minus: v(), y_plus: v(), y_minus: v() }
    }
}

/// E-PSM's position update at fixed θ ([EP] Eq. 5–6): r = r_ref − r̂_cur(x, y) ≈ H δ with
/// H = ∂r̂/∂(x, y) by central differences (each a re-projection), and the unweighted least-squares
/// δ = (HᵀH)⁻¹Hᵀr, over the beams valid at all five evaluations. Returns (δx, δy) [m].
fn gauss_newton_step(
    cost: &mut impl Cost,
    pose: Pose2,
    h: f64,
    b: &mut JacobianBuffers,
) -> Result<(f64, f64), Stop> {
    let shifted = |dx: f64, dy: f64| Pose2::new(pose.x + dx, pose.y + dy, pose.theta);
    cost.residuals(pose, &mut b.centre);
    cost.residuals(shifted(h, 0.0), &mut b.x_plus);
    cost.residuals(shifted(-h, 0.0), &mut b.x_minus);
    cost.residuals(shifted(0.0, h), &mut b.y_plus);
    cost.residuals(shifted(0.0, -h), &mut b.y_minus);

    // Normal equations HᵀH δ = Hᵀr, accumulated row by row.
    let (mut hxx, mut hxy, mut hyy, mut gx, mut gy) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let mut rows = 0usize;
    for i in 0..b.centre.len() {
        let values = [b.centre[i], b.x_plus[i], b.x_minus[i], b.y_plus[i], b.y_minus[i]];
        if !values.iter().all(|v| v.is_finite()) {
            continue;
        }
        // r = r_ref − r̂, so ∂r̂/∂x = −∂r/∂x.                                          // Eq. (5)
        let hx = -(b.x_plus[i] - b.x_minus[i]) / (2.0 * h);
        let hy = -(b.y_plus[i] - b.y_minus[i]) / (2.0 * h);
        let r = b.centre[i];
        hxx += hx * hx;
        hxy += hx * hy;
        hyy += hy * hy;
        gx += hx * r;
        gy += hy * r;
        rows += 1;
    }
    if rows == 0 {
        return Err(Stop::TooFewPairs);
    }
    let det = hxx * hyy - hxy * hxy;
    let trace = hxx + hyy;
    if !det.is_finite() || det <= SINGULAR_DET_REL * trace * trace {
        return Err(Stop::Singular);
    }
    // δ = (HᵀH)⁻¹Hᵀr with the symmetric 2 × 2 inverse.                                    // Eq. (6)
    Ok(((hyy * gx - hxy * gy) / det, (hxx * gy - hxy * gx) / det))
}

/// The Fig 7 position update: min over (x, y) of f(x, y | θ) with NLopt LN_BOBYQA, in the box
/// ±`half_window_m` around the current position (scaled to [−1, 1]²). Returns the move to the
/// lowest finite f seen (which BOBYQA's own result is, unless it failed); zero if none beat the
/// start. NLopt failures leave the best pose seen; a box without any finite f is
/// [`Stop::TooFewPairs`]; a parameter NLopt rejects is [`Stop::Optimiser`] with its code.
fn bobyqa_step(
    cost: &mut impl Cost,
    pose: Pose2,
    params: &BobyqaParams,
) -> Result<(f64, f64), Stop> {
    let scale = [params.half_window_m, params.half_window_m, 1.0];
    let unused_step = [0.0; 3]; // BOBYQA asks for no gradient
    let scaled = ScaledCost::new(cost, pose, scale, unused_step, params.infeasible_f_cm2);
    let mut opt = Nlopt::new(
        Algorithm::Bobyqa,
        2,
        ScaledCost::<_>::nlopt_objective,
        Target::Minimize,
        scaled,
    );
    let configured = (|| -> Result<(), FailState> {
        opt.set_lower_bounds(&[-1.0, -1.0])?;
        opt.set_upper_bounds(&[1.0, 1.0])?;
        opt.set_xtol_abs(&[params.xtol_m / params.half_window_m; 2])?;
        opt.set_initial_step(&[params.initial_step_m / params.half_window_m; 2])?;
        opt.set_maxeval(params.maxeval)?;
        Ok(())
    })();
    if let Err(e) = configured {
        return Err(Stop::Optimiser(format!("{e:?}")));
    }
    seed_nlopt(BOBYQA_SEED);
    let mut u = [0.0; 2];
    // Whatever NLopt returns (RoundoffLimited included), ScaledCost kept the best pose seen.
    let _ = opt.optimize(&mut u);
    let scaled = opt.recover_user_data();
    match scaled.best {
        Some((best, _)) => Ok((best.x - pose.x, best.y - pose.y)),
        None => Err(Stop::TooFewPairs),
    }
}

#[cfg(test)]
mod tests {
    use super::super::search::synthetic::{NanCost, PointCost, guess, truth};
    use super::*;

    #[test]
    fn describe_names_grids_step_and_tolerances() {
        let s = EpsmParams::default().describe();
        assert!(
            s.contains("on a 1° grid over ±10°")
                && s.contains("then 0.01° over ±0.5°")
                && s.contains("central-difference Jacobian (1 mm)"),
            "{s}"
        );
        assert!(
            s.contains("at least 8 and at most 30 half-iterations")
                && s.contains("< 0.1 mm and |δθ| < 0.01° for 2 cycles; f-check off."),
            "{s}"
        );
        let s = EpsmParams::table5().describe();
        assert!(s.contains("NLopt's BOBYQA") && s.contains("f-check on:"), "{s}");
    }

    #[test]
    fn defaults_validate_and_serde_is_strict() {
        assert!(EpsmParams::default().validate().is_empty());
        assert!(EpsmParams::table5().validate().is_empty());
        let p: EpsmParams = toml::from_str(
            "position_step = \"bobyqa\"\nf_check = true\n[orientation]\nfine_step_deg = 0.02",
        )
        .unwrap();
        assert_eq!(p.position_step, PositionStep::Bobyqa);
        assert_eq!(p.orientation.fine_step_deg, 0.02);
        assert!(toml::from_str::<EpsmParams>("position = \"bobyqa\"").is_err());
        let bad = EpsmParams { min_iter: 40, fd_step_m: -1.0, ..EpsmParams::default() };
        let keys: Vec<_> = bad.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["fd_step_m", "min_iter"]);
        let bad = EpsmParams {
            orientation: OrientationParams { fine_step_deg: 0.0, ..Default::default() },
            ..Default::default()
        };
        assert_eq!(bad.validate()[0].key, "orientation.fine_step_deg");
    }

    #[test]
    fn grid_argmin_prefers_the_centre_on_ties() {
        assert_eq!(grid_argmin(&[1.0, 1.0, 1.0], 1), (0, 1.0));
        assert_eq!(grid_argmin(&[0.5, 1.0, 0.5], 1), (-1, 0.5));
        assert_eq!(grid_argmin(&[3.0, 2.0, 1.0], 1), (1, 1.0));
        assert_eq!(grid_argmin(&[f64::INFINITY; 3], 1), (0, f64::INFINITY));
    }

    #[test]
    fn orientation_search_finds_theta_on_the_fine_grid_with_21_plus_100_evaluations() {
        let mut cost = PointCost::new(Pose2::new(0.2, -0.1, 3.37f64.to_radians()));
        let o = orientation_search(
            &mut cost,
            Pose2::new(0.2, -0.1, 0.0),
            &OrientationParams::default(),
        );
        assert!((o.theta.to_degrees() - 3.37).abs() < 1e-9, "{o:?}");
        assert_eq!(o.expansions, 0);
        assert_eq!(o.evaluations, 121);
        assert_eq!(cost.evaluations, 121);
    }

    #[test]
    fn orientation_search_expands_past_the_window_edge() {
        // True θ 14.5° from the start: the coarse minimum sits on the +10° edge.
        // True θ 14.3° from the start: the coarse minimum sits on the +10° edge; f falls at
        // 11°…14° and rises at 15° (5 expansions), then the fine grid around 14° finds 14.3°.
        let mut cost = PointCost::new(Pose2::new(0.0, 0.0, 14.3f64.to_radians()));
        let o = orientation_search(&mut cost, Pose2::IDENTITY, &OrientationParams::default());
        assert!((o.theta.to_degrees() - 14.3).abs() < 1e-9, "{o:?}");
        assert_eq!(o.expansions, 5);
    }

    #[test]
    fn orientation_search_expansion_is_capped() {
        let mut cost = PointCost::new(Pose2::new(0.0, 0.0, 60f64.to_radians()));
        let params = OrientationParams { max_expansion_steps: 3, ..Default::default() };
        let o = orientation_search(&mut cost, Pose2::IDENTITY, &params);
        assert_eq!(o.expansions, 3);
        assert!((o.theta.to_degrees() - 13.5).abs() < 1e-9, "{o:?}");
    }

    #[test]
    fn gauss_newton_recovers_a_smooth_minimum() {
        let mut cost = PointCost::new(truth());
        let r = epsm(&mut cost, guess(), &EpsmParams::default());
        assert!((r.pose.x - 0.2).abs() < 1e-4 && (r.pose.y + 0.1).abs() < 1e-4, "{r:?}");
        assert!((r.pose.theta - truth().theta).abs() < 1e-9, "{r:?}");
        assert_eq!(r.stop, Stop::Converged);
        assert!(r.iterations >= 8 && r.iterations % 2 == 0);
        assert_eq!(r.evaluations, cost.evaluations);
        assert!(!r.fallback);
    }

    #[test]
    fn bobyqa_position_step_recovers_a_smooth_minimum() {
        let mut cost = PointCost::new(truth());
        let params = EpsmParams { position_step: PositionStep::Bobyqa, ..EpsmParams::default() };
        let r = epsm(&mut cost, guess(), &params);
        assert!((r.pose.x - 0.2).abs() < 1e-4 && (r.pose.y + 0.1).abs() < 1e-4, "{r:?}");
        assert!((r.pose.theta - truth().theta).abs() < 1e-9, "{r:?}");
        assert_eq!(r.stop, Stop::Converged);
    }

    #[test]
    fn f_check_passes_an_estimate_that_lowers_f() {
        let mut cost = PointCost::new(truth());
        let r = epsm(&mut cost, guess(), &EpsmParams { f_check: true, ..EpsmParams::default() });
        assert!(!r.fallback && r.f < r.f_initial, "{r:?}");
    }

    /// f from one true pose, residuals from another 5 cm away: the Gauss–Newton steps walk to
    /// the decoy, so the estimate is worse than an initial guess at the true pose.
    struct Decoy {
        f: PointCost,
        residuals: PointCost,
    }

    impl Cost for Decoy {
        fn f(&mut self, pose: Pose2) -> f64 {
            self.f.f(pose)
        }
        fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize {
            self.residuals.residuals(pose, out)
        }
        fn beams(&self) -> usize {
            self.f.beams()
        }
        fn evaluations(&self) -> u64 {
            self.f.evaluations + self.residuals.evaluations
        }
    }

    #[test]
    fn f_check_rejects_an_estimate_worse_than_the_initial_guess() {
        let decoy = Pose2::new(truth().x + 0.05, truth().y, truth().theta);
        let mut cost = Decoy { f: PointCost::new(truth()), residuals: PointCost::new(decoy) };
        let start = Pose2::new(truth().x + 0.01, truth().y, truth().theta);
        let without = epsm(&mut cost, start, &EpsmParams::default());
        assert!(without.f > without.f_initial && !without.fallback, "{without:?}");
        let with = epsm(&mut cost, start, &EpsmParams { f_check: true, ..EpsmParams::default() });
        assert!(with.fallback, "{with:?}");
        assert_eq!((with.pose, with.f), (start, with.f_initial));
    }

    #[test]
    fn singular_system_is_reported_not_panicked() {
        // Every residual independent of (x, y): H = 0.
        struct Flat(u64);
        impl Cost for Flat {
            fn f(&mut self, pose: Pose2) -> f64 {
                self.0 += 1;
                1.0 + pose.theta * pose.theta
            }
            fn residuals(&mut self, _pose: Pose2, out: &mut [f64]) -> usize {
                self.0 += 1;
                out.fill(0.1);
                out.len()
            }
            fn beams(&self) -> usize {
                5
            }
            fn evaluations(&self) -> u64 {
                self.0
            }
        }
        let r = epsm(&mut Flat(0), guess(), &EpsmParams::default());
        assert_eq!(r.stop, Stop::Singular);
        assert_eq!(r.pose, Pose2::new(guess().x, guess().y, 0.0));
        assert_eq!(r.iterations, 2);
    }

    #[test]
    fn nan_cost_returns_the_initial_guess() {
        for step in [PositionStep::GaussNewton, PositionStep::Bobyqa] {
            let params = EpsmParams { position_step: step, f_check: true, ..EpsmParams::default() };
            let r = epsm(&mut NanCost { evaluations: 0 }, guess(), &params);
            assert_eq!(r.pose, guess());
            assert_eq!(r.stop, Stop::TooFewPairs);
            assert_eq!(r.iterations, 1);
        }
    }

    /// On a noise-free scan pair of the rectangular room with a column.
    mod room {
        use super::*;
        use crate::scanmatch::objective::{Objective, ObjectiveParams};
        use crate::scanmatch::scan::testing::room_pair;

        const TRUTH: Pose2 = Pose2::new(0.2, -0.1, 0.05235987755982988); // 3°

        /// ~5 cm and 2° off the truth; the second excites the slow θ/y zig-zag of the alternation.
        fn guesses() -> [Pose2; 2] {
            [
                Pose2::new(0.25, -0.1, TRUTH.theta - 2f64.to_radians()),
                Pose2::new(0.2, -0.05, TRUTH.theta + 2f64.to_radians()),
            ]
        }

        #[test]
        fn both_position_steps_recover_the_transform() {
            let (reference, current) = room_pair(TRUTH);
            for step in [PositionStep::GaussNewton, PositionStep::Bobyqa] {
                for guess in guesses() {
                    let mut cost =
                        Objective::new(&reference, &current, &ObjectiveParams::default());
                    let r = epsm(
                        &mut cost,
                        guess,
                        &EpsmParams { position_step: step, ..EpsmParams::default() },
                    );
                    let (dx, dy) = (r.pose.x - TRUTH.x, r.pose.y - TRUTH.y);
                    let dtheta = (r.pose.theta - TRUTH.theta).to_degrees();
                    assert!(
                        dx.abs() < 1e-3 && dy.abs() < 1e-3 && dtheta.abs() < 0.05,
                        "{step:?}: {dx:+.5} {dy:+.5} {dtheta:+.4}° {r:?}"
                    );
                    assert!(matches!(r.stop, Stop::Converged | Stop::Budget), "{r:?}");
                    assert!(r.f < 0.01 && r.f < r.f_initial && r.pairs >= 40, "{r:?}");
                    assert_eq!(r.evaluations, cost.evaluations());
                }
            }
        }

        /// The room objective, but its residuals are taken 5 cm further along x, so the
        /// Gauss–Newton steps head 5 cm away from the f minimum.
        struct MisalignedResiduals<'a>(Objective<'a>);

        impl Cost for MisalignedResiduals<'_> {
            fn f(&mut self, pose: Pose2) -> f64 {
                self.0.f(pose)
            }
            fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize {
                self.0.residuals(Pose2::new(pose.x + 0.05, pose.y, pose.theta), out)
            }
            fn beams(&self) -> usize {
                self.0.beams()
            }
            fn evaluations(&self) -> u64 {
                self.0.evaluations()
            }
        }

        #[test]
        fn f_check_falls_back_when_the_estimate_is_worse_than_the_initial_guess() {
            let (reference, current) = room_pair(TRUTH);
            let start = Pose2::new(TRUTH.x + 0.002, TRUTH.y - 0.001, TRUTH.theta);
            let mut cost = MisalignedResiduals(Objective::new(
                &reference,
                &current,
                &ObjectiveParams::default(),
            ));
            let without = epsm(&mut cost, start, &EpsmParams::default());
            assert!(!without.fallback && without.f > without.f_initial, "{without:?}");
            let with =
                epsm(&mut cost, start, &EpsmParams { f_check: true, ..EpsmParams::default() });
            assert!(with.fallback, "{with:?}");
            assert_eq!((with.pose, with.f), (start, with.f_initial));
            assert!(with.pairs >= 40);
        }
    }
}
