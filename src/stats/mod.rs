//! Statistics below the reports, the verdicts and `slamlab diff`: per-cell summaries and number
//! formatting (here), intervals and comparisons ([`compare`]), hypothesis tests ([`hypothesis`]).
//! Sums run sequentially in the order given (run-id order), so results are bit-identical whatever
//! the thread count that produced them.

pub mod compare;
pub mod hypothesis;
pub mod power;
pub mod sensitivity;
pub mod sequential;

use statrs::distribution::{ContinuousCDF, StudentsT};

/// Confidence level of every interval in the reports.
pub const CONFIDENCE: f64 = 0.95;

/// Summary of one cell's replicate values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    pub n: usize,
    pub mean: f64,
    /// Sample standard deviation (ddof = 1); NaN for n < 2.
    pub std: f64,
    /// Student-t confidence interval of the mean; NaN for n < 2.
    pub ci_low: f64,
    pub ci_high: f64,
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

/// Degrees of freedom above which [`student_t_inverse`] expands about the normal quantile.
const T_EXPANSION_DF: f64 = 1e4;

/// The Student-t quantile t_{p, df}. Above [`T_EXPANSION_DF`] degrees of freedom statrs' inverse
/// CDF loses accuracy (10⁻⁸ at 3·10⁴, 0.26 at 10⁷) and at 10⁸ does not return, so the quantile
/// is the Cornish–Fisher expansion about z_p, t = z + (z³ + z)/(4ν) + (5z⁵ + 16z³ + 3z)/(96ν²)
/// (Abramowitz & Stegun 26.7.5), which agrees with statrs to 10⁻¹¹ at 10⁴.
pub fn student_t_inverse(df: f64, p: f64) -> f64 {
    if df <= T_EXPANSION_DF {
        return StudentsT::new(0.0, 1.0, df).map_or(f64::NAN, |t| t.inverse_cdf(p));
    }
    let z = sequential::z_quantile(p);
    z + (z.powi(3) + z) / (4.0 * df)
        + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * df * df)
}

/// Two-sided Student-t quantile t_{(1+CONFIDENCE)/2, df}.
pub fn t_quantile(df: usize) -> f64 {
    StudentsT::new(0.0, 1.0, df as f64)
        .map(|t| t.inverse_cdf(0.5 + CONFIDENCE / 2.0))
        .unwrap_or(f64::NAN)
}

