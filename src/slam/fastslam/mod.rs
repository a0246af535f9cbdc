//! FastSLAM 1.0 with line and corner landmarks: World (odometry + laser scans) → Trace, exactly
//! the filter loop of [FT] Table 6.3.
//!
//! Per odometry step every particle samples its pose from the motion model ([FT] Eq. 7.18). Per
//! scan with features:
//! - each particle associates every feature by Maximum Likelihood with a new-landmark likelihood
//!   P0, then updates its landmarks' 2 × 2 EKFs and multiplies its weight by the features'
//!   likelihoods (a new landmark contributes P0);
//! - the best particle is taken *after* weighting and *before* resampling, and its map is the
//!   output;
//! - systematic resampling follows when N̂eff = 1/Σw² falls below the threshold (∞ = always).

pub mod association;
pub mod models;
pub mod particle;
pub mod resample;

use super::driver::{self, Filter};
use super::motion::MotionModel;
use super::observations::{self, Observation, Source, StepObservations};
use super::{LandmarkMap, SlamError, Trace};
use crate::config::{Checks, Violation};
use crate::features::FeatureParams;
use crate::geom::{Line, Point2, Pose2, wrap_angle};
use crate::world::World;
use crate::world::odometry::Spread;
use association::{Ambiguity, Association, Candidates, resolve_shared};
use models::{Model, Prediction};
use nalgebra::{Matrix2, Vector2};
use particle::{Landmark, Particle};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

pub const CODE_VERSION: &str = "fastslam1-4";

/// ln(2π), the normalising constant of a bivariate Gaussian's log density.
const LN_2PI: f64 = 1.837_877_066_409_345_5;

/// `[base.fastslam]`. Defaults: [FT] Table 10.2 (the Dmax study's fixed configuration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct FastSlamParams {
    /// M, the number of particles.
    pub particles: u32,
    /// P0: likelihood of the "new landmark" hypothesis (a density value, not a probability).
    pub p0: f64,
    /// Resample when N̂eff < this (an absolute particle count; `inf` = always, [FT]'s default;
    /// 1 ≈ never).
    pub neff_threshold: f64,
    /// Per-step pose noise of the motion model ([FT] Eq. 7.18), x component: σx [m] or σx² [m²]
    /// according to `motion_noise_is`.
    pub motion_x: f64,
    /// y component: σy [m] or σy² [m²].
    pub motion_y: f64,
    /// θ component: σθ [rad] or σθ² [rad²].
    pub motion_theta: f64,
    /// How `motion_*` are read. [FT] prints them as variances, diag(σx², σy², σθ²); read that
    /// way its values (e.g. 0.007 m² per step) swamp any realistic odometry and no step rate
    /// reproduces its results, while read as standard deviations they do — and the thesis
    /// mixes σ and σ² up elsewhere (its erratum 5). `experiments/ft-motion-noise-reading.toml`
    /// shows both readings.
    pub motion_noise_is: Spread,
    /// σρ² [m²] of line observations (and the range of corners, [FT]'s single laser covariance).
    pub obs_var_rho_m2: f64,
    /// σθ² [rad²] of line observations (and the bearing of corners).
    pub obs_var_theta_rad2: f64,
    /// Which ambiguous associations are ignored.
    pub ambiguity: Ambiguity,
    /// `maximum_likelihood` with P0 ([FT], the default) or `known`: the sensor's landmark
    /// identities ([PF] §V: "association was assumed known"). Written out only when not the
    /// default, so existing run hashes are unchanged.
    #[serde(skip_serializing_if = "DataAssociation::is_default")]
    pub association: DataAssociation,
    /// The trajectory (and map) reported: `best_per_step` (at every step the pose of the particle
    /// with the highest current weight; the map of the final best particle),
    /// `path_of_final_best` ([FT] §5: the final best particle's map and its own pose history),
    /// `path_of_best` ([PF] Eq. 20: the whole path and the map of the particle with the highest
    /// log-weight accumulated along its lineage), or `weighted_mean` (the weighted mean pose at
    /// every step; the final best particle's map). Written out only when not the default.
    #[serde(skip_serializing_if = "Estimate::is_default")]
    pub estimate: Estimate,
    /// Most landmarks a particle's map may hold: a run whose map grows past it fails cleanly
    /// (`LandmarkCap`) instead of exhausting memory and time — [FT]'s P0 = 100, whose map
    /// "explodes". Written out only when not the default.
    #[serde(skip_serializing_if = "is_default_landmark_cap")]
    pub max_landmarks: u32,
}

/// Default of [`FastSlamParams::max_landmarks`]: far above any map of the studies (the largest
/// holds a few hundred landmarks).
pub const DEFAULT_MAX_LANDMARKS: u32 = 2_000;

fn is_default_landmark_cap(v: &u32) -> bool {
    *v == DEFAULT_MAX_LANDMARKS
}

/// Which trajectory a particle filter reports (see [`FastSlamParams::estimate`]).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Estimate {
    #[default]
    BestPerStep,
    PathOfBest,
    /// [FT]: the final best particle (highest current weight) and its own pose history.
    PathOfFinalBest,
    WeightedMean,
}

impl Estimate {
    pub fn is_default(&self) -> bool {
        *self == Estimate::BestPerStep
    }

    /// Every particle keeps its path (shared ancestry) for this estimate.
    pub fn keeps_paths(&self) -> bool {
        matches!(self, Estimate::PathOfBest | Estimate::PathOfFinalBest)
    }

    /// The report's words for the trajectory and map this estimate reports.
    pub fn describe(&self) -> &'static str {
        match self {
            Estimate::BestPerStep => {
                "the best particle is the one with the highest current weight (the trajectory is its pose at every step, which may jump between lineages)."
            }
            Estimate::PathOfBest => {
                "the trajectory and map are those of the particle with the highest log-weight accumulated along its lineage ([PF] Eq. 20), its whole path kept through resampling."
            }
            Estimate::PathOfFinalBest => {
                "the map is the final best particle's (the highest current weight, taken after weighting and before resampling, [FT] §5) and the trajectory is that particle's own pose history, kept through resampling ([FT]: the best particle's pose history builds its grid map)."
            }
            Estimate::WeightedMean => {
                "the trajectory is the particles' weighted mean pose at every step; the map is the final best particle's."
            }
        }
    }
}

