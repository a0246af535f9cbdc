//! Group-sequential boundaries by alpha spending (issue 31 item 2): a study that looks at its
//! verdicts after each stage of replicates, and adds replicates only where a verdict is still
//! open, must not let the repeated looks inflate its error rates. The error each look may use is
//! fixed before the first look by a **spending function** α(t) of the information fraction
//! t = n / n_max [LD]; the boundary of look k is the z value c_k whose first crossing there has
//! probability α(t_k) − α(t_{k−1}) under the null hypothesis, found by the recursive numerical
//! integration of Armitage, McPherson and Rowe [AMR] over the joint normal law of the looks'
//! statistics (independent increments, corr(Z_j, Z_k) = √(t_j / t_k)).
//!
//! The boundaries are one-sided: each side of a verdict (confirm, refute) spends its own α, as
//! the fixed design's two-sided 95 % interval spends 2.5 % per side. They are applied to the
//! claims' t tests by their **nominal level** 1 − Φ(c_k) [JT §3.8]: a look rejects when the t
//! test's one-sided p is below it, i.e. when the two-sided 1 − 2·(1 − Φ(c_k)) interval clears the
//! bound. At one look (t = 1) both spending functions give c = Φ⁻¹(1 − α): the fixed design.
//!
//! - [LD] Lan & DeMets 1983, *Biometrika* 70:659–663 (spending functions; the O'Brien–Fleming
//!   type α(t) = 2 − 2Φ(z_{1−α/2} / √t) and the Pocock type α(t) = α ln(1 + (e − 1)t)).
//! - [AMR] Armitage, McPherson & Rowe 1969, *J. R. Statist. Soc. A* 132:235–244.
//! - [JT] Jennison & Turnbull, *Group Sequential Methods with Applications to Clinical Trials*,
//!   2000: §3.8 (t statistics at the nominal levels of the normal boundaries), §7.2 (spending
//!   functions), §19.2 (the numerical integration used here).
//!
//! Pure: no IO, no threads, no randomness.

use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, Normal};
use statrs::function::erf::erfc;

/// The spending function, stated in the spec before the first look.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Spending {
    /// Lan–DeMets O'Brien–Fleming type: spends almost nothing early, so the last look's level
    /// is close to the fixed design's.
    #[default]
    ObrienFleming,
    /// Lan–DeMets Pocock type: spends about evenly, stopping earlier at the cost of a stricter
    /// last look.
    Pocock,
}

impl Spending {
    pub fn as_str(self) -> &'static str {
        match self {
            Spending::ObrienFleming => "O'Brien–Fleming type (Lan–DeMets)",
            Spending::Pocock => "Pocock type (Lan–DeMets)",
        }
    }

    /// α(t): the error spent by information fraction t ∈ [0, 1] of a one-sided total α.
    pub fn spent(self, alpha: f64, t: f64) -> f64 {
        if t <= 0.0 {
            return 0.0;
        }
        let t = t.min(1.0);
        match self {
            Spending::ObrienFleming => 2.0 * upper_tail(z_quantile(1.0 - alpha / 2.0) / t.sqrt()),
            Spending::Pocock => alpha * (1.0 + (std::f64::consts::E - 1.0) * t).ln(),
        }
    }
}

/// 1 − Φ(x), accurate in the far tail.
pub fn upper_tail(x: f64) -> f64 {
    0.5 * erfc(x / std::f64::consts::SQRT_2)
}

/// Φ⁻¹(p).
pub fn z_quantile(p: f64) -> f64 {
    Normal::new(0.0, 1.0).map(|n| n.inverse_cdf(p)).unwrap_or(f64::NAN)
}