pub fn summarize(values: &[f64]) -> Summary {
    let n = values.len();
    if n == 0 {
        return Summary {
            n,
            mean: f64::NAN,
            std: f64::NAN,
            ci_low: f64::NAN,
            ci_high: f64::NAN,
            median: f64::NAN,
            min: f64::NAN,
            max: f64::NAN,
        };
    }
    let mean = values.iter().sum::<f64>() / n as f64;
    let (std, half) = if n >= 2 && mean.is_finite() {
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let std = var.sqrt();
        (std, t_quantile(n - 1) * std / (n as f64).sqrt())
    } else {
        (f64::NAN, f64::NAN)
    };
    Summary {
        n,
        mean,
        std,
        ci_low: mean - half,
        ci_high: mean + half,
        median: crate::metrics::median(values),
        min: values.iter().copied().fold(f64::INFINITY, f64::min),
        max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

/// [`summarize`] for a quantity that cannot be negative (every metric: `metrics::out_of_range`):
/// the t interval cut at 0. A confidence interval intersected with the values the quantity can
/// take keeps its coverage, and no longer shows a negative lower bound.
pub fn summarize_nonnegative(values: &[f64]) -> Summary {
    let mut s = summarize(values);
    if s.ci_low < 0.0 {
        s.ci_low = 0.0;
    }
    s
}

/// `v` with `digits` significant figures: plain notation for 1e-4 ≤ |v| < 1e6, scientific
/// otherwise; ∞ and NaN spelled out ("∞", "−∞", "—").
pub fn sig(v: f64, digits: usize) -> String {
    if v.is_nan() {
        return "—".into();
    }
    if v.is_infinite() {
        return if v > 0.0 { "∞".into() } else { "−∞".into() };
    }
    if v == 0.0 {
        return "0".into();
    }
    let digits = digits.max(1);
    // Magnitude after rounding to `digits` significant figures (9.996 → 10.0, not 9.996).
    let rounded: f64 = format!("{:.*e}", digits - 1, v).parse().unwrap_or(v);
    let mag = rounded.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{:.*e}", digits - 1, v);
    }
    let decimals = (digits as i32 - 1 - mag).max(0) as usize;
    let s = format!("{:.*}", decimals, rounded);
    if s.starts_with('-') { s.replacen('-', "−", 1) } else { s }
}

/// Plain ASCII variant for CSV (machine-readable: `inf`, `nan`, `-`).
pub fn sig_ascii(v: f64, digits: usize) -> String {
    if v.is_nan() {
        return String::new();
    }
    if v.is_infinite() {
        return if v > 0.0 { "inf".into() } else { "-inf".into() };
    }
    sig(v, digits).replace('−', "-")
}

#[cfg(test)]
mod tests {

    /// Above 10⁴ degrees of freedom the t quantile is the expansion about z: continuous at the
    /// switch, the normal quantile in the limit, and it returns where statrs did not (10⁸).
    #[test]
    fn t_quantiles_at_large_degrees_of_freedom() {
        let exact = StudentsT::new(0.0, 1.0, T_EXPANSION_DF).unwrap().inverse_cdf(0.95);
        let expanded = {
            let z = sequential::z_quantile(0.95);
            let df = T_EXPANSION_DF;
            z + (z.powi(3) + z) / (4.0 * df)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * df * df)
        };
        assert!((exact - expanded).abs() < 1e-10, "{exact} against {expanded}");
        assert_eq!(student_t_inverse(T_EXPANSION_DF, 0.95), exact);
        let z = sequential::z_quantile(0.95);
        for df in [1e5, 1e7, 1e8, 1e15] {
            let t = student_t_inverse(df, 0.95);
            assert!(t > z && t - z < 1e-4, "df {df}: {t}");
        }
    }
    use super::*;

    /// Student t CI of x = [1, 2, 3, 4, 5] at 95 %: mean 3, s² = 2.5, t_{0.975,4} = 2.776445
    /// (any t table; scipy `t.ppf(0.975, 4)` = 2.7764451051977934) ⇒ half-width
    /// 2.776445·√2.5/√5 = 1.963243161337696. n < 2 gives NaN bounds.
    #[test]
    fn a_nonnegative_summary_never_shows_a_negative_lower_bound() {
        // a skewed small sample whose t interval crosses 0
        let v = [0.0, 0.0, 0.1, 5.0];
        assert!(summarize(&v).ci_low < 0.0);
        let s = summarize_nonnegative(&v);
        assert_eq!(s.ci_low, 0.0);
        assert_eq!((s.mean, s.ci_high), (summarize(&v).mean, summarize(&v).ci_high));
        // an interval already above 0 is unchanged
        assert_eq!(summarize_nonnegative(&[4.0, 5.0, 6.0]), summarize(&[4.0, 5.0, 6.0]));
    }

    #[test]
    fn mean_ci_textbook() {
        let s = summarize(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(s.mean, 3.0);
        assert!((s.ci_low - (3.0 - 1.963243161337696)).abs() < 1e-9, "lo = {}", s.ci_low);
        assert!((s.ci_high - (3.0 + 1.963243161337696)).abs() < 1e-9, "hi = {}", s.ci_high);
        let one = summarize(&[4.0]);
        assert_eq!(one.mean, 4.0);
        assert!(one.ci_low.is_nan() && one.ci_high.is_nan());
    }

    #[test]
    fn t_quantiles_match_tables() {
        // Standard two-sided 95 % critical values.
        for (df, t) in [(1, 12.706), (2, 4.303), (4, 2.776), (9, 2.262), (19, 2.093), (29, 2.045)] {
            assert!((t_quantile(df) - t).abs() < 1e-3, "df {df}: {}", t_quantile(df));
        }
    }

    #[test]
    fn summary_of_known_sample() {
        // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, sample sd 2.138, CI 5 ± 2.365·2.138/√8
        let s = summarize(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]);
        assert_eq!(s.mean, 5.0);
        assert!((s.std - 2.13809).abs() < 1e-5);
        let half = 2.364624 * 2.13809 / 8f64.sqrt();
        assert!((s.ci_high - 5.0 - half).abs() < 1e-4 && (5.0 - s.ci_low - half).abs() < 1e-4);
        assert_eq!(s.median, 4.5);
        assert_eq!((s.min, s.max), (2.0, 9.0));
    }

    #[test]
    fn single_value_has_no_interval() {
        let s = summarize(&[3.0]);
        assert_eq!(s.mean, 3.0);
        assert!(s.ci_low.is_nan() && s.std.is_nan());
    }

    #[test]
    fn significant_figures() {
        assert_eq!(sig(0.123456, 3), "0.123");
        assert_eq!(sig(12.3456, 3), "12.3");
        assert_eq!(sig(9.996, 3), "10.0");
        assert_eq!(sig(1234.5, 3), "1230");
        assert_eq!(sig(-0.5, 2), "−0.50");
        assert_eq!(sig(0.0000123, 3), "1.23e-5");
        assert_eq!(sig(f64::INFINITY, 3), "∞");
        assert_eq!(sig(f64::NAN, 3), "—");
        assert_eq!(sig_ascii(-0.5, 2), "-0.50");
    }
}
