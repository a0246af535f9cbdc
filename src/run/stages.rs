//! A sequential study's stages (issue 31): the runs of replicates 0 … n₁ − 1 of every cell, then,
//! look by look, the next stage of replicates of the cells [`judge::sequential::replay`] asks
//! for, until it asks for none. The stages are a function of the runs' results, and those of the
//! spec: the same spec always takes the same runs, whatever the thread count or shard. Added
//! replicates are ordinary runs (replicate k, seeded by (study, map, k)), cached by content hash.

use super::{Done, RunError, RunOptions, compute, progress::Progress};
use crate::judge::sequential::{self, Design};
use crate::plan::{ExperimentPlan, RunSpec};
use crate::store::{self, Cache, Manifest, RunRow, StudyData};
use std::collections::BTreeSet;

/// The plan with only the runs `active` (indices into `plan.runs`, ascending).
pub fn subset(plan: &ExperimentPlan, active: &BTreeSet<usize>) -> ExperimentPlan {
    ExperimentPlan { runs: active.iter().map(|&i| plan.runs[i].clone()).collect(), ..plan.clone() }
}

/// A run's row from the cache, if it is there and intact.
pub fn cached_row(plan: &ExperimentPlan, run: &RunSpec, cache: &Cache) -> Option<RunRow> {
    match cache.lookup_summary(&run.hash) {
        store::Lookup::Hit(c) => {
            Some(Done::of(c.row, c.wall_ms, c.trace_rows, true, None).row(plan, run))
        }
        _ => None,
    }
}

/// The stages of a sequential study's plan (which holds its whole budget): `rows_of(stage)`
/// gives every run's row of a stage, computing what it may, or `None` when some cannot be had
/// here (another shard's). Returns the plan of the runs taken (the last stage reached) and
/// whether the looks are complete (`false`: the stage returned waits for runs made elsewhere).
pub fn staged<E>(
    plan: &ExperimentPlan,
    design: &Design,
    mut rows_of: impl FnMut(&ExperimentPlan) -> Result<Option<Vec<RunRow>>, E>,
) -> Result<(ExperimentPlan, bool), E> {
    let first = design.looks[0];
    // the published rows the staged items' cells are judged against (checked when planned)
    let reference = plan
        .reference
        .as_deref()
        .and_then(|text| store::reference::parse(text).ok())
        .unwrap_or_default();
    let mut active: BTreeSet<usize> =
        (0..plan.runs.len()).filter(|&i| plan.runs[i].replicate < first).collect();
    loop {
        let stage = subset(plan, &active);
        let Some(rows) = rows_of(&stage)? else { return Ok((stage, false)) };
        let data = StudyData::new(
            std::path::PathBuf::new(),
            super::resolved(&stage),
            Manifest::blank(stage.id(), stage.runs.len()),
            rows,
            stage.maps.iter().map(|m| (m.name.clone(), m.text.clone())).collect(),
            reference.clone(),
        );
        let replay = sequential::replay(&data, design);
        let Some((next, cells)) = replay.pending else { return Ok((stage, true)) };
        let cells: BTreeSet<sequential::Cell> = cells.into_iter().collect();
        let before = active.len();
        for (i, run) in plan.runs.iter().enumerate() {
            if run.replicate < next
                && cells.contains(&(
                    plan.maps[run.map].name.clone(),
                    run.algorithm.to_string(),
                    plan.points[run.point].label.clone(),
                ))
            {
                active.insert(i);
            }
        }
        // (a pending stage always adds runs: the cells it names lack some below `next`)
        debug_assert!(active.len() > before, "a stage that adds no run would loop");
        if active.len() == before {
            return Ok((stage, true));
        }
    }
}

/// The stage a sequential study stands at from the cache alone (what `plan` and a shard see).
pub fn from_cache(plan: &ExperimentPlan, design: &Design, cache: &Cache) -> (ExperimentPlan, bool) {
    let Ok(staged) = staged(plan, design, |stage| {
        Ok::<_, std::convert::Infallible>(
            stage.runs.iter().map(|r| cached_row(stage, r, cache)).collect::<Option<Vec<_>>>(),
        )
    });
    staged
}

/// Runs a sequential study's stages into the cache (computing what is not cached, everything
/// with `--force`, each run once): the plan of the runs taken and how many were computed.
pub fn run_stages(
    plan: &ExperimentPlan,
    design: &Design,
    opts: &RunOptions,
    pool: &rayon::ThreadPool,
) -> Result<(ExperimentPlan, usize), RunError> {
    let cache = Cache::new(&opts.cache_dir);
    let mut done: std::collections::BTreeMap<String, Done> = Default::default();
    let mut computed = 0usize;
    let mut look = 0usize;
    let (stage, _) = staged(plan, design, |stage| {
        look += 1;
        let mut missing = Vec::new();
        let mut seen = BTreeSet::new();
        for (i, run) in stage.runs.iter().enumerate() {
            if done.contains_key(&run.hash) || !seen.insert(run.hash.as_str()) {
                continue;
            }
            let hit =
                if opts.force { store::Lookup::Absent } else { cache.lookup_summary(&run.hash) };
            match hit {
                store::Lookup::Hit(c) => {
                    done.insert(
                        run.hash.clone(),
                        Done::of(c.row, c.wall_ms, c.trace_rows, true, None),
                    );
                }
                _ => missing.push(i),
            }
        }
        let cost = |i: usize| crate::plan::cost::expected_s(stage, &stage.runs[i]);
        let mut progress = Progress::new(
            &format!("{} (look {look}: {} replicates)", plan.id(), design.looks[look - 1]),
            stage.runs.len(),
            missing.len(),
            missing.iter().map(|&i| cost(i) * 1e3).sum(),
            opts.progress,
        );
        compute(stage, &missing, &cost, pool, &|| progress.computing(), |i, c| {
            let run = &stage.runs[i];
            if let Err(e) = cache.put(&run.hash, &c, true) {
                progress.warn(&format!("cannot cache {}: {e}", run.run_id));
            }
            progress.finished(c.row.status, false, 1, cost(i) * 1e3);
            computed += 1;
            let trace_rows = c.trace.truth.len();
            done.insert(run.hash.clone(), Done::of(c.row, c.wall_ms, trace_rows, false, None));
        });
        progress.done();
        Ok::<_, RunError>(Some(stage.runs.iter().map(|r| done[&r.hash].row(stage, r)).collect()))
    })?;
    Ok((stage, computed))
}
