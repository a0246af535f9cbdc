//! EKF-SLAM with range-bearing point landmarks and (ρ, θ) line landmarks: ([`World`] odometry,
//! per-step [`Observation`]s) → [`Trace`]. One joint Gaussian over the robot pose and every
//! landmark, x = (x, y, θ, m₁, m₂, …), each mᵢ two-dimensional.
//!
//! References:
//! - [PR] Thrun, Burgard, Fox, *Probabilistic Robotics*, Table 10.1 (EKF-SLAM with known
//!   correspondences) and Table 10.2 (unknown correspondences: Mahalanobis / maximum-likelihood
//!   association, new landmarks when nothing is close enough).
//! - [TB] T. Bailey's EKF-SLAM simulator (`ekfslam_v1`): the two χ² gates `gate_reject` (an
//!   observation must be this close to update a landmark) and `gate_augment` (this far from every
//!   landmark to create one), sequential updates, augmentation after the updates.
//! - [EV] "SLAM con EKF y visión artificial" §3.8 (reference notes Part B.8): the same cycle
//!   (predict → update re-observed → add new), and its omission of the covariance update on
//!   re-observation ("the covariance matrix is not altered"), kept as the faithful option
//!   [`CovarianceUpdate::NoneOnReobservation`].
//!
//! Each step follows [EV]'s steps 0–3 in [PR]'s and [TB]'s order: predict with the odometry
//! increment, associate every observation of the step against the predicted map as it was before
//! the step (gated on the innovation, where [EV] compares global positions with a 3 cm box),
//! update sequentially with the matched ones (Joseph form, O(n²) per observation: H has only the
//! pose's and one landmark's columns), then augment the state with the new ones.
//!
//! Under known association, several readings of one identity in a step arrive fused into one
//! ([`super::observations::fuse`]). Known limitations of gated association (as in [TB]): two
//! observations of one step may match the same landmark and both update it; two observations of
//! one unseen landmark create two landmarks.

use super::driver::{self, Filter};
use super::fastslam::models::Model;
use super::motion::MotionModel;
use super::observations::{Observation, StepObservations};
use super::{LandmarkMap, SlamError, Trace};
use crate::config::{Checks, Violation};
use crate::geom::{Line, Point2, Pose2, wrap_angle};
use crate::world::World;
use nalgebra::{DMatrix, DVector, Dyn, Matrix2, Matrix2x3, Matrix3, OMatrix, U2, Vector2, Vector3};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

pub const CODE_VERSION: &str = "ekf-slam-4";

/// Dimension of the robot pose (x, y, θ) in the joint state.
const POSE_DIM: usize = 3;
/// Dimension of every landmark ((x, y) or (ρ, θ)).
const LANDMARK_DIM: usize = 2;
/// Index of the heading θ in the joint state.
const HEADING: usize = 2;

/// `[base.ekf]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct EkfParams {
    /// How observations are matched to landmarks.
    pub association: EkfAssociation,
    /// χ²(2 dof) gate on the normalised innovation squared νᵀS⁻¹ν [–]: only landmarks closer
    /// than this can be updated by an observation. Default 4.0, [TB]'s `GATE_REJECT`.
    pub gate_reject: f64,
    /// χ²(2 dof) gate [–]: an observation farther than this from every landmark of its kind
    /// creates a new one; between the two gates it is ignored as ambiguous. Default 25.0, [TB]'s
    /// `GATE_AUGMENT`. Unused under known association.
    pub gate_create: f64,
    /// Prior σ of x and y at the start [m]. Default 0: the start pose is given to every
    /// algorithm, so it is known exactly (P₀ = 0; the first prediction makes P_rr positive).
    pub initial_pose_sigma_m: f64,
    /// Prior σ of θ at the start [rad]. Default 0, as above.
    pub initial_pose_sigma_rad: f64,
    /// What a re-observation does to P.
    pub covariance_update: CovarianceUpdate,
    /// Under known association, ignore a reading whose NIS against its landmark exceeds this
    /// (χ²₂; `inf` = never, the default and the textbook's known-correspondence EKF). Real logs
    /// have gross outliers (MRCLAM: about 3 % of the bearings). Written out only when set, so
    /// existing run hashes are unchanged.
    #[serde(skip_serializing_if = "is_off")]
    pub known_outlier_gate: f64,
    /// σρ² [m²] of line features (and the range of corner features) on laser worlds; point
    /// sensors state their own noise. Default: [FT] Table 10.2.
    pub laser_var_rho_m2: f64,
    /// σθ² [rad²] of line features (and the bearing of corners) on laser worlds.
    pub laser_var_theta_rad2: f64,
}

