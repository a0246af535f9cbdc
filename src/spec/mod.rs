//! Study specs: `experiments/<id>.toml` → [`LoadedSpec`] — what the user wrote, parsed with
//! `deny_unknown_fields` and range-checked, every problem reported with file, line, column and key.
//! Expansion into runs is [`crate::plan`]'s job.

use crate::algo::{AlgorithmId, Catalogue};
use crate::metrics::metric_def;
pub use crate::params::Params;
use crate::source::{Locator, SourceError, join_key};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub mod algorithms;
pub mod cause;
pub mod items;

/// A study as written in its TOML file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    /// Study id: lower-case letters, digits, `-` and `_`; names `data/results/<id>/` and `reports/<id>/`.
    pub id: String,
    pub title: String,
    #[serde(default)]
    pub description: String,
    /// Study seed: with (map, replicate) it determines every random number of every run.
    pub seed: u64,
    /// Runs per (map, algorithm, sweep point); with `max_replicates`, the first stage's.
    pub replicates: u32,
    /// The replication budget of a sequential study: replicates are added in stages (see
    /// `[sequential]`) to the cells of claims still undecided, up to this many per cell.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_replicates: Option<u32>,
    /// How a sequential study adds replicates (with `max_replicates`; defaults if absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sequential: Option<SequentialSpec>,
    /// `true`: every replicate sees the same world (odometry and sensor noise of replicate 0) and
    /// only the filters' random numbers differ — [PF]'s design ("the same odometry readings and
    /// the same map throughout all experiments"). Default `false`: each replicate draws a world.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fixed_world: bool,
    /// Map names, each `data/maps/<name>.toml`.
    pub maps: Vec<String>,
    pub algorithms: Vec<AlgorithmId>,
    /// Parameters shared by every run; sweeps override single keys.
    #[serde(default)]
    pub base: Params,
    #[serde(default)]
    pub sweeps: Vec<SweepSpec>,
    #[serde(default)]
    pub report: ReportSpec,
    /// Modelling notes shown in the report (documented choices specific to this study).
    #[serde(default)]
    pub notes: Vec<String>,
    /// Testable claims of the reference work, evaluated from this study's runs in its report.
    #[serde(default)]
    pub claims: Vec<ClaimSpec>,
}

/// The group-sequential design of a study with `max_replicates`, fixed before its first look.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SequentialSpec {
    /// The alpha-spending function: `obrien_fleming` (default) or `pocock`.
    #[serde(default)]
    pub spending: Spending,
    /// Replicates added per stage (default: `replicates`). The looks are at `replicates`,
    /// `replicates + stage_replicates`, … and `max_replicates`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage_replicates: Option<u32>,
    /// The published result items file (`data/reference/published-results.toml`) whose items
    /// answered by this study's published cells are staged too: their unresolved cells get
    /// replicates as undecided claims' cells do. Read when the study is planned; the items are
    /// kept with the results, so the report replays the looks the run took.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub items: Option<String>,
}

/// Lan–DeMets alpha-spending functions (see `stats::sequential`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Spending {
    #[default]
    ObrienFleming,
    Pocock,
}

/// Most looks a sequential study may take.
pub const MAX_LOOKS: usize = 20;
/// Fewest replicates of a sequential study's first stage: the fewest paired replicates a claim's
/// test accepts (`judge::claims::MIN_REPLICATES`), so that the first look can judge and project.
pub const SEQUENTIAL_MIN_REPLICATES: u32 = 3;

impl ExperimentSpec {
    /// The replicates each cell may get: `max_replicates`, else `replicates`.
    pub fn replicate_budget(&self) -> u32 {
        self.max_replicates.unwrap_or(self.replicates).max(self.replicates)
    }

    /// The replicate counts at which a sequential study looks at its verdicts (ascending, the
    /// last `max_replicates`); `None` for a fixed study.
    pub fn looks(&self) -> Option<Vec<u32>> {
        let max = self.max_replicates?;
        if max <= self.replicates {
            return None;
        }
        let step = self
            .sequential
            .as_ref()
            .and_then(|s| s.stage_replicates)
            .unwrap_or(self.replicates)
            .max(1);
        let mut looks = vec![self.replicates];
        while *looks.last().expect("one look") < max {
            looks.push((looks.last().expect("one look") + step).min(max));
        }
        Some(looks)
    }
}

/// A claim of a reference work and the test that checks it against the study's cells.
/// Cells are picked by parameter values (`at`, `than`, `over`); every claim is evaluated per map
/// (and algorithm) and then combined according to `require`.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ClaimSpec {
    /// Short identifier (shown in the report).
    pub id: String,
    /// Where the claim is made, e.g. "[FT] §7 claim 5"; a leading `[TAG]` names the reference work.
    pub source: String,
    /// `seed`: a result the reference work states; `calibration`: true by construction (a
    /// modelling choice tuned to a published number); `extension`: slamlab's own question or a
    /// claim carried to another setting. Only seed claims count as reproduced results.
    pub kind: ClaimKind,
    /// The claim in words.
    pub text: String,
    /// The metric tested (every test but `fails`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub metric: String,
    /// For `fails`: the text a run's error must contain to count (absent: any failure).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<String>,
    pub test: ClaimTest,
    /// The cell the claim is about: parameter path → value (the other parameters at base).
    #[serde(default)]
    pub at: toml::Table,
    /// For `greater` / `less`: the cell it is compared with.
    #[serde(default)]
    pub than: toml::Table,
    /// For `flat`: one parameter and the values over which the metric should not change.
    #[serde(default)]
    pub over: toml::Table,
    /// For `above` / `below`: the threshold; for `between`: the lower bound.
    #[serde(default)]
    pub value: Option<f64>,
    /// For `between`: the upper bound.
    #[serde(default)]
    pub upper: Option<f64>,
    /// For `flat`: the largest difference between cells that still counts as flat (absolute)…
    #[serde(default)]
    pub tolerance: Option<f64>,
    /// …or relative to the mean level of the compared cells (e.g. 0.25 = 25 %).
    #[serde(default)]
    pub tolerance_rel: Option<f64>,
    /// For `flat`: `both` (equivalence), or the one-sided readings `no_decrease` / `no_increase`
    /// against the first `over` value ("no significant gain above x").
    #[serde(default)]
    pub direction: FlatDirection,
    /// For `greater` / `less`: the smallest relevant difference (absolute), or the margin of
    /// `not_greater` / `not_less`…
    #[serde(default)]
    pub min_effect: Option<f64>,
    /// …or relative to the compared (`than`) cell's mean. Default 0.05.
    #[serde(default)]
    pub min_effect_rel: Option<f64>,
    /// Why the tolerance, margin or minimum effect is what it is (required for `flat`,
    /// `not_greater`, `not_less` and any explicit minimum effect).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub why: String,
    /// For a verdict other than confirmed: the cause found, shown in the report and the fidelity
    /// scoreboard (absent: "not yet investigated").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<String>,
    /// A condition on the claim's own cell (`at`, or the first `over` value) without which its
    /// runs cannot test it, e.g. "no corner is kept" for a claim about maps without corners; when
    /// the cell's mean misses it, the claim is untestable on that map.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub precondition: Option<Precondition>,
    /// Maps to check (default: all of the study's).
    #[serde(default)]
    pub maps: Vec<String>,
    /// Algorithm the claim is about (default: the study's first).
    #[serde(default)]
    pub algorithm: Option<AlgorithmId>,
    /// For `greater` / `less`: compare with this algorithm (at `than`, or at the same cell).
    #[serde(default)]
    pub than_algorithm: Option<AlgorithmId>,
    /// How many maps must confirm: all (default), most, any, or `pooled` (the effect on average
    /// over the maps, by a random-effects test).
    #[serde(default)]
    pub require: Require,
    /// `cells`: a comparison of `algorithm` with `than_algorithm` judged in every sweep point of
    /// every map (the source states it over a table's cells, e.g. [EP]'s "21 of 24 cells"); the
    /// (map, cell) verdicts are combined by `require`. Default `maps`: one cell (`at`) per map.
    #[serde(default, skip_serializing_if = "Across::is_maps")]
    pub across: Across,
    /// `time`: a cost claim the source states in time on its own machine. It is judged on the
    /// timing page (`data/results/<study>/timings.html`, machine-dependent), never on evaluation
    /// counts, and not in the committed reports or the scoreboard.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub judged_on: Option<JudgedOn>,
    /// Why `require` is not "all": the source's wording that makes the claim one about most maps,
    /// any map, or the average over the maps (required for `most`, `any` and `pooled`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub require_why: String,
    /// A claim on a global-sensitivity index (a morris / sobol sweep of the study) instead of a
    /// cell: `above` / `below` / `between` test the index's 95 % bootstrap interval against
    /// `value` (and `upper`), `greater` / `less` the interval of its difference with
    /// `than_parameter`'s same index against `min_effect` (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub index: Option<IndexKind>,
    /// For an index claim: the parameter (a path of the sweep's `ranges`).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub parameter: String,
    /// For an index claim with `greater` / `less`: the parameter compared with.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub than_parameter: String,
}

