//! The tests behind slamlab's verdicts: Student t intervals and one-sided p-values of a mean, and
//! Spearman's rank correlation (and, in tests only, the agreement rules issue 25 replaced: Welch
//! against a published (mean, variance, n) and a normal prediction interval for a single run).
//!
//! References:
//! - [S] Student 1908; any textbook t interval, e.g. Casella & Berger, *Statistical Inference*, §9.2.
//! - [W] Welch 1947, *Biometrika* 34:28–35; Satterthwaite 1946 (effective degrees of freedom).
//! - [HM] Hahn & Meeker, *Statistical Intervals*, 1991, §4.6 (prediction interval for one future
//!   observation: x̄ ± t_{n−1} s √(1 + 1/n)).
//! - [Sc] Schuirmann 1987, *J. Pharmacokin. Biopharm.* 15:657 (two one-sided tests, TOST).
//!
//! Pure: no IO and no randomness. Non-finite inputs give NaN estimates and p = NaN; callers decide
//! what an untestable input means.

use super::hypothesis::{mean, sample_variance as variance};
use statrs::distribution::{ContinuousCDF, StudentsT};
use std::collections::BTreeMap;

fn student(df: f64) -> Option<StudentsT> {
    (df > 0.0).then(|| StudentsT::new(0.0, 1.0, df).ok()).flatten()
}

/// Paired differences a − b over the replicates both cells have (replicate k of both cells saw
/// the same world), in replicate order.
pub fn paired_differences(a: &BTreeMap<u32, f64>, b: &BTreeMap<u32, f64>) -> Vec<f64> {
    a.iter().filter_map(|(r, x)| b.get(r).map(|y| x - y)).collect()
}

/// The paired comparison of two cells' replicate values: the mean difference a − b with its
/// two-sided t interval at `confidence`, and the mean of b over the same replicates (the level a
/// relative change is taken against).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairedContrast {
    pub pairs: usize,
    pub mean: f64,
    pub ci: (f64, f64),
    pub against_mean: f64,
}

pub fn paired_contrast(
    a: &BTreeMap<u32, f64>,
    b: &BTreeMap<u32, f64>,
    confidence: f64,
) -> PairedContrast {
    let d = paired_differences(a, b);
    let against: Vec<f64> = a.keys().filter_map(|r| b.get(r).copied()).collect();
    PairedContrast {
        pairs: d.len(),
        mean: mean(&d),
        ci: t_interval(&d, confidence),
        against_mean: mean(&against),
    }
}

/// Two-sided Student t interval of the mean of `x` at `confidence` (e.g. 0.95, or 0.90 for TOST);
/// (NaN, NaN) for n < 2 or non-finite data. A constant sample gives the point interval (c, c).
pub fn t_interval(x: &[f64], confidence: f64) -> (f64, f64) {
    if x.len() < 2 || x.iter().any(|v| !v.is_finite()) || !(confidence > 0.0 && confidence < 1.0) {
        return (f64::NAN, f64::NAN);
    }
    let n = x.len() as f64;
    let m = mean(x);
    let half = match student(n - 1.0) {
        Some(t) => t.inverse_cdf(0.5 + confidence / 2.0) * (variance(x) / n).sqrt(),
        None => f64::NAN,
    };
    (m - half, m + half)
}

/// One-sided p-value of H1: mean(x) > `delta` (`above = true`) or mean(x) < `delta` (`above =
/// false`), by the one-sample t statistic. A constant sample decides without error: p = 0 when it
/// lies strictly on the H1 side, else 1. NaN for n < 2 or non-finite data.
pub fn t_one_sided_p(x: &[f64], delta: f64, above: bool) -> f64 {
    if x.len() < 2 || x.iter().any(|v| !v.is_finite()) || !delta.is_finite() {
        return f64::NAN;
    }
    let n = x.len() as f64;
    let m = mean(x);
    let se = (variance(x) / n).sqrt();
    let signed = if above { m - delta } else { delta - m };
    if se == 0.0 {
        return if signed > 0.0 { 0.0 } else { 1.0 };
    }
    match student(n - 1.0) {
        Some(t) => t.sf(signed / se),
        None => f64::NAN,
    }
}

