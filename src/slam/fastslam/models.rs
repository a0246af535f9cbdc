//! Observation models of [FT] §7.4.2 — landmark (world frame) and robot pose → predicted
//! measurement and its Jacobian with respect to the landmark — with the corrected Jacobian and
//! inverse models of the thesis's errata (§9 items 2–4).
//!
//! - Line (ρ, θ) observed as (ρ', θ') in the robot frame (Eq. 7.25).
//! - Corner (x, y) observed as range and bearing (Eq. 7.21).
//!
//! Measurements of lines use the normalised form ρ' ≥ 0 (the extractor's output), so a prediction
//! with ρ' < 0 is flipped to (−ρ', θ' + π), and its Jacobian with it.

use crate::geom::{Line, Pose2, wrap_angle};
use nalgebra::{Matrix2, Matrix2x3, Vector2};
use std::f64::consts::PI;

/// A predicted measurement ẑ and H = ∂ẑ/∂m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    pub z: Vector2<f64>,
    pub h: Matrix2<f64>,
}

/// The kind of landmark, which fixes its observation model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// m = (ρ, θ) of an infinite line, z = (ρ', θ').
    Line,
    /// m = (x, y) of a corner, z = (range, bearing).
    Point,
}

impl Model {
    pub fn predict(self, m: &Vector2<f64>, pose: &Pose2) -> Prediction {
        match self {
            Model::Line => line_predict(m, pose),
            Model::Point => point_predict(m, pose),
        }
    }

    /// The landmark that would produce `z` from `pose` (the inverse observation model).
    pub fn inverse(self, z: &Vector2<f64>, pose: &Pose2) -> Vector2<f64> {
        match self {
            Model::Line => line_inverse(z, pose),
            Model::Point => point_inverse(z, pose),
        }
    }

    /// z − ẑ with the angular component wrapped to (−π, π].
    ///
    /// Lines: a measured line has two parameterisations, (ρ, θ) and (−ρ, θ + π). Near ρ' = 0 the
    /// measurement and a prediction from a slightly different pose fall on opposite sides of the
    /// robot, and their normalised forms differ by π in angle although the lines are centimetres
    /// apart. The innovation is therefore taken against the measurement's representation on the
    /// prediction's side (the one within π/2 of ẑ's angle), so that it is the signed difference
    /// the prediction's Jacobian (flipped with ẑ) linearises.
    pub fn innovation(self, z: &Vector2<f64>, predicted: &Vector2<f64>) -> Vector2<f64> {
        let nu = Vector2::new(z[0] - predicted[0], wrap_angle(z[1] - predicted[1]));
        if self == Model::Line && nu[1].abs() > PI / 2.0 {
            return Vector2::new(-z[0] - predicted[0], wrap_angle(z[1] + PI - predicted[1]));
        }
        nu
    }

    /// Brings a landmark mean back to its canonical form after an update, with the covariance
    /// transformed accordingly (lines: ρ ≥ 0, θ ∈ (−π, π]; points need nothing).
    pub fn normalise(self, mean: &mut Vector2<f64>, cov: &mut Matrix2<f64>) {
        if self == Model::Line {
            if mean[0] < 0.0 {
                // (ρ, θ) → (−ρ, θ + π): Jacobian diag(−1, 1) flips the cross-covariance.
                *mean = Vector2::new(-mean[0], wrap_angle(mean[1] + PI));
                cov[(0, 1)] = -cov[(0, 1)];
                cov[(1, 0)] = -cov[(1, 0)];
            } else {
                mean[1] = wrap_angle(mean[1]);
            }
        }
    }
}

/// [FT] Eq. 7.25: ρ' = ρ − (x cos θ + y sin θ), θ' = θ − θr; Jacobian with the errata's
/// correction (Eq. 7.26 printed its entries misplaced): H = [[1, x sin θ − y cos θ], [0, 1]].
pub fn line_predict(m: &Vector2<f64>, pose: &Pose2) -> Prediction {
    line_predict_trig(m, m[1].sin_cos(), pose)
}

