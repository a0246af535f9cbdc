//! Odometry: true controls → noisy body-frame pose increments, under one of the noise models a
//! spec selects. Increments are the common currency of every dataset: the velocity model's
//! (v, ω, Δt) is the arc increment `unicycle_increment(v, ω, Δt)`, so a filter composing
//! increments reproduces [FT] Eq. 7.18 exactly.

use crate::config::{Checks, Violation};
use crate::geom::{Pose2, unicycle_increment};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Whether a noise parameter is a standard deviation or a variance. [FT] is ambiguous about
/// both its odometry noise ("variance equal to 10 % of the measured velocity", written
/// N(0, 0.1·v)) and its motion covariance, so specs say which reading they use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Spread {
    /// A standard deviation σ.
    Std,
    /// A variance σ².
    Variance,
}

/// `[base.odometry]`: the odometry error model of the simulated logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum OdometryNoise {
    /// Perfect odometry. (A struct variant, so that stray keys are rejected like everywhere
    /// else: serde skips the rest of the table for a unit variant.)
    None {},
    /// [FT] §3.2: v += N(0, s(k, |v|)), ω += N(0, s(k, |ω|)) per step, s given by `k_is`.
    Proportional {
        /// k: noise scale (dimensionless).
        k: f64,
        /// Whether k·|v| is a standard deviation or a variance.
        k_is: Spread,
    },
    /// Additive per-step pose noise diag(σx², σy², σθ²) in the world frame ([FT] Eq. 7.18):
    /// o_{k+1} = o_k ⊕ Δ_true + ε.
    Pose {
        /// σx² [m²] per step.
        var_x_m2: f64,
        /// σy² [m²] per step.
        var_y_m2: f64,
        /// σθ² [rad²] per step.
        var_theta_rad2: f64,
    },
    /// Proportional noise (σ = k·|v|, k·|ω|) plus the systematic errors [EV] §4.1 measured on its
    /// robot: a heading drift while driving (the odometry misses `heading_bias_deg_per_m` of
    /// rotation per metre driven: ω̃ = ω − b·v) and wheel slip in turns (phantom forward motion
    /// of `turn_slip_m_per_rad` per radian turned: ṽ = v + s·|ω|).
    Systematic {
        /// k: random noise scale, read as a standard deviation.
        k: f64,
        /// b [deg/m]: rotation the odometry misses per metre driven ([EV]: ≈ 6°/m uncorrected).
        heading_bias_deg_per_m: f64,
        /// s [m/rad]: phantom translation per radian turned ([EV] Exp. 2: ≈ 10 cm per 90° turn).
        turn_slip_m_per_rad: f64,
    },
}

impl Default for OdometryNoise {
    /// [FT]'s synthetic logs: 10 % proportional noise, read as a standard deviation.
    fn default() -> Self {
        OdometryNoise::Proportional { k: 0.1, k_is: Spread::Std }
    }
}

impl OdometryNoise {
    /// The report's sentence on the simulated odometry noise, with its parameter values.
    pub fn describe(&self) -> String {
        match self {
            OdometryNoise::None {} => "Odometry: noise-free.".to_string(),
            OdometryNoise::Proportional { k, k_is } => format!(
                "Odometry ([FT] §3.2 \"proportional\" model): v += N(0, s(|v|)), ω += N(0, s(|ω|)) each step, with {} (k = {k} in the base configuration). Odometry is passed to algorithms as body-frame pose increments (the velocity model's arc).",
                match k_is {
                    Spread::Std => "s = k·|·| read as a standard deviation",
                    Spread::Variance => "s = k·|·| read as a variance",
                }
            ),
            OdometryNoise::Pose { var_x_m2, var_y_m2, var_theta_rad2 } => {
                format!(
                    "Odometry: additive per-step pose noise diag(σx², σy², σθ²) = diag({var_x_m2}, {var_y_m2}, {var_theta_rad2}) in the world frame ([FT] Eq. 7.18)."
                )
            }
            OdometryNoise::Systematic { k, heading_bias_deg_per_m, turn_slip_m_per_rad } => {
                format!(
                    "Odometry: v and ω perturbed by N(0, (k·|·|)²) with k = {k} (σ), plus [EV]'s systematic errors: {heading_bias_deg_per_m}°/m of heading drift missed while driving and {turn_slip_m_per_rad} m of phantom forward motion per radian turned (wheel slip)."
                )
            }
        }
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        match *self {
            OdometryNoise::None {} => {}
            OdometryNoise::Proportional { k, .. } => c.non_negative("k", k),
            OdometryNoise::Pose { var_x_m2, var_y_m2, var_theta_rad2 } => {
                c.non_negative("var_x_m2", var_x_m2);
                c.non_negative("var_y_m2", var_y_m2);
                c.non_negative("var_theta_rad2", var_theta_rad2);
            }
            OdometryNoise::Systematic { k, heading_bias_deg_per_m, turn_slip_m_per_rad } => {
                c.non_negative("k", k);
                c.finite("heading_bias_deg_per_m", heading_bias_deg_per_m);
                c.non_negative("turn_slip_m_per_rad", turn_slip_m_per_rad);
            }
        }
        c.finish()
    }