/// The sensitivity index an index claim is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum IndexKind {
    /// Sobol' first-order index (sobol sweep).
    S1,
    /// Sobol' total index (sobol sweep).
    St,
    /// ST − S1: the share of variance due to the parameter's interactions (sobol sweep).
    Interaction,
    /// Morris's μ*, in the metric's unit per full range (morris sweep).
    MuStar,
}

impl IndexKind {
    pub fn as_str(self) -> &'static str {
        match self {
            IndexKind::S1 => "S1",
            IndexKind::St => "ST",
            IndexKind::Interaction => "ST − S1",
            IndexKind::MuStar => "μ*",
        }
    }
    /// The sweep kind that estimates it.
    pub fn sweep(self) -> SweepKind {
        if self == IndexKind::MuStar { SweepKind::Morris } else { SweepKind::Sobol }
    }
}

/// The statistical test behind a claim (the rules are in `judge::claims`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClaimTest {
    /// The cell's mean is above `value` (its 95 % CI lies above it).
    Above,
    /// The cell's mean is below `value`.
    Below,
    /// The cell's mean lies in [`value`, `upper`].
    Between,
    /// The cell's mean exceeds the `than` cell's by more than the minimum effect (paired 95 % CI).
    Greater,
    /// The cell's mean is below the `than` cell's by more than the minimum effect.
    Less,
    /// Non-inferiority: the cell's mean is not above the `than` cell's by more than the margin.
    NotGreater,
    /// Non-inferiority: the cell's mean is not below the `than` cell's by more than the margin.
    NotLess,
    /// Equivalence over `over` within the tolerance (TOST), or one-sided (`direction`).
    Flat,
    /// The runs of the cell fail (e.g. a map that explodes): every run failed ⇒ confirmed, none
    /// ⇒ refuted; `failure` restricts the count to errors containing that text. Needs no metric.
    Fails,
}

/// `precondition = { metric = "…", below = x | above = x, why = "…" }` of a claim.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Precondition {
    pub metric: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub below: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub above: Option<f64>,
    /// What the condition ensures.
    pub why: String,
}

/// What a claim is, for the tallies (see [`ClaimSpec::kind`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ClaimKind {
    Seed,
    Calibration,
    Extension,
}

/// The reading of a `flat` claim.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FlatDirection {
    /// Equivalent both ways.
    #[default]
    Both,
    /// Not lower than at the first value by more than the tolerance.
    NoDecrease,
    /// Not higher than at the first value by more than the tolerance.
    NoIncrease,
}

impl ClaimSpec {
    /// The parameter a `flat` claim varies.
    pub fn over_param(&self) -> String {
        self.over.keys().next().cloned().unwrap_or_default()
    }

    /// The reference work's tag leading `source`: "[FT] §7 claim 5" → "FT".
    pub fn seed_tag(&self) -> Option<&str> {
        let s = self.source.trim_start().strip_prefix('[')?;
        let tag = &s[..s.find(']')?];
        (!tag.is_empty() && tag.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit()))
            .then_some(tag)
    }
}

impl ClaimKind {
    pub fn as_str(self) -> &'static str {
        match self {
            ClaimKind::Seed => "seed",
            ClaimKind::Calibration => "calibration",
            ClaimKind::Extension => "extension",
        }
    }
}

/// What a claim's per-map verdicts range over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Across {
    /// One cell per map.
    #[default]
    Maps,
    /// Every sweep point of every map.
    Cells,
}

impl Across {
    fn is_maps(&self) -> bool {
        *self == Across::Maps
    }
}

/// Where a claim is judged, when not in the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JudgedOn {
    /// On the machine-dependent timing page.
    Time,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Require {
    /// Confirmed on every map.
    #[default]
    All,
    /// Confirmed on more than half of the maps.
    Most,
    /// Confirmed on at least one map.
    Any,
    /// The effect on average over the maps (a claim worded as an average): a random-effects test
    /// of the maps' relative effects (`flat` claims are checked per map as for `all`).
    Pooled,
}

/// A reference work's published results to show beside this study's.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ReferenceSpec {
    /// CSV file of published results (see data/reference/README.md).
    pub file: String,
    /// Rows of these experiments are used.
    pub experiments: Vec<String>,
    /// How the published values are labelled, e.g. "[FT] Table 10.3".
    pub label: String,
    /// Runs behind each published mean, as the source states ([FT]: 5; [EP], [EV]: 1). Cells are
    /// judged against the published spread with it (`judge::agreement`).
    #[serde(default = "one_run")]
    pub runs: u32,
}

fn one_run() -> u32 {
    1
}

/// One sweep block: `values` maps parameter paths (`"odometry.k"`, or nested tables) to lists.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSpec {
    pub kind: SweepKind,
    /// one_at_a_time / grid / zip: each parameter's list of values.
    #[serde(default)]
    pub values: toml::Table,
    /// Names of a zip sweep's points, one per position (e.g. [EP] Table 1's noise cells
    /// `none`, `odo1`, …): they label the points (and run ids), the columns of the report's
    /// per-cell tables and the categorical x axis of its plots.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub labels: Vec<String>,
    /// morris / sobol: each parameter's range `[low, high]` (integers for an integer parameter,
    /// which is then rounded to the nearest integer).
    #[serde(default, skip_serializing_if = "toml::Table::is_empty")]
    pub ranges: toml::Table,
    /// morris / sobol: parameters whose range is sampled uniformly in the logarithm (low > 0).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub log: Vec<String>,
    /// morris / sobol: parameter → the ranged parameter whose value it takes at every point
    /// (e.g. `"fastslam.motion_y" = "fastslam.motion_x"`: one factor, two keys).
    #[serde(default, skip_serializing_if = "toml::Table::is_empty")]
    pub tied: toml::Table,
    /// morris: grid levels per parameter (even; default 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub levels: Option<u32>,
    /// morris: trajectories (default 10).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectories: Option<u32>,
    /// sobol: base samples N, a power of two (default 64); the design has N (d + 2) points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub samples: Option<u32>,
}

/// A parameter of a morris / sobol sweep and its range.
#[derive(Debug, Clone, PartialEq)]
pub struct RangedParam {
    pub path: String,
    /// Location key of its range in the spec.
    pub key: String,
    pub low: f64,
    pub high: f64,
    pub log: bool,
    /// An integer parameter (its `[base]` value is an integer): values are rounded.
    pub integer: bool,
}

/// The design of a morris / sobol sweep block.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignSpec {
    pub params: Vec<RangedParam>,
    /// (tied parameter path, index of the ranged parameter it follows).
    pub tied: Vec<(String, usize)>,
    pub levels: usize,
    pub trajectories: usize,
    pub samples: usize,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepKind {
    /// Each parameter varied alone, the others at `[base]` ([FT]'s one-factor-at-a-time design).
    OneAtATime,
    /// Every combination of the listed values.
    Grid,
    /// The i-th values of every list together (lists of equal length).
    Zip,
    /// Morris's elementary-effects screening over `ranges` (global sensitivity).
    Morris,
    /// Saltelli's design on a scrambled Sobol' sequence over `ranges`: Sobol' indices S1, ST.
    Sobol,
}

impl SweepKind {
    /// A global-sensitivity design (`ranges`, not `values`).
    pub fn is_design(self) -> bool {
        matches!(self, SweepKind::Morris | SweepKind::Sobol)
    }
}

/// What the report shows.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReportSpec {
    /// Metrics tabulated and plotted against each swept parameter, first = headline metric.
    pub metrics: Vec<String>,
    /// Swept parameters plotted on a log x axis (default: automatic, when all values are > 0 and
    /// span at least two decades).
    pub log_x: Vec<String>,
    /// Published results shown beside ours (tables, and a dashed series on the plots).
    pub reference: Option<ReferenceSpec>,
    /// Published per-landmark errors (e.g. [EV] Tables 4.1–4.3): the report shows, for each, a
    /// table of our per-landmark errors at that sweep point beside the published ones.
    pub landmark_reference: Vec<LandmarkReference>,
    /// How `slamlab diff` judges this study's changes (absent: the command's `--alpha` and
    /// `--min-effect`).
    #[serde(skip_serializing_if = "DiffSpec::is_empty")]
    pub diff: DiffSpec,
    /// What the bands around our series show: `ci` (95 % confidence interval of the mean, the
    /// default) or `two_sigma` (mean ± 2 sample standard deviations, as [PF]'s Figs 8–9 draw).
    pub bands: Bands,
    /// Tables of paired differences between chosen cells (`[[report.contrasts]]`), e.g. the
    /// contribution of each modelling choice to an error budget.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub contrasts: Vec<ContrastSpec>,
    /// morris / sobol sweeps: metrics analysed on a log scale (ln of each run's value; the
    /// indices then apportion the variance of the metric's order of magnitude, which heavy-tailed
    /// errors — a few diverged runs metres off — would otherwise dominate). Values ≤ 0 count as
    /// missing.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub sensitivity_log: Vec<String>,
}

