//! Scan matching ([EP]): (reference scan, current scan, initial guess) → the current scan's pose in
//! the reference frame. Pure: no IO, no threads, no global RNG; stochastic optimisers are seeded
//! by the caller.
//!
//! Conventions (one for every matcher): SI units inside (m, rad); the laser frame has x forward
//! and bearings increase counter-clockwise (a 180° scan spans [−π/2, π/2]); a pose (x, y, θ) is
//! the current laser pose expressed in the reference laser frame. PSM's cm constants are
//! converted at their definition. The objective f is reported in cm² (see [`objective`]).
//!
//! Layout:
//! - [`scan`]: [`scan::PolarScan`], a prepared scan (filtered ranges, validity, segment labels).
//! - [`segment`]: preprocessing — Diosi's heuristics, line segmentation, or none.
//! - [`objective`]: projection (Eq. 1–2), interpolation within segments, z-buffer, the occlusion
//!   rule (Eq. 3) and f (Eq. 4): the one cost every matcher is scored by.
//! - [`psm`]: Diosi & Kleeman's Polar Scan Matching as Diosi's v0.3 program computes it.
//! - [`real`]: the precision PSM computes in (single, as v0.3, or double).
//! - [`epsm`]: E-PSM's alternating orientation/position search (§5.3.1), with the BOBYQA
//!   position step and the f-check as options.
//! - [`search`]: simultaneous (x, y, θ) search with NLopt's optimisers (§5.3.2).
//! - [`brute`]: the brute-force reference (translation grid + E-PSM's orientation search).
//! - [`track`]: laser odometry — a world's scans matched in sequence, with the per-match records.
//! - [`diagnose`]: one match re-run with observers — f(θ) slices, PSM's criterion, f contours,
//!   paths — and the incremental maps ([EP] Figs 25–27, 52–59).

pub mod brute;
pub mod diagnose;
pub mod epsm;
pub mod objective;
pub mod plicp;
pub mod psm;
pub mod real;
pub mod scan;
pub mod search;
pub mod segment;
pub mod track;

use crate::geom::Pose2;

/// The cost a pose search minimises. Implemented by [`objective::Objective`]; matchers are generic
/// over it so they can be tested on synthetic costs.
pub trait Cost {
    /// f at `pose` (current laser pose in the reference frame). `+∞` when the pose leaves too few
    /// valid pairs to be judged.
    fn f(&mut self, pose: Pose2) -> f64;
    /// Range residuals r_ref − r̂_cur [m] at every reference beam (`out.len()` = reference beams),
    /// NaN where the beam has no valid pair; returns the number of valid pairs.
    fn residuals(&mut self, pose: Pose2, out: &mut [f64]) -> usize;
    /// Number of reference beams (length of the residual vector).
    fn beams(&self) -> usize;
    /// How many times `f` or `residuals` was called so far (each is one projection).
    fn evaluations(&self) -> u64;
}

/// Why a matcher stopped.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Stop {
    /// Its convergence test passed.
    Converged,
    /// It used its iteration or evaluation budget.
    Budget,
    /// Too few valid pairs to go on (the estimate is the last good one, or the initial guess).
    TooFewPairs,
    /// A singular least-squares system.
    Singular,
    /// What NLopt returned (success codes included), e.g. "XtolReached".
    Optimiser(String),
}

/// One match.
#[derive(Debug, Clone, PartialEq)]
pub struct MatchResult {
    /// The estimate: the current laser pose in the reference frame.
    pub pose: Pose2,
    /// f at `pose` [cm²] (the common objective, whatever the matcher optimised).
    pub f: f64,
    /// f at the initial guess [cm²].
    pub f_initial: f64,
    /// Valid pairs at `pose`.
    pub pairs: usize,
    /// Matcher iterations (PSM/E-PSM half-iterations; NLopt: 0).
    pub iterations: u32,
    /// Objective evaluations (projections) spent.
    pub evaluations: u64,
    /// The f-check rejected the estimate and `pose` is the initial guess.
    pub fallback: bool,
    pub stop: Stop,
}
