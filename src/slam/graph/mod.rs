//! Graph-based SLAM on point landmarks (smoothing and mapping, "SAM"; Dellaert & Kaess 2006,
//! GraphSLAM in Thrun et al. 2005 Ch. 11): every pose x₀ … x_K and every landmark m_j are
//! unknowns of one nonlinear least-squares problem,
//!
//!   min Σ‖x₀ ⊖ x̄₀‖²_P₀ + Σₖ‖(x_{k+1} ⊖ xₖ) − uₖ‖²_Qₖ + Σ‖h(xₖ, m_j) − z‖²_R,
//!
//! a prior on the first pose, odometry between-factors with the noise the filters are told and
//! range–bearing factors with the sensor's R. The odometry factor is the motion model's own
//! ([`BetweenFactor`]): for `proportional`, the residual is in the arc's coordinates — length,
//! turn and the offset across the arc — where its noise is defined, so a perturbed arc is exactly
//! as likely as the simulation makes it (the filters' body-frame Q is that noise linearised, rank
//! two plus the matched floor); for `pose`, the world-frame residual of [FT] Eq. 7.18.
//!
//! It is solved by Levenberg–Marquardt (Marquardt's diagonal damping, Nielsen's update of λ)
//! over each pose's left perturbation on SE(2) and each landmark's position, on the sparse normal
//! equations factorised by faer's sparse Cholesky (AMD ordering; simplicial, sequential: the same
//! operations on every machine and thread count). Each solve runs by continuation on the
//! odometry's stiffness (`Graph::solve_to`).
//!
//! Two estimates, two registry algorithms:
//! - **batch** (`graph_slam_batch`): one solve over the whole run; its trajectory is the
//!   smoothed one, and its pose beliefs are the marginals of the information matrix at every
//!   `belief_every`-th step;
//! - **online** (`graph_slam`): the graph grows step by step and is re-solved every
//!   `relinearise_every` steps, warm-started from the last solution (new poses by odometry, new
//!   landmarks from their first reading); the estimate of a step is what the smoother knew at that
//!   step — the newest pose of the last solve, composed with the odometry since — comparable with
//!   a filter's, and its belief at each solve is that pose's marginal.
//!
//! Data association is known (the sensor's landmark identities; data without them is refused,
//! as EKF-SLAM with `association = "known"` refuses it), or EKF-SLAM's χ²-gated nearest neighbour
//! against the smoother's own estimate and marginals ([`GraphAssociation`]).
//!
//! For real logs: poses at the steps with a reading only, the odometry between composed
//! ([`Nodes::ReadingSteps`]); Cauchy's kernel on the range–bearing factors
//! (`range_bearing_cauchy`) against gross readings. The laser pose graph
//! (`slam::pose_graph`) adds relative-pose factors (scan matches) between any two poses.

use super::SlamError;
use super::observations::{Observation, StepObservations};
use crate::config::{Checks, Violation};
use crate::geom::{Pose2, wrap_angle};
use crate::slam::fastslam::models::point_predict;
use crate::slam::motion::{BetweenFactor, MotionModel};
use crate::trace::{LandmarkMap, Trace};
use crate::world::World;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Mat, Par, Side};
use nalgebra::{Matrix2, Matrix3, SMatrix, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Code version of graph-SLAM runs.
pub const CODE_VERSION: &str = "graph-2";

/// `[graph]`: the smoother's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct GraphParams {
    /// Online estimate: re-solve every this many odometry steps. Default 10.
    pub relinearise_every: u32,
    /// Batch estimate: the pose marginal (for NEES) at every this many steps. Default 10.
    pub belief_every: u32,
    /// Levenberg–Marquardt iterations per solve. Default 100.
    pub max_iterations: u32,
    /// A solve stops when an accepted step lowers the cost by less than this fraction. Default 1e-10.
    pub relative_decrease: f64,
    /// σ of the prior on the first pose (the true start, as the filters are given it) [m, rad].
    /// Default 1e-6.
    pub prior_sigma: f64,
    /// Which steps get a pose of their own (see [`Nodes`]). Default `every_step`; written out only
    /// when set, so the runs of studies without it keep their hashes.
    #[serde(skip_serializing_if = "Nodes::is_every_step")]
    pub nodes: Nodes,
    /// Width of Cauchy's kernel on every range–bearing factor, in σ (whitened units); infinite =
    /// plain least squares. Default infinite; written out only when finite.
    #[serde(skip_serializing_if = "is_infinite")]
    pub range_bearing_cauchy: f64,
    /// How readings are matched to landmarks (see [`GraphAssociation`]). Default `known`; written
    /// out only when set.
    #[serde(skip_serializing_if = "GraphAssociation::is_known")]
    pub association: GraphAssociation,
    /// Nearest-neighbour association: a landmark can take a reading only below this NIS (χ²₂).
    /// Default 4, EKF-SLAM's `gate_reject`; written out only when set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gate_reject: Option<f64>,
    /// … and a reading above this NIS from every landmark makes a new one; between the gates it
    /// is ignored. Default 25, EKF-SLAM's `gate_create`; written out only when set.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gate_create: Option<f64>,
}

/// How the smoother matches readings to landmarks.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum GraphAssociation {
    /// The sensor's landmark identities; data without them is refused.
    #[default]
    Known,
    /// EKF-SLAM's χ²-gated nearest neighbour, decided as each pose is added, against the
    /// smoother's estimate then: the newest pose (the last solve's, composed with the odometry
    /// since) and each landmark, with the newest pose's covariance (the last solve's marginal,
    /// propagated with the odometry's) and each landmark's marginal from the last solve (from
    /// its first reading until a solve gives one). S = H_x P_x H_xᵀ + H_m P_m H_mᵀ + R: the
    /// pose–landmark cross-covariance of the joint marginal is not formed. Decisions are not
    /// revisited after later solves.
    NearestNeighbour,
}

impl GraphAssociation {
    fn is_known(&self) -> bool {
        *self == GraphAssociation::Known
    }
}

/// EKF-SLAM's default gates (`EkfParams`), the smoother's defaults.
const DEFAULT_GATE_REJECT: f64 = 4.0;
const DEFAULT_GATE_CREATE: f64 = 25.0;

fn is_infinite(x: &f64) -> bool {
    x.is_infinite() && *x > 0.0
}

/// Which steps of a run are poses of the graph.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Nodes {
    /// Every odometry step, joined by the motion model's own between-factor.
    #[default]
    EveryStep,
    /// The first and last steps and every step with a reading, joined by the odometry of the
    /// steps between composed into one relative-pose factor, its covariance propagated to first
    /// order through the compositions (the motion model's noise of each step, in the frame of
    /// the node it starts from). For logs with fast odometry and sparse readings (MRCLAM's 50 Hz
    /// commands): a step without a reading adds nothing a composed increment does not carry, to
    /// first order. The estimate between nodes is the last node's pose composed with the odometry
    /// since.
    ReadingSteps,
}