/// `[[report.contrasts]]`: each pair `[cell, against]` of sweep points (a named zip cell's name,
/// or the label `slamlab plan` prints) becomes a row of paired differences cell − against, per
/// map, with their 95 % confidence interval (replicate k of both cells sees the same world).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ContrastSpec {
    pub title: String,
    /// What the differences show, printed under the tables.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub caption: String,
    pub pairs: Vec<[String; 2]>,
    /// Metrics tabulated (default: the report's).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub metrics: Vec<String>,
}

/// The band drawn around each of our series in the error-vs-parameter plots.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bands {
    #[default]
    Ci,
    TwoSigma,
}

/// `[report.diff]`: significance level and smallest relevant change for `slamlab diff`, for the
/// whole study and per metric (`[report.diff.metrics.<name>]`).
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct DiffSpec {
    /// Significance level of the Holm-adjusted p-values, in (0, 1).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    /// Smallest change that counts, as a fraction of |BASE mean| (≥ 0).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_effect: Option<f64>,
    /// Per-metric overrides.
    #[serde(skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub metrics: std::collections::BTreeMap<String, MetricDiffSpec>,
}

/// One metric's `alpha` / `min_effect`.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct MetricDiffSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub min_effect: Option<f64>,
}

impl DiffSpec {
    pub fn is_empty(&self) -> bool {
        *self == DiffSpec::default()
    }

    /// (alpha, min_effect) for `metric`: its own, else the study's, else `defaults`.
    pub fn for_metric(&self, metric: &str, defaults: (f64, f64)) -> (f64, f64) {
        let m = self.metrics.get(metric);
        (
            m.and_then(|m| m.alpha).or(self.alpha).unwrap_or(defaults.0),
            m.and_then(|m| m.min_effect).or(self.min_effect).unwrap_or(defaults.1),
        )
    }
}

/// A published per-landmark error table of one sweep point.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct LandmarkReference {
    /// Shown as the table's title, e.g. "[EV] Table 4.1 (Exp. 1)".
    pub label: String,
    /// The sweep point: parameter path → value, every other swept parameter at its base value.
    pub at: toml::Table,
    /// Published landmarks as [x_true, y_true, error_x, error_y] [m], error = true − estimated.
    pub landmarks: Vec<[f64; 4]>,
}

impl Default for ReportSpec {
    fn default() -> Self {
        Self {
            metrics: vec![
                "ate_rmse_m".into(),
                "final_position_error_m".into(),
                "final_heading_error_deg".into(),
            ],
            log_x: Vec::new(),
            reference: None,
            landmark_reference: Vec::new(),
            diff: DiffSpec::default(),
            bands: Bands::default(),
            contrasts: Vec::new(),
            sensitivity_log: Vec::new(),
        }
    }
}

/// A swept parameter: its path in `[base]`, where it is written, and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct SweptParam {
    /// Parameter path, e.g. `odometry.k`.
    pub path: String,
    /// Location key of the list in the spec, e.g. `sweeps[0].values."odometry.k"`.
    pub key: String,
    pub values: Vec<toml::Value>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct SweepBlock {
    pub kind: SweepKind,
    pub params: Vec<SweptParam>,
    /// Point names (zip sweeps with `labels`), else empty.
    pub labels: Vec<String>,
    /// morris / sobol sweeps: their ranges and design sizes.
    pub design: Option<DesignSpec>,
}

/// A parsed, validated spec with what is needed to place later errors in its text.
#[derive(Debug, Clone)]
pub struct LoadedSpec {
    pub path: PathBuf,
    /// blake3 of the file's bytes.
    pub hash: String,
    pub locator: Locator,
    pub spec: ExperimentSpec,
    pub sweeps: Vec<SweepBlock>,
    /// The algorithms its names were resolved against (built-ins and external programs).
    pub catalogue: Arc<Catalogue>,
}

/// Problems in one file, each with line, column and key.
#[derive(Debug)]
pub struct SpecError {
    pub path: PathBuf,
    pub errors: Vec<SourceError>,
}

impl SpecError {
    pub fn new(path: &Path, errors: Vec<SourceError>) -> Self {
        Self { path: path.to_path_buf(), errors }
    }
    pub fn io(path: &Path, err: &std::io::Error) -> Self {
        Self::new(
            path,
            vec![SourceError {
                line: 0,
                column: 0,
                key: String::new(),
                message: format!("cannot read: {err}"),
            }],
        )
    }
}

impl fmt::Display for SpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.errors.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{}", self.path.display())?;
            if e.line > 0 {
                write!(f, ":{}:{}", e.line, e.column)?;
            }
            write!(f, ": ")?;
            if !e.key.is_empty() {
                write!(f, "key `{}`: ", e.key)?;
            }
            f.write_str(&e.message)?;
        }
        Ok(())
    }
}

impl std::error::Error for SpecError {}

/// Problems across several files (a spec and the maps it names).
#[derive(Debug)]
pub struct InputErrors(pub Vec<SpecError>);

impl fmt::Display for InputErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let lines: Vec<String> = self.0.iter().map(ToString::to_string).collect();
        f.write_str(&lines.join("\n"))
    }
}

impl std::error::Error for InputErrors {}

impl From<SpecError> for InputErrors {
    fn from(e: SpecError) -> Self {
        InputErrors(vec![e])
    }
}

/// The largest spec file read (the repository's largest is about 20 KB): `validate /dev/zero`
/// or a runaway generated spec is refused instead of filling memory.
pub const MAX_SPEC_BYTES: u64 = 1 << 20;

/// Reads at most [`MAX_SPEC_BYTES`] of a spec file as text.
fn read_bounded(path: &Path) -> Result<String, SpecError> {
    read_text_bounded(
        path,
        MAX_SPEC_BYTES,
        "the most a spec may be (sweeps expand a few lines into many runs)",
    )
    .map_err(|e| SpecError::io(path, &e))
}

/// The largest map file read (the repository's largest is about 4 KB; walls are listed by
/// their corners).
pub const MAX_MAP_BYTES: u64 = 1 << 20;

/// Reads a text file of at most `limit` bytes (`/dev/zero` or a runaway file is refused, not
/// read into memory); `why` ends the error for a larger one.
pub fn read_text_bounded(path: &Path, limit: u64, why: &str) -> std::io::Result<String> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(std::io::Error::other(format!("larger than {limit} bytes, {why}")));
    }
    String::from_utf8(bytes).map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// Reads and validates a spec file.
pub fn load(path: &Path, catalogue: &Arc<Catalogue>) -> Result<LoadedSpec, SpecError> {
    let text = read_bounded(path)?;
    let loaded = parse(path, &text, catalogue)?;
    // `experiments/<id>.toml`: the file says which study it is.
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    if stem != loaded.spec.id {
        return Err(SpecError::new(
            path,
            vec![loaded.error_at(
                "id",
                format!(
                    "is `{}` but the file is named {stem}.toml: name the file after the study id",
                    loaded.spec.id
                ),
            )],
        ));
    }
    Ok(loaded)
}

