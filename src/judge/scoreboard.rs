//! The fidelity scoreboard: every published result item of the reference works
//! (`data/reference/published-results.toml`) classified MATCH / TREND / DISAGREE / MISSING from the
//! studies' runs, and every claim's verdict tallied per reference work and per kind.
//!
//! The rule, decided before looking at any number and applied to every item alike:
//! - An item answered by **published cells**: each cell is judged by [`super::agreement`] (Welch
//!   against the published variance, or a prediction interval for the published runs).
//!   MATCH when at least half of the judged cells are compatible ([`MATCH_SHARE`]). Otherwise
//!   TREND when ours follow the published ordering: the mean Spearman rank correlation of
//!   published and ours over each (map, algorithm, metric) series of ≥ 3 cells is at least
//!   [`TREND_RHO`] (over all the item's cells of a metric when no series has 3); else DISAGREE.
//! - An item answered by **claims**: MATCH when every testable claim is confirmed; DISAGREE when
//!   one is refuted, or one is inconclusive with its point estimate on the wrong side; TREND when
//!   the non-confirmed ones are inconclusive with the point estimate on the claimed side;
//!   MISSING when every claim is untestable.
//! - An item with **no counterpart**: MISSING, with the reason.

use super::agreement::{self, Published};
use super::claims::{ClaimResult, Verdict};
use crate::stats::compare::spearman;
use crate::stats::sig;
use crate::store::reference::{ReferenceRow, cell_metric_name};
use crate::store::{ParamValue, StudyData};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Share of compatible cells from which an item MATCHes.
pub const MATCH_SHARE: f64 = 0.5;
/// Mean Spearman ρ from which an item that does not match follows the published TREND.
pub const TREND_RHO: f64 = 0.5;

/// `published-results.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ItemsFile {
    pub item: Vec<Item>,
}

/// One published result item.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Item {
    pub id: String,
    pub seed: String,
    pub source: String,
    pub result: String,
    #[serde(default)]
    pub study: Option<String>,
    #[serde(default)]
    pub cells: Option<CellSelector>,
    #[serde(default)]
    pub claims: Vec<String>,
    #[serde(default)]
    pub missing: Option<String>,
}

/// Which published numbers answer an item (rows of the study's reference file).
#[derive(Debug, Clone, PartialEq, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CellSelector {
    pub file: String,
    /// Wide layout: the experiment(s).
    #[serde(default)]
    pub experiment: Option<String>,
    #[serde(default)]
    pub experiments: Vec<String>,
    #[serde(default)]
    pub values: Vec<f64>,
    /// Long layout: the table, stat (`mean` or `max`; both when absent), algorithms and named cells.
    #[serde(default)]
    pub table: Option<String>,
    #[serde(default)]
    pub stat: Option<String>,
    #[serde(default)]
    pub algorithms: Vec<String>,
    #[serde(default)]
    pub cells: Vec<String>,
    #[serde(default)]
    pub maps: Vec<String>,
    pub metrics: Vec<String>,
}

/// Parses the items file; errors name the item and key.
pub fn parse_items(text: &str) -> Result<Vec<Item>, String> {
    let f: ItemsFile = toml::from_str(text).map_err(|e| e.to_string())?;
    for (i, it) in f.item.iter().enumerate() {
        let answers = it.cells.is_some() as usize
            + (!it.claims.is_empty()) as usize
            + it.missing.is_some() as usize;
        if answers != 1 {
            return Err(format!(
                "item[{i}] ({}): needs exactly one of `cells`, `claims` or `missing`",
                it.id
            ));
        }
        if (it.cells.is_some() || !it.claims.is_empty()) && it.study.is_none() {
            return Err(format!(
                "item[{i}] ({}): `cells` and `claims` need the `study` that answers them",
                it.id
            ));
        }
        if f.item[..i].iter().any(|o| o.id == it.id) {
            return Err(format!("item[{i}]: id `{}` is used twice", it.id));
        }
    }
    Ok(f.item)
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Class {
    Match,
    Trend,
    Disagree,
    Missing,
}

impl Class {
    pub const ALL: [Class; 4] = [Class::Match, Class::Trend, Class::Disagree, Class::Missing];
    pub fn as_str(self) -> &'static str {
        match self {
            Class::Match => "MATCH",
            Class::Trend => "TREND",
            Class::Disagree => "DISAGREE",
            Class::Missing => "MISSING",
        }
    }
}

/// How an item judged on a study's published cells came out: a study's report keeps these
/// (`items.json`), so that a kept report (a study without results here) contributes its items to
/// the scoreboard as it contributes its claims.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CellVerdict {
    pub id: String,
    pub class: Class,
    pub basis: String,
}

