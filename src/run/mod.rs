//! Executes plans: ExperimentPlan → per-run simulation (rayon — the only parallel place) →
//! study results in the store. Each run owns its RNGs, so the results do not depend on the
//! thread count; rows are sorted by run id before writing. A failed run becomes a row with
//! `status = failed` and the study goes on.

pub mod diagnostics;
pub mod external;
pub mod progress;
pub mod provenance;
pub mod stages;
pub mod worlds;

use crate::algo::RunInput;
use crate::metrics;
use crate::params::flatten;
use crate::plan::{ExperimentPlan, RunSpec, SCHEMA_VERSION};
use crate::slam::SlamError;
use crate::store::{
    self, Cache, CachedRun, GroupRecord, LandmarkRow, Manifest, MatchRows, ParamValue, PointRecord,
    ResolvedStudy, RunLandmarks, RunRow, RunStatus, StoreError, StudyOutput, Timing, TraceRows,
};
use crate::world::WorldKind;
use crate::world::{self, WORLD_CODE_VERSION, WorldError, WorldSpec};
use progress::Progress;
pub use provenance::Provenance;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How to run (never what to compute: that is the spec's job).
#[derive(Debug, Clone)]
pub struct RunOptions {
    pub threads: usize,
    /// Recompute runs even when cached.
    pub force: bool,
    pub results_dir: PathBuf,
    pub cache_dir: PathBuf,
    /// Progress bar/lines on stderr.
    pub progress: bool,
}

/// Why a run will be computed, or that it will not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reason {
    /// A valid cache entry exists: nothing to compute.
    Cached,
    /// No earlier result with this run id.
    New,
    ParametersChanged,
    CodeVersionChanged,
    ParametersAndCodeVersionChanged,
    /// Unchanged since the study's last results, but the cache entry is gone.
    CacheMissing,
    /// `--force`.
    Forced,
}

impl Reason {
    pub fn as_str(self) -> &'static str {
        match self {
            Reason::Cached => "cached",
            Reason::New => "new",
            Reason::ParametersChanged => "parameters changed",
            Reason::CodeVersionChanged => "code version changed",
            Reason::ParametersAndCodeVersionChanged => "parameters and code version changed",
            Reason::CacheMissing => "cache entry missing",
            Reason::Forced => "forced",
        }
    }
}

/// For each run of the plan: will it be computed, and why. Compares with the cache and with
/// the study's previous results (by run id).
pub fn reasons(plan: &ExperimentPlan, opts: &RunOptions) -> Vec<Reason> {
    let cache = Cache::new(&opts.cache_dir);
    let cached: std::collections::BTreeSet<&str> =
        plan.runs.iter().map(|r| r.hash.as_str()).filter(|h| cache.contains(h)).collect();
    // the previous results only explain runs that are not cached
    let previous = if opts.force || !plan.runs.iter().all(|r| cached.contains(r.hash.as_str())) {
        store::read_runs(&opts.results_dir.join(plan.id())).unwrap_or_default()
    } else {
        Vec::new()
    };
    explain(&plan.runs, &|h| cached.contains(h), &previous, opts.force)
}

/// The pure part of [`reasons`].
pub fn explain(
    runs: &[RunSpec],
    cached: &dyn Fn(&str) -> bool,
    previous: &[RunRow],
    force: bool,
) -> Vec<Reason> {
    let previous: BTreeMap<&str, &RunRow> =
        previous.iter().map(|r| (r.run_id.as_str(), r)).collect();
    runs.iter()
        .map(|run| {
            if force {
                return Reason::Forced;
            }
            if cached(&run.hash) {
                return Reason::Cached;
            }
            match previous.get(run.run_id.as_str()) {
                None => Reason::New,
                Some(prev) => match (
                    prev.params_hash != run.params_hash,
                    *prev.code_version != *run.code_version,
                ) {
                    (true, true) => Reason::ParametersAndCodeVersionChanged,
                    (true, false) => Reason::ParametersChanged,
                    (false, true) => Reason::CodeVersionChanged,
                    (false, false) => Reason::CacheMissing,
                },
            }
        })
        .collect()
}

/// What running a study did.
#[derive(Debug, Clone, PartialEq)]
pub struct StudySummary {
    pub study: String,
    pub dir: PathBuf,
    pub runs: usize,
    pub computed: usize,
    /// Cache entries that failed verification and were recomputed (counted in `computed`).
    pub recomputed_corrupt: usize,
    pub failed: usize,
    pub diverged: usize,
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("cannot start {threads} worker threads: {message}")]
    Threads { threads: usize, message: String },
}