/// Parses and validates spec text (`path` only names it in errors); algorithm names are
/// resolved against `catalogue`.
pub fn parse(path: &Path, text: &str, catalogue: &Arc<Catalogue>) -> Result<LoadedSpec, SpecError> {
    let locator = Locator::new(text);
    let spec: ExperimentSpec = toml::from_str(text)
        .map_err(|e| SpecError::new(path, vec![SourceError::from_toml(&locator, &e)]))?;
    let mut errors = Vec::new();
    let mut err = |key: &str, msg: String| errors.push(SourceError::at_key(&locator, key, msg));

    if spec.id.is_empty()
        || !spec
            .id
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-' || c == '_')
    {
        err(
            "id",
            format!("must be non-empty lower-case letters, digits, `-` or `_`, got {:?}", spec.id),
        );
    }
    if spec.title.trim().is_empty() {
        err("title", "must not be empty".into());
    }
    if spec.replicates == 0 {
        err("replicates", "must be ≥ 1".into());
    }
    if let Some(max) = spec.max_replicates {
        if spec.replicates < SEQUENTIAL_MIN_REPLICATES {
            err(
                "replicates",
                format!(
                    "a sequential study's first stage needs at least {SEQUENTIAL_MIN_REPLICATES} replicates (the fewest a test accepts), got {}",
                    spec.replicates
                ),
            );
        }
        if max < spec.replicates {
            err(
                "max_replicates",
                format!("must be at least `replicates` ({}), got {max}", spec.replicates),
            );
        }
    } else if spec.sequential.is_some() {
        err(
            "sequential",
            "a sequential design needs a budget: set `max_replicates` (the most replicates per cell)"
                .into(),
        );
    }
    if spec.sequential.as_ref().and_then(|s| s.stage_replicates) == Some(0) {
        err("sequential.stage_replicates", "must be ≥ 1".into());
    }
    if let Some(looks) = spec.looks() {
        if looks.len() > MAX_LOOKS {
            err(
                "max_replicates",
                format!(
                    "{} looks ({}…{} replicates in stages of {}); at most {MAX_LOOKS}: raise `sequential.stage_replicates`",
                    looks.len(),
                    looks[0],
                    looks[looks.len() - 1],
                    looks[1] - looks[0]
                ),
            );
        }
        for (i, c) in spec.claims.iter().enumerate() {
            let why = if c.index.is_some() {
                Some("a sensitivity index is decided by design rows, not by replicates")
            } else if c.metric == crate::metrics::LANDMARK_ERROR_GROWTH
                || c.precondition
                    .as_ref()
                    .is_some_and(|p| p.metric == crate::metrics::LANDMARK_ERROR_GROWTH)
            {
                Some(
                    "this metric is derived from the stored maps after the runs, and the looks are taken while they run",
                )
            } else {
                None
            };
            if let Some(why) = why {
                err(
                    &format!("claims[{i}]"),
                    format!(
                        "claim `{}` cannot be judged sequentially ({why}); move it to a study without `max_replicates`",
                        c.id
                    ),
                );
            }
        }
    }
    if spec.maps.is_empty() {
        err("maps", "list at least one map".into());
    }
    for (i, m) in spec.maps.iter().enumerate() {
        if spec.maps[..i].contains(m) {
            err(&format!("maps[{i}]"), format!("map `{m}` is listed twice"));
        }
        // a map is named, not pathed: it is `<name>.toml` in the --maps folder, never elsewhere
        if m.is_empty() || m.contains(['/', '\\']) || m.starts_with('.') {
            err(
                &format!("maps[{i}]"),
                format!(
                    "`{m}` is not a map name: name a file of the --maps folder without its `.toml` (no path)"
                ),
            );
        }
    }
    if let Some(r) = &spec.report.reference {
        // published tables live in the repository's data/reference/: a relative path inside the
        // working folder, never `..` or an absolute path
        let p = std::path::Path::new(&r.file);
        if p.is_absolute() || p.components().any(|c| !matches!(c, std::path::Component::Normal(_)))
        {
            err(
                "report.reference.file",
                format!(
                    "`{}` leaves the working folder: give a relative path without `..` (e.g. data/reference/fastslam-thesis.csv)",
                    r.file
                ),
            );
        }
    }
    if spec.algorithms.is_empty() {
        err("algorithms", "list at least one algorithm".into());
    }
    for (i, a) in spec.algorithms.iter().enumerate() {
        if catalogue.get(a.as_str()).is_none() {
            err(
                &format!("algorithms[{i}]"),
                format!(
                    "unknown algorithm `{a}`, expected one of: {} (external programs are declared in data/algorithms/)",
                    catalogue.names().join(", ")
                ),
            );
        } else if spec.algorithms[..i].contains(a) {
            err(&format!("algorithms[{i}]"), format!("algorithm `{a}` is listed twice"));
        }
    }
    // Only names the catalogue knows are asked about below.
    let known_algorithms: Vec<AlgorithmId> =
        spec.algorithms.iter().filter(|a| catalogue.get(a.as_str()).is_some()).cloned().collect();
    let read = sections_read(catalogue, &known_algorithms);
    let names = spec.algorithms.iter().map(AlgorithmId::as_str).collect::<Vec<_>>().join(", ");
    for name in spec.base.external.keys() {
        if !known_algorithms.iter().any(|a| a.as_str() == name)
            || catalogue.externals().all(|e| e.name != *name)
        {
            err(
                &format!("base.external.{name}"),
                format!(
                    "`{name}` is not an external algorithm of this study (its algorithms: {names})"
                ),
            );
        }
    }
    // Sensor rates against the clock: checked by the plan, which knows the maps' world kinds.
    for v in spec.base.validate(crate::world::Sensors::NONE) {
        err(&format!("base.{}", v.key), v.message);
    }
    let d = &spec.report.diff;
    let check_diff = |key: String,
                      alpha: Option<f64>,
                      min_effect: Option<f64>,
                      err: &mut dyn FnMut(&str, String)| {
        if let Some(a) = alpha.filter(|a| !(*a > 0.0 && *a < 1.0)) {
            err(&format!("{key}.alpha"), format!("must be in (0, 1), got {a}"));
        }
        if let Some(m) = min_effect.filter(|m| !(m.is_finite() && *m >= 0.0)) {
            err(&format!("{key}.min_effect"), format!("must be a finite number ≥ 0, got {m}"));
        }
    };
    check_diff("report.diff".into(), d.alpha, d.min_effect, &mut err);
    for (name, m) in &d.metrics {
        if metric_def(name).is_none() {
            err(&format!("report.diff.metrics.{name}"), format!("unknown metric `{name}`"));
        }
        check_diff(format!("report.diff.metrics.{name}"), m.alpha, m.min_effect, &mut err);
    }
    for (i, m) in spec.report.metrics.iter().enumerate() {
        if metric_def(m).is_none() {
            let known: Vec<_> = crate::metrics::METRICS.iter().map(|d| d.name).collect();
            err(
                &format!("report.metrics[{i}]"),
                format!("unknown metric `{m}` (known: {})", known.join(", ")),
            );
        }
    }
    if spec.report.metrics.is_empty() {
        err("report.metrics", "list at least one metric".into());
    }
    for (i, c) in spec.report.contrasts.iter().enumerate() {
        if c.pairs.is_empty() {
            err(
                &format!("report.contrasts[{i}].pairs"),
                "list at least one [cell, against] pair".into(),
            );
        }
        for (j, m) in c.metrics.iter().enumerate() {
            if metric_def(m).is_none() {
                err(
                    &format!("report.contrasts[{i}].metrics[{j}]"),
                    format!("unknown metric `{m}`"),
                );
            }
        }
    }

    for (i, m) in spec.report.sensitivity_log.iter().enumerate() {
        if metric_def(m).is_none() {
            err(&format!("report.sensitivity_log[{i}]"), format!("unknown metric `{m}`"));
        } else if !spec.sweeps.iter().any(|b| b.kind.is_design()) {
            err(
                &format!("report.sensitivity_log[{i}]"),
                "only a study with a morris or sobol sweep has sensitivity indices".into(),
            );
        }
    }

    // Sweep blocks: flatten nested tables to parameter paths; every leaf must be a non-empty list
    // naming a parameter that exists in [base].
    let mut base_leaves = Vec::new();
    crate::params::flatten("", &toml::Value::Table(spec.base.to_table()), &mut base_leaves);
    let known = |p: &str| base_leaves.iter().any(|(k, _)| k == p);
    let mut sweeps = Vec::new();
    for (i, block) in spec.sweeps.iter().enumerate() {
        if block.kind.is_design() {
            let design = check_design(i, block, &base_leaves, &read, &names, &mut err);
            sweeps.push(SweepBlock {
                kind: block.kind,
                params: Vec::new(),
                labels: Vec::new(),
                design,
            });
            continue;
        }
        for (k, set) in [
            ("ranges", !block.ranges.is_empty()),
            ("log", !block.log.is_empty()),
            ("tied", !block.tied.is_empty()),
            ("levels", block.levels.is_some()),
            ("trajectories", block.trajectories.is_some()),
            ("samples", block.samples.is_some()),
        ] {
            if set {
                err(
                    &format!("sweeps[{i}].{k}"),
                    "only a morris or sobol sweep has this key".into(),
                );
            }
        }
        let mut swept = Vec::new();
        flatten_sweep(&block.values, "", &format!("sweeps[{i}].values"), &mut swept);
        if swept.is_empty() {
            err(
                &format!("sweeps[{i}].values"),
                "list at least one parameter with its values".into(),
            );
        }
        // A block that switches a section's `model` may set that variant's own fields; they are
        // checked when each point is resolved.
        let switches: Vec<&str> =
            swept.iter().filter_map(|p| p.path.strip_suffix(".model")).collect();
        let variant_field = |p: &str| switches.iter().any(|s| p.starts_with(&format!("{s}.")));
        for p in &swept {
            if known(&p.path) && !is_read(&read, &p.path) {
                err(
                    &p.key,
                    format!(
                        "`{}` is not read by any of this study's algorithms ({names}): sweeping it would only repeat identical runs",
                        p.path,
                    ),
                );
                continue;
            }
            if !known(&p.path) && !variant_field(&p.path) {
                let names: Vec<_> = base_leaves.iter().map(|(k, _)| k.as_str()).collect();
                err(
                    &p.key,
                    format!("unknown parameter `{}` (parameters: {})", p.path, names.join(", ")),
                );
            } else if p.values.is_empty() {
                err(&p.key, "must be a non-empty list of values".into());
            }
        }
        if block.kind == SweepKind::Zip
            && swept.windows(2).any(|w| w[0].values.len() != w[1].values.len())
        {
            let lens: Vec<_> =
                swept.iter().map(|p| format!("{} has {}", p.path, p.values.len())).collect();
            err(
                &format!("sweeps[{i}].values"),
                format!("a zip sweep needs lists of equal length ({})", lens.join(", ")),
            );
        }
        if !block.labels.is_empty() {
            let n = swept.first().map_or(0, |p| p.values.len());
            let key = format!("sweeps[{i}].labels");
            if block.kind != SweepKind::Zip {
                err(&key, "only a zip sweep can name its points".into());
            } else if block.labels.len() != n {
                err(
                    &key,
                    format!("needs one name per point: {n} points, {} names", block.labels.len()),
                );
            }
            for (j, l) in block.labels.iter().enumerate() {
                if l.is_empty()
                    || !l.chars().all(|c| c.is_ascii_alphanumeric() || "._-+".contains(c))
                {
                    err(
                        &format!("{key}[{j}]"),
                        format!("`{l}` must be non-empty letters, digits, `.`, `_`, `-` or `+`"),
                    );
                } else if block.labels[..j].contains(l) {
                    err(&format!("{key}[{j}]"), format!("`{l}` is used twice"));
                }
            }
        }
        sweeps.push(SweepBlock {
            kind: block.kind,
            params: swept,
            labels: block.labels.clone(),
            design: None,
        });
    }
    for (i, p) in spec.report.log_x.iter().enumerate() {
        let values: Vec<&toml::Value> = sweeps
            .iter()
            .flat_map(|b| &b.params)
            .filter(|s| &s.path == p)
            .flat_map(|s| &s.values)
            .collect();
        if values.is_empty() {
            err(&format!("report.log_x[{i}]"), format!("`{p}` is not a swept parameter"));
        } else if !values.iter().all(|v| {
            v.as_float().map(|f| f > 0.0).or(v.as_integer().map(|n| n > 0)).unwrap_or(false)
        }) {
            err(
                &format!("report.log_x[{i}]"),
                format!(
                    "`{p}` can only be plotted on a log axis if all its values are numbers > 0"
                ),
            );
        }
    }

    for (i, c) in spec.claims.iter().enumerate() {
        let key = |k: &str| format!("claims[{i}].{k}");
        if let Some(index) = c.index {
            // where the index comes from: a design sweep of its kind with this parameter
            let ranged = |p: &str| {
                sweeps
                    .iter()
                    .filter(|b| b.kind == index.sweep())
                    .filter_map(|b| b.design.as_ref())
                    .any(|d| d.params.iter().any(|r| r.path == p))
            };
            if !sweeps.iter().any(|b| b.kind == index.sweep()) {
                err(
                    &key("index"),
                    format!(
                        "{} comes from a {} sweep, which this study does not have",
                        index.as_str(),
                        if index.sweep() == SweepKind::Morris { "morris" } else { "sobol" }
                    ),
                );
            } else if c.parameter.is_empty() {
                err(
                    &format!("claims[{i}]"),
                    "an index claim needs the `parameter` it is about".into(),
                );
            } else if !ranged(&c.parameter) {
                err(
                    &key("parameter"),
                    format!(
                        "`{}` has no range in this study's {} sweep",
                        c.parameter,
                        if index.sweep() == SweepKind::Morris { "morris" } else { "sobol" }
                    ),
                );
            }
            match c.test {
                ClaimTest::Greater | ClaimTest::Less if c.than_parameter.is_empty() => err(
                    &format!("claims[{i}]"),
                    "this test needs a `than_parameter` to compare the index with".into(),
                ),
                ClaimTest::Greater | ClaimTest::Less if !ranged(&c.than_parameter) => err(
                    &key("than_parameter"),
                    format!("`{}` has no range in the same sweep", c.than_parameter),
                ),
                ClaimTest::Greater
                | ClaimTest::Less
                | ClaimTest::Above
                | ClaimTest::Below
                | ClaimTest::Between => {}
                _ => err(
                    &key("test"),
                    "an index claim is tested with above, below, between, greater or less".into(),
                ),
            }
            if !c.than_parameter.is_empty()
                && !matches!(c.test, ClaimTest::Greater | ClaimTest::Less)
            {
                err(
                    &key("than_parameter"),
                    "only a greater or less index claim compares parameters".into(),
                );
            }
            for (k, set) in [
                ("at", !c.at.is_empty()),
                ("than", !c.than.is_empty()),
                ("over", !c.over.is_empty()),
                ("than_algorithm", c.than_algorithm.is_some()),
                ("precondition", c.precondition.is_some()),
                ("min_effect_rel", c.min_effect_rel.is_some()),
            ] {
                if set {
                    err(
                        &key(k),
                        "an index claim is about the whole design, not cells: leave this key out"
                            .into(),
                    );
                }
            }
        } else {
            for (k, set) in [
                ("parameter", !c.parameter.is_empty()),
                ("than_parameter", !c.than_parameter.is_empty()),
            ] {
                if set {
                    err(&key(k), "only an index claim (`index = …`) names a parameter".into());
                }
            }
        }
        if c.test == ClaimTest::Fails {
            if !c.metric.is_empty() {
                err(
                    &key("metric"),
                    "a `fails` claim tests run failures, not a metric: leave `metric` out".into(),
                );
            }
        } else if c.metric.is_empty() {
            err(&key("metric"), "this test needs a `metric`".into());
        } else if metric_def(&c.metric).is_none() {
            err(&key("metric"), format!("unknown metric `{}`", c.metric));
        }
        if c.failure.is_some() && c.test != ClaimTest::Fails {
            err(&key("failure"), "only a `fails` claim has a `failure` text".into());
        }
        let missing = match c.test {
            ClaimTest::Above | ClaimTest::Below => {
                c.value.is_none().then_some("a threshold `value`")
            }
            ClaimTest::Fails => None,
            ClaimTest::Between => {
                (c.value.is_none() || c.upper.is_none()).then_some("bounds `value` and `upper`")
            }
            ClaimTest::Greater | ClaimTest::Less | ClaimTest::NotGreater | ClaimTest::NotLess => {
                (c.index.is_none() && c.than.is_empty() && c.than_algorithm.is_none())
                    .then_some("a cell (`than`) or an algorithm (`than_algorithm`) to compare with")
            }
            ClaimTest::Flat => {
                (c.over.len() != 1 || c.tolerance.is_some() == c.tolerance_rel.is_some()).then_some(
                    "one parameter's values in `over` and either `tolerance` or `tolerance_rel`",
                )
            }
        };
        if let Some(what) = missing {
            err(&format!("claims[{i}]"), format!("this test needs {what}"));
        }
        let comparative = matches!(
            c.test,
            ClaimTest::Greater | ClaimTest::Less | ClaimTest::NotGreater | ClaimTest::NotLess
        );
        for (k, v) in [("tolerance", c.tolerance), ("tolerance_rel", c.tolerance_rel)] {
            match v {
                Some(_) if c.test != ClaimTest::Flat => {
                    err(&key(k), "only a `flat` claim has a tolerance".into())
                }
                Some(t) if !(t.is_finite() && t > 0.0) => {
                    err(&key(k), format!("must be a finite number > 0, got {t}"))
                }
                _ => {}
            }
        }
        for (k, v) in [("min_effect", c.min_effect), ("min_effect_rel", c.min_effect_rel)] {
            match v {
                Some(_) if !comparative => err(
                    &key(k),
                    "only greater, less, not_greater and not_less claims have a minimum effect"
                        .into(),
                ),
                Some(t) if !(t.is_finite() && t >= 0.0) => {
                    err(&key(k), format!("must be a finite number ≥ 0, got {t}"))
                }
                _ => {}
            }
        }
        if c.min_effect.is_some() && c.min_effect_rel.is_some() {
            err(&key("min_effect_rel"), "give `min_effect` or `min_effect_rel`, not both".into());
        }
        if let Some(pre) = &c.precondition {
            if metric_def(&pre.metric).is_none() {
                err(&key("precondition.metric"), format!("unknown metric `{}`", pre.metric));
            }
            if pre.below.is_some() == pre.above.is_some() {
                err(&key("precondition"), "needs exactly one of `below` and `above`".into());
            }
            if pre.why.trim().is_empty() {
                err(&key("precondition.why"), "say what the condition ensures".into());
            }
        }
        if c.direction != FlatDirection::Both && c.test != ClaimTest::Flat {
            err(&key("direction"), "only a `flat` claim has a direction".into());
        }
        let needs_why = c.test == ClaimTest::Flat
            || matches!(c.test, ClaimTest::NotGreater | ClaimTest::NotLess)
            || c.min_effect.is_some()
            || c.min_effect_rel.is_some();
        if needs_why && c.why.trim().is_empty() {
            err(&key("why"), "say why the tolerance, margin or minimum effect is what it is (a `why` is required for flat, not_greater and not_less claims and any explicit minimum effect)".into());
        }
        if let Some(text) = &c.cause {
            if let Err(e) = cause::parse(text) {
                err(&key("cause"), e);
            }
            let numbers = cause::literal_numbers(text);
            if !numbers.is_empty() {
                err(
                    &key("cause"),
                    format!(
                        "literal number(s) {}: write a result as a placeholder {{mean:METRIC:MAP:POINT}}, a published number inside a citation [FT …], a setting of the runs in a code span `…` (docs/src/findings/fidelity.md, \"Cause texts\")",
                        numbers.join(", ")
                    ),
                );
            }
            if text.trim_start().starts_with("Measured") && !text.contains('{') {
                err(
                    &key("cause"),
                    "a \"Measured:\" cause shows what was measured as placeholders filled from this study's runs; a cause no committed study isolates is \"Suspected:\"".into(),
                );
            }
        }
        if c.across == Across::Cells
            && (c.than_algorithm.is_none()
                || !c.at.is_empty()
                || !c.than.is_empty()
                || !matches!(
                    c.test,
                    ClaimTest::Greater
                        | ClaimTest::Less
                        | ClaimTest::NotGreater
                        | ClaimTest::NotLess
                ))
        {
            err(
                &key("across"),
                "`across = \"cells\"` compares `algorithm` with `than_algorithm` in every cell: a greater / less / not_greater / not_less claim with `than_algorithm` and without `at` or `than`".into(),
            );
        }
        if c.judged_on == Some(JudgedOn::Time)
            && (c.metric != "evals_mean" || c.than_algorithm.is_none())
        {
            err(
                &key("judged_on"),
                "`judged_on = \"time\"` is for a cost claim: metric `evals_mean`, comparing `algorithm` with `than_algorithm` (the timing page reads it on median time per match)".into(),
            );
        }
        if c.require != Require::All && c.require_why.trim().is_empty() {
            err(
                &key("require_why"),
                "a claim the source states for every map uses require = \"all\"; for `most`, `any` or `pooled` quote the source's wording that makes it a claim about most maps, any map or the average".into(),
            );
        }
        if c.kind == ClaimKind::Seed && c.seed_tag().is_none() {
            err(
                &key("source"),
                format!(
                    "a `seed` claim's source must start with the reference work's tag, e.g. \"[FT] §7 claim 5\", got {:?}",
                    c.source
                ),
            );
        }
        for m in &c.maps {
            if !spec.maps.contains(m) {
                err(&key("maps"), format!("map `{m}` is not one of the study's maps"));
            }
        }
        for (k, a) in [("algorithm", &c.algorithm), ("than_algorithm", &c.than_algorithm)] {
            if let Some(a) = a
                && !spec.algorithms.contains(a)
            {
                err(&key(k), format!("`{a}` is not one of the study's algorithms"));
            }
        }
        if spec.claims[..i].iter().any(|o| o.id == c.id) {
            err(&key("id"), format!("claim id `{}` is used twice", c.id));
        }
    }

    if !errors.is_empty() {
        return Err(SpecError::new(path, errors));
    }
    Ok(LoadedSpec {
        path: path.to_path_buf(),
        hash: blake3::hash(text.as_bytes()).to_hex().to_string(),
        locator,
        spec,
        sweeps,
        catalogue: Arc::clone(catalogue),
    })
}

