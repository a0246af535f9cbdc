//! Motion models of the landmark filters that propagate a pose Gaussian (EKF-SLAM) or sample
//! from one (FastSLAM 2.0, and FastSLAM 1.0 on point-landmark worlds): odometry increment u
//! (body frame) and pose → predicted pose, its Jacobian F = ∂(x ⊕ u)/∂x, and the process noise
//! Q in the world frame, so that x' ~ N(x ⊕ u, Q) to first order.
//!
//! [FT]'s FastSLAM 1.0 on laser worlds keeps its own `[fastslam]` motion noise (Eq. 7.18).

use crate::config::{Checks, Violation};
use crate::geom::{Pose2, unicycle_increment, wrap_angle};
use nalgebra::{Matrix3, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// `[base.motion_model]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
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
    /// Noise on the driven arc, as the simulated `proportional` odometry draws it: the increment u
    /// is the arc of length d = v·Δt turning by φ = ω·Δt, and d and φ are perturbed by
    /// N(0, (k_translation·|d|)²) and N(0, (k_rotation·|φ|)²), then the exact arc is driven — so
    /// the error lies along the direction of travel and in heading only as far as the robot
    /// turns. In the filters, Q = G_u (J diag(σd², σφ²) Jᵀ + F) G_uᵀ with J = ∂u/∂(d, φ) the arc's
    /// Jacobian and F = diag(floor_translation_m², floor_translation_m², floor_rotation_rad²) a
    /// floor of independent body-frame noise. With k_translation = k_rotation = k it is the
    /// simulated noise (tested against the world's own samples) plus the floor.
    ///
    /// The simulation draws nothing off the arc: driving straight it moves neither sideways nor
    /// in heading. So the floor defaults to [`MATCHED_FLOOR`], which only keeps Q positive
    /// definite, and a floor above [`FLOOR_NEEDS_REASON`] — noise the filter is told of that the
    /// world does not draw — needs its reason stated in `floor_reason` (shown in the report).
    Proportional {
        /// Translation noise per metre driven [m/m].
        k_translation: f64,
        /// Rotation noise per radian turned [rad/rad].
        k_rotation: f64,
        /// Translation noise floor per step, per body axis [m].
        #[serde(default = "matched_floor")]
        floor_translation_m: f64,
        /// Rotation noise floor per step [rad].
        #[serde(default = "matched_floor")]
        floor_rotation_rad: f64,
        /// Why the floor exceeds what the world draws (required above [`FLOOR_NEEDS_REASON`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        floor_reason: Option<String>,
    },
}

/// The default floor of the `proportional` model, in m and rad per step: the simulated odometry
/// draws no noise off the driven arc, and 1e-7 keeps Q positive definite (and FastSLAM 2.0's
/// proposal invertible) without telling the filter of noise it never meets. A floor of 1e-4 per
/// step already made EKF-SLAM conservative in `cross-consistency` (mean NEES 1.84 against 3).
pub const MATCHED_FLOOR: f64 = 1e-7;

/// A floor above this (m or rad per step) is noise the world does not draw: it needs a reason.
/// Ten times [`MATCHED_FLOOR`]; below a micrometre or microradian per step any floor is numerical.
pub const FLOOR_NEEDS_REASON: f64 = 1e-6;

fn matched_floor() -> f64 {
    MATCHED_FLOOR
}