/// Runs (or takes from the cache) every run of `plan` and writes the study's results. A
/// sequential study (`max_replicates`) runs the stages its looks ask for ([`stages`]) and
/// writes those runs.
pub fn run_study(
    plan: &ExperimentPlan,
    opts: &RunOptions,
    provenance: &Provenance,
) -> Result<StudySummary, RunError> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| RunError::Threads { threads: opts.threads, message: e.to_string() })?;
    let Some(design) = crate::judge::sequential::Design::of(&plan.spec.spec) else {
        return write_runs(plan, opts, provenance, &pool);
    };
    let (staged, computed) = stages::run_stages(plan, &design, opts, &pool)?;
    // every run of the stages is computed (or forced) by now: the rest only writes them
    let opts = RunOptions { force: false, ..opts.clone() };
    let mut summary = write_runs(&staged, &opts, provenance, &pool)?;
    summary.computed += computed;
    Ok(summary)
}

/// Runs (or takes from the cache) every run of `plan` and writes the study's results.
fn write_runs(
    plan: &ExperimentPlan,
    opts: &RunOptions,
    provenance: &Provenance,
    pool: &rayon::ThreadPool,
) -> Result<StudySummary, RunError> {
    let cache = Cache::new(&opts.cache_dir);
    if opts.progress && plan.runs.len() >= LARGE_STUDY {
        eprintln!(
            "{}: looking up {} runs in the cache and scheduling them",
            plan.id(),
            plan.runs.len()
        );
    }
    let reasons = reasons(plan, opts);
    let to_compute = reasons.iter().filter(|r| **r != Reason::Cached).count();
    let dir = opts.results_dir.join(plan.id());
    let maps: Vec<(String, String)> =
        plan.maps.iter().map(|m| (m.name.clone(), m.text.clone())).collect();
    let resolved = resolved(plan);

    // Nothing to compute and the stored study is exactly this one: leave it as it is.
    if to_compute == 0 {
        let ids: Vec<(String, String)> =
            plan.runs.iter().map(|r| (r.run_id.clone(), r.hash.clone())).collect();
        let stored = store::read_run_keys(&dir).unwrap_or_default();
        let bad = stored.iter().filter(|(_, _, s)| *s != RunStatus::Ok).count();
        let manifest = manifest(plan, provenance, plan.runs.len(), bad);
        let diagnosed = plan.has_scan_matcher();
        if store::is_up_to_date(
            &dir,
            &ids,
            &resolved,
            &manifest,
            &maps,
            plan.reference.as_deref(),
            diagnosed,
        ) {
            let count = |s: RunStatus| stored.iter().filter(|(_, _, r)| *r == s).count();
            return Ok(StudySummary {
                study: plan.id().to_string(),
                dir,
                runs: plan.runs.len(),
                computed: 0,
                recomputed_corrupt: 0,
                failed: count(RunStatus::Failed),
                diverged: count(RunStatus::Diverged),
            });
        }
    }
    // Each distinct content hash is computed (or read) once, even when two runs share it.
    let mut unique: Vec<usize> = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for (i, run) in plan.runs.iter().enumerate() {
        if seen.insert(run.hash.as_str()) {
            unique.push(i);
        }
    }
    // runs sharing a content hash are computed once and counted each, as `plan` counts them
    let mut multiplicity: BTreeMap<&str, usize> = BTreeMap::new();
    for run in &plan.runs {
        *multiplicity.entry(run.hash.as_str()).or_default() += 1;
    }
    // planned cost of each unique hash to compute: its compute time last time, else its
    // algorithm's mean then, else the cost model's expectation
    let previous_ms: BTreeMap<String, f64> = store::read_timings(&dir)
        .unwrap_or_default()
        .into_iter()
        .filter(|t| t.wall_ms.is_finite())
        .map(|t| (t.run_id, t.wall_ms))
        .collect();
    let mut by_algorithm: BTreeMap<&str, (f64, usize)> = BTreeMap::new();
    for r in &plan.runs {
        if let Some(ms) = previous_ms.get(&r.run_id) {
            let e = by_algorithm.entry(r.algorithm.as_str()).or_default();
            *e = (e.0 + ms, e.1 + 1);
        }
    }
    let planned = |r: &RunSpec| {
        previous_ms
            .get(&r.run_id)
            .copied()
            .or_else(|| by_algorithm.get(r.algorithm.as_str()).map(|(s, n)| s / *n as f64))
            .unwrap_or_else(|| crate::plan::cost::expected_s(plan, r) * 1e3)
    };
    let planned_cost: BTreeMap<&str, f64> =
        unique.iter().map(|&i| (plan.runs[i].hash.as_str(), planned(&plan.runs[i]))).collect();
    let to_compute_cost: f64 = unique
        .iter()
        .filter(|&&i| reasons[i] != Reason::Cached)
        .map(|&i| planned_cost[plan.runs[i].hash.as_str()])
        .sum();
    let mut progress =
        Progress::new(plan.id(), plan.runs.len(), to_compute, to_compute_cost, opts.progress);
    // Cache IO (Parquet, through polars' own thread pool) stays on this thread: a worker of ours
    // waiting on polars would run further jobs of ours meanwhile, nesting without bound. So cached
    // runs are looked up first, and computed runs are cached here as the workers send them.
    // What is kept of each run is its row, compute time and trace length ([`Done`]): its trace,
    // landmarks and matches are read back from the cache when the study is written, a batch at a
    // time, so a study's memory does not grow with its runs' results.
    let mut done: BTreeMap<&str, Done> = BTreeMap::new();
    let mut missing: Vec<usize> = Vec::new();
    let mut corrupt = 0usize;
    for &i in &unique {
        let run = &plan.runs[i];
        let lookup = if reasons[i] == Reason::Cached {
            cache.lookup_summary(&run.hash)
        } else {
            store::Lookup::Absent
        };
        match lookup {
            store::Lookup::Hit(c) => {
                progress.finished(c.row.status, true, multiplicity[run.hash.as_str()], 0.0);
                done.insert(
                    run.hash.as_str(),
                    Done::of(c.row, c.wall_ms, c.trace_rows, true, None),
                );
            }
            store::Lookup::Corrupt(why) => {
                progress.warn(&format!(
                    "{}: its cache entry failed verification ({why}); recomputing it",
                    run.run_id
                ));
                corrupt += 1;
                missing.push(i);
            }
            store::Lookup::Absent => missing.push(i),
        }
    }
    let started = || progress.computing();
    compute(
        plan,
        &missing,
        &|i| planned_cost[plan.runs[i].hash.as_str()],
        pool,
        &started,
        |i, c| {
            let run = &plan.runs[i];
            // Replace whatever is there: forced, or an entry that could not be read. A cache that
            // cannot be written only costs a recomputation next time; until the study is written,
            // the run's results are then held here.
            let cached = cache.put(&run.hash, &c, true);
            let CachedRun { row, trace, landmarks, matches, wall_ms } = c;
            let trace_rows = trace.truth.len();
            let held = match cached {
                Ok(()) => None,
                Err(e) => {
                    progress.warn(&format!("cannot cache {}: {e}", run.run_id));
                    Some(store::RunParts { trace, landmarks, matches })
                }
            };
            progress.finished(
                row.status,
                false,
                multiplicity[run.hash.as_str()],
                planned_cost[run.hash.as_str()],
            );
            done.insert(run.hash.as_str(), Done::of(row, wall_ms, trace_rows, false, held));
        },
    );
    progress.done();

    let mut order: Vec<&RunSpec> = plan.runs.iter().collect();
    order.sort_by(|a, b| a.run_id.cmp(&b.run_id));
    let rows: Vec<RunRow> =
        order.iter().map(|run| done[run.hash.as_str()].row(plan, run)).collect();
    let timings: Vec<Timing> = order
        .iter()
        .map(|run| {
            let d = &done[run.hash.as_str()];
            Timing {
                run_id: run.run_id.clone(),
                wall_ms: d.wall_ms,
                steps: d.trace_rows.saturating_sub(1) as u32,
                cached: d.cached,
            }
        })
        .collect();
    // a run's trace, landmarks and matches, labelled with its run id
    let parts_of = |run: &RunSpec| -> Result<store::RunParts, StoreError> {
        let d = &done[run.hash.as_str()];
        let mut parts = match &d.held {
            Some(p) => p.clone(),
            None => cache.parts(&run.hash, &run.run_id).ok_or_else(|| {
                StoreError::format(
                    &opts.cache_dir,
                    format!(
                        "the cache entry of {} ({}) vanished while the study ran",
                        run.run_id, run.hash
                    ),
                )
            })?,
        };
        parts.trace.run_id.clone_from(&run.run_id);
        parts.landmarks.run_id.clone_from(&run.run_id);
        parts.matches.run_id.clone_from(&run.run_id);
        Ok(parts)
    };
    let failed = rows.iter().filter(|r| r.status == RunStatus::Failed).count();
    let diverged = rows.iter().filter(|r| r.status == RunStatus::Diverged).count();

    // Diagnostics are an addition to the results: when they cannot be made, say why and go on.
    let diagnosed = plan.has_scan_matcher();
    let load = |run_id: &str| {
        let run = plan.runs.iter().find(|r| r.run_id == run_id)?;
        parts_of(run).ok()
    };
    let diagnostics = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        diagnostics::build(plan, &resolved, &rows, &load)
    })) {
        Ok(Ok(d)) => d,
        Ok(Err(why)) => {
            progress.warn(&format!("{}: no match diagnostics: {why}", plan.id()));
            None
        }
        Err(_) => {
            progress.warn(&format!(
                "{}: no match diagnostics: they panicked (a defect: please report it)",
                plan.id()
            ));
            None
        }
    };
    let manifest = manifest(plan, provenance, rows.len(), failed + diverged);
    store::write_study(
        &dir,
        &StudyOutput {
            runs: &rows,
            timings: &timings,
            resolved: &resolved,
            manifest: &manifest,
            maps: &maps,
            reference: plan.reference.as_deref(),
            diagnostics: diagnosed.then_some(diagnostics.as_ref()),
        },
        &mut |k| parts_of(order[k]),
    )?;
    Ok(StudySummary {
        study: plan.id().to_string(),
        dir,
        runs: rows.len(),
        computed: to_compute + corrupt,
        recomputed_corrupt: corrupt,
        failed,
        diverged,
    })
}