/// Welch's two-sided p for equal means, from summaries: ours (mean, sample variance, n) against a
/// published (mean, variance, n). Both variances 0: p = 1 when the means are equal, else 0.
/// The agreement rule before issue 25 ("compatible when p ≥ 0.05"); kept for the tests that show
/// why it was replaced (`judge::agreement`).
#[cfg(test)]
pub fn welch_summary_p(m1: f64, v1: f64, n1: usize, m2: f64, v2: f64, n2: usize) -> f64 {
    if n1 < 2 || n2 < 2 || !(m1.is_finite() && v1.is_finite() && m2.is_finite() && v2.is_finite()) {
        return f64::NAN;
    }
    let (a, b) = (v1 / n1 as f64, v2 / n2 as f64);
    let se2 = a + b;
    if se2 == 0.0 {
        return if m1 == m2 { 1.0 } else { 0.0 };
    }
    // Welch–Satterthwaite degrees of freedom; a zero-variance side contributes nothing.
    let df = se2 * se2 / (a * a / (n1 as f64 - 1.0) + b * b / (n2 as f64 - 1.0));
    match student(df) {
        Some(t) => 2.0 * (1.0 - t.cdf((m1 - m2).abs() / se2.sqrt())),
        None => f64::NAN,
    }
}

/// Prediction interval at `confidence` for the mean of `m` further runs, from replicates `x`
/// ([HM] §4.6): x̄ ± t_{n−1} s √(1/n + 1/m); m = 1 is a single further run. (NaN, NaN) for
/// n < 2, m = 0 or non-finite data. The single-run rule before issue 25 (normal, so it reaches
/// below zero on a skewed metric); kept for the tests that show why it was replaced.
#[cfg(test)]
pub fn prediction_interval(x: &[f64], confidence: f64, m: u32) -> (f64, f64) {
    if x.len() < 2 || m == 0 || x.iter().any(|v| !v.is_finite()) {
        return (f64::NAN, f64::NAN);
    }
    let n = x.len() as f64;
    let c = mean(x);
    let half = match student(n - 1.0) {
        Some(t) => {
            t.inverse_cdf(0.5 + confidence / 2.0)
                * (variance(x) * (1.0 / n + 1.0 / m as f64)).sqrt()
        }
        None => f64::NAN,
    };
    (c - half, c + half)
}