    /// Noisy body-frame increments for the true `controls` (v, ω) applied from `start`.
    /// Draws a fixed number of standard normals per step (2 proportional, 3 pose), whatever the
    /// parameter values, so every sweep point sees the same underlying draws.
    pub fn measure(
        &self,
        start: Pose2,
        controls: &[(f64, f64)],
        dt_s: f64,
        rng: &mut ChaCha8Rng,
    ) -> Vec<Pose2> {
        match *self {
            OdometryNoise::None {} => {
                controls.iter().map(|&(v, w)| unicycle_increment(v, w, dt_s)).collect()
            }
            OdometryNoise::Proportional { k, k_is } => {
                let sigma = |x: f64| match k_is {
                    Spread::Std => k * x.abs(),
                    Spread::Variance => (k * x.abs()).sqrt(),
                };
                controls
                    .iter()
                    .map(|&(v, w)| {
                        let zv: f64 = rng.sample(StandardNormal);
                        let zw: f64 = rng.sample(StandardNormal);
                        unicycle_increment(v + sigma(v) * zv, w + sigma(w) * zw, dt_s)
                    })
                    .collect()
            }
            OdometryNoise::Systematic { k, heading_bias_deg_per_m, turn_slip_m_per_rad } => {
                controls
                    .iter()
                    .map(|&(v, w)| {
                        let zv: f64 = rng.sample(StandardNormal);
                        let zw: f64 = rng.sample(StandardNormal);
                        let v_meas = v + turn_slip_m_per_rad * w.abs() + k * v.abs() * zv;
                        let w_meas = w - heading_bias_deg_per_m.to_radians() * v + k * w.abs() * zw;
                        unicycle_increment(v_meas, w_meas, dt_s)
                    })
                    .collect()
            }
            OdometryNoise::Pose { var_x_m2, var_y_m2, var_theta_rad2 } => {
                let (sx, sy, st) = (var_x_m2.sqrt(), var_y_m2.sqrt(), var_theta_rad2.sqrt());
                let mut odom = start;
                controls
                    .iter()
                    .map(|&(v, w)| {
                        let (zx, zy, zt): (f64, f64, f64) = (
                            rng.sample(StandardNormal),
                            rng.sample(StandardNormal),
                            rng.sample(StandardNormal),
                        );
                        let mut next = odom.compose(unicycle_increment(v, w, dt_s));
                        next = Pose2::new(
                            next.x + sx * zx,
                            next.y + sy * zy,
                            crate::geom::wrap_angle(next.theta + st * zt),
                        );
                        let delta = next.relative_to(odom);
                        odom = next;
                        delta
                    })
                    .collect()
            }
        }
    }
}

