//! FastSLAM 2.0 on point and line landmarks: (World odometry, per-step [`Observation`]s, a
//! [`MotionModel`]) → [`Trace`]. [FS2] Montemerlo, Thrun, Koller, Wegbreit, "FastSLAM 2.0",
//! IJCAI 2003, §3; [MM] Montemerlo's thesis (CMU 2003) ch. 4; [PR] Thrun, Burgard, Fox,
//! *Probabilistic Robotics*, the FastSLAM 2.0 table of ch. 13 (Table 13.3).
//!
//! Per step, every particle (x, w, map):
//! - moves without observations: x ~ p(x | x₋, u) (the motion model's own sample);
//! - with observations, associates them against its map as it was before the step, judging
//!   each landmark under the *predicted* pose with its uncertainty; samples its pose from the
//!   proposal that includes the associated observations; updates the landmark EKFs from the
//!   sampled pose; and multiplies its weight by each observation's predictive likelihood.
//!
//! Then, as in FastSLAM 1.0 ([FT] Table 6.3): the best particle is taken after weighting and
//! before resampling, and systematic resampling follows when N̂eff falls below the threshold.
//!
//! The equations, numbered for this file (the symbols of [FS2] in brackets; [PR] writes Q for
//! the measurement noise and R for the motion noise, the other way round):
//! - (1) x̂ = x ⊕ u, Q = cov(x̂): the motion prediction [ŝ_t, P_t].
//! - (2) Z = H_m Σ H_mᵀ + R: the measurement's covariance given the pose [Q_t].
//! - (3) S = H_x Q H_xᵀ + Z: its covariance given the previous pose and the control [L_t].
//! - (4) Σx ← (H_xᵀ Z⁻¹ H_x + Σx⁻¹)⁻¹: proposal covariance [Σ_{s_t}].
//! - (5) μ ← μ + Σx H_xᵀ Z⁻¹ (z − ẑ(μ)): proposal mean [μ_{s_t}].
//! - (6) x ~ N(μ, Σx).
//! - (7) landmark EKF from the sampled pose: K = Σ H_mᵀ Z⁻¹, μ_m += K ν,
//!   Σ ← (I − K H_m) Σ (I − K H_m)ᵀ + K R Kᵀ (Joseph form).
//! - (8) w ← w · p(z_matched | x_{t−1}, u, map) · P0 per new landmark · 1 per ignored one
//!   [importance weight N(z_t; ẑ_t, L_t)], the matched observations' *joint* predictive density.
//!
//! Choices:
//! - Several observations per step fold into the proposal one after another, each relinearised
//!   at the current proposal mean μ (an iterated, sequential update; [PR]'s table linearises at
//!   x̂ and treats a single measurement). (4)–(5) are computed in their Kalman form
//!   K = Σx H_xᵀ (H_x Σx H_xᵀ + Z)⁻¹, Σx ← (I − K H_x) Σx (I − K H_x)ᵀ + K Z Kᵀ, μ ← μ + K ν, which
//!   is the same by the matrix inversion lemma (K = Σx' H_xᵀ Z⁻¹) but needs no Σx⁻¹, so a motion
//!   model with zero noise in one component works.
//! - Maximum-likelihood association scores landmark j by N(z; ẑ_j(x̂), S_j), the density (8)
//!   also weights with ([PR]'s π_j, evaluated at x̂ instead of at a per-landmark sample), against
//!   P0 and the thesis's ambiguity rules, as FastSLAM 1.0 does.
//! - The joint density of (8) is the product of the chain-rule factors the proposal computes
//!   anyway: observation j's N(z_j; ẑ_j(μ_{j−1}), H_x Σx_{j−1} H_xᵀ + Z_j), with the earlier
//!   observations already folded into (μ, Σx) — exact for linear-Gaussian models, where the
//!   product of the marginals at x̂ would count the shared pose error once per observation
//!   (tested against the joint Gaussian). The association-time density N(z; ẑ(x̂), S) decides
//!   the association only, and weighs an observation whose proposal step failed (counted).
//! - The proposal is sampled with a Cholesky factor that accepts zero pivots (a positive
//!   semi-definite Σx); an indefinite Σx falls back to the motion model's sample and is counted.
//! - A particle none of whose observations matched a known landmark samples from the motion
//!   model itself (the proposal is then the prior), exactly as on steps without observations.
//! - Maximum-likelihood association first skips landmarks whose likelihood bound from one
//!   component (range or line angle) cannot beat P0 — exact, it changes no decision.
//! - Known association, as in FastSLAM 1.0: an observation without an identity is an error
//!   ([`SlamError::NoIdentities`]); an identity seen twice in one step is created by its first
//!   sighting and the second is ignored. Landmarks keep their identity only under known
//!   association (what [`super::LandmarkMap::point_ids`] promises).
//! - A matched observation's importance factor counts even if its landmark's EKF update then
//!   fails (counted): the factor is the predictive density, which does not depend on it.
//!
//! Private and for the tests only, the same code can sample from the motion model instead
//! (FastSLAM 1.0: association and weights N(z; ẑ(x), Z) at the sampled pose), to show what the
//! proposal buys.

