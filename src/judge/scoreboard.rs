//! The fidelity scoreboard: every published result item of the reference works
//! (`data/reference/published-results.toml`) classified MATCH / TREND / DISAGREE / UNRESOLVED /
//! CALIBRATED / MISSING from the studies' runs, and every claim's verdict tallied per reference
//! work and per kind.
//!
//! The rule, fixed before the scoreboard was regenerated under it (2026-11-26, issue 25), applied
//! to every item alike:
//! - An item answered by **published cells**: each cell is shown equivalent, shown different or
//!   unresolved within its work's margin ([`super::agreement`], [`super::margins`]). Where the
//!   item is about an effect along an axis (the swept parameter, or the algorithms compared), its
//!   **trend** is scored per series along that axis: a series that does not move (range within
//!   the margin) is "no effect", which agrees with a published series that does not move (1) and
//!   contradicts one that does (0); two moving series score their Spearman ρ. Then:
//!   - MATCH when at least half the judged cells are shown equivalent ([`MATCH_SHARE`]) and the
//!     trend, if the item has one, scores at least [`TREND_RHO`];
//!   - TREND when the trend scores at least [`TREND_RHO`] (the shape, not the levels);
//!   - DISAGREE when the trend scores below it, or, for an item without a trend, when at least
//!     half the judged cells are shown different;
//!   - UNRESOLVED otherwise: neither shown equivalent nor shown different, with the replicates
//!     that would resolve the cells at the observed spread.
//! - An item answered by **claims**: CALIBRATED when every claim is a calibration (true by
//!   construction, never a MATCH); MATCH when every testable claim is confirmed; DISAGREE when
//!   one is refuted; TREND when the rest are inconclusive with the point estimate on the claimed
//!   side; UNRESOLVED when one is inconclusive with it on the other side; MISSING when every claim
//!   is untestable.
//! - An item with **no counterpart**: MISSING, with the reason.

use super::agreement::{self, Needed, Outcome, Published};
use super::claims::{ClaimResult, Verdict};
use super::margins::{self, WorkMargins};
use crate::stats::compare::spearman;
use crate::stats::sig;
use crate::store::reference::{ReferenceRow, cell_metric_name};
use crate::store::{ParamValue, StudyData};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub use crate::spec::items::{Axis, CellSelector, Item, ItemsFile, parse_items};

/// Share of cells shown equivalent from which an item MATCHes.
pub const MATCH_SHARE: f64 = 0.5;
/// Mean trend score (Spearman ρ; 1 or 0 for series that do not move) from which an item follows
/// the published trend.
pub const TREND_RHO: f64 = 0.5;

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Class {
    Match,
    Trend,
    Disagree,
    Unresolved,
    Calibrated,
    Missing,
}

impl Class {
    pub const ALL: [Class; 6] = [
        Class::Match,
        Class::Trend,
        Class::Disagree,
        Class::Unresolved,
        Class::Calibrated,
        Class::Missing,
    ];
    pub fn as_str(self) -> &'static str {
        match self {
            Class::Match => "MATCH",
            Class::Trend => "TREND",
            Class::Disagree => "DISAGREE",
            Class::Unresolved => "UNRESOLVED",
            Class::Calibrated => "CALIBRATED",
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

/// One published cell of an item: (index of its row in the study's reference rows, metric).
pub type ItemCell = (usize, String);

/// The rows (with their indices) and metrics an item's selector picks.
fn selected<'a>(data: &'a StudyData, sel: &CellSelector) -> Vec<(usize, &'a ReferenceRow, String)> {
    let mut experiments = sel.experiments.clone();
    experiments.extend(sel.experiment.clone());
    let mut out = Vec::new();
    for (index, row) in data.reference.iter().enumerate() {
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
                    out.push((index, row, name));
                }
            }
        }
    }
    out
}

/// A series' trend score against the published one: 1 when neither moves beyond the margin
/// around its level, 0 when one moves and the other does not, else Spearman's ρ (0 when
/// undefined).
pub fn trend_score(published: &[f64], ours: &[f64], relative: f64) -> f64 {
    let moves = |v: &[f64]| {
        let (lo, hi) =
            v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(*x), b.max(*x)));
        let level = v.iter().map(|x| x.abs()).sum::<f64>() / v.len() as f64;
        hi - lo > relative * level
    };
    match (moves(published), moves(ours)) {
        (false, false) => 1.0,
        (true, true) => {
            let rho = spearman(published, ours);
            if rho.is_finite() { rho } else { 0.0 }
        }
        _ => 0.0,
    }
}