impl Nodes {
    fn is_every_step(&self) -> bool {
        *self == Nodes::EveryStep
    }
}

impl Default for GraphParams {
    fn default() -> Self {
        Self {
            relinearise_every: 10,
            belief_every: 10,
            max_iterations: 100,
            relative_decrease: 1e-10,
            prior_sigma: 1e-6,
            nodes: Nodes::EveryStep,
            range_bearing_cauchy: f64::INFINITY,
            association: GraphAssociation::Known,
            gate_reject: None,
            gate_create: None,
        }
    }
}

impl GraphParams {
    /// The nearest-neighbour gates (reject, create).
    pub fn gates(&self) -> (f64, f64) {
        (
            self.gate_reject.unwrap_or(DEFAULT_GATE_REJECT),
            self.gate_create.unwrap_or(DEFAULT_GATE_CREATE),
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.require(self.relinearise_every >= 1, "relinearise_every", || "must be at least 1".into());
        c.require(self.belief_every >= 1, "belief_every", || "must be at least 1".into());
        c.require(self.max_iterations >= 1, "max_iterations", || "must be at least 1".into());
        c.positive("relative_decrease", self.relative_decrease);
        c.positive("prior_sigma", self.prior_sigma);
        let nn = self.association == GraphAssociation::NearestNeighbour;
        for (key, gate) in [("gate_reject", self.gate_reject), ("gate_create", self.gate_create)] {
            if let Some(g) = gate {
                c.positive(key, g);
                c.require(nn, key, || "applies to association = \"nearest_neighbour\" only".into());
            }
        }
        let (reject, create) = self.gates();
        c.require(reject <= create, "gate_create", || {
            format!("must be at least gate_reject ({reject}), got {create}")
        });
        c.require(self.range_bearing_cauchy > 0.0, "range_bearing_cauchy", || {
            format!("must be > 0 (inf: no kernel), got {}", self.range_bearing_cauchy)
        });
        c.finish()
    }

    /// The report's sentence on the smoother.
    pub fn describe(&self) -> String {
        let association = match self.association {
            GraphAssociation::Known => "known association".to_string(),
            GraphAssociation::NearestNeighbour => {
                let (reject, create) = self.gates();
                format!(
                    "nearest-neighbour association with EKF-SLAM's χ² gates (update below {reject}, new landmark above {create}), decided as each pose is added against the smoother's estimate and marginals then (the pose–landmark cross-covariance included)"
                )
            }
        };
        let mut text = format!(
            "Graph-based SLAM (smoothing and mapping): all poses and landmarks solved together by Levenberg–Marquardt on the sparse normal equations (faer's sparse Cholesky), with a prior of σ = {} on the true start, odometry factors with the motion model's own noise (for the arc model in the arc's coordinates: length, turn and offset across the arc) and range–bearing factors with the sensor's; {association}. Each solve runs by continuation on the odometry's stiffness (body-frame σ of 1e-3 down to 1e-6 added, then as stated). The batch estimate is one solve over the whole run (pose marginals every {} steps for NEES); the online estimate re-solves every {} steps, warm-started, and reports at each step the newest solved pose composed with the odometry since.",
            self.prior_sigma, self.belief_every, self.relinearise_every
        );
        if self.nodes == Nodes::ReadingSteps {
            text.push_str(" Poses are kept only at the steps with a reading (and the first and last): the odometry between them is composed into one factor, its covariance propagated to first order; re-solves and marginals count poses, not steps, and the steps between poses follow the odometry from the last.");
        }
        if self.range_bearing_cauchy.is_finite() {
            text.push_str(&format!(
                " Every range–bearing factor is under Cauchy's kernel of width {} σ.",
                self.range_bearing_cauchy
            ));
        }
        text
    }
}

/// A factor of the graph.
#[derive(Debug, Clone, Copy)]
enum Factor {
    /// On pose k (the first, in a run): xₖ − x̄, whitened by `w` (P^{-1/2}).
    Prior { k: usize, mean: Pose2, w: Matrix3<f64> },
    /// Between poses k and k + 1: the motion model's residual of the increment, whitened.
    Odometry { k: usize, between: BetweenFactor, w: Matrix3<f64> },
    /// Pose k sees landmark slot j at (range, bearing) z, whitened by R^{-1/2}; under Cauchy's
    /// kernel of width `cauchy` when it is finite.
    RangeBearing { k: usize, j: usize, z: Vector2<f64>, w: Matrix2<f64>, cauchy: f64 },
    /// A measured pose of b in a's frame (a scan match): (x_b ⊖ x_a) − z, with the angle
    /// wrapped, whitened by `w`; under Cauchy's kernel of width `cauchy` (in whitened units)
    /// when it is finite.
    Relative { a: usize, b: usize, z: Pose2, w: Matrix3<f64>, cauchy: f64 },
}

/// L⁻¹ with LLᵀ = `cov` (so that ‖L⁻¹r‖² = rᵀ cov⁻¹ r); `None` when `cov` is not positive definite.
fn whitener<const D: usize>(cov: SMatrix<f64, D, D>) -> Option<SMatrix<f64, D, D>> {
    let l = cov.cholesky()?.l();
    l.try_inverse()
}

/// The factor graph and its current linearisation point.
pub struct Graph {
    /// Poses, then landmarks: x = (x₀, y₀, θ₀, …, m₀ₓ, m₀ᵧ, …).
    poses: Vec<Pose2>,
    /// The odometry step of each pose (its index, unless `GraphParams::nodes` skips steps).
    steps: Vec<usize>,
    landmarks: Vec<Vector2<f64>>,
    /// Landmark identity of each slot, and the slot of each identity seen.
    identity: Vec<usize>,
    slot: std::collections::HashMap<usize, usize>,
    factors: Vec<Factor>,
    params: GraphParams,
    /// Solves whose factorisation failed at every damping tried.
    pub numerical_failures: u64,
    /// The structure of the last solve (see [`Graph::take_structure`]).
    structure: Option<Structure>,
    /// Levenberg–Marquardt's λ at the end of the last converged solve (1e-4 before the first).
    lambda: f64,
    /// The smallest σ of any odometry factor (its covariance's smallest eigenvalue, square-rooted).
    stiffest_sigma: f64,
    /// Nearest-neighbour association's covariances: the newest pose's, each landmark's, and each
    /// landmark's with the newest pose (rows: x, y, θ).
    pose_cov: Matrix3<f64>,
    landmark_cov: Vec<Matrix2<f64>>,
    cross_cov: Vec<nalgebra::Matrix3x2<f64>>,
    /// The longest range read so far [m].
    max_range_m: f64,
}

/// One factor's whitened residual and Jacobian blocks: residual rows, and for up to two variable
/// blocks (first column, width, the rows × width Jacobian in row-major order).
struct Linear {
    /// The factor's cost: rᵀr, or Cauchy's ρ(rᵀr) = c² ln(1 + rᵀr/c²) under a robust kernel
    /// (whose `r` and Jacobians are then scaled by √ρ′, iteratively reweighted least squares).
    cost: f64,
    r: [f64; 3],
    rows: usize,
    blocks: [(usize, usize, [f64; 9]); 2],
    nblocks: usize,
}

impl Graph {
    pub fn new(start: Pose2, params: &GraphParams) -> Self {
        let s = params.prior_sigma;
        let w = Matrix3::from_diagonal_element(1.0 / s);
        Graph {
            poses: vec![start],
            steps: vec![0],
            landmarks: Vec::new(),
            identity: Vec::new(),
            slot: Default::default(),
            factors: vec![Factor::Prior { k: 0, mean: start, w }],
            params: params.clone(),
            numerical_failures: 0,
            stiffest_sigma: f64::INFINITY,
            lambda: 1e-4,
            structure: None,
            pose_cov: Matrix3::from_diagonal_element(s * s),
            landmark_cov: Vec::new(),
            cross_cov: Vec::new(),
            max_range_m: 0.0,
        }
    }

