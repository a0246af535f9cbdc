//! Claims of a reference work, checked against a study's runs: ClaimSpec + cells → verdict
//! (confirmed / refuted / inconclusive) with the numbers behind it, per map and overall.
//!
//! Runs share their world seeds across sweep points (replicate k of every point saw the same
//! world), so cell comparisons use paired differences over replicates.

use super::stats::{self, sig, Summary};
use crate::spec::{ClaimSpec, ClaimTest, Require};
use crate::store::{ClaimCells, RunRow, RunStatus, StudyData};
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    Confirmed,
    Refuted,
    Inconclusive,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Confirmed => "confirmed",
            Verdict::Refuted => "refuted",
            Verdict::Inconclusive => "inconclusive",
        }
    }
}

/// A claim with its verdict, for the report.
#[derive(Debug, Clone, Serialize)]
pub struct ClaimView {
    pub id: String,
    pub source: String,
    pub text: String,
    pub test: String,
    pub verdict: String,
    pub summary: String,
    /// One line per map: its verdict and numbers.
    pub evidence: Vec<String>,
}

/// Replicate → metric value of the successful runs of one cell.
fn cell_values(data: &StudyData, map: &str, algorithm: &str, point: &str, metric: &str) -> BTreeMap<u32, f64> {
    data.runs
        .iter()
        .filter(|r: &&RunRow| r.map == map && r.algorithm == algorithm && r.point == point && r.status == RunStatus::Ok)
        .filter_map(|r| r.metric(metric).map(|v| (r.replicate, v)))
        .collect()
}

/// Mean and CI bounds; without a CI (n < 2, or an infinite mean) the bounds are the mean.
fn bounds(s: &Summary) -> (f64, f64) {
    if s.ci_low.is_finite() && s.ci_high.is_finite() { (s.ci_low, s.ci_high) } else { (s.mean, s.mean) }
}

fn describe(s: &Summary) -> String {
    if s.ci_low.is_finite() {
        format!("{} [{}, {}] (n = {})", sig(s.mean, 3), sig(s.ci_low, 3), sig(s.ci_high, 3), s.n)
    } else {
        format!("{} (n = {})", sig(s.mean, 3), s.n)
    }
}

/// Paired differences a − b over the replicates both cells have.
fn paired(a: &BTreeMap<u32, f64>, b: &BTreeMap<u32, f64>) -> Vec<f64> {
    a.iter().filter_map(|(r, x)| b.get(r).map(|y| x - y)).collect()
}

/// Verdict on "the mean difference is > 0" from paired differences.
fn positive(d: &[f64]) -> Verdict {
    if d.len() < 2 {
        return Verdict::Inconclusive;
    }
    if d.iter().any(|x| !x.is_finite()) {
        // e.g. nothing detected (∞ error) on one side: decide by signs
        return if d.iter().all(|&x| x > 0.0) {
            Verdict::Confirmed
        } else if d.iter().all(|&x| x < 0.0) {
            Verdict::Refuted
        } else {
            Verdict::Inconclusive
        };
    }
    let s = stats::summarize(d);
    let (lo, hi) = bounds(&s);
    if lo > 0.0 {
        Verdict::Confirmed
    } else if hi < 0.0 {
        Verdict::Refuted
    } else {
        Verdict::Inconclusive
    }
}