/// One published cell of an item with our replicates in its counterpart.
#[derive(Debug, Clone)]
pub struct CellData {
    pub key: ItemCell,
    pub published: Published,
    pub ours: Vec<f64>,
    /// The margin ε of its work for this metric and published value.
    pub eps: f64,
    /// Our cell it is compared with: (map, algorithm, sweep point).
    pub run_cell: (String, String, String),
}

/// The published cells an item's selector picks that have a counterpart among our runs.
pub fn item_cells(data: &StudyData, sel: &CellSelector, work: &WorkMargins) -> Vec<CellData> {
    selected(data, sel)
        .into_iter()
        .filter_map(|(index, row, metric)| {
            let p = published(data, row, &metric)?;
            let ours = our_values(data, row, &metric)?;
            let point = point_of(data, row)?;
            let algorithm = if row.algorithm.is_empty() {
                data.resolved.spec.algorithms.first()?.to_string()
            } else {
                row.algorithm.clone()
            };
            Some(CellData {
                eps: work.margin(&metric, p.mean),
                key: (index, metric),
                published: p,
                ours,
                run_cell: (row.map.clone(), algorithm, point),
            })
        })
        .collect()
}

/// How each cell of an item is judged: the fixed design's [`agreement::judge`], or a sequential
/// study's look ([`super::sequential`]).
pub type CellJudge<'a> = dyn Fn(&CellData) -> agreement::Agreement + 'a;

/// Classifies an item answered by published cells, within the margins of its work.
fn classify_cells(data: &StudyData, sel: &CellSelector, work: &WorkMargins) -> (Class, String) {
    classify_cells_with(data, sel, work, &|c| agreement::judge(c.published, &c.ours, c.eps))
}

/// [`classify_cells`] with each cell judged by `judge`.
pub fn classify_cells_with(
    data: &StudyData,
    sel: &CellSelector,
    work: &WorkMargins,
    judge: &CellJudge,
) -> (Class, String) {
    let rows = selected(data, sel);
    let long = rows.first().is_some_and(|(_, r, _)| !r.cell.is_empty());
    let axis = sel.axis.unwrap_or(if long { Axis::None } else { Axis::Value });
    // series key (the cell's coordinates off the axis, metric) → (published, ours mean)
    let mut series: BTreeMap<(String, String, String), Vec<(f64, f64)>> = BTreeMap::new();
    let (mut equivalent, mut different, mut unresolved) = (0usize, 0usize, 0usize);
    let mut needed: Vec<Needed> = Vec::new();
    let mut replicates = BTreeMap::<usize, usize>::new();
    let cells = item_cells(data, sel, work);
    let mut cells = cells.iter().peekable();
    for (index, row, metric) in &rows {
        // (item_cells keeps the selector's order, dropping the cells without a counterpart)
        let Some(cell) = cells.next_if(|c| c.key.0 == *index && &c.key.1 == metric) else {
            continue;
        };
        let (p, ours) = (cell.published, &cell.ours);
        let a = judge(cell);
        match a.outcome {
            Some(Outcome::Equivalent) => equivalent += 1,
            Some(Outcome::Different) => different += 1,
            Some(Outcome::Unresolved) => {
                unresolved += 1;
                needed.extend(a.needed);
                *replicates.entry(ours.len()).or_default() += 1;
            }
            None => {}
        }
        let mean = ours.iter().sum::<f64>() / ours.len() as f64;
        if !(p.mean.is_finite() && mean.is_finite()) {
            continue;
        }
        let key = match axis {
            Axis::Value | Axis::None => (row.map.clone(), format!("{}{}", row.algorithm, row.cell)),
            Axis::Cell => (row.map.clone(), row.algorithm.clone()),
            Axis::Algorithm => (row.map.clone(), row.cell.clone()),
            Axis::Map => (row.algorithm.clone(), format!("{}{}", row.cell, row.value)),
        };
        series.entry((key.0, key.1, metric.clone())).or_default().push((p.mean, mean));
    }
    let judged = equivalent + different + unresolved;
    if judged == 0 {
        return (
            Class::Missing,
            format!(
                "none of the {} selected published cells has a counterpart with ≥ 2 replicates",
                rows.len()
            ),
        );
    }
    let scores: Vec<f64> = series
        .values()
        .filter(|s| s.len() >= axis.min_series())
        .map(|s| {
            let (p, o): (Vec<f64>, Vec<f64>) = s.iter().copied().unzip();
            trend_score(&p, &o, work.relative)
        })
        .collect();
    let trend = (!scores.is_empty()).then(|| scores.iter().sum::<f64>() / scores.len() as f64);
    let half = |k: usize| k as f64 >= MATCH_SHARE * judged as f64;
    let class = match trend {
        _ if half(equivalent) && trend.is_none_or(|t| t >= TREND_RHO) => Class::Match,
        Some(t) if t >= TREND_RHO => Class::Trend,
        Some(_) => Class::Disagree,
        None if half(different) => Class::Disagree,
        None => Class::Unresolved,
    };
    let margin = format!("±{} %", sig(work.relative * 100.0, 2));
    let mut basis = format!(
        "of {judged} cells, {equivalent} shown equivalent within {margin}, {different} shown different, {unresolved} unresolved"
    );
    match trend {
        Some(t) => basis.push_str(&format!(
            "; trend along {}: mean score {} over {} series (Spearman ρ; 1 or 0 for a series that does not move)",
            axis.as_str(),
            sig(t, 2),
            scores.len()
        )),
        None if axis == Axis::None => basis.push_str("; an item about levels, no trend"),
        None => basis.push_str(&format!("; no series along {} to order", axis.as_str())),
    }
    if unresolved > 0 {
        basis.push_str(&format!("; {}", needed_text(&needed, &replicates)));
    }
    (class, basis)
}

