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
//! - **Stopping.** A unit (map, or map @ cell) confirmed or refuted at a look keeps that verdict;
//!   a claim whose units combine (`require`) to a verdict keeps it. A claim pooled over its maps
//!   is judged as a whole at every look.
//! - **Where replicates go.** Only to the cells of the undecided units of undecided claims, and
//!   only where the unit's projection at the last look's levels ([`crate::stats::power`]) lies
//!   within the budget: a unit that even `max_replicates` would not decide at its observed mean and
//!   spread stops there (non-binding futility: it only withholds runs, so it cannot raise the
//!   chance of a wrong verdict). Pooled claims, failure counts and untestable units get none.
//! - **The end.** The looks stop when no cell is asked for, or at n_K.
//!
//! The same function ([`replay`]) decides the stages while `slamlab run` runs them and re-judges
//! the stored runs in the report, so both always agree: the stages are a function of the runs'
//! results, which are a function of the spec.

use super::claims::{self, ClaimResult, Context, Levels, MapOutcome, Verdict};
use crate::spec::{ClaimTest, ExperimentSpec, Spending};
use crate::stats::power::Replicates;
use crate::stats::sequential as gs;
use crate::store::StudyData;
use std::collections::{BTreeMap, BTreeSet};

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
    /// When the runs of the next stage are not all there yet: its replicate count and the cells
    /// that need it (what `slamlab run` computes next).
    pub pending: Option<(u32, Vec<Cell>)>,
    /// Replicates present per cell (runs of any status).
    pub replicates: BTreeMap<Cell, u32>,
}

fn decisive(v: Verdict) -> bool {
    matches!(v, Verdict::Confirmed | Verdict::Refuted)
}

/// Judges a sequential study's claims look by look on the runs `data` holds (see the module).
pub fn replay(data: &StudyData, design: &Design) -> Replay {
    let spec = &data.resolved.spec;
    let context = Context::of(data);
    let budget = *design.looks.last().expect("at least one look");
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
    let mut looks = Vec::new();
    let mut pending = None;
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
                result.summary.push_str(&format!(
                    ". Decided at look {} of {} ({n} replicates per cell; nominal two-sided level {})",
                    k + 1,
                    design.looks.len(),
                    claims::percent(design.levels[k].confidence)
                ));
            } else if result.verdict == Verdict::Inconclusive
                && !judged.pooled
                && claim.test != ClaimTest::Fails
            {
                for ((unit, cells), o) in judged.units.iter().zip(&judged.outcomes) {
                    // (decided already at the last look's level counts: the next look is
                    // stricter than the last, so it needs the replicates)
                    let reachable = match o.replicates {
                        Some(Replicates::Needed(m)) => m <= budget as usize,
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
        let last = k + 1 == design.looks.len();
        let extended: Vec<Cell> = if last { Vec::new() } else { asked.into_iter().collect() };
        let stop = extended.is_empty();
        looks.push(Look {
            n,
            levels: design.levels[k],
            spent: design.spent[k],
            decided,
            extended: extended.clone(),
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
    Replay { design: design.clone(), looks, results, decided_at, pending, replicates }
}
