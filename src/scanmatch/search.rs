//! Simultaneous (x, y, θ) search ([EP] §5.3.2, reference §3.7): ([`Cost`], initial guess, NLopt
//! algorithm, seed) → [`MatchResult`]. f (Eq. 4) is minimised over all three pose variables at
//! once with one of the eleven NLopt algorithms the document tested, instead of E-PSM's
//! alternating orientation/position search (Figs 6–7).
//!
//! Choices where [EP] is silent (reference §3.7 [ASSUMPTION]s; each is a [`SearchParams`] field):
//! - The search box is centred on the initial guess: ±0.4 m in x and y (the brute-force area,
//!   §3.8) and ±10° in θ (the coarse orientation window, §3.5).
//! - NLopt works in scaled variables u ∈ [−1, 1]³, pose = initial + u ⊙ half-widths, so the box is
//!   a unit cube and metres and radians weigh alike (gradient methods and DIRECT's rectangle
//!   division are sensitive to the scale). Tolerances are given in pose units and scaled too.
//! - The gradient methods get central differences of f: 6 extra evaluations per gradient,
//!   counted like any other ([`Cost::evaluations`]).
//! - f = ∞ ("too few pairs") would poison the quadratic models, line searches and DIRECT's
//!   hulls; NLopt sees the finite penalty P·(1 + |u|²) instead (P = `infeasible_f_cm2`), which
//!   exceeds any attainable f and slopes back towards the initial guess; a central difference
//!   with one infinite side falls back to the one-sided difference (see [`ScaledCost`]).
//! - The result is the lowest finite f evaluated (NLopt's own best, plus gradient probes), so a
//!   failure return (e.g. `RoundoffLimited`) still yields the best pose seen.
//!
//! Seeding: CRS2 and ISRES draw from NLopt's Mersenne Twister (the other nine do not: DIRECT-L
//! is the non-randomised variant, MLSL-LDS samples a Sobol sequence, COBYLA has its own fixed
//! LCG). The generator's state is thread-local in this build (`THREADLOCAL` = `__thread`,
//! util/mt19937ar.c, checked in the generated nlopt_config.h). [`seed_nlopt`] reseeds it from
//! `seed` right before every optimisation, on the calling thread, so a run depends only on its
//! seed whatever else runs in parallel, and NLopt never seeds itself from the clock
//! (`nlopt_srand_time_default` does so only on a thread that has never been seeded).

use super::{Cost, MatchResult, Stop};
use crate::config::{Checks, Violation};
use crate::geom::{Pose2, wrap_angle};
use nlopt::{Algorithm, FailState, Nlopt, SuccessState, Target};
use serde::{Deserialize, Serialize};

/// Dimension of the simultaneous search: (x, y, θ).
const POSE_DIM: usize = 3;

/// The NLopt algorithms of [EP] Table 3, in the table's order. Default CRS2, [EP]'s
/// recommendation (§6.2).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default, Serialize, Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Optimizer {
    /// `GN_DIRECT_L`: locally biased DIRECT (deterministic, global).
    DirectL,
    /// `GN_CRS2_LM`: controlled random search with local mutation ([EP]'s recommendation).
    #[default]
    Crs2,
    /// `GN_ISRES`: improved stochastic ranking evolution strategy.
    Isres,
    /// `GD_MLSL_LDS`: multi-level single linkage on a Sobol sequence, with a gradient-based
    /// local subsolver ([`SearchParams::mlsl_local`]; the document does not name one).
    MlslLds,
    /// `LN_COBYLA`.
    Cobyla,
    /// `LN_BOBYQA`.
    Bobyqa,
    /// `LN_SBPLX`: Subplex (NLopt's re-implementation).
    Sbplx,
    /// `LD_SLSQP`.
    Slsqp,
    /// `LD_LBFGS` ([EP]'s "BFGS": NLopt only has the low-storage variant).
    Lbfgs,
    /// `LD_TNEWTON_PRECOND_RESTART` ([EP]'s "NEWTON"; the variant is not stated, this is NLopt's
    /// full truncated Newton, preconditioned, with steepest-descent restarts).
    Tnewton,
    /// `LD_VAR2`: shifted limited-memory variable metric, rank 2.
    Var2,
}

impl Optimizer {
    pub const ALL: [Optimizer; 11] = [
        Optimizer::DirectL,
        Optimizer::Crs2,
        Optimizer::Isres,
        Optimizer::MlslLds,
        Optimizer::Cobyla,
        Optimizer::Bobyqa,
        Optimizer::Sbplx,
        Optimizer::Slsqp,
        Optimizer::Lbfgs,
        Optimizer::Tnewton,
        Optimizer::Var2,
    ];

