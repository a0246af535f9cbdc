//! How close is "the same": one equivalence margin per reference work, and the resolution of the
//! metrics a work prints, below which no difference means anything. Fixed on 2026-11-26 before the
//! scoreboard was regenerated under the equivalence rule (issue 25), and written out in the book
//! (docs/src/findings/fidelity.md, "How verdicts are reached"); a margin is never chosen by where a published number falls.
//!
//! - A published cell is **shown equivalent** to ours when the difference lies within ± the
//!   margin ([`WorkMargins::margin`]): the larger of `relative` × |published value| and the
//!   metric's resolution.
//! - A claim's tolerance (`flat`) defaults to `relative` × the level of its reference cell, and a
//!   directional claim's minimum effect is never below the metric's resolution.
//!
//! Where each value comes from:
//! - **[FT] 20 %**: the thesis reruns one configuration in two tables (Pmin = 9 in Table 10.6 and
//!   M = 100 in Table 10.17) and prints errors 8–23 % apart (median 14 %): a difference below 20 %
//!   of the level is one the thesis itself does not resolve.
//! - **[EP] 20 %**: [EP] prints no rerun of a configuration (Table 3 reprints Table 2's runs: its
//!   28 shared cells agree to the printed digits), so it has no spread of its own; slamlab adopts
//!   [FT]'s, the only rerun spread the four works print. Resolutions: the orientation error is
//!   not resolved below E-PSM's finest orientation step, 0.01° ([EP] L415); Table 3, where claims
//!   C4–C6 are stated, prints f to 0.01 cm².
//! - **[PF] 10 %**: [PF] gives no threshold for "not significant"; its claims have used 10 % of
//!   the level since 2026-11-23 (7f9caaf; slamlab's choice), and it has no published cells.
//! - **[EV] 20 %**: one real run per experiment and no rerun; slamlab adopts [FT]'s spread as for
//!   [EP].

/// The margins of one reference work.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkMargins {
    /// The work's tag, as in a claim's `source` or an item's `seed` ("FT").
    pub tag: &'static str,
    /// Relative equivalence margin (of the published value, or of a claim's reference level).
    pub relative: f64,
    /// Where `relative` comes from.
    pub why: &'static str,
    /// (metric, smallest difference that means anything, in the metric's unit, why).
    pub resolutions: &'static [(&'static str, f64, &'static str)],
}

/// The table, one row per reference work.
pub const WORKS: [WorkMargins; 4] = [
    WorkMargins {
        tag: "FT",
        relative: 0.20,
        why: "the thesis reruns one configuration in Tables 10.6 and 10.17 and prints errors 8–23 % apart",
        resolutions: &[],
    },
    WorkMargins {
        tag: "EP",
        relative: 0.20,
        why: "no rerun printed (Table 3 reprints Table 2's runs); [FT]'s rerun spread adopted",
        resolutions: &[
            ("atheta_deg", 0.01, "E-PSM's finest orientation step ([EP] L415)"),
            ("f", 0.01, "Table 3 prints f to 0.01 cm²"),
        ],
    },
    WorkMargins {
        tag: "PF",
        relative: 0.10,
        why: "no threshold in [PF]; slamlab's choice, used by its claims since 2026-11-23 (7f9caaf)",
        resolutions: &[],
    },
    WorkMargins {
        tag: "EV",
        relative: 0.20,
        why: "one real run per experiment, no rerun; [FT]'s rerun spread adopted",
        resolutions: &[],
    },
];

/// The margins of a work the table does not name (a user's own published file): [FT]'s rerun
/// spread, the only one the reference works print.
pub const DEFAULT: WorkMargins = WorkMargins {
    tag: "",
    relative: 0.20,
    why: "no margin stated for this work: [FT]'s rerun spread",
    resolutions: &[],
};

/// The margins of the work tagged `tag` ("FT", or a source such as "[FT] L7816"), if it is one.
pub fn of(tag: &str) -> Option<&'static WorkMargins> {
    let t = tag.trim_start_matches('[');
    WORKS
        .iter()
        .find(|w| t.starts_with(w.tag) && !t[w.tag.len()..].starts_with(char::is_alphanumeric))
}

/// The margins of the work a label or source names, or [`DEFAULT`].
pub fn for_label(label: &str) -> &'static WorkMargins {
    of(label).unwrap_or(&DEFAULT)
}

/// The metric a long-layout cell name stands for: `ax_mean_mm` → `ax_mm`, `f_max` → `f`.
pub fn base_metric(name: &str) -> String {
    for stat in ["mean", "max"] {
        if let Some(base) = name.strip_suffix(&format!("_{stat}")) {
            return base.to_string();
        }
        if let Some((base, unit)) = name.split_once(&format!("_{stat}_")) {
            return format!("{base}_{unit}");
        }
    }
    name.to_string()
}

impl WorkMargins {
    /// The smallest difference of `metric` that means anything (0 when none is stated).
    pub fn resolution(&self, metric: &str) -> f64 {
        let base = base_metric(metric);
        self.resolutions.iter().find(|(m, _, _)| *m == base).map_or(0.0, |(_, r, _)| *r)
    }

    /// The equivalence margin around a published value of `metric`.
    pub fn margin(&self, metric: &str, published: f64) -> f64 {
        (self.relative * published.abs()).max(self.resolution(metric))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn works_and_metrics_are_found() {
        assert_eq!(of("FT").unwrap().relative, 0.20);
        assert_eq!(of("[EP] L423").unwrap().tag, "EP");
        assert!(of("slamlab").is_none());
        assert!(of("FTX").is_none());
        assert_eq!(base_metric("atheta_mean_deg"), "atheta_deg");
        assert_eq!(base_metric("f_max"), "f");
        assert_eq!(base_metric("landmark_error_m"), "landmark_error_m");
        let ep = of("EP").unwrap();
        assert_eq!(ep.resolution("atheta_max_deg"), 0.01);
        // near zero the resolution, not the relative margin, sets the margin
        assert_eq!(ep.margin("f_mean", 0.004), 0.01);
        assert!((ep.margin("f_mean", 2.0) - 0.4).abs() < 1e-12);
    }
}