/// Computes the runs `todo` (indices into `plan.runs`) on `pool`, calling `done` on this thread
/// with each result as it arrives. The runs are taken in decreasing expected cost (`cost`), each
/// worker taking the next when it is free (Graham's longest-processing-time list schedule): the
/// last runs to finish are short ones, so no core idles long at a study's end. The order
/// changes nothing computed. Cache IO (Parquet, through polars' own thread pool) belongs in
/// `done`, on this thread: a worker of ours waiting on polars would run further jobs of ours
/// meanwhile, nesting without bound.
fn compute(
    plan: &ExperimentPlan,
    todo: &[usize],
    cost: &dyn Fn(usize) -> f64,
    pool: &rayon::ThreadPool,
    started: &dyn Fn(),
    mut done: impl FnMut(usize, CachedRun),
) {
    let order = schedule(plan, todo, cost);
    let worlds = worlds::Worlds::new(plan, todo);
    started(); // the set-up is done: the runs start now
    let next = std::sync::atomic::AtomicUsize::new(0);
    // Bounded: a worker waits when this thread (caching each result, with an fsync) falls behind,
    // so results in flight stay a few per worker instead of piling up (fast runs outpace the
    // cache writes; unbounded, 4 000 quick runs held 1.4 GB).
    let (sender, results) = std::sync::mpsc::sync_channel(2 * pool.current_num_threads());
    std::thread::scope(|scope| {
        let (order, next, worlds) = (&order, &next, &worlds);
        scope.spawn(move || {
            pool.broadcast(|_| {
                let sender = sender.clone();
                loop {
                    let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(&i) = order.get(k) else { break };
                    let run = &plan.runs[i];
                    sender
                        .send((i, execute_with(plan, run, || worlds.take(run))))
                        .expect("the receiver outlives the workers");
                }
            });
            drop(sender);
        });
        for (i, c) in results {
            done(i, c);
        }
    });
}