/// What would resolve the unresolved cells: the median count of replicates per cell at the
/// observed spread, and how many no count of ours can resolve.
fn needed_text(needed: &[Needed], replicates: &BTreeMap<usize, usize>) -> String {
    let mut counts: Vec<usize> = needed
        .iter()
        .filter_map(|n| match n {
            Needed::Replicates(k) => Some(*k),
            Needed::Never => None,
        })
        .collect();
    counts.sort_unstable();
    let never = needed.len() - counts.len();
    let now = replicates.keys().map(|n| n.to_string()).collect::<Vec<_>>().join("–");
    let mut parts = Vec::new();
    if !counts.is_empty() {
        parts.push(format!(
            "{} would resolve at a median of {} replicates per cell (now {now})",
            counts.len(),
            counts[counts.len() / 2]
        ));
    }
    if never > 0 {
        parts.push(format!(
            "{never} cannot be resolved by more runs of ours (the published spread is wider than the gap to the margin, or the published run is one of ours while our median lies beyond the margin)"
        ));
    }
    parts.join("; ")
}

/// Classifies an item answered by claims about its levels (`ids`) and, if any, about its shape
/// (`shape`): with a shape, MATCH needs both; the shape alone is TREND; otherwise the shape's
/// class stands.
fn classify_item_claims(
    ids: &[String],
    shape: &[String],
    claims: &[&ClaimResult],
) -> (Class, String) {
    if shape.is_empty() {
        return classify_claims(ids, claims);
    }
    let (shape_class, shape_basis) = classify_claims(shape, claims);
    if ids.is_empty() {
        return (shape_class, format!("shape: {shape_basis}"));
    }
    let (level_class, level_basis) = classify_claims(ids, claims);
    let class = match (shape_class, level_class) {
        (Class::Match, Class::Match) => Class::Match,
        (Class::Match, _) => Class::Trend,
        (c, _) => c,
    };
    (class, format!("shape: {shape_basis}; levels: {level_basis}"))
}

/// Classifies an item answered by claims.
/// `s` with its first letter in lower case (a sentence quoted inside another).
fn lower_first(s: &str) -> String {
    let mut c = s.chars();
    c.next().map_or_else(String::new, |f| f.to_lowercase().chain(c).collect())
}

fn classify_claims(ids: &[String], claims: &[&ClaimResult]) -> (Class, String) {
    let found: Vec<&&ClaimResult> =
        ids.iter().filter_map(|id| claims.iter().find(|c| &c.id == id)).collect();
    let listed = found
        .iter()
        .map(|c| match c.projection.as_str() {
            "" => format!("{}: {}", c.id, c.verdict.as_str()),
            p => format!("{}: {} ({})", c.id, c.verdict.as_str(), lower_first(p)),
        })
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
    if found.iter().all(|c| c.kind == "calibration") {
        return (Class::Calibrated, format!("{listed} (a calibration: true by construction)"));
    }
    let testable: Vec<&&ClaimResult> =
        found.iter().copied().filter(|c| c.verdict != Verdict::Untestable).collect();
    let class = if testable.is_empty() {
        Class::Missing
    } else if testable.iter().all(|c| c.verdict == Verdict::Confirmed) {
        Class::Match
    } else if testable.iter().any(|c| c.verdict == Verdict::Refuted) {
        Class::Disagree
    } else if testable
        .iter()
        .any(|c| c.verdict == Verdict::Inconclusive && c.direction_agrees != Some(true))
    {
        Class::Unresolved
    } else {
        Class::Trend
    };
    (class, listed)
}