/// The cell items of `study` among `classified` (in the order of `items`).
pub fn cell_verdicts(items: &[Item], classified: &[ItemResult], study: &str) -> Vec<CellVerdict> {
    items
        .iter()
        .zip(classified)
        .filter(|(it, r)| it.cells.is_some() && it.missing.is_none() && r.study == study)
        .map(|(_, r)| CellVerdict { id: r.id.clone(), class: r.class, basis: r.basis.clone() })
        .collect()
}

/// An item with its class and the numbers behind it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ItemResult {
    pub id: String,
    pub seed: String,
    pub source: String,
    pub result: String,
    pub study: String,
    pub class: Class,
    /// How it was classified, with the numbers.
    pub basis: String,
}

/// The sweep point that a published row describes (see [`point_in`]).
pub fn point_of(data: &StudyData, row: &ReferenceRow) -> Option<String> {
    let base = toml::Table::try_from(&data.resolved.spec.base).unwrap_or_default();
    point_in(&data.resolved.points, &base, row)
}

/// The sweep point of `points` that a published row describes: the named cell (long layout); else
/// (wide layout) the first point that sets the row's parameter to the row's value, or, when that
/// value is the base one, a point of the base configuration (every value it sets equals the
/// base's) — never a point that varies another parameter.
pub fn point_in(
    points: &[crate::store::PointRecord],
    base: &toml::Table,
    row: &ReferenceRow,
) -> Option<String> {
    if !row.cell.is_empty() {
        return points.iter().find(|p| p.label == row.cell).map(|p| p.label.clone());
    }
    let close = |v: &toml::Value| {
        ParamValue::from_toml(v).as_f64().is_some_and(|v| {
            v == row.value || (v - row.value).abs() <= 1e-9 * row.value.abs().max(1.0)
        })
    };
    if let Some(p) = points.iter().find(|p| p.assignments.get(&row.parameter).is_some_and(close)) {
        return Some(p.label.clone());
    }
    let mut leaves = Vec::new();
    crate::params::flatten("", &toml::Value::Table(base.clone()), &mut leaves);
    if !leaves.iter().any(|(k, v)| *k == row.parameter && close(v)) {
        return None;
    }
    let at_base = |k: &str, v: &toml::Value| leaves.iter().any(|(b, bv)| b == k && bv == v);
    points
        .iter()
        .find(|p| p.assignments.iter().all(|(k, v)| at_base(k, v)))
        .map(|p| p.label.clone())
}

/// Our successful replicates' values of `metric` in the cell a published row describes (the
/// study's first algorithm for a wide-layout row).
pub fn our_values(data: &StudyData, row: &ReferenceRow, metric: &str) -> Option<Vec<f64>> {
    let point = point_of(data, row)?;
    let algorithm = if row.algorithm.is_empty() {
        data.resolved.spec.algorithms.first()?.to_string()
    } else {
        row.algorithm.clone()
    };
    let v: Vec<f64> =
        data.replicate_values(&row.map, &algorithm, &point, metric).into_values().collect();
    (!v.is_empty()).then_some(v)
}

/// The published number of `metric` in `row` with its spread.
pub fn published(data: &StudyData, row: &ReferenceRow, metric: &str) -> Option<Published> {
    let mean = row.metric(metric)?;
    let runs = data.resolved.spec.report.reference.as_ref().map_or(1, |r| r.runs);
    Some(Published { mean, var: row.metric(&format!("{metric}_var")), runs })
}

fn selected<'a>(data: &'a StudyData, sel: &CellSelector) -> Vec<(&'a ReferenceRow, String)> {
    let mut experiments = sel.experiments.clone();
    experiments.extend(sel.experiment.clone());
    let mut out = Vec::new();
    for row in &data.reference {
        let long = !row.cell.is_empty();
        let ok = if long {
            sel.table.as_deref().is_none_or(|t| t == row.table)
                && (sel.algorithms.is_empty() || sel.algorithms.contains(&row.algorithm))
                && (sel.cells.is_empty() || sel.cells.contains(&row.cell))
        } else {
            (experiments.is_empty() || experiments.contains(&row.experiment))
                && (sel.values.is_empty()
                    || sel.values.iter().any(|v| (v - row.value).abs() <= 1e-9 * v.abs().max(1.0)))
        };
        if !ok || !(sel.maps.is_empty() || sel.maps.contains(&row.map)) {
            continue;
        }
        // Long layout: the stat named, or both when none is.
        let stats: Vec<&str> = match sel.stat.as_deref() {
            Some(s) => vec![s],
            None => vec!["mean", "max"],
        };
        for m in &sel.metrics {
            let names: Vec<String> = if long {
                stats.iter().map(|s| cell_metric_name(m, s)).collect()
            } else {
                vec![m.clone()]
            };
            for name in names {
                if row.metric(&name).is_some() {
                    out.push((row, name));
                }
            }
        }
    }
    out
}

