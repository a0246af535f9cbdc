//! Sequential replication (issue 31): a study with `max_replicates` judges its claims at looks
//! n₁ = `replicates` < n₂ < … < n_K = `max_replicates`, and adds the next stage of replicates
//! only to the cells its still-undecided claims compare. The rule, fixed by the spec before the
//! first look:
//!
//! - **Levels.** Each side of every test (confirm, refute) spends the fixed design's one-sided α
//!   (2.5 % for the 95 % intervals, 5 % for the TOST halves of `flat`) over the looks by the
//!   spec's spending function at information fraction n_k / n_K ([`crate::stats::sequential`]);
//!   look k judges every test at its nominal level, so the repeated looks do not inflate the
//!   error rates.
//! - **Margins.** A relative minimum effect or tolerance is taken of its reference cell at the
//!   first look, so the hypothesis every look tests is the same.
//! - **Stopping.** A unit (map, or map @ cell) confirmed or refuted at a look keeps that verdict;
//!   a claim whose units combine (`require`) to a verdict keeps it. A claim pooled over its maps
//!   is judged as a whole at every look.
//! - **Where replicates go.** Only to the cells of the undecided units of undecided claims, and
//!   only while a study of the whole budget, with the unit's observed effect as the true one,
//!   would decide it with a chance of at least [`FUTILITY_POWER`] ([`Design::futility_replicates`], from the unit's projection
//!   at the last look's levels, [`crate::stats::power`]). The futility rule is non-binding: it
//!   only withholds runs, so it cannot raise the chance of a wrong verdict. Pooled claims,
//!   failure counts and untestable units get none.
//! - **The end.** The looks stop when no cell is asked for, or at n_K.
//!
//! The same function ([`replay`]) decides the stages while `slamlab run` runs them and re-judges
//! the stored runs in the report, so both always agree: the stages are a function of the runs'
//! results, which are a function of the spec.

use super::agreement::{self, Agreement, Needed, Outcome};
use super::claims::{self, ClaimResult, Context, Levels, MapOutcome, Verdict};
use super::margins::{self, WorkMargins};
use super::scoreboard::{self, CellSelector, Class, ItemCell};
use crate::spec::{ClaimTest, ExperimentSpec, Spending};
use crate::stats::power::Replicates;
use crate::stats::sequential as gs;
use crate::store::StudyData;
use std::collections::{BTreeMap, BTreeSet};

/// Power under the observed trend below which a unit gets no more replicates.
pub const FUTILITY_POWER: f64 = 0.10;

/// A cell: (map, algorithm, sweep point label).
pub type Cell = (String, String, String);

/// A study's group-sequential design.
#[derive(Debug, Clone, PartialEq)]
pub struct Design {
    pub spending: Spending,
    /// Replicates per cell at each look (ascending; the last is `max_replicates`).
    pub looks: Vec<u32>,
    /// The nominal levels of each look.
    pub levels: Vec<Levels>,
    /// The one-sided α spent by each look, cumulative, for the 2.5 % and the 5 % sides.
    pub spent: Vec<(f64, f64)>,
}

impl Design {
    /// The design a spec declares; `None` for a fixed study.
    pub fn of(spec: &ExperimentSpec) -> Option<Design> {
        let looks = spec.looks()?;
        Some(Design::new(spec.sequential.as_ref().map(|s| s.spending).unwrap_or_default(), looks))
    }

    pub fn new(spending: Spending, looks: Vec<u32>) -> Design {
        let max = f64::from(*looks.last().expect("at least one look"));
        let t: Vec<f64> = looks.iter().map(|&n| f64::from(n) / max).collect();
        let function = match spending {
            Spending::ObrienFleming => gs::Spending::ObrienFleming,
            Spending::Pocock => gs::Spending::Pocock,
        };
        let side = Levels::FIXED.side();
        let tost = Levels::FIXED.tost_alpha;
        let levels = gs::nominal_levels(function, side, &t)
            .into_iter()
            .zip(gs::nominal_levels(function, tost, &t))
            .map(|(s, a)| Levels { confidence: 1.0 - 2.0 * s, tost_alpha: a })
            .collect();
        let spent = t.iter().map(|&t| (function.spent(side, t), function.spent(tost, t))).collect();
        Design { spending, looks, levels, spent }
    }