/// How FastSLAM matches observations to landmarks.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum DataAssociation {
    /// Per-particle Maximum Likelihood with the new-landmark likelihood P0 ([FT] §5.4).
    #[default]
    MaximumLikelihood,
    /// The sensor's landmark identities (only for sensors that report them).
    Known,
}

impl DataAssociation {
    pub fn is_default(&self) -> bool {
        *self == DataAssociation::MaximumLikelihood
    }
}

impl Default for FastSlamParams {
    fn default() -> Self {
        Self {
            particles: 100,
            p0: 0.005,
            neff_threshold: f64::INFINITY,
            motion_x: 0.007,
            motion_y: 0.007,
            motion_theta: 0.008,
            motion_noise_is: Spread::Std,
            obs_var_rho_m2: 0.04,
            obs_var_theta_rad2: 0.00122,
            ambiguity: Ambiguity::Both,
            association: DataAssociation::MaximumLikelihood,
            estimate: Estimate::BestPerStep,
            max_landmarks: DEFAULT_MAX_LANDMARKS,
        }
    }
}

/// Most particles a run may use (memory and time bound).
pub const MAX_PARTICLES: u32 = 100_000;

impl FastSlamParams {
    /// (σx [m], σy [m], σθ [rad]) of the per-step motion noise.
    pub fn motion_sigmas(&self) -> [f64; 3] {
        let sigma = |v: f64| match self.motion_noise_is {
            Spread::Std => v,
            Spread::Variance => v.sqrt(),
        };
        [sigma(self.motion_x), sigma(self.motion_y), sigma(self.motion_theta)]
    }

    /// The resampling threshold as the report states it: "∞ (always)" or the particle count.
    fn neff_text(&self) -> String {
        if self.neff_threshold.is_infinite() {
            "∞ (always)".to_string()
        } else {
            self.neff_threshold.to_string()
        }
    }

    /// The report's sentence on FastSLAM 1.0 on point-landmark worlds, and on FastSLAM 2.0 too
    /// when `with_fastslam2`: particles, association and resampling.
    pub fn describe_on_points(&self, with_fastslam2: bool) -> String {
        format!(
            "FastSLAM{}: {} particles, {} association, resampling when N̂eff < {}; {}",
            if with_fastslam2 { " 1.0 on point worlds and 2.0" } else { " 1.0 on point worlds" },
            self.particles,
            match self.association {
                DataAssociation::Known => "known".to_string(),
                DataAssociation::MaximumLikelihood =>
                    format!("maximum-likelihood (P0 = {})", self.p0),
            },
            self.neff_text(),
            self.estimate.describe(),
        )
    }

    /// The report's sentence on FastSLAM 1.0 on laser worlds ([FT] Table 6.3): particles, P0,
    /// resampling, its own motion noise and its reading, observation covariance, ambiguity rule.
    pub fn describe_on_lasers(&self) -> String {
        format!(
            "FastSLAM 1.0 on laser worlds ([FT] Table 6.3): {} particles, P0 = {}, resampling when N̂eff < {}; motion noise ({}, {}, {}) per step read as {}; observation covariance diag({}, {}); ambiguous associations: {}.",
            self.particles,
            self.p0,
            self.neff_text(),
            self.motion_x,
            self.motion_y,
            self.motion_theta,
            match self.motion_noise_is {
                Spread::Std => "standard deviations (σ)",
                Spread::Variance => "variances (σ²)",
            },
            self.obs_var_rho_m2,
            self.obs_var_theta_rad2,
            match self.ambiguity {
                Ambiguity::None => "kept (plain ML)",
                Ambiguity::MultipleCandidates => "ignored when several landmarks beat P0",
                Ambiguity::SharedLandmark => "ignored when two features choose one landmark",
                Ambiguity::Both =>
                    "ignored when several landmarks beat P0 or two features choose one landmark",
            }
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.require((1..=MAX_PARTICLES).contains(&self.particles), "particles", || {
            format!("must be in [1, {MAX_PARTICLES}], got {}", self.particles)
        });
        c.positive("p0", self.p0);
        c.require(self.neff_threshold >= 0.0, "neff_threshold", || {
            format!("must be ≥ 0 (inf = always resample), got {}", self.neff_threshold)
        });
        for (k, v) in [
            ("motion_x", self.motion_x),
            ("motion_y", self.motion_y),
            ("motion_theta", self.motion_theta),
        ] {
            c.non_negative(k, v);
        }
        c.positive("obs_var_rho_m2", self.obs_var_rho_m2);
        c.positive("obs_var_theta_rad2", self.obs_var_theta_rad2);
        c.require(self.max_landmarks >= 1, "max_landmarks", || "must be ≥ 1".to_string());
        c.finish()
    }
}

/// One landmark's prediction for a measurement: ẑ, H, Q = H Σ Hᵀ + R, and log N(z; ẑ, Q).
#[derive(Debug, Clone, Copy)]
struct Match {
    prediction: Prediction,
    q: Matrix2<f64>,
    innovation: Vector2<f64>,
    log_likelihood: f64,
}

/// An upper bound on a line landmark's log-likelihood from the angle alone, without trigonometry:
/// the θ row of H is (0, 1), so Q_θθ = Σ_θθ + R_θθ; the marginal Mahalanobis distance bounds
/// the joint one from below, and det Q ≥ det R since Q = H Σ Hᵀ + R ⪰ R. A landmark whose bound
/// is below ln P0 can never be chosen, nor count as a plausible candidate: skipping it changes
/// no decision.
fn line_bound(m: &Observation, l: &Landmark, pose: &Pose2, r: &Matrix2<f64>, ln_det_r: f64) -> f64 {
    let mut nu = wrap_angle(m.z[1] - (l.mean[1] - pose.theta));
    // the prediction may be flipped to (−ρ', θ' + π): take the nearer of the two angles
    nu = nu.abs().min((std::f64::consts::PI - nu.abs()).abs());
    let q = l.cov[(1, 1)] + r[(1, 1)];
    -0.5 * nu * nu / q - LN_2PI - 0.5 * ln_det_r
}

/// ln det R with the full determinant (R need not be diagonal); −∞ or NaN for a singular R.
fn ln_det(r: &Matrix2<f64>) -> f64 {
    r.determinant().ln()
}

/// Gaussian log-likelihood of `m` for landmark `l`, or `None` if Q is not positive definite.
fn evaluate(m: &Observation, l: &Landmark, pose: &Pose2, r: &Matrix2<f64>) -> Option<Match> {
    let prediction = l.predict(m.model, pose);
    let h = prediction.h;
    let q = h * l.cov * h.transpose() + r; // Eq. (3.14), standard orientation
    let det = q[(0, 0)] * q[(1, 1)] - q[(0, 1)] * q[(1, 0)];
    if !(det > 0.0 && det.is_finite()) {
        return None;
    }
    let nu = m.model.innovation(&m.z, &prediction.z);
    // νᵀ Q⁻¹ ν with the closed-form 2 × 2 inverse
    let d2 = (q[(1, 1)] * nu[0] * nu[0] - (q[(0, 1)] + q[(1, 0)]) * nu[0] * nu[1]
        + q[(0, 0)] * nu[1] * nu[1])
        / det;
    Some(Match {
        prediction,
        q,
        innovation: nu,
        log_likelihood: -0.5 * d2 - LN_2PI - 0.5 * det.ln(),
    }) // Eq. (3.13)
}

/// EKF correction of one landmark (Joseph form, which keeps Σ symmetric positive semi-definite).
fn correct(l: &mut Landmark, model: Model, m: &Match, r: &Matrix2<f64>) -> bool {
    let Some(q_inv) = m.q.try_inverse() else { return false };
    let h = m.prediction.h;
    let k = l.cov * h.transpose() * q_inv; // K = Σ Hᵀ Q⁻¹
    let i_kh = Matrix2::identity() - k * h;
    l.mean += k * m.innovation; // μ = μ + K (z − ẑ)
    l.cov = i_kh * l.cov * i_kh.transpose() + k * r * k.transpose(); // (I − KH) Σ (I − KH)ᵀ + K R Kᵀ
    l.cov = 0.5 * (l.cov + l.cov.transpose());
    model.normalise(&mut l.mean, &mut l.cov);
    l.refresh();
    l.mean.iter().all(|v| v.is_finite())
}

/// A new landmark from the inverse model, with Σ = H⁻¹ R H⁻ᵀ ([FT] Table 3.2).
fn initialise(m: &Observation, pose: &Pose2, r: &Matrix2<f64>) -> Option<Landmark> {
    let mean = m.model.inverse(&m.z, pose);
    let h_inv = m.model.predict(&mean, pose).h.try_inverse()?;
    let cov = h_inv * r * h_inv.transpose();
    Some(Landmark { id: m.landmark, ..Landmark::new(mean, 0.5 * (cov + cov.transpose())) })
}

/// The filter state (cloning it is cheap: particle maps are shared copy-on-write).
#[derive(Clone)]
pub struct FastSlam1<'a> {
    params: &'a FastSlamParams,
    /// The motion model on point-landmark worlds; `None`: [FT]'s Eq. 7.18 with `params.motion_*`.
    motion: Option<&'a MotionModel>,
    particles: Vec<Particle>,
    /// Index of the best particle (after the last weighting, followed through resampling).
    best: usize,
    ln_p0: f64,
    motion_sigma: [f64; 3],
    /// Which landmarks an earlier feature of the scan being applied to a particle corrected:
    /// `corrected[kind][landmark] == stamp` (lines, corners); the stamp changes for every
    /// (particle, scan), so nothing is cleared.
    corrected: [Vec<u64>; 2],
    stamp: u64,
    pub numerical_failures: u64,
    pub resamples: u64,
    pub weighted_steps: u64,
}