    /// The config spelling (as serde writes it).
    pub fn name(self) -> &'static str {
        match self {
            Optimizer::DirectL => "direct_l",
            Optimizer::Crs2 => "crs2",
            Optimizer::Isres => "isres",
            Optimizer::MlslLds => "mlsl_lds",
            Optimizer::Cobyla => "cobyla",
            Optimizer::Bobyqa => "bobyqa",
            Optimizer::Sbplx => "sbplx",
            Optimizer::Slsqp => "slsqp",
            Optimizer::Lbfgs => "lbfgs",
            Optimizer::Tnewton => "tnewton",
            Optimizer::Var2 => "var2",
        }
    }

    /// The name [EP] Table 3 prints.
    pub fn title(self) -> &'static str {
        match self {
            Optimizer::DirectL => "DIRECT-L",
            Optimizer::Crs2 => "CRS2",
            Optimizer::Isres => "ISRES",
            Optimizer::MlslLds => "GD_MLSL_LDS",
            Optimizer::Cobyla => "COBYLA",
            Optimizer::Bobyqa => "BOBYQA",
            Optimizer::Sbplx => "SBPLX",
            Optimizer::Slsqp => "SLSQP",
            Optimizer::Lbfgs => "BFGS",
            Optimizer::Tnewton => "NEWTON",
            Optimizer::Var2 => "VAR2",
        }
    }

    /// One of [EP]'s four global methods.
    pub fn is_global(self) -> bool {
        matches!(self, Optimizer::DirectL | Optimizer::Crs2 | Optimizer::Isres | Optimizer::MlslLds)
    }

    /// Needs ∇f (central differences here); MLSL-LDS through its local subsolver.
    pub fn uses_gradient(self) -> bool {
        matches!(
            self,
            Optimizer::MlslLds
                | Optimizer::Slsqp
                | Optimizer::Lbfgs
                | Optimizer::Tnewton
                | Optimizer::Var2
        )
    }

    fn algorithm(self) -> Algorithm {
        match self {
            Optimizer::DirectL => Algorithm::DirectL,
            Optimizer::Crs2 => Algorithm::Crs2Lm,
            Optimizer::Isres => Algorithm::Isres,
            Optimizer::MlslLds => Algorithm::GdMlslLds,
            Optimizer::Cobyla => Algorithm::Cobyla,
            Optimizer::Bobyqa => Algorithm::Bobyqa,
            Optimizer::Sbplx => Algorithm::Sbplx,
            Optimizer::Slsqp => Algorithm::Slsqp,
            Optimizer::Lbfgs => Algorithm::Lbfgs,
            Optimizer::Tnewton => Algorithm::TNewtonPrecondRestart,
            Optimizer::Var2 => Algorithm::LdVar2,
        }
    }
}

/// The local subsolver of MLSL-LDS (NLopt requires one; [EP] does not say which it used).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum MlslLocal {
    /// `LD_MMA` (CCSA method of moving asymptotes): NLopt's default local search for the GD_MLSL
    /// family, so what [EP] most likely ran if it set none. It tolerates the piecewise-smooth f;
    /// MLSL aborts its whole run on the first local failure, which L-BFGS's line search often
    /// reports on this objective.
    #[default]
    Mma,
    /// `LD_LBFGS` ([EP]'s "BFGS").
    Lbfgs,
    /// `LD_SLSQP`.
    Slsqp,
}

impl MlslLocal {
    fn algorithm(self) -> Algorithm {
        match self {
            MlslLocal::Mma => Algorithm::Mma,
            MlslLocal::Lbfgs => Algorithm::Lbfgs,
            MlslLocal::Slsqp => Algorithm::Slsqp,
        }
    }
}