    /// The projection (replicates at which the observed trend reaches the last look's bound)
    /// beyond which a unit gets no more replicates: N · (c / (c − z₀.₉))², with N the budget and
    /// c the last look's boundary (of the 2.5 % side), is where a study of N replicates with the
    /// observed effect as the true one would decide with a chance of about 10 % (θ̂√N = c − z₀.₉,
    /// with θ̂ = c / √n*): the power under the observed trend, a simpler and slightly more
    /// lenient reading than conditional power given the runs so far. The 10 % is the usual
    /// futility bound (Lachin 2005, *Clin. Trials* 2:325; Jennison & Turnbull 2000, §10.6),
    /// chosen before the first study ran.
    pub fn futility_replicates(&self) -> f64 {
        self.futility_replicates_at(self.last().side())
    }

    /// [`Design::futility_replicates`] for a test whose last look is at one-sided level
    /// `last_alpha` (a published cell's, at the 5 % side's last level).
    pub fn futility_replicates_at(&self, last_alpha: f64) -> f64 {
        let budget = f64::from(*self.looks.last().expect("at least one look"));
        let c = gs::z_quantile(1.0 - last_alpha);
        let z = gs::z_quantile(1.0 - FUTILITY_POWER);
        budget * (c / (c - z)).powi(2)
    }

    /// The last look's levels: what a decision at the full budget needs (the projections').
    pub fn last(&self) -> Levels {
        *self.levels.last().expect("at least one look")
    }

    /// The spending function in words.
    pub fn spending_text(&self) -> &'static str {
        match self.spending {
            Spending::ObrienFleming => "O'Brien–Fleming type (Lan–DeMets)",
            Spending::Pocock => "Pocock type (Lan–DeMets)",
        }
    }
}

/// One look, as it was taken.
#[derive(Debug, Clone, PartialEq)]
pub struct Look {
    /// Replicates per cell (of the cells that reached this look).
    pub n: u32,
    pub levels: Levels,
    /// Cumulative one-sided α spent (2.5 % side, 5 % side).
    pub spent: (f64, f64),
    /// Claims decided at this look: (id, verdict).
    pub decided: Vec<(String, Verdict)>,
    /// Cells given the next stage's replicates after this look.
    pub extended: Vec<Cell>,
    /// Published cells of staged items shown equivalent or different at this look.
    pub cells_decided: usize,
}

/// A published result item the study staged (`[sequential] items`), as its looks judged it.
#[derive(Debug, Clone, PartialEq)]
pub struct StagedItem {
    pub id: String,
    /// Each published cell's judgement, with the look (0-based) it is from: the look that showed
    /// it equivalent or different, else the last look taken.
    pub cells: BTreeMap<ItemCell, (Agreement, usize)>,
    /// The item's class at each look taken.
    pub classes: Vec<Class>,
    /// The nominal one-sided level of the last look taken (a cell it did not reach is judged so).
    last_alpha: f64,
}

impl StagedItem {
    /// The item's class and basis from its cells as the looks judged them
    /// ([`scoreboard::classify_cells_with`]).
    pub fn classify(
        &self,
        data: &StudyData,
        sel: &CellSelector,
        work: &WorkMargins,
    ) -> (Class, String) {
        let (class, mut basis) = scoreboard::classify_cells_with(data, sel, work, &|c| {
            self.cells.get(&c.key).map_or_else(
                || agreement::judge_at(c.published, &c.ours, c.eps, self.last_alpha),
                |(a, _)| *a,
            )
        });
        let taken = self.classes.len();
        let early = self.cells.values().filter(|(a, k)| decisive_cell(a) && *k + 1 < taken).count();
        basis.push_str(&format!(
            "; judged look by look in this sequential study: {early} cells decided before look {taken}, each at the nominal level of the look that decided it, the rest at look {taken}'s (α {} per side)",
            crate::stats::sig(self.last_alpha, 2)
        ));
        (class, basis)
    }
}

fn decisive_cell(a: &Agreement) -> bool {
    matches!(a.outcome, Some(Outcome::Equivalent | Outcome::Different))
}