    fn dim(&self) -> usize {
        3 * self.poses.len() + 2 * self.landmarks.len()
    }

    fn landmark_col(&self, j: usize) -> usize {
        3 * self.poses.len() + 2 * j
    }

    /// Adds pose k + 1 after the odometry increment `u` (initialised by composing it with pose k).
    pub fn add_odometry(&mut self, u: &Pose2, motion: &MotionModel) -> Result<(), SlamError> {
        let k = self.poses.len() - 1;
        let between = motion.between_factor(u);
        let w = whitener(between.cov).unwrap_or_else(|| Matrix3::from_diagonal_element(1e6));
        let smallest = between.cov.symmetric_eigenvalues().min().max(0.0).sqrt();
        self.stiffest_sigma = self.stiffest_sigma.min(smallest);
        if self.params.association == GraphAssociation::NearestNeighbour {
            let g = motion.jacobian(&self.poses[k], u);
            self.pose_cov =
                g * self.pose_cov * g.transpose() + motion.covariance(&self.poses[k], u);
            self.cross_cov.iter_mut().for_each(|c| *c = g * *c);
        }
        self.poses.push(self.poses[k].compose(*u));
        self.steps.push(self.steps[k] + 1);
        self.factors.push(Factor::Odometry { k, between, w });
        Ok(())
    }

    /// Adds the pose of step `step` after the odometry `increments` since the newest pose, joined
    /// to it by one relative-pose factor ([`Nodes::ReadingSteps`]): their composition, with the
    /// covariance propagated to first order, Σ ← J_a Σ J_aᵀ + Q(Δ, u) (Q the motion model's noise
    /// of the step from pose Δ, in the newest pose's frame).
    pub fn add_odometry_run(&mut self, increments: &[Pose2], motion: &MotionModel, step: usize) {
        let k = self.poses.len() - 1;
        let (mut delta, mut cov) = (Pose2::IDENTITY, Matrix3::zeros());
        for u in increments {
            let ja = motion.jacobian(&delta, u); // ∂(Δ ⊕ u)/∂Δ
            cov = ja * cov * ja.transpose() + motion.covariance(&delta, u);
            delta = delta.compose(*u);
        }
        let cov = (cov + cov.transpose()) * 0.5;
        let smallest = cov.symmetric_eigenvalues().min().max(0.0).sqrt();
        self.stiffest_sigma = self.stiffest_sigma.min(smallest);
        let w = whitener(cov).unwrap_or_else(|| Matrix3::from_diagonal_element(1e6));
        if self.params.association == GraphAssociation::NearestNeighbour {
            // x_new = x_k ⊕ Δ: Σ ← J_a Σ J_aᵀ + R(θ_k) Σ_Δ R(θ_k)ᵀ
            let p = self.poses[k];
            let ja = motion.jacobian(&p, &delta);
            let (s, c) = p.theta.sin_cos();
            let r = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
            self.pose_cov = ja * self.pose_cov * ja.transpose() + r * cov * r.transpose();
            self.cross_cov.iter_mut().for_each(|c| *c = ja * *c);
        }
        self.poses.push(self.poses[k].compose(delta));
        self.steps.push(step);
        self.factors.push(Factor::Relative { a: k, b: k + 1, z: delta, w, cauchy: f64::INFINITY });
    }

    /// The odometry step of each pose.
    pub fn steps(&self) -> &[usize] {
        &self.steps
    }

    /// Adds a pose with no factor to it yet, at `initial` (its step: the newest pose's + 1);
    /// returns its index.
    pub fn add_pose(&mut self, initial: Pose2) -> usize {
        self.steps.push(self.steps[self.steps.len() - 1] + 1);
        self.poses.push(initial);
        self.poses.len() - 1
    }

    /// Adds a measured pose `z` of pose b in pose a's frame with covariance `cov` (a scan match),
    /// under Cauchy's kernel of width `cauchy` σ (`f64::INFINITY`: plain least squares).
    pub fn add_relative(&mut self, a: usize, b: usize, z: Pose2, cov: Matrix3<f64>, cauchy: f64) {
        let w = whitener(cov).unwrap_or_else(|| Matrix3::from_diagonal_element(1e6));
        self.factors.push(Factor::Relative { a, b, z, w, cauchy });
    }

    /// Sets pose k's current value (the start of the next solve).
    pub fn set_pose(&mut self, k: usize, pose: Pose2) {
        self.poses[k] = pose;
    }

    /// Adds the readings of the newest pose; a new identity gets a landmark initialised from its
    /// first reading.
    pub fn add_observations(&mut self, observations: &[Observation]) -> Result<(), SlamError> {
        if self.params.association == GraphAssociation::NearestNeighbour {
            self.add_observations_nearest(observations);
            return Ok(());
        }
        let k = self.poses.len() - 1;
        for o in observations {
            let id = o.landmark.ok_or(SlamError::NoIdentities)?;
            let j = match self.slot.get(&id) {
                Some(&j) => j,
                None => {
                    let pose = self.poses[k];
                    let (r, b) = (o.z[0], o.z[1]);
                    let a = pose.theta + b;
                    self.landmarks.push(Vector2::new(pose.x + r * a.cos(), pose.y + r * a.sin()));
                    self.identity.push(id);
                    self.slot.insert(id, self.landmarks.len() - 1);
                    self.landmarks.len() - 1
                }
            };
            let w = whitener(o.r).unwrap_or_else(|| Matrix2::from_diagonal_element(1e6));
            let cauchy = self.params.range_bearing_cauchy;
            self.factors.push(Factor::RangeBearing { k, j, z: o.z, w, cauchy });
        }
        Ok(())
    }

