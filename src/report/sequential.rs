//! A sequential study's report tables: the looks as they were taken (replicates, nominal
//! levels, α spent, verdicts decided, cells extended), the replicates each cell got, and the
//! verdicts the added replicates decided. Formatting only: the looks are
//! [`crate::judge::sequential::replay`]'s.

use super::model::{NamedTable, TableView};
use crate::judge::sequential::Replay;
use crate::stats::sig;
use std::collections::BTreeMap;

pub fn tables(replay: &Replay, runs: usize) -> Vec<NamedTable> {
    let design = &replay.design;
    let looks_planned: Vec<String> = design.looks.iter().map(|n| n.to_string()).collect();
    let budget = *design.looks.last().expect("at least one look");
    let taken = replay.looks.len();
    let stop = if replay.pending.is_some() {
        format!(
            "The stored runs stop at look {taken}: the runs of the next stage are missing (the study was not run to its end), so the verdicts are those of look {taken}."
        )
    } else if taken == design.looks.len() {
        format!("The looks ended at the budget, look {taken} of {}.", design.looks.len())
    } else if replay.items.is_empty() {
        format!(
            "The looks ended at look {taken} of {}: no undecided claim had a cell worth more replicates (every claim decided, or its trend too weak for the budget).",
            design.looks.len()
        )
    } else {
        format!(
            "The looks ended at look {taken} of {}: no undecided claim and no unresolved published item had a cell worth more replicates.",
            design.looks.len()
        )
    };
    let mut out = Vec::new();
    out.push(NamedTable {
        title: "Sequential replication: the looks".into(),
        caption: format!(
            "Group-sequential design, fixed by the spec before the first look: looks at {} replicates per cell; alpha spending {} at information fraction n / {budget}, for each side of every test (the one-sided 2.5 % of the 95 % intervals, and the 5 % of the TOST halves of flat claims); each look judges at the nominal levels of its boundaries (a two-sided interval at 1 − 2α per side) (Lan & DeMets 1983; Jennison & Turnbull 2000, §3.8, §7.2). A unit (map) decided at a look keeps its verdict; replicates are added only to the cells of undecided units of undecided claims{items}, while a study of the whole budget, with the unit's observed effect as the true one, would decide it with a chance of at least 10 % (a projection within {} replicates; a non-binding futility rule: it withholds runs and cannot raise an error rate). {stop} Runs taken: {runs} of the budget's {} for these cells.",
            looks_planned.join(", "),
            design.spending_text(),
            design.futility_replicates().floor(),
            replay.replicates.len() * budget as usize,
            items = if replay.items.is_empty() {
                ""
            } else {
                " and of the undecided published cells of items still UNRESOLVED (see “published items staged”)"
            },
        ),
        table: TableView {
            columns: vec![
                "Look".into(),
                "Replicates".into(),
                "Nominal α per side".into(),
                "Nominal TOST α".into(),
                "α spent (2.5 % / 5 %)".into(),
                "Claims decided".into(),
                "Cells extended".into(),
            ],
            rows: replay
                .looks
                .iter()
                .enumerate()
                .map(|(k, l)| {
                    let decided: Vec<String> =
                        l.decided.iter().map(|(id, v)| format!("{id} ({})", v.as_str())).collect();
                    vec![
                        (k + 1).to_string(),
                        l.n.to_string(),
                        sig(l.levels.side(), 3),
                        sig(l.levels.tost_alpha, 3),
                        format!("{} / {}", sig(l.spent.0, 3), sig(l.spent.1, 3)),
                        if decided.is_empty() { "—".into() } else { decided.join(", ") },
                        l.extended.len().to_string(),
                    ]
                })
                .collect(),
            align: "rrrrrp{0.35\\linewidth}r".into(),
        },
    });
    if !replay.items.is_empty() {
        let looks = &mut out.last_mut().expect("the looks table").table;
        looks.columns.push("Published cells decided".into());
        for (row, l) in looks.rows.iter_mut().zip(&replay.looks) {
            row.push(l.cells_decided.to_string());
        }
        looks.align.push('r');
        out.push(items_table(replay));
    }
    let mut by_count: BTreeMap<u32, usize> = BTreeMap::new();
    for n in replay.replicates.values() {
        *by_count.entry(*n).or_default() += 1;
    }
    out.push(NamedTable {
        title: "Sequential replication: replicates per cell".into(),
        caption: "Cells (map, algorithm, sweep point) by the replicates they got.".into(),
        table: TableView {
            columns: vec!["Replicates".into(), "Cells".into()],
            rows: by_count.iter().map(|(n, c)| vec![n.to_string(), c.to_string()]).collect(),
            align: "rr".into(),
        },
    });
    let later: Vec<Vec<String>> = replay
        .results
        .iter()
        .filter_map(|r| {
            let k = *replay.decided_at.get(&r.id)?;
            replay.added.contains(&r.id).then(|| {
                vec![
                    r.id.clone(),
                    r.verdict.as_str().into(),
                    (k + 1).to_string(),
                    replay.looks[k].n.to_string(),
                ]
            })
        })
        .collect();
    let undecided = replay
        .results
        .iter()
        .filter(|r| r.verdict == crate::judge::claims::Verdict::Inconclusive)
        .count();
    out.push(NamedTable {
        title: "Sequential replication: verdicts the added replicates decided".into(),
        caption: format!(
            "Claims undecided at the first look ({} replicates) and decided at a later one, with replicates added to their cells.{} {} still inconclusive after the last look.",
            design.looks[0],
            {
                let unaided: Vec<&str> = replay
                    .decided_at
                    .iter()
                    .filter(|(id, k)| **k > 0 && !replay.added.contains(*id))
                    .map(|(id, _)| id.as_str())
                    .collect();
                if unaided.is_empty() {
                    String::new()
                } else {
                    format!(
                        " Decided at a later look on the first stage's runs alone (their cells got no more replicates; a later look is less strict): {}.",
                        unaided.join(", ")
                    )
                }
            },
            match undecided {
                0 => "None is".to_string(),
                1 => "One claim is".to_string(),
                n => format!("{n} claims are"),
            }
        ),
        table: TableView {
            columns: vec!["Claim".into(), "Verdict".into(), "Look".into(), "Replicates".into()],
            rows: if later.is_empty() {
                vec![vec!["(none)".into(), "".into(), "".into(), "".into()]]
            } else {
                later
            },
            align: "llrr".into(),
        },
    });
    out
}