/// `known_outlier_gate = inf`: no gate.
fn is_off(gate: &f64) -> bool {
    gate.is_infinite()
}

impl EkfParams {
    /// R of line and corner features on laser worlds.
    pub fn laser_covariance(&self) -> Matrix2<f64> {
        Matrix2::new(self.laser_var_rho_m2, 0.0, 0.0, self.laser_var_theta_rad2)
    }
}

impl Default for EkfParams {
    fn default() -> Self {
        Self {
            association: EkfAssociation::NearestNeighbour,
            gate_reject: 4.0,
            gate_create: 25.0,
            initial_pose_sigma_m: 0.0,
            initial_pose_sigma_rad: 0.0,
            covariance_update: CovarianceUpdate::Joseph,
            known_outlier_gate: f64::INFINITY,
            laser_var_rho_m2: 0.04,
            laser_var_theta_rad2: 0.00122,
        }
    }
}

impl EkfParams {
    /// The report's sentence on EKF-SLAM: association, its NIS gates, the outlier gate of known
    /// association when set, and the covariance update.
    pub fn describe(&self) -> String {
        format!(
            "EKF-SLAM: {} association (NIS gates: update below {}, new landmark above {}){}; covariance update {}.",
            match self.association {
                EkfAssociation::Known => "known",
                EkfAssociation::NearestNeighbour => "nearest-neighbour",
                EkfAssociation::MaximumLikelihood => "maximum-likelihood",
            },
            self.gate_reject,
            self.gate_create,
            if self.known_outlier_gate.is_finite() {
                format!(
                    ", known matches with NIS above {} ignored as outliers",
                    self.known_outlier_gate
                )
            } else {
                String::new()
            },
            match self.covariance_update {
                CovarianceUpdate::Joseph => "in Joseph form",
                CovarianceUpdate::NoneOnReobservation =>
                    "skipped on re-observation ([EV]'s omission)",
            }
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.non_negative("gate_reject", self.gate_reject);
        c.non_negative("gate_create", self.gate_create);
        if self.gate_reject.is_finite() && self.gate_create.is_finite() {
            c.require(self.gate_create >= self.gate_reject, "gate_create", || {
                format!("must be ≥ gate_reject ({}), got {}", self.gate_reject, self.gate_create)
            });
        }
        c.non_negative("initial_pose_sigma_m", self.initial_pose_sigma_m);
        c.non_negative("initial_pose_sigma_rad", self.initial_pose_sigma_rad);
        c.positive("laser_var_rho_m2", self.laser_var_rho_m2);
        c.positive("laser_var_theta_rad2", self.laser_var_theta_rad2);
        c.require(self.known_outlier_gate > 0.0, "known_outlier_gate", || {
            format!("must be > 0 (inf = off), got {}", self.known_outlier_gate)
        });
        c.finish()
    }
}

/// How EKF-SLAM matches observations to landmarks.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum EkfAssociation {
    /// The sensor's landmark identities ([PR] Table 10.1). An observation without one is
    /// ignored and counted in `numerical_failures` (the sensor cannot serve this mode).
    Known,
    /// Smallest normalised innovation squared among landmarks of the same kind, within
    /// `gate_reject` ([PR] Table 10.2 with a Mahalanobis gate).
    #[default]
    NearestNeighbour,
    /// Largest Gaussian likelihood N(ν; 0, S), i.e. smallest νᵀS⁻¹ν + ln det S, among landmarks
    /// within `gate_reject` ([TB]'s `data_associate`).
    MaximumLikelihood,
}

/// What the update does to the covariance.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum CovarianceUpdate {
    /// P = (I − KH) P (I − KH)ᵀ + K R Kᵀ: symmetric positive semi-definite whatever rounding.
    #[default]
    Joseph,
    /// [EV]'s implementation: the mean is updated, P is not ("the covariance matrix is not
    /// altered"); only prediction and augmentation change P.
    NoneOnReobservation,
}

