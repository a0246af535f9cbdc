//! The fidelity scoreboard's view: the classified published result items and the judged claims
//! (from `judge::scoreboard` and `judge::claims`) → tables for `reports/fidelity/` (HTML, LaTeX,
//! Markdown) and the Markdown block the README quotes. Formats only; every rule is in `judge/`.

use super::model::TableView;
use crate::judge::claims::{ClaimResult, Verdict};
use crate::judge::scoreboard::{Class, ItemResult};
use serde::Serialize;

/// The reference works, in the order the scoreboard lists them: (tag, title).
pub const SEEDS: [(&str, &str); 4] = [
    ("FT", "[FT] FastSLAM 1.0 with laser lines and corners (thesis)"),
    ("EP", "[EP] E-PSM: enhanced polar scan matching"),
    ("PF", "[PF] Particle-filter SLAM parameters"),
    ("EV", "[EV] EKF-SLAM with vision in a maze (thesis)"),
];

#[derive(Debug, Clone, Serialize)]
pub struct SeedView {
    pub tag: String,
    pub title: String,
    pub items: TableView,
    pub claims: TableView,
}

#[derive(Debug, Clone, Serialize)]
pub struct FidelityView {
    /// Items per seed × class.
    pub item_counts: TableView,
    /// Claims per seed × kind × verdict.
    pub claim_counts: TableView,
    pub seeds: Vec<SeedView>,
    /// Claims of no reference work ([FT]/[EP]/[PF]/[EV]): other papers' claims and slamlab's own.
    pub other_claims: TableView,
    pub items_total: usize,
    pub claims_total: usize,
    /// Studies with a page in this report folder (the others are named, not linked).
    pub studies: Vec<String>,
    /// The equivalence margins per reference work (`judge::margins`).
    pub margins: TableView,
}

/// The margins table (`judge::margins`), as the scoreboard and the book show it.
pub fn margins_table() -> TableView {
    use crate::judge::margins::WORKS;
    TableView {
        columns: ["Work", "Margin", "Why", "Resolutions"].map(String::from).to_vec(),
        rows: WORKS
            .iter()
            .map(|w| {
                let res = if w.resolutions.is_empty() {
                    "—".to_string()
                } else {
                    w.resolutions
                        .iter()
                        .map(|(m, r, why)| format!("{m}: {r} ({why})"))
                        .collect::<Vec<_>>()
                        .join("; ")
                };
                vec![
                    format!("[{}]", w.tag),
                    format!("±{} %", crate::stats::sig(w.relative * 100.0, 2)),
                    w.why.to_string(),
                    res,
                ]
            })
            .collect(),
        align: "lrp{0.4\\linewidth}p{0.35\\linewidth}".into(),
    }
}

fn counts_row(label: String, classes: &[Class]) -> Vec<String> {
    let mut row = vec![label];
    row.extend(Class::ALL.iter().map(|c| classes.iter().filter(|x| *x == c).count().to_string()));
    row.push(classes.len().to_string());
    row
}

fn verdict_row(label: String, kind: &str, claims: &[&ClaimResult]) -> Vec<String> {
    let mut row = vec![label, kind.to_string()];
    row.extend(
        Verdict::ALL.iter().map(|v| claims.iter().filter(|c| c.verdict == *v).count().to_string()),
    );
    row.push(claims.len().to_string());
    row
}

fn claims_table(claims: &[&ClaimResult]) -> TableView {
    TableView {
        columns: ["Study", "Claim", "Kind", "Source", "Verdict", "Test and numbers", "Cause"].map(String::from).to_vec(),
        rows: claims
            .iter()
            .map(|c| {
                vec![c.study.clone(), c.id.clone(), c.kind.clone(), c.source.clone(), c.verdict.as_str().to_string(), format!("{} {}.", c.test, c.summary), if c.cause.is_empty() { "—".into() } else { c.cause.clone() }]
            })
            .collect(),
        align: "p{0.07\\linewidth}p{0.12\\linewidth}lp{0.09\\linewidth}lp{0.28\\linewidth}p{0.2\\linewidth}".into(),
    }
}