/// The published result items the study staged (`[sequential] items`): their class at each look
/// and their cells' outcomes, with the look each was decided at.
fn items_table(replay: &Replay) -> NamedTable {
    use crate::judge::agreement::Outcome;
    let rows = replay
        .items
        .iter()
        .map(|item| {
            let count =
                |o: Outcome| item.cells.values().filter(|(a, _)| a.outcome == Some(o)).count();
            let mut at: BTreeMap<usize, usize> = BTreeMap::new();
            for (a, k) in item.cells.values() {
                if matches!(a.outcome, Some(Outcome::Equivalent | Outcome::Different)) {
                    *at.entry(k + 1).or_default() += 1;
                }
            }
            vec![
                item.id.clone(),
                item.classes.iter().map(|c| c.as_str()).collect::<Vec<_>>().join(" → "),
                item.cells.len().to_string(),
                count(Outcome::Equivalent).to_string(),
                count(Outcome::Different).to_string(),
                count(Outcome::Unresolved).to_string(),
                if at.is_empty() {
                    "—".into()
                } else {
                    at.iter()
                        .map(|(k, n)| format!("{n} at look {k}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                },
            ]
        })
        .collect();
    NamedTable {
        title: "Sequential replication: published items staged".into(),
        caption: "The fidelity items this study answers by published cells (`[sequential] items`). Each cell is judged at each look's nominal level for the 5 % side (its 90 % interval) until shown equivalent to the published number or different from it, and keeps that outcome; an item still UNRESOLVED at a look asks for the next stage's replicates in its undecided cells (within the futility bound), as an undecided claim does. The class shown per look is the item's from its cells alone; the scoreboard's is the last one.".into(),
        table: TableView {
            columns: vec![
                "Item".into(),
                "Class at each look".into(),
                "Cells".into(),
                "Equivalent".into(),
                "Different".into(),
                "Unresolved".into(),
                "Decided".into(),
            ],
            rows,
            align: "lp{0.3\\linewidth}rrrrl".into(),
        },
    }
}