/// What a sequential study did, or is doing.
#[derive(Debug, Clone, PartialEq)]
pub struct Replay {
    pub design: Design,
    pub looks: Vec<Look>,
    /// The claims' results (spec order), each from the look that decided it or the last look.
    pub results: Vec<ClaimResult>,
    /// Claim id → the look (0-based) that decided it.
    pub decided_at: BTreeMap<String, usize>,
    /// The claims decided at a later look whose cells then held replicates beyond the first
    /// stage's: the verdicts the added replicates decided. (A claim decided later on the first
    /// stage's runs alone — pooled, or with cells no undecided claim asked for — is not one.)
    pub added: BTreeSet<String>,
    /// When the runs of the next stage are not all there yet: its replicate count and the cells
    /// that need it (what `slamlab run` computes next).
    pub pending: Option<(u32, Vec<Cell>)>,
    /// Replicates present per cell (runs of any status).
    pub replicates: BTreeMap<Cell, u32>,
    /// The staged published items, in the order the study's items file lists them.
    pub items: Vec<StagedItem>,
}

impl Replay {
    /// The staged item `id`, if the study staged it.
    pub fn item(&self, id: &str) -> Option<&StagedItem> {
        self.items.iter().find(|i| i.id == id)
    }
}

fn decisive(v: Verdict) -> bool {
    matches!(v, Verdict::Confirmed | Verdict::Refuted)
}