    /// Adds the readings of the newest pose by nearest-neighbour association (see
    /// [`GraphAssociation::NearestNeighbour`]): every reading is decided against the state before
    /// any of them is added, as EKF-SLAM does; a new landmark starts at its reading, with the
    /// covariance G_p P_x G_pᵀ + G_z R G_zᵀ.
    fn add_observations_nearest(&mut self, observations: &[Observation]) {
        let k = self.poses.len() - 1;
        let pose = self.poses[k];
        let (reject, create) = self.params.gates();
        self.max_range_m = observations.iter().map(|o| o.z[0]).fold(self.max_range_m, f64::max);
        let decisions: Vec<Option<Option<usize>>> = observations
            .iter()
            .map(|o| {
                let mut best: Option<(f64, usize)> = None;
                for (j, m) in self.landmarks.iter().enumerate() {
                    let p = point_predict(m, &pose);
                    let hx = range_bearing_pose_jacobian(&p.h);
                    let hph = hx * self.cross_cov[j] * p.h.transpose();
                    let s = hx * self.pose_cov * hx.transpose()
                        + hph
                        + hph.transpose()
                        + p.h * self.landmark_cov[j] * p.h.transpose()
                        + o.r;
                    let Some(s_inv) = ((s + s.transpose()) * 0.5).try_inverse() else { continue };
                    let nu = Vector2::new(o.z[0] - p.z[0], wrap_angle(o.z[1] - p.z[1]));
                    let nis = (nu.transpose() * s_inv * nu)[0];
                    if nis.is_finite() && best.is_none_or(|(b, _)| nis < b) {
                        best = Some((nis, j));
                    }
                }
                match best {
                    Some((nis, j)) if nis < reject => Some(Some(j)),
                    Some((nis, _)) if nis <= create => None,
                    _ => Some(None),
                }
            })
            .collect();
        for (o, d) in observations.iter().zip(decisions) {
            let j = match d {
                None => continue, // between the gates: ambiguous, ignored
                Some(Some(j)) => j,
                Some(None) => {
                    let (r, b) = (o.z[0], o.z[1]);
                    let a = pose.theta + b;
                    let (sa, ca) = a.sin_cos();
                    let gp = nalgebra::Matrix2x3::new(1.0, 0.0, -r * sa, 0.0, 1.0, r * ca);
                    let gz = Matrix2::new(ca, -r * sa, sa, r * ca);
                    self.landmarks.push(Vector2::new(pose.x + r * ca, pose.y + r * sa));
                    self.landmark_cov
                        .push(gp * self.pose_cov * gp.transpose() + gz * o.r * gz.transpose());
                    self.cross_cov.push(self.pose_cov * gp.transpose());
                    self.landmarks.len() - 1
                }
            };
            let w = whitener(o.r).unwrap_or_else(|| Matrix2::from_diagonal_element(1e6));
            let cauchy = self.params.range_bearing_cauchy;
            self.factors.push(Factor::RangeBearing { k, j, z: o.z, w, cauchy });
        }
    }

    /// After a solve under nearest-neighbour association: the newest pose's marginal and each
    /// landmark's, from the new information matrix (left as they were where the factorisation
    /// fails).
    fn refresh_association_covariances(&mut self) {
        let newest = self.poses.len() - 1;
        let n = self.dim();
        let Some(structure) = self.take_structure() else { return };
        let (values, _, _) = self.normal_equations(&structure);
        let h = SparseColMat::new(structure.symbolic.clone(), values);
        let cols: Vec<usize> = (0..self.landmarks.len()).map(|j| self.landmark_col(j)).collect();
        let p = self.poses[newest];
        // the landmarks the next readings can reach before the next solve, unless the robot moves
        // farther than the longest range read: within twice that of the newest pose (the others
        // keep their last marginal, which only shrinks as readings come: the gate stays wider)
        let reach = 2.0 * self.max_range_m;
        let near: Vec<usize> = (0..self.landmarks.len())
            .filter(|&j| (self.landmarks[j] - Vector2::new(p.x, p.y)).norm() <= reach)
            .collect();
        // (x, y, θ) = retract(x̂, δ) to first order: Cov(x, ·) = lift · Cov(δ, ·)
        let lift = Matrix3::new(1.0, 0.0, -p.y, 0.0, 1.0, p.x, 0.0, 0.0, 1.0);
        let blocks = with_llt(&structure.cholesky, &h, |llt| {
            // the newest pose's columns of H⁻¹: its marginal and its cross-covariance with every
            // landmark
            let mut e = Mat::<f64>::zeros(n, 3);
            for i in 0..3 {
                e[(3 * newest + i, i)] = 1.0;
            }
            solve_in_place(llt, &mut e);
            let pose = lift * Matrix3::from_fn(|r, c| e[(3 * newest + r, c)]) * lift.transpose();
            let cross: Vec<nalgebra::Matrix3x2<f64>> = cols
                .iter()
                .map(|&col| lift * nalgebra::Matrix3x2::from_fn(|r, c| e[(col + c, r)]))
                .collect();
            let landmarks: Vec<(usize, Matrix2<f64>)> = near
                .iter()
                .map(|&j| {
                    let col = cols[j];
                    let mut e = Mat::<f64>::zeros(n, 2);
                    e[(col, 0)] = 1.0;
                    e[(col + 1, 1)] = 1.0;
                    solve_in_place(llt, &mut e);
                    (j, Matrix2::new(e[(col, 0)], e[(col, 1)], e[(col + 1, 0)], e[(col + 1, 1)]))
                })
                .collect();
            (pose, cross, landmarks)
        });
        self.structure = Some(structure);
        let Some((pose, cross, landmarks)) = blocks else {
            self.numerical_failures += 1;
            return;
        };
        let finite = pose.iter().chain(cross.iter().flat_map(|c| c.iter())).all(|v| v.is_finite())
            && landmarks.iter().flat_map(|(_, m)| m.iter()).all(|v| v.is_finite());
        if finite {
            self.pose_cov = (pose + pose.transpose()) * 0.5;
            self.cross_cov = cross;
            for (j, m) in landmarks {
                self.landmark_cov[j] = (m + m.transpose()) * 0.5;
            }
        }
    }

