//! How many replicates would decide a test, at the effect and spread observed (issue 31 item 1):
//! the projection a researcher makes next when a verdict is inconclusive. Each function takes the
//! observed mean and sample standard deviation of the quantity the test reads (a paired
//! difference, or a cell's values) and returns the smallest replicate count n at which the same
//! test, with the same mean and standard deviation, would no longer be inconclusive — or that no
//! count would, because the observed mean sits exactly on the test's bound.
//!
//! This is a projection, not a guarantee: the next replicates move the mean and the spread. It is
//! the textbook sample-size reading of a t interval (Student's t at n − 1 degrees of freedom;
//! e.g. Julious 2004, *Stat. Med.* 23:1921, for the equivalence case), searched over n rather than
//! solved with a normal approximation, so that it matches the test the verdict used exactly.

/// Replicates that would decide a test.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Replicates {
    /// At least this many (per cell, paired) at the observed mean and spread; more than the
    /// runs already made.
    Needed(usize),
    /// The observed data already decide it (the test is not inconclusive).
    Decided,
    /// No number would: the observed mean lies on the bound (an effect exactly at the margin), so
    /// the interval straddles it at every n.
    Never,
    /// More than `cap` replicates, or the inputs are not finite.
    BeyondCap,
}

/// Half-width of the two-sided `confidence` t interval of a mean of `n` values with sample
/// standard deviation `sd`.
fn half_width(sd: f64, n: usize, confidence: f64) -> f64 {
    let t = super::student_t_inverse((n - 1) as f64, 0.5 + confidence / 2.0);
    t * sd / (n as f64).sqrt()
}

/// The smallest n (≥ `have`, ≥ 2, ≤ `cap`) for which the two-sided `confidence` interval of the
/// mean, mean ± t·sd/√n, lies wholly on one side of `bound`: what decides greater / less
/// (bound = the minimum effect δ), non-inferiority (bound = the margin) and above / below (bound
/// = the threshold). [`Replicates::Decided`] when it already does at `have`.
pub fn to_clear(
    mean: f64,
    sd: f64,
    bound: f64,
    confidence: f64,
    have: usize,
    cap: usize,
) -> Replicates {
    if !(mean.is_finite() && sd.is_finite() && bound.is_finite() && sd >= 0.0) {
        return Replicates::BeyondCap;
    }
    let gap = (mean - bound).abs();
    if gap == 0.0 {
        return Replicates::Never;
    }
    first_n(have, cap, |n| half_width(sd, n, confidence) < gap)
}

/// The smallest n for which a two one-sided tests (TOST) equivalence reading at one-sided level
/// `alpha` is no longer inconclusive for one pair whose paired differences have mean `mean` and
/// standard deviation `sd`, within ±`tolerance`: the (1 − 2α) interval inside ±tolerance
/// (confirmed) when |mean| < tolerance; when |mean| > tolerance, the (1 − 2α) interval wholly
/// outside (the excess shown, as a one-sided test at α). [`Replicates::Never`] when
/// |mean| = tolerance.
pub fn to_settle_equivalence(
    mean: f64,
    sd: f64,
    tolerance: f64,
    alpha: f64,
    have: usize,
    cap: usize,
) -> Replicates {
    if !(mean.is_finite() && sd.is_finite() && tolerance.is_finite() && sd >= 0.0) {
        return Replicates::BeyondCap;
    }
    let gap = tolerance - mean.abs();
    if gap == 0.0 {
        return Replicates::Never;
    }
    first_n(have, cap, |n| half_width(sd, n, 1.0 - 2.0 * alpha) < gap.abs())
}

/// The first n in max(have, 2)..=cap with `decides(n)`; `Decided` when it is the first.
fn first_n(have: usize, cap: usize, decides: impl Fn(usize) -> bool) -> Replicates {
    let start = have.max(2);
    if start > cap {
        return Replicates::BeyondCap;
    }
    if decides(start) {
        return Replicates::Decided;
    }
    // the half-width falls monotonically in n: bisect for the first n that decides
    let (mut lo, mut hi) = (start, cap);
    if !decides(hi) {
        return Replicates::BeyondCap;
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        if decides(mid) { hi = mid } else { lo = mid }
    }
    Replicates::Needed(hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the returned n the interval clears the bound, and at n − 1 it does not (the first n).
    #[test]
    fn the_count_is_the_first_that_clears_the_bound() {
        for &(mean, sd, bound) in
            &[(0.10, 0.2, 0.05), (0.02, 0.05, 0.05), (-0.3, 1.0, 0.0), (1.0, 0.01, 0.999)]
        {
            match to_clear(mean, sd, bound, 0.95, 3, 1_000_000) {
                Replicates::Needed(n) => {
                    let gap = (mean - bound).abs();
                    assert!(half_width(sd, n, 0.95) < gap, "clears at n = {n}");
                    assert!(half_width(sd, n - 1, 0.95) >= gap, "not before n = {n}");
                }
                other => panic!("({mean}, {sd}, {bound}): {other:?}"),
            }
        }
    }

    /// The normal-approximation count (z·sd/gap)² is close for large n: a check of the scale.
    #[test]
    fn large_counts_agree_with_the_normal_approximation() {
        let (mean, sd, bound) = (0.01, 1.0, 0.0);
        let Replicates::Needed(n) = to_clear(mean, sd, bound, 0.95, 3, 10_000_000) else {
            panic!()
        };
        let z = 1.959_963_984_540_054;
        let approx = (z * sd / (mean - bound)).powi(2);
        assert!((n as f64 / approx - 1.0).abs() < 0.01, "{n} vs {approx}");
    }

    #[test]
    fn decided_never_and_beyond_the_cap() {
        // already clear at 10 replicates
        assert_eq!(to_clear(1.0, 0.1, 0.0, 0.95, 10, 1000), Replicates::Decided);
        // an effect exactly at the margin is never decided
        assert_eq!(to_clear(0.05, 0.3, 0.05, 0.95, 10, 1000), Replicates::Never);
        assert_eq!(to_settle_equivalence(-0.2, 0.3, 0.2, 0.05, 10, 1000), Replicates::Never);
        // a tiny gap needs more than the cap
        assert_eq!(to_clear(1e-6, 1.0, 0.0, 0.95, 10, 1000), Replicates::BeyondCap);
        assert_eq!(to_clear(f64::NAN, 1.0, 0.0, 0.95, 10, 1000), Replicates::BeyondCap);
        // a spread of zero decides at once
        assert_eq!(to_clear(0.1, 0.0, 0.0, 0.95, 3, 1000), Replicates::Decided);
    }

    /// Equivalence: a mean inside the tolerance needs the 90 % interval inside it; one outside
    /// needs the interval outside; both counts are the first that do.
    #[test]
    fn equivalence_counts_confirm_inside_and_refute_outside() {
        for &(mean, sd, tol) in &[(0.05, 0.3, 0.2), (-0.35, 0.4, 0.2), (0.0, 0.5, 0.1)] {
            let Replicates::Needed(n) = to_settle_equivalence(mean, sd, tol, 0.05, 5, 1_000_000)
            else {
                panic!("({mean}, {sd}, {tol})")
            };
            let gap = (tol - f64::abs(mean)).abs();
            assert!(half_width(sd, n, 0.90) < gap && half_width(sd, n - 1, 0.90) >= gap);
        }
    }
}
