//! The timing page of a scan-matching study: stored per-match CPU times → `timings.html`, written
//! beside the results (`data/results/<study>/timings.html`), never into `reports/`, because times
//! depend on the machine and the committed reports must be byte-identical.
//!
//! It shows the median time per match of every algorithm in every cell beside the published mean
//! time ([EP]'s time rows), and every cost claim of the study (a claim on `evals_mean` comparing
//! two algorithms) re-read on time: the ratio of the two median times against the claim's bound.
//! The verdicts of the report proper are judged on evaluation counts, which are deterministic.

use crate::spec::ClaimTest;
use crate::stats::sig;
use crate::store::{MatchRows, RunStatus, StudyData};
use serde::Serialize;
use std::collections::BTreeMap;

/// The metric cost claims are stated on.
pub const COST_METRIC: &str = "evals_mean";

#[derive(Debug, Clone, Serialize)]
pub struct TimingPage {
    pub id: String,
    pub title: String,
    /// Runs whose matches are timed, and how many of them were taken from the cache.
    pub runs: usize,
    pub matches: usize,
    /// One table per map: rows = sweep points, columns = algorithms.
    pub tables: Vec<TimingTable>,
    pub checks: Vec<CostCheck>,
}

#[derive(Debug, Clone, Serialize)]
pub struct TimingTable {
    pub map: String,
    pub algorithms: Vec<String>,
    /// (point label, one entry per algorithm: "median ms (published ms)").
    pub rows: Vec<(String, Vec<String>)>,
}

/// A cost claim re-read on time, on one map.
#[derive(Debug, Clone, Serialize)]
pub struct CostCheck {
    pub claim: String,
    pub text: String,
    pub map: String,
    /// "E-PSM / PSM at odo10" and the bound, e.g. "> 24".
    pub ratio_of: String,
    pub bound: String,
    pub time_ratio: String,
    pub evals_ratio: String,
    pub published_ratio: String,
    /// "holds", "does not hold", or "no times".
    pub on_time: String,
}

/// Median per-match time [ms] and mean evaluations of the successful runs' matches, per (map,
/// algorithm, point).
type Cells = BTreeMap<(String, String, String), (f64, f64, usize)>;

/// The cells, and how many runs had timed matches.
fn cells(data: &StudyData, matches: &[MatchRows]) -> (Cells, usize) {
    let by_run: BTreeMap<&str, &MatchRows> =
        matches.iter().map(|m| (m.run_id.as_str(), m)).collect();
    let mut times: BTreeMap<(String, String, String), (Vec<f64>, Vec<f64>)> = BTreeMap::new();
    let mut runs = 0;
    for run in data.runs.iter().filter(|r| r.status == RunStatus::Ok) {
        let Some(m) = by_run.get(run.run_id.as_str()).filter(|m| !m.matches.is_empty()) else {
            continue;
        };
        runs += 1;
        let entry =
            times.entry((run.map.clone(), run.algorithm.clone(), run.point.clone())).or_default();
        for record in &m.matches {
            entry.0.push(record.time_s * 1e3);
            entry.1.push(record.evaluations as f64);
        }
    }
    let cells = times
        .into_iter()
        .map(|(k, (t, e))| {
            let n = t.len();
            (k, (crate::metrics::median(&t), e.iter().sum::<f64>() / n as f64, n))
        })
        .collect();
    (cells, runs)
}