    /// The whitened residual of `f` at (`poses`, `landmarks`) and its Jacobians with respect to
    /// the solver's variables: each pose's left perturbation δ = (vx, vy, ω) of [`retract`], each
    /// landmark's position.
    fn linearise(&self, f: &Factor, poses: &[Pose2], landmarks: &[Vector2<f64>]) -> Linear {
        let mut l = self.linearise_in_coordinates(f, poses, landmarks);
        let s = l.r[..l.rows].iter().map(|v| v * v).sum::<f64>();
        l.cost = s;
        let kernel = match *f {
            Factor::Relative { cauchy, .. } | Factor::RangeBearing { cauchy, .. }
                if cauchy.is_finite() =>
            {
                Some(cauchy)
            }
            _ => None,
        };
        if let Some(c) = kernel {
            // ρ(s) = c² ln(1 + s/c²), ρ′(s) = 1/(1 + s/c²): the Gauss–Newton model of Σρ has
            // gradient Σρ′Jᵀr and Hessian Σρ′JᵀJ, i.e. plain least squares on √ρ′·(r, J)
            let c2 = c * c;
            l.cost = c2 * (s / c2).ln_1p();
            let scale = (1.0 / (1.0 + s / c2)).sqrt();
            l.r.iter_mut().for_each(|v| *v *= scale);
            for (_, _, jac) in l.blocks.iter_mut().take(l.nblocks) {
                jac.iter_mut().for_each(|v| *v *= scale);
            }
        }
        for (col, width, jac) in l.blocks.iter_mut().take(l.nblocks) {
            if *width == 3 && *col < 3 * poses.len() {
                // ∂x/∂δ = [[1, 0, −y], [0, 1, x], [0, 0, 1]] at pose (x, y, θ)
                let p = poses[*col / 3];
                for row in 0..l.rows {
                    let j = &mut jac[3 * row..3 * row + 3];
                    j[2] += -p.y * j[0] + p.x * j[1];
                }
            }
        }
        l
    }

    /// The whitened residual of `f` and its Jacobians with respect to the poses' coordinates
    /// (x, y, θ) and the landmarks' positions.
    fn linearise_in_coordinates(
        &self,
        f: &Factor,
        poses: &[Pose2],
        landmarks: &[Vector2<f64>],
    ) -> Linear {
        match *f {
            Factor::Prior { k, mean, w } => {
                let x = poses[k];
                let e = nalgebra::Vector3::new(
                    x.x - mean.x,
                    x.y - mean.y,
                    wrap_angle(x.theta - mean.theta),
                );
                let r = w * e;
                let mut j = [0.0; 9];
                j.copy_from_slice(w.transpose().as_slice()); // row-major of w
                Linear {
                    cost: 0.0,
                    r: [r[0], r[1], r[2]],
                    rows: 3,
                    blocks: [(3 * k, 3, j), (0, 0, [0.0; 9])],
                    nblocks: 1,
                }
            }
            Factor::Odometry { k, between, w } => {
                let (e, ja, jb) = between.residual(&poses[k], &poses[k + 1]);
                two_pose_linear(k, k + 1, &w, e, ja, jb)
            }
            Factor::Relative { a, b, z, w, .. } => {
                let (e, ja, jb) = relative_residual(&poses[a], &poses[b], &z);
                two_pose_linear(a, b, &w, e, ja, jb)
            }
            Factor::RangeBearing { k, j, z, w, .. } => {
                let (x, m) = (poses[k], landmarks[j]);
                let p = point_predict(&m, &x);
                let e = Vector2::new(p.z[0] - z[0], wrap_angle(p.z[1] - z[1]));
                // ∂h/∂m = H; ∂h/∂(x, y) = −H; ∂bearing/∂θ = −1
                let hm = w * p.h;
                let hx = w * range_bearing_pose_jacobian(&p.h);
                let r = w * e;
                let mut jx = [0.0; 9];
                for row in 0..2 {
                    for col in 0..3 {
                        jx[row * 3 + col] = hx[(row, col)];
                    }
                }
                let mut jm = [0.0; 9];
                for row in 0..2 {
                    for col in 0..2 {
                        jm[row * 2 + col] = hm[(row, col)];
                    }
                }
                Linear {
                    cost: 0.0,
                    r: [r[0], r[1], 0.0],
                    rows: 2,
                    blocks: [(3 * k, 3, jx), (self.landmark_col(j), 2, jm)],
                    nblocks: 2,
                }
            }
        }
    }

    fn cost_at(&self, poses: &[Pose2], landmarks: &[Vector2<f64>]) -> f64 {
        self.factors.iter().map(|f| self.linearise(f, poses, landmarks).cost).sum()
    }

    /// Runs `entry(row, col, value)` for each factor's contribution to the lower triangle of
    /// H = JᵀJ, in factor order; returns g = Jᵀr and the cost rᵀr.
    fn accumulate(&self, mut entry: impl FnMut(usize, usize, f64)) -> (Vec<f64>, f64) {
        let mut g = vec![0.0; self.dim()];
        let mut cost = 0.0;
        for f in &self.factors {
            let l = self.linearise(f, &self.poses, &self.landmarks);
            cost += l.cost;
            for a in 0..l.nblocks {
                let (ca, wa, ja) = l.blocks[a];
                for ia in 0..wa {
                    g[ca + ia] += (0..l.rows).map(|k| ja[k * wa + ia] * l.r[k]).sum::<f64>();
                }
                for b in 0..l.nblocks {
                    let (cb, wb, jb) = l.blocks[b];
                    for ia in 0..wa {
                        for ib in 0..wb {
                            let (row, col) = (ca + ia, cb + ib);
                            if row >= col {
                                let v = (0..l.rows).map(|k| ja[k * wa + ia] * jb[k * wb + ib]);
                                entry(row, col, v.sum::<f64>());
                            }
                        }
                    }
                }
            }
        }
        (g, cost)
    }

    /// H's stored values (duplicates summed in factor order), g and the cost at the current values.
    fn normal_equations(&self, structure: &Structure) -> (Vec<f64>, Vec<f64>, f64) {
        let mut h = vec![0.0; structure.symbolic.compute_nnz()];
        let mut slots = structure.slot.iter();
        let (g, cost) = self.accumulate(|_, _, v| h[*slots.next().expect("same factors")] += v);
        (h, g, cost)
    }

    /// Levenberg–Marquardt from the current values to `relative_decrease`; returns whether it
    /// converged.
    pub fn solve(&mut self) -> bool {
        self.solve_to(self.params.relative_decrease)
    }

    /// An intermediate solve that only initialises a later one: to a relative decrease of 1e-6.
    pub fn solve_warm(&mut self) -> bool {
        self.solve_to(self.params.relative_decrease.max(1e-6))
    }

    /// Levenberg–Marquardt by continuation on the odometry's stiffness: the arc model's factors
    /// are near-exact across the arc (σ of the matched floor, 1e-7), and from a start far from the
    /// optimum their second-order violation by each step held ρ near 0.7 and λ up — 100
    /// iterations ended far short. So the graph is first solved with body-frame noise of σ = s
    /// added to every increment, for s = 1e-3, 1e-4, … down to 10 times the stiffest factor's σ,
    /// each from the last, and then as stated; near the optimum the stated problem converges in
    /// a few steps.
    fn solve_to(&mut self, relative_decrease: f64) -> bool {
        let Some(structure) = self.take_structure() else {
            self.numerical_failures += 1;
            return false;
        };
        let stiffest = self.stiffest_sigma;
        for s in CONTINUATION_SIGMAS.into_iter().filter(|&s| s > 10.0 * stiffest) {
            self.set_inflation(s);
            self.levenberg_marquardt(&structure, relative_decrease.max(1e-6));
        }
        self.set_inflation(0.0);
        let converged = self.levenberg_marquardt(&structure, relative_decrease);
        self.structure = Some(structure);
        if self.params.association == GraphAssociation::NearestNeighbour {
            self.refresh_association_covariances();
        }
        converged
    }

