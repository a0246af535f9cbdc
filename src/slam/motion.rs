//! Motion models of the landmark filters that propagate a pose Gaussian (EKF-SLAM) or sample
//! from one (FastSLAM 2.0, and FastSLAM 1.0 on point-landmark worlds): odometry increment u
//! (body frame) and pose → predicted pose, its Jacobian F = ∂(x ⊕ u)/∂x, and the process noise
//! Q in the world frame, so that x' ~ N(x ⊕ u, Q) to first order.
//!
//! [FT]'s FastSLAM 1.0 on laser worlds keeps its own `[fastslam]` motion noise (Eq. 7.18).

use crate::config::{Checks, Violation};
use crate::geom::{wrap_angle, Pose2};
use nalgebra::Matrix3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// `[base.motion_model]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum MotionModel {
    /// Additive per-step pose noise in the world frame, [FT] Eq. 7.18:
    /// x' = x ⊕ u + ε, ε ~ N(0, diag(σx², σy², σθ²)).
    Pose {
        /// σx [m] per step.
        sigma_x_m: f64,
        /// σy [m] per step.
        sigma_y_m: f64,
        /// σθ [rad] per step.
        sigma_theta_rad: f64,
    },
    /// Noise on the odometry increment itself (body frame), proportional to the motion:
    /// u' = u + n, n ~ N(0, diag(σt², σt², σr²)), σt = k_translation·|(ux, uy)| + floor_translation_m,
    /// σr = k_rotation·|uθ| + floor_rotation_rad. It matches the simulated `proportional`
    /// odometry noise (v and ω perturbed by k·|v|, k·|ω|) when k_translation = k_rotation = k.
    Proportional {
        /// Translation noise per metre driven [m/m].
        k_translation: f64,
        /// Rotation noise per radian turned [rad/rad].
        k_rotation: f64,
        /// Translation noise floor per step [m] (keeps Q positive definite when standing).
        floor_translation_m: f64,
        /// Rotation noise floor per step [rad].
        floor_rotation_rad: f64,
    },
}

impl Default for MotionModel {
    /// Matches the default simulated odometry (10 % proportional noise, read as σ), with floors
    /// of 1 mm and 0.001 rad per step.
    fn default() -> Self {
        MotionModel::Proportional { k_translation: 0.1, k_rotation: 0.1, floor_translation_m: 1e-3, floor_rotation_rad: 1e-3 }
    }
}