/// `[scanmatch.search]`: the simultaneous search's box, stopping rules and derivatives. [EP]
/// gives none of them (reference §3.7); the defaults are the reference's [ASSUMPTION]s, with
/// `maxeval` tuned so that CRS2 keeps its accuracy on noise-free room scans at a few ms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SearchParams {
    /// Half-width of the box in x and y around the initial guess [m]. Default 0.4 (800 × 800 mm,
    /// the brute-force area, [EP] §6.1).
    pub half_window_m: f64,
    /// Half-width of the box in θ around the initial guess [deg]. Default 10 (the coarse
    /// orientation window, [EP] §5.3.1).
    pub half_window_deg: f64,
    /// NLopt `xtol_abs` in x and y [m]. Default 1e-4 (0.1 mm).
    pub xtol_m: f64,
    /// NLopt `xtol_abs` in θ [deg]. Default 0.005.
    pub xtol_deg: f64,
    /// NLopt `ftol_rel` [–]; 0 = off. Default 0: f → 0 on noise-free scans, where a relative
    /// test on f means nothing; xtol and maxeval stop instead.
    pub ftol_rel: f64,
    /// NLopt `maxeval`: objective calls NLopt may make (a call with a gradient costs 7
    /// evaluations of f). Default 1500.
    pub maxeval: u32,
    /// Initial population of CRS2, ISRES and MLSL [points]; 0 = NLopt's default (CRS2
    /// 10·(n + 1) = 40, ISRES 20·(n + 1) = 80, MLSL 4). Default 0.
    pub population: u32,
    /// Central-difference step in x and y for the gradient methods [m]. Default 1e-3 (E-PSM's
    /// `fd_step_m`).
    pub gradient_step_m: f64,
    /// Central-difference step in θ [deg]. Default 0.01 (about 1 mm of arc at 5 m).
    pub gradient_step_deg: f64,
    /// MLSL-LDS's local subsolver. Default `mma` (NLopt's default).
    pub mlsl_local: MlslLocal,
    /// `maxeval` of each MLSL local search (same xtol and ftol_rel as above). Default 100.
    pub mlsl_local_maxeval: u32,
    /// P [cm²]: NLopt sees P·(1 + |u|²) where f = ∞ (too few pairs). Default 1e6 = (10 m)²,
    /// the square of the largest residual a 10 m laser can produce.
    pub infeasible_f_cm2: f64,
}

impl Default for SearchParams {
    fn default() -> Self {
        Self {
            half_window_m: 0.4,
            half_window_deg: 10.0,
            xtol_m: 1e-4,
            xtol_deg: 0.005,
            ftol_rel: 0.0,
            maxeval: 1500,
            population: 0,
            gradient_step_m: 1e-3,
            gradient_step_deg: 0.01,
            mlsl_local: MlslLocal::Mma,
            mlsl_local_maxeval: 100,
            infeasible_f_cm2: 1e6,
        }
    }
}