    /// The structure of the graph's normal equations: the last one's while no factor was added.
    fn take_structure(&mut self) -> Option<Structure> {
        match self.structure.take() {
            Some(s) if s.factors == self.factors.len() => Some(s),
            _ => Structure::of(self),
        }
    }

    /// Every odometry factor whitened for its noise plus independent body-frame noise of σ = `s`.
    fn set_inflation(&mut self, s: f64) {
        for f in &mut self.factors {
            if let Factor::Odometry { between, w, .. } = f {
                *w = whitener(between.inflated_cov(s))
                    .unwrap_or_else(|| Matrix3::from_diagonal_element(1e6));
            }
        }
    }

    fn levenberg_marquardt(&mut self, structure: &Structure, relative_decrease: f64) -> bool {
        let n = self.dim();
        let (mut h, mut g, mut cost) = self.normal_equations(structure);
        let mut damped = SparseColMat::new(structure.symbolic.clone(), h.clone());
        // λ starts where the last solve left it: a warm start is near the optimum, where Gauss–Newton
        // steps are accepted, and would spend ~8 iterations lowering λ from 1e-4 by Nielsen's ⅓
        let (mut lambda, mut nu) = (self.lambda.max(1e-12), 2.0);
        for _ in 0..self.params.max_iterations {
            damped.val_mut().copy_from_slice(&h);
            for &d in &structure.diagonal {
                damped.val_mut()[d] = h[d] + lambda * h[d].max(1e-12);
            }
            let Some(dx) = solve_llt(&structure.cholesky, &damped, &g) else {
                lambda *= nu;
                nu *= 2.0;
                continue;
            };
            let (poses, landmarks) = self.stepped(&dx);
            let new_cost = self.cost_at(&poses, &landmarks);
            // predicted decrease of the Gauss–Newton model: −(2gᵀΔ + ΔᵀHΔ)
            let h_dx = symmetric_product(&structure.symbolic, &h, &dx);
            let predicted = -(0..n).map(|i| 2.0 * g[i] * dx[i] + dx[i] * h_dx[i]).sum::<f64>();
            let rho = (cost - new_cost) / predicted;
            if new_cost < cost && rho > 0.0 {
                let decrease = cost - new_cost;
                (self.poses, self.landmarks) = (poses, landmarks);
                lambda *= (1.0f64 / 3.0).max(1.0 - (2.0 * rho - 1.0).powi(3));
                nu = 2.0;
                if decrease <= relative_decrease * cost {
                    self.lambda = lambda;
                    return true;
                }
                (h, g, cost) = self.normal_equations(structure);
            } else {
                lambda *= nu;
                nu *= 2.0;
                if !lambda.is_finite() || lambda > 1e16 {
                    return cost.is_finite();
                }
            }
        }
        false
    }

    fn stepped(&self, dx: &[f64]) -> (Vec<Pose2>, Vec<Vector2<f64>>) {
        let poses = (self.poses.iter().enumerate())
            .map(|(k, p)| retract(p, dx[3 * k], dx[3 * k + 1], dx[3 * k + 2]))
            .collect();
        let base = 3 * self.poses.len();
        let landmarks = (self.landmarks.iter().enumerate())
            .map(|(j, m)| Vector2::new(m.x + dx[base + 2 * j], m.y + dx[base + 2 * j + 1]))
            .collect();
        (poses, landmarks)
    }

    /// The marginal covariances of the given poses (blocks of H⁻¹ at the current values).
    pub fn pose_marginals(&mut self, which: &[usize]) -> Vec<Option<Matrix3<f64>>> {
        let n = self.dim();
        let Some(structure) = self.take_structure() else {
            return vec![None; which.len()];
        };
        let (values, _, _) = self.normal_equations(&structure);
        let h = SparseColMat::new(structure.symbolic.clone(), values);
        let cholesky = &structure.cholesky;
        let marginals = with_llt(&cholesky, &h, |llt| {
            which
                .iter()
                .map(|&k| {
                    let mut e = Mat::<f64>::zeros(n, 3);
                    for i in 0..3 {
                        e[(3 * k + i, i)] = 1.0;
                    }
                    solve_in_place(llt, &mut e);
                    // the covariance of δ, and of (x, y, θ) = retract(x̂, δ) to first order
                    let m = Matrix3::from_fn(|r, c| e[(3 * k + r, c)]);
                    let p = self.poses[k];
                    let lift = Matrix3::new(1.0, 0.0, -p.y, 0.0, 1.0, p.x, 0.0, 0.0, 1.0);
                    let m = lift * m * lift.transpose();
                    m.iter().all(|v| v.is_finite()).then(|| (m + m.transpose()) * 0.5)
                })
                .collect()
        });
        self.structure = Some(structure);
        marginals.unwrap_or_else(|| {
            self.numerical_failures += 1;
            vec![None; which.len()]
        })
    }

    pub fn poses(&self) -> &[Pose2] {
        &self.poses
    }

    pub fn map(&self) -> LandmarkMap {
        LandmarkMap {
            points: self.landmarks.iter().map(|m| crate::geom::Point2::new(m.x, m.y)).collect(),
            // nearest-neighbour landmarks have no identity (`identity` stays empty)
            point_ids: match self.params.association {
                GraphAssociation::Known => self.identity.iter().map(|&id| Some(id)).collect(),
                GraphAssociation::NearestNeighbour => vec![None; self.landmarks.len()],
            },
            ..LandmarkMap::default()
        }
    }
}

/// ∂(range, bearing)/∂(x, y, θ) of a point reading, from H = ∂(range, bearing)/∂m: −H on the
/// position, and −1 of the bearing on the heading.
fn range_bearing_pose_jacobian(h: &Matrix2<f64>) -> nalgebra::Matrix2x3<f64> {
    nalgebra::Matrix2x3::new(-h[(0, 0)], -h[(0, 1)], 0.0, -h[(1, 0)], -h[(1, 1)], -1.0)
}

/// A factor on poses a and b with residual `e` and Jacobians `ja`, `jb`, whitened by `w`.
fn two_pose_linear(
    a: usize,
    b: usize,
    w: &Matrix3<f64>,
    e: Vector3<f64>,
    ja: Matrix3<f64>,
    jb: Matrix3<f64>,
) -> Linear {
    let (r, ja, jb) = (w * e, w * ja, w * jb);
    let row_major = |m: Matrix3<f64>| {
        let mut out = [0.0; 9];
        out.copy_from_slice(m.transpose().as_slice());
        out
    };
    Linear {
        cost: 0.0,
        r: [r[0], r[1], r[2]],
        rows: 3,
        blocks: [(3 * a, 3, row_major(ja)), (3 * b, 3, row_major(jb))],
        nblocks: 2,
    }
}

/// The residual of a measured relative pose z of b in a's frame, e = (x_b ⊖ x_a) − z with the
/// angle wrapped, and its Jacobians with respect to (x, y, θ) of a and of b: with
/// d = R(θ_a)ᵀ(t_b − t_a), ∂d/∂t_a = −R(θ_a)ᵀ, ∂d/∂t_b = R(θ_a)ᵀ, ∂d/∂θ_a = ∂R(θ_a)ᵀ/∂θ·(t_b − t_a).
fn relative_residual(
    a: &Pose2,
    b: &Pose2,
    z: &Pose2,
) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
    let (s, c) = a.theta.sin_cos();
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let e = Vector3::new(
        c * dx + s * dy - z.x,
        -s * dx + c * dy - z.y,
        wrap_angle(b.theta - a.theta - z.theta),
    );
    let ja = Matrix3::new(-c, -s, -s * dx + c * dy, s, -c, -c * dx - s * dy, 0.0, 0.0, -1.0);
    let jb = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
    (e, ja, jb)
}