/// One landmark of the joint state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkInfo {
    pub model: Model,
    /// The true landmark id when the filter was told it (known association).
    pub id: Option<usize>,
    /// Index of its first component in x.
    pub index: usize,
}

/// What to do with one observation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Association {
    /// Update landmark (index into the landmark list).
    Update(usize),
    /// Far from every landmark: add it to the state.
    New,
    /// Between the gates, or unusable: no effect.
    Ignored,
}

/// The EKF-SLAM filter state: mean x, covariance P and what each landmark is.
#[derive(Debug, Clone)]
pub struct Ekf<'a> {
    params: &'a EkfParams,
    motion: &'a MotionModel,
    x: DVector<f64>,
    p: DMatrix<f64>,
    landmarks: Vec<LandmarkInfo>,
    pub numerical_failures: u64,
    pub weighted_steps: u64,
    /// ‖K_pose‖ (Frobenius) of every successful update, in order.
    pub kalman_gain: Vec<f64>,
}

impl<'a> Ekf<'a> {
    pub fn new(params: &'a EkfParams, motion: &'a MotionModel, start: Pose2) -> Self {
        let (sm, sr) = (params.initial_pose_sigma_m, params.initial_pose_sigma_rad);
        Self {
            params,
            motion,
            x: DVector::from_column_slice(&[start.x, start.y, start.theta]),
            p: DMatrix::from_diagonal(&DVector::from_column_slice(&[sm * sm, sm * sm, sr * sr])),
            landmarks: Vec::new(),
            numerical_failures: 0,
            weighted_steps: 0,
            kalman_gain: Vec::new(),
        }
    }