impl MotionModel {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        match *self {
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                c.non_negative("sigma_x_m", sigma_x_m);
                c.non_negative("sigma_y_m", sigma_y_m);
                c.non_negative("sigma_theta_rad", sigma_theta_rad);
            }
            MotionModel::Proportional { k_translation, k_rotation, floor_translation_m, floor_rotation_rad } => {
                c.non_negative("k_translation", k_translation);
                c.non_negative("k_rotation", k_rotation);
                c.non_negative("floor_translation_m", floor_translation_m);
                c.non_negative("floor_rotation_rad", floor_rotation_rad);
            }
        }
        c.finish()
    }

    /// The report's sentence on this model, with its parameter values.
    pub fn describe(&self) -> String {
        match self {
            MotionModel::Proportional { k_translation, k_rotation, floor_translation_m, floor_rotation_rad } => format!(
                "Motion model of EKF-SLAM, FastSLAM 2.0 and FastSLAM on point worlds: noise on the odometry increment, σ = {k_translation}·|translation| + {floor_translation_m} m per axis and {k_rotation}·|rotation| + {floor_rotation_rad} rad per step."
            ),
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                format!("Motion model of EKF-SLAM, FastSLAM 2.0 and FastSLAM on point worlds: per-step world-frame pose noise σ = ({sigma_x_m} m, {sigma_y_m} m, {sigma_theta_rad} rad) ([FT] Eq. 7.18).")
            }
        }
    }

    /// The noise-free prediction x ⊕ u.
    pub fn predict(&self, pose: &Pose2, u: &Pose2) -> Pose2 {
        pose.compose(*u)
    }

    /// F = ∂(x ⊕ u)/∂x.
    pub fn jacobian(&self, pose: &Pose2, u: &Pose2) -> Matrix3<f64> {
        let (s, c) = pose.theta.sin_cos();
        Matrix3::new(1.0, 0.0, -s * u.x - c * u.y, 0.0, 1.0, c * u.x - s * u.y, 0.0, 0.0, 1.0)
    }

    /// Q: covariance of the predicted pose's error in the world frame.
    pub fn covariance(&self, pose: &Pose2, u: &Pose2) -> Matrix3<f64> {
        match *self {
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => Matrix3::from_diagonal(&nalgebra::Vector3::new(sigma_x_m.powi(2), sigma_y_m.powi(2), sigma_theta_rad.powi(2))),
            MotionModel::Proportional { .. } => {
                let [st, sr] = self.increment_sigmas(u);
                let (s, c) = pose.theta.sin_cos();
                // G_u = ∂(x ⊕ u)/∂u = diag(R(θ), 1); Q = G_u N G_uᵀ with N = diag(σt², σt², σr²)
                let g = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
                g * Matrix3::from_diagonal(&nalgebra::Vector3::new(st * st, st * st, sr * sr)) * g.transpose()
            }
        }
    }

    /// A sample of x' (three standard normals drawn, whatever the parameters).
    pub fn sample(&self, pose: &Pose2, u: &Pose2, rng: &mut ChaCha8Rng) -> Pose2 {
        let (z0, z1, z2): (f64, f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal), rng.sample(StandardNormal));
        match *self {
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                let q = pose.compose(*u);
                Pose2::new(q.x + sigma_x_m * z0, q.y + sigma_y_m * z1, wrap_angle(q.theta + sigma_theta_rad * z2))
            }
            MotionModel::Proportional { .. } => {
                let [st, sr] = self.increment_sigmas(u);
                pose.compose(Pose2::new(u.x + st * z0, u.y + st * z1, u.theta + sr * z2))
            }
        }
    }

    /// (σt, σr) of a proportional model for increment `u`.
    fn increment_sigmas(&self, u: &Pose2) -> [f64; 2] {
        match *self {
            MotionModel::Proportional { k_translation, k_rotation, floor_translation_m, floor_rotation_rad } => {
                [k_translation * u.x.hypot(u.y) + floor_translation_m, k_rotation * u.theta.abs() + floor_rotation_rad]
            }
            MotionModel::Pose { .. } => [0.0, 0.0],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn jacobian_matches_finite_differences() {
        let m = MotionModel::default();
        let u = Pose2::new(0.3, -0.05, 0.2);
        let pose = Pose2::new(1.0, 2.0, 2.9);
        let f = m.jacobian(&pose, &u);
        let eps = 1e-6;
        for k in 0..3 {
            let shift = |e: f64| {
                let mut p = [pose.x, pose.y, pose.theta];
                p[k] += e;
                m.predict(&Pose2::new(p[0], p[1], p[2]), &u)
            };
            let (a, b) = (shift(eps), shift(-eps));
            let num = [(a.x - b.x) / (2.0 * eps), (a.y - b.y) / (2.0 * eps), wrap_angle(a.theta - b.theta) / (2.0 * eps)];
            for r in 0..3 {
                assert!((f[(r, k)] - num[r]).abs() < 1e-6, "F[{r},{k}] = {} vs {}", f[(r, k)], num[r]);
            }
        }
    }

    #[test]
    fn describe_names_the_noise_parameters() {
        let proportional = MotionModel::Proportional { k_translation: 0.15, k_rotation: 0.25, floor_translation_m: 0.002, floor_rotation_rad: 0.003 }.describe();
        assert!(proportional.contains("σ = 0.15·|translation| + 0.002 m") && proportional.contains("0.25·|rotation| + 0.003 rad"), "{proportional}");
        let pose = MotionModel::Pose { sigma_x_m: 0.02, sigma_y_m: 0.01, sigma_theta_rad: 0.03 }.describe();
        assert!(pose.contains("σ = (0.02 m, 0.01 m, 0.03 rad)"), "{pose}");
    }

    #[test]
    fn samples_have_the_stated_covariance() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let pose = Pose2::new(0.0, 0.0, 0.7);
        let u = Pose2::new(0.5, 0.0, 0.1);
        for m in [MotionModel::default(), MotionModel::Pose { sigma_x_m: 0.02, sigma_y_m: 0.01, sigma_theta_rad: 0.03 }] {
            let mean = m.predict(&pose, &u);
            let n = 40_000;
            let mut cov = Matrix3::zeros();
            for _ in 0..n {
                let s = m.sample(&pose, &u, &mut rng);
                let e = nalgebra::Vector3::new(s.x - mean.x, s.y - mean.y, wrap_angle(s.theta - mean.theta));
                cov += e * e.transpose() / n as f64;
            }
            let q = m.covariance(&pose, &u);
            assert!((cov - q).abs().max() < 0.06 * q.abs().max(), "{m:?}\n{cov}\n{q}");
        }
    }
}