/// The order runs are started in: the runs sharing a world one after another (so that a world
/// lives only while its runs compute), those groups in decreasing cost of their dearest run, and
/// the runs of a group in decreasing cost; ties by index.
pub fn schedule(plan: &ExperimentPlan, todo: &[usize], cost: &dyn Fn(usize) -> f64) -> Vec<usize> {
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for &i in todo {
        groups.entry(worlds::key(plan, &plan.runs[i])).or_default().push(i);
    }
    // each run's cost asked once (the sort compares many times; `cost` may be a map lookup)
    let mut costs = vec![f64::NAN; plan.runs.len()];
    for &i in todo {
        costs[i] = cost(i);
    }
    let by_cost = |a: &usize, b: &usize| costs[*b].total_cmp(&costs[*a]).then(a.cmp(b));
    let mut groups: Vec<Vec<usize>> = groups.into_values().collect();
    for g in &mut groups {
        g.sort_by(by_cost);
    }
    groups.sort_by(|a, b| by_cost(&a[0], &b[0]));
    groups.concat()
}

/// What computing one shard did.
#[derive(Debug, Clone, PartialEq)]
pub struct ShardSummary {
    /// Distinct runs (content hashes) of the shard, and of those: computed now, found cached.
    pub runs: usize,
    pub computed: usize,
    pub cached: usize,
    pub failed: usize,
    /// Expected cost [s] of the shard's runs (the partition's measure).
    pub expected_s: f64,
}

/// The shard (1-based) of every distinct run of `plans`: the partition every task of an array
/// computes alike (see [`crate::plan::shard`]).
pub fn shards(plans: &[ExperimentPlan], count: usize) -> BTreeMap<&str, usize> {
    let items = plans.iter().filter(|p| !skipped(p)).flat_map(|p| {
        p.runs.iter().map(move |r| (r.hash.as_str(), crate::plan::cost::expected_s(p, r)))
    });
    crate::plan::shard::partition(items, count)
}

/// What one shard holds: its distinct runs, those not cached yet, and their expected cost [s].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ShardLoad {
    pub runs: usize,
    pub to_compute: usize,
    pub cost_s: f64,
    pub to_compute_s: f64,
}

/// The load of each shard (index k − 1) of the partition `owner` ([`shards`]); `cached` says
/// whether a content hash needs no computing.
pub fn shard_loads(
    plans: &[ExperimentPlan],
    owner: &BTreeMap<&str, usize>,
    count: usize,
    cached: &dyn Fn(&str) -> bool,
) -> Vec<ShardLoad> {
    let mut loads = vec![ShardLoad::default(); count];
    let mut seen = std::collections::BTreeSet::new();
    for plan in plans.iter().filter(|p| !skipped(p)) {
        for r in plan.runs.iter().filter(|r| seen.insert(r.hash.as_str())) {
            let (load, cost) =
                (&mut loads[owner[r.hash.as_str()] - 1], crate::plan::cost::expected_s(plan, r));
            load.runs += 1;
            load.cost_s += cost;
            if !cached(&r.hash) {
                load.to_compute += 1;
                load.to_compute_s += cost;
            }
        }
    }
    loads
}