impl<'a> FastSlam1<'a> {
    pub fn new(params: &'a FastSlamParams, motion: Option<&'a MotionModel>, start: Pose2) -> Self {
        Self {
            params,
            motion,
            particles: vec![Particle::new(start); params.particles as usize],
            best: 0,
            ln_p0: params.p0.ln(),
            motion_sigma: params.motion_sigmas(),
            corrected: [Vec::new(), Vec::new()],
            stamp: 0,
            numerical_failures: 0,
            resamples: 0,
            weighted_steps: 0,
        }
    }

    /// One step of [FT] Table 6.3. Returns N̂eff when the step weighted the particles.
    pub fn step(
        &mut self,
        control: Option<&Pose2>,
        observations: &[Observation],
        rng: &mut ChaCha8Rng,
    ) -> Option<f64> {
        if let Some(u) = control {
            self.predict(u, rng); // 1: sample every particle's pose
        }
        if observations.is_empty() {
            return None; // 4: no observation: stop
        }
        for i in 0..self.particles.len() {
            self.weigh_and_update(i, observations); // 5–13: associate, update, weight
        }
        self.weighted_steps += 1;
        let weights = self.normalised_weights();
        self.best = particle::argmax(&weights); // 15: best particle, before resampling
        let neff = resample::effective_sample_size(&weights);
        if neff < self.params.neff_threshold {
            self.resample(&weights, rng); // 16–17: resample, weights back to uniform
        }
        Some(neff)
    }

    /// [FT] Eq. 7.18: x' = x ⊕ u + ε, ε ~ N(0, diag(σx², σy², σθ²)) in the world frame, per step.
    fn predict(&mut self, u: &Pose2, rng: &mut ChaCha8Rng) {
        if let Some(motion) = self.motion {
            for p in &mut self.particles {
                p.pose = motion.sample(&p.pose, u, rng);
            }
            return;
        }
        let [sx, sy, st] = self.motion_sigma;
        for p in &mut self.particles {
            let (zx, zy, zt): (f64, f64, f64) = (
                rng.sample(StandardNormal),
                rng.sample(StandardNormal),
                rng.sample(StandardNormal),
            );
            let q = p.pose.compose(*u);
            p.pose = Pose2::new(q.x + sx * zx, q.y + sy * zy, wrap_angle(q.theta + st * zt));
        }
    }

