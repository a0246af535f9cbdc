//! The report's view-models: what a study's page, its LaTeX document and the index show, already
//! formatted (criterion's `Context` structs). Built by `view`, `sensitivity` and `diagnostics`;
//! read by the templates, which only format. A leaf of `report/`: it imports none of its
//! builders.

use serde::Serialize;

#[derive(Debug, Clone, Serialize)]
pub struct Kv {
    pub key: String,
    pub value: String,
}

#[derive(Debug, Clone, Serialize, Default, PartialEq)]
pub struct TableView {
    pub columns: Vec<String>,
    pub rows: Vec<Vec<String>>,
    /// LaTeX column spec, e.g. `llrr`.
    pub align: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct NamedTable {
    pub title: String,
    pub caption: String,
    pub table: TableView,
}

#[derive(Debug, Clone, Serialize)]
pub struct FigureView {
    /// File stem under `figures/` (`.svg` and `.tex`): letters, digits and `-` only.
    pub file: String,
    pub caption: String,
    /// Inline SVG for the HTML page.
    pub svg: String,
    /// pgfplots code for the LaTeX document.
    #[serde(skip)]
    pub pgf: String,
    /// One panel of small multiples (one per map): drawn half-width, side by side.
    pub panel: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct GroupView {
    pub title: String,
    /// How often the published values lie inside our confidence intervals, per metric.
    pub agreement: Vec<String>,
    /// Leading text columns of `table` (map, algorithm); the rest are right-aligned numbers.
    pub label_columns: usize,
    pub figures: Vec<FigureView>,
    pub table: TableView,
    /// Named cells only: one table per metric, algorithms × cells, published values beside ours
    /// (the layout of [EP]'s tables).
    pub matrices: Vec<NamedTable>,
}

#[derive(Debug, Clone, Serialize)]
pub struct StudyView {
    pub id: String,
    pub title: String,
    pub description: Vec<String>,
    pub facts: Vec<Kv>,
    pub maps: TableView,
    pub sweeps: Vec<String>,
    pub base_params: TableView,
    pub choices: Vec<String>,
    pub notes: Vec<String>,
    pub groups: Vec<GroupView>,
    /// morris / sobol groups: global sensitivity.
    pub sensitivity: Vec<SensitivitySection>,
    pub claims: Vec<crate::judge::claims::ClaimResult>,
    /// A sequential study (`max_replicates`): its looks, replicates per cell and the verdicts the
    /// added replicates decided ([`super::sequential`]); empty for a fixed study.
    pub sequential: Vec<NamedTable>,
    /// Cost claims stated in time (`judged_on = "time"`): "id (text)", judged on the timing page.
    pub timed_claims: Vec<String>,
    pub trajectories: Vec<FigureView>,
    /// Scan matching: the match diagnostics' sentences and figures ([EP] Figs 25–27, 52–59).
    pub diagnostics_intro: Vec<String>,
    pub diagnostics: Vec<FigureView>,
    /// Scan matching: how the heading error is distributed over the matches of each cell.
    pub match_tables: Vec<NamedTable>,
    /// Per-landmark error tables beside published ones (`[report] landmark_reference`).
    pub landmark_tables: Vec<NamedTable>,
    /// Paired differences between chosen cells (`[[report.contrasts]]`).
    pub contrasts: Vec<NamedTable>,
    pub failures: TableView,
    pub metrics: TableView,
    pub provenance: Vec<Kv>,
}

/// One line of the index page (also written beside each report as `entry.json`, so that a kept
/// report keeps its line).
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct IndexEntry {
    pub id: String,
    pub title: String,
    pub summary: String,
    pub runs: String,
    pub failed: String,
    pub maps: String,
    pub algorithms: String,
}

/// A study rendered into view-models plus the CSV.
pub struct StudyPages {
    pub view: StudyView,
    pub index: IndexEntry,
    pub csv: String,
    /// morris / sobol groups: every design row's outputs (`sensitivity.csv`; empty: none).
    pub sensitivity_csv: String,
    /// A sequential study's staged published items, as its looks judged them (the scoreboard
    /// classifies them from these).
    pub staged: Vec<crate::judge::sequential::StagedItem>,
}

#[derive(Debug, Clone, Serialize)]
pub struct SensitivityBlock {
    pub title: String,
    pub findings: Vec<String>,
    pub table: TableView,
    pub figure: Option<FigureView>,
}

#[derive(Debug, Clone, Serialize)]
pub struct SensitivitySection {
    pub title: String,
    pub intro: Vec<String>,
    pub blocks: Vec<SensitivityBlock>,
}
