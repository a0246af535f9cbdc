//! Agreement of one of our cells with one published number, judged by the publication's own
//! spread: (published mean, its variance if printed, the runs behind it) + our replicates →
//! compatible or not.
//!
//! - A published mean **with its variance** over m runs ([FT] prints σ² over its 5 runs): Welch's
//!   test of our replicates against (mean, σ², m); compatible when p ≥ [`ALPHA`].
//! - A published mean **without a variance** over m runs (one run per cell in [EP] and [EV]; [FT]'s
//!   landmark counts): the 95 % prediction interval for the mean of m further runs from our
//!   replicates, x̄ ± t_{n−1} s √(1/n + 1/m) (m = 1: a single run); compatible when it holds the
//!   published value.
//! - ∞ published (nothing detected): compatible only when every one of our replicates is ∞ too; ∞
//!   or NaN in ours against a finite published value is incompatible.
//! - Fewer than 2 of our replicates: not judged.

use crate::stats::compare::{prediction_interval, welch_summary_p};
use crate::stats::hypothesis::{mean, sample_variance};

/// Significance level of the agreement tests (and 1 − the prediction interval's level).
pub const ALPHA: f64 = 0.05;

/// A published number with what the publication says of its spread.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Published {
    pub mean: f64,
    /// Variance over the publication's runs, when printed.
    pub var: Option<f64>,
    /// Runs behind the published mean (1 for a single run).
    pub runs: u32,
}

/// The judgement of one cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Agreement {
    /// None when it cannot be judged (fewer than 2 replicates of ours).
    pub compatible: Option<bool>,
    /// Welch's p, when a variance is published.
    pub p: Option<f64>,
    /// The prediction interval, when no variance is published.
    pub interval: Option<(f64, f64)>,
}

/// Judges our replicates `ours` against `published`.
pub fn judge(published: Published, ours: &[f64]) -> Agreement {
    let none = Agreement { compatible: None, p: None, interval: None };
    if ours.len() < 2 || published.mean.is_nan() {
        return none;
    }
    if published.mean.is_infinite() {
        return Agreement { compatible: Some(ours.iter().all(|v| *v == published.mean)), ..none };
    }
    if ours.iter().any(|v| !v.is_finite()) {
        return Agreement { compatible: Some(false), ..none };
    }
    match published.var {
        Some(var) if published.runs >= 2 => {
            let p = welch_summary_p(
                mean(ours),
                sample_variance(ours),
                ours.len(),
                published.mean,
                var,
                published.runs as usize,
            );
            Agreement { compatible: Some(p >= ALPHA), p: Some(p), interval: None }
        }
        _ => {
            let (lo, hi) = prediction_interval(ours, 1.0 - ALPHA, published.runs.max(1));
            // A constant sample gives a point interval: equal up to rounding is compatible.
            let tol = 1e-9 * published.mean.abs().max(1e-12);
            Agreement {
                compatible: Some(published.mean >= lo - tol && published.mean <= hi + tol),
                p: None,
                interval: Some((lo, hi)),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welch_with_the_published_spread() {
        // ours 0.26 ± small over 10 runs; thesis 0.14 with σ² 0.0015 over 5: clearly apart
        let ours = [0.25, 0.27, 0.26, 0.24, 0.28, 0.26, 0.25, 0.27, 0.26, 0.26];
        let far = judge(Published { mean: 0.14, var: Some(0.0015), runs: 5 }, &ours);
        assert_eq!(far.compatible, Some(false));
        // a wide published spread makes the same gap compatible
        let wide = judge(Published { mean: 0.20, var: Some(0.02), runs: 5 }, &ours);
        assert_eq!(wide.compatible, Some(true));
        assert!(wide.p.unwrap() > 0.05);
    }

    #[test]
    fn single_runs_use_a_prediction_interval() {
        let ours = [1.0, 1.2, 0.8, 1.1, 0.9];
        // 95 % PI for one run: 1 ± t_{0.975,4}·s·√(1 + 1/5) = 1 ± 0.481
        assert_eq!(
            judge(Published { mean: 1.6, var: None, runs: 1 }, &ours).compatible,
            Some(false)
        );
        assert_eq!(
            judge(Published { mean: 1.4, var: None, runs: 1 }, &ours).compatible,
            Some(true)
        );
        // the mean of 5 published runs must be closer: 1.4 is outside that narrower interval
        assert_eq!(
            judge(Published { mean: 1.4, var: None, runs: 5 }, &ours).compatible,
            Some(false)
        );
        let (lo, hi) = prediction_interval(&ours, 1.0 - ALPHA, 1);
        let half = 2.7764451051977934 * 0.15811388300841897 * (1.2f64).sqrt();
        assert!((lo - (1.0 - half)).abs() < 1e-9 && (hi - (1.0 + half)).abs() < 1e-9);
    }

    #[test]
    fn infinities_and_small_samples() {
        let inf = [f64::INFINITY; 3];
        assert_eq!(
            judge(Published { mean: f64::INFINITY, var: Some(0.0), runs: 5 }, &inf).compatible,
            Some(true)
        );
        assert_eq!(
            judge(Published { mean: f64::INFINITY, var: Some(0.0), runs: 5 }, &[1.0, 2.0])
                .compatible,
            Some(false)
        );
        assert_eq!(
            judge(Published { mean: 1.0, var: None, runs: 1 }, &[1.0, f64::INFINITY]).compatible,
            Some(false)
        );
        assert_eq!(judge(Published { mean: 1.0, var: None, runs: 1 }, &[1.0]).compatible, None);
        // a constant sample equal to the published value
        assert_eq!(
            judge(Published { mean: 9.0, var: None, runs: 5 }, &[9.0, 9.0, 9.0]).compatible,
            Some(true)
        );
    }
}