/// Classifies every item: on the studies' results, their claims, and — for a study without
/// results here whose report is kept — the cell verdicts that report kept (`kept`). A sequential
/// study's staged items (`staged`, by study: [`super::sequential::replay`]'s) are classified from
/// their cells as its looks judged them.
pub fn classify(
    items: &[Item],
    studies: &BTreeMap<String, &StudyData>,
    claims: &[ClaimResult],
    kept: &[CellVerdict],
    staged: &BTreeMap<&str, &[super::sequential::StagedItem]>,
) -> Vec<ItemResult> {
    items
        .iter()
        .map(|it| {
            let study = it.study.clone().unwrap_or_default();
            let (class, basis) = if let Some(why) = &it.missing {
                (Class::Missing, format!("no counterpart: {why}"))
            } else if let Some(sel) = &it.cells {
                match (studies.get(&study), kept.iter().find(|k| k.id == it.id)) {
                    // a staged item is classified as it was staged: by the selector and work
                    // the study ran with (`resolved.items`), which its looks judged
                    (Some(data), _) => match staged
                        .get(study.as_str())
                        .and_then(|items| items.iter().find(|s| s.id == it.id))
                        .zip(data.resolved.items.iter().find(|s| s.id == it.id))
                    {
                        Some((staged, stored)) => staged.classify(
                            data,
                            stored.cells.as_ref().unwrap_or(sel),
                            margins::for_label(&stored.seed),
                        ),
                        None => classify_cells(data, sel, margins::for_label(&it.seed)),
                    },
                    (None, Some(k)) => (k.class, k.basis.clone()),
                    (None, None) => (Class::Missing, format!("study {study} has no results here")),
                }
            } else {
                let of_study: Vec<&ClaimResult> =
                    claims.iter().filter(|c| c.study == study).collect();
                classify_item_claims(&it.claims, &it.shape, &of_study)
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
            projection: String::new(),
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
        assert_eq!(c(Confirmed, Some(true), Inconclusive, Some(false)), Class::Unresolved);
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

    /// An item with a shape: the direction reproduced but the levels not is TREND, never MATCH.
    #[test]
    fn shape_and_levels() {
        use Verdict::*;
        let (g, m) = (claim("grows", Confirmed, Some(true)), claim("size", Refuted, Some(false)));
        let ids = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let c = |levels: &[&str], shape: &[&str], cs: &[&ClaimResult]| {
            classify_item_claims(&ids(levels), &ids(shape), cs).0
        };
        assert_eq!(c(&["size"], &["grows"], &[&g, &m]), Class::Trend);
        let m2 = claim("size", Confirmed, Some(true));
        assert_eq!(c(&["size"], &["grows"], &[&g, &m2]), Class::Match);
        let g2 = claim("grows", Refuted, Some(false));
        assert_eq!(c(&["size"], &["grows"], &[&g2, &m2]), Class::Disagree);
        assert_eq!(c(&[], &["grows"], &[&g]), Class::Match);
    }

    /// A series that does not move is "no effect": it agrees with a flat published series and
    /// contradicts a sloped one ([FT]-R13: ours 23 landmarks at every M, the thesis 31 → 22).
    #[test]
    fn a_flat_series_against_a_flat_and_a_sloped_published_one() {
        let ours = [23.0, 23.0, 23.0, 23.0, 23.0];
        assert_eq!(trend_score(&[22.4, 22.0, 22.2, 22.6, 22.0], &ours, 0.2), 1.0);
        assert_eq!(trend_score(&[31.0, 27.0, 24.0, 22.0, 22.0], &ours, 0.2), 0.0);
        // both moving: Spearman's ρ, whatever the levels
        assert_eq!(trend_score(&[0.84, 0.5, 0.3, 0.26], &[2.0, 1.5, 1.2, 1.0], 0.2), 1.0);
        assert_eq!(trend_score(&[0.84, 0.5, 0.3, 0.26], &[1.0, 1.2, 1.5, 2.0], 0.2), -1.0);
        // ours moving where the publication is flat: no agreement
        assert_eq!(trend_score(&[0.13, 0.14, 0.15], &[0.2, 0.4, 0.6], 0.2), 0.0);
    }
}