/// Evaluates one claim on one map.
fn on_map(data: &StudyData, claim: &ClaimSpec, cells: &ClaimCells, map: &str, algorithm: &str) -> (Verdict, String) {
    let values = |point: &Option<String>| point.as_deref().map(|p| cell_values(data, map, algorithm, p, &claim.metric)).unwrap_or_default();
    let than_algorithm = claim.than_algorithm.map_or(algorithm, |a| a.name());
    let at = values(&cells.at);
    let s_at = stats::summarize(&at.values().copied().collect::<Vec<_>>());
    match claim.test {
        ClaimTest::Above | ClaimTest::Below | ClaimTest::Between => {
            let (lo, hi) = bounds(&s_at);
            let (a, b) = match claim.test {
                ClaimTest::Above => (claim.value.unwrap_or(f64::NAN), f64::INFINITY),
                ClaimTest::Below => (f64::NEG_INFINITY, claim.value.unwrap_or(f64::NAN)),
                _ => (claim.value.unwrap_or(f64::NAN), claim.upper.unwrap_or(f64::NAN)),
            };
            let v = if s_at.n == 0 {
                Verdict::Inconclusive
            } else if lo >= a && hi <= b {
                Verdict::Confirmed
            } else if hi < a || lo > b {
                Verdict::Refuted
            } else {
                Verdict::Inconclusive
            };
            (v, describe(&s_at))
        }
        ClaimTest::Greater | ClaimTest::Less => {
            let than = cells.than.as_deref().map(|p| cell_values(data, map, than_algorithm, p, &claim.metric)).unwrap_or_default();
            let s_than = stats::summarize(&than.values().copied().collect::<Vec<_>>());
            let mut d = paired(&at, &than);
            if claim.test == ClaimTest::Less {
                d.iter_mut().for_each(|x| *x = -*x);
            }
            let diff = stats::summarize(&d);
            let v = positive(&d);
            (v, format!("{} vs {}; paired difference {}", describe(&s_at), describe(&s_than), describe(&diff)))
        }
        ClaimTest::Flat => {
            let tol = claim.tolerance.unwrap_or(0.0);
            let cells_over: Vec<(String, BTreeMap<u32, f64>)> = cells.over.iter().map(|(v, p)| (v.clone(), cell_values(data, map, algorithm, p, &claim.metric))).collect();
            let means: Vec<(String, f64)> =
                cells_over.iter().map(|(v, c)| (v.clone(), stats::summarize(&c.values().copied().collect::<Vec<_>>()).mean)).collect();
            let (lo, hi) = means.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (_, m)| (a.min(*m), b.max(*m)));
            let range = hi - lo;
            // Refuted when two cells differ by more than the tolerance with confidence.
            let beyond = cells_over.iter().enumerate().any(|(i, (_, a))| {
                cells_over[i + 1..].iter().any(|(_, b)| {
                    let d = paired(a, b);
                    let s = stats::summarize(&d);
                    let (l, h) = bounds(&s);
                    d.len() >= 2 && (l > tol || h < -tol)
                })
            });
            let v = if means.is_empty() || !range.is_finite() && !beyond {
                Verdict::Inconclusive
            } else if range <= tol {
                Verdict::Confirmed
            } else if beyond {
                Verdict::Refuted
            } else {
                Verdict::Inconclusive
            };
            let listed: Vec<String> = means.iter().map(|(v, m)| format!("{v}: {}", sig(*m, 3))).collect();
            (v, format!("means {}; range {} (tolerance {})", listed.join(", "), sig(range, 3), sig(tol, 3)))
        }
    }
}

fn combine(verdicts: &[Verdict], require: Require) -> Verdict {
    let n = verdicts.len();
    let count = |v: Verdict| verdicts.iter().filter(|x| **x == v).count();
    let (c, r) = (count(Verdict::Confirmed), count(Verdict::Refuted));
    match require {
        Require::All if n > 0 && c == n => Verdict::Confirmed,
        Require::All if r > 0 => Verdict::Refuted,
        Require::Most if 2 * c > n => Verdict::Confirmed,
        Require::Most if 2 * r >= n && n > 0 => Verdict::Refuted,
        Require::Any if c > 0 => Verdict::Confirmed,
        Require::Any if n > 0 && r == n => Verdict::Refuted,
        _ => Verdict::Inconclusive,
    }
}

/// The pooled verdict: one test over the runs of all maps (paired differences, or cell values).
fn pooled(data: &StudyData, claim: &ClaimSpec, cells: &ClaimCells, maps: &[&String], algorithm: &str) -> (Verdict, String) {
    let values = |point: &Option<String>, alg: &str| -> Vec<BTreeMap<u32, f64>> {
        maps.iter().map(|m| point.as_deref().map(|p| cell_values(data, m, alg, p, &claim.metric)).unwrap_or_default()).collect()
    };
    let at = values(&cells.at, algorithm);
    match claim.test {
        ClaimTest::Greater | ClaimTest::Less => {
            let than = values(&cells.than, claim.than_algorithm.map_or(algorithm, |a| a.name()));
            let mut d: Vec<f64> = at.iter().zip(&than).flat_map(|(a, b)| paired(a, b)).collect();
            if claim.test == ClaimTest::Less {
                d.iter_mut().for_each(|x| *x = -*x);
            }
            (positive(&d), format!("all maps pooled: paired difference {}", describe(&stats::summarize(&d))))
        }
        _ => {
            let all: Vec<f64> = at.iter().flat_map(|m| m.values().copied()).collect();
            let s = stats::summarize(&all);
            let (lo, hi) = bounds(&s);
            let (a, b) = match claim.test {
                ClaimTest::Above => (claim.value.unwrap_or(f64::NAN), f64::INFINITY),
                ClaimTest::Below => (f64::NEG_INFINITY, claim.value.unwrap_or(f64::NAN)),
                _ => (claim.value.unwrap_or(f64::NAN), claim.upper.unwrap_or(f64::NAN)),
            };
            let v = if s.n == 0 {
                Verdict::Inconclusive
            } else if lo >= a && hi <= b {
                Verdict::Confirmed
            } else if hi < a || lo > b {
                Verdict::Refuted
            } else {
                Verdict::Inconclusive
            };
            (v, format!("all maps pooled: {}", describe(&s)))
        }
    }
}