impl SearchParams {
    /// The report's sentence on the simultaneous search: box, tolerances, evaluation budget,
    /// gradients and seeding.
    pub fn describe(&self) -> String {
        format!(
            "Simultaneous search ([EP] §5.3.2) with the real NLopt 2.9: box ±{} m, ±{}° around the guess, xtol {} mm / {}°, at most {} evaluations; gradient optimisers get central-difference gradients; MLSL-LDS uses MMA as its local solver; CRS2 and ISRES are seeded from the run seed before every match (NLopt's generator is thread-local in this build, so results do not depend on the thread count).",
            self.half_window_m,
            self.half_window_deg,
            self.xtol_m * 1e3,
            self.xtol_deg,
            self.maxeval
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.positive("half_window_m", self.half_window_m);
        c.in_range("half_window_deg", self.half_window_deg, f64::MIN_POSITIVE, 180.0);
        c.positive("xtol_m", self.xtol_m);
        c.positive("xtol_deg", self.xtol_deg);
        c.non_negative("ftol_rel", self.ftol_rel);
        c.require(self.maxeval >= 1, "maxeval", || "must be ≥ 1".to_string());
        c.require(
            self.population == 0 || self.population as usize > POSE_DIM,
            "population",
            || {
                format!(
                    "must be 0 (NLopt's default) or ≥ {} (dimension + 1), got {}",
                    POSE_DIM + 1,
                    self.population
                )
            },
        );
        c.positive("gradient_step_m", self.gradient_step_m);
        c.positive("gradient_step_deg", self.gradient_step_deg);
        if self.gradient_step_m.is_finite() && self.half_window_m.is_finite() {
            c.require(self.gradient_step_m < self.half_window_m, "gradient_step_m", || {
                format!(
                    "must be < half_window_m ({}), got {}",
                    self.half_window_m, self.gradient_step_m
                )
            });
        }
        if self.gradient_step_deg.is_finite() && self.half_window_deg.is_finite() {
            c.require(self.gradient_step_deg < self.half_window_deg, "gradient_step_deg", || {
                format!(
                    "must be < half_window_deg ({}), got {}",
                    self.half_window_deg, self.gradient_step_deg
                )
            });
        }
        c.require(self.mlsl_local_maxeval >= 1, "mlsl_local_maxeval", || "must be ≥ 1".to_string());
        c.positive("infeasible_f_cm2", self.infeasible_f_cm2);
        c.finish()
    }
}

/// Minimises f over (x, y, θ) in the box around `initial` with `optimizer` ([EP] §5.3.2).
/// NLopt's generator is seeded from `seed` first (see the module docs); the deterministic
/// algorithms ignore it. `stop` is [`Stop::Optimiser`] with NLopt's return code (e.g.
/// "XtolReached", "MaxEvalReached", "RoundoffLimited"), or [`Stop::TooFewPairs`] when no
/// evaluated pose had a finite f (the result is then the initial guess).
pub fn simultaneous(
    cost: &mut impl Cost,
    initial: Pose2,
    optimizer: Optimizer,
    params: &SearchParams,
    seed: u64,
) -> MatchResult {
    let evaluations_start = cost.evaluations();
    let f_initial = cost.f(initial);
    let scale = [params.half_window_m, params.half_window_m, params.half_window_deg.to_radians()];
    let step =
        [params.gradient_step_m, params.gradient_step_m, params.gradient_step_deg.to_radians()];
    let mut scaled = ScaledCost::new(cost, initial, scale, step, params.infeasible_f_cm2);
    scaled.offer(initial, f_initial);

    let outcome = {
        let mut opt = Nlopt::new(
            optimizer.algorithm(),
            POSE_DIM,
            ScaledCost::<_>::nlopt_objective,
            Target::Minimize,
            scaled,
        );
        match configure(&mut opt, optimizer, params, scale) {
            Ok(()) => {
                seed_nlopt(seed);
                let mut u = [0.0; POSE_DIM];
                let code = optimize_code(opt.optimize(&mut u));
                scaled = opt.recover_user_data();
                code
            }
            Err(e) => {
                scaled = opt.recover_user_data();
                format!("{e:?}")
            }
        }
    };

    let best = scaled.best;
    let cost = scaled.cost;
    let (pose, f, stop) = match best {
        Some((pose, f)) => (pose, f, Stop::Optimiser(outcome)),
        None => (initial, f_initial, Stop::TooFewPairs),
    };
    let pairs = pairs_at(cost, pose);
    MatchResult {
        pose,
        f,
        f_initial,
        pairs,
        iterations: 0,
        evaluations: cost.evaluations() - evaluations_start,
        fallback: false,
        stop,
    }
}

/// Bounds, tolerances, budget, population and (MLSL) the local subsolver.
fn configure<F: nlopt::ObjFn<T>, T>(
    opt: &mut Nlopt<F, T>,
    optimizer: Optimizer,
    params: &SearchParams,
    scale: [f64; POSE_DIM],
) -> Result<(), FailState> {
    let xtol = [
        params.xtol_m / scale[0],
        params.xtol_m / scale[1],
        params.xtol_deg.to_radians() / scale[2],
    ];
    opt.set_lower_bounds(&[-1.0; POSE_DIM])?;
    opt.set_upper_bounds(&[1.0; POSE_DIM])?;
    opt.set_xtol_abs(&xtol)?;
    opt.set_ftol_rel(params.ftol_rel)?;
    opt.set_maxeval(params.maxeval)?;
    opt.set_population(params.population as usize)?;
    if optimizer == Optimizer::MlslLds {
        let mut local = opt.get_local_optimizer(params.mlsl_local.algorithm());
        local.set_xtol_abs(&xtol)?;
        local.set_ftol_rel(params.ftol_rel)?;
        local.set_maxeval(params.mlsl_local_maxeval)?;
        opt.set_local_optimizer(local)?;
    }
    Ok(())
}

/// NLopt's return code as a name ("XtolReached", "RoundoffLimited", …).
fn optimize_code(result: Result<(SuccessState, f64), (FailState, f64)>) -> String {
    match result {
        Ok((s, _)) => format!("{s:?}"),
        Err((e, _)) => format!("{e:?}"),
    }
}

/// Seeds NLopt's Mersenne Twister on the calling thread (its state is thread-local in this
/// build). `nlopt_init_genrand` keeps only the low 32 bits of its argument, so the 64-bit seed
/// is first folded through SplitMix64's finaliser: seeds that differ only in their high bits
/// still give different streams.
pub fn seed_nlopt(seed: u64) {
    let mixed = splitmix64(seed) as u32;
    Nlopt::<fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64, ()>::srand_seed(Some(u64::from(mixed)));
}

/// SplitMix64's output function (Steele, Lea & Flood 2014).
fn splitmix64(seed: u64) -> u64 {
    let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Valid pairs at `pose` (one evaluation).
pub(crate) fn pairs_at(cost: &mut impl Cost, pose: Pose2) -> usize {
    let mut residuals = vec![0.0; cost.beams()];
    cost.residuals(pose, &mut residuals)
}

/// f as NLopt sees it: in scaled variables u (pose = origin + u ⊙ scale, over the first `dims`
/// of (x, y, θ); the rest stay at the origin), with the infeasible penalty and central-difference
/// gradients. Keeps the lowest finite f it has evaluated. Shared with E-PSM's BOBYQA position
/// step ([`super::epsm`]), which searches (x, y) only.
pub(crate) struct ScaledCost<'a, C> {
    pub(crate) cost: &'a mut C,
    origin: Pose2,
    /// Half-widths of the box [m, m, rad]: u = ±1 at its faces.
    scale: [f64; POSE_DIM],
    /// Central-difference steps [m, m, rad].
    step: [f64; POSE_DIM],
    /// P [cm²].
    penalty: f64,
    /// Lowest finite f evaluated and its pose.
    pub(crate) best: Option<(Pose2, f64)>,
}

impl<'a, C: Cost> ScaledCost<'a, C> {
    pub(crate) fn new(
        cost: &'a mut C,
        origin: Pose2,
        scale: [f64; POSE_DIM],
        step: [f64; POSE_DIM],
        penalty: f64,
    ) -> Self {
        Self { cost, origin, scale, step, penalty, best: None }
    }