/// Builds the scoreboard from the classified items and every judged claim (sorted by study, then
/// in spec order).
pub fn build(items: &[ItemResult], claims: &[ClaimResult], studies: Vec<String>) -> FidelityView {
    let mut columns = vec!["Reference work".to_string()];
    columns.extend(Class::ALL.iter().map(|c| c.as_str().to_string()));
    columns.push("items".into());
    let mut rows: Vec<Vec<String>> = SEEDS
        .iter()
        .map(|(tag, _)| {
            counts_row(
                format!("[{tag}]"),
                &items.iter().filter(|i| i.seed == *tag).map(|i| i.class).collect::<Vec<_>>(),
            )
        })
        .collect();
    rows.push(counts_row("all".into(), &items.iter().map(|i| i.class).collect::<Vec<_>>()));
    let align = format!("l{}r", "r".repeat(Class::ALL.len()));
    let item_counts = TableView { columns, rows, align };

    let mut columns = vec!["Reference work".to_string(), "Kind".to_string()];
    columns.extend(Verdict::ALL.iter().map(|v| v.as_str().to_string()));
    columns.push("claims".into());
    let mut rows = Vec::new();
    for kind in ["seed", "calibration", "extension"] {
        for (tag, _) in SEEDS {
            let of: Vec<&ClaimResult> =
                claims.iter().filter(|c| c.seed == tag && c.kind == kind).collect();
            if !of.is_empty() {
                rows.push(verdict_row(format!("[{tag}]"), kind, &of));
            }
        }
        let other: Vec<&ClaimResult> = claims
            .iter()
            .filter(|c| !SEEDS.iter().any(|(t, _)| *t == c.seed) && c.kind == kind)
            .collect();
        if !other.is_empty() {
            rows.push(verdict_row("other".into(), kind, &other));
        }
        let all: Vec<&ClaimResult> = claims.iter().filter(|c| c.kind == kind).collect();
        rows.push(verdict_row("all".into(), kind, &all));
    }
    let claim_counts = TableView { columns, rows, align: "llrrrrr".into() };

    let seeds = SEEDS
        .iter()
        .map(|(tag, title)| SeedView {
            tag: tag.to_string(),
            title: title.to_string(),
            items: TableView {
                columns: ["Item", "Source", "Published result", "Study", "Class", "Basis"]
                    .map(String::from)
                    .to_vec(),
                rows: items
                    .iter()
                    .filter(|i| i.seed == *tag)
                    .map(|i| {
                        vec![
                            i.id.clone(),
                            i.source.clone(),
                            i.result.clone(),
                            if i.study.is_empty() { "—".into() } else { i.study.clone() },
                            i.class.as_str().to_string(),
                            i.basis.clone(),
                        ]
                    })
                    .collect(),
                align: "lp{0.14\\linewidth}p{0.26\\linewidth}p{0.1\\linewidth}lp{0.26\\linewidth}"
                    .into(),
            },
            claims: claims_table(&claims.iter().filter(|c| c.seed == *tag).collect::<Vec<_>>()),
        })
        .collect();
    let other_claims = claims_table(
        &claims.iter().filter(|c| !SEEDS.iter().any(|(t, _)| *t == c.seed)).collect::<Vec<_>>(),
    );
    FidelityView {
        item_counts,
        claim_counts,
        seeds,
        other_claims,
        items_total: items.len(),
        claims_total: claims.len(),
        studies,
        margins: margins_table(),
    }
}

/// A Markdown table (cells with `|` escaped).
pub fn markdown_table(t: &TableView) -> String {
    let cell = |s: &str| s.replace('|', "\\|").replace('\n', " ");
    let mut out =
        format!("| {} |\n", t.columns.iter().map(|c| cell(c)).collect::<Vec<_>>().join(" | "));
    out.push_str(&format!(
        "|{}\n",
        t.columns
            .iter()
            .enumerate()
            .map(|(i, _)| if i == 0 { "---|" } else { "---:|" })
            .collect::<String>()
    ));
    for r in &t.rows {
        out.push_str(&format!(
            "| {} |\n",
            r.iter().map(|c| cell(c)).collect::<Vec<_>>().join(" | ")
        ));
    }
    out
}

/// The block the README quotes (between its `fidelity:begin` / `fidelity:end` markers), checked
/// by `make check-reports`: the counts, each item's class, and every seed claim not confirmed
/// with its cause.
pub fn readme_block(view: &FidelityView, items: &[ItemResult], claims: &[ClaimResult]) -> String {
    let mut s = String::new();
    s.push_str("Published result items, classified from the committed runs (rule: the book, *How verdicts are reached*, docs/src/findings/fidelity.md):\n\n");
    s.push_str(&markdown_table(&view.item_counts));
    s.push_str("\nClaims by reference work, kind and verdict (only *seed* claims are the reference works' own results):\n\n");
    s.push_str(&markdown_table(&view.claim_counts));
    for (tag, title) in SEEDS {
        let of: Vec<&ItemResult> = items.iter().filter(|i| i.seed == tag).collect();
        if of.is_empty() {
            continue;
        }
        s.push_str(&format!("\n**{title}.** "));
        let by_class: Vec<String> = Class::ALL
            .iter()
            .filter_map(|c| {
                let ids: Vec<&str> =
                    of.iter().filter(|i| i.class == *c).map(|i| i.id.as_str()).collect();
                (!ids.is_empty()).then(|| format!("{} {}", c.as_str(), ids.join(", ")))
            })
            .collect();
        s.push_str(&by_class.join("; "));
        s.push_str(".\n");
        let open: Vec<&ClaimResult> = claims
            .iter()
            .filter(|c| c.seed == tag && c.kind == "seed" && c.verdict != Verdict::Confirmed)
            .collect();
        if !open.is_empty() {
            s.push_str("Seed claims not confirmed:\n");
            for c in open {
                s.push_str(&format!(
                    "- `{}` ({}) {}: {}\n",
                    c.id,
                    c.study,
                    c.verdict.as_str(),
                    c.cause
                ));
            }
        }
    }
    s.push_str("\nEvery item and claim with its numbers: `reports/fidelity/index.html` (also `fidelity.md`, `fidelity.tex`).\n");
    s
}

/// The whole scoreboard as Markdown: the README block, then every item and claim per work.
pub fn full_markdown(view: &FidelityView, block: &str) -> String {
    let mut s = String::from("# Fidelity scoreboard\n\nGenerated by `slamlab report`.\n\n");
    s.push_str(block);
    for seed in &view.seeds {
        s.push_str(&format!("\n## {}\n\n### Published result items\n\n", seed.title));
        s.push_str(&markdown_table(&seed.items));
        if !seed.claims.rows.is_empty() {
            s.push_str("\n### Claims\n\n");
            s.push_str(&markdown_table(&seed.claims));
        }
    }
    if !view.other_claims.rows.is_empty() {
        s.push_str("\n## Claims of other works and slamlab's own\n\n");
        s.push_str(&markdown_table(&view.other_claims));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_tables_escape_bars() {
        let t = TableView {
            columns: vec!["a".into(), "b".into()],
            rows: vec![vec!["x|y".into(), "1".into()]],
            align: "lr".into(),
        };
        assert_eq!(markdown_table(&t), "| a | b |\n|---|---:|\n| x\\|y | 1 |\n");
    }
}