/// Every `[base]` section (or `external.<name>` table) any of `algorithms` reads in any kind of
/// world.
fn sections_read(catalogue: &Catalogue, algorithms: &[AlgorithmId]) -> Vec<String> {
    algorithms
        .iter()
        .flat_map(|a| {
            crate::world::WorldKind::ALL
                .into_iter()
                .flat_map(move |k| catalogue.algorithm(a).sections_read(k))
        })
        .collect()
}

/// Whether the parameter `path` lies in one of the sections `read`.
fn is_read(read: &[String], path: &str) -> bool {
    read.iter().any(|r| path == r || path.starts_with(&format!("{r}.")))
}

/// Checks a morris / sobol block: `ranges` of known parameters read by the study's algorithms,
/// `[low, high]` numbers with low < high (integers for an integer parameter), `log` ranges
/// above 0, `tied` keys following a ranged parameter, and the design's sizes.
fn check_design(
    i: usize,
    block: &SweepSpec,
    base_leaves: &[(String, toml::Value)],
    read: &[String],
    names: &str,
    err: &mut dyn FnMut(&str, String),
) -> Option<DesignSpec> {
    let key = |k: &str| format!("sweeps[{i}].{k}");
    let before = std::cell::Cell::new(0usize);
    let mut fail = |k: String, m: String| {
        before.set(before.get() + 1);
        err(&k, m)
    };
    if !block.values.is_empty() {
        fail(
            key("values"),
            "a morris or sobol sweep samples `ranges`, not lists of `values`".into(),
        );
    }
    if !block.labels.is_empty() {
        fail(key("labels"), "only a zip sweep can name its points".into());
    }
    let mut ranged = Vec::new();
    flatten_sweep(&block.ranges, "", &key("ranges"), &mut ranged);
    if ranged.is_empty() {
        fail(
            key("ranges"),
            "give each parameter's range, e.g. ranges = { \"features.dmax_m\" = [0.001, 0.1] }"
                .into(),
        );
    }
    let mut params = Vec::new();
    for p in &ranged {
        let Some((_, base)) = base_leaves.iter().find(|(k, _)| *k == p.path) else {
            let names: Vec<_> = base_leaves.iter().map(|(k, _)| k.as_str()).collect();
            fail(
                p.key.clone(),
                format!("unknown parameter `{}` (parameters: {})", p.path, names.join(", ")),
            );
            continue;
        };
        if !is_read(read, &p.path) {
            fail(
                p.key.clone(),
                format!(
                    "`{}` is not read by any of this study's algorithms ({names}): its indices would be zero by construction",
                    p.path,
                ),
            );
            continue;
        }
        let integer = base.is_integer();
        if !(base.is_integer() || base.is_float()) {
            fail(
                p.key.clone(),
                format!("`{}` is not a number: a range needs a numeric parameter", p.path),
            );
            continue;
        }
        let bounds: Vec<Option<f64>> =
            p.values.iter().map(|v| v.as_float().or(v.as_integer().map(|n| n as f64))).collect();
        let (low, high) = match bounds[..] {
            [Some(lo), Some(hi)] if lo.is_finite() && hi.is_finite() && lo < hi => (lo, hi),
            _ => {
                fail(
                    p.key.clone(),
                    "must be [low, high], two finite numbers with low < high".into(),
                );
                continue;
            }
        };
        if integer && !p.values.iter().all(toml::Value::is_integer) {
            fail(
                p.key.clone(),
                format!("`{}` is an integer parameter: give integer bounds", p.path),
            );
            continue;
        }
        let log = block.log.contains(&p.path);
        if log && low <= 0.0 {
            fail(
                p.key.clone(),
                format!(
                    "`{}` is sampled on a log scale (`log`): its low bound must be > 0",
                    p.path
                ),
            );
        }
        params.push(RangedParam {
            path: p.path.clone(),
            key: p.key.clone(),
            low,
            high,
            log,
            integer,
        });
    }
    for (j, l) in block.log.iter().enumerate() {
        if !ranged.iter().any(|p| &p.path == l) {
            fail(key(&format!("log[{j}]")), format!("`{l}` has no range in this sweep"));
        }
    }
    let mut tied = Vec::new();
    for (path, source) in &block.tied {
        let k = join_key(&key("tied"), path);
        if !base_leaves.iter().any(|(b, _)| b == path) {
            fail(k, format!("unknown parameter `{path}`"));
        } else if ranged.iter().any(|p| &p.path == path) {
            fail(k, format!("`{path}` has its own range"));
        } else {
            match source.as_str().and_then(|s| params.iter().position(|p| p.path == s)) {
                Some(j) => tied.push((path.clone(), j)),
                None => fail(k, "must name a parameter of this sweep's `ranges`".into()),
            }
        }
    }
    let d = params.len();
    let or_default = |v: Option<u32>, default: u32| v.unwrap_or(default) as usize;
    let (levels, trajectories, samples) = (
        or_default(block.levels, 4),
        or_default(block.trajectories, 10),
        or_default(block.samples, 64),
    );
    match block.kind {
        SweepKind::Morris => {
            if block.samples.is_some() {
                fail(
                    key("samples"),
                    "a morris sweep has `trajectories` and `levels`, not `samples`".into(),
                );
            }
            if !(2..=64).contains(&levels) || levels % 2 == 1 {
                fail(key("levels"), format!("must be an even number in [2, 64], got {levels}"));
            }
            if !(2..=10_000).contains(&trajectories) {
                fail(key("trajectories"), format!("must be in [2, 10000], got {trajectories}"));
            }
        }
        _ => {
            for (k, set) in
                [("levels", block.levels.is_some()), ("trajectories", block.trajectories.is_some())]
            {
                if set {
                    fail(key(k), "a sobol sweep has `samples`, not this key".into());
                }
            }
            if !samples.is_power_of_two() || !(8..=65_536).contains(&samples) {
                fail(
                    key("samples"),
                    format!(
                        "must be a power of two in [8, 65536] (the Sobol' sequence's balance), got {samples}"
                    ),
                );
            }
            let most = crate::stats::sensitivity::MAX_DIMENSIONS / 2;
            if !(2..=most).contains(&d) && !ranged.is_empty() {
                fail(
                    key("ranges"),
                    format!(
                        "a sobol sweep takes 2 to {most} parameters (its design uses 2d Sobol' dimensions, {} available), got {d}",
                        crate::stats::sensitivity::MAX_DIMENSIONS
                    ),
                );
            }
        }
    }
    (before.get() == 0).then_some(DesignSpec { params, tied, levels, trajectories, samples })
}