    /// One filter step: predict → associate → update → augment.
    pub fn step(&mut self, control: Option<&Pose2>, observations: &[Observation]) {
        if let Some(u) = control {
            self.predict(u); // [EV] step 1: odometry
        }
        let decisions: Vec<Association> = observations.iter().map(|o| self.associate(o)).collect(); // [EV] step 0, after the prediction
        let mut updated = false;
        for (o, d) in observations.iter().zip(&decisions) {
            if let Association::Update(j) = *d {
                updated |= self.update(o, j); // [EV] step 2: re-observed, one at a time
            }
        }
        for (o, d) in observations.iter().zip(&decisions) {
            if *d == Association::New {
                self.augment(o); // [EV] step 3: new landmarks
            }
        }
        self.weighted_steps += updated as u64;
    }

    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x[0], self.x[1], self.x[HEADING])
    }

    /// P_rr, the pose block of P.
    pub fn pose_cov(&self) -> Matrix3<f64> {
        self.p.fixed_view::<POSE_DIM, POSE_DIM>(0, 0).into_owned()
    }

    /// The joint mean x = (x, y, θ, m₁, …).
    pub fn mean(&self) -> &DVector<f64> {
        &self.x
    }

    /// The joint covariance P.
    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.p
    }

    pub fn landmarks(&self) -> &[LandmarkInfo] {
        &self.landmarks
    }

    /// The map: lines, and point landmarks as corners (laser worlds) or points.
    pub fn map(&self, points_as_corners: bool) -> LandmarkMap {
        let mut map = LandmarkMap::default();
        for l in &self.landmarks {
            let (a, b) = (self.x[l.index], self.x[l.index + 1]);
            match (l.model, points_as_corners) {
                (Model::Line, _) => map.lines.push(Line::normalised(a, b)),
                (Model::Point, true) => map.corners.push(Point2::new(a, b)),
                (Model::Point, false) => {
                    map.points.push(Point2::new(a, b));
                    map.point_ids.push(l.id);
                }
            }
        }
        map
    }

    /// x_r ← x_r ⊕ u; P_rr ← F P_rr Fᵀ + Q; P_rm ← F P_rm, P_mr = P_rmᵀ: [EV] Eq. 2.14 with
    /// F = diag(F_r, I) (Eq. 2.12), touching only the pose rows and columns (O(n)).
    fn predict(&mut self, u: &Pose2) {
        let pose = self.pose();
        let f = self.motion.jacobian(&pose, u);
        let q = self.motion.covariance(&pose, u);
        let next = self.motion.predict(&pose, u); // Eq. (2.4): x̂⁻ = f(x̂, u, 0)
        self.x.fixed_rows_mut::<POSE_DIM>(0).copy_from(&Vector3::new(next.x, next.y, next.theta));
        let prr = f * self.pose_cov() * f.transpose() + q; // Eq. (2.14), pose block
        self.p.fixed_view_mut::<POSE_DIM, POSE_DIM>(0, 0).copy_from(&symmetric3(&prr));
        let m = self.x.len() - POSE_DIM;
        if m > 0 {
            let prm = f * self.p.view((0, POSE_DIM), (POSE_DIM, m)); // Eq. (2.14), cross block
            self.p.view_mut((0, POSE_DIM), (POSE_DIM, m)).copy_from(&prm);
            self.p.view_mut((POSE_DIM, 0), (m, POSE_DIM)).copy_from(&prm.transpose());
        }
    }

    /// The landmark this observation belongs to, if any.
    fn associate(&mut self, o: &Observation) -> Association {
        match self.params.association {
            EkfAssociation::Known => self.associate_known(o),
            EkfAssociation::NearestNeighbour | EkfAssociation::MaximumLikelihood => {
                self.associate_gated(o)
            }
        }
    }

    fn associate_known(&mut self, o: &Observation) -> Association {
        let Some(id) = o.landmark else {
            self.numerical_failures += 1; // known association needs identities: counted, ignored
            return Association::Ignored;
        };
        match self.landmarks.iter().position(|l| l.model == o.model && l.id == Some(id)) {
            // an outlier gate on known matches (off by default): a reading whose NIS exceeds it
            // is ignored
            Some(j) if self.params.known_outlier_gate.is_finite() => {
                let pose = self.pose();
                match self.innovation(o, j, &pose) {
                    Some(inn) if inn.nis() <= self.params.known_outlier_gate => {
                        Association::Update(j)
                    }
                    Some(_) => Association::Ignored,
                    None => {
                        self.numerical_failures += 1;
                        Association::Ignored
                    }
                }
            }
            Some(j) => Association::Update(j),
            None => Association::New,
        }
    }

    /// [TB]'s `data_associate`: among landmarks of the same kind with NIS < gate_reject the one
    /// with the smallest score (NIS, or NIS + ln det S for maximum likelihood); none such and
    /// every NIS > gate_create: new; otherwise ignored.
    fn associate_gated(&mut self, o: &Observation) -> Association {
        let pose = self.pose();
        let mut best: Option<(usize, f64)> = None;
        let mut nearest_nis = f64::INFINITY;
        for j in 0..self.landmarks.len() {
            if self.landmarks[j].model != o.model {
                continue;
            }
            let Some(innovation) = self.innovation(o, j, &pose) else {
                self.numerical_failures += 1;
                continue;
            };
            let nis = innovation.nis();
            nearest_nis = nearest_nis.min(nis);
            let score = match self.params.association {
                EkfAssociation::MaximumLikelihood => nis + innovation.ln_det_s(), // −2 ln N(ν; 0, S) − 2 ln 2π
                _ => nis,
            };
            if nis < self.params.gate_reject && best.is_none_or(|(_, s)| score < s) {
                best = Some((j, score));
            }
        }
        match best {
            Some((j, _)) => Association::Update(j),
            None if nearest_nis > self.params.gate_create => Association::New,
            None => Association::Ignored,
        }
    }

    /// ν, S and the sparse H of observation `o` against landmark `j` from `pose`, or `None` when
    /// S is not positive definite. S = H P Hᵀ + R from the 5 × 5 block of P that H touches.
    fn innovation(&self, o: &Observation, j: usize, pose: &Pose2) -> Option<Innovation> {
        let i = self.landmarks[j].index;
        let m = Vector2::new(self.x[i], self.x[i + 1]);
        let pred = o.model.predict_full(&m, pose); // Eq. (2.5): ẑ = h(x̂⁻); H = [h_pose 0 … h_landmark 0 …]
        let (hp, hl) = (pred.h_pose, pred.h_landmark);
        let prr = self.pose_cov();
        let prl = self.p.fixed_view::<POSE_DIM, LANDMARK_DIM>(0, i).into_owned();
        let pll = self.p.fixed_view::<LANDMARK_DIM, LANDMARK_DIM>(i, i).into_owned();
        let hph = hp * prr * hp.transpose()
            + hp * prl * hl.transpose()
            + hl * prl.transpose() * hp.transpose()
            + hl * pll * hl.transpose();
        let s = symmetric2(&(hph + o.r)); // Eq. (2.15): S = H P Hᵀ + R
        let chol = s.cholesky()?;
        let nu = o.model.innovation(&o.z, &pred.z); // z − ẑ, angle wrapped
        Some(Innovation { nu, s, s_inv: chol.inverse(), h_pose: hp, h_landmark: hl, index: i })
    }

    /// Sequential EKF update with one observation of landmark `j` ([EV] step 2, [PR] Table
    /// 10.1's loop body). Returns false (and counts a failure) when S is singular or the update is not
    /// finite; the state is then left as it was.
    fn update(&mut self, o: &Observation, j: usize) -> bool {
        let Some(inn) = self.innovation(o, j, &self.pose()) else {
            self.numerical_failures += 1;
            return false;
        };
        let w = inn.p_ht(&self.p); // P Hᵀ from the 3 + 2 columns of P that H touches
        let k = &w * inn.s_inv; // Eq. (2.16): K = P Hᵀ S⁻¹
        let dx = &k * inn.nu;
        if !(k.iter().all(|v| v.is_finite()) && dx.iter().all(|v| v.is_finite())) {
            self.numerical_failures += 1;
            return false;
        }
        self.kalman_gain.push(k.rows(0, POSE_DIM).norm()); // how far this observation moves the pose
        self.x += dx; // x̂ = x̂⁻ + K (z − ẑ)
        self.x[HEADING] = wrap_angle(self.x[HEADING]);
        if self.params.covariance_update == CovarianceUpdate::Joseph {
            // (I − KH) P (I − KH)ᵀ + K R Kᵀ in O(n²): A = (I − KH) P = P − K Wᵀ (W = P Hᵀ),
            // then A (I − KH)ᵀ + K R Kᵀ = A − (A Hᵀ − K R) Kᵀ
            self.p.gemm(-1.0, &k, &w.transpose(), 1.0);
            let b = inn.p_ht(&self.p) - &k * o.r;
            self.p.gemm(-1.0, &b, &k.transpose(), 1.0);
            symmetrise(&mut self.p);
        }
        self.normalise_lines();
        true
    }

    /// Adds a landmark m = g⁻¹(x_r, z) with P_mm = G_p P_rr G_pᵀ + G_z R G_zᵀ and
    /// P_m· = G_p P_r· ([EV] step 3 and Eqs. 2.18–2.24, [TB] `augment`).
    fn augment(&mut self, o: &Observation) {
        let inv = o.model.inverse_full(&o.z, &self.pose());
        let n = self.x.len();
        let cross = inv.g_pose * self.p.rows(0, POSE_DIM); // Eqs. (2.18–2.24): P_m· = G_p P_r·
        let pmm = inv.g_pose * self.pose_cov() * inv.g_pose.transpose()
            + inv.g_z * o.r * inv.g_z.transpose(); // P_mm = G_p P_rr G_pᵀ + G_z R G_zᵀ
        if !(inv.m.iter().chain(cross.iter()).chain(pmm.iter()).all(|v| v.is_finite())) {
            self.numerical_failures += 1;
            return;
        }
        self.x.resize_vertically_mut(n + LANDMARK_DIM, 0.0);
        self.x.fixed_rows_mut::<LANDMARK_DIM>(n).copy_from(&inv.m);
        self.p.resize_mut(n + LANDMARK_DIM, n + LANDMARK_DIM, 0.0);
        self.p.view_mut((n, 0), (LANDMARK_DIM, n)).copy_from(&cross);
        self.p.view_mut((0, n), (n, LANDMARK_DIM)).copy_from(&cross.transpose());
        self.p.fixed_view_mut::<LANDMARK_DIM, LANDMARK_DIM>(n, n).copy_from(&symmetric2(&pmm));
        let id = if self.params.association == EkfAssociation::Known { o.landmark } else { None };
        self.landmarks.push(LandmarkInfo { model: o.model, id, index: n });
    }

    /// Lines back to ρ ≥ 0, θ ∈ (−π, π]: (ρ, θ) → (−ρ, θ + π) has Jacobian diag(−1, 1) on that
    /// landmark, so P ← J P Jᵀ negates the ρ row and column (the variance keeps its sign).
    fn normalise_lines(&mut self) {
        for l in &self.landmarks {
            if l.model != Model::Line {
                continue;
            }
            let i = l.index;
            if self.x[i] < 0.0 {
                self.x[i] = -self.x[i];
                self.x[i + 1] = wrap_angle(self.x[i + 1] + PI);
                self.p.row_mut(i).neg_mut();
                self.p.column_mut(i).neg_mut();
            } else {
                self.x[i + 1] = wrap_angle(self.x[i + 1]);
            }
        }
    }
}