/// A study whose real data is absent on this machine (`run` skips it).
pub fn skipped(plan: &ExperimentPlan) -> bool {
    plan.maps.iter().any(|m| m.missing_data.is_some())
}

/// Computes shard `shard` of the runs of `plans` into the cache: the runs of that shard that are
/// not cached yet (all of them with `force`). Writes no study results: once every shard is done,
/// `run` without `--shard` finds every run cached and writes them.
pub fn run_shard(
    plans: &[ExperimentPlan],
    shard: crate::plan::shard::Shard,
    opts: &RunOptions,
) -> Result<ShardSummary, RunError> {
    let cache = Cache::new(&opts.cache_dir);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build()
        .map_err(|e| RunError::Threads { threads: opts.threads, message: e.to_string() })?;
    let owner = shards(plans, shard.count);
    let mut summary = ShardSummary { runs: 0, computed: 0, cached: 0, failed: 0, expected_s: 0.0 };
    let mut seen: std::collections::BTreeSet<String> = std::collections::BTreeSet::new();
    for plan in plans.iter().filter(|p| !skipped(p)) {
        let design = crate::judge::sequential::Design::of(&plan.spec.spec);
        // A sequential study: the shard's runs of the stage the cache stands at, stage after
        // stage while it can tell the next one (the other shards' runs of a stage may still be
        // missing: then the next array pass, or the gathering `run`, goes on from there).
        let mut stage_plan = None;
        loop {
            let stage = match &design {
                Some(d) => &*stage_plan.insert(stages::from_cache(plan, d, &cache).0),
                None => plan,
            };
            // each distinct run once, also when runs of one plan share a content hash
            let mine: Vec<usize> = (0..stage.runs.len())
                .filter(|&i| {
                    let hash = stage.runs[i].hash.as_str();
                    owner.get(hash) == Some(&shard.index) && seen.insert(hash.to_string())
                })
                .collect();
            summary.runs += mine.len();
            summary.expected_s += mine
                .iter()
                .map(|&i| crate::plan::cost::expected_s(stage, &stage.runs[i]))
                .sum::<f64>();
            let todo: Vec<usize> = mine
                .iter()
                .copied()
                .filter(|&i| opts.force || !cache.contains(&stage.runs[i].hash))
                .collect();
            summary.cached += mine.len() - todo.len();
            if todo.is_empty() {
                if design.is_none() || mine.is_empty() {
                    break;
                }
                continue; // this stage's runs of ours were cached: the next stage may have more
            }
            compute_shard(stage, &todo, shard, opts, &pool, &cache, &mut summary);
            if design.is_none() {
                break;
            }
        }
    }
    Ok(summary)
}

/// Computes the runs `todo` of one shard's study into the cache.
fn compute_shard(
    plan: &ExperimentPlan,
    todo: &[usize],
    shard: crate::plan::shard::Shard,
    opts: &RunOptions,
    pool: &rayon::ThreadPool,
    cache: &Cache,
    summary: &mut ShardSummary,
) {
    let cost: f64 =
        todo.iter().map(|&i| crate::plan::cost::expected_s(plan, &plan.runs[i]) * 1e3).sum();
    let mut progress = Progress::new(
        &format!("{} (shard {shard})", plan.id()),
        todo.len(),
        todo.len(),
        cost,
        opts.progress,
    );
    compute(
        plan,
        todo,
        &|i| crate::plan::cost::expected_s(plan, &plan.runs[i]),
        pool,
        &|| progress.computing(),
        |i, c| {
            let run = &plan.runs[i];
            if let Err(e) = cache.put(&run.hash, &c, true) {
                progress.warn(&format!("cannot cache {}: {e}", run.run_id));
            }
            summary.computed += 1;
            summary.failed += usize::from(c.row.status != RunStatus::Ok);
            progress.finished(
                c.row.status,
                false,
                1,
                crate::plan::cost::expected_s(plan, run) * 1e3,
            );
        },
    );
    progress.done();
}

/// Simulates one run; never panics outward: errors and panics become a failed row.
pub fn execute(plan: &ExperimentPlan, run: &RunSpec) -> CachedRun {
    execute_with(plan, run, || worlds::alone(plan, run))
}