/// Judges a sequential study's claims look by look on the runs `data` holds (see the module).
pub fn replay(data: &StudyData, design: &Design) -> Replay {
    let spec = &data.resolved.spec;
    // relative margins (δ, tolerances) are the first look's: the hypothesis does not move
    let context = Context::of(data).with_margins_of(data.up_to(design.looks[0]));
    let budget = *design.looks.last().expect("at least one look");
    let futility = design.futility_replicates();
    let mut replicates: BTreeMap<Cell, u32> = BTreeMap::new();
    for r in &data.runs {
        let n =
            replicates.entry((r.map.clone(), r.algorithm.clone(), r.point.clone())).or_default();
        *n = (*n).max(r.replicate + 1);
    }
    let claims = &spec.claims;
    let mut frozen: Vec<Vec<Option<MapOutcome>>> = vec![Vec::new(); claims.len()];
    let mut latest: Vec<Option<ClaimResult>> = vec![None; claims.len()];
    let mut done = vec![false; claims.len()];
    let mut decided_at = BTreeMap::new();
    let mut added = BTreeSet::new();
    let mut looks = Vec::new();
    let mut pending = None;
    let staged = &data.resolved.items;
    let mut items: Vec<StagedItem> = staged
        .iter()
        .map(|it| StagedItem {
            id: it.id.clone(),
            cells: BTreeMap::new(),
            classes: Vec::new(),
            last_alpha: design.levels[0].tost_alpha,
        })
        .collect();
    let cell_futility = design.futility_replicates_at(design.last().tost_alpha);
    for (k, &n) in design.looks.iter().enumerate() {
        let view = data.up_to(n);
        let look = (design.levels[k], design.last());
        let mut decided = Vec::new();
        let mut asked: BTreeSet<Cell> = BTreeSet::new();
        for (i, claim) in claims.iter().enumerate() {
            if done[i] {
                continue;
            }
            let Some(judged) = claims::judge(&view, &context, claim, look, &frozen[i]) else {
                done[i] = true;
                continue;
            };
            let mut result = judged.result;
            result
                .test
                .push_str("; in this sequential study, at each look's nominal level instead");
            if !judged.pooled {
                frozen[i].resize(judged.outcomes.len(), None);
                for (slot, o) in frozen[i].iter_mut().zip(&judged.outcomes) {
                    if slot.is_none() && decisive(o.verdict) {
                        let mut o = o.clone();
                        o.text.push_str(&format!(
                            " (decided at look {} of {}, n = {n})",
                            k + 1,
                            design.looks.len()
                        ));
                        *slot = Some(o);
                    }
                }
            }
            if decisive(result.verdict) {
                done[i] = true;
                decided_at.insert(claim.id.clone(), k);
                decided.push((claim.id.clone(), result.verdict));
                // the most replicates a cell of the claim holds at this look: a claim no stage
                // gave replicates (pooled, or cells no undecided claim asked for) is decided on
                // the first stage's runs at a later, less strict look
                let algorithms = (judged.algorithms.0.as_str(), judged.algorithms.1.as_str());
                let used = judged
                    .units
                    .iter()
                    .flat_map(|(unit, cells)| {
                        claims::unit_cells(
                            unit.split(" @ ").next().unwrap_or(unit),
                            cells,
                            algorithms,
                        )
                    })
                    .flat_map(|c| {
                        view.runs_in(&c.0, &c.1, &c.2).map(|r| r.replicate + 1).collect::<Vec<_>>()
                    })
                    .max()
                    .unwrap_or(0);
                if k > 0 && used > design.looks[0] {
                    added.insert(claim.id.clone());
                }
                let levels = design.levels[k];
                result.summary.push_str(&format!(
                    ". Decided at look {} of {}, with up to {used} replicates per cell{} (nominal α {} per side, {} for equivalence)",
                    k + 1,
                    design.looks.len(),
                    if k > 0 && used <= design.looks[0] {
                        ", the first stage's: its cells got no more, and the later look is less strict"
                    } else {
                        ""
                    },
                    crate::stats::sig(levels.side(), 2),
                    crate::stats::sig(levels.tost_alpha, 2)
                ));
            } else if result.verdict == Verdict::Inconclusive
                && !judged.pooled
                && claim.test != ClaimTest::Fails
            {
                for ((unit, cells), o) in judged.units.iter().zip(&judged.outcomes) {
                    // (decided already at the last look's level counts: the next look is
                    // stricter than the last, so it needs the replicates)
                    let reachable = match o.replicates {
                        Some(Replicates::Needed(m)) => m as f64 <= futility,
                        Some(Replicates::Decided) => true,
                        _ => false,
                    };
                    if o.verdict == Verdict::Inconclusive && reachable {
                        let map = unit.split(" @ ").next().unwrap_or(unit);
                        let algorithms =
                            (judged.algorithms.0.as_str(), judged.algorithms.1.as_str());
                        asked.extend(claims::unit_cells(map, cells, algorithms));
                    }
                }
            }
            latest[i] = Some(result);
        }
        // the staged published items: each cell is judged at this look's level (the 5 % side's:
        // the cells' intervals are 90 %) until shown equivalent or different; an item still
        // UNRESOLVED asks for its undecided cells' replicates, as an undecided claim does
        let alpha = design.levels[k].tost_alpha;
        // (a published cell two items share is counted once)
        let mut cells_decided: BTreeSet<ItemCell> = BTreeSet::new();
        for (it, item) in staged.iter().zip(items.iter_mut()) {
            let Some(sel) = &it.cells else { continue };
            let work = margins::for_label(&it.seed);
            item.last_alpha = alpha;
            let cells = scoreboard::item_cells(&view, sel, work);
            for c in &cells {
                if item.cells.get(&c.key).is_some_and(|(a, _)| decisive_cell(a)) {
                    continue;
                }
                let a = agreement::judge_at(c.published, &c.ours, c.eps, alpha);
                if decisive_cell(&a) {
                    cells_decided.insert(c.key.clone());
                }
                item.cells.insert(c.key.clone(), (a, k));
            }
            let (class, _) = item.classify(&view, sel, work);
            item.classes.push(class);
            if class != Class::Unresolved {
                continue;
            }
            for c in &cells {
                if item
                    .cells
                    .get(&c.key)
                    .is_none_or(|(a, _)| a.outcome != Some(Outcome::Unresolved))
                {
                    continue;
                }
                // the replicates that would resolve it at the last look's level, within the
                // futility bound (the claims' rule, at the 5 % side)
                let at_last =
                    agreement::judge_at(c.published, &c.ours, c.eps, design.last().tost_alpha);
                let reachable = match at_last.needed {
                    Some(Needed::Replicates(m)) => m as f64 <= cell_futility,
                    Some(Needed::Never) => false,
                    // decided already at the last look's level: the next look is stricter
                    None => decisive_cell(&at_last),
                };
                if reachable {
                    asked.insert(c.run_cell.clone());
                }
            }
        }
        let last = k + 1 == design.looks.len();
        let extended: Vec<Cell> = if last { Vec::new() } else { asked.into_iter().collect() };
        let stop = extended.is_empty();
        looks.push(Look {
            n,
            levels: design.levels[k],
            spent: design.spent[k],
            decided,
            extended: extended.clone(),
            cells_decided: cells_decided.len(),
        });
        if stop {
            break;
        }
        let next = design.looks[k + 1];
        let stage_done = extended.iter().all(|cell| {
            let have: BTreeSet<u32> = data
                .runs_in(&cell.0, &cell.1, &cell.2)
                .map(|r| r.replicate)
                .filter(|&r| r < next)
                .collect();
            have.len() == next as usize
        });
        if !stage_done {
            pending = Some((next, extended));
            break;
        }
    }
    // the claims still open: their last look's result, and why they stopped there
    let taken = looks.len();
    let n_last = looks.last().map_or(0, |l| l.n);
    let results = latest
        .into_iter()
        .zip(claims)
        .filter_map(|(r, claim)| {
            let mut r = r?;
            if !decided_at.contains_key(&claim.id) && r.verdict == Verdict::Inconclusive {
                r.summary.push_str(&format!(
                    ". Undecided at look {taken} of {} ({n_last} replicates per cell at most; budget {budget})",
                    design.looks.len()
                ));
            }
            Some(r)
        })
        .collect();
    Replay { design: design.clone(), looks, results, decided_at, added, pending, replicates, items }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::ExperimentSpec;
    use crate::store::{ClaimCells, Manifest, PointRecord, ResolvedStudy, RunRow, RunStatus};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn normal(rng: &mut ChaCha8Rng) -> f64 {
        StandardNormal.sample(rng)
    }

    /// A successful odometry run of the simulated study on map `m` with metric `y`.
    fn row(point: &str, replicate: u32, y: f64) -> RunRow {
        RunRow {
            study: "sim".into(),
            run_id: format!("m--odometry--{point}--r{replicate:02}"),
            map: "m".into(),
            algorithm: "odometry".into(),
            point: point.into(),
            replicate,
            world_seed: 0,
            filter_seed: 0,
            status: RunStatus::Ok,
            error: None,
            run_hash: String::new(),
            params_hash: String::new(),
            code_version: String::new(),
            params: Vec::new(),
            metrics: vec![("y".into(), y)],
        }
    }

    /// δ of the simulated claim ("b exceeds a by more than 0.1"), and the spread of a paired
    /// difference.
    const DELTA: f64 = 0.1;
    const SIGMA: f64 = 1.0;

    fn spec(spending: &str) -> ExperimentSpec {
        toml::from_str(&format!(
            r#"id = "sim"
title = "simulated"
seed = 1
replicates = 8
max_replicates = 40
maps = ["m"]
algorithms = ["odometry"]
[sequential]
spending = "{spending}"
[[claims]]
id = "c"
source = "s"
kind = "extension"
text = "b exceeds a"
metric = "y"
test = "greater"
at = {{ k = 2 }}
than = {{ k = 1 }}
min_effect = {DELTA}
why = "simulated"
"#
        ))
        .unwrap()
    }

    /// A study whose cell b exceeds cell a by `effect` + N(0, SIGMA²) in each of 40 replicates.
    fn study(spec: &ExperimentSpec, effect: f64, rng: &mut ChaCha8Rng) -> StudyData {
        let point = |label: &str| PointRecord {
            label: label.into(),
            groups: Vec::new(),
            assignments: Default::default(),
        };
        let resolved = ResolvedStudy {
            spec: spec.clone(),
            groups: Vec::new(),
            points: vec![point("a"), point("b")],
            claims: vec![ClaimCells {
                id: "c".into(),
                at: Some("b".into()),
                than: Some("a".into()),
                over: Vec::new(),
            }],
            landmark_points: Vec::new(),
            externals: Vec::new(),
            items: Vec::new(),
        };
        let mut runs = Vec::new();
        for r in 0..40 {
            let a = 10.0 + normal(rng);
            let d = normal(rng);
            runs.push(row("a", r, a));
            runs.push(row("b", r, a + effect + SIGMA * d));
        }
        let manifest = Manifest::blank("sim", runs.len());
        StudyData::new(Default::default(), resolved, manifest, runs, Vec::new(), Vec::new())
    }

    /// Share of trials confirming and refuting, and the mean replicates at the stop.
    fn simulate(spending: &str, effect: f64, trials: usize, seed: u64) -> (f64, f64, f64) {
        let spec = spec(spending);
        let design = Design::of(&spec).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (mut confirmed, mut refuted, mut replicates) = (0usize, 0usize, 0u64);
        for _ in 0..trials {
            let replay = replay(&study(&spec, effect, &mut rng), &design);
            assert!(replay.pending.is_none());
            match replay.results[0].verdict {
                Verdict::Confirmed => confirmed += 1,
                Verdict::Refuted => refuted += 1,
                _ => {}
            }
            replicates += u64::from(replay.looks.last().unwrap().n);
        }
        let share = |k: usize| k as f64 / trials as f64;
        (share(confirmed), share(refuted), replicates as f64 / trials as f64)
    }

    /// A study of one published cell (a mean of 5 runs, printed spread 0) and our cell of
    /// N(`mean`, `sd`²) replicates, with the item that compares them staged.
    fn item_study(mean: f64, sd: f64, rng: &mut ChaCha8Rng) -> StudyData {
        let spec: ExperimentSpec = toml::from_str(
            r#"id = "sim"
title = "simulated"
seed = 1
replicates = 8
max_replicates = 40
maps = ["m"]
algorithms = ["odometry"]
[sequential]
items = "items.toml"
[report]
reference = { file = "published.csv", experiments = ["e"], label = "[EP]", runs = 5 }
"#,
        )
        .unwrap();
        let item = crate::spec::items::Item {
            id: "I".into(),
            seed: "EP".into(),
            source: "s".into(),
            result: "r".into(),
            study: Some("sim".into()),
            cells: Some(CellSelector {
                file: "published.csv".into(),
                experiment: Some("e".into()),
                metrics: vec!["y".into()],
                axis: Some(scoreboard::Axis::None),
                ..Default::default()
            }),
            claims: Vec::new(),
            shape: Vec::new(),
            missing: None,
        };
        let resolved = ResolvedStudy {
            spec,
            groups: Vec::new(),
            points: vec![PointRecord {
                label: "a".into(),
                groups: Vec::new(),
                assignments: [("k".to_string(), toml::Value::Float(1.0))].into_iter().collect(),
            }],
            claims: Vec::new(),
            landmark_points: Vec::new(),
            externals: Vec::new(),
            items: vec![item],
        };
        let reference = vec![crate::store::reference::ReferenceRow {
            experiment: "e".into(),
            table: "t".into(),
            map: "m".into(),
            parameter: "k".into(),
            value: 1.0,
            metrics: vec![("y".into(), 10.0), ("y_var".into(), 0.0)],
            algorithm: String::new(),
            cell: String::new(),
        }];
        let runs: Vec<RunRow> = (0..40).map(|r| row("a", r, mean + sd * normal(rng))).collect();
        let manifest = Manifest::blank("sim", runs.len());
        StudyData::new(Default::default(), resolved, manifest, runs, Vec::new(), reference)
    }

    /// Shares of trials whose cell ends shown equivalent and shown different, and the mean
    /// replicates at the stop, under `design`.
    fn simulate_item(design: &Design, mean: f64, trials: usize, seed: u64) -> (f64, f64, f64) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (mut equivalent, mut different, mut replicates) = (0usize, 0usize, 0u64);
        for _ in 0..trials {
            let replay = replay(&item_study(mean, 3.0, &mut rng), design);
            assert!(replay.pending.is_none());
            let item = replay.item("I").expect("the item is staged");
            assert_eq!(item.classes.len(), replay.looks.len());
            match item.cells.values().next().and_then(|(a, _)| a.outcome) {
                Some(Outcome::Equivalent) => equivalent += 1,
                Some(Outcome::Different) => different += 1,
                _ => {}
            }
            replicates += u64::from(replay.looks.last().unwrap().n);
        }
        let share = |k: usize| k as f64 / trials as f64;
        (share(equivalent), share(different), replicates as f64 / trials as f64)
    }

    /// A published item's cells under the looks keep the fixed design's errors: with our mean
    /// exactly at the margin's edge (10 + 20 %: neither equivalent nor different is true), the
    /// looks show the cell equivalent, and different, each no more often than the 5 % each side
    /// spends (within three standard errors of the simulation); the same looks each at the fixed
    /// 5 % (no spending) exceed it. A cell well inside the margin is shown equivalent, and the
    /// item stops asking once it is.
    #[test]
    fn staged_items_keep_the_cells_error_rates() {
        let spec = item_study(10.0, 1.0, &mut ChaCha8Rng::seed_from_u64(0)).resolved.spec;
        let design = Design::of(&spec).unwrap();
        let trials = 2000;
        let bound = 0.05 + 3.0 * (0.05 * 0.95 / trials as f64).sqrt();
        let (equivalent, different, n) = simulate_item(&design, 12.0, trials, 5);
        assert!(equivalent <= bound, "shown equivalent {equivalent} > {bound}");
        assert!(different <= bound, "shown different {different} > {bound}");
        assert!(n > 8.0, "the looks went on: {n}");
        let naive = Design { levels: vec![Levels::FIXED; design.looks.len()], ..design.clone() };
        let (equivalent_naive, _, _) = simulate_item(&naive, 12.0, trials, 5);
        assert!(equivalent_naive > 0.06, "repeated looks at 5 % stay at {equivalent_naive}");
        // a real agreement (our mean 1 % off, the margin 20 %): shown equivalent, then no more runs
        let (equivalent, _, n) = simulate_item(&design, 10.1, 200, 6);
        assert!(equivalent > 0.9, "{equivalent}");
        assert!(n < 40.0, "stopped before the budget on average: {n}");
    }

    #[test]
    fn the_design_states_its_looks_and_levels() {
        let d = Design::of(&spec("obrien_fleming")).unwrap();
        assert_eq!(d.looks, [8, 16, 24, 32, 40]);
        // the 2.5 % side at five equal looks: 1 − Φ(c) of the published 4.877, …, 2.031
        let published = [4.877, 3.357, 2.680, 2.290, 2.031];
        for (l, c) in d.levels.iter().zip(published) {
            let want = gs::upper_tail(c);
            assert!((l.side() - want).abs() < 0.02 * want, "{} against {want}", l.side());
        }
        assert!((d.spent[4].0 - 0.025).abs() < 1e-9 && (d.spent[4].1 - 0.05).abs() < 1e-9);
        assert!(Design::of(&toml::from_str("id = \"x\"\ntitle = \"x\"\nseed = 1\nreplicates = 8\nmaps = [\"m\"]\nalgorithms = [\"odometry\"]\n").unwrap()).is_none());
    }

    /// The issue's must-show, on the procedure `slamlab run` and the report use (`replay`):
    /// with the effect exactly at δ — no effect beyond the claim's margin, the least favourable
    /// case for both errors — the looks confirm and refute each no more often than the 2.5 % each
    /// side spends (within three standard errors of the simulation; the issue asks for 5 %),
    /// under either spending function.
    #[test]
    fn repeated_looks_keep_both_error_rates() {
        let trials = 4000;
        let side = Levels::FIXED.side();
        let bound = side + 3.0 * (side * (1.0 - side) / trials as f64).sqrt();
        for spending in ["obrien_fleming", "pocock"] {
            let (confirmed, refuted, _) = simulate(spending, DELTA, trials, 31);
            assert!(
                confirmed <= bound,
                "{spending}: confirmed {confirmed} with no effect beyond δ"
            );
            assert!(refuted <= bound, "{spending}: refuted {refuted} an effect at δ");
        }
        // no effect at all: confirming is rarer still
        let (confirmed, _, _) = simulate("obrien_fleming", 0.0, 2000, 32);
        assert!(confirmed <= side, "confirmed {confirmed} without any effect");
    }

    /// A one-sided threshold claim ("above 9") whose mean lies above the threshold but whose
    /// interval does not yet: the projection is the replicates that clear the threshold, not
    /// "more than the cap" from the infinite upper end of its range — and a sequential look
    /// therefore gives its cell the next stage.
    #[test]
    fn an_undecided_threshold_claim_projects_a_count_and_gets_the_next_stage() {
        let text = toml::to_string(&spec("obrien_fleming")).unwrap();
        let text = text
            .replace("test = \"greater\"", "test = \"above\"\nvalue = 9.0")
            .replace("min_effect = 0.1\n", "");
        let mut above: ExperimentSpec = toml::from_str(&text).unwrap();
        above.claims[0].than = Default::default();
        let mut rng = ChaCha8Rng::seed_from_u64(36);
        let mut data = study(&above, 0.0, &mut rng);
        data.resolved.claims[0].than = None;
        let first = data.up_to(8);
        let fixed = claims::evaluate(&first);
        assert_eq!(fixed[0].verdict, Verdict::Inconclusive, "{}", fixed[0].summary);
        assert!(
            fixed[0].projection.contains("replicates would decide")
                && !fixed[0].projection.contains("more than"),
            "{}",
            fixed[0].projection
        );
        let replay = replay(&first, &Design::of(&above).unwrap());
        let (next, cells) = replay.pending.expect("the first look asks for the next stage");
        assert_eq!(next, 16);
        assert_eq!(cells, [("m".to_string(), "odometry".to_string(), "b".to_string())]);
    }

    /// A relative minimum effect is taken of the compared cell at the first look: every look
    /// tests the same hypothesis, not one that moves with the cell's mean as replicates arrive.
    #[test]
    fn a_relative_margin_is_the_first_looks() {
        let text = toml::to_string(&spec("obrien_fleming")).unwrap();
        let relative: ExperimentSpec =
            toml::from_str(&text.replace("min_effect = 0.1\n", "min_effect_rel = 0.05\n")).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(37);
        let data = study(&relative, 0.8, &mut rng);
        let replay = replay(&data, &Design::of(&relative).unwrap());
        let decided = replay.decided_at["c"];
        assert!(decided > 0, "decided at the first look: nothing to test");
        let level = |d: &StudyData| {
            let a = d.replicate_values("m", "odometry", "a", "y");
            0.05 * (a.values().sum::<f64>() / a.len() as f64).abs()
        };
        let (first, then) = (level(&data.up_to(8)), level(&data.up_to(replay.looks[decided].n)));
        assert_ne!(crate::stats::sig(first, 3), crate::stats::sig(then, 3), "pick another seed");
        let evidence = &replay.results[0].evidence[0];
        assert!(
            evidence.contains(&format!("against δ = {}", crate::stats::sig(first, 3))),
            "{evidence} (first look's δ {first}, the deciding look's {then})"
        );
    }

    /// Without the spending the same five looks at the fixed 95 % interval confirm far more
    /// often than 2.5 %: the rule is what keeps the rate down (the test above could fail).
    #[test]
    fn naive_repeated_looks_inflate_the_error() {
        let mut rng = ChaCha8Rng::seed_from_u64(33);
        let trials = 4000;
        let mut confirmed = 0;
        for _ in 0..trials {
            let d: Vec<f64> = (0..40).map(|_| DELTA + SIGMA * normal(&mut rng)).collect();
            confirmed += usize::from(
                [8, 16, 24, 32, 40]
                    .iter()
                    .any(|&n| claims::decide_margin(&d[..n], DELTA, true) == Verdict::Confirmed),
            );
        }
        let rate = confirmed as f64 / trials as f64;
        assert!(rate > 0.04, "naive looks confirmed only {rate}");
    }

    /// Under a real effect the looks stop, on average, before the fixed design of the same power:
    /// the fixed design's n is the fewest replicates whose power (simulated with the fixed
    /// design's own test) reaches the sequential procedure's.
    #[test]
    fn a_real_effect_stops_earlier_than_the_fixed_design_of_the_same_power() {
        let effect = DELTA + 0.55;
        let (power, _, mean_n) = simulate("obrien_fleming", effect, 2000, 34);
        assert!(power > 0.5, "power {power}");
        let mut rng = ChaCha8Rng::seed_from_u64(35);
        let fixed_power = |n: usize, rng: &mut ChaCha8Rng| {
            let trials = 4000;
            let hits = (0..trials)
                .filter(|_| {
                    let d: Vec<f64> = (0..n).map(|_| effect + SIGMA * normal(rng)).collect();
                    claims::decide_margin(&d, DELTA, true) == Verdict::Confirmed
                })
                .count();
            hits as f64 / trials as f64
        };
        let fixed_n = (3..200).find(|&n| fixed_power(n, &mut rng) >= power).unwrap();
        assert!(
            mean_n < fixed_n as f64,
            "sequential: power {power} at {mean_n} replicates on average; fixed: {fixed_n}"
        );
    }
}