use super::driver::{self, Filter};
use super::fastslam::association::{Association, Candidates, resolve_shared};
use super::fastslam::models::{FullPrediction, Model};
use super::fastslam::particle::{self, Landmark, Map, Particle};
use super::fastslam::{DataAssociation, FastSlamParams, ParticleRecord, pose_belief, resample};
use super::motion::MotionModel;
use super::observations::{Observation, StepObservations};
use super::{SlamError, Trace};
use crate::geom::{Pose2, wrap_angle};
use crate::world::World;
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::collections::BTreeMap;
use std::f64::consts::PI;

pub const CODE_VERSION: &str = "fastslam2-4";

/// ln(2π), the normalising constant of a bivariate Gaussian's log density.
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// A Cholesky pivot of the proposal covariance within this fraction of its largest diagonal
/// entry counts as zero (a direction without uncertainty). Far above the rounding of a 3 × 3
/// factorisation (~10 ε), far below any physical pose variance ratio.
const PIVOT_RELATIVE_TOLERANCE: f64 = 1e-12;

/// How far L Lᵀ may differ from the factored matrix, relative to its largest diagonal entry,
/// before it counts as indefinite (a zero pivot with a non-zero column below it).
const FACTOR_RELATIVE_TOLERANCE: f64 = 1e-9;

/// Where the particles' poses are drawn from. Private: FastSLAM 1.0 sampling exists only so
/// the tests can show what the proposal buys.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Proposal {
    /// [FS2]: the motion prediction conditioned on the step's associated observations.
    Observations,
    /// FastSLAM 1.0: the motion model alone; association and weights at the sampled pose.
    #[cfg_attr(not(test), allow(dead_code))] // only the tests compare against it
    Motion,
}

/// One landmark's prediction of an observation under an uncertain pose.
#[derive(Debug, Clone, Copy)]
struct Match {
    /// ẑ, H_x and H_m at the pose the match was evaluated at.
    full: FullPrediction,
    /// Z = H_m Σ H_mᵀ + R.
    z_cov: Matrix2<f64>,
    /// S = H_x P H_xᵀ + Z for the pose covariance P.
    s: Matrix2<f64>,
    /// z − ẑ, angle wrapped.
    innovation: Vector2<f64>,
    /// ln N(z; ẑ, S).
    log_likelihood: f64,
}

/// ln N(ν; 0, S) with the closed-form 2 × 2 inverse, or `None` if S is not positive definite or
/// the result is not finite.
fn log_gaussian(nu: &Vector2<f64>, s: &Matrix2<f64>) -> Option<f64> {
    let det = s[(0, 0)] * s[(1, 1)] - s[(0, 1)] * s[(1, 0)];
    if !(det > 0.0 && s[(0, 0)] > 0.0 && det.is_finite()) {
        return None;
    }
    let d2 = (s[(1, 1)] * nu[0] * nu[0] - (s[(0, 1)] + s[(1, 0)]) * nu[0] * nu[1]
        + s[(0, 0)] * nu[1] * nu[1])
        / det;
    let ll = -0.5 * d2 - LN_2PI - 0.5 * det.ln();
    ll.is_finite().then_some(ll)
}