/// Average ranks (1-based), ties sharing their mean rank.
fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        let avg = (i + j) as f64 / 2.0 + 1.0;
        for &k in &idx[i..=j] {
            r[k] = avg;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation of paired values (Pearson's r of the average ranks). ±∞ rank as
/// the largest / smallest values; NaN for fewer than 3 pairs, a NaN value, or a constant side.
pub fn spearman(a: &[f64], b: &[f64]) -> f64 {
    if a.len() != b.len() || a.len() < 3 || a.iter().chain(b).any(|v| v.is_nan()) {
        return f64::NAN;
    }
    let (ra, rb) = (ranks(a), ranks(b));
    let (ma, mb) = (mean(&ra), mean(&rb));
    let cov: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = ra.iter().map(|x| (x - ma) * (x - ma)).sum();
    let vb: f64 = rb.iter().map(|y| (y - mb) * (y - mb)).sum();
    if va == 0.0 || vb == 0.0 {
        return f64::NAN;
    }
    cov / (va * vb).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Only replicates both cells ran are paired, and the relative level is the compared cell's
    /// mean over those same replicates.
    #[test]
    fn paired_contrast_pairs_common_replicates() {
        let a: BTreeMap<u32, f64> = [(0, 3.0), (1, 5.0), (2, 4.0), (7, 100.0)].into();
        let b: BTreeMap<u32, f64> = [(0, 1.0), (1, 2.0), (2, 3.0), (5, -50.0)].into();
        assert_eq!(paired_differences(&a, &b), vec![2.0, 3.0, 1.0]);
        let c = paired_contrast(&a, &b, 0.95);
        assert_eq!((c.pairs, c.mean, c.against_mean), (3, 2.0, 2.0));
        // 2 ± t(0.975, 2)·1/√3 = 2 ± 4.3027·0.57735
        assert!(
            (c.ci.0 - (2.0 - 2.48414)).abs() < 1e-4 && (c.ci.1 - (2.0 + 2.48414)).abs() < 1e-4,
            "{:?}",
            c.ci
        );
    }
    use rand_distr::{Distribution, Normal as RNormal};

    /// x = 1..5: mean 3, s = √2.5; t_{0.975,4} = 2.776445 ⇒ half-width 1.963243.
    #[test]
    fn t_interval_textbook() {
        let (lo, hi) = t_interval(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.95);
        assert!(
            (lo - (3.0 - 1.963243161337696)).abs() < 1e-9
                && (hi - (3.0 + 1.963243161337696)).abs() < 1e-9
        );
        assert_eq!(t_interval(&[2.0, 2.0, 2.0], 0.95), (2.0, 2.0));
        assert!(t_interval(&[1.0], 0.95).0.is_nan());
        assert!(t_interval(&[1.0, f64::INFINITY], 0.95).0.is_nan());
    }

    /// One-sided p at the interval's edge equals (1 − confidence)/2.
    #[test]
    fn one_sided_p_matches_the_interval() {
        let x = [0.3, 0.9, 0.4, 1.2, 0.7, 0.8];
        let (lo, hi) = t_interval(&x, 0.90);
        assert!((t_one_sided_p(&x, lo, true) - 0.05).abs() < 1e-9);
        assert!((t_one_sided_p(&x, hi, false) - 0.05).abs() < 1e-9);
        assert_eq!(t_one_sided_p(&[1.0, 1.0, 1.0], 0.5, true), 0.0);
        assert_eq!(t_one_sided_p(&[1.0, 1.0, 1.0], 0.5, false), 1.0);
    }

    /// Welch from summaries equals Welch from the raw samples (whose test is checked against
    /// Wikipedia's example in [`super::super::hypothesis`]).
    #[test]
    fn welch_from_summaries() {
        let a = [
            27.5, 21.0, 19.0, 23.6, 17.0, 17.9, 16.9, 20.1, 21.9, 22.6, 23.1, 19.6, 19.0, 21.7,
            21.4,
        ];
        let b = [
            27.1, 22.0, 20.8, 23.4, 23.4, 23.5, 25.8, 22.0, 24.8, 20.2, 21.9, 22.1, 22.9, 20.5,
            24.4,
        ];
        let p = welch_summary_p(mean(&a), variance(&a), a.len(), mean(&b), variance(&b), b.len());
        let (.., p_raw) = crate::stats::hypothesis::welch_p(&a, &b);
        assert!((p - p_raw).abs() < 1e-9, "p = {p}, from the samples {p_raw}");
        assert_eq!(welch_summary_p(1.0, 0.0, 5, 1.0, 0.0, 5), 1.0);
        assert_eq!(welch_summary_p(1.0, 0.0, 5, 2.0, 0.0, 5), 0.0);
    }

    /// A 95 % prediction interval from n = 5 normal draws covers a sixth draw 95 % of the time.
    #[test]
    fn prediction_interval_covers_a_new_run() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let d = RNormal::new(0.0, 1.0).unwrap();
        let trials = 4000;
        let hits = (0..trials)
            .filter(|_| {
                let x: Vec<f64> = (0..5).map(|_| d.sample(&mut rng)).collect();
                let (lo, hi) = prediction_interval(&x, 0.95, 1);
                let y = d.sample(&mut rng);
                lo <= y && y <= hi
            })
            .count();
        let rate = hits as f64 / trials as f64;
        assert!((rate - 0.95).abs() < 0.015, "coverage {rate}");
    }

    #[test]
    fn spearman_ranks() {
        assert!((spearman(&[1.0, 2.0, 3.0, 4.0], &[10.0, 20.0, 30.0, 40.0]) - 1.0).abs() < 1e-12);
        assert!((spearman(&[1.0, 2.0, 3.0, 4.0], &[4.0, 3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        assert!((spearman(&[1.0, 2.0, f64::INFINITY], &[1.0, 2.0, 3.0]) - 1.0).abs() < 1e-12);
        assert!(spearman(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]).is_nan());
        // textbook: ranks with a tie
        let r = spearman(&[1.0, 2.0, 2.0, 4.0, 5.0], &[1.0, 3.0, 2.0, 5.0, 4.0]);
        // ranks (1, 2.5, 2.5, 4, 5) and (1, 3, 2, 5, 4): r = 8.5 / √(9.5·10) = 0.872082
        assert!((r - 0.872082).abs() < 1e-6, "{r}");
    }
}