fn density(x: f64) -> f64 {
    (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Grid step of the numerical integration (on the z scale) and its lower end: the law of Z
/// below −10 carries less than 1e-23.
const STEP: f64 = 0.005;
const LOW: f64 = -10.0;

/// The continuation region (LOW, c) of one look as a Simpson grid: points and weights.
fn simpson_grid(c: f64) -> (Vec<f64>, Vec<f64>) {
    let intervals = (((c - LOW) / STEP).ceil() as usize).max(2).next_multiple_of(2);
    let h = (c - LOW) / intervals as f64;
    let z = (0..=intervals).map(|i| LOW + h * i as f64).collect();
    let w = (0..=intervals)
        .map(|i| {
            let k = if i == 0 || i == intervals {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            k * h / 3.0
        })
        .collect();
    (z, w)
}

/// One-sided upper boundaries c_1 … c_K (z scale) for information fractions `t` (increasing,
/// the last 1): the first crossing at look k has probability α(t_k) − α(t_{k−1}) when there is no
/// effect. A look that may spend nothing more (an increment below 1e-15) gets c = ∞.
pub fn boundaries(spending: Spending, alpha: f64, t: &[f64]) -> Vec<f64> {
    let mut c = Vec::with_capacity(t.len());
    // the sub-density of Z_k on the continuation region of looks 1…k, on its grid
    let mut grid: Option<(Vec<f64>, Vec<f64>, Vec<f64>)> = None; // (z, weights, f)
    let mut spent_before = 0.0;
    for (k, &tk) in t.iter().enumerate() {
        let spent = spending.spent(alpha, tk);
        let increment = spent - spent_before;
        spent_before = spent;
        // P(still going, Z_k ≥ x)
        let crossing = |x: f64| match &grid {
            None => upper_tail(x),
            Some((z, w, f)) => {
                let (tp, d) = (t[k - 1], tk - t[k - 1]);
                z.iter()
                    .zip(w)
                    .zip(f)
                    .map(|((zi, wi), fi)| {
                        wi * fi * upper_tail((x * tk.sqrt() - zi * tp.sqrt()) / d.sqrt())
                    })
                    .sum()
            }
        };
        let ck = if increment <= 1e-15 {
            f64::INFINITY
        } else {
            // crossing(x) falls with x: bisect
            let (mut lo, mut hi) = (-10.0, 40.0);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if crossing(mid) > increment {
                    lo = mid
                } else {
                    hi = mid
                }
                if hi - lo < 1e-12 {
                    break;
                }
            }
            0.5 * (lo + hi)
        };
        c.push(ck);
        if k + 1 == t.len() {
            break;
        }
        // the sub-density on (LOW, c_k) of Z_k, from that of Z_{k−1}
        let upper = if ck.is_finite() { ck } else { 12.0 };
        let (zk, wk) = simpson_grid(upper);
        let fk: Vec<f64> = match &grid {
            None => zk.iter().map(|&y| density(y)).collect(),
            Some((z, w, f)) => {
                let (tp, d) = (t[k - 1], tk - t[k - 1]);
                let scale = (tk / d).sqrt();
                zk.iter()
                    .map(|&y| {
                        z.iter()
                            .zip(w)
                            .zip(f)
                            .map(|((zi, wi), fi)| {
                                wi * fi * density((y * tk.sqrt() - zi * tp.sqrt()) / d.sqrt())
                            })
                            .sum::<f64>()
                            * scale
                    })
                    .collect()
            }
        };
        grid = Some((zk, wk, fk));
    }
    c
}

/// The nominal one-sided level 1 − Φ(c_k) of each look.
pub fn nominal_levels(spending: Spending, alpha: f64, t: &[f64]) -> Vec<f64> {
    boundaries(spending, alpha, t).into_iter().map(upper_tail).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn equal(k: usize) -> Vec<f64> {
        (1..=k).map(|i| i as f64 / k as f64).collect()
    }

    #[test]
    fn one_look_is_the_fixed_design() {
        for s in [Spending::ObrienFleming, Spending::Pocock] {
            assert!((s.spent(0.025, 1.0) - 0.025).abs() < 1e-9, "{}", s.spent(0.025, 1.0));
            let c = boundaries(s, 0.025, &[1.0]);
            assert!((c[0] - 1.959963984540054).abs() < 1e-7, "{c:?}");
        }
    }

    /// Published boundaries: Jennison & Turnbull 2000, Table 7.5 / gsDesign's `sfLDOF` for five
    /// equally spaced looks at one-sided α = 0.025: 4.877, 3.357, 2.680, 2.290, 2.031.
    #[test]
    fn obrien_fleming_five_looks_match_the_published_boundaries() {
        let c = boundaries(Spending::ObrienFleming, 0.025, &equal(5));
        let published = [4.877, 3.357, 2.680, 2.290, 2.031];
        for (ours, theirs) in c.iter().zip(published) {
            assert!((ours - theirs).abs() < 2e-3, "{c:?} against {published:?}");
        }
    }

    /// The boundaries spend exactly what the spending function says, look by look: checked by
    /// simulating the looks' statistics (Brownian motion at the information fractions).
    #[test]
    fn simulated_crossings_spend_the_increments() {
        let t = [0.2, 0.45, 0.7, 1.0];
        for s in [Spending::ObrienFleming, Spending::Pocock] {
            let alpha = 0.05;
            let c = boundaries(s, alpha, &t);
            let mut rng = ChaCha8Rng::seed_from_u64(7);
            let trials = 400_000;
            let mut first = [0usize; 4];
            for _ in 0..trials {
                let (mut sum, mut prev) = (0.0, 0.0);
                for k in 0..t.len() {
                    let x: f64 = StandardNormal.sample(&mut rng);
                    sum += x * (t[k] - prev).sqrt();
                    prev = t[k];
                    if sum / t[k].sqrt() >= c[k] {
                        first[k] += 1;
                        break;
                    }
                }
            }
            let mut before = 0.0;
            for k in 0..t.len() {
                let want = s.spent(alpha, t[k]) - before;
                before = s.spent(alpha, t[k]);
                let got = first[k] as f64 / trials as f64;
                let se = (want * (1.0 - want) / trials as f64).sqrt();
                assert!(
                    (got - want).abs() < 4.0 * se + 1e-5,
                    "{s:?} look {k}: {got} against {want}"
                );
            }
        }
    }

    #[test]
    fn pocock_spends_earlier_than_obrien_fleming() {
        let t = equal(4);
        let ob = nominal_levels(Spending::ObrienFleming, 0.025, &t);
        let po = nominal_levels(Spending::Pocock, 0.025, &t);
        assert!(po[0] > ob[0] && po[3] < ob[3], "{ob:?} {po:?}");
        // every nominal level is below the total: looking again costs level
        assert!(ob.iter().chain(&po).all(|p| *p < 0.025));
    }
}