    /// Associates all features of the scan against the particle's map (as it was before this
    /// scan), then applies the updates and multiplies the weight ([FT] Table 6.3 lines 6–13).
    fn weigh_and_update(&mut self, i: usize, z: &[Observation]) {
        let (ln_p0, rule) = (self.ln_p0, self.params.ambiguity);
        let known = self.params.association == DataAssociation::Known;
        let p = &self.particles[i];
        let pose = p.pose;
        let mut failures = 0;
        let mut decisions: Vec<(Association, Option<Match>)> = z
            .iter()
            .map(|m| {
                let landmarks = p.map.of(m.model);
                if known {
                    // Known association: the landmark created from this identity, else a new one.
                    return match m.landmark.and_then(|id| p.map.find_id(m.model, id)) {
                        None => (Association::New, None),
                        Some(j) => match evaluate(m, &landmarks[j], &pose, &m.r) {
                            Some(mt) => (
                                Association::Known {
                                    landmark: j,
                                    log_likelihood: mt.log_likelihood,
                                },
                                Some(mt),
                            ),
                            None => {
                                failures += 1;
                                (Association::Ignored, None)
                            }
                        },
                    };
                }
                let ln_det_r = ln_det(&m.r);
                let mut candidates = Candidates::new(ln_p0);
                for (j, l) in landmarks.iter().enumerate() {
                    if m.model == Model::Line && line_bound(m, l, &pose, &m.r, ln_det_r) < ln_p0 {
                        continue; // cannot beat P0: not a candidate
                    }
                    match evaluate(m, l, &pose, &m.r) {
                        Some(mt) => candidates.offer(j, mt.log_likelihood, mt),
                        None => failures += 1,
                    }
                }
                candidates.decide(rule)
            })
            .collect();
        // The shared-landmark rule compares features of the same landmark type (identities
        // never collide under known association).
        for model in [Model::Line, Model::Point].into_iter().filter(|_| !known) {
            let idx: Vec<usize> = (0..z.len()).filter(|&k| z[k].model == model).collect();
            let mut ds: Vec<Association> = idx.iter().map(|&k| decisions[k].0).collect();
            resolve_shared(&mut ds, rule);
            for (&k, d) in idx.iter().zip(ds) {
                decisions[k].0 = d;
            }
        }

        let mut log_weight = 0.0;
        let needs_write = decisions.iter().any(|(d, _)| !matches!(d, Association::Ignored));
        let p = &mut self.particles[i];
        if needs_write {
            let map = p.map_mut();
            // the landmarks an earlier feature of this scan went to, by stamp: O(1) per feature,
            // where comparing with every earlier feature was O(z²) per scan
            self.stamp += 1;
            let stamp = self.stamp;
            for (m, (d, matched)) in z.iter().zip(&decisions) {
                match (d, matched) {
                    (Association::Known { landmark, .. }, Some(mt)) => {
                        // a landmark an earlier feature of this scan already corrected is evaluated
                        // afresh against its corrected state (a sequential EKF update and factor)
                        let seen = &mut self.corrected[usize::from(m.model == Model::Point)];
                        if seen.len() <= *landmark {
                            seen.resize(*landmark + 1, 0);
                        }
                        let again = std::mem::replace(&mut seen[*landmark], stamp) == stamp;
                        let fresh = if again {
                            evaluate(m, &map.of(m.model)[*landmark], &pose, &m.r)
                        } else {
                            Some(*mt)
                        };
                        let Some(mt) = fresh else {
                            failures += 1;
                            continue;
                        };
                        if correct(&mut map.of_mut(m.model)[*landmark], m.model, &mt, &m.r) {
                            log_weight += mt.log_likelihood; // the association's own value when first
                        } else {
                            failures += 1;
                        }
                    }
                    (Association::New, _) => match initialise(m, &pose, &m.r) {
                        Some(l) => {
                            // identities are kept only when the filter uses them
                            map.push(
                                m.model,
                                Landmark { id: if known { l.id } else { None }, ..l },
                            );
                            log_weight += ln_p0;
                        }
                        None => failures += 1,
                    },
                    _ => {} // ignored: weight factor 1
                }
            }
        }
        p.log_weight += log_weight; // 13: multiplicative across steps
        p.lineage_log_weight += log_weight; // [PF] Eq. 20: never normalised nor reset
        self.numerical_failures += failures as u64;
    }

    /// Normalised weights; all weights unusable is a numerical failure, counted, and the weights
    /// made uniform so that the filter can go on.
    fn normalised_weights(&mut self) -> Vec<f64> {
        particle::normalised_weights(&mut self.particles).unwrap_or_else(|| {
            self.numerical_failures += 1;
            vec![1.0 / self.particles.len() as f64; self.particles.len()]
        })
    }

    fn resample(&mut self, weights: &[f64], rng: &mut ChaCha8Rng) {
        let ancestors = resample::low_variance(weights, rng);
        (self.particles, self.best) = particle::resampled(&self.particles, &ancestors, self.best);
        self.resamples += 1;
    }

    pub fn best(&self) -> &Particle {
        &self.particles[self.best]
    }

    /// The filter's pose belief: the weighted mean of the particle poses and their weighted
    /// spread about it (for NEES; Bailey et al. 2006).
    pub fn pose_belief(&self) -> (Pose2, nalgebra::Matrix3<f64>) {
        let max = self.particles.iter().map(|p| p.log_weight).fold(f64::NEG_INFINITY, f64::max);
        let poses: Vec<Pose2> = self.particles.iter().map(|p| p.pose).collect();
        if !max.is_finite() {
            return pose_belief(&poses, None);
        }
        let w: Vec<f64> = self.particles.iter().map(|p| (p.log_weight - max).exp()).collect();
        let sum: f64 = w.iter().sum();
        let w: Vec<f64> = w.iter().map(|x| x / sum).collect();
        pose_belief(&poses, Some(&w))
    }

    /// Landmarks in the best particle's map.
    pub fn map_size(&self) -> usize {
        self.best().map.len()
    }
}

/// Runs FastSLAM 1.0 over a world's odometry and scans ([FT]: line and corner features, its own
/// motion noise).
pub fn run(
    world: &World,
    params: &FastSlamParams,
    feature_params: &FeatureParams,
    rng: &mut ChaCha8Rng,
) -> Result<Trace, SlamError> {
    let line_r = Matrix2::new(params.obs_var_rho_m2, 0.0, 0.0, params.obs_var_theta_rad2);
    let observations =
        observations::stream(world, Source::LaserFeatures { features: feature_params, line_r })?;
    run_on(world, params, None, &observations, true, rng)
}