/// Classifies an item answered by published cells.
fn classify_cells(data: &StudyData, sel: &CellSelector) -> (Class, String) {
    let rows = selected(data, sel);
    // series key (map, algorithm, metric) → (published, ours mean)
    let mut series: BTreeMap<(String, String, String), Vec<(f64, f64)>> = BTreeMap::new();
    let (mut compatible, mut judged) = (0usize, 0usize);
    for (row, metric) in &rows {
        let (Some(p), Some(ours)) = (published(data, row, metric), our_values(data, row, metric))
        else {
            continue;
        };
        let a = agreement::judge(p, &ours);
        if let Some(c) = a.compatible {
            judged += 1;
            compatible += c as usize;
        }
        let mean = ours.iter().sum::<f64>() / ours.len() as f64;
        series
            .entry((row.map.clone(), row.algorithm.clone(), metric.clone()))
            .or_default()
            .push((p.mean, mean));
    }
    if judged == 0 {
        return (
            Class::Missing,
            format!(
                "none of the {} selected published cells has a counterpart with ≥ 2 replicates",
                rows.len()
            ),
        );
    }
    let share = compatible as f64 / judged as f64;
    let rho_of = |s: &[(f64, f64)]| {
        spearman(
            &s.iter().map(|x| x.0).collect::<Vec<_>>(),
            &s.iter().map(|x| x.1).collect::<Vec<_>>(),
        )
    };
    let mut rhos: Vec<f64> = series
        .values()
        .filter(|s| s.len() >= 3)
        .map(|s| rho_of(s))
        .filter(|r| r.is_finite())
        .collect();
    let mut scope = "series";
    if rhos.is_empty() {
        // no series of 3: one ordering per metric over the item's cells
        let mut by_metric: BTreeMap<&str, Vec<(f64, f64)>> = BTreeMap::new();
        for ((_, _, m), s) in &series {
            by_metric.entry(m.as_str()).or_default().extend(s);
        }
        rhos = by_metric
            .values()
            .filter(|s| s.len() >= 3)
            .map(|s| rho_of(s))
            .filter(|r| r.is_finite())
            .collect();
        scope = "metric";
    }
    let rho = if rhos.is_empty() { f64::NAN } else { rhos.iter().sum::<f64>() / rhos.len() as f64 };
    let class = if share >= MATCH_SHARE {
        Class::Match
    } else if rho >= TREND_RHO {
        Class::Trend
    } else {
        Class::Disagree
    };
    let rho_text = if rho.is_nan() {
        "no ordering to compare".to_string()
    } else {
        format!("mean Spearman ρ {} over {} {scope} orderings", sig(rho, 2), rhos.len())
    };
    (
        class,
        format!("{compatible} of {judged} cells compatible with the published spread; {rho_text}"),
    )
}

/// Classifies an item answered by claims.
fn classify_claims(ids: &[String], claims: &[&ClaimResult]) -> (Class, String) {
    let found: Vec<&&ClaimResult> =
        ids.iter().filter_map(|id| claims.iter().find(|c| &c.id == id)).collect();
    let listed = found
        .iter()
        .map(|c| format!("{}: {}", c.id, c.verdict.as_str()))
        .collect::<Vec<_>>()
        .join("; ");
    if found.len() != ids.len() {
        let absent: Vec<&String> =
            ids.iter().filter(|id| !claims.iter().any(|c| &c.id == *id)).collect();
        return (
            Class::Missing,
            format!(
                "claims not evaluated: {}",
                absent.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
            ),
        );
    }
    let testable: Vec<&&ClaimResult> =
        found.iter().copied().filter(|c| c.verdict != Verdict::Untestable).collect();
    let class = if testable.is_empty() {
        Class::Missing
    } else if testable.iter().all(|c| c.verdict == Verdict::Confirmed) {
        Class::Match
    } else if testable.iter().any(|c| {
        c.verdict == Verdict::Refuted
            || (c.verdict == Verdict::Inconclusive && c.direction_agrees != Some(true))
    }) {
        Class::Disagree
    } else {
        Class::Trend
    };
    (class, listed)
}

