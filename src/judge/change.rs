//! The verdict of `slamlab diff` on one metric of one cell (criterion.rs-style): identical, no
//! change, too few replicates to tell, within noise, improved or regressed, from the
//! Holm-adjusted p, the interval of NEW − BASE and the smallest relevant change. "No change" is
//! shown, never assumed: a difference that is not significant but whose interval still admits a
//! relevant change is "too few replicates".

/// Outcome of comparing one metric between BASE and NEW (criterion.rs-style).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Both sides bit-identical: nothing to test.
    Identical,
    /// Adjusted p ≥ α and the CI of NEW − BASE within [−min_effect, +min_effect]: no relevant
    /// change, shown.
    NoChange,
    /// Adjusted p ≥ α, but the CI of NEW − BASE reaches beyond ±min_effect (or there is none):
    /// the replicates cannot tell a relevant change from none.
    TooFewReplicates,
    /// Significant, but the CI of NEW − BASE reaches into [−min_effect, +min_effect].
    WithinNoise,
    /// Significant and beyond min_effect in the good direction.
    Improved,
    /// Significant and beyond min_effect in the bad direction.
    Regressed,
}

impl Verdict {
    /// Stable snake_case identifier (for CSV/Parquet; reports format their own label).
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Identical => "identical",
            Verdict::NoChange => "no_change",
            Verdict::TooFewReplicates => "too_few_replicates",
            Verdict::WithinNoise => "within_noise",
            Verdict::Improved => "improved",
            Verdict::Regressed => "regressed",
        }
    }
}

/// Verdict for one metric, evaluated in this order:
/// 1. `identical` ⇒ [`Verdict::Identical`];
/// 2. `p_adjusted ≥ alpha` or NaN ⇒ [`Verdict::NoChange`] when the CI lies within
///    [−min_effect, +min_effect], else [`Verdict::TooFewReplicates`];
/// 3. CI `(lo, hi)` of NEW − BASE overlapping [−min_effect, +min_effect] (closed: lo ≤ min_effect and
///    hi ≥ −min_effect), or a NaN/inverted CI (no evidence of size) ⇒ [`Verdict::WithinNoise`];
/// 4. otherwise the CI lies wholly above or below the band: NEW − BASE > 0 is [`Verdict::Regressed`]
///    when `lower_is_better` (errors, runtimes) and [`Verdict::Improved`] otherwise; mirrored below.
pub fn verdict(
    identical: bool,
    p_adjusted: f64,
    alpha: f64,
    ci: (f64, f64),
    min_effect: f64,
    lower_is_better: bool,
) -> Verdict {
    if identical {
        return Verdict::Identical;
    }
    let (lo, hi) = ci;
    if p_adjusted.is_nan() || p_adjusted >= alpha {
        let shown = lo.is_finite() && hi.is_finite() && lo >= -min_effect && hi <= min_effect;
        return if shown { Verdict::NoChange } else { Verdict::TooFewReplicates };
    }
    if lo.is_nan() || hi.is_nan() || lo > hi || (lo <= min_effect && hi >= -min_effect) {
        return Verdict::WithinNoise;
    }
    let increased = lo > min_effect;
    if increased == lower_is_better { Verdict::Regressed } else { Verdict::Improved }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Verdict table, one row per branch, min_effect = 0.1, alpha = 0.05.
    #[test]
    fn diff_verdict_table() {
        use Verdict::*;
        let rows = [
            // (identical, p, ci, lower_is_better, expected)
            (true, 0.0, (1.0, 2.0), true, Identical),
            // not significant: "no change" only when the interval excludes a relevant change
            (false, 0.05, (-0.05, 0.08), true, NoChange),
            (false, 0.05, (1.0, 2.0), true, TooFewReplicates),
            (false, 0.3, (-0.5, 8.0), true, TooFewReplicates), // the review's +737 % at n = 4
            (false, f64::NAN, (f64::NAN, f64::NAN), true, TooFewReplicates),
            (false, 0.01, (0.05, 2.0), true, WithinNoise),
            (false, 0.01, (-2.0, -0.1), true, WithinNoise), // touches the band edge
            (false, 0.01, (f64::NAN, f64::NAN), true, WithinNoise),
            (false, 0.01, (0.2, 2.0), true, Regressed), // error went up
            (false, 0.01, (0.2, 2.0), false, Improved), // score went up
            (false, 0.01, (-2.0, -0.2), true, Improved),
            (false, 0.01, (-2.0, -0.2), false, Regressed),
        ];
        for (identical, p, ci, lib, want) in rows {
            assert_eq!(
                verdict(identical, p, 0.05, ci, 0.1, lib),
                want,
                "{identical} {p} {ci:?} {lib}"
            );
        }
        assert_eq!(Regressed.as_str(), "regressed");
        assert_eq!(WithinNoise.as_str(), "within_noise");
    }
}