    /// The pose at scaled point `u` (`u.len()` ≤ 3 leading coordinates vary).
    fn pose(&self, u: &[f64]) -> Pose2 {
        let mut p = [self.origin.x, self.origin.y, self.origin.theta];
        for (i, &ui) in u.iter().enumerate() {
            p[i] += ui * self.scale[i];
        }
        Pose2::new(p[0], p[1], wrap_angle(p[2]))
    }

    /// Records a finite f (ties keep the earlier pose).
    pub(crate) fn offer(&mut self, pose: Pose2, f: f64) {
        if f.is_finite() && self.best.is_none_or(|(_, b)| f < b) {
            self.best = Some((pose, f));
        }
    }

    /// f at `pose`, recorded; NaN and −∞ count as ∞ (no judgement possible).
    fn eval(&mut self, pose: Pose2) -> f64 {
        let f = self.cost.f(pose);
        let f = if f.is_finite() { f } else { f64::INFINITY };
        self.offer(pose, f);
        f
    }

    /// The penalty P·(1 + |u|²): above any attainable f, sloping back to the origin.
    fn penalty_at(&self, u: &[f64]) -> f64 {
        self.penalty * (1.0 + u.iter().map(|v| v * v).sum::<f64>())
    }

    /// The NLopt objective: f(pose(u)) (or the penalty), and ∂/∂u by central differences when
    /// asked: (f(p + hᵢeᵢ) − f(p − hᵢeᵢ)) / 2hᵢ · scaleᵢ, one-sided when a side is infinite, 0
    /// when both are; the penalty's own gradient 2P·u where the centre is infinite.
    pub(crate) fn nlopt_objective(u: &[f64], grad: Option<&mut [f64]>, this: &mut Self) -> f64 {
        let pose = this.pose(u);
        let f = this.eval(pose);
        if !f.is_finite() {
            if let Some(g) = grad {
                for (gi, &ui) in g.iter_mut().zip(u) {
                    *gi = 2.0 * this.penalty * ui;
                }
            }
            return this.penalty_at(u);
        }
        if let Some(g) = grad {
            for (i, gi) in g.iter_mut().enumerate() {
                let h = this.step[i];
                let f_plus = this.eval(shifted(pose, i, h));
                let f_minus = this.eval(shifted(pose, i, -h));
                let derivative = match (f_plus.is_finite(), f_minus.is_finite()) {
                    (true, true) => (f_plus - f_minus) / (2.0 * h),
                    (true, false) => (f_plus - f) / h,
                    (false, true) => (f - f_minus) / h,
                    (false, false) => 0.0,
                };
                *gi = derivative * this.scale[i];
            }
        }
        f
    }
}

/// `pose` moved by `delta` along coordinate `i` (0 = x, 1 = y, 2 = θ).
fn shifted(pose: Pose2, i: usize, delta: f64) -> Pose2 {
    match i {
        0 => Pose2::new(pose.x + delta, pose.y, pose.theta),
        1 => Pose2::new(pose.x, pose.y + delta, pose.theta),
        _ => Pose2::new(pose.x, pose.y, wrap_angle(pose.theta + delta)),
    }
}

#[cfg(test)]
pub(crate) mod synthetic {
    //! Synthetic costs for testing the searches before (and apart from) the scan objective.
    use super::super::Cost;
    use crate::geom::{Point2, Pose2};

    /// The pose change every search test recovers (0.2 m, −0.1 m, 3°).
    pub fn truth() -> Pose2 {
        Pose2::new(0.2, -0.1, 3f64.to_radians())
    }

    /// The initial guess of those tests: 5 cm and 4 cm off, 2° short.
    pub fn guess() -> Pose2 {
        Pose2::new(0.25, -0.06, 1f64.to_radians())
    }

    /// A room of landmark points seen from a true pose: the residuals are the x and y offsets
    /// [m] between each reference point and the current point mapped through the candidate
    /// pose; f = 10⁴ · mean(residual²) [cm²], exactly 0 at the truth. Optional: a θ-ripple
    /// `ripple_cm2 · (1 − cos(ω Δθ))` (local minima every 2π/ω), and an ∞ region (too few
    /// pairs) beyond `feasible_radius_m` from the truth.
    pub(crate) struct PointCost {
        reference: Vec<Point2>,
        current: Vec<Point2>,
        pub(crate) truth: Pose2,
        pub(crate) ripple_cm2: f64,
        pub(crate) ripple_omega: f64,
        pub(crate) feasible_radius_m: f64,
        pub(crate) evaluations: u64,
        /// Every pose evaluated, in order.
        pub(crate) trace: Vec<Pose2>,
    }