impl OdometryNoise {
    /// Noisy copies of exact body-frame `increments` (a log whose odometry is its ground truth,
    /// e.g. the Intel lab's corrected poses): each increment (dx, dy, dθ) of length d gets
    /// independent errors of σ = s(k, d) on dx and dy and s(k, |dθ|) on dθ (`proportional`;
    /// `systematic` adds its heading bias b·d and its slip s·|dθ| along x), or the `pose` model's
    /// σx, σy, σθ. Three normals per increment, whatever the model.
    pub fn perturb(&self, increments: &[Pose2], rng: &mut ChaCha8Rng) -> Vec<Pose2> {
        increments
            .iter()
            .map(|d| {
                let z: [f64; 3] = [
                    rng.sample(StandardNormal),
                    rng.sample(StandardNormal),
                    rng.sample(StandardNormal),
                ];
                let length = d.x.hypot(d.y);
                let (sx, sy, st, bias_x, bias_t) = match *self {
                    OdometryNoise::None {} => (0.0, 0.0, 0.0, 0.0, 0.0),
                    OdometryNoise::Proportional { k, k_is } => {
                        let s = |x: f64| match k_is {
                            Spread::Std => k * x,
                            Spread::Variance => (k * x).sqrt(),
                        };
                        (s(length), s(length), s(d.theta.abs()), 0.0, 0.0)
                    }
                    OdometryNoise::Pose { var_x_m2, var_y_m2, var_theta_rad2 } => {
                        (var_x_m2.sqrt(), var_y_m2.sqrt(), var_theta_rad2.sqrt(), 0.0, 0.0)
                    }
                    OdometryNoise::Systematic {
                        k,
                        heading_bias_deg_per_m,
                        turn_slip_m_per_rad,
                    } => (
                        k * length,
                        k * length,
                        k * d.theta.abs(),
                        turn_slip_m_per_rad * d.theta.abs(),
                        -heading_bias_deg_per_m.to_radians() * length,
                    ),
                };
                Pose2::new(
                    d.x + bias_x + sx * z[0],
                    d.y + sy * z[1],
                    crate::geom::wrap_angle(d.theta + bias_t + st * z[2]),
                )
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {

    #[test]
    fn perturb_scales_with_the_increment_and_keeps_exact_without_noise() {
        let increments = vec![Pose2::new(0.5, 0.0, 0.2); 20_000];
        assert_eq!(OdometryNoise::None {}.perturb(&increments, &mut rng()), increments);
        let noisy = OdometryNoise::Proportional { k: 0.1, k_is: Spread::Std }
            .perturb(&increments, &mut rng());
        let std = |f: &dyn Fn(&Pose2) -> f64| {
            let m = noisy.iter().map(f).sum::<f64>() / noisy.len() as f64;
            (noisy.iter().map(|p| (f(p) - m).powi(2)).sum::<f64>() / (noisy.len() - 1) as f64)
                .sqrt()
        };
        assert!((std(&|p| p.x) - 0.05).abs() < 0.002 && (std(&|p| p.y) - 0.05).abs() < 0.002);
        assert!((std(&|p| p.theta) - 0.02).abs() < 0.001);
    }
    use super::*;
    use rand::SeedableRng;

    fn rng() -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(7)
    }

    #[test]
    fn no_noise_reproduces_truth() {
        let controls = vec![(0.5, 0.1); 50];
        let inc = OdometryNoise::None {}.measure(Pose2::IDENTITY, &controls, 0.1, &mut rng());
        assert_eq!(inc[0], unicycle_increment(0.5, 0.1, 0.1));
    }

    #[test]
    fn proportional_std_has_the_stated_spread() {
        // Straight driving: dx ≈ (v + σ z)·Δt, so the sample std of dx/Δt estimates k·v.
        let n = 20_000;
        let controls = vec![(0.5, 0.0); n];
        let noise = OdometryNoise::Proportional { k: 0.1, k_is: Spread::Std };
        let inc = noise.measure(Pose2::IDENTITY, &controls, 0.1, &mut rng());
        let v: Vec<f64> = inc.iter().map(|d| d.x.hypot(d.y) / 0.1).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        assert!((mean - 0.5).abs() < 0.002, "{mean}");
        assert!((std - 0.05).abs() < 0.002, "{std}"); // k·v = 0.05 m/s
        // ω = 0 ⇒ no heading noise under the proportional model
        assert!(inc.iter().all(|d| d.theta == 0.0));
    }

    #[test]
    fn proportional_variance_reading_uses_square_root() {
        let n = 20_000;
        let controls = vec![(0.5, 0.0); n];
        let noise = OdometryNoise::Proportional { k: 0.1, k_is: Spread::Variance };
        let inc = noise.measure(Pose2::IDENTITY, &controls, 0.1, &mut rng());
        let v: Vec<f64> = inc.iter().map(|d| d.x / 0.1).collect();
        let mean = v.iter().sum::<f64>() / n as f64;
        let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        assert!((var - 0.05).abs() < 0.002, "{var}"); // σ² = k·v = 0.05 (m/s)²
    }

    #[test]
    fn pose_noise_has_the_stated_covariance() {
        let n = 20_000;
        let controls = vec![(0.0, 0.0); n];
        let noise =
            OdometryNoise::Pose { var_x_m2: 0.01, var_y_m2: 0.0025, var_theta_rad2: 0.0004 };
        // standing still at θ = 0: world-frame noise equals the increments
        let inc = noise.measure(Pose2::IDENTITY, &controls, 0.1, &mut rng());
        let var =
            |f: &dyn Fn(&Pose2) -> f64| inc.iter().map(|d| f(d).powi(2)).sum::<f64>() / n as f64;
        // the first increment is relative to θ = 0, later ones to a drifting heading: use θ stats
        let vt = var(&|d| d.theta);
        assert!((vt - 0.0004).abs() < 0.00003, "{vt}");
        let pos = inc.iter().map(|d| d.x * d.x + d.y * d.y).sum::<f64>() / n as f64;
        assert!((pos - 0.0125).abs() < 0.0008, "{pos}"); // σx² + σy², rotation-invariant
    }

    #[test]
    fn none_rejects_stray_keys() {
        // regression: `model = "none"` (a unit variant) silently accepted any other key
        let err = toml::from_str::<OdometryNoise>("model = \"none\"\nk = 0.5\n").unwrap_err();
        assert!(err.message().contains("unknown field `k`"), "{}", err.message());
        assert_eq!(
            toml::from_str::<OdometryNoise>("model = \"none\"\n").unwrap(),
            OdometryNoise::None {}
        );
    }

    #[test]
    fn common_random_numbers_across_noise_levels() {
        // The same seed at two noise levels draws the same z: the velocity error scales exactly.
        let controls = vec![(0.4, 0.0); 100];
        let a = OdometryNoise::Proportional { k: 0.05, k_is: Spread::Std }.measure(
            Pose2::IDENTITY,
            &controls,
            0.1,
            &mut rng(),
        );
        let b = OdometryNoise::Proportional { k: 0.2, k_is: Spread::Std }.measure(
            Pose2::IDENTITY,
            &controls,
            0.1,
            &mut rng(),
        );
        for (da, db) in a.iter().zip(&b) {
            let ea = da.x / 0.1 - 0.4;
            let eb = db.x / 0.1 - 0.4;
            assert!((eb - 4.0 * ea).abs() < 1e-12);
        }
    }

    #[test]
    fn systematic_errors_bias_heading_and_add_phantom_motion() {
        // 1 m straight at 1 m/s, then a quarter turn in place, noise-free apart from the biases
        let noise = OdometryNoise::Systematic {
            k: 0.0,
            heading_bias_deg_per_m: 6.0,
            turn_slip_m_per_rad: 0.1 / std::f64::consts::FRAC_PI_2,
        };
        let mut controls = vec![(1.0, 0.0); 10];
        controls.extend(vec![(0.0, std::f64::consts::FRAC_PI_2); 10]);
        let inc = noise.measure(Pose2::IDENTITY, &controls, 0.1, &mut rng());
        let end_straight = inc[..10].iter().fold(Pose2::IDENTITY, |p, d| p.compose(*d));
        assert!((end_straight.theta.to_degrees() + 6.0).abs() < 1e-9, "6° missed over 1 m");
        let turn = inc[10..].iter().fold(Pose2::IDENTITY, |p, d| p.compose(*d));
        let moved = turn.x.hypot(turn.y);
        // 10 cm of phantom travel along the quarter arc: chord = 2·r·sin(π/4), r = 0.1/(π/2)
        let r = 0.1 / std::f64::consts::FRAC_PI_2;
        assert!((moved - 2.0 * r * std::f64::consts::FRAC_PI_4.sin()).abs() < 1e-9, "{moved}");
    }

    #[test]
    fn describe_names_the_model_and_its_parameters() {
        let s = OdometryNoise::Proportional { k: 0.2, k_is: Spread::Variance }.describe();
        assert!(s.contains("read as a variance (k = 0.2 in the base configuration)"), "{s}");
        let s = OdometryNoise::Pose { var_x_m2: 0.01, var_y_m2: 0.02, var_theta_rad2: 0.003 }
            .describe();
        assert!(s.contains("diag(0.01, 0.02, 0.003)"), "{s}");
        let s = OdometryNoise::Systematic {
            k: 0.05,
            heading_bias_deg_per_m: 6.0,
            turn_slip_m_per_rad: 0.064,
        }
        .describe();
        assert!(
            s.contains("k = 0.05 (σ)")
                && s.contains("6°/m of heading drift")
                && s.contains("0.064 m of phantom"),
            "{s}"
        );
        assert_eq!(OdometryNoise::None {}.describe(), "Odometry: noise-free.");
    }
}