/// Runs FastSLAM 1.0 on any observation stream. `motion`: the motion model of point-landmark
/// worlds (`None`: [FT] Eq. 7.18 with `params.motion_*`); `points_as_corners`: point landmarks
/// are laser corners (else the map's point landmarks).
pub fn run_on(
    world: &World,
    params: &FastSlamParams,
    motion: Option<&MotionModel>,
    observations: &[StepObservations],
    points_as_corners: bool,
    rng: &mut ChaCha8Rng,
) -> Result<Trace, SlamError> {
    if params.association == DataAssociation::Known
        && observations.iter().flat_map(|s| &s.observations).any(|o| o.landmark.is_none())
    {
        return Err(SlamError::NoIdentities);
    }
    let run = Fastslam1Run {
        filter: FastSlam1::new(params, motion, world.truth[0]),
        rng,
        record: ParticleRecord::new(params, world.odometry.len()),
        points_as_corners,
    };
    driver::run(world, observations, params.association == DataAssociation::Known, run)
}

/// FastSLAM 1.0 as the driver steps it.
struct Fastslam1Run<'a, 'r> {
    filter: FastSlam1<'a>,
    rng: &'r mut ChaCha8Rng,
    record: ParticleRecord,
    points_as_corners: bool,
}

impl Filter for Fastslam1Run<'_, '_> {
    fn step(
        &mut self,
        k: usize,
        control: Option<&Pose2>,
        observations: &[Observation],
    ) -> Result<(), SlamError> {
        let f = &mut self.filter;
        let neff = f.step(control, observations, self.rng);
        // the particles' spread, for NEES on point worlds (the study's motion model) and for the
        // weighted-mean estimate
        let noisy = f.motion.is_some();
        let belief =
            (noisy || f.params.estimate == Estimate::WeightedMean).then(|| f.pose_belief());
        self.record.record(k, neff, &mut f.particles, f.best, belief, noisy)
    }

    fn finish(self) -> Trace {
        let f = self.filter;
        let counts = (f.numerical_failures, f.resamples, f.weighted_steps);
        self.record.finish(&f.particles, f.best, self.points_as_corners, counts)
    }
}

/// What a particle filter's run records at every step (FastSLAM 1.0 and 2.0): N̂eff, the pose
/// belief, the trajectory estimate ([`Estimator`]); and the cap on a particle's map.
pub struct ParticleRecord {
    neff: Vec<Option<f64>>,
    pose_belief: Vec<Option<(Pose2, nalgebra::Matrix3<f64>)>>,
    estimator: Estimator,
    max_landmarks: u32,
}

impl ParticleRecord {
    pub fn new(params: &FastSlamParams, steps: usize) -> Self {
        Self {
            neff: Vec::with_capacity(steps + 1),
            pose_belief: Vec::new(),
            estimator: Estimator::new(params.estimate, steps + 1),
            max_landmarks: params.max_landmarks,
        }
    }

    /// After step `k`: its N̂eff (`None`: nothing weighted the particles), the landmark cap, the
    /// estimate (`belief`: the weighted mean pose and spread, where computed), and the belief
    /// itself when `keep_belief` (NEES).
    pub fn record(
        &mut self,
        k: usize,
        neff: Option<f64>,
        particles: &mut [Particle],
        best: usize,
        belief: Option<(Pose2, nalgebra::Matrix3<f64>)>,
        keep_belief: bool,
    ) -> Result<(), SlamError> {
        self.neff.push(neff);
        if particles.iter().any(|p| p.map.len() > self.max_landmarks as usize) {
            return Err(SlamError::LandmarkCap { limit: self.max_landmarks, step: k });
        }
        self.estimator.record(particles, best, belief.map(|b| b.0));
        if keep_belief {
            self.pose_belief.push(belief);
        }
        Ok(())
    }

    /// The trace: the estimate, and the map of the particle the estimate reports;
    /// `(numerical failures, resamples, weighted steps)` as the filter counted them.
    pub fn finish(
        self,
        particles: &[Particle],
        best: usize,
        points_as_corners: bool,
        (numerical_failures, resamples, weighted_steps): (u64, u64, u64),
    ) -> Trace {
        let (estimate, reported) = self.estimator.finish(particles, best);
        Trace {
            estimate,
            numerical_failures,
            map: Some(landmark_map(&particles[reported].map, points_as_corners)),
            neff: self.neff,
            resamples,
            weighted_steps,
            pose_belief: self.pose_belief,
            ..Trace::default()
        }
    }
}

/// Builds a particle filter's trajectory estimate step by step, as [`FastSlamParams::estimate`]
/// asks (shared by FastSLAM 1.0 and 2.0).
pub struct Estimator {
    kind: Estimate,
    poses: Vec<Pose2>,
}

impl Estimator {
    pub fn new(kind: Estimate, steps: usize) -> Self {
        Self { kind, poses: Vec::with_capacity(if kind.keeps_paths() { 0 } else { steps }) }
    }

    /// After a step: the best particle's pose, or the weighted mean (`mean`, needed then), or —
    /// for the path of the best lineage — every particle's pose appended to its path.
    pub fn record(&mut self, particles: &mut [Particle], best: usize, mean: Option<Pose2>) {
        match self.kind {
            Estimate::BestPerStep => self.poses.push(particles[best].pose),
            Estimate::WeightedMean => {
                self.poses.push(mean.expect("the weighted mean is computed for this estimate"))
            }
            Estimate::PathOfBest | Estimate::PathOfFinalBest => {
                particles.iter_mut().for_each(|p| p.path.push(p.pose))
            }
        }
    }

    /// The trajectory and the index of the particle whose map is reported: the final best
    /// particle, or for the path of the best the particle with the highest lineage log-weight
    /// ([PF] Eq. 20; the first on ties) with its own path.
    pub fn finish(self, particles: &[Particle], best: usize) -> (Vec<Pose2>, usize) {
        match self.kind {
            Estimate::PathOfBest => {
                let i = particle::argmax(
                    &particles.iter().map(|p| p.lineage_log_weight).collect::<Vec<_>>(),
                );
                (particles[i].path.poses(), i)
            }
            Estimate::PathOfFinalBest => (particles[best].path.poses(), best),
            _ => (self.poses, best),
        }
    }
}

/// A particle map as a [`LandmarkMap`].
pub fn landmark_map(m: &particle::Map, points_as_corners: bool) -> LandmarkMap {
    let points = m.corners().iter().map(|l| Point2::new(l.mean[0], l.mean[1])).collect();
    let lines = m.lines().iter().map(|l| Line::normalised(l.mean[0], l.mean[1])).collect();
    if points_as_corners {
        LandmarkMap { lines, corners: points, ..LandmarkMap::default() }
    } else {
        LandmarkMap {
            lines,
            points,
            point_ids: m.corners().iter().map(|l| l.id).collect(),
            ..LandmarkMap::default()
        }
    }
}