    impl PointCost {
        pub(crate) fn new(truth: Pose2) -> Self {
            // Walls of a 6 × 4 m room around the reference origin, one point every 0.25 m,
            // plus an off-centre column so that no symmetry makes the minimum ambiguous.
            let mut reference = Vec::new();
            for k in 0..=24 {
                let t = -3.0 + 0.25 * f64::from(k);
                reference.push(Point2::new(t, -2.0));
                reference.push(Point2::new(t, 2.0 + 0.02 * t));
            }
            for k in 0..=16 {
                let t = -2.0 + 0.25 * f64::from(k);
                reference.push(Point2::new(3.0, t));
            }
            reference.push(Point2::new(1.0, 0.5));
            reference.push(Point2::new(1.2, 0.7));
            let current = reference.iter().map(|&q| inverse_transform(truth, q)).collect();
            Self {
                reference,
                current,
                truth,
                ripple_cm2: 0.0,
                ripple_omega: 0.0,
                feasible_radius_m: f64::INFINITY,
                evaluations: 0,
                trace: Vec::new(),
            }
        }

        pub(crate) fn with_ripple(mut self, ripple_cm2: f64, omega: f64) -> Self {
            self.ripple_cm2 = ripple_cm2;
            self.ripple_omega = omega;
            self
        }

        pub(crate) fn with_feasible_radius(mut self, radius_m: f64) -> Self {
            self.feasible_radius_m = radius_m;
            self
        }

        fn feasible(&self, pose: Pose2) -> bool {
            (pose.x - self.truth.x).hypot(pose.y - self.truth.y) <= self.feasible_radius_m
        }
    }

    fn inverse_transform(pose: Pose2, q: Point2) -> Point2 {
        let (s, c) = pose.theta.sin_cos();
        let (dx, dy) = (q.x - pose.x, q.y - pose.y);
        Point2::new(c * dx + s * dy, -s * dx + c * dy)
    }

    impl Cost for PointCost {
        fn f(&mut self, pose: Pose2) -> f64 {
            self.evaluations += 1;
            self.trace.push(pose);
            if !self.feasible(pose) {
                return f64::INFINITY;
            }
            let n = self.reference.len() as f64;
            let sum: f64 = self
                .reference
                .iter()
                .zip(&self.current)
                .map(|(&q, &l)| {
                    let p = pose.transform_point(l);
                    (q.x - p.x).powi(2) + (q.y - p.y).powi(2)
                })
                .sum();
            let ripple = self.ripple_cm2
                * (1.0 - (self.ripple_omega * (pose.theta - self.truth.theta)).cos());
            1e4 * sum / (2.0 * n) + ripple
        }

        fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize {
            self.evaluations += 1;
            self.trace.push(pose);
            if !self.feasible(pose) {
                out.fill(f64::NAN);
                return 0;
            }
            for (k, (&q, &l)) in self.reference.iter().zip(&self.current).enumerate() {
                let p = pose.transform_point(l);
                out[2 * k] = q.x - p.x;
                out[2 * k + 1] = q.y - p.y;
            }
            out.len()
        }

        fn beams(&self) -> usize {
            2 * self.reference.len()
        }

        fn evaluations(&self) -> u64 {
            self.evaluations
        }
    }

    /// Records every pose a matcher evaluates on the wrapped cost.
    pub(crate) struct Recording<C> {
        pub(crate) inner: C,
        pub(crate) trace: Vec<Pose2>,
    }

    impl<C: Cost> Cost for Recording<C> {
        fn f(&mut self, pose: Pose2) -> f64 {
            self.trace.push(pose);
            self.inner.f(pose)
        }
        fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize {
            self.trace.push(pose);
            self.inner.residuals(pose, out)
        }
        fn beams(&self) -> usize {
            self.inner.beams()
        }
        fn evaluations(&self) -> u64 {
            self.inner.evaluations()
        }
    }

    /// A cost that is NaN everywhere (a broken objective must not panic a matcher).
    pub(crate) struct NanCost {
        pub(crate) evaluations: u64,
    }

    impl Cost for NanCost {
        fn f(&mut self, _pose: Pose2) -> f64 {
            self.evaluations += 1;
            f64::NAN
        }
        fn residuals(&mut self, _pose: Pose2, out: &mut [f64]) -> usize {
            self.evaluations += 1;
            out.fill(f64::NAN);
            0
        }
        fn beams(&self) -> usize {
            10
        }
        fn evaluations(&self) -> u64 {
            self.evaluations
        }
    }
}

#[cfg(test)]
mod tests {
    use super::synthetic::{NanCost, PointCost, guess, truth};
    use super::*;