/// Landmark `l` as the source of `o`, seen from `pose` known up to covariance `pose_cov`
/// (Eqs. 2, 3 and the likelihood of 8). `None` when S is singular.
fn evaluate(o: &Observation, l: &Landmark, pose: &Pose2, pose_cov: &Matrix3<f64>) -> Option<Match> {
    let full = o.model.predict_full(&l.mean, pose);
    let (hx, hm) = (full.h_pose, full.h_landmark);
    let z_cov = hm * l.cov * hm.transpose() + o.r; // Eq. (2)
    let s = hx * pose_cov * hx.transpose() + z_cov; // Eq. (3)
    let innovation = o.model.innovation(&o.z, &full.z);
    let log_likelihood = log_gaussian(&innovation, &s)?; // Eq. (8)
    Some(Match { full, z_cov, s, innovation, log_likelihood })
}

/// An upper bound on ln N(z; ẑ, S) from one component, without the trigonometry and matrix
/// products of [`evaluate`]: points from the range (row (−u, 0) of H_x and u of H_m, u the unit
/// vector to the landmark), lines from the angle (rows (0, 0, −1) and (0, 1), flipped or not).
/// The marginal Mahalanobis distance bounds the joint one from below, and det S ≥ det R since
/// S − R ⪰ 0. A landmark whose bound is at most ln P0 can never be chosen nor count as a
/// plausible candidate: skipping it changes no decision. +∞ (no skipping) when R is singular.
fn log_likelihood_bound(
    o: &Observation,
    l: &Landmark,
    pose: &Pose2,
    pose_cov: &Matrix3<f64>,
    ln_det_r: f64,
) -> f64 {
    if !ln_det_r.is_finite() {
        return f64::INFINITY;
    }
    let (nu, s) = match o.model {
        Model::Point => {
            let (dx, dy) = (l.mean[0] - pose.x, l.mean[1] - pose.y);
            let r = dx.hypot(dy);
            if r.is_nan() || r <= 0.0 {
                return f64::INFINITY; // left to `evaluate`, which counts it
            }
            let u = Vector2::new(dx / r, dy / r);
            let s =
                (u.transpose() * (pose_cov.fixed_view::<2, 2>(0, 0) + l.cov) * u)[0] + o.r[(0, 0)]; // S_rr
            (o.z[0] - r, s)
        }
        Model::Line => {
            let nu = wrap_angle(o.z[1] - (l.mean[1] - pose.theta)).abs();
            (nu.min((PI - nu).abs()), pose_cov[(2, 2)] + l.cov[(1, 1)] + o.r[(1, 1)]) // S_θθ
        }
    };
    -0.5 * nu * nu / s - LN_2PI - 0.5 * ln_det_r
}

/// Folds one observation of landmark `l` into the pose proposal N(μ, Σx), relinearised at μ:
/// Eqs. (4)–(5) in Kalman form. Returns the observation's chain-rule factor of the importance
/// weight, ln N(z; ẑ(μ), H_x Σx H_xᵀ + Z) = ln p(z_j | z_1..j−1, x_{t−1}, u) with the earlier
/// observations already folded in; leaves the proposal unchanged and returns `None` when S is
/// singular or the result is not finite.
fn refine(mu: &mut Pose2, sigma: &mut Matrix3<f64>, o: &Observation, l: &Landmark) -> Option<f64> {
    let m = evaluate(o, l, mu, sigma)?;
    let s_inv = m.s.try_inverse()?;
    let hx = m.full.h_pose;
    let k = *sigma * hx.transpose() * s_inv; // K = Σx H_xᵀ S⁻¹ = Σx' H_xᵀ Z⁻¹
    let i_kh = Matrix3::identity() - k * hx;
    let next = i_kh * *sigma * i_kh.transpose() + k * m.z_cov * k.transpose(); // Eq. (4)
    let next = 0.5 * (next + next.transpose());
    let step = k * m.innovation; // Eq. (5)
    if !(next.iter().all(|v| v.is_finite()) && step.iter().all(|v| v.is_finite())) {
        return None;
    }
    *mu = Pose2::new(mu.x + step[0], mu.y + step[1], wrap_angle(mu.theta + step[2]));
    *sigma = next;
    Some(m.log_likelihood)
}