/// [`line_predict`] with (sin θ, cos θ) of the landmark supplied (filters cache them).
pub fn line_predict_trig(m: &Vector2<f64>, (s, c): (f64, f64), pose: &Pose2) -> Prediction {
    let rho = m[0] - (pose.x * c + pose.y * s); // Eq. (7.25)
    let theta = wrap_angle(m[1] - pose.theta);
    let d = pose.x * s - pose.y * c; // ∂ρ'/∂θ — corrected Eq. (7.26)
    if rho >= 0.0 {
        Prediction { z: Vector2::new(rho, theta), h: Matrix2::new(1.0, d, 0.0, 1.0) }
    } else {
        Prediction {
            z: Vector2::new(-rho, wrap_angle(theta + PI)),
            h: Matrix2::new(-1.0, -d, 0.0, 1.0),
        }
    }
}

/// Corrected Eq. 7.27: θ = θ' + θr, ρ = ρ' + x cos θ + y sin θ (the printed form is inconsistent
/// with Eq. 7.25), normalised.
pub fn line_inverse(z: &Vector2<f64>, pose: &Pose2) -> Vector2<f64> {
    let theta = z[1] + pose.theta;
    let rho = z[0] + pose.x * theta.cos() + pose.y * theta.sin();
    let l = Line::normalised(rho, theta);
    Vector2::new(l.rho, l.theta)
}

/// [FT] Eq. 7.21–7.22: r = √q, φ = atan2(Δy, Δx) − θ, H = [[Δx/√q, Δy/√q], [−Δy/q, Δx/q]].
pub fn point_predict(m: &Vector2<f64>, pose: &Pose2) -> Prediction {
    let (dx, dy) = (m[0] - pose.x, m[1] - pose.y);
    let q = dx * dx + dy * dy;
    let r = q.sqrt();
    Prediction {
        z: Vector2::new(r, wrap_angle(dy.atan2(dx) - pose.theta)),
        h: Matrix2::new(dx / r, dy / r, -dy / q, dx / q),
    } // Eq. (7.21), (7.22)
}

/// Corrected Eq. 7.23 (the printed m_y has `m_y0 sin θ` for `m_x0 sin θ`): the robot-frame point
/// (r cos φ, r sin φ) rotated by θ and moved to the robot's position.
pub fn point_inverse(z: &Vector2<f64>, pose: &Pose2) -> Vector2<f64> {
    let a = z[1] + pose.theta;
    Vector2::new(pose.x + z[0] * a.cos(), pose.y + z[0] * a.sin())
}

/// A predicted measurement with its Jacobians with respect to the robot pose (2 × 3) and the
/// landmark (2 × 2): what EKF-SLAM and FastSLAM 2.0 need beyond FastSLAM 1.0's `H = ∂ẑ/∂m`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FullPrediction {
    pub z: Vector2<f64>,
    /// ∂ẑ/∂(x, y, θ).
    pub h_pose: Matrix2x3<f64>,
    /// ∂ẑ/∂m.
    pub h_landmark: Matrix2<f64>,
}

/// The inverse observation model m = g⁻¹(pose, z) with its Jacobians, for initialising a
/// landmark in a joint state (EKF augmentation: P_mm = G_p P_pp G_pᵀ + G_z R G_zᵀ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FullInverse {
    pub m: Vector2<f64>,
    /// ∂m/∂(x, y, θ).
    pub g_pose: Matrix2x3<f64>,
    /// ∂m/∂z.
    pub g_z: Matrix2<f64>,
}