/// Evaluates every claim of a study.
pub fn evaluate(data: &StudyData) -> Vec<ClaimView> {
    let spec = &data.resolved.spec;
    spec.claims
        .iter()
        .filter_map(|claim| {
            let cells = data.resolved.claims.iter().find(|c| c.id == claim.id)?;
            let maps: Vec<&String> = if claim.maps.is_empty() { spec.maps.iter().collect() } else { claim.maps.iter().collect() };
            let algorithm = claim.algorithm.or(spec.algorithms.first().copied())?;
            let per_map: Vec<(Verdict, String)> = maps.iter().map(|m| on_map(data, claim, cells, m, algorithm.name())).collect();
            let verdicts: Vec<Verdict> = per_map.iter().map(|(v, _)| *v).collect();
            let pooled = (claim.require == Require::Pooled && claim.test != ClaimTest::Flat).then(|| pooled(data, claim, cells, &maps, algorithm.name()));
            let verdict = match &pooled {
                Some((v, _)) => *v,
                None => combine(&verdicts, if claim.require == Require::Pooled { Require::All } else { claim.require }),
            };
            let count = |v: Verdict| verdicts.iter().filter(|x| **x == v).count();
            let require = match claim.require {
                Require::All => "all maps",
                Require::Most => "most maps",
                Require::Any => "any map",
                Require::Pooled if claim.test == ClaimTest::Flat => "all maps",
                Require::Pooled => "all maps pooled",
            };
            let mut evidence: Vec<String> = maps.iter().zip(&per_map).map(|(m, (v, e))| format!("{m}: {} — {e}", v.as_str())).collect();
            if let Some((v, e)) = &pooled {
                evidence.push(format!("{} — {e}", v.as_str()));
            }
            Some(ClaimView {
                id: claim.id.clone(),
                source: claim.source.clone(),
                text: claim.text.clone(),
                test: test_text(claim, cells),
                verdict: verdict.as_str().to_string(),
                summary: format!(
                    "Required on {require}; of {} maps: {} confirmed, {} refuted, {} inconclusive",
                    verdicts.len(),
                    count(Verdict::Confirmed),
                    count(Verdict::Refuted),
                    count(Verdict::Inconclusive)
                ),
                evidence,
            })
        })
        .collect()
}

/// A cell as the claim wrote it: `a.b = 1, c.d = 2`, or "base".
fn cell_text(t: &toml::Table) -> String {
    let mut leaves = Vec::new();
    crate::spec::params::flatten("", &toml::Value::Table(t.clone()), &mut leaves);
    if leaves.is_empty() {
        return "base".into();
    }
    leaves.iter().map(|(k, v)| format!("{k} = {}", crate::plan::format_value(v))).collect::<Vec<_>>().join(", ")
}

/// The test in words.
fn test_text(c: &ClaimSpec, cells: &ClaimCells) -> String {
    let at = cell_text(&c.at);
    let metric = &c.metric;
    let v = |x: Option<f64>| x.map_or("?".into(), |x| sig(x, 3));
    match c.test {
        ClaimTest::Above => format!("{metric} at {at} above {} (95 % CI)", v(c.value)),
        ClaimTest::Below => format!("{metric} at {at} below {} (95 % CI)", v(c.value)),
        ClaimTest::Between => format!("{metric} at {at} within [{}, {}] (95 % CI)", v(c.value), v(c.upper)),
        ClaimTest::Greater | ClaimTest::Less => {
            let than = match c.than_algorithm {
                Some(a) if c.than.is_empty() => format!("that of {}", a.title()),
                Some(a) => format!("{} at {}", a.title(), cell_text(&c.than)),
                None => format!("at {}", cell_text(&c.than)),
            };
            let _ = cells;
            let who = c.algorithm.map_or(String::new(), |a| format!(" of {}", a.title()));
            let word = if c.test == ClaimTest::Greater { "greater" } else { "less" };
            format!("{metric}{who} at {at} {word} than {than} (paired 95 % CI)")
        }
        ClaimTest::Flat => {
            let over: Vec<&str> = cells.over.iter().map(|(v, _)| v.as_str()).collect();
            format!("{metric} flat within {} over {} ∈ {{{}}}", v(c.tolerance), c.over.keys().next().cloned().unwrap_or_default(), over.join(", "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paired_differences_decide_direction() {
        assert_eq!(positive(&[0.5, 0.6, 0.4, 0.55]), Verdict::Confirmed);
        assert_eq!(positive(&[-0.5, -0.6, -0.4, -0.55]), Verdict::Refuted);
        assert_eq!(positive(&[0.5, -0.6, 0.4, -0.55]), Verdict::Inconclusive);
        assert_eq!(positive(&[f64::INFINITY, 0.2, 0.1]), Verdict::Confirmed);
        assert_eq!(positive(&[0.3]), Verdict::Inconclusive);
    }

    #[test]
    fn combining_maps() {
        use Verdict::*;
        assert_eq!(combine(&[Confirmed, Confirmed], Require::All), Confirmed);
        assert_eq!(combine(&[Confirmed, Refuted], Require::All), Refuted);
        assert_eq!(combine(&[Confirmed, Inconclusive], Require::All), Inconclusive);
        assert_eq!(combine(&[Confirmed, Confirmed, Refuted], Require::Most), Confirmed);
        assert_eq!(combine(&[Refuted, Refuted, Confirmed, Confirmed], Require::Most), Refuted);
        assert_eq!(combine(&[Refuted, Inconclusive, Confirmed], Require::Any), Confirmed);
    }
}