/// [`refine`] for several readings of one landmark, stacked into one observation: innovations
/// ν = (ν₁ … ν_n), H_x stacked, and Z = H_m P H_mᵀ + blockdiag(R_i), whose off-diagonal blocks
/// H_mi P H_mjᵀ are the landmark error the readings share. Returns the readings' joint factor
/// ln N(ν; 0, H_x Σx H_xᵀ + Z).
fn refine_stacked(
    mu: &mut Pose2,
    sigma: &mut Matrix3<f64>,
    readings: &[&Observation],
    l: &Landmark,
) -> Option<f64> {
    use nalgebra::{DMatrix, DVector};
    let n = 2 * readings.len();
    let (mut hx, mut hm) = (DMatrix::<f64>::zeros(n, 3), DMatrix::<f64>::zeros(n, 2));
    let (mut r, mut nu) = (DMatrix::<f64>::zeros(n, n), DVector::<f64>::zeros(n));
    for (i, o) in readings.iter().enumerate() {
        let full = o.model.predict_full(&l.mean, mu);
        hx.view_mut((2 * i, 0), (2, 3)).copy_from(&full.h_pose);
        hm.view_mut((2 * i, 0), (2, 2)).copy_from(&full.h_landmark);
        r.view_mut((2 * i, 2 * i), (2, 2)).copy_from(&o.r);
        nu.rows_mut(2 * i, 2).copy_from(&o.model.innovation(&o.z, &full.z));
    }
    let p = DMatrix::from_iterator(2, 2, l.cov.iter().copied());
    let z_cov = &hm * p * hm.transpose() + r;
    let sx = DMatrix::from_iterator(3, 3, sigma.iter().copied());
    let s = &hx * &sx * hx.transpose() + &z_cov;
    let s_inv = s.clone().try_inverse()?;
    let k = &sx * hx.transpose() * &s_inv;
    let i_kh = DMatrix::<f64>::identity(3, 3) - &k * &hx;
    let next = &i_kh * &sx * i_kh.transpose() + &k * &z_cov * k.transpose();
    let next = Matrix3::from_iterator((0.5 * (&next + next.transpose())).iter().copied());
    let step = &k * &nu;
    let log_likelihood = -0.5 * (nu.transpose() * &s_inv * &nu)[0]
        - 0.5 * (n as f64 * (2.0 * PI).ln() + s.determinant().ln());
    if !(next.iter().all(|v| v.is_finite())
        && step.iter().all(|v| v.is_finite())
        && log_likelihood.is_finite())
    {
        return None;
    }
    *mu = Pose2::new(mu.x + step[0], mu.y + step[1], wrap_angle(mu.theta + step[2]));
    *sigma = next;
    Some(log_likelihood)
}

/// Lower-triangular L with L Lᵀ = A for a symmetric positive semi-definite 3 × 3 A (Cholesky–
/// Banachiewicz; a pivot within [`PIVOT_RELATIVE_TOLERANCE`] of zero leaves its column zero:
/// a direction without uncertainty). `None` if A is indefinite or not finite.
fn psd_cholesky(a: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if !a.iter().all(|v| v.is_finite()) {
        return None;
    }
    let scale = a.diagonal().max().max(0.0);
    let tol = PIVOT_RELATIVE_TOLERANCE * scale;
    let mut l = Matrix3::zeros();
    for j in 0..3 {
        let d = a[(j, j)] - (0..j).map(|k| l[(j, k)] * l[(j, k)]).sum::<f64>();
        if d < -tol {
            return None;
        }
        if d <= tol {
            continue; // zero pivot: checked below that nothing was lost
        }
        let ljj = d.sqrt();
        l[(j, j)] = ljj;
        for i in j + 1..3 {
            l[(i, j)] = (a[(i, j)] - (0..j).map(|k| l[(i, k)] * l[(j, k)]).sum::<f64>()) / ljj;
        }
    }
    ((l * l.transpose() - a).abs().max() <= FACTOR_RELATIVE_TOLERANCE * scale).then_some(l)
}

