//! Which run stands for a study in its single-run figures (the trajectory figure, the match
//! diagnostics): one choice, made here for the report and for the run stage, so that both show
//! the same run.

use super::{PointRecord, RunRow, RunStatus};
use crate::algo::Catalogue;
use crate::params::flatten;
use crate::spec::ExperimentSpec;
use crate::world::WorldKind;

/// The base parameters the study's algorithms read on its kinds of world, flattened (what
/// entered the run hashes).
pub fn read_base(
    spec: &ExperimentSpec,
    catalogue: &Catalogue,
    kinds: &[WorldKind],
) -> Vec<(String, toml::Value)> {
    let mut read = toml::Table::new();
    for a in &spec.algorithms {
        for &k in kinds {
            merge(&mut read, spec.base.sections(&catalogue.algorithm(a).sections_read(k)));
        }
    }
    let mut base = Vec::new();
    flatten("", &toml::Value::Table(read), &mut base);
    base
}

/// Adds `more` to `into`, merging tables both have (two external algorithms' `external.<name>`).
fn merge(into: &mut toml::Table, more: toml::Table) {
    for (k, v) in more {
        match (into.get_mut(&k), v) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => merge(a, b),
            (_, v) => {
                into.insert(k, v);
            }
        }
    }
}

/// The base configuration if it was run (a point whose every assignment is the base value), else
/// the middle point of the first group.
pub fn reference_point<'a>(
    points: &'a [PointRecord],
    base: &[(String, toml::Value)],
) -> Option<&'a PointRecord> {
    points
        .iter()
        .find(|p| p.assignments.iter().all(|(k, v)| base.iter().any(|(bk, bv)| bk == k && bv == v)))
        .or_else(|| {
            let first: Vec<_> = points.iter().filter(|p| p.groups.contains(&0)).collect();
            first.get(first.len() / 2).copied()
        })
}

/// The median replicate by `headline` among `algorithm`'s successful runs at (map, point): the
/// lower median, ties by run id.
pub fn median_run<'a>(
    runs: &'a [RunRow],
    map: &str,
    algorithm: &str,
    point: &str,
    headline: &str,
) -> Option<&'a RunRow> {
    let mut candidates: Vec<&RunRow> = runs
        .iter()
        .filter(|r| {
            r.map == map
                && r.algorithm == algorithm
                && r.point == point
                && r.status == RunStatus::Ok
        })
        .collect();
    candidates.sort_by(|a, b| {
        a.metric(headline)
            .unwrap_or(f64::NAN)
            .total_cmp(&b.metric(headline).unwrap_or(f64::NAN))
            .then(a.run_id.cmp(&b.run_id))
    });
    candidates.get(candidates.len().saturating_sub(1) / 2).copied()
}

/// The headline metric: the report's first metric that slamlab knows, else ATE RMSE.
pub fn headline(spec: &ExperimentSpec) -> &'static str {
    spec.report
        .metrics
        .iter()
        .find_map(|m| crate::metrics::metric_def(m))
        .map_or(crate::metrics::ATE_RMSE, |m| m.name)
}