    #[test]
    fn describe_names_box_tolerances_and_budget() {
        let s = SearchParams { maxeval: 900, ..SearchParams::default() }.describe();
        assert!(
            s.contains(
                "box ±0.4 m, ±10° around the guess, xtol 0.1 mm / 0.005°, at most 900 evaluations"
            ),
            "{s}"
        );
    }

    #[test]
    fn names_titles_and_serde_agree() {
        for o in Optimizer::ALL {
            let toml = toml::to_string(&SearchConfigProbe { o }).unwrap();
            assert_eq!(toml.trim(), format!("o = \"{}\"", o.name()));
            assert!(!o.title().is_empty());
        }
        assert_eq!(Optimizer::ALL.iter().filter(|o| o.is_global()).count(), 4);
        assert_eq!(Optimizer::ALL.iter().filter(|o| o.uses_gradient()).count(), 5);
    }

    #[derive(Serialize)]
    struct SearchConfigProbe {
        o: Optimizer,
    }

    #[test]
    fn default_params_validate_and_bad_ones_are_named() {
        assert!(SearchParams::default().validate().is_empty());
        let bad = SearchParams {
            population: 2,
            xtol_m: 0.0,
            gradient_step_m: 1.0,
            ..SearchParams::default()
        };
        let keys: Vec<_> = bad.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["xtol_m", "population", "gradient_step_m"]);
        let parsed: SearchParams = toml::from_str("maxeval = 10").unwrap();
        assert_eq!(parsed.maxeval, 10);
        assert!(toml::from_str::<SearchParams>("max_eval = 10").is_err());
    }

    #[test]
    fn crs2_recovers_a_smooth_minimum() {
        let mut cost = PointCost::new(truth());
        let r = simultaneous(&mut cost, guess(), Optimizer::Crs2, &SearchParams::default(), 7);
        assert!((r.pose.x - 0.2).abs() < 1e-3 && (r.pose.y + 0.1).abs() < 1e-3, "{r:?}");
        assert!((r.pose.theta - 3f64.to_radians()).abs() < 0.05f64.to_radians(), "{r:?}");
        assert!(r.f < r.f_initial);
        assert_eq!(r.evaluations, cost.evaluations);
        assert!(matches!(r.stop, Stop::Optimiser(_)));
    }

    #[test]
    fn every_optimizer_runs_and_improves_on_a_smooth_cost() {
        for o in Optimizer::ALL {
            let mut cost = PointCost::new(truth());
            let r = simultaneous(&mut cost, guess(), o, &SearchParams::default(), 1);
            assert!(r.pose.is_finite() && r.f.is_finite(), "{o:?}: {r:?}");
            assert!(r.f < r.f_initial, "{o:?}: {r:?}");
            // ISRES, an evolution strategy, is far from converged within the default budget.
            if o != Optimizer::Isres {
                assert!(
                    (r.pose.x - 0.2).abs() < 5e-3 && (r.pose.y + 0.1).abs() < 5e-3,
                    "{o:?}: {r:?}"
                );
            }
        }
    }

    #[test]
    fn global_optimizers_escape_a_ripple_minimum() {
        // Local minima every 2° in θ, the initial guess 2° off sits near the wrong one.
        for o in Optimizer::ALL.into_iter().filter(|o| o.is_global()) {
            let mut cost = PointCost::new(truth()).with_ripple(50.0, 180.0);
            let r = simultaneous(
                &mut cost,
                Pose2::new(0.2, -0.1, 1f64.to_radians()),
                o,
                &SearchParams::default(),
                3,
            );
            assert!((r.pose.theta - 3f64.to_radians()).abs() < 0.2f64.to_radians(), "{o:?}: {r:?}");
        }
    }

    #[test]
    fn infinite_cost_outside_a_disc_is_handled_by_every_optimizer() {
        for o in Optimizer::ALL {
            let mut cost = PointCost::new(truth()).with_feasible_radius(0.15);
            let r = simultaneous(&mut cost, guess(), o, &SearchParams::default(), 5);
            assert!(r.f.is_finite() && r.f < r.f_initial, "{o:?}: {r:?}");
        }
    }

    #[test]
    fn nan_cost_returns_the_initial_guess() {
        let mut cost = NanCost { evaluations: 0 };
        for o in Optimizer::ALL {
            let r = simultaneous(
                &mut cost,
                guess(),
                o,
                &SearchParams { maxeval: 50, ..SearchParams::default() },
                0,
            );
            assert_eq!(r.pose, guess());
            assert_eq!(r.stop, Stop::TooFewPairs);
            assert_eq!(r.pairs, 0);
        }
    }