/// Classifies every item. `studies` are the studies with runs; `claims` every judged claim
/// (including those of studies whose report was kept without runs).
/// Classifies every item: on the studies' results, their claims, and — for a study without
/// results here whose report is kept — the cell verdicts that report kept (`kept`).
pub fn classify(
    items: &[Item],
    studies: &BTreeMap<String, &StudyData>,
    claims: &[ClaimResult],
    kept: &[CellVerdict],
) -> Vec<ItemResult> {
    items
        .iter()
        .map(|it| {
            let study = it.study.clone().unwrap_or_default();
            let (class, basis) = if let Some(why) = &it.missing {
                (Class::Missing, format!("no counterpart: {why}"))
            } else if let Some(sel) = &it.cells {
                match (studies.get(&study), kept.iter().find(|k| k.id == it.id)) {
                    (Some(data), _) => classify_cells(data, sel),
                    (None, Some(k)) => (k.class, k.basis.clone()),
                    (None, None) => (Class::Missing, format!("study {study} has no results here")),
                }
            } else {
                let of_study: Vec<&ClaimResult> =
                    claims.iter().filter(|c| c.study == study).collect();
                classify_claims(&it.claims, &of_study)
            };
            ItemResult {
                id: it.id.clone(),
                seed: it.seed.clone(),
                source: it.source.clone(),
                result: it.result.clone(),
                study,
                class,
                basis,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn claim(id: &str, verdict: Verdict, direction: Option<bool>) -> ClaimResult {
        ClaimResult {
            study: "s".into(),
            id: id.into(),
            source: "[FT]".into(),
            seed: "FT".into(),
            kind: "seed".into(),
            text: String::new(),
            test: String::new(),
            verdict,
            summary: String::new(),
            evidence: Vec::new(),
            direction_agrees: direction,
            why: String::new(),
            cause: String::new(),
        }
    }

    #[test]
    fn claims_classify_items() {
        let ids = vec!["a".to_string(), "b".to_string()];
        let c = |va, da, vb, db| {
            let (x, y) = (claim("a", va, da), claim("b", vb, db));
            classify_claims(&ids, &[&x, &y]).0
        };
        use Verdict::*;
        assert_eq!(c(Confirmed, Some(true), Confirmed, Some(true)), Class::Match);
        assert_eq!(c(Confirmed, Some(true), Refuted, Some(false)), Class::Disagree);
        assert_eq!(c(Confirmed, Some(true), Inconclusive, Some(true)), Class::Trend);
        assert_eq!(c(Confirmed, Some(true), Inconclusive, Some(false)), Class::Disagree);
        assert_eq!(c(Untestable, None, Untestable, None), Class::Missing);
        assert_eq!(c(Untestable, None, Confirmed, Some(true)), Class::Match);
        let x = claim("a", Confirmed, Some(true));
        assert_eq!(classify_claims(&ids, &[&x]).0, Class::Missing);
    }

    /// A published row at the base value of a parameter whose sweep omits it describes the base
    /// configuration — here the σρ² sweep's base point — not the first point that merely leaves
    /// the parameter at base while varying another (σρ² = 1e-4).
    #[test]
    fn a_base_valued_row_maps_to_the_base_configuration() {
        let point = |label: &str, k: &str, v: f64| crate::store::PointRecord {
            label: label.into(),
            groups: vec![0],
            assignments: [(k.to_string(), toml::Value::Float(v))].into_iter().collect(),
        };
        let rho = "fastslam.obs_var_rho_m2";
        let theta = "fastslam.obs_var_theta_rad2";
        let points = vec![
            point("rho-small", rho, 1e-4),
            point("rho-base", rho, 0.04),
            point("theta-small", theta, 1e-4),
        ];
        let base: toml::Table =
            toml::from_str("[fastslam]\nobs_var_rho_m2 = 0.04\nobs_var_theta_rad2 = 0.001224\n")
                .unwrap();
        let row = |param: &str, value: f64| ReferenceRow {
            experiment: "e".into(),
            table: "t".into(),
            map: "m".into(),
            parameter: param.into(),
            value,
            metrics: Vec::new(),
            algorithm: String::new(),
            cell: String::new(),
        };
        assert_eq!(point_in(&points, &base, &row(theta, 0.001224)).as_deref(), Some("rho-base"));
        assert_eq!(point_in(&points, &base, &row(theta, 1e-4)).as_deref(), Some("theta-small"));
        assert_eq!(point_in(&points, &base, &row(theta, 0.5)), None, "no counterpart");
    }

    #[test]
    fn items_need_one_answer() {
        let ok = "[[item]]\nid = \"A\"\nseed = \"FT\"\nsource = \"L1\"\nresult = \"r\"\nmissing = \"not run\"\n";
        assert_eq!(parse_items(ok).unwrap().len(), 1);
        let two = format!("{ok}claims = [\"x\"]\nstudy = \"s\"\n");
        assert!(parse_items(&two).unwrap_err().contains("exactly one"));
        let no_study = "[[item]]\nid = \"A\"\nseed = \"FT\"\nsource = \"L1\"\nresult = \"r\"\nclaims = [\"x\"]\n";
        assert!(parse_items(no_study).unwrap_err().contains("study"));
        assert!(parse_items(&format!("{ok}{ok}")).unwrap_err().contains("twice"));
    }
}