/// The page, or `None` when the study has no timed matches.
pub fn build(data: &StudyData, matches: &[MatchRows]) -> Option<TimingPage> {
    let (cells, runs) = cells(data, matches);
    if cells.is_empty() {
        return None;
    }
    let spec = &data.resolved.spec;
    let catalogue = data.resolved.catalogue();
    // the published mean time per match [ms] (one reference row per number)
    let published = |map: &str, algorithm: &str, point: &str| {
        data.reference
            .iter()
            .filter(|r| r.map == map && r.algorithm == algorithm && r.cell == point)
            .find_map(|r| r.metric("time_mean_s"))
            .map(|s| s * 1e3)
    };
    let points: Vec<String> = data.resolved.points.iter().map(|p| p.label.clone()).collect();
    let tables = spec
        .maps
        .iter()
        .map(|map| {
            let algorithms: Vec<String> = spec
                .algorithms
                .iter()
                .map(|a| a.to_string())
                .filter(|a| {
                    points.iter().any(|p| cells.contains_key(&(map.clone(), a.clone(), p.clone())))
                })
                .collect();
            let rows = points
                .iter()
                .map(|p| {
                    let entries = algorithms
                        .iter()
                        .map(|a| {
                            let ours = cells
                                .get(&(map.clone(), a.clone(), p.clone()))
                                .map_or("—".to_string(), |c| sig(c.0, 3));
                            match published(map, a, p) {
                                Some(ms) => format!("{ours} ({})", sig(ms, 3)),
                                None => ours,
                            }
                        })
                        .collect();
                    (p.clone(), entries)
                })
                .collect();
            TimingTable { map: map.clone(), algorithms, rows }
        })
        .collect();
    let mut checks = Vec::new();
    for claim in spec.claims.iter().filter(|c| c.metric == COST_METRIC) {
        let (Some(a), Some(b)) = (
            claim.algorithm.as_ref().or(spec.algorithms.first()).map(|a| catalogue.algorithm(a)),
            claim.than_algorithm.as_ref().map(|a| catalogue.algorithm(a)),
        ) else {
            continue;
        };
        let Some(cells_of) = data.resolved.claims.iter().find(|c| c.id == claim.id) else {
            continue;
        };
        // the claim's cell, or every cell for a claim across cells
        let pairs: Vec<(String, String)> = match (&cells_of.at, claim.across) {
            (_, crate::spec::Across::Cells) => {
                data.resolved.points.iter().map(|p| (p.label.clone(), p.label.clone())).collect()
            }
            (Some(at), _) => {
                vec![(at.clone(), cells_of.than.clone().unwrap_or_else(|| at.clone()))]
            }
            (None, _) => continue,
        };
        if !matches!(
            claim.test,
            ClaimTest::Greater | ClaimTest::Less | ClaimTest::NotGreater | ClaimTest::NotLess
        ) {
            continue;
        }
        let maps: Vec<&String> = if claim.maps.is_empty() {
            spec.maps.iter().collect()
        } else {
            claim.maps.iter().collect()
        };
        for (map, (at, than)) in maps.iter().flat_map(|m| pairs.iter().map(move |p| (*m, p))) {
            let x = cells.get(&(map.clone(), a.name().to_string(), at.clone()));
            let y = cells.get(&(map.clone(), b.name().to_string(), than.clone()));
            // the claim's minimum effect as a ratio: relative, or an absolute one over the
            // compared cell's evaluations (as the report judges it, on evaluations)
            let rel = match (claim.min_effect, y) {
                (Some(m), Some(y)) if y.1 > 0.0 => m / y.1,
                _ => claim.min_effect_rel.unwrap_or(0.05),
            };
            let (bound, holds): (String, Box<dyn Fn(f64) -> bool>) = match claim.test {
                ClaimTest::Greater => {
                    (format!("> {}", sig(1.0 + rel, 3)), Box::new(move |r| r > 1.0 + rel))
                }
                ClaimTest::Less => {
                    (format!("< {}", sig(1.0 - rel, 3)), Box::new(move |r| r < 1.0 - rel))
                }
                ClaimTest::NotGreater => {
                    (format!("≤ {}", sig(1.0 + rel, 3)), Box::new(move |r| r <= 1.0 + rel))
                }
                _ => (format!("≥ {}", sig(1.0 - rel, 3)), Box::new(move |r| r >= 1.0 - rel)),
            };
            let ratio = |f: fn(&(f64, f64, usize)) -> f64| match (x, y) {
                (Some(x), Some(y)) if f(y) > 0.0 => Some(f(x) / f(y)),
                _ => None,
            };
            let time_ratio = ratio(|c| c.0);
            let published_ratio =
                match (published(map, a.name(), &at), published(map, b.name(), &than)) {
                    (Some(p), Some(q)) if q > 0.0 => sig(p / q, 3),
                    _ => "—".into(),
                };
            checks.push(CostCheck {
                claim: claim.id.clone(),
                text: claim.text.clone(),
                map: map.clone(),
                ratio_of: format!("{} at {at} / {} at {than}", a.title(), b.title()),
                bound,
                time_ratio: time_ratio.map_or("—".into(), |r| sig(r, 3)),
                evals_ratio: ratio(|c| c.1).map_or("—".into(), |r| sig(r, 3)),
                published_ratio,
                on_time: match time_ratio {
                    Some(r) if holds(r) => "holds".into(),
                    Some(_) => "does not hold".into(),
                    None => "no times".into(),
                },
            });
        }
    }
    Some(TimingPage {
        id: spec.id.clone(),
        title: spec.title.clone(),
        runs,
        matches: cells.values().map(|c| c.2).sum(),
        tables,
        checks,
    })
}