/// [`execute`] with the run's world from `world` (shared with other runs, see [`worlds`]).
pub fn execute_with(
    plan: &ExperimentPlan,
    run: &RunSpec,
    world: impl FnOnce() -> worlds::Shared,
) -> CachedRun {
    let start = Instant::now();
    let result =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| simulate(plan, run, world)));
    let wall_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut row = base_row(plan, run);
    let no_map = || RunLandmarks { run_id: run.run_id.clone(), landmarks: Vec::new() };
    let no_matches = || MatchRows { run_id: run.run_id.clone(), matches: Vec::new() };
    let (trace, landmarks, matches) = match result {
        Ok(Ok((trace_rows, landmarks, matches, metrics, diverged))) => {
            row.status = if diverged { RunStatus::Diverged } else { RunStatus::Ok };
            // a metric out of its range is a defect of ours: the run says so instead of storing it
            if let Some((name, value)) = crate::metrics::out_of_range(metrics.iter().copied()) {
                row.status = RunStatus::Failed;
                row.error = Some(format!(
                    "metric {name} = {value} is negative, which no metric can be (a defect: please report it)"
                ));
            }
            row.metrics = metrics.into_iter().map(|(k, v)| (k.to_string(), v)).collect();
            (trace_rows, landmarks, matches)
        }
        Ok(Err(message)) => {
            row.status = RunStatus::Failed;
            row.error = Some(message);
            (TraceRows::empty(&run.run_id), no_map(), no_matches())
        }
        Err(panic) => {
            let message = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "panic".into());
            row.status = RunStatus::Failed;
            row.error = Some(format!("panicked: {message}"));
            (TraceRows::empty(&run.run_id), no_map(), no_matches())
        }
    };
    CachedRun { row, trace, landmarks, matches, wall_ms }
}