    #[test]
    fn same_seed_same_trace_different_seed_different_trace() {
        let run = |seed: u64| {
            let mut cost = PointCost::new(truth()).with_ripple(5.0, 90.0);
            let r =
                simultaneous(&mut cost, guess(), Optimizer::Crs2, &SearchParams::default(), seed);
            (r, cost.trace)
        };
        let (a, trace_a) = run(11);
        let (b, trace_b) = run(11);
        assert_eq!(a, b);
        assert_eq!(trace_a, trace_b);
        let (_, trace_c) = run(12);
        assert_ne!(trace_a, trace_c);
        // Seeds that differ only in their high 32 bits must not collide (NLopt keeps 32 bits).
        let (_, trace_d) = run(11 + (1 << 32));
        assert_ne!(trace_a, trace_d);
    }

    #[test]
    fn gradient_evaluations_are_counted() {
        let mut cost = PointCost::new(truth());
        let r = simultaneous(&mut cost, guess(), Optimizer::Lbfgs, &SearchParams::default(), 0);
        // Every NLopt call of a gradient method costs 7 evaluations; plus f_initial and pairs.
        assert_eq!((r.evaluations - 2) % 7, 0, "{r:?}");
    }

    /// On a noise-free scan pair of the rectangular room with a column ([`scan::testing`]).
    mod room {
        use super::super::synthetic::Recording;
        use super::*;
        use crate::scanmatch::objective::{Objective, ObjectiveParams};
        use crate::scanmatch::scan::testing::room_pair;

        const TRUTH: Pose2 = Pose2::new(0.2, -0.1, 0.05235987755982988); // 3°

        /// ~5 cm and 2° off the truth.
        fn guesses() -> [Pose2; 2] {
            [
                Pose2::new(0.23, -0.14, TRUTH.theta - 2f64.to_radians()),
                Pose2::new(0.2, -0.05, TRUTH.theta + 2f64.to_radians()),
            ]
        }

        fn assert_recovered(r: &MatchResult, what: &str) {
            let (dx, dy) = (r.pose.x - TRUTH.x, r.pose.y - TRUTH.y);
            let dtheta = (r.pose.theta - TRUTH.theta).to_degrees();
            assert!(
                dx.abs() < 1e-3 && dy.abs() < 1e-3 && dtheta.abs() < 0.05,
                "{what}: {dx:+.5} m {dy:+.5} m {dtheta:+.4}° {r:?}"
            );
        }

        #[test]
        fn crs2_recovers_the_transform_for_several_seeds() {
            let (reference, current) = room_pair(TRUTH);
            for (k, guess) in guesses().into_iter().enumerate() {
                for seed in 0..5 {
                    let mut cost =
                        Objective::new(&reference, &current, &ObjectiveParams::default());
                    let r = simultaneous(
                        &mut cost,
                        guess,
                        Optimizer::Crs2,
                        &SearchParams::default(),
                        seed,
                    );
                    assert_recovered(&r, &format!("guess {k} seed {seed}"));
                    assert!(r.pairs >= 40 && r.f < 0.01, "{r:?}");
                }
            }
        }

        #[test]
        fn every_optimizer_returns_a_finite_pose_and_the_global_ones_lower_f() {
            let (reference, current) = room_pair(TRUTH);
            for o in Optimizer::ALL {
                let mut cost = Objective::new(&reference, &current, &ObjectiveParams::default());
                let r = simultaneous(&mut cost, guesses()[0], o, &SearchParams::default(), 9);
                assert!(
                    r.pose.is_finite() && r.f.is_finite() && r.f <= r.f_initial,
                    "{o:?}: {r:?}"
                );
                assert!(matches!(r.stop, Stop::Optimiser(_)), "{o:?}: {r:?}");
                if o.is_global() {
                    assert!(r.f < r.f_initial, "{o:?}: {r:?}");
                }
            }
        }

        #[test]
        fn same_seed_same_result_different_seed_different_trace() {
            let (reference, current) = room_pair(TRUTH);
            let run = |seed: u64| {
                let mut cost = Recording {
                    inner: Objective::new(&reference, &current, &ObjectiveParams::default()),
                    trace: Vec::new(),
                };
                let r = simultaneous(
                    &mut cost,
                    guesses()[1],
                    Optimizer::Crs2,
                    &SearchParams::default(),
                    seed,
                );
                (r, cost.trace)
            };
            let (a, trace_a) = run(2024);
            let (b, trace_b) = run(2024);
            assert_eq!(a, b);
            assert_eq!(trace_a, trace_b);
            let (_, trace_c) = run(2025);
            assert_ne!(trace_a, trace_c);
        }
    }
}