/// The body-frame σ of the continuation's stages (see `Graph::solve_to`) [m, rad].
const CONTINUATION_SIGMAS: [f64; 4] = [1e-3, 1e-4, 1e-5, 1e-6];

/// The sparsity structure of a graph's normal equations, shared by the solves over it.
struct Structure {
    /// The number of factors it was built for.
    factors: usize,
    /// H's lower triangle.
    symbolic: SymbolicSparseColMat<usize>,
    cholesky: SymbolicCholesky<usize>,
    /// Where each entry `Graph::accumulate` emits lies among H's stored values, in its order.
    slot: Vec<usize>,
    /// Where each diagonal entry lies among H's stored values.
    diagonal: Vec<usize>,
}

impl Structure {
    /// The structure of `graph`'s normal equations and its symbolic factorisation; `None` when
    /// the factorisation's ordering fails.
    fn of(graph: &Graph) -> Option<Structure> {
        let n = graph.dim();
        let mut idx = Vec::new();
        graph.accumulate(|row, col, _| idx.push(Pair::new(row, col)));
        let (symbolic, _) = SymbolicSparseColMat::try_new_from_indices(n, n, &idx).ok()?;
        let cholesky = symbolic_cholesky(&symbolic)?;
        let at = |row: usize, col: usize| {
            let start = symbolic.col_ptr()[col];
            let rows = symbolic.row_idx_of_col_raw(col);
            start + rows.binary_search(&row).expect("an entry of H's structure")
        };
        let slot = idx.iter().map(|p| at(p.row, p.col)).collect();
        let diagonal = (0..n).map(|c| at(c, c)).collect();
        Some(Structure { factors: graph.factors.len(), symbolic, cholesky, slot, diagonal })
    }
}

/// A pose moved by the left perturbation δ = (vx, vy, ω): rotated by ω about the origin, then
/// shifted by (vx, vy). A step that moves a stretch of trajectory rigidly keeps the relative poses
/// of its odometry factors exactly, where additive (x, y, θ) steps bend them at second order —
/// against the arc model's near-exact factors (σ of 1e-7 off the arc). This alone did not let
/// Levenberg–Marquardt converge on them (the continuation of `Graph::solve_to` did); it is the
/// standard update on the pose manifold.
fn retract(p: &Pose2, vx: f64, vy: f64, omega: f64) -> Pose2 {
    let (s, c) = omega.sin_cos();
    Pose2::new(c * p.x - s * p.y + vx, s * p.x + c * p.y + vy, wrap_angle(p.theta + omega))
}

/// The fill-reducing ordering and simplicial structure of H's Cholesky factor (simplicial and
/// sequential, so the arithmetic does not depend on the CPU's vector width or the thread count).
///
/// The ordering is faer's approximate minimum degree, run here on *zeroed* scratch memory rather
/// than through `SymmetricOrdering::Amd`. faer 0.23's AMD, when it compares two candidate
/// supervariables of different lengths, keeps reading the shorter one's index list past its end
/// (SuiteSparse stops at the first mismatch), into workspace it never wrote: the mismatch is
/// already decided, so the values read do not matter — unless the allocator left an out-of-range
/// index there, which panics (index 1.4e19 into a length of 357, in a unit test). On zeroed
/// memory the stray reads are of index 0 and harmless, and the ordering does not depend on what
/// the heap held.
fn symbolic_cholesky(symbolic: &SymbolicSparseColMat<usize>) -> Option<SymbolicCholesky<usize>> {
    use faer::sparse::linalg::amd;
    let n = symbolic.nrows();
    let req = amd::order_maybe_unsorted_scratch::<usize>(n, symbolic.compute_nnz());
    let mut scratch = vec![std::mem::MaybeUninit::new(0u8); req.unaligned_bytes_required()];
    let (mut fwd, mut inv) = (vec![0usize; n], vec![0usize; n]);
    amd::order_maybe_unsorted(
        &mut fwd,
        &mut inv,
        symbolic.as_ref(),
        amd::Control::default(),
        MemStack::new(&mut scratch),
    )
    .ok()?;
    let ordering = faer::perm::PermRef::new_checked(&fwd, &inv, n);
    factorize_symbolic_cholesky(
        symbolic.as_ref(),
        Side::Lower,
        SymmetricOrdering::Custom(ordering),
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SIMPLICIAL,
            ..Default::default()
        },
    )
    .ok()
}