/// EKF correction of landmark `l` from the sampled pose (Eq. 7). Leaves `l` unchanged and
/// returns `false` when Z is singular or the result is not finite.
fn correct(l: &mut Landmark, o: &Observation, pose: &Pose2) -> bool {
    let p = l.predict(o.model, pose);
    let h = p.h;
    let z_cov = h * l.cov * h.transpose() + o.r; // Eq. (2)
    let Some(z_inv) = z_cov.try_inverse() else { return false };
    let k = l.cov * h.transpose() * z_inv; // Eq. (7)
    let i_kh = Matrix2::identity() - k * h;
    let mut mean = l.mean + k * o.model.innovation(&o.z, &p.z);
    let cov = i_kh * l.cov * i_kh.transpose() + k * o.r * k.transpose(); // Eq. (7), Joseph form
    let mut cov = 0.5 * (cov + cov.transpose());
    if !(mean.iter().all(|v| v.is_finite()) && cov.iter().all(|v| v.is_finite())) {
        return false;
    }
    o.model.normalise(&mut mean, &mut cov);
    l.mean = mean;
    l.cov = cov;
    l.refresh();
    true
}

/// A new landmark from the inverse model with Σ = H_m⁻¹ R H_m⁻ᵀ ([FT] Table 3.2), or `None`
/// if H_m is singular there.
fn initialise(o: &Observation, pose: &Pose2, id: Option<usize>) -> Option<Landmark> {
    let mean = o.model.inverse(&o.z, pose);
    let h_inv = o.model.predict(&mean, pose).h.try_inverse()?;
    let cov = h_inv * o.r * h_inv.transpose();
    let cov = 0.5 * (cov + cov.transpose());
    (mean.iter().all(|v| v.is_finite()) && cov.iter().all(|v| v.is_finite()))
        .then(|| Landmark { id, ..Landmark::new(mean, cov) })
}

/// Each observation's association against one particle's map.
type Decisions = Vec<Association>;

/// The filter state.
struct FastSlam2<'a> {
    params: &'a FastSlamParams,
    motion: &'a MotionModel,
    proposal: Proposal,
    particles: Vec<Particle>,
    /// The current normalised weights (uniform after resampling).
    weights: Vec<f64>,
    /// Index of the best particle (after the last weighting, followed through resampling).
    best: usize,
    ln_p0: f64,
    numerical_failures: u64,
    resamples: u64,
    weighted_steps: u64,
}

impl<'a> FastSlam2<'a> {
    fn new(
        params: &'a FastSlamParams,
        motion: &'a MotionModel,
        proposal: Proposal,
        start: Pose2,
    ) -> Self {
        // `FastSlamParams::validate` rejects 0 particles; one keeps the filter defined anyway.
        let m = (params.particles as usize).max(1);
        Self {
            params,
            motion,
            proposal,
            particles: vec![Particle::new(start); m],
            weights: vec![1.0 / m as f64; m],
            best: 0,
            ln_p0: params.p0.ln(),
            numerical_failures: 0,
            resamples: 0,
            weighted_steps: 0,
        }
    }

    /// One step. Returns N̂eff when the step weighted the particles.
    fn step(
        &mut self,
        control: Option<&Pose2>,
        z: &[Observation],
        rng: &mut ChaCha8Rng,
    ) -> Option<f64> {
        for i in 0..self.particles.len() {
            self.advance(i, control, z, rng); // predict, associate, propose, sample, update, weight
        }
        (!z.is_empty()).then(|| self.select(rng)) // best particle, resample
    }