/// Walks a sweep's `values` table: a list is a leaf (the values of one parameter); a non-list,
/// non-table value is a leaf with no values (reported as an error by the caller).
fn flatten_sweep(table: &toml::Table, prefix: &str, key_prefix: &str, out: &mut Vec<SweptParam>) {
    for (k, v) in table {
        let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
        let key = join_key(key_prefix, k);
        match v {
            toml::Value::Table(t) => flatten_sweep(t, &path, &key, out),
            toml::Value::Array(values) => {
                out.push(SweptParam { path, key, values: values.clone() })
            }
            _ => out.push(SweptParam { path, key, values: Vec::new() }),
        }
    }
}

impl LoadedSpec {
    pub fn error_at(&self, key: &str, message: impl Into<String>) -> SourceError {
        SourceError::at_key(&self.locator, key, message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
id = "t"
title = "T"
seed = 1
replicates = 2
maps = ["a"]
algorithms = ["odometry"]

[base.odometry]
model = "proportional"
k = 0.1
k_is = "std"

[[sweeps]]
kind = "one_at_a_time"
values = { "odometry.k" = [0.0, 0.1], sim = { dt_s = [0.05, 0.1] } }
"#;

    fn errs(text: &str) -> Vec<SourceError> {
        parse(Path::new("x.toml"), text, &Default::default()).unwrap_err().errors
    }

    #[test]
    fn good_spec_flattens_sweeps_in_written_order() {
        let s = parse(Path::new("x.toml"), GOOD, &Default::default()).unwrap();
        let paths: Vec<_> =
            s.sweeps[0].params.iter().map(|p| (p.path.as_str(), p.key.as_str())).collect();
        assert_eq!(
            paths,
            vec![
                ("odometry.k", "sweeps[0].values.\"odometry.k\""),
                ("sim.dt_s", "sweeps[0].values.sim.dt_s")
            ]
        );
        assert_eq!(
            s.spec.base.odometry,
            crate::world::odometry::OdometryNoise::Proportional {
                k: 0.1,
                k_is: crate::world::odometry::Spread::Std
            }
        );
    }

    #[test]
    fn seed_tags() {
        let tag = |source: &str| {
            ClaimSpec {
                source: source.into(),
                ..toml::from_str::<ClaimSpec>(
                    "id = \"c\"\nsource = \"\"\nkind = \"seed\"\ntext = \"t\"\ntest = \"fails\"",
                )
                .unwrap()
            }
            .seed_tag()
            .map(str::to_string)
        };
        assert_eq!(tag("[FT] §7 claim 5").as_deref(), Some("FT"));
        assert_eq!(tag("Montemerlo et al. 2003"), None);
        assert_eq!(tag("[EP] claim C2 on real scans").as_deref(), Some("EP"));
    }

    /// The claim rules' inputs are checked with file/line/key errors: a kind, a tagged source
    /// for seed claims, a `why` for a tolerance or a margin, a metric except for `fails`.
    #[test]
    fn claims_need_their_justifications() {
        let claim = |body: &str| format!("{GOOD}\n[[claims]]\nid = \"c\"\ntext = \"t\"\n{body}\n");
        let keys = |body: &str| errs(&claim(body)).into_iter().map(|e| e.key).collect::<Vec<_>>();
        let ok = "source = \"[FT] x\"\nkind = \"seed\"\nmetric = \"ate_rmse_m\"\ntest = \"flat\"\nover = { \"odometry.k\" = [0.0, 0.1] }\ntolerance_rel = 0.2\nwhy = \"the thesis's rerun\"";
        assert!(
            parse(Path::new("x.toml"), &claim(ok), &Default::default()).is_ok(),
            "{:?}",
            keys(ok)
        );
        assert!(
            keys(&ok.replace("\nwhy = \"the thesis's rerun\"", ""))
                .contains(&"claims[0].why".to_string())
        );
        assert!(
            keys(&ok.replace("[FT] x", "Montemerlo")).contains(&"claims[0].source".to_string()),
            "a seed claim names its work"
        );
        assert!(!keys(&ok.replace("kind = \"seed\"\n", "")).is_empty(), "the kind is required");
        assert!(
            keys(&ok.replace("tolerance_rel = 0.2", "tolerance_rel = 0.2\ntolerance = 0.1"))
                .contains(&"claims[0]".to_string()),
            "one tolerance"
        );
        let fails =
            "source = \"[FT] x\"\nkind = \"seed\"\ntest = \"fails\"\nat = { \"odometry.k\" = 0.1 }";
        assert!(
            parse(Path::new("x.toml"), &claim(fails), &Default::default()).is_ok(),
            "{:?}",
            keys(fails)
        );
        assert!(
            keys(&format!("{fails}\nmetric = \"ate_rmse_m\""))
                .contains(&"claims[0].metric".to_string())
        );
        assert!(
            keys(&fails.replace(
                "test = \"fails\"",
                "test = \"greater\"\nthan = { \"odometry.k\" = 0.0 }"
            ))
            .contains(&"claims[0].metric".to_string())
        );
    }

    #[test]
    fn unknown_key_names_line_and_key() {
        let e = errs(&GOOD.replace("k = 0.1\n", "k = 0.1\nkk = 3\n"));
        assert_eq!(e.len(), 1);
        assert!(e[0].message.contains("unknown field `kk`"), "{}", e[0].message);
        // serde places it at the [base.odometry] table (a tagged enum); we point at the key
        assert_eq!((e[0].key.as_str(), e[0].line), ("base.odometry.kk", 12));
    }

    #[test]
    fn negative_noise_names_line_and_key() {
        let e = errs(&GOOD.replace("k = 0.1\n", "k = -0.1\n"));
        assert_eq!(e.len(), 1);
        assert_eq!(e[0].key, "base.odometry.k");
        assert_eq!(e[0].line, 11);
        assert!(e[0].message.contains("≥ 0"));
    }

    #[test]
    fn unknown_sweep_parameter_and_algorithm() {
        let e = errs(&GOOD.replace("\"odometry.k\"", "\"odometry.kk\""));
        assert_eq!(e[0].key, "sweeps[0].values.\"odometry.kk\"");
        assert_eq!(e[0].line, 16);
        let e = errs(&GOOD.replace("[\"odometry\"]", "[\"odometry\", \"magic\"]"));
        assert!(e[0].message.contains("unknown algorithm `magic`"), "{}", e[0].message);
        assert_eq!(e[0].line, 7);
    }

    #[test]
    fn sweeping_what_no_algorithm_reads_is_refused() {
        // the odometry baseline reads no laser: runs would differ in label only
        let e = errs(
            &GOOD.replace("\"odometry.k\" = [0.0, 0.1]", "\"laser.max_range_m\" = [4.0, 8.0]"),
        );
        assert_eq!(e[0].key, "sweeps[0].values.\"laser.max_range_m\"");
        assert!(e[0].message.contains("not read by any"), "{}", e[0].message);
    }

    #[test]
    fn log_axis_needs_positive_values() {
        let e = errs(&format!("{GOOD}\n[report]\nlog_x = [\"odometry.k\"]\n"));
        assert_eq!(e[0].key, "report.log_x[0]");
    }

    #[test]
    fn zip_needs_equal_lengths() {
        let e = errs(&GOOD.replace("one_at_a_time", "zip").replace("[0.05, 0.1]", "[0.05]"));
        assert_eq!(e[0].key, "sweeps[0].values");
    }

    /// A sequential budget (issue 31): looks at `replicates`, then every `stage_replicates`, up
    /// to `max_replicates`; a budget below the first stage, a design without a budget, an empty
    /// stage, too many looks and claims no replicate can decide are errors naming their key.
    #[test]
    fn a_sequential_budget_is_checked_and_expanded_into_looks() {
        // a top-level key after `replicates`, and a `[sequential]` table at the end
        let with = |extra: &str| {
            let (top, table) = match extra.split_once('[') {
                Some((top, rest)) => (top, format!("[{rest}")),
                None => (extra, String::new()),
            };
            format!(
                "{}{table}",
                GOOD.replace("replicates = 2\n", &format!("replicates = 3\n{top}"))
            )
        };
        let s =
            parse(Path::new("x.toml"), &with("max_replicates = 7\n"), &Default::default()).unwrap();
        assert_eq!(s.spec.looks(), Some(vec![3, 6, 7]));
        assert_eq!(s.spec.replicate_budget(), 7);
        let staged =
            with("max_replicates = 9\n[sequential]\nstage_replicates = 3\nspending = \"pocock\"\n");
        let s = parse(Path::new("x.toml"), &staged, &Default::default()).unwrap();
        assert_eq!(s.spec.looks(), Some(vec![3, 6, 9]));
        assert_eq!(s.spec.sequential.unwrap().spending, Spending::Pocock);
        assert_eq!(
            parse(Path::new("x.toml"), GOOD, &Default::default()).unwrap().spec.looks(),
            None
        );

        let e = errs(&with("max_replicates = 1\n"));
        assert_eq!((e[0].key.as_str(), e[0].line), ("max_replicates", 6));
        assert!(e[0].message.contains("at least `replicates` (3)"), "{}", e[0].message);
        // a first stage too small to judge could never ask for the next
        let e = errs(&GOOD.replace("replicates = 2\n", "replicates = 2\nmax_replicates = 8\n"));
        assert_eq!(e[0].key, "replicates");
        assert!(e[0].message.contains("at least 3 replicates"), "{}", e[0].message);
        let e = errs(&with("[sequential]\nspending = \"pocock\"\n"));
        assert_eq!(e[0].key, "sequential");
        let e = errs(&with("max_replicates = 8\n[sequential]\nstage_replicates = 0\n"));
        assert_eq!(e[0].key, "sequential.stage_replicates");
        let e = errs(&with("max_replicates = 100\n[sequential]\nstage_replicates = 1\n"));
        assert!(e[0].key == "max_replicates" && e[0].message.contains("98 looks"), "{e:?}");
        let e = errs(&with("[sequential]\nspending = \"lucky\"\n"));
        assert!(e[0].key.starts_with("sequential"), "{e:?}");
        // a sensitivity index is decided by design rows: no stage of replicates can decide it
        let index = "[[claims]]\nid = \"c\"\nsource = \"s\"\nkind = \"extension\"\ntext = \"t\"\nmetric = \"ate_rmse_m\"\nindex = \"st\"\nparameter = \"odometry.k\"\ntest = \"below\"\nvalue = 0.05\n";
        let e = errs(&format!("{}{index}", with("max_replicates = 8\n")));
        assert!(
            e.iter().any(
                |e| e.key == "claims[0]" && e.message.contains("cannot be judged sequentially")
            ),
            "{e:?}"
        );
    }

    #[test]
    fn display_is_file_line_column_key_message() {
        let err = parse(
            Path::new("experiments/x.toml"),
            &GOOD.replace("replicates = 2", "replicates = 0"),
            &Default::default(),
        )
        .unwrap_err();
        assert_eq!(err.to_string(), "experiments/x.toml:5:1: key `replicates`: must be ≥ 1");
    }

    #[test]
    fn diff_criteria_are_checked_and_resolved_per_metric() {
        let text = format!(
            "{GOOD}\n[report.diff]\nalpha = 0.01\n[report.diff.metrics.ate_rmse_m]\nmin_effect = 0.05\n"
        );
        let spec = parse(Path::new("t.toml"), &text, &Default::default()).unwrap().spec;
        assert_eq!(spec.report.diff.for_metric("ate_rmse_m", (0.05, 0.01)), (0.01, 0.05));
        assert_eq!(spec.report.diff.for_metric("ate_mean_m", (0.05, 0.01)), (0.01, 0.01));
        let e = errs(&format!(
            "{GOOD}\n[report.diff]\nalpha = 1.5\n[report.diff.metrics.nope]\nmin_effect = -1.0\n"
        ));
        let keys: Vec<&str> = e.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(
            keys,
            [
                "report.diff.alpha",
                "report.diff.metrics.nope",
                "report.diff.metrics.nope.min_effect"
            ]
        );
    }

    const DESIGN_HEAD: &str = "id = \"t\"\ntitle = \"T\"\nseed = 1\nreplicates = 2\nmaps = [\"a\"]\nalgorithms = [\"fastslam1\"]\n";

    /// A sobol sweep: ranges of known, read, numeric parameters with low < high, integer bounds for
    /// an integer parameter, log ranges above 0, tied keys naming a ranged parameter, a
    /// power-of-two sample count, no `values`; each error at its key.
    #[test]
    fn design_sweeps_are_checked_key_by_key() {
        let good = format!(
            "{DESIGN_HEAD}[[sweeps]]\nkind = \"sobol\"\nsamples = 16\nranges = {{ \"features.dmax_m\" = [0.001, 0.1], \"fastslam.particles\" = [5, 500], \"fastslam.motion_x\" = [0.0001, 0.02] }}\nlog = [\"features.dmax_m\", \"fastslam.particles\"]\ntied = {{ \"fastslam.motion_y\" = \"fastslam.motion_x\" }}\n"
        );
        let s = parse(Path::new("x.toml"), &good, &Default::default()).unwrap();
        let d = s.sweeps[0].design.as_ref().unwrap();
        let summary: Vec<(&str, bool, bool)> =
            d.params.iter().map(|p| (p.path.as_str(), p.log, p.integer)).collect();
        assert_eq!(
            summary,
            [
                ("features.dmax_m", true, false),
                ("fastslam.particles", true, true),
                ("fastslam.motion_x", false, false)
            ]
        );
        assert_eq!((d.tied.clone(), d.samples), (vec![("fastslam.motion_y".to_string(), 2)], 16));
        let keys = |text: String| errs(&text).into_iter().map(|e| e.key).collect::<Vec<_>>();
        assert_eq!(
            keys(good.replace("[5, 500]", "[5.0, 500.0]")),
            ["sweeps[0].ranges.\"fastslam.particles\""],
            "integer parameter, float bounds"
        );
        assert_eq!(
            keys(good.replace("[0.001, 0.1]", "[0.1, 0.001]")),
            ["sweeps[0].ranges.\"features.dmax_m\""],
            "low ≥ high"
        );
        assert_eq!(
            keys(good.replace("[0.001, 0.1]", "[0.0, 0.1]")),
            ["sweeps[0].ranges.\"features.dmax_m\""],
            "log from 0"
        );
        assert_eq!(keys(good.replace("samples = 16", "samples = 24")), ["sweeps[0].samples"]);
        assert_eq!(
            keys(good.replace("\"fastslam.motion_x\" }", "\"fastslam.motion_z\" }")),
            ["sweeps[0].tied.\"fastslam.motion_y\""]
        );
        assert_eq!(
            keys(good.replace("features.dmax_m\" = [", "features.dmax\" = ["))
                .first()
                .map(String::as_str),
            Some("sweeps[0].ranges.\"features.dmax\"")
        );
        assert_eq!(
            keys(good.replace("\"fastslam.particles\" = [5, 500]", "\"ekf.gate\" = [1.0, 9.0]"))
                .first()
                .map(String::as_str),
            Some("sweeps[0].ranges.\"ekf.gate\""),
            "{:?}",
            errs(&good.replace("\"fastslam.particles\" = [5, 500]", "\"ekf.gate\" = [1.0, 9.0]"))
        );
        assert_eq!(
            keys(
                good.replace("samples = 16", "samples = 16\nvalues = { \"fastslam.p0\" = [0.1] }")
            ),
            ["sweeps[0].values"]
        );
        assert_eq!(
            keys(good.replace("samples = 16", "samples = 16\nlevels = 4")),
            ["sweeps[0].levels"]
        );
        // morris: even levels; a grid sweep has no ranges
        let morris =
            good.replace("kind = \"sobol\"\nsamples = 16", "kind = \"morris\"\nlevels = 5");
        assert_eq!(keys(morris), ["sweeps[0].levels"]);
        let grid = format!(
            "{DESIGN_HEAD}[[sweeps]]\nkind = \"grid\"\nvalues = {{ \"fastslam.p0\" = [0.1] }}\nranges = {{ \"fastslam.p0\" = [0.1, 1.0] }}\n"
        );
        assert_eq!(keys(grid), ["sweeps[0].ranges"]);
    }

    /// Index claims name a ranged parameter of a sweep of their index's kind and no cells.
    #[test]
    fn index_claims_are_checked() {
        let base = format!(
            "{DESIGN_HEAD}[[sweeps]]\nkind = \"sobol\"\nsamples = 16\nranges = {{ \"features.dmax_m\" = [0.001, 0.1], \"fastslam.particles\" = [5, 500] }}\n[[claims]]\nid = \"c\"\nsource = \"slamlab\"\nkind = \"extension\"\ntext = \"t\"\nmetric = \"ate_rmse_m\"\nindex = \"st\"\nparameter = \"fastslam.particles\"\ntest = \"above\"\nvalue = 0.3\n"
        );
        assert!(parse(Path::new("x.toml"), &base, &Default::default()).is_ok());
        let keys = |text: String| errs(&text).into_iter().map(|e| e.key).collect::<Vec<_>>();
        assert_eq!(
            keys(base.replace("index = \"st\"", "index = \"mu_star\"")),
            ["claims[0].index"],
            "no morris sweep"
        );
        assert_eq!(
            keys(base.replace("parameter = \"fastslam.particles\"", "parameter = \"fastslam.p0\"")),
            ["claims[0].parameter"]
        );
        assert_eq!(
            keys(base.replace("test = \"above\"", "test = \"greater\"")),
            ["claims[0]"],
            "greater needs than_parameter"
        );
        assert!(
            parse(
                Path::new("x.toml"),
                &base.replace(
                    "test = \"above\"",
                    "test = \"greater\"\nthan_parameter = \"features.dmax_m\""
                ),
                &Default::default()
            )
            .is_ok()
        );
        assert_eq!(
            keys(base.replace("test = \"above\"", "test = \"flat\"")).first().map(String::as_str),
            Some("claims[0].test")
        );
        assert_eq!(
            keys(base.replace("value = 0.3", "value = 0.3\nat = { \"fastslam.p0\" = 0.1 }")),
            ["claims[0].at"]
        );
    }
}