/// Why a run's world or algorithm failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error("world: {0}")]
    World(#[from] WorldError),
    #[error("{0}")]
    Slam(#[from] SlamError),
    #[error("dataset: {0}")]
    Dataset(String),
}

/// The world a run sees: its map's simulation with the run's world seed, or its dataset's log
/// (with the study's odometry model applied where the log has none).
pub fn world_of(plan: &ExperimentPlan, run: &RunSpec) -> Result<world::World, SimError> {
    let params = &plan.points[run.point].params;
    let map = &plan.maps[run.map];
    let sensors = plan.algorithm(run).sensors(map.world_kind());
    let mut world = match &map.dataset {
        // Real data: read from its files (relative paths from the working directory, the
        // repository); the plan hashed their bytes.
        Some(dataset) => crate::dataset::load(dataset, Path::new("."))
            .map_err(|e| SimError::Dataset(e.to_string()))?,
        None => {
            let spec = WorldSpec {
                map: &map.map,
                sim: &params.sim,
                odometry: &params.odometry,
                laser: sensors.laser.then_some(&params.laser),
                landmark_sensor: sensors.landmarks.then_some(&params.landmark_sensor),
            };
            world::generate(&spec, run.world_seed)?
        }
    };
    if map.dataset.as_ref().is_some_and(|d| d.odometry_is_truth()) {
        // A log without raw odometry (its increments are the truth's): the study's
        // [odometry] model makes the odometry from them.
        let mut rng = ChaCha8Rng::seed_from_u64(run.world_seed);
        world.odometry = params.odometry.perturb(&world.odometry, &mut rng);
    }
    Ok(world)
}

/// World → algorithm → metrics. Returns the trace, the final map, the metrics, and whether the
/// estimate diverged.
fn simulate(
    plan: &ExperimentPlan,
    run: &RunSpec,
    world: impl FnOnce() -> worlds::Shared,
) -> Result<(TraceRows, RunLandmarks, MatchRows, metrics::RunMetrics, bool), String> {
    let shared = world()?;
    (|| -> Result<_, SimError> {
        let params = &plan.points[run.point].params;
        let kind = plan.maps[run.map].world_kind();
        let start = Instant::now();
        let mut clock = || start.elapsed().as_secs_f64();
        let features = |p: &crate::features::FeatureParams| shared.features(p);
        let launch = |l: &crate::algo::Launch<'_>| external::launch(l, &run.run_id);
        let output = plan.algorithm(run).run(RunInput {
            world: &shared.world,
            kind,
            params,
            run_id: &run.run_id,
            seed: run.filter_seed,
            features: &features,
            clock: &mut clock,
            launch: &launch,
        })?;
        // A scan matcher's metrics cover the steps up to its last match: a copy of the world
        // cut there.
        let cut = output.steps.map(|steps| {
            let mut cut = shared.world.clone();
            cut.truth.truncate(steps);
            cut.odometry.truncate(steps.saturating_sub(1));
            cut
        });
        let trace = output.trace;
        let world: &world::World = cut.as_ref().unwrap_or(&shared.world);
        let mut metrics = metrics::compute(world, &trace);
        // a scan matcher's incremental map against the walls of a simulated map
        let map = &plan.maps[run.map];
        if !trace.matches.is_empty() && map.dataset.is_none() && !map.map.walls.is_empty() {
            let mut steps = crate::scanmatch::track::matched_steps(&trace.matches);
            steps.sort_unstable();
            steps.dedup();
            metrics.push((
                metrics::MAP_WALL_RMS,
                metrics::map_wall_rms(world, &trace.estimate, &steps, &map.map.walls),
            ));
        }
        let diverged = trace.estimate.iter().any(|p| !p.is_finite());
        let landmarks = RunLandmarks {
            run_id: run.run_id.clone(),
            landmarks: trace
                .map
                .iter()
                .flat_map(|m| {
                    let lines = m
                        .lines
                        .iter()
                        .map(|l| LandmarkRow::Line { rho_m: l.rho, theta_rad: l.theta });
                    let corners =
                        m.corners.iter().map(|c| LandmarkRow::Corner { x_m: c.x, y_m: c.y });
                    let points = m.points.iter().enumerate().map(|(i, p)| LandmarkRow::Point {
                        x_m: p.x,
                        y_m: p.y,
                        id: m.point_ids.get(i).copied().flatten().map(|id| id as u32),
                    });
                    lines.chain(corners).chain(points)
                })
                .collect(),
        };
        let matches = MatchRows { run_id: run.run_id.clone(), matches: trace.matches };
        let rows = TraceRows {
            run_id: run.run_id.clone(),
            dt_s: world.dt_s,
            truth: world.truth.clone(),
            estimate: trace.estimate,
            neff: trace.neff,
        };
        Ok((rows, landmarks, matches, metrics, diverged))
    })()
    .map_err(|e| e.to_string())
}

/// The parameters of `run` that differ from those `previous` (its earlier result) ran with, as
/// "path: old → new" ("—" where one side lacks the parameter), in path order.
pub fn changed_parameters(plan: &ExperimentPlan, run: &RunSpec, previous: &RunRow) -> Vec<String> {
    let params = base_row(plan, run).params;
    let now: BTreeMap<&str, &ParamValue> = params.iter().map(|(k, v)| (k.as_str(), v)).collect();
    let before: BTreeMap<&str, &ParamValue> =
        previous.params.iter().map(|(k, v)| (k.as_str(), v)).collect();
    let keys: std::collections::BTreeSet<&str> = now.keys().chain(before.keys()).copied().collect();
    let show = |v: Option<&&ParamValue>| v.map_or("—".to_string(), |v| v.to_string());
    keys.into_iter()
        .filter(|k| now.get(k) != before.get(k))
        .map(|k| format!("{k}: {} → {}", show(before.get(k)), show(now.get(k))))
        .collect()
}

/// The study-specific fields of a run's row (status and metrics are filled by the caller).
fn base_row(plan: &ExperimentPlan, run: &RunSpec) -> RunRow {
    let mut leaves = Vec::new();
    flatten(
        "",
        &toml::Value::Table(
            plan.points[run.point]
                .params
                .sections(&plan.algorithm(run).sections_read(plan.maps[run.map].world_kind())),
        ),
        &mut leaves,
    );
    RunRow {
        study: plan.id().to_string(),
        run_id: run.run_id.clone(),
        map: plan.maps[run.map].name.clone(),
        algorithm: run.algorithm.to_string(),
        point: plan.points[run.point].label.clone(),
        replicate: run.replicate,
        world_seed: run.world_seed,
        filter_seed: run.filter_seed,
        status: RunStatus::Ok,
        error: None,
        run_hash: run.hash.clone(),
        params_hash: run.params_hash.clone(),
        code_version: run.code_version.to_string(),
        params: leaves.iter().map(|(k, v)| (k.clone(), ParamValue::from_toml(v))).collect(),
        metrics: Vec::new(),
    }
}

/// A cache entry may come from another study or run id with identical inputs: give it this
/// run's identity.
/// Studies from this many runs say what they do before their first run starts (looking up and
/// scheduling 10⁶ runs takes seconds).
const LARGE_STUDY: usize = 100_000;

/// A run as a study keeps it until its results are written: what its row takes from the
/// computation (the rest of the row is the study's own, from the plan).
struct Done {
    status: RunStatus,
    error: Option<String>,
    metrics: Vec<(String, f64)>,
    wall_ms: f64,
    trace_rows: usize,
    /// Taken from the cache this time.
    cached: bool,
    /// Its trace, landmarks and matches when they could not be cached (else read back from the
    /// cache when the study is written).
    held: Option<store::RunParts>,
}

impl Done {
    fn of(
        row: RunRow,
        wall_ms: f64,
        trace_rows: usize,
        cached: bool,
        held: Option<store::RunParts>,
    ) -> Self {
        let RunRow { status, error, metrics, .. } = row;
        Self { status, error, metrics, wall_ms, trace_rows, cached, held }
    }

    /// The row of `run` of this study: its own id, point, seeds and parameters; the computed (or
    /// cached) status, error and metrics.
    fn row(&self, plan: &ExperimentPlan, run: &RunSpec) -> RunRow {
        RunRow {
            status: self.status,
            error: self.error.clone(),
            metrics: self.metrics.clone(),
            ..base_row(plan, run)
        }
    }
}

fn manifest(plan: &ExperimentPlan, p: &Provenance, runs: usize, failed: usize) -> Manifest {
    let mut code_versions = BTreeMap::new();
    code_versions.insert("schema".to_string(), SCHEMA_VERSION.to_string());
    code_versions.insert("world".to_string(), WORLD_CODE_VERSION.to_string());
    code_versions.insert("metrics".to_string(), metrics::METRICS_VERSION.to_string());
    for a in &plan.spec.spec.algorithms {
        let a = plan.spec.catalogue.algorithm(a);
        code_versions.insert(a.name().to_string(), a.code_version().to_string());
    }
    if plan.maps.iter().any(|m| m.dataset.is_some()) {
        code_versions
            .insert("datasets".to_string(), crate::dataset::DATASET_CODE_VERSION.to_string());
    }
    if plan.maps.iter().any(|m| m.dataset.is_none() && m.world_kind() == WorldKind::Points) {
        code_versions.insert(
            "point sensor".to_string(),
            crate::world::point_sensor::POINT_SENSOR_CODE_VERSION.to_string(),
        );
    }
    Manifest {
        study: plan.id().to_string(),
        schema_version: SCHEMA_VERSION.to_string(),
        crate_version: p.crate_version.clone(),
        git_commit: p.git_commit.clone(),
        git_dirty: p.git_dirty,
        rustc: p.rustc.clone(),
        spec_path: display_path(&plan.spec.path),
        spec_blake3: plan.spec.hash.clone(),
        code_versions,
        maps: plan.maps.iter().map(|m| (m.name.clone(), m.hash.clone())).collect(),
        runs,
        failed,
    }
}

/// The spec's path relative to the working directory (the repository) when it lies below it,
/// else only its file name: no absolute path reaches manifests and reports.
fn display_path(p: &Path) -> String {
    let absolute = if p.is_absolute() {
        Some(p.to_path_buf())
    } else {
        std::env::current_dir().ok().map(|c| c.join(p))
    };
    let below_cwd = absolute
        .as_ref()
        .zip(std::env::current_dir().ok())
        .and_then(|(a, cwd)| a.strip_prefix(&cwd).ok().map(Path::to_path_buf));
    let shown = match below_cwd {
        Some(rel) => rel,
        None => PathBuf::from(p.file_name().unwrap_or_default()),
    };
    shown.to_string_lossy().replace('\\', "/")
}

fn resolved(plan: &ExperimentPlan) -> ResolvedStudy {
    // `spec.base` is already resolved: serialising it writes every default out.
    ResolvedStudy {
        spec: plan.spec.spec.clone(),
        groups: plan
            .groups
            .iter()
            .map(|g| GroupRecord {
                kind: g.kind,
                params: g.params.clone(),
                named: g.named,
                design: g.design.clone(),
            })
            .collect(),
        points: plan
            .points
            .iter()
            .map(|p| PointRecord {
                label: p.label.clone(),
                groups: p.groups.clone(),
                assignments: p.assignments.iter().cloned().collect(),
            })
            .collect(),
        claims: plan.claims.clone(),
        landmark_points: plan.landmark_points.clone(),
        externals: plan
            .spec
            .catalogue
            .externals()
            .filter(|e| plan.spec.spec.algorithms.iter().any(|a| a.as_str() == e.name))
            .cloned()
            .collect(),
        items: plan.items.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(id: &str, params: &str, code: &str) -> RunSpec {
        RunSpec {
            run_id: id.into(),
            map: 0,
            point: 0,
            algorithm: crate::algo::AlgorithmId("odometry".into()),
            replicate: 0,
            world_seed: 1,
            filter_seed: 2,
            params_hash: params.into(),
            code_version: code.into(),
            hash: format!("{params}/{code}"),
        }
    }

    fn row(id: &str, params: &str, code: &str) -> RunRow {
        RunRow {
            study: "s".into(),
            run_id: id.into(),
            map: "m".into(),
            algorithm: "odometry".into(),
            point: "base".into(),
            replicate: 0,
            world_seed: 1,
            filter_seed: 2,
            status: RunStatus::Ok,
            error: None,
            run_hash: format!("{params}/{code}"),
            params_hash: params.into(),
            code_version: code.into(),
            params: vec![],
            metrics: vec![],
        }
    }

    #[test]
    fn every_reason_is_told_apart() {
        let runs = [
            run("a", "p1", "c1"),
            run("b", "p2", "c1"),
            run("c", "p1", "c2"),
            run("d", "p2", "c2"),
            run("e", "p1", "c1"),
            run("f", "p1", "c1"),
        ];
        let previous = [
            row("b", "p1", "c1"),
            row("c", "p1", "c1"),
            row("d", "p1", "c1"),
            row("e", "p1", "c1"),
            row("f", "p1", "c1"),
        ];
        let cached = |h: &str| h == "p1/c1";
        // "a" and "f" have the cached hash; "e" too — it is the same content
        let got = explain(&runs, &cached, &previous, false);
        assert_eq!(
            got,
            [
                Reason::Cached,
                Reason::ParametersChanged,
                Reason::CodeVersionChanged,
                Reason::ParametersAndCodeVersionChanged,
                Reason::Cached,
                Reason::Cached
            ]
        );
        // the cache entry is gone although nothing changed
        assert_eq!(explain(&runs[4..5], &|_| false, &previous, false), [Reason::CacheMissing]);
        assert!(explain(&runs, &cached, &previous, true).iter().all(|r| *r == Reason::Forced));
    }
}