impl Model {
    /// ẑ with both Jacobians.
    pub fn predict_full(self, m: &Vector2<f64>, pose: &Pose2) -> FullPrediction {
        let p = self.predict(m, pose);
        let h_pose = match self {
            // r = √q: ∂r/∂(x, y, θ) = (−Δx/r, −Δy/r, 0); φ: (Δy/q, −Δx/q, −1)
            Model::Point => {
                let (dx, dy) = (m[0] - pose.x, m[1] - pose.y);
                let q = dx * dx + dy * dy;
                let r = q.sqrt();
                Matrix2x3::new(-dx / r, -dy / r, 0.0, dy / q, -dx / q, -1.0)
            }
            // ρ' = ρ − (x cos θ + y sin θ): (−cos θ, −sin θ, 0); θ' = θ − θr: (0, 0, −1); the
            // flipped form (ρ' < 0 → −ρ') negates the ρ row, as it does in H.
            Model::Line => {
                let (s, c) = m[1].sin_cos();
                let sign = p.h[(0, 0)]; // +1 unflipped, −1 flipped
                Matrix2x3::new(-c * sign, -s * sign, 0.0, 0.0, 0.0, -1.0)
            }
        };
        FullPrediction { z: p.z, h_pose, h_landmark: p.h }
    }