/// One observation against one landmark: ν = z − ẑ, S, S⁻¹ and the non-zero blocks of H.
struct Innovation {
    nu: Vector2<f64>,
    s: Matrix2<f64>,
    s_inv: Matrix2<f64>,
    h_pose: Matrix2x3<f64>,
    h_landmark: Matrix2<f64>,
    /// Index of the landmark's first component in x.
    index: usize,
}

impl Innovation {
    /// Normalised innovation squared νᵀ S⁻¹ ν.
    fn nis(&self) -> f64 {
        (self.nu.transpose() * self.s_inv * self.nu)[0]
    }

    fn ln_det_s(&self) -> f64 {
        self.s.determinant().ln()
    }

    /// M Hᵀ for an n × n matrix M, from the pose columns and the landmark's two columns.
    fn p_ht(&self, m: &DMatrix<f64>) -> OMatrix<f64, Dyn, U2> {
        m.columns(0, POSE_DIM) * self.h_pose.transpose()
            + m.columns(self.index, LANDMARK_DIM) * self.h_landmark.transpose()
    }
}

fn symmetric2(m: &Matrix2<f64>) -> Matrix2<f64> {
    (m + m.transpose()) * 0.5
}

fn symmetric3(m: &Matrix3<f64>) -> Matrix3<f64> {
    (m + m.transpose()) * 0.5
}