    /// Moves particle `i` and, with observations, associates, updates its map and weights it.
    fn advance(
        &mut self,
        i: usize,
        control: Option<&Pose2>,
        z: &[Observation],
        rng: &mut ChaCha8Rng,
    ) {
        let previous = self.particles[i].pose;
        let Some(u) = control else {
            // the start: the pose is known exactly, nothing to sample
            if !z.is_empty() {
                let decisions = self.associate(i, &previous, &Matrix3::zeros(), z);
                self.update(i, previous, z, &decisions);
            }
            return;
        };
        if z.is_empty() {
            self.particles[i].pose = self.motion.sample(&previous, u, rng); // no observation: p(x | x₋, u)
            return;
        }
        let pose = match self.proposal {
            Proposal::Observations => {
                let predicted = self.motion.predict(&previous, u); // Eq. (1)
                let q = self.motion.covariance(&previous, u); // Eq. (1)
                let mut decisions = self.associate(i, &predicted, &q, z);
                let pose =
                    self.sample_proposal(i, (&previous, u), (predicted, q), z, &mut decisions, rng);
                self.update(i, pose, z, &decisions);
                pose
            }
            Proposal::Motion => {
                let pose = self.motion.sample(&previous, u, rng);
                let decisions = self.associate(i, &pose, &Matrix3::zeros(), z);
                self.update(i, pose, z, &decisions);
                pose
            }
        };
        self.particles[i].pose = pose;
    }

    /// Associates every observation against particle `i`'s map (as it was before this step),
    /// seen from `pose` with covariance `pose_cov`.
    fn associate(
        &mut self,
        i: usize,
        pose: &Pose2,
        pose_cov: &Matrix3<f64>,
        z: &[Observation],
    ) -> Decisions {
        let (ln_p0, rule) = (self.ln_p0, self.params.ambiguity);
        let known = self.params.association == DataAssociation::Known;
        let map = &self.particles[i].map;
        let mut failures = 0;
        let mut decisions: Decisions = z
            .iter()
            .map(|o| {
                let landmarks = map.of(o.model);
                if known {
                    // the landmark created from this identity, else a new one (`run` checked
                    // that every observation has an identity)
                    return match o.landmark.and_then(|id| map.find_id(o.model, id)) {
                        None => Association::New,
                        Some(j) => match evaluate(o, &landmarks[j], pose, pose_cov) {
                            Some(m) => {
                                Association::Known { landmark: j, log_likelihood: m.log_likelihood }
                            }
                            None => {
                                failures += 1;
                                Association::Ignored
                            }
                        },
                    };
                }
                let ln_det_r = o.r.determinant().ln();
                let mut candidates = Candidates::new(ln_p0);
                for (j, l) in landmarks.iter().enumerate() {
                    if log_likelihood_bound(o, l, pose, pose_cov, ln_det_r) <= ln_p0 {
                        continue; // cannot beat P0: not a candidate
                    }
                    match evaluate(o, l, pose, pose_cov) {
                        Some(m) => candidates.offer(j, m.log_likelihood, ()),
                        None => failures += 1,
                    }
                }
                candidates.decide(rule).0
            })
            .collect();
        // The shared-landmark rule compares observations of the same landmark type
        // (identities never collide under known association).
        for model in [Model::Line, Model::Point].into_iter().filter(|_| !known) {
            let idx: Vec<usize> = (0..z.len()).filter(|&k| z[k].model == model).collect();
            let mut ds: Vec<Association> = idx.iter().map(|&k| decisions[k]).collect();
            resolve_shared(&mut ds, rule);
            for (&k, d) in idx.iter().zip(ds) {
                decisions[k] = d;
            }
        }
        self.numerical_failures += failures;
        decisions
    }