    /// m = g⁻¹(pose, z) with both Jacobians.
    pub fn inverse_full(self, z: &Vector2<f64>, pose: &Pose2) -> FullInverse {
        match self {
            Model::Point => {
                let a = z[1] + pose.theta;
                let (s, c) = a.sin_cos();
                let r = z[0];
                FullInverse {
                    m: Vector2::new(pose.x + r * c, pose.y + r * s),
                    g_pose: Matrix2x3::new(1.0, 0.0, -r * s, 0.0, 1.0, r * c),
                    g_z: Matrix2::new(c, -r * s, s, r * c),
                }
            }
            Model::Line => {
                // θ = θ' + θr, ρ = ρ' + x cos θ + y sin θ; then normalised (ρ < 0 → (−ρ, θ + π))
                let theta = z[1] + pose.theta;
                let (s, c) = theta.sin_cos();
                let rho = z[0] + pose.x * c + pose.y * s;
                let d = -pose.x * s + pose.y * c; // ∂ρ/∂θ
                let mut g_pose = Matrix2x3::new(c, s, d, 0.0, 0.0, 1.0);
                let mut g_z = Matrix2::new(1.0, d, 0.0, 1.0);
                if rho < 0.0 {
                    for j in 0..3 {
                        g_pose[(0, j)] = -g_pose[(0, j)];
                    }
                    g_z[(0, 0)] = -g_z[(0, 0)];
                    g_z[(0, 1)] = -g_z[(0, 1)];
                }
                let l = Line::normalised(rho, theta);
                FullInverse { m: Vector2::new(l.rho, l.theta), g_pose, g_z }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central finite differences of ẑ with respect to the landmark.
    fn numeric_jacobian(model: Model, m: &Vector2<f64>, pose: &Pose2) -> Matrix2<f64> {
        let eps = 1e-6;
        let mut j = Matrix2::zeros();
        for k in 0..2 {
            let mut a = *m;
            let mut b = *m;
            a[k] += eps;
            b[k] -= eps;
            let za = model.predict(&a, pose).z;
            let zb = model.predict(&b, pose).z;
            j[(0, k)] = (za[0] - zb[0]) / (2.0 * eps);
            j[(1, k)] = wrap_angle(za[1] - zb[1]) / (2.0 * eps);
        }
        j
    }

    /// A wall's extension crossing the corridor ([FT]'s Bigloop2 x = 8): the robot just beyond
    /// the line sees it at ρ' = 0.10 m facing one way, a particle 15 cm off sees it facing the
    /// other way. The innovation is the 15 cm between them, not π in angle.
    #[test]
    fn the_innovation_crosses_the_flip_near_rho_zero() {
        let wall = Vector2::new(8.0, 0.0);
        let z = Model::Line.predict(&wall, &Pose2::new(8.10, 0.5, PI / 2.0)).z;
        let zhat = Model::Line.predict(&wall, &Pose2::new(7.95, 0.5, PI / 2.0)).z;
        assert!(
            (z[1] - zhat[1]).abs() > 3.0,
            "the two normalised forms face opposite ways: {z} vs {zhat}"
        );
        let nu = Model::Line.innovation(&z, &zhat);
        assert!((nu[0] + 0.15).abs() < 1e-9 && nu[1].abs() < 1e-9, "innovation {nu}");
        // and the linearisation agrees: ẑ + H Δm predicts the moved line on the same side
        let moved = Vector2::new(8.05, 0.01);
        let p = Model::Line.predict(&wall, &Pose2::new(7.95, 0.5, PI / 2.0));
        let linear = p.z + p.h * (moved - wall);
        let nu = Model::Line
            .innovation(&Model::Line.predict(&moved, &Pose2::new(7.95, 0.5, PI / 2.0)).z, &linear);
        assert!(nu.norm() < 1e-3, "{nu}");
        // far from ρ' = 0 nothing changes
        let (a, b) = (Vector2::new(3.0, 0.2), Vector2::new(2.9, 0.25));
        assert_eq!(
            Model::Line.innovation(&a, &b),
            Vector2::new(a[0] - b[0], wrap_angle(a[1] - b[1]))
        );
    }

    // Off every test line (on a line ρ' = 0 and the normalised form flips); the last two lie
    // beyond some lines, so the flipped branch (ρ' < 0) is exercised too.
    const POSES: [Pose2; 5] = [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(2.0, -0.5, 0.7),
        Pose2::new(-3.0, 4.0, -2.5),
        Pose2::new(10.0, 5.0, 3.0),
        Pose2::new(20.5, 12.0, 1.0),
    ];

    #[test]
    fn line_jacobian_matches_finite_differences() {
        let mut flipped = 0;
        for pose in POSES {
            // lines on both sides of the robot (so that both ρ' signs occur)
            for m in [
                Vector2::new(19.0, 0.0),
                Vector2::new(1.0, -PI / 2.0),
                Vector2::new(9.0, PI / 2.0),
                Vector2::new(4.0, 2.2),
                Vector2::new(0.5, -2.8),
            ] {
                let analytic = line_predict(&m, &pose).h;
                flipped += (analytic[(0, 0)] < 0.0) as usize;
                let numeric = numeric_jacobian(Model::Line, &m, &pose);
                assert!(
                    (analytic - numeric).abs().max() < 1e-6,
                    "pose {pose:?} m {m:?}\n{analytic}\n{numeric}"
                );
            }
        }
        assert!(flipped >= 2, "the ρ' < 0 branch must be tested");
    }

    #[test]
    fn point_jacobian_matches_finite_differences() {
        for pose in POSES {
            for m in [Vector2::new(19.0, 9.0), Vector2::new(-1.0, -1.0), Vector2::new(2.5, 3.5)] {
                let analytic = point_predict(&m, &pose).h;
                let numeric = numeric_jacobian(Model::Point, &m, &pose);
                assert!(
                    (analytic - numeric).abs().max() < 1e-6,
                    "pose {pose:?} m {m:?}\n{analytic}\n{numeric}"
                );
            }
        }
    }

    #[test]
    fn inverse_models_invert_the_forward_models() {
        for pose in POSES {
            for (model, m) in [
                (Model::Line, Vector2::new(19.0, 0.0)),
                (Model::Line, Vector2::new(4.0, 2.2)),
                (Model::Point, Vector2::new(2.5, 3.5)),
            ] {
                let z = model.predict(&m, &pose).z;
                let back = model.inverse(&z, &pose);
                assert!(
                    (back[0] - m[0]).abs() < 1e-9 && wrap_angle(back[1] - m[1]).abs() < 1e-9
                        || model == Model::Point && (back - m).norm() < 1e-9,
                    "{model:?} {pose:?}: {m:?} → {z:?} → {back:?}"
                );
            }
        }
    }

    #[test]
    fn the_printed_jacobian_would_have_been_wrong() {
        // regression guard for [FT] erratum 2: Eq. 7.26 as printed, [[0, x sinθ − y cosθ], [1, 0]]
        let (m, pose) = (Vector2::new(4.0_f64, 0.6), Pose2::new(1.0, 2.0, 0.3));
        let d = pose.x * m[1].sin() - pose.y * m[1].cos();
        let printed = Matrix2::new(0.0, d, 1.0, 0.0);
        assert!((printed - numeric_jacobian(Model::Line, &m, &pose)).abs().max() > 0.5);
    }

    #[test]
    fn a_line_seen_from_the_world_origin_is_itself() {
        let m = Vector2::new(9.0, PI / 2.0);
        let p = line_predict(&m, &Pose2::IDENTITY);
        assert!((p.z - m).norm() < 1e-12);
    }

    #[test]
    fn pose_and_inverse_jacobians_match_finite_differences() {
        let eps = 1e-6;
        for pose in POSES {
            for (model, m) in [
                (Model::Line, Vector2::new(19.0, 0.0)),
                (Model::Line, Vector2::new(4.0, 2.2)),
                (Model::Line, Vector2::new(0.5, -2.8)),
                (Model::Point, Vector2::new(2.5, 3.5)),
                (Model::Point, Vector2::new(-1.0, -1.0)),
            ] {
                let full = model.predict_full(&m, &pose);
                assert_eq!(full.h_landmark, model.predict(&m, &pose).h);
                for k in 0..3 {
                    let shift = |e: f64| {
                        let mut p = [pose.x, pose.y, pose.theta];
                        p[k] += e;
                        model.predict(&m, &Pose2::new(p[0], p[1], p[2])).z
                    };
                    let (a, b) = (shift(eps), shift(-eps));
                    let num = Vector2::new(
                        (a[0] - b[0]) / (2.0 * eps),
                        wrap_angle(a[1] - b[1]) / (2.0 * eps),
                    );
                    assert!(
                        (full.h_pose.column(k) - num).abs().max() < 1e-6,
                        "{model:?} {pose:?} {m:?} column {k}: {} vs {num}",
                        full.h_pose
                    );
                }
                // inverse: m = g⁻¹(pose, z) and its Jacobians
                let z = full.z;
                let inv = model.inverse_full(&z, &pose);
                assert!(
                    (inv.m[0] - m[0]).abs() < 1e-9 && wrap_angle(inv.m[1] - m[1]).abs() < 1e-9
                        || (inv.m - m).norm() < 1e-9
                );
                let diff = |a: Vector2<f64>, b: Vector2<f64>| match model {
                    Model::Line => Vector2::new(a[0] - b[0], wrap_angle(a[1] - b[1])),
                    Model::Point => a - b,
                };
                for k in 0..3 {
                    let shift = |e: f64| {
                        let mut p = [pose.x, pose.y, pose.theta];
                        p[k] += e;
                        model.inverse(&z, &Pose2::new(p[0], p[1], p[2]))
                    };
                    let num = diff(shift(eps), shift(-eps)) / (2.0 * eps);
                    assert!(
                        (inv.g_pose.column(k) - num).abs().max() < 1e-6,
                        "{model:?} g_pose column {k}: {} vs {num}",
                        inv.g_pose
                    );
                }
                for k in 0..2 {
                    let shift = |e: f64| {
                        let mut zz = z;
                        zz[k] += e;
                        model.inverse(&zz, &pose)
                    };
                    let num = diff(shift(eps), shift(-eps)) / (2.0 * eps);
                    assert!(
                        (inv.g_z.column(k) - num).abs().max() < 1e-6,
                        "{model:?} g_z column {k}: {} vs {num}",
                        inv.g_z
                    );
                }
            }
        }
    }
}