impl Default for MotionModel {
    /// Matches the default simulated odometry (10 % proportional noise, read as σ) with the
    /// matched floor.
    fn default() -> Self {
        MotionModel::Proportional {
            k_translation: 0.1,
            k_rotation: 0.1,
            floor_translation_m: MATCHED_FLOOR,
            floor_rotation_rad: MATCHED_FLOOR,
            floor_reason: None,
        }
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
            MotionModel::Proportional {
                k_translation,
                k_rotation,
                floor_translation_m,
                floor_rotation_rad,
                ref floor_reason,
            } => {
                c.non_negative("k_translation", k_translation);
                c.non_negative("k_rotation", k_rotation);
                c.non_negative("floor_translation_m", floor_translation_m);
                c.non_negative("floor_rotation_rad", floor_rotation_rad);
                let stated = floor_reason.as_deref().is_some_and(|r| !r.trim().is_empty());
                for (key, floor, unit) in [
                    ("floor_translation_m", floor_translation_m, "m"),
                    ("floor_rotation_rad", floor_rotation_rad, "rad"),
                ] {
                    c.require(stated || !(floor > FLOOR_NEEDS_REASON), key, || {
                        format!(
                            "{floor} {unit} per step is noise the simulated odometry never draws \
                             (it draws none off the driven arc): state why in `floor_reason`, or \
                             leave the floor out for the matched {MATCHED_FLOOR}"
                        )
                    });
                }
                if floor_reason.is_some() && !stated {
                    c.fail("floor_reason", "is empty: state why the floor exceeds the world's");
                }
            }
        }
        c.finish()
    }

    /// The report's sentence on this model, with its parameter values.
    pub fn describe(&self) -> String {
        match self {
            MotionModel::Proportional {
                k_translation,
                k_rotation,
                floor_translation_m,
                floor_rotation_rad,
                floor_reason,
            } => {
                let above = floor_translation_m.max(*floor_rotation_rad) > FLOOR_NEEDS_REASON;
                let why = match floor_reason {
                    Some(reason) if above => {
                        format!(", more than the world draws: {}", reason.trim())
                    }
                    _ => ", which only keeps Q positive definite: the simulated odometry draws no noise off the arc".into(),
                };
                format!(
                    "Motion model of EKF-SLAM, FastSLAM 2.0 and FastSLAM on point worlds: the simulated odometry's own noise on the driven arc, σ = {k_translation}·|arc length| and {k_rotation}·|turn| per step propagated through the arc, plus a floor of {floor_translation_m} m per axis and {floor_rotation_rad} rad per step{why}{}",
                    if why.ends_with('.') { "" } else { "." }
                )
            }
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                format!(
                    "Motion model of EKF-SLAM, FastSLAM 2.0 and FastSLAM on point worlds: per-step world-frame pose noise σ = ({sigma_x_m} m, {sigma_y_m} m, {sigma_theta_rad} rad) ([FT] Eq. 7.18)."
                )
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
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                Matrix3::from_diagonal(&nalgebra::Vector3::new(
                    sigma_x_m.powi(2),
                    sigma_y_m.powi(2),
                    sigma_theta_rad.powi(2),
                ))
            }
            MotionModel::Proportional {
                k_translation,
                k_rotation,
                floor_translation_m: ft,
                floor_rotation_rad: fr,
                ..
            } => {
                let (d, phi) = arc_of(u);
                let j = arc_jacobian(d, phi);
                let (sd, sp) = (k_translation * d.abs(), k_rotation * phi.abs());
                let n = j * nalgebra::Matrix2::new(sd * sd, 0.0, 0.0, sp * sp) * j.transpose()
                    + Matrix3::from_diagonal(&nalgebra::Vector3::new(ft * ft, ft * ft, fr * fr));
                let (s, c) = pose.theta.sin_cos();
                // G_u = ∂(x ⊕ u)/∂u = diag(R(θ), 1); Q = G_u N G_uᵀ
                let g = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
                g * n * g.transpose()
            }
        }
    }

    /// The between-factor of odometry increment `u` (see [`BetweenFactor`]).
    pub fn between_factor(&self, u: &Pose2) -> BetweenFactor {
        match *self {
            MotionModel::Pose { .. } => BetweenFactor {
                u: *u,
                arc: false,
                cov: self.covariance(&Pose2::IDENTITY, u),
                t: Matrix3::identity(),
            },
            MotionModel::Proportional {
                k_translation,
                k_rotation,
                floor_translation_m: ft,
                floor_rotation_rad: fr,
                ..
            } => {
                // the arc's noise moves (d, φ) alone; the floor is body-frame noise, mapped by T
                let (f, t) = arc_coordinates(u);
                let (sd, sp) = (k_translation * f[0].abs(), k_rotation * f[1].abs());
                let floor = Matrix3::from_diagonal(&Vector3::new(ft * ft, ft * ft, fr * fr));
                let cov = Matrix3::from_diagonal(&Vector3::new(sd * sd, sp * sp, 0.0))
                    + t * floor * t.transpose();
                BetweenFactor { u: *u, arc: true, cov, t }
            }
        }
    }

    /// A sample of x' (five standard normals drawn, whatever the parameters): the arc's length
    /// and turn perturbed and the exact arc driven, as the simulation does, plus the floor.
    pub fn sample(&self, pose: &Pose2, u: &Pose2, rng: &mut ChaCha8Rng) -> Pose2 {
        let z: [f64; 5] = std::array::from_fn(|_| rng.sample(StandardNormal));
        match *self {
            MotionModel::Pose { sigma_x_m, sigma_y_m, sigma_theta_rad } => {
                let q = pose.compose(*u);
                Pose2::new(
                    q.x + sigma_x_m * z[0],
                    q.y + sigma_y_m * z[1],
                    wrap_angle(q.theta + sigma_theta_rad * z[2]),
                )
            }
            MotionModel::Proportional {
                k_translation,
                k_rotation,
                floor_translation_m: ft,
                floor_rotation_rad: fr,
                ..
            } => {
                // the perturbed arc's change, applied to u (u itself when u is an arc: then this
                // is driving the perturbed arc, exactly as the simulation does)
                let (d, phi) = arc_of(u);
                let (a, b) = (
                    unicycle_increment(d, phi, 1.0),
                    unicycle_increment(
                        d + k_translation * d.abs() * z[0],
                        phi + k_rotation * phi.abs() * z[1],
                        1.0,
                    ),
                );
                pose.compose(Pose2::new(
                    u.x + b.x - a.x + ft * z[2],
                    u.y + b.y - a.y + ft * z[3],
                    u.theta + b.theta - a.theta + fr * z[4],
                ))
            }
        }
    }
}