    /// Draws particle `i`'s pose from the proposal: the motion prediction (x̂, Q) refined by
    /// every observation matched to a known landmark (Eqs. 4–6): three standard normals. With
    /// nothing matched, or an indefinite Σx (counted), the motion model's sample instead, with the
    /// normals that model draws ([`MotionModel::sample`]).
    /// Each matched observation's weight factor becomes its chain-rule factor (see [`refine`]):
    /// together they are the joint predictive density of the matched observations, whose shared
    /// pose error the product of their marginals would count once per observation. A failed
    /// refinement keeps the association's value.
    fn sample_proposal(
        &mut self,
        i: usize,
        (previous, u): (&Pose2, &Pose2),
        (predicted, q): (Pose2, Matrix3<f64>),
        z: &[Observation],
        decisions: &mut Decisions,
        rng: &mut ChaCha8Rng,
    ) -> Pose2 {
        let map = &self.particles[i].map;
        let (mut mu, mut sigma) = (predicted, q);
        let mut refined = 0;
        // A landmark that several observations picked (maximum-likelihood association without
        // the shared-landmark rule) is folded once, with its readings stacked: they share the
        // landmark's error, which folding each against the unchanged landmark would count once
        // per reading. The group's factor goes to its first reading.
        // The readings that chose each landmark, in reading order: reading k's group is the rest
        // of its landmark's list from k on (found in O(z), not by a scan of the later readings).
        let mut chose: BTreeMap<(bool, usize), Vec<usize>> = BTreeMap::new();
        for (k, d) in decisions.iter().enumerate() {
            if let Association::Known { landmark, .. } = *d {
                chose.entry((z[k].model == Model::Point, landmark)).or_default().push(k);
            }
        }
        let mut folded = vec![false; z.len()];
        for k in 0..z.len() {
            let Association::Known { landmark, .. } = decisions[k] else { continue };
            if folded[k] {
                continue;
            }
            let o = &z[k];
            let list = &chose[&(o.model == Model::Point, landmark)];
            let group: Vec<usize> = list[list.partition_point(|&g| g < k)..].to_vec();
            let l = &map.of(o.model)[landmark];
            let factor = if group.len() == 1 {
                refine(&mut mu, &mut sigma, o, l)
            } else {
                let readings: Vec<&Observation> = group.iter().map(|&g| &z[g]).collect();
                refine_stacked(&mut mu, &mut sigma, &readings, l)
            };
            match factor {
                Some(factor) => {
                    for (n, &g) in group.iter().enumerate() {
                        folded[g] = true;
                        if let Association::Known { log_likelihood, .. } = &mut decisions[g] {
                            *log_likelihood = if n == 0 { factor } else { 0.0 };
                        }
                    }
                    refined += 1;
                }
                None => self.numerical_failures += 1,
            }
        }
        if refined == 0 {
            return self.motion.sample(previous, u, rng); // the proposal is the motion model
        }
        let Some(l) = psd_cholesky(&sigma) else {
            self.numerical_failures += 1;
            return self.motion.sample(previous, u, rng);
        };
        let n: Vector3<f64> = Vector3::new(
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        );
        let d = l * n; // Eq. (6)
        Pose2::new(mu.x + d[0], mu.y + d[1], wrap_angle(mu.theta + d[2]))
    }

    /// Updates particle `i`'s landmarks from its sampled `pose` (Eq. 7), adds the new ones, and
    /// multiplies its weight (Eq. 8) by each decision's factor.
    fn update(&mut self, i: usize, pose: Pose2, z: &[Observation], decisions: &Decisions) {
        let known = self.params.association == DataAssociation::Known;
        let ln_p0 = self.ln_p0;
        let mut failures = 0;
        let mut log_weight = 0.0;
        let p = &mut self.particles[i];
        if decisions.iter().any(|d| !matches!(d, Association::Ignored)) {
            let map: &mut Map = p.map_mut(); // copied here only if shared
            for (o, d) in z.iter().zip(decisions) {
                match *d {
                    Association::Known { landmark, log_likelihood } => {
                        log_weight += log_likelihood; // Eq. (8): the chain-rule factor, jointly
                        if !correct(&mut map.of_mut(o.model)[landmark], o, &pose) {
                            failures += 1;
                        }
                    }
                    Association::New => {
                        let id = if known { o.landmark } else { None };
                        match initialise(o, &pose, id) {
                            Some(l) => {
                                map.push(o.model, l);
                                log_weight += ln_p0; // Eq. (8)
                            }
                            None => failures += 1,
                        }
                    }
                    Association::Ignored => {} // weight factor 1
                }
            }
        }
        p.log_weight += log_weight;
        p.lineage_log_weight += log_weight; // [PF] Eq. 20: never normalised nor reset
        self.numerical_failures += failures;
    }