/// Runs `f` on the numeric Cholesky factorisation of `h` (sequential); `None` when `h` is not
/// positive definite.
fn with_llt<R>(
    cholesky: &SymbolicCholesky<usize>,
    h: &SparseColMat<usize, f64>,
    f: impl FnOnce(&LltRef<'_, usize, f64>) -> R,
) -> Option<R> {
    let mut l_val = vec![0.0; cholesky.len_val()];
    let mut buffer =
        MemBuffer::new(cholesky.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
    let llt = cholesky
        .factorize_numeric_llt(
            &mut l_val,
            h.as_ref(),
            Side::Lower,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut buffer),
            Default::default(),
        )
        .ok()?;
    Some(f(&llt))
}

/// x ← H⁻¹x with `llt` the factorisation of H.
fn solve_in_place(llt: &LltRef<'_, usize, f64>, x: &mut Mat<f64>) {
    let mut buffer = MemBuffer::new(llt.solve_in_place_scratch::<f64>(x.ncols(), Par::Seq));
    llt.solve_in_place_with_conj(faer::Conj::No, x.as_mut(), Par::Seq, MemStack::new(&mut buffer));
}

/// Solves H Δ = −g by the sparse Cholesky factorisation of H.
fn solve_llt(
    cholesky: &SymbolicCholesky<usize>,
    h: &SparseColMat<usize, f64>,
    g: &[f64],
) -> Option<Vec<f64>> {
    let n = g.len();
    let dx = with_llt(cholesky, h, |llt| {
        let mut rhs = Mat::<f64>::from_fn(n, 1, |i, _| -g[i]);
        solve_in_place(llt, &mut rhs);
        (0..n).map(|i| rhs[(i, 0)]).collect::<Vec<f64>>()
    })?;
    dx.iter().all(|v| v.is_finite()).then_some(dx)
}

/// H·v for H stored as its lower triangle (`structure`, `values`).
fn symmetric_product(
    structure: &SymbolicSparseColMat<usize>,
    values: &[f64],
    v: &[f64],
) -> Vec<f64> {
    let mut out = vec![0.0; v.len()];
    for c in 0..v.len() {
        let start = structure.col_ptr()[c];
        for (k, &r) in structure.row_idx_of_col_raw(c).iter().enumerate() {
            let x = values[start + k];
            out[r] += x * v[c];
            if r != c {
                out[c] += x * v[r];
            }
        }
    }
    out
}

/// Grows the graph step by step over the world's odometry and observations; `at_step(graph, k,
/// due)` runs after step k is added, `due` at the last step and at every `relinearise_every`-th
/// step ([`Nodes::EveryStep`]) or every `relinearise_every`-th pose added
/// ([`Nodes::ReadingSteps`]).
fn grow(
    world: &World,
    motion: &MotionModel,
    params: &GraphParams,
    observations: &[StepObservations],
    mut at_step: impl FnMut(&mut Graph, usize, bool),
) -> Result<Graph, SlamError> {
    let mut graph = Graph::new(world.truth[0], params);
    let mut cursor = super::observations::Cursor::new(observations, true);
    let steps = world.odometry.len();
    let every = params.relinearise_every as usize;
    let mut pending = Vec::new();
    for k in 0..=steps {
        let readings = cursor.at(k);
        let due = match params.nodes {
            Nodes::EveryStep => {
                if k > 0 {
                    graph.add_odometry(&world.odometry[k - 1], motion)?;
                }
                k % every == 0
            }
            Nodes::ReadingSteps => {
                if k > 0 {
                    pending.push(world.odometry[k - 1]);
                }
                let node = k > 0 && (!readings.is_empty() || k == steps);
                if node {
                    graph.add_odometry_run(&pending, motion, k);
                    pending.clear();
                }
                k == 0 || (node && (graph.poses.len() - 1) % every == 0)
            }
        };
        if graph.steps[graph.steps.len() - 1] == k {
            graph.add_observations(readings)?;
        }
        at_step(&mut graph, k, due || k == steps);
    }
    Ok(graph)
}

/// Every step's pose: the graph's at its poses' steps, the steps between by odometry from the
/// last pose before them (every step is a pose under [`Nodes::EveryStep`]).
fn trajectory(graph: &Graph, world: &World) -> Vec<Pose2> {
    let mut estimate: Vec<Pose2> = Vec::with_capacity(world.odometry.len() + 1);
    let mut node = 0;
    for k in 0..=world.odometry.len() {
        if node < graph.steps.len() && graph.steps[node] == k {
            estimate.push(graph.poses[node]);
            node += 1;
        } else {
            let last = estimate[k - 1];
            estimate.push(last.compose(world.odometry[k - 1]));
        }
    }
    estimate
}

/// Batch smoothing: the smoothed trajectory after the last step. The graph is re-solved every
/// `relinearise_every` steps while it grows only to initialise the final solve (from the odometry
/// alone, Levenberg–Marquardt can stall on long runs with large heading errors); the estimate is
/// that final solve's, over the whole run.
pub fn run_batch(
    world: &World,
    motion: &MotionModel,
    params: &GraphParams,
    observations: &[StepObservations],
) -> Result<Trace, SlamError> {
    let steps = world.odometry.len();
    let mut graph = grow(world, motion, params, observations, |graph, k, due| {
        if due && k < steps {
            graph.solve_warm();
        }
    })?;
    if !graph.solve() {
        graph.numerical_failures += 1;
    }
    let every = params.belief_every as usize;
    let which: Vec<usize> = (0..graph.poses.len()).step_by(every).collect();
    let marginals = graph.pose_marginals(&which);
    let mut pose_belief = vec![None; steps + 1];
    for (i, m) in which.iter().zip(marginals) {
        pose_belief[graph.steps[*i]] = m.map(|m| (graph.poses[*i], m));
    }
    Ok(Trace {
        estimate: trajectory(&graph, world),
        numerical_failures: graph.numerical_failures,
        map: Some(graph.map()),
        pose_belief,
        ..Trace::default()
    })
}

/// Online smoothing: re-solved every `relinearise_every` steps to a relative decrease of 1e-6
/// (and at the last step to `relative_decrease`); each step's estimate is what the smoother knew
/// then: the newest pose of the last solve, composed with the odometry since.
pub fn run_online(
    world: &World,
    motion: &MotionModel,
    params: &GraphParams,
    observations: &[StepObservations],
) -> Result<Trace, SlamError> {
    let steps = world.odometry.len();
    let mut estimate = Vec::with_capacity(steps + 1);
    let mut pose_belief = Vec::with_capacity(steps + 1);
    let mut pose = world.truth[0];
    let graph = grow(world, motion, params, observations, |graph, k, due| {
        if due {
            // the last solve to full precision (the final map); the others to 1e-6 of the cost
            let converged = if k == steps { graph.solve() } else { graph.solve_warm() };
            if !converged {
                graph.numerical_failures += 1;
            }
            // the newest pose is step k's: under `reading_steps` a solve is due only where a pose
            // was added (and at the last step, always a pose)
            let newest = graph.poses.len() - 1;
            pose = graph.poses[newest];
            let marginal = graph.pose_marginals(&[newest]).pop().flatten();
            pose_belief.push(marginal.map(|m| (pose, m)));
        } else {
            pose = pose.compose(world.odometry[k - 1]);
            pose_belief.push(None);
        }
        estimate.push(pose);
    })?;
    Ok(Trace {
        estimate,
        numerical_failures: graph.numerical_failures,
        map: Some(graph.map()),
        pose_belief,
        ..Trace::default()
    })
}

#[cfg(test)]
mod tests;

/// For the benchmark of one solve's cost (`benches/graph_slam.rs`): the graph of the whole run
/// with every pose at the truth and every landmark at its first reading from there, to be solved
/// once by [`Graph::solve`] — a re-solve near the optimum, the smoother's building block.
pub fn graph_at_truth(
    world: &World,
    motion: &MotionModel,
    params: &GraphParams,
    observations: &[StepObservations],
) -> Result<Graph, SlamError> {
    let mut graph = Graph::new(world.truth[0], params);
    let mut cursor = super::observations::Cursor::new(observations, true);
    for k in 0..=world.odometry.len() {
        if k > 0 {
            graph.add_odometry(&world.odometry[k - 1], motion)?;
            graph.poses[k] = world.truth[k];
        }
        graph.add_observations(cursor.at(k))?;
    }
    Ok(graph)
}