/// The motion model as a smoother's between-factor on poses a and b for the odometry increment
/// u: a residual e(a, b) that is zero when b = a ⊕ u, with covariance `cov` — the same noise the
/// filters are told, in the coordinates where it is defined, so that the residual is exact where
/// the filters' Q is a linearisation.
#[derive(Debug, Clone, Copy)]
pub struct BetweenFactor {
    u: Pose2,
    /// `Pose`: e = b − (a ⊕ u) in the world frame. `Proportional`: e = f(b ⊖ a) − f(u) with
    /// f = (d, φ, ℓ) the increment's arc length, turn and offset from its arc ([`arc_coordinates`]).
    arc: bool,
    /// The covariance of e.
    pub cov: Matrix3<f64>,
    /// ∂e/∂u at b = a ⊕ u (maps body-frame noise on the increment to e).
    t: Matrix3<f64>,
}

impl BetweenFactor {
    /// The covariance of e with independent body-frame noise of σ = `s` (m, m, rad) added to
    /// the increment's.
    pub fn inflated_cov(&self, s: f64) -> Matrix3<f64> {
        self.cov + self.t * self.t.transpose() * (s * s)
    }

    /// e(a, b) and its Jacobians ∂e/∂a, ∂e/∂b (rows e, columns x, y, θ).
    pub fn residual(&self, a: &Pose2, b: &Pose2) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let (s, c) = a.theta.sin_cos();
        if !self.arc {
            let p = a.compose(self.u);
            let e = Vector3::new(b.x - p.x, b.y - p.y, wrap_angle(b.theta - p.theta));
            let u = self.u;
            let f = Matrix3::new(
                1.0,
                0.0,
                -s * u.x - c * u.y,
                0.0,
                1.0,
                c * u.x - s * u.y,
                0.0,
                0.0,
                1.0,
            );
            return (e, -f, Matrix3::identity());
        }
        // ũ = b ⊖ a and its Jacobians
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let rel = b.relative_to(*a);
        let ja = Matrix3::new(-c, -s, -s * dx + c * dy, s, -c, -c * dx - s * dy, 0.0, 0.0, -1.0);
        let jb = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
        let (f, t) = arc_coordinates(&rel);
        let (f0, _) = arc_coordinates(&self.u);
        let e = Vector3::new(f[0] - f0[0], wrap_angle(f[1] - f0[1]), f[2] - f0[2]);
        (e, t * ja, t * jb)
    }
}