    /// After weighting: the best particle, N̂eff, and resampling below the threshold.
    fn select(&mut self, rng: &mut ChaCha8Rng) -> f64 {
        self.weighted_steps += 1;
        let weights = self.normalised_weights();
        self.best = particle::argmax(&weights); // before resampling
        let neff = resample::effective_sample_size(&weights);
        if neff < self.params.neff_threshold {
            self.resample(&weights, rng);
        } else {
            self.weights = weights;
        }
        neff
    }

    /// Normalised weights; all weights unusable is a numerical failure, counted, and the weights
    /// made uniform.
    fn normalised_weights(&mut self) -> Vec<f64> {
        particle::normalised_weights(&mut self.particles).unwrap_or_else(|| {
            self.numerical_failures += 1;
            vec![1.0 / self.particles.len() as f64; self.particles.len()]
        })
    }

    /// Systematic resampling; the maps are shared, not copied.
    fn resample(&mut self, weights: &[f64], rng: &mut ChaCha8Rng) {
        let ancestors = resample::low_variance(weights, rng);
        (self.particles, self.best) = particle::resampled(&self.particles, &ancestors, self.best);
        self.weights = vec![1.0 / ancestors.len() as f64; ancestors.len()];
        self.resamples += 1;
    }

    /// The weighted mean of the particle poses and their weighted spread around it.
    fn pose_belief(&self) -> (Pose2, Matrix3<f64>) {
        let poses: Vec<Pose2> = self.particles.iter().map(|p| p.pose).collect();
        pose_belief(&poses, Some(&self.weights))
    }
}

/// Runs FastSLAM 2.0 over a world's odometry and an observation stream (in step order).
/// `points_as_corners`: point landmarks are laser corners (else the map's point landmarks, with
/// their identities under known association).
pub fn run(
    world: &World,
    params: &FastSlamParams,
    motion: &MotionModel,
    observations: &[StepObservations],
    points_as_corners: bool,
    rng: &mut ChaCha8Rng,
) -> Result<Trace, SlamError> {
    run_with(world, params, motion, observations, points_as_corners, Proposal::Observations, rng)
}

fn run_with(
    world: &World,
    params: &FastSlamParams,
    motion: &MotionModel,
    observations: &[StepObservations],
    points_as_corners: bool,
    proposal: Proposal,
    rng: &mut ChaCha8Rng,
) -> Result<Trace, SlamError> {
    if params.association == DataAssociation::Known
        && observations.iter().flat_map(|s| &s.observations).any(|o| o.landmark.is_none())
    {
        return Err(SlamError::NoIdentities);
    }
    let Some(&start) = world.truth.first() else { return Ok(Trace::default()) };
    let record = ParticleRecord::new(params, world.odometry.len());
    let run = Fastslam2Run {
        filter: FastSlam2::new(params, motion, proposal, start),
        rng,
        record,
        points_as_corners,
    };
    driver::run(world, observations, params.association == DataAssociation::Known, run)
}

/// FastSLAM 2.0 as the driver steps it.
struct Fastslam2Run<'a, 'r> {
    filter: FastSlam2<'a>,
    rng: &'r mut ChaCha8Rng,
    record: ParticleRecord,
    points_as_corners: bool,
}

impl Filter for Fastslam2Run<'_, '_> {
    fn step(
        &mut self,
        k: usize,
        control: Option<&Pose2>,
        observations: &[Observation],
    ) -> Result<(), SlamError> {
        let f = &mut self.filter;
        let neff = f.step(control, observations, self.rng);
        let belief = f.pose_belief();
        self.record.record(k, neff, &mut f.particles, f.best, Some(belief), true)
    }

    fn finish(self) -> Trace {
        let f = self.filter;
        let counts = (f.numerical_failures, f.resamples, f.weighted_steps);
        self.record.finish(&f.particles, f.best, self.points_as_corners, counts)
    }
}

#[cfg(test)]
mod tests;