/// P ← (P + Pᵀ) / 2 in place.
fn symmetrise(p: &mut DMatrix<f64>) {
    let n = p.nrows();
    for c in 0..n {
        for r in (c + 1)..n {
            let v = 0.5 * (p[(r, c)] + p[(c, r)]);
            p[(r, c)] = v;
            p[(c, r)] = v;
        }
    }
}

/// Runs EKF-SLAM over a world's odometry and the given observations (in step order; steps
/// without one are absent). Point landmarks go to the map's `corners` when `points_as_corners`
/// (laser features), else to `points`.
pub fn run(
    world: &World,
    motion: &MotionModel,
    params: &EkfParams,
    observations: &[StepObservations],
    points_as_corners: bool,
) -> Result<Trace, SlamError> {
    let filter = Ekf::new(params, motion, world.truth[0]);
    let steps = world.odometry.len();
    let run = EkfRun {
        filter,
        points_as_corners,
        estimate: Vec::with_capacity(steps + 1),
        pose_belief: Vec::with_capacity(steps + 1),
    };
    driver::run(world, observations, params.association == EkfAssociation::Known, run)
}

/// EKF-SLAM as the driver steps it: the filter and the pose estimate and belief of every step.
struct EkfRun<'a> {
    filter: Ekf<'a>,
    points_as_corners: bool,
    estimate: Vec<Pose2>,
    pose_belief: Vec<Option<(Pose2, Matrix3<f64>)>>,
}

impl Filter for EkfRun<'_> {
    fn step(
        &mut self,
        _: usize,
        control: Option<&Pose2>,
        observations: &[Observation],
    ) -> Result<(), SlamError> {
        self.filter.step(control, observations);
        self.estimate.push(self.filter.pose());
        self.pose_belief.push(Some((self.filter.pose(), self.filter.pose_cov())));
        Ok(())
    }

    fn finish(self) -> Trace {
        Trace {
            estimate: self.estimate,
            numerical_failures: self.filter.numerical_failures,
            map: Some(self.filter.map(self.points_as_corners)),
            weighted_steps: self.filter.weighted_steps,
            pose_belief: self.pose_belief,
            kalman_gain: self.filter.kalman_gain,
            ..Trace::default()
        }
    }
}

#[cfg(test)]
mod tests;