/// The arc coordinates f(u) = (d, φ, ℓ) of a body-frame increment and T = ∂f/∂u: the arc through
/// the chord with turn φ ([`arc_of`]), and ℓ the increment's offset across the direction φ/2 that
/// the chord of an exact arc takes — zero on every arc, so noise on (d, φ) moves (d, φ) only.
pub fn arc_coordinates(u: &Pose2) -> (Vector3<f64>, Matrix3<f64>) {
    let phi = u.theta;
    let h = 0.5 * phi;
    let (s, c) = h.sin_cos();
    let chord = u.x * c + u.y * s;
    let offset = -u.x * s + u.y * c;
    // d = chord · g(h), g(h) = h / sin h
    let (g, dg) = if phi.abs() < SERIES_BELOW_RAD {
        (1.0 + h * h / 6.0, h / 3.0)
    } else {
        (h / s, (s - h * c) / (s * s))
    };
    let d_phi = 0.5 * offset * g + 0.5 * chord * dg;
    let t = Matrix3::new(c * g, s * g, d_phi, 0.0, 0.0, 1.0, -s, c, -0.5 * chord);
    (Vector3::new(chord * g, phi, offset), t)
}

/// The arc (d, φ) — length and turn, v·Δt and ω·Δt — that drives increment `u`: exact for an arc
/// ([`unicycle_increment`]); an increment off any arc (a real log's slip) gets the arc through
/// its chord's length and its turn.
fn arc_of(u: &Pose2) -> (f64, f64) {
    let phi = u.theta;
    let (s, c) = (0.5 * phi).sin_cos();
    let chord = u.x * c + u.y * s; // signed: the chord points along φ/2
    let d = if phi.abs() < SERIES_BELOW_RAD { chord } else { chord * (0.5 * phi) / s };
    (d, phi)
}

/// Below this turn [rad] the arc's functions use their Taylor series (no 0/0).
const SERIES_BELOW_RAD: f64 = 1e-4;