/// The particles' weighted mean pose (circular mean heading) and their spread around it (equal
/// weights: after resampling, or between weighting steps the current normalised weights are
/// those of the last step's resampling), headings wrapped about the mean heading.
pub fn pose_belief(poses: &[Pose2], weights: Option<&[f64]>) -> (Pose2, nalgebra::Matrix3<f64>) {
    let n = poses.len() as f64;
    let w = |i: usize| weights.map_or(1.0 / n, |w| w[i]);
    let (mut mx, mut my, mut ms, mut mc) = (0.0, 0.0, 0.0, 0.0);
    for (i, p) in poses.iter().enumerate() {
        mx += w(i) * p.x;
        my += w(i) * p.y;
        ms += w(i) * p.theta.sin();
        mc += w(i) * p.theta.cos();
    }
    let mt = ms.atan2(mc);
    let mut cov = nalgebra::Matrix3::zeros();
    for (i, p) in poses.iter().enumerate() {
        let e = nalgebra::Vector3::new(p.x - mx, p.y - my, wrap_angle(p.theta - mt));
        cov += w(i) * e * e.transpose();
    }
    (Pose2::new(mx, my, mt), cov)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The three trajectory estimates: lengths match the truth; the weighted mean is the belief's
    /// mean; the path of the best follows the lineage with the highest accumulated log-weight,
    /// inherited through resampling, and reports that particle's map.
    #[test]
    fn trajectory_estimates_are_a_choice() {
        use rand::SeedableRng;
        let motion = MotionModel::Pose { sigma_x_m: 0.05, sigma_y_m: 0.05, sigma_theta_rad: 0.02 };
        let n = 30;
        let truth: Vec<Pose2> = (0..=n).map(|k| Pose2::new(0.1 * k as f64, 0.0, 0.0)).collect();
        let world = World::from_odometry(truth.clone(), vec![Pose2::new(0.1, 0.0, 0.0); n]);
        let r = Matrix2::new(0.01, 0.0, 0.0, 0.001);
        let marks = [Vector2::new(2.0, 1.0), Vector2::new(3.0, -1.5)];
        let stream: Vec<StepObservations> = (1..=n)
            .map(|k| StepObservations {
                step: k,
                observations: marks
                    .iter()
                    .enumerate()
                    .map(|(i, m)| Observation {
                        model: Model::Point,
                        z: Model::Point.predict(m, &truth[k]).z,
                        r,
                        landmark: Some(i),
                    })
                    .collect(),
            })
            .collect();
        let run = |estimate: Estimate| {
            let p = FastSlamParams {
                particles: 20,
                association: DataAssociation::Known,
                estimate,
                ..FastSlamParams::default()
            };
            run_on(&world, &p, Some(&motion), &stream, false, &mut ChaCha8Rng::seed_from_u64(3))
                .unwrap()
        };
        let (best, mean, path) =
            (run(Estimate::BestPerStep), run(Estimate::WeightedMean), run(Estimate::PathOfBest));
        let final_best = run(Estimate::PathOfFinalBest);
        // [FT]'s estimate: the final best particle's map (as the per-step estimate reports) and its
        // own path, which ends at the per-step estimate's last pose
        assert_eq!(final_best.map, best.map);
        assert_eq!(final_best.estimate.last(), best.estimate.last());
        assert_ne!(
            final_best.estimate, best.estimate,
            "its own path, not the per-step argmax sequence"
        );
        for t in [&best, &mean, &path, &final_best] {
            assert_eq!(t.estimate.len(), truth.len());
        }
        // same random numbers: the filters ran alike, only the report differs
        assert_eq!(best.pose_belief, path.pose_belief);
        for (e, b) in mean.estimate.iter().zip(&mean.pose_belief).skip(1) {
            assert_eq!(*e, b.unwrap().0);
        }
        assert_ne!(
            best.estimate, path.estimate,
            "the per-step best and the best lineage's path differ"
        );
        assert_eq!(path.estimate[0], truth[0]);
        // the lineage weight is inherited: a resampled copy keeps its ancestor's
        let mut a = Particle::new(Pose2::IDENTITY);
        a.lineage_log_weight = -3.5;
        a.log_weight = -1.0;
        let (copies, _) = particle::resampled(&[a], &[0, 0], 0);
        assert!(copies.iter().all(|c| c.lineage_log_weight == -3.5 && c.log_weight == 0.0));
    }

    /// A map that explodes (every observation a new landmark, [FT]'s P0 = 100) stops the run
    /// cleanly at the landmark cap instead of growing without bound.
    #[test]
    fn an_exploding_map_fails_cleanly_at_the_cap() {
        use rand::SeedableRng;
        let motion = MotionModel::Pose { sigma_x_m: 0.05, sigma_y_m: 0.05, sigma_theta_rad: 0.02 };
        let n = 10;
        let truth: Vec<Pose2> = (0..=n).map(|k| Pose2::new(0.1 * k as f64, 0.0, 0.0)).collect();
        let world = World::from_odometry(truth.clone(), vec![Pose2::new(0.1, 0.0, 0.0); n]);
        let r = Matrix2::new(0.01, 0.0, 0.0, 0.001);
        let stream: Vec<StepObservations> = (1..=n)
            .map(|k| StepObservations {
                step: k,
                observations: vec![Observation {
                    model: Model::Point,
                    z: Model::Point.predict(&Vector2::new(2.0, 1.0), &truth[k]).z,
                    r,
                    landmark: None,
                }],
            })
            .collect();
        let p =
            FastSlamParams { particles: 5, p0: 1e9, max_landmarks: 3, ..FastSlamParams::default() };
        let err =
            run_on(&world, &p, Some(&motion), &stream, false, &mut ChaCha8Rng::seed_from_u64(1))
                .unwrap_err();
        assert_eq!(
            err,
            SlamError::LandmarkCap { limit: 3, step: 4 },
            "the fourth new landmark crosses the cap of 3"
        );
        let fine = FastSlamParams { p0: 1e9, ..FastSlamParams::default() };
        assert!(
            run_on(&world, &fine, Some(&motion), &stream, false, &mut ChaCha8Rng::seed_from_u64(1))
                .is_ok(),
            "10 landmarks stay under the default cap"
        );
    }

    /// A stream with two entries for one step: both are read (merged, as FastSLAM 2.0 and the
    /// EKF read them), and the steps after it still get theirs.
    #[test]
    fn duplicate_step_entries_are_merged_not_stalled() {
        let p = FastSlamParams {
            particles: 3,
            association: DataAssociation::Known,
            ..FastSlamParams::default()
        };
        let motion = MotionModel::Pose { sigma_x_m: 0.01, sigma_y_m: 0.01, sigma_theta_rad: 0.01 };
        let truth = vec![Pose2::IDENTITY, Pose2::new(0.1, 0.0, 0.0), Pose2::new(0.2, 0.0, 0.0)];
        let odometry = vec![Pose2::new(0.1, 0.0, 0.0); 2];
        let world = World::from_odometry(truth.clone(), odometry);
        let r = Matrix2::new(0.01, 0.0, 0.0, 0.001);
        let seen = |k: usize, m: Vector2<f64>, id: usize| Observation {
            model: Model::Point,
            z: Model::Point.predict(&m, &truth[k]).z,
            r,
            landmark: Some(id),
        };
        let stream = vec![
            StepObservations { step: 1, observations: vec![seen(1, Vector2::new(3.0, 1.0), 0)] },
            StepObservations { step: 1, observations: vec![seen(1, Vector2::new(2.0, -1.0), 1)] },
            StepObservations { step: 2, observations: vec![seen(2, Vector2::new(4.0, 2.0), 2)] },
        ];
        let trace = run_on(
            &world,
            &p,
            Some(&motion),
            &stream,
            false,
            &mut <ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1),
        )
        .unwrap();
        let mut ids: Vec<Option<usize>> = trace.map.unwrap().point_ids;
        ids.sort();
        assert_eq!(
            ids,
            vec![Some(0), Some(1), Some(2)],
            "every entry of the stream reaches the filter"
        );
    }

    /// Two features matched to one landmark in one scan update it one after the other, each
    /// against the landmark as the previous one left it (a sequential EKF), and weigh by the
    /// sequential factors (matches under gated association); a new identity read twice in one
    /// step arrives fused and makes one landmark.
    #[test]
    fn two_features_on_one_landmark_update_it_sequentially() {
        let p = FastSlamParams {
            particles: 1,
            association: DataAssociation::Known,
            ..FastSlamParams::default()
        };
        let pose = Pose2::new(0.1, -0.2, 0.05);
        let l = Landmark {
            id: Some(0),
            ..Landmark::new(Vector2::new(4.0, 1.0), Matrix2::identity() * 0.25)
        };
        let r = Matrix2::new(0.04, 0.0, 0.0, 0.00122);
        let o = Observation {
            model: Model::Point,
            z: Model::Point.predict(&Vector2::new(4.3, 1.2), &pose).z,
            r,
            landmark: Some(0),
        };
        let mut f = FastSlam1::new(&p, None, pose);
        f.particles[0].map_mut().push(Model::Point, l);
        f.weigh_and_update(0, &[o, o]);
        let (mut expected, mut log_weight) = (l, 0.0);
        for _ in 0..2 {
            let m = evaluate(&o, &expected, &pose, &r).unwrap();
            log_weight += m.log_likelihood;
            assert!(correct(&mut expected, Model::Point, &m, &r));
        }
        let got = f.particles[0].map.corners()[0];
        assert!(
            (got.mean - expected.mean).norm() < 1e-12,
            "{} vs sequential {}",
            got.mean,
            expected.mean
        );
        assert!(
            (got.cov - expected.cov).abs().max() < 1e-12,
            "{} vs sequential {}",
            got.cov,
            expected.cov
        );
        assert!((f.particles[0].log_weight - log_weight).abs() < 1e-9);

        // a new identity seen twice in one step: the filter reads it fused (known association),
        // so one landmark
        let stream = [StepObservations { step: 0, observations: vec![o, o] }];
        let mut f = FastSlam1::new(&p, None, pose);
        f.weigh_and_update(0, observations::Cursor::new(&stream, true).at(0));
        assert_eq!(f.particles[0].map.corners().len(), 1);
        assert!(
            (f.particles[0].log_weight - p.p0.ln()).abs() < 1e-12,
            "one new landmark, one P0 factor"
        );
    }

    /// NEES pairs the filter's belief, its weighted mean with its weighted spread (Bailey et al.
    /// 2006). For a consistent cloud — particles and truth both drawn from one N(m, P) — that
    /// scores E[NEES] = 3; pairing the spread about the mean with one particle (the best particle,
    /// itself a draw) would score 6.
    #[test]
    fn a_consistent_particle_cloud_scores_nees_three() {
        use rand::SeedableRng;
        let p = FastSlamParams { particles: 300, ..FastSlamParams::default() };
        let chol = nalgebra::Matrix3::new(0.2, 0.0, 0.0, 0.05, 0.1, 0.0, 0.01, -0.02, 0.05);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let draw = |m: &Pose2, rng: &mut ChaCha8Rng| {
            let n = nalgebra::Vector3::new(
                rng.sample(StandardNormal),
                rng.sample(StandardNormal),
                rng.sample(StandardNormal),
            );
            let d = chol * n;
            Pose2::new(m.x + d[0], m.y + d[1], wrap_angle(m.theta + d[2]))
        };
        let (mut on_belief, mut on_particle) = (Vec::new(), Vec::new());
        for trial in 0..600 {
            let m = Pose2::new(trial as f64 * 0.01, 1.0, 0.3);
            let truth = draw(&m, &mut rng);
            let mut f = FastSlam1::new(&p, None, m);
            for q in f.particles.iter_mut() {
                q.pose = draw(&m, &mut rng);
                q.log_weight = 0.0;
            }
            let (mean, cov) = f.pose_belief();
            let score = |e: &Pose2| match crate::metrics::nees(&truth, e, &cov) {
                crate::metrics::Nees::Value(v) => v,
                other => panic!("{other:?}"),
            };
            on_belief.push(score(&mean));
            on_particle.push(score(&f.particles[0].pose));
        }
        let avg = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!((avg(&on_belief) - 3.0).abs() < 0.3, "NEES of the belief {}", avg(&on_belief));
        assert!(
            (avg(&on_particle) - 6.0).abs() < 0.7,
            "NEES of one particle against the spread {}",
            avg(&on_particle)
        );
    }

    #[test]
    fn describe_names_particles_p0_and_resampling() {
        let p = FastSlamParams {
            particles: 37,
            p0: 0.02,
            neff_threshold: 12.5,
            ..FastSlamParams::default()
        };
        let points = p.describe_on_points(true);
        assert!(points.starts_with("FastSLAM 1.0 on point worlds and 2.0: 37 particles, maximum-likelihood (P0 = 0.02) association") && points.contains("N̂eff < 12.5"), "{points}");
        let known =
            FastSlamParams { association: DataAssociation::Known, ..FastSlamParams::default() }
                .describe_on_points(false);
        assert!(
            known.starts_with("FastSLAM 1.0 on point worlds: 100 particles, known association")
                && known.contains("∞ (always)"),
            "{known}"
        );
        let lasers = p.describe_on_lasers();
        assert!(
            lasers.contains("37 particles, P0 = 0.02, resampling when N̂eff < 12.5")
                && lasers.contains("(0.007, 0.007, 0.008) per step read as standard deviations"),
            "{lasers}"
        );
    }

    #[test]
    fn joseph_update_shrinks_and_keeps_covariance_symmetric_psd() {
        let r = Matrix2::new(0.04, 0.0, 0.0, 0.00122);
        let pose = Pose2::new(1.0, 0.5, 0.2);
        let truth = Vector2::new(9.0, std::f64::consts::FRAC_PI_2);
        let z = models::line_predict(&truth, &pose).z;
        let m = Observation { model: Model::Line, z, r, landmark: None };
        let mut l = initialise(&m, &pose, &r).unwrap();
        for k in 0..50 {
            let pose_k = Pose2::new(1.0 + 0.1 * k as f64, 0.5, 0.2);
            let mk = Observation {
                model: Model::Line,
                z: models::line_predict(&truth, &pose_k).z,
                r,
                landmark: None,
            };
            let before = l.cov.trace();
            let mt = evaluate(&mk, &l, &pose_k, &r).unwrap();
            assert!(correct(&mut l, Model::Line, &mt, &r));
            assert!(l.cov.trace() <= before + 1e-15);
            assert_eq!(l.cov[(0, 1)], l.cov[(1, 0)]);
            let eig = l.cov.symmetric_eigenvalues();
            assert!(eig.iter().all(|&e| e >= 0.0), "{eig}");
        }
        assert!((l.mean - truth).norm() < 1e-9, "{:?}", l.mean);
    }

    #[test]
    fn the_angle_bound_never_underestimates_the_likelihood() {
        let r = Matrix2::new(0.04, 0.0, 0.0, 0.00122);
        let ln_det_r = (0.04f64 * 0.00122).ln();
        let mut rng = <ChaCha8Rng as rand::SeedableRng>::seed_from_u64(11);
        for _ in 0..2000 {
            let u = |rng: &mut ChaCha8Rng, a: f64, b: f64| rng.random_range(a..b);
            let pose =
                Pose2::new(u(&mut rng, -5.0, 5.0), u(&mut rng, -5.0, 5.0), u(&mut rng, -3.1, 3.1));
            let a = u(&mut rng, 0.0, 0.05);
            let l = Landmark::new(
                Vector2::new(u(&mut rng, 0.5, 20.0), u(&mut rng, -3.1, 3.1)),
                Matrix2::new(
                    a,
                    0.3 * a.sqrt() * 0.01,
                    0.3 * a.sqrt() * 0.01,
                    u(&mut rng, 0.0, 0.01),
                ),
            );
            let m = Observation {
                model: Model::Line,
                z: Vector2::new(u(&mut rng, 0.0, 10.0), u(&mut rng, -3.1, 3.1)),
                r,
                landmark: None,
            };
            let exact = evaluate(&m, &l, &pose, &r).unwrap().log_likelihood;
            assert!(line_bound(&m, &l, &pose, &r, ln_det_r) >= exact - 1e-9);
        }
        // A correlated R: the bound needs the full determinant; ln(R₀₀R₁₁) overstates ln det R
        // and lets the bound fall below the likelihood, skipping a landmark that could win.
        let r = Matrix2::new(0.04, 0.006, 0.006, 0.00122);
        let (mut violations_diag, mut checked) = (0, 0);
        for _ in 0..2000 {
            let u = |rng: &mut ChaCha8Rng, a: f64, b: f64| rng.random_range(a..b);
            let pose =
                Pose2::new(u(&mut rng, -5.0, 5.0), u(&mut rng, -5.0, 5.0), u(&mut rng, -3.1, 3.1));
            let l = Landmark::new(
                Vector2::new(u(&mut rng, 0.5, 20.0), u(&mut rng, -3.1, 3.1)),
                Matrix2::new(1e-4, 0.0, 0.0, 1e-5),
            );
            let truth = l.predict(Model::Line, &pose).z;
            let m = Observation { model: Model::Line, z: truth, r, landmark: None };
            let exact = evaluate(&m, &l, &pose, &r).unwrap().log_likelihood;
            assert!(line_bound(&m, &l, &pose, &r, ln_det(&r)) >= exact - 1e-9);
            violations_diag += (line_bound(&m, &l, &pose, &r, (r[(0, 0)] * r[(1, 1)]).ln())
                < exact - 1e-9) as usize;
            checked += 1;
        }
        assert!(
            violations_diag > 0,
            "the diagonal product must be shown to fail ({checked} cases)"
        );
    }

    #[test]
    fn likelihood_is_a_normalised_gaussian() {
        // ∫ N(z; ẑ, Q) dz = 1: Riemann sum over the measurement plane around a corner landmark
        let r = Matrix2::new(0.04, 0.0, 0.0, 0.01);
        let l = Landmark::new(Vector2::new(3.0, 4.0), Matrix2::new(0.02, 0.005, 0.005, 0.03));
        let pose = Pose2::IDENTITY;
        let zc = models::point_predict(&l.mean, &pose).z;
        let (n, h) = (400, 0.01);
        let mut total = 0.0;
        for i in 0..n {
            for j in 0..n {
                let z = zc
                    + Vector2::new(
                        (i as f64 - n as f64 / 2.0) * h * 4.0,
                        (j as f64 - n as f64 / 2.0) * h * 2.0,
                    );
                total += evaluate(
                    &Observation { model: Model::Point, z, r, landmark: None },
                    &l,
                    &pose,
                    &r,
                )
                .unwrap()
                .log_likelihood
                .exp()
                    * h
                    * 4.0
                    * h
                    * 2.0;
            }
        }
        assert!((total - 1.0).abs() < 0.01, "{total}");
    }
}