/// J = ∂u/∂(d, φ) of u = (d·sin φ/φ, d·(1 − cos φ)/φ, φ).
fn arc_jacobian(d: f64, phi: f64) -> nalgebra::Matrix3x2<f64> {
    let (a, b, da, db) = if phi.abs() < SERIES_BELOW_RAD {
        // sin φ/φ, (1 − cos φ)/φ and their derivatives, to O(φ³)
        (1.0 - phi * phi / 6.0, 0.5 * phi - phi.powi(3) / 24.0, -phi / 3.0, 0.5 - phi * phi / 8.0)
    } else {
        let (s, c) = phi.sin_cos();
        (s / phi, (1.0 - c) / phi, (phi * c - s) / (phi * phi), (phi * s - (1.0 - c)) / (phi * phi))
    };
    nalgebra::Matrix3x2::new(a, d * da, b, d * db, 0.0, 1.0)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::SeedableRng;

    /// Asserts that `jac` (rows: f's components; columns: x, y, θ) is ∂f/∂p at `at`, against central
    /// differences of step `eps`, within 1e-6.
    pub(crate) fn assert_jacobian(
        jac: Matrix3<f64>,
        at: Pose2,
        eps: f64,
        f: impl Fn(Pose2) -> Vector3<f64>,
    ) {
        for k in 0..3 {
            let shift = |e: f64| {
                let mut p = [at.x, at.y, at.theta];
                p[k] += e;
                f(Pose2::new(p[0], p[1], p[2]))
            };
            let num = (shift(eps) - shift(-eps)) / (2.0 * eps);
            for r in 0..3 {
                assert!(
                    (jac[(r, k)] - num[r]).abs() < 1e-6,
                    "[{r},{k}] = {} vs {} at {at:?}",
                    jac[(r, k)],
                    num[r]
                );
            }
        }
    }

    /// f(u) = (d, φ, ℓ) is (d, φ, 0) on every arc, and T = ∂f/∂u matches central differences,
    /// straight and turning.
    #[test]
    fn arc_coordinates_are_the_arc_and_their_jacobian_matches_finite_differences() {
        for (d, phi) in [(0.4, 0.3), (0.1, -1.2), (0.3, 2e-5), (-0.2, 0.05)] {
            let (f, _) = arc_coordinates(&unicycle_increment(d, phi, 1.0));
            assert!(
                (f[0] - d).abs() < 1e-12 && (f[1] - phi).abs() < 1e-15 && f[2].abs() < 1e-12,
                "({d}, {phi}): {f}"
            );
        }
        for u in
            [Pose2::new(0.4, 0.03, 0.3), Pose2::new(0.1, -0.02, -1.2), Pose2::new(0.3, 0.01, 2e-5)]
        {
            let (_, t) = arc_coordinates(&u);
            assert_jacobian(t, u, 1e-7, |v| arc_coordinates(&v).0);
        }
    }

    /// Both models' between-factors: zero at b = a ⊕ u, Jacobians matching central differences.
    #[test]
    fn between_factors_vanish_on_the_increment_and_their_jacobians_match_finite_differences() {
        let u = Pose2::new(0.3, 0.02, 0.25);
        let a = Pose2::new(1.0, -2.0, 3.0);
        let b = Pose2::new(1.1, -1.8, -3.1);
        for model in [
            MotionModel::default(),
            MotionModel::Pose { sigma_x_m: 0.1, sigma_y_m: 0.05, sigma_theta_rad: 0.01 },
        ] {
            let factor = model.between_factor(&u);
            let (e0, _, _) = factor.residual(&a, &a.compose(u));
            assert!(e0.norm() < 1e-12, "{model:?}: {e0}");
            let (_, ja, jb) = factor.residual(&a, &b);
            assert_jacobian(ja, a, 1e-7, |q| factor.residual(&q, &b).0);
            assert_jacobian(jb, b, 1e-7, |q| factor.residual(&a, &q).0);
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let m = MotionModel::default();
        let u = Pose2::new(0.3, -0.05, 0.2);
        let pose = Pose2::new(1.0, 2.0, 2.9);
        // θ stays within (−π, π] here (2.9 + 0.2 ± 1e-6), so no difference needs wrapping
        assert_jacobian(m.jacobian(&pose, &u), pose, 1e-6, |q| {
            let p = m.predict(&q, &u);
            Vector3::new(p.x, p.y, p.theta)
        });
    }

    /// A floor the world does not draw is refused without a reason, and accepted with one; the
    /// default is the matched floor, read from a section that leaves it out.
    #[test]
    fn a_floor_above_the_worlds_needs_a_stated_reason() {
        let section = |floors: &str| {
            toml::from_str::<MotionModel>(&format!(
                "model = \"proportional\"\nk_translation = 0.1\nk_rotation = 0.1\n{floors}"
            ))
            .unwrap()
        };
        assert_eq!(section(""), MotionModel::default());
        assert!(section("").validate().is_empty());
        let keys = |m: MotionModel| m.validate().into_iter().map(|v| v.key).collect::<Vec<_>>();
        assert_eq!(
            keys(section("floor_translation_m = 0.001\nfloor_rotation_rad = 0.001")),
            ["floor_translation_m", "floor_rotation_rad"]
        );
        assert_eq!(keys(section("floor_rotation_rad = 0.000002")), ["floor_rotation_rad"]);
        assert!(keys(section("floor_translation_m = 0.000001")).is_empty(), "at the threshold");
        assert!(
            keys(section("floor_translation_m = 0.001\nfloor_reason = \"real odometry slips\""))
                .is_empty()
        );
        assert_eq!(
            keys(section("floor_translation_m = 0.001\nfloor_reason = \" \"")),
            ["floor_translation_m", "floor_reason"]
        );
        // a section without a reason serialises as before: its run hashes do not change
        let text = toml::to_string(&section("floor_translation_m = 0.001")).unwrap();
        assert!(!text.contains("floor_reason"), "{text}");
    }

    #[test]
    fn describe_names_the_noise_parameters() {
        let proportional = MotionModel::Proportional {
            k_translation: 0.15,
            k_rotation: 0.25,
            floor_translation_m: 0.002,
            floor_rotation_rad: 0.003,
            floor_reason: Some("the robot slips.".into()),
        }
        .describe();
        assert!(
            proportional.contains("σ = 0.15·|arc length| and 0.25·|turn|")
                && proportional.contains(
                    "floor of 0.002 m per axis and 0.003 rad per step, more than the world \
                     draws: the robot slips."
                ),
            "{proportional}"
        );
        let matched = MotionModel::default().describe();
        assert!(
            matched.contains(
                "floor of 0.0000001 m per axis and 0.0000001 rad per step, which only keeps Q \
                 positive definite"
            ),
            "{matched}"
        );
        let pose = MotionModel::Pose { sigma_x_m: 0.02, sigma_y_m: 0.01, sigma_theta_rad: 0.03 }
            .describe();
        assert!(pose.contains("σ = (0.02 m, 0.01 m, 0.03 rad)"), "{pose}");
    }

    #[test]
    fn samples_have_the_stated_covariance() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let pose = Pose2::new(0.0, 0.0, 0.7);
        let u = Pose2::new(0.5, 0.0, 0.1);
        for m in [
            MotionModel::default(),
            MotionModel::Pose { sigma_x_m: 0.02, sigma_y_m: 0.01, sigma_theta_rad: 0.03 },
        ] {
            let mean = m.predict(&pose, &u);
            let n = 40_000;
            let mut cov = Matrix3::zeros();
            for _ in 0..n {
                let s = m.sample(&pose, &u, &mut rng);
                let e = nalgebra::Vector3::new(
                    s.x - mean.x,
                    s.y - mean.y,
                    wrap_angle(s.theta - mean.theta),
                );
                cov += e * e.transpose() / n as f64;
            }
            let q = m.covariance(&pose, &u);
            assert!((cov - q).abs().max() < 0.06 * q.abs().max(), "{m:?}\n{cov}\n{q}");
        }
    }

    /// The filter's Q for the `proportional` model equals the covariance of the simulated
    /// odometry's own increments (the world's samples, not the filter's): v and ω perturbed by
    /// k·|v|, k·|ω|, then the exact arc — driving straight, turning on the spot and along an arc.
    #[test]
    fn the_proportional_model_matches_the_simulated_odometry() {
        use crate::world::odometry::{OdometryNoise, Spread};
        let k = 0.1;
        let world = OdometryNoise::Proportional { k, k_is: Spread::Std };
        let filter = MotionModel::Proportional {
            k_translation: k,
            k_rotation: k,
            floor_translation_m: 0.0,
            floor_rotation_rad: 0.0,
            floor_reason: None,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for (v, w) in [(1.0, 0.0), (0.0, 0.5), (1.0, 0.8), (0.5, -2.0)] {
            let n = 40_000;
            let samples = world.measure(Pose2::IDENTITY, &vec![(v, w); n], 0.1, &mut rng);
            let u = unicycle_increment(v, w, 0.1);
            let mut cov = Matrix3::zeros();
            for s in &samples {
                let e = nalgebra::Vector3::new(s.x - u.x, s.y - u.y, wrap_angle(s.theta - u.theta));
                cov += e * e.transpose() / n as f64;
            }
            let q = filter.covariance(&Pose2::IDENTITY, &u);
            assert!(
                (cov - q).abs().max() < 0.05 * q.abs().max(),
                "(v, ω) = ({v}, {w}):\nworld\n{cov}\nfilter\n{q}"
            );
        }
    }

    #[test]
    fn the_arc_is_recovered_and_differentiated() {
        for (d, phi) in [(0.3, 0.0), (0.3, 1e-6), (0.2, 0.4), (-0.1, -0.7), (0.0, 0.5)] {
            let (d2, phi2) = arc_of(&unicycle_increment(d, phi, 1.0));
            assert!(
                (d2 - d).abs() < 1e-12 && (phi2 - phi).abs() < 1e-12,
                "({d}, {phi}) → ({d2}, {phi2})"
            );
            let j = arc_jacobian(d, phi);
            let eps = 1e-6;
            for (col, (a, b)) in
                [((d + eps, phi), (d - eps, phi)), ((d, phi + eps), (d, phi - eps))]
                    .into_iter()
                    .enumerate()
            {
                let (ua, ub) =
                    (unicycle_increment(a.0, a.1, 1.0), unicycle_increment(b.0, b.1, 1.0));
                let num = [
                    (ua.x - ub.x) / (2.0 * eps),
                    (ua.y - ub.y) / (2.0 * eps),
                    (ua.theta - ub.theta) / (2.0 * eps),
                ];
                for r in 0..3 {
                    assert!(
                        (j[(r, col)] - num[r]).abs() < 1e-6,
                        "J[{r},{col}] at ({d}, {phi}): {} vs {}",
                        j[(r, col)],
                        num[r]
                    );
                }
            }
        }
    }
}
