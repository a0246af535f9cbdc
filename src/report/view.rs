//! Stored results → view-models: every number pre-formatted, every list explicitly sorted.
//! Templates receive only these structs.

use super::figure::{
    self, LineFigure, LineSeries, PathSeries, SeriesPoint, TrajectoryFigure, XAxis,
};
use super::model::{
    FigureView, GroupView, IndexEntry, Kv, NamedTable, StudyPages, StudyView, TableView,
};
use crate::algo::{Choice, Topic};
use crate::judge::agreement::{self, Outcome, Published};
use crate::judge::margins;
use crate::metrics::{MetricDef, metric_def};
use crate::params::flatten;
use crate::scenario::Scenario;
use crate::spec::{Bands, SweepKind};
use crate::stats::{self, Summary, sig, sig_ascii};
use crate::store::reference::ReferenceRow;
use crate::store::{
    LandmarkRow, MatchRows, ParamValue, RunLandmarks, RunRow, RunStatus, StudyData, TraceRows,
};
use std::collections::BTreeMap;

/// From this many maps, a figure with published series is drawn as one panel per map.
const SMALL_MULTIPLES_MAPS: usize = 3;
/// Significant figures in report tables and in `summary.csv`.
const TABLE_DIGITS: usize = 3;
const CSV_DIGITS: usize = 6;

fn kv(key: &str, value: impl ToString) -> Kv {
    Kv { key: key.to_string(), value: value.to_string() }
}

/// Maps and runs of a study, in the order the spec lists them.
struct Study<'a> {
    data: &'a StudyData,
    /// The built-in algorithms and the study's external ones.
    catalogue: crate::algo::Catalogue,
    maps: Vec<(String, Option<Scenario>)>,
    metrics: Vec<&'static MetricDef>,
    /// Base parameters, flattened.
    base: Vec<(String, toml::Value)>,
    /// A sequential study that staged published items: each published cell's outcome as its
    /// looks left it, (reference row index, metric) → outcome, and the last look's one-sided α
    /// (for a cell no staged item judged).
    staged: Option<(BTreeMap<(usize, String), Option<Outcome>>, f64)>,
}

impl Study<'_> {
    fn spec(&self) -> &crate::spec::ExperimentSpec {
        &self.data.resolved.spec
    }
    /// The study's algorithms, in the spec's order.
    fn algorithms(&self) -> impl Iterator<Item = &dyn crate::algo::Algorithm> {
        self.data.resolved.spec.algorithms.iter().map(|a| self.catalogue.algorithm(a))
    }
    fn runs_of<'b>(
        &'b self,
        map: &'b str,
        algorithm: &'b str,
        point: &'b str,
    ) -> impl Iterator<Item = &'b RunRow> + 'b {
        self.data.runs_in(map, algorithm, point)
    }
    /// Summary of a metric over a cell's successful runs (run-id order), and (failed, n).
    fn cell(
        &self,
        map: &str,
        algorithm: &str,
        point: &str,
        metric: &str,
    ) -> (Summary, usize, usize) {
        let runs: Vec<&RunRow> = self.runs_of(map, algorithm, point).collect();
        let values: Vec<f64> = runs
            .iter()
            .filter(|r| r.status == RunStatus::Ok)
            .filter_map(|r| r.metric(metric))
            .collect();
        let failed = runs.iter().filter(|r| r.status != RunStatus::Ok).count();
        (stats::summarize_nonnegative(&values), failed, runs.len())
    }
    /// The successful replicates' values of a cell.
    fn values(&self, map: &str, algorithm: &str, point: &str, metric: &str) -> Vec<f64> {
        self.data.replicate_values(map, algorithm, point, metric).into_values().collect()
    }
    /// Runs behind each published mean.
    fn published_runs(&self) -> u32 {
        self.spec().report.reference.as_ref().map_or(1, |r| r.runs)
    }
    /// The margins of the work the study's published values come from.
    fn work(&self) -> &'static margins::WorkMargins {
        margins::for_label(self.spec().report.reference.as_ref().map_or("", |r| r.label.as_str()))
    }
    /// Whether a published value of `metric` (with its variance, if printed; from reference row
    /// `row`) is shown equivalent to our cell, shown different, or unresolved
    /// (`judge::agreement`); None when it cannot be judged. In a sequential study that staged
    /// published items, the outcome its looks left (the scoreboard's), else the last look's.
    fn agreement(
        &self,
        row: usize,
        metric: &str,
        mean: f64,
        var: Option<f64>,
        ours: &[f64],
    ) -> Option<Outcome> {
        let p = Published { mean, var, runs: self.published_runs() };
        let eps = self.work().margin(metric, mean);
        match &self.staged {
            None => agreement::judge(p, ours, eps).outcome,
            Some((cells, last_alpha)) => match cells.get(&(row, metric.to_string())) {
                Some(outcome) => *outcome,
                None => agreement::judge_at(p, ours, eps, *last_alpha).outcome,
            },
        }
    }
    /// The published dispersion drawn on the dashed series: the 95 % CI of the published mean
    /// when its variance over its runs is printed ([FT]), else none.
    fn published_bars(&self, mean: f64, var: Option<f64>) -> (f64, f64) {
        let m = self.published_runs();
        match var {
            Some(v) if m >= 2 && mean.is_finite() => {
                let half = stats::t_quantile(m as usize - 1) * (v / m as f64).sqrt();
                // cut at 0 like ours: no published metric can be negative either
                ((mean - half).max(0.0), mean + half)
            }
            _ => (f64::NAN, f64::NAN),
        }
    }
    /// The sentence that says how ≠ and ? are decided.
    fn agreement_rule(&self) -> String {
        let m = self.published_runs();
        let margin = sig(self.work().relative * 100.0, 2);
        if m >= 2 {
            format!(
                "the 90 % interval of our mean minus the published mean of {m} runs (with its printed variance, or ours where none is printed) against ±{margin} % of the published value"
            )
        } else {
            format!(
                "the order-statistic 90 % interval of our median against ±{margin} % of the published single run; a published run inside our replicates' 90 % prediction interval is never shown different (distribution-free)"
            )
        }
    }
    /// The published row for (map, parameter = value), if the study shows a reference.
    fn published(&self, map: &str, param: &str, value: f64) -> Option<(usize, &ReferenceRow)> {
        self.data.reference.iter().enumerate().find(|(_, r)| {
            r.map == map
                && r.parameter == param
                && (r.value - value).abs() <= 1e-9 * value.abs().max(1.0)
        })
    }

    /// The published value of `metric` for (map, algorithm, named cell), from a long-layout
    /// reference, with the table it comes from.
    fn published_cell(
        &self,
        map: &str,
        algorithm: &str,
        cell: &str,
        metric: &str,
    ) -> Option<(usize, f64, &str)> {
        self.data
            .reference
            .iter()
            .enumerate()
            .filter(|(_, r)| r.map == map && r.algorithm == algorithm && r.cell == cell)
            .find_map(|(i, r)| r.metric(metric).map(|v| (i, v, r.table.as_str())))
    }

    fn reference_label(&self) -> &str {
        self.spec().report.reference.as_ref().map_or("published", |r| r.label.as_str())
    }

    /// The value of parameter `path` at a point: its sweep assignment, else the base value.
    fn value_at(&self, point: &crate::store::PointRecord, path: &str) -> Option<toml::Value> {
        point
            .assignments
            .get(path)
            .cloned()
            .or_else(|| self.base.iter().find(|(k, _)| k == path).map(|(_, v)| v.clone()))
    }
}

/// Reads the traces and final maps of the given runs.
/// Reads the stored traces, final maps and per-match rows of the given runs.
/// Only the kinds of rows `Parts` asks for are read; the others come back empty.
pub type Fetch<'a> =
    dyn Fn(&[String], Parts) -> (Vec<TraceRows>, Vec<RunLandmarks>, Vec<MatchRows>) + 'a;

/// Which of a run's stored rows a [`Fetch`] reads: traces, final maps, matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Parts {
    pub traces: bool,
    pub landmarks: bool,
    pub matches: bool,
}

impl Parts {
    pub const ALL: Parts = Parts { traces: true, landmarks: true, matches: true };
    const LANDMARKS: Parts = Parts { traces: false, landmarks: true, matches: false };
    const MATCHES: Parts = Parts { traces: false, landmarks: false, matches: true };
}

pub fn build(
    data: &StudyData,
    traces: &Fetch<'_>,
    diagnostics: Option<&crate::scanmatch::diagnose::Diagnostics>,
) -> StudyPages {
    let spec = &data.resolved.spec;
    let maps: Vec<(String, Option<Scenario>)> = spec
        .maps
        .iter()
        .map(|name| {
            (
                name.clone(),
                data.maps
                    .iter()
                    .find(|(n, _)| n == name)
                    .and_then(|(_, text)| Scenario::from_toml(text).ok()),
            )
        })
        .collect();
    let metrics: Vec<&'static MetricDef> =
        spec.report.metrics.iter().filter_map(|m| metric_def(m)).collect();
    // Only the sections the study's algorithms read (what entered the run hashes).
    let catalogue = data.resolved.catalogue();
    let base = crate::store::select::read_base(spec, &catalogue, &world_kinds(&maps));
    // a sequential study's looks: its claims, and the published cells of the items it staged
    let replay = crate::judge::sequential::Design::of(spec)
        .map(|design| crate::judge::sequential::replay(data, &design));
    let staged = replay.as_ref().filter(|r| !r.items.is_empty()).map(|r| {
        let mut cells = BTreeMap::new();
        for item in &r.items {
            for (key, (a, _)) in &item.cells {
                cells.entry(key.clone()).or_insert(a.outcome);
            }
        }
        (cells, r.looks.last().map_or(agreement::ALPHA, |l| l.levels.tost_alpha))
    });
    let study = Study { data, catalogue, maps, metrics, base, staged };

    // morris / sobol groups get the sensitivity section instead of error-vs-parameter plots
    let mut groups: Vec<GroupView> = data
        .resolved
        .groups
        .iter()
        .enumerate()
        .filter(|(_, g)| g.design.is_none())
        .map(|(gi, _)| group_view(&study, gi))
        .collect();
    let analyses = super::sensitivity::analyses(data, &study.metrics);
    let sensitivity = super::sensitivity::build(data, &analyses, &study.metrics);
    // Two groups can sweep the same parameters (e.g. a one-at-a-time list and a zip): keep file
    // names (and HTML ids) unique, deterministically, in group order.
    let mut used: Vec<String> = Vec::new();
    for f in groups.iter_mut().flat_map(|g| g.figures.iter_mut()) {
        let mut name = f.file.clone();
        let mut k = 2;
        while used.contains(&name) {
            name = format!("{}-{k}", f.file);
            k += 1;
        }
        f.file = name.clone();
        used.push(name);
    }
    let trajectories = trajectory_views(&study, traces);
    let diagnostics = diagnostics.map(|d| {
        super::diagnostics::build(
            d,
            spec,
            &study.catalogue,
            study
                .maps
                .iter()
                .find(|(n, _)| n == &d.map)
                .and_then(|(_, m)| m.as_ref().map(|s| &s.map)),
        )
    });
    let landmark_tables = landmark_tables(&study, traces);
    let contrasts = contrast_tables(&study);
    let failed = data.runs.iter().filter(|r| r.status != RunStatus::Ok).count();
    let (claims, sequential, staged) = match replay {
        None => (crate::judge::claims::evaluate(data), Vec::new(), Vec::new()),
        Some(replay) => {
            let tables = super::sequential::tables(&replay, data.runs.len());
            (replay.results, tables, replay.items)
        }
    };
    let view = StudyView {
        id: spec.id.clone(),
        title: spec.title.clone(),
        description: paragraphs(&spec.description),
        facts: facts(&study, failed),
        maps: maps_table(&study),
        sweeps: sweep_lines(&study),
        base_params: TableView {
            columns: vec!["Parameter".into(), "Value".into()],
            rows: study
                .base
                .iter()
                .map(|(k, v)| vec![k.clone(), crate::plan::format_value(v)])
                .collect(),
            align: "ll".into(),
        },
        choices: modelling_choices(&study),
        notes: spec.notes.clone(),
        groups,
        sensitivity,
        claims,
        sequential,
        timed_claims: spec
            .claims
            .iter()
            .filter(|c| c.judged_on.is_some())
            .map(|c| format!("{} (“{}”)", c.id, c.text))
            .collect(),
        trajectories,
        diagnostics_intro: diagnostics.as_ref().map_or(Vec::new(), |d| d.intro.clone()),
        diagnostics: diagnostics.map_or(Vec::new(), |d| d.figures),
        match_tables: match_distribution(&study, traces),
        landmark_tables,
        contrasts,
        failures: failures_table(data),
        metrics: TableView {
            columns: vec!["Metric".into(), "Unit".into(), "Definition".into()],
            rows: study
                .metrics
                .iter()
                .map(|m| vec![m.name.to_string(), m.unit.to_string(), m.description.to_string()])
                .collect(),
            align: "llp{0.55\\linewidth}".into(),
        },
        provenance: provenance(data),
    };
    let index = IndexEntry {
        id: spec.id.clone(),
        title: spec.title.clone(),
        summary: paragraphs(&spec.description).into_iter().next().unwrap_or_default(),
        runs: data.runs.len().to_string(),
        failed: format!("{failed}/{}", data.runs.len()),
        maps: spec.maps.join(", "),
        algorithms: spec.algorithms.iter().map(|a| a.as_str()).collect::<Vec<_>>().join(", "),
    };
    let csv = summary_csv(&study);
    let sensitivity_csv = super::sensitivity::csv(data, &analyses);
    StudyPages { view, index, csv, sensitivity_csv, staged }
}

fn paragraphs(text: &str) -> Vec<String> {
    text.split("\n\n")
        .map(|p| p.split_whitespace().collect::<Vec<_>>().join(" "))
        .filter(|p| !p.is_empty())
        .collect()
}

fn facts(study: &Study<'_>, failed: usize) -> Vec<Kv> {
    let spec = study.spec();
    let points = study.data.resolved.points.len();
    let cells = spec.maps.len() * spec.algorithms.len() * points;
    vec![
        kv("Study id", &spec.id),
        kv("Seed", spec.seed),
        kv("Maps", spec.maps.join(", ")),
        kv("Algorithms", study.algorithms().map(|a| a.title()).collect::<Vec<_>>().join(", ")),
        kv("Sweep points", points),
        kv("Cells (map × algorithm × point)", cells),
        match spec.looks() {
            None => kv("Replicates per cell (n)", spec.replicates),
            Some(looks) => kv(
                "Replicates per cell (n)",
                format!(
                    "{} to {}, in stages where claims were undecided (sequential: looks at {})",
                    spec.replicates,
                    spec.replicate_budget(),
                    looks.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")
                ),
            ),
        },
        kv("Runs", study.data.runs.len()),
        kv("Failed or diverged runs", format!("{failed}/{}", study.data.runs.len())),
    ]
}

/// The algorithms' modelling-choice sentences on worlds of `kinds`, each once, in topic order.
fn algorithm_choices(study: &Study<'_>, kinds: &[crate::world::WorldKind]) -> Vec<Choice> {
    study.catalogue.choices(&study.spec().algorithms, &study.spec().base, kinds)
}

/// The choices of a study on real data only: the simulation's do not apply.
fn dataset_choices(study: &Study<'_>) -> Vec<String> {
    let mut out = vec!["Real data: odometry, measurements and truth come from the dataset's files (read from the path in each map file; the files' bytes are part of every run's content hash). The simulation settings of [base] do not apply.".to_string()];
    out.extend(
        algorithm_choices(study, &[crate::world::WorldKind::Points]).into_iter().map(|c| c.text),
    );
    out.push("Trajectory error is evo's APE (translation part) at the steps with truth; truth without headings (GPS) is first aligned to the estimate by a rigid transform (rotation and translation).".into());
    let mut notes: Vec<String> = Vec::new();
    for (name, map) in &study.maps {
        for note in map.iter().flat_map(|m| &m.map.notes) {
            notes.push(format!("Map {name}: {note}"));
        }
    }
    out.extend(notes);
    out
}

/// The kinds of world among a study's maps (laser first), laser for a map that cannot be read.
fn world_kinds(maps: &[(String, Option<Scenario>)]) -> Vec<crate::world::WorldKind> {
    let has = |k| {
        maps.iter().any(|(_, m)| {
            m.as_ref().map_or(crate::world::WorldKind::Laser, Scenario::world_kind) == k
        })
    };
    crate::world::WorldKind::ALL.into_iter().filter(|&k| has(k)).collect()
}

fn maps_table(study: &Study<'_>) -> TableView {
    // Point landmarks only matter (and are only shown) when a map has some.
    let points = study
        .maps
        .iter()
        .any(|(_, m)| m.as_ref().is_some_and(|m| !m.map.point_landmarks.is_empty()));
    let rows = study
        .maps
        .iter()
        .map(|(name, map)| {
            let path_length = study
                .data
                .runs
                .iter()
                .find(|r| &r.map == name && r.status == RunStatus::Ok)
                .and_then(|r| r.metric("path_length_m"));
            let mut row = vec![name.clone()];
            match map.as_ref().map(|s| &s.map) {
                Some(m) => {
                    row.push(format!(
                        "{} + {} = {}",
                        m.lines.len(),
                        m.corners.len(),
                        m.landmark_count()
                    ));
                    if points {
                        row.push(m.point_landmarks.len().to_string());
                    }
                    row.push(m.trajectory.as_ref().map_or("real data".to_string(), |t| {
                        format!("{} × {} waypoints", t.laps, t.waypoints.len())
                    }));
                    row.push(path_length.map_or("—".into(), |l| format!("{l:.1} m")));
                    row.push(m.source.clone());
                }
                None => row.extend([
                    "(map file not stored)".to_string(),
                    String::new(),
                    String::new(),
                    String::new(),
                ]),
            }
            row
        })
        .collect();
    let mut columns: Vec<String> = vec!["Map".into(), "Lines + corners".into()];
    if points {
        columns.push("Point landmarks".into());
    }
    columns.extend(["Laps".into(), "True path".into(), "Source".into()]);
    let align = format!("lr{}lrp{{0.3\\linewidth}}", if points { "r" } else { "" });
    TableView { columns, rows, align }
}

fn sweep_lines(study: &Study<'_>) -> Vec<String> {
    let spec = study.spec();
    if spec.sweeps.is_empty() {
        return vec!["No sweep: every run uses the base parameters.".into()];
    }
    spec.sweeps
        .iter()
        .map(|s| {
            if s.kind.is_design() {
                return super::sensitivity::sweep_line(s);
            }
            let mut leaves = Vec::new();
            flatten("", &toml::Value::Table(s.values.clone()), &mut leaves);
            // `flatten` stops at arrays: each leaf is one parameter's list.
            let lists: Vec<String> = leaves
                .iter()
                .map(|(k, v)| {
                    let vals: Vec<String> = v
                        .as_array()
                        .map(|a| a.iter().map(crate::plan::format_value).collect())
                        .unwrap_or_default();
                    format!("{k} ∈ {{{}}}", vals.join(", "))
                })
                .collect();
            let kind = match s.kind {
                SweepKind::OneAtATime => "one at a time",
                SweepKind::Grid => "full grid",
                SweepKind::Zip => "zipped",
                SweepKind::Morris | SweepKind::Sobol => unreachable!("described above"),
            };
            format!("{kind}: {}", lists.join("; "))
        })
        .collect()
}

/// The modelling choices behind these runs, stated from the parameters actually used.
fn modelling_choices(study: &Study<'_>) -> Vec<String> {
    let b = &study.spec().base;
    let datasets =
        study.maps.iter().filter(|(_, m)| m.as_ref().is_some_and(|m| m.dataset.is_some())).count();
    if datasets > 0 && datasets == study.maps.len() {
        return dataset_choices(study);
    }
    let mut out = vec![b.sim.describe(&sig(1.0 / b.sim.dt_s, 3)), b.odometry.describe()];
    let kinds = world_kinds(&study.maps);
    let sensors: Vec<_> =
        study.algorithms().flat_map(|a| kinds.iter().map(move |&k| a.sensors(k))).collect();
    if sensors.iter().any(|s| s.laser) {
        out.push(b.laser.describe());
        out.extend(b.laser.describe_artefacts());
    }
    // the algorithms' sentences; the landmark sensor's stands before the filters' models
    let (sensor_side, filter_side): (Vec<Choice>, Vec<Choice>) =
        algorithm_choices(study, &kinds).into_iter().partition(|c| c.topic < Topic::MotionModel);
    out.extend(sensor_side.into_iter().map(|c| c.text));
    if sensors.iter().any(|s| s.landmarks) {
        out.push(b.landmark_sensor.describe());
    }
    out.extend(filter_side.into_iter().map(|c| c.text));
    out.push("Seeds derive from (study seed, map, replicate), never from the swept value: replicate k of every sweep point and algorithm sees the same world noise (paired comparisons).".into());
    let aligned: Vec<&str> = study
        .maps
        .iter()
        .filter(|(_, m)| {
            m.as_ref().and_then(|m| m.dataset.as_ref()).is_some_and(|d| d.truth_is_positions_only())
        })
        .map(|(n, _)| n.as_str())
        .collect();
    out.push(alignment_sentence(&aligned, study.maps.len()));
    // Map notes, each stated once with the maps it applies to (in spec order).
    let mut notes: Vec<(&str, Vec<&str>)> = Vec::new();
    for (name, map) in &study.maps {
        for note in map.iter().flat_map(|m| &m.map.notes) {
            match notes.iter_mut().find(|(n, _)| *n == note.as_str()) {
                Some((_, maps)) => maps.push(name),
                None => notes.push((note, vec![name])),
            }
        }
    }
    for (note, maps) in notes {
        out.push(format!(
            "{} {}: {note}",
            if maps.len() == 1 { "Map" } else { "Maps" },
            maps.join(", ")
        ));
    }
    out
}

/// How the x axis of a group is laid out, from the values its points take.
fn x_axis(values: &[toml::Value], force_log: bool) -> (XAxis, Vec<f64>, Vec<(f64, String)>) {
    let numeric: Option<Vec<f64>> =
        values.iter().map(|v| ParamValue::from_toml(v).as_f64()).collect();
    match numeric {
        Some(xs) => {
            let positive = xs.iter().all(|&x| x > 0.0);
            let (lo, hi) = xs
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
            // Log axis when asked, or automatically when all values are positive and span ≥ 2 decades.
            let log = positive && (force_log || hi / lo >= 100.0);
            let ticks =
                xs.iter().zip(values).map(|(&x, v)| (x, crate::plan::format_value(v))).collect();
            (if log { XAxis::Log } else { XAxis::Linear }, xs, ticks)
        }
        None => {
            // One position per distinct value (a grid repeats each value once per other value).
            let mut names: Vec<String> = Vec::new();
            for v in values.iter().map(crate::plan::format_value) {
                if !names.contains(&v) {
                    names.push(v);
                }
            }
            let xs = values
                .iter()
                .map(|v| {
                    names.iter().position(|n| *n == crate::plan::format_value(v)).unwrap_or(0)
                        as f64
                })
                .collect();
            let ticks = names.iter().enumerate().map(|(i, n)| (i as f64, n.clone())).collect();
            (XAxis::Categorical(names), xs, ticks)
        }
    }
}

fn slug(s: &str) -> String {
    let mut out = String::new();
    for c in s.chars() {
        if c.is_ascii_alphanumeric() {
            out.push(c.to_ascii_lowercase());
        } else if !out.ends_with('-') {
            out.push('-');
        }
    }
    crate::store::short_name(out.trim_matches('-'))
}

fn group_view(study: &Study<'_>, gi: usize) -> GroupView {
    let spec = study.spec();
    let group = &study.data.resolved.groups[gi];
    let points: Vec<&crate::store::PointRecord> =
        study.data.resolved.points.iter().filter(|p| p.groups.contains(&gi)).collect();
    let title = match (group.kind, group.params.len()) {
        (_, 0) => "Base configuration".to_string(),
        (SweepKind::Zip, _) if group.named => format!("Named cells of {}", group.params.join(", ")),
        (SweepKind::OneAtATime, _) => format!("Varying {} (others at base)", group.params[0]),
        (SweepKind::Grid, _) => format!("Grid over {}", group.params.join(" × ")),
        (SweepKind::Zip, _) => format!("Varying {} together", group.params.join(", ")),
        (SweepKind::Morris | SweepKind::Sobol, _) => {
            unreachable!("design groups have their own section")
        }
    };

    // Table: one row per (map, algorithm, point), metrics as "mean [CI]".
    // The algorithm column only when there is a choice.
    let show_algorithm = spec.algorithms.len() > 1;
    let mut columns = vec!["Map".to_string()];
    if show_algorithm {
        columns.push("Algorithm".into());
    }
    columns.extend(group.params.iter().cloned());
    columns.push("n".into());
    columns.extend(study.metrics.iter().map(|m| format!("{} [{}]", m.title, m.unit)));
    columns.push("Failed".into());
    // Published values beside ours, for the metrics the reference has, when it sweeps this x.
    let x_param = group.params.first();
    let ref_metrics: Vec<&MetricDef> = study
        .metrics
        .iter()
        .copied()
        .filter(|m| {
            x_param.is_some_and(|x| {
                study.data.reference.iter().any(|r| &r.parameter == x && r.metric(m.name).is_some())
            })
        })
        .collect();
    let label = study.reference_label();
    columns.extend(ref_metrics.iter().map(|m| format!("{label}: {}", m.title)));
    let mut agreement: Vec<Tally> = vec![Tally::default(); ref_metrics.len()];
    let mut rows = Vec::new();
    for (map, _) in &study.maps {
        for algorithm in study.algorithms() {
            for p in &points {
                let mut row = vec![map.clone()];
                if show_algorithm {
                    row.push(algorithm.title().to_string());
                }
                row.extend(group.params.iter().map(|k| {
                    study.value_at(p, k).map(|v| crate::plan::format_value(&v)).unwrap_or_default()
                }));
                let mut n_ok = 0;
                let mut failed_text = String::new();
                for (mi, m) in study.metrics.iter().enumerate() {
                    let (s, failed, n) = study.cell(map, algorithm.name(), &p.label, m.name);
                    if mi == 0 {
                        n_ok = s.n;
                        failed_text = format!("{failed}/{n}");
                    }
                    row.push(if s.ci_low.is_finite() {
                        format!(
                            "{} [{}, {}]",
                            sig(s.mean, TABLE_DIGITS),
                            sig(s.ci_low, TABLE_DIGITS),
                            sig(s.ci_high, TABLE_DIGITS)
                        )
                    } else {
                        sig(s.mean, TABLE_DIGITS)
                    });
                }
                row.insert(row.len() - study.metrics.len(), n_ok.to_string());
                row.push(failed_text);
                // The reference ran the study's first algorithm.
                let x = x_param
                    .and_then(|k| study.value_at(p, k))
                    .and_then(|v| ParamValue::from_toml(&v).as_f64());
                let published = x
                    .zip(x_param)
                    .filter(|_| {
                        Some(algorithm.name()) == spec.algorithms.first().map(|a| a.as_str())
                    })
                    .and_then(|(x, k)| study.published(map, k, x));
                for (mi, m) in ref_metrics.iter().enumerate() {
                    row.push(
                        match published.and_then(|(i, r)| r.metric(m.name).map(|v| (i, r, v))) {
                            None => String::new(),
                            Some((index, r, v)) => {
                                let var = r.metric(&format!("{}_var", m.name));
                                let outcome = study.agreement(
                                    index,
                                    m.name,
                                    v,
                                    var,
                                    &study.values(map, algorithm.name(), &p.label, m.name),
                                );
                                agreement[mi].add(outcome);
                                let var =
                                    var.map(|w| format!(" (σ² {})", sig(w, 2))).unwrap_or_default();
                                format!("{}{var}{}", sig(v, TABLE_DIGITS), Tally::mark(outcome))
                            }
                        },
                    );
                }
                rows.push(row);
            }
        }
    }
    let align = format!(
        "{}{}r{}r{}",
        if show_algorithm { "ll" } else { "l" },
        "l".repeat(group.params.len()),
        "r".repeat(study.metrics.len()),
        "r".repeat(ref_metrics.len())
    );
    let table = TableView { columns, rows, align };
    let agreement: Vec<String> = ref_metrics
        .iter()
        .zip(&agreement)
        .filter(|(_, t)| t.judged > 0)
        .map(|(m, t)| format!("{}: {} by {}.", m.title, t.sentence(), study.agreement_rule()))
        .collect();

    let mut figures = Vec::new();
    if let Some(x_param) = group.params.first() {
        let x_values: Vec<toml::Value> = if group.named {
            points.iter().map(|p| toml::Value::String(p.label.clone())).collect()
        } else {
            points.iter().filter_map(|p| study.value_at(p, x_param)).collect()
        };
        if x_values.len() == points.len() {
            let (axis, xs, mut ticks) = x_axis(&x_values, spec.report.log_x.contains(x_param));
            ticks.sort_by(|a, b| a.0.total_cmp(&b.0));
            ticks.dedup_by(|a, b| a.0 == b.0);
            // Series: (map, algorithm) and, for grids, the values of the other parameters.
            let others: Vec<&String> = if group.kind == SweepKind::Grid {
                group.params[1..].iter().collect()
            } else {
                Vec::new()
            };
            for m in &study.metrics {
                let mut series: Vec<LineSeries> = Vec::new();
                // our series take consecutive colours; a published series shares its own's
                let mut ours = 0usize;
                let mut series_map: Vec<String> = Vec::new();
                for (map, _) in &study.maps {
                    for algorithm in study.algorithms() {
                        let mut by_key: BTreeMap<usize, (String, Vec<SeriesPoint>)> =
                            BTreeMap::new();
                        let mut keys: Vec<String> = Vec::new();
                        for (p, &x) in points.iter().zip(&xs) {
                            let other = others
                                .iter()
                                .map(|k| {
                                    format!(
                                        "{k}={}",
                                        study
                                            .value_at(p, k)
                                            .map(|v| crate::plan::format_value(&v))
                                            .unwrap_or_default()
                                    )
                                })
                                .collect::<Vec<_>>()
                                .join(", ");
                            let ki = keys.iter().position(|k| *k == other).unwrap_or_else(|| {
                                keys.push(other.clone());
                                keys.len() - 1
                            });
                            let (s, ..) = study.cell(map, algorithm.name(), &p.label, m.name);
                            let entry =
                                by_key.entry(ki).or_insert_with(|| (other.clone(), Vec::new()));
                            let (lo, hi) = match spec.report.bands {
                                Bands::Ci => (s.ci_low, s.ci_high),
                                // no metric can be negative: the band stops at 0
                                Bands::TwoSigma => {
                                    ((s.mean - 2.0 * s.std).max(0.0), s.mean + 2.0 * s.std)
                                }
                            };
                            entry.1.push(SeriesPoint { x, mean: s.mean, lo, hi });
                        }
                        for (_, (other, mut pts)) in by_key {
                            pts.sort_by(|a, b| a.x.total_cmp(&b.x));
                            let mut label = match (study.maps.len() > 1, spec.algorithms.len() > 1)
                            {
                                (true, true) => format!("{map} / {}", algorithm.title()),
                                (false, true) => algorithm.title().to_string(),
                                _ => map.clone(),
                            };
                            if !other.is_empty() {
                                label = format!("{label} ({other})");
                            }
                            series.push(LineSeries {
                                label,
                                color: ours,
                                points: pts,
                                dashed: false,
                                scatter: false,
                            });
                            series_map.push(map.clone());
                            ours += 1;
                        }
                        // Named cells: the published values of this (map, algorithm), dashed, in its colour.
                        if group.named {
                            let pts: Vec<SeriesPoint> = points
                                .iter()
                                .zip(&xs)
                                .filter_map(|(p, &x)| {
                                    study
                                        .published_cell(map, algorithm.name(), &p.label, m.name)
                                        .map(|(_, v, _)| SeriesPoint {
                                            x,
                                            mean: v,
                                            lo: f64::NAN,
                                            hi: f64::NAN,
                                        })
                                })
                                .collect();
                            if !pts.is_empty() {
                                let color = ours.saturating_sub(1);
                                let label = match (study.maps.len() > 1, spec.algorithms.len() > 1)
                                {
                                    (true, true) => format!(
                                        "{map} / {} ({})",
                                        algorithm.title(),
                                        study.reference_label()
                                    ),
                                    (false, true) => format!(
                                        "{} ({})",
                                        algorithm.title(),
                                        study.reference_label()
                                    ),
                                    _ => format!("{map} ({})", study.reference_label()),
                                };
                                series.push(LineSeries {
                                    label,
                                    color,
                                    points: pts,
                                    dashed: true,
                                    scatter: false,
                                });
                                series_map.push(map.clone());
                            }
                        }
                    }
                }
                // Published values: dashed, in the colour of the map's (first algorithm's) series.
                if let Some(x_param) = group.params.first().filter(|_| !group.named) {
                    for (mi, (map, _)) in study.maps.iter().enumerate() {
                        let color = mi * spec.algorithms.len();
                        let pts: Vec<SeriesPoint> = points
                            .iter()
                            .zip(&xs)
                            .filter_map(|(p, &x)| {
                                let v = study
                                    .value_at(p, x_param)
                                    .and_then(|v| ParamValue::from_toml(&v).as_f64())?;
                                let (_, row) = study.published(map, x_param, v)?;
                                let published = row.metric(m.name)?;
                                let (lo, hi) = study.published_bars(
                                    published,
                                    row.metric(&format!("{}_var", m.name)),
                                );
                                Some(SeriesPoint { x, mean: published, lo, hi })
                            })
                            .collect();
                        if !pts.is_empty() {
                            let mut pts = pts;
                            pts.sort_by(|a, b| a.x.total_cmp(&b.x));
                            series.push(LineSeries {
                                label: format!("{map} ({})", study.reference_label()),
                                color,
                                points: pts,
                                dashed: true,
                                scatter: false,
                            });
                            series_map.push(map.clone());
                        }
                    }
                }
                let x_label = if group.named {
                    "cell".to_string()
                } else if group.kind == SweepKind::Zip {
                    group.params.join(" / ")
                } else {
                    x_param.clone()
                };
                let published_bars =
                    series.iter().any(|s| s.dashed && s.points.iter().any(|p| p.lo.is_finite()));
                let fig = LineFigure {
                    x_label,
                    y_label: format!("{} [{}]", m.title, m.unit),
                    x_axis: axis.clone(),
                    x_ticks: ticks.clone(),
                    series,
                };
                let file = slug(&format!("{}--{}", group.params.join("-"), m.name));
                let band = match spec.report.bands {
                    Bands::Ci => format!("band = {:.0} % confidence interval of the mean (Student t, cut at 0: no metric can be negative)", stats::CONFIDENCE * 100.0),
                    Bands::TwoSigma => "band = mean ± 2 sample standard deviations over the replicates (the spread of single runs, as the reference work's figures draw it; not a confidence interval)".to_string(),
                };
                let bars = if published_bars {
                    format!(
                        "; dashed: published means with error bars = 95 % confidence interval of the published mean over its {} runs, from its printed variance",
                        study.published_runs()
                    )
                } else if fig.series.iter().any(|s| s.dashed) {
                    "; dashed: published values (no dispersion printed)".to_string()
                } else {
                    String::new()
                };
                let caption = format!(
                    "{} against {}: mean over the n successful replicates of each cell, {band}{bars}.",
                    m.title,
                    if group.named { "the named cell" } else { x_param.as_str() },
                );
                // Three or more maps with published series: one panel per map (small multiples),
                // each with its own published series, instead of every curve in one.
                if study.maps.len() >= SMALL_MULTIPLES_MAPS && fig.series.iter().any(|s| s.dashed) {
                    for (k, (map, _)) in study.maps.iter().enumerate() {
                        let series: Vec<LineSeries> = fig
                            .series
                            .iter()
                            .zip(&series_map)
                            .filter(|(_, m)| *m == map)
                            .map(|(s, _)| s.clone())
                            .collect();
                        if series.is_empty() {
                            continue;
                        }
                        let panel = LineFigure { series, ..fig.clone() };
                        figures.push(FigureView {
                            panel: true,
                            caption: if k == 0 { format!("{map} — {caption} One panel per map, each with its own published series and its own y scale.") } else { format!("{map} — as the first panel.") },
                            svg: figure::line_svg(&panel),
                            pgf: super::pgf::line_pgf(&panel),
                            file: slug(&format!("{file}--{map}")),
                        });
                    }
                    continue;
                }
                let zoom = zoomed(&fig);
                figures.push(FigureView {
                    panel: false,
                    caption,
                    svg: figure::line_svg(&fig),
                    pgf: super::pgf::line_pgf(&fig),
                    file: file.clone(),
                });
                // a baseline far above the rest squashes them: the same figure again without it
                if let Some((zoomed, label, top)) = zoom {
                    figures.push(FigureView {
                        panel: false,
                        caption: format!("{} against {}, without {label} (up to {}), whose values squash the others in the figure above.", m.title, if group.named { "the named cell" } else { x_param.as_str() }, sig(top, 3)),
                        svg: figure::line_svg(&zoomed),
                        pgf: super::pgf::line_pgf(&zoomed),
                        file: format!("{file}--zoom"),
                    });
                }
            }
        }
    }
    let matrices = if group.named { cell_matrices(study, &points) } else { Vec::new() };
    if group.named && spec.algorithms.len() > 1 {
        figures.extend(cost_figure(study, &points, &slug(&group.params.join("-"))));
    }
    GroupView {
        title,
        label_columns: if show_algorithm { 2 } else { 1 },
        figures,
        table,
        agreement,
        matrices,
    }
}

/// How far above every other series a baseline must reach before it gets a figure without it.
const SQUASH_RATIO: f64 = 5.0;

/// `fig` without its dominant series (ours and its published one share a colour) when that
/// series' largest value is more than [`SQUASH_RATIO`] times every other series' and at least
/// two other series remain: (the figure, the removed series' label, its largest value).
fn zoomed(fig: &LineFigure) -> Option<(LineFigure, String, f64)> {
    let top = |s: &LineSeries| {
        s.points.iter().map(|p| p.mean).filter(|v| v.is_finite()).fold(f64::NEG_INFINITY, f64::max)
    };
    let mut by_color: BTreeMap<usize, f64> = BTreeMap::new();
    for s in &fig.series {
        let e = by_color.entry(s.color).or_insert(f64::NEG_INFINITY);
        *e = e.max(top(s));
    }
    if by_color.len() < 3 {
        return None;
    }
    let (&color, &max) = by_color.iter().max_by(|a, b| a.1.total_cmp(b.1))?;
    let rest = by_color
        .iter()
        .filter(|(c, _)| **c != color)
        .map(|(_, v)| *v)
        .fold(f64::NEG_INFINITY, f64::max);
    if !(rest > 0.0 && max > SQUASH_RATIO * rest) {
        return None;
    }
    let label = fig
        .series
        .iter()
        .find(|s| s.color == color && !s.dashed)
        .map_or_else(String::new, |s| s.label.clone());
    let series = fig.series.iter().filter(|s| s.color != color).cloned().collect();
    Some((LineFigure { series, ..fig.clone() }, label, max))
}

/// Named cells: per metric, a table with one row per (map, algorithm) and one column per cell —
/// ours as mean ± half-width of the 95 % CI, and under it the published value when the reference
/// has one ([EP] Tables 2–5).
fn cell_matrices(study: &Study<'_>, points: &[&crate::store::PointRecord]) -> Vec<NamedTable> {
    let label = study.reference_label();
    let mut out = Vec::new();
    for m in &study.metrics {
        let mut columns = vec!["Map".to_string(), "Algorithm".to_string()];
        columns.extend(points.iter().map(|p| p.label.clone()));
        let mut rows = Vec::new();
        let mut agreement = Tally::default();
        for (map, _) in &study.maps {
            for algorithm in study.algorithms() {
                let mut ours = vec![map.clone(), algorithm.title().to_string()];
                let mut published = vec![String::new(), String::new()];
                let mut tables: Vec<&str> = Vec::new();
                for p in points {
                    let (s, ..) = study.cell(map, algorithm.name(), &p.label, m.name);
                    // the t interval's half-width (its lower end may be cut at 0)
                    let hw = s.ci_high - s.mean;
                    ours.push(if hw.is_finite() {
                        format!("{} ± {}", sig(s.mean, TABLE_DIGITS), sig(hw, 2))
                    } else {
                        sig(s.mean, TABLE_DIGITS)
                    });
                    match study.published_cell(map, algorithm.name(), &p.label, m.name) {
                        Some((index, v, table)) => {
                            let outcome = study.agreement(
                                index,
                                m.name,
                                v,
                                None,
                                &study.values(map, algorithm.name(), &p.label, m.name),
                            );
                            agreement.add(outcome);
                            published.push(format!(
                                "{}{}",
                                sig(v, TABLE_DIGITS),
                                Tally::mark(outcome)
                            ));
                            if !tables.contains(&table) {
                                tables.push(table);
                            }
                        }
                        None => published.push(String::new()),
                    }
                }
                rows.push(ours);
                if tables.is_empty() {
                    continue;
                }
                published[1] = format!("{label} Table {}", tables.join("/"));
                rows.push(published);
            }
        }
        let caption = if agreement.judged > 0 {
            format!(
                "Ours: mean ± half-width of the 95 % confidence interval over the replicates; under it the published value. {} by {}.",
                agreement.sentence(),
                study.agreement_rule()
            )
        } else {
            "Mean ± half-width of the 95 % confidence interval over the replicates.".to_string()
        };
        out.push(NamedTable {
            title: format!("{} [{}] per cell", m.title, m.unit),
            caption,
            table: TableView { columns, rows, align: format!("ll{}", "r".repeat(points.len())) },
        });
    }
    out
}

/// Cost against accuracy across the algorithms ([EP] Table 3's time/f trade-off): mean f against
/// mean objective evaluations per match (log x), one point per (map, algorithm, cell). Evaluations
/// stand in for time, which is not deterministic (times are measured by `make bench`).
fn cost_figure(
    study: &Study<'_>,
    points: &[&crate::store::PointRecord],
    group_slug: &str,
) -> Option<FigureView> {
    let mut series = Vec::new();
    let mut all_x = Vec::new();
    for (map, _) in &study.maps {
        for algorithm in study.algorithms() {
            let mut pts: Vec<SeriesPoint> = points
                .iter()
                .filter_map(|p| {
                    let (e, ..) = study.cell(map, algorithm.name(), &p.label, "evals_mean");
                    let (f, ..) = study.cell(map, algorithm.name(), &p.label, "f_mean");
                    (e.mean > 0.0 && e.mean.is_finite() && f.mean.is_finite()).then_some(
                        SeriesPoint { x: e.mean, mean: f.mean, lo: f64::NAN, hi: f64::NAN },
                    )
                })
                .collect();
            if pts.is_empty() {
                continue;
            }
            pts.sort_by(|a, b| a.x.total_cmp(&b.x));
            all_x.extend(pts.iter().map(|p| p.x));
            let label = if study.maps.len() > 1 {
                format!("{map} / {}", algorithm.title())
            } else {
                algorithm.title().to_string()
            };
            series.push(LineSeries {
                label,
                color: series.len(),
                points: pts,
                dashed: false,
                scatter: true,
            });
        }
    }
    if series.is_empty() {
        return None;
    }
    let (lo, hi) =
        all_x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x), b.max(x)));
    let ticks: Vec<(f64, String)> = (lo.log10().floor() as i32..=hi.log10().ceil() as i32)
        .map(|e| (10f64.powi(e), sig(10f64.powi(e), 1)))
        .collect();
    let fig = LineFigure {
        x_label: "objective evaluations per match".into(),
        y_label: "Mean f [cm²]".into(),
        x_axis: XAxis::Log,
        x_ticks: ticks,
        series,
    };
    Some(FigureView {
        panel: false,
        file: format!("{group_slug}--cost"),
        caption: "Accuracy against cost: mean final f against mean objective evaluations per match, one point per cell of each algorithm. Evaluations stand in for time, which is not deterministic (per-match times are measured by make bench and listed in the book, docs/src/development/benchmarks.md).".into(),
        svg: figure::line_svg(&fig),
        pgf: super::pgf::line_pgf(&fig),
    })
}

/// One figure per map: truth and every algorithm's estimate for a representative replicate.
fn trajectory_views(study: &Study<'_>, traces: &Fetch<'_>) -> Vec<FigureView> {
    let spec = study.spec();
    let points = &study.data.resolved.points;
    let Some(reference) = crate::store::select::reference_point(points, &study.base) else {
        return Vec::new();
    };
    let headline = crate::store::select::headline(spec);
    let Some(first_algorithm) = study.algorithms().next() else { return Vec::new() };

    let mut out = Vec::new();
    for (map_name, scenario) in &study.maps {
        let Some(scenario) = scenario else { continue };
        let map = &scenario.map;
        let Some(chosen) = crate::store::select::median_run(
            &study.data.runs,
            map_name,
            first_algorithm.name(),
            &reference.label,
            headline,
        ) else {
            continue;
        };
        let ids: Vec<String> = study
            .algorithms()
            .filter_map(|a| {
                study
                    .runs_of(map_name, a.name(), &reference.label)
                    .find(|r| r.replicate == chosen.replicate)
                    .map(|r| r.run_id.clone())
            })
            .collect();
        let (rows, maps, matches) = traces(&ids, Parts::ALL);
        let Some(truth) = rows.first() else { continue };
        // Real data may lack truth at some steps: the path joins the known positions.
        let finite = |p: &&crate::geom::Pose2| p.x.is_finite() && p.y.is_finite();
        let mut paths = vec![PathSeries {
            label: "ground truth".into(),
            color: None,
            points: truth.truth.iter().filter(finite).map(|p| (p.x, p.y)).collect(),
        }];
        for (ai, id) in ids.iter().enumerate() {
            if let Some(t) = rows.iter().find(|t| &t.run_id == id) {
                let label = study
                    .algorithms()
                    .find(|a| id.contains(&format!("--{}--", a.name())))
                    .map_or(id.clone(), |a| a.title().to_string());
                paths.push(PathSeries {
                    label,
                    color: Some(ai),
                    points: t.estimate.iter().filter(finite).map(|p| (p.x, p.y)).collect(),
                });
            }
        }
        // Final maps, coloured like their algorithm's path.
        let (mut est_corners, mut est_lines) = (Vec::new(), Vec::new());
        for (ai, id) in ids.iter().enumerate() {
            for l in maps.iter().filter(|m| &m.run_id == id).flat_map(|m| &m.landmarks) {
                match *l {
                    LandmarkRow::Corner { x_m, y_m } | LandmarkRow::Point { x_m, y_m, .. } => {
                        est_corners.push((ai, (x_m, y_m)))
                    }
                    LandmarkRow::Line { rho_m, theta_rad } => {
                        est_lines.push((ai, rho_m, theta_rad))
                    }
                }
            }
        }
        let points_world = scenario.world_kind() == crate::world::WorldKind::Points;
        let fig = TrajectoryFigure {
            walls: map.walls.iter().map(|s| ((s.a.x, s.a.y), (s.b.x, s.b.y))).collect(),
            // a point world's landmarks are its points; its wall corners are not landmarks
            corners: if points_world {
                map.point_landmarks.iter().map(|c| (c.x, c.y)).collect()
            } else {
                map.corners.iter().map(|c| (c.x, c.y)).collect()
            },
            point_landmarks: points_world,
            paths,
            // the true start pose (a dataset's first truth pose; the map's start for a simulation)
            start: truth
                .truth
                .first()
                .filter(|p| p.x.is_finite() && p.y.is_finite())
                .map_or((map.start.x, map.start.y), |p| (p.x, p.y)),
            est_corners,
            est_lines,
        };
        let value = chosen.metric(headline).map_or("—".into(), |v| sig(v, TABLE_DIGITS));
        out.push(FigureView {
            panel: false,
            file: slug(&format!("trajectory--{map_name}")),
            caption: format!(
                "{} ({map_name}): ground truth and estimates of replicate {} at {} — the median replicate by {headline} ({value}) of {}. Triangle: start; red dots: {}; ×{}: the final maps of the algorithms that build one.",
                map.title,
                chosen.replicate,
                reference.label,
                first_algorithm.title(),
                if points_world { "true landmarks" } else { "true corners" },
                if points_world { "" } else { ", dashed lines" }
            ),
            svg: figure::trajectory_svg(&fig),
            pgf: super::pgf::trajectory_pgf(&fig),
        });
        out.extend(match_error_views(
            study,
            map_name,
            &map.title,
            &ids,
            &matches,
            chosen.replicate,
            &reference.label,
        ));
    }
    out
}

/// How the trajectory error was computed: without alignment, except on `aligned` maps (truth =
/// positions in their own frame), where the estimate is first aligned rigidly, as evo's `--align`.
fn alignment_sentence(aligned: &[&str], maps: usize) -> String {
    const APE: &str = "Trajectory error is evo's APE (translation part, every step";
    match aligned.len() {
        0 => format!("{APE}, no alignment: estimate and truth start at the same pose)."),
        n if n == maps => format!(
            "{APE}) after aligning the estimate to the truth by the least-squares rigid transform (evo's --align, no scale): the truth of {} is positions only, in its own frame.",
            aligned.join(", ")
        ),
        _ => format!(
            "{APE}): on {}, whose truth is positions only in its own frame, after aligning the estimate by the least-squares rigid transform (evo's --align, no scale); on the other maps with no alignment (estimate and truth start at the same pose).",
            aligned.join(", ")
        ),
    }
}

/// [EP] Figs 16–19: every match's error, in match order, for each scan matcher of the runs `ids`
/// (one figure per component |ax|, |ay|, |aθ|). Empty when no run has matches.
fn match_error_views(
    study: &Study<'_>,
    map_name: &str,
    map_title: &str,
    ids: &[String],
    matches: &[MatchRows],
    replicate: u32,
    cell: &str,
) -> Vec<FigureView> {
    let spec = study.spec();
    let per_run: Vec<(usize, &MatchRows)> = ids
        .iter()
        .filter_map(|id| {
            let ai = spec.algorithms.iter().position(|a| id.contains(&format!("--{a}--")))?;
            matches.iter().find(|m| &m.run_id == id && !m.matches.is_empty()).map(|m| (ai, m))
        })
        .collect();
    if per_run.is_empty() {
        return Vec::new();
    }
    type Component = fn(&crate::trace::MatchRecord) -> f64;
    let components: [(&str, &str, Component); 3] = [
        ("ax", "|ax| [mm]", |m| m.error().0.abs() * 1e3),
        ("ay", "|ay| [mm]", |m| m.error().1.abs() * 1e3),
        ("atheta", "|aθ| [deg]", |m| m.error().2.abs().to_degrees()),
    ];
    components
        .iter()
        .map(|(key, label, value)| {
            let series = per_run
                .iter()
                .map(|(ai, rows)| LineSeries {
                    label: study.catalogue.algorithm(&spec.algorithms[*ai]).title().to_string(),
                    color: *ai,
                    points: rows
                        .matches
                        .iter()
                        .enumerate()
                        .map(|(k, m)| {
                            let v = value(m);
                            SeriesPoint { x: (k + 1) as f64, mean: v, lo: v, hi: v }
                        })
                        .collect(),
                    dashed: false,
                    scatter: false,
                })
                .collect();
            let fig = LineFigure { x_label: "match".into(), y_label: label.to_string(), x_axis: XAxis::Linear, x_ticks: Vec::new(), series };
            FigureView {
                panel: false,
                file: slug(&format!("match-errors-{key}--{map_name}")),
                caption: format!(
                    "{map_title} ({map_name}): {label} of every match of replicate {replicate} at {cell}, in match order, for each scan matcher ([EP] Figs 16–19 plot E-PSM's on the rectangular map at 10 % odometry). A failed match keeps the pose it returned (PSM: its initial guess)."
                ),
                svg: figure::line_svg(&fig),
                pgf: super::pgf::line_pgf(&fig),
            }
        })
        .collect()
}

/// The spread of |aθ| over the matches of each (map, scan matcher, cell), all replicates pooled:
/// a mean can hide that most matches are exact and a few are far off.
fn match_distribution(study: &Study<'_>, traces: &Fetch<'_>) -> Vec<NamedTable> {
    if !study.algorithms().any(|a| a.is_scan_matcher()) {
        return Vec::new();
    }
    let ids: Vec<String> = study
        .data
        .runs
        .iter()
        .filter(|r| r.status == RunStatus::Ok)
        .map(|r| r.run_id.clone())
        .collect();
    let (_, _, matches) = traces(&ids, Parts::MATCHES);
    let by_run: BTreeMap<&str, &MatchRows> =
        matches.iter().map(|m| (m.run_id.as_str(), m)).collect();
    let mut out = Vec::new();
    for (map, _) in &study.maps {
        let mut rows = Vec::new();
        for algorithm in study.algorithms().filter(|a| a.is_scan_matcher()) {
            for point in &study.data.resolved.points {
                let mut errors: Vec<f64> = study
                    .runs_of(map, algorithm.name(), &point.label)
                    .filter_map(|r| by_run.get(r.run_id.as_str()))
                    .flat_map(|m| m.matches.iter().map(|k| k.error().2.abs().to_degrees()))
                    .collect();
                if errors.is_empty() {
                    continue;
                }
                errors.sort_by(f64::total_cmp);
                let q = |p: f64| errors[((errors.len() - 1) as f64 * p).round() as usize];
                let total: f64 = errors.iter().filter(|e| e.is_finite()).sum();
                let far: Vec<f64> = errors.iter().copied().filter(|e| *e > 1.0).collect();
                rows.push(vec![
                    algorithm.title().to_string(),
                    point.label.clone(),
                    errors.len().to_string(),
                    sig(q(0.5), 2),
                    sig(q(0.9), 2),
                    sig(errors[errors.len() - 1], 2),
                    format!("{} %", sig(100.0 * far.len() as f64 / errors.len() as f64, 2)),
                    if total > 0.0 {
                        format!(
                            "{} %",
                            sig(
                                100.0 * far.iter().filter(|e| e.is_finite()).sum::<f64>() / total,
                                2
                            )
                        )
                    } else {
                        "—".into()
                    },
                ]);
            }
        }
        if rows.is_empty() {
            continue;
        }
        out.push(NamedTable {
            title: format!("Heading error per match: {map}"),
            caption: "The distribution of |aθ| [deg] over every match of a cell (all replicates pooled): its median, 90th percentile and maximum, the share of matches more than 1° off, and the share of the cell's summed |aθ| — of its mean — that those matches carry. A mean far above the median is carried by a few matches.".into(),
            table: TableView {
                columns: ["Algorithm", "Cell", "Matches", "Median", "90th pct", "Max", "> 1°", "Share of the mean"].map(String::from).to_vec(),
                rows,
                align: "llrrrrrr".into(),
            },
        });
    }
    out
}

/// [EV]-style per-landmark tables: for each published table, our mean estimate of every true
/// landmark (the map landmark created from it, known association) at that sweep point, over the
/// replicates, with the error true − estimated in cm, beside the published error.
fn landmark_tables(study: &Study<'_>, traces: &Fetch<'_>) -> Vec<NamedTable> {
    let spec = study.spec();
    let Some(algorithm) = study.algorithms().next() else { return Vec::new() };
    let mut out = Vec::new();
    // each published table's sweep point, resolved by the plan
    for (reference, label) in
        spec.report.landmark_reference.iter().zip(&study.data.resolved.landmark_points)
    {
        let Some(point) = study.data.resolved.points.iter().find(|p| &p.label == label) else {
            continue;
        };
        for (map_name, map) in &study.maps {
            let Some(map) = map.as_ref().map(|s| &s.map) else { continue };
            let ids: Vec<String> = study
                .runs_of(map_name, algorithm.name(), &point.label)
                .filter(|r| r.status == RunStatus::Ok)
                .map(|r| r.run_id.clone())
                .collect();
            if ids.is_empty() || map.point_landmarks.is_empty() {
                continue;
            }
            let (_, maps, _) = traces(&ids, Parts::LANDMARKS);
            let cm =
                |v: f64| if v.is_finite() { format!("{:.1}", v * 100.0) } else { "—".into() };
            let rows = map
                .point_landmarks
                .iter()
                .enumerate()
                .map(|(i, truth)| {
                    let estimates: Vec<(f64, f64)> = maps
                        .iter()
                        .filter_map(|m| {
                            m.landmarks.iter().find_map(|l| match *l {
                                LandmarkRow::Point { x_m, y_m, id: Some(id) }
                                    if id as usize == i =>
                                {
                                    Some((x_m, y_m))
                                }
                                _ => None,
                            })
                        })
                        .collect();
                    let n = estimates.len() as f64;
                    let (ex, ey) = if estimates.is_empty() {
                        (f64::NAN, f64::NAN)
                    } else {
                        (
                            estimates.iter().map(|e| e.0).sum::<f64>() / n,
                            estimates.iter().map(|e| e.1).sum::<f64>() / n,
                        )
                    };
                    let rms = if estimates.is_empty() {
                        f64::NAN
                    } else {
                        (estimates
                            .iter()
                            .map(|e| (e.0 - truth.x).powi(2) + (e.1 - truth.y).powi(2))
                            .sum::<f64>()
                            / n)
                            .sqrt()
                    };
                    let published = reference
                        .landmarks
                        .iter()
                        .find(|l| (l[0] - truth.x).hypot(l[1] - truth.y) < LANDMARK_MATCH_M);
                    vec![
                        format!("{}", i + 1),
                        cm(truth.x),
                        cm(ex),
                        cm(truth.x - ex),
                        cm(truth.y),
                        cm(ey),
                        cm(truth.y - ey),
                        format!("{}/{}", estimates.len(), ids.len()),
                        cm(rms),
                        published.map_or("—".into(), |l| cm(l[2])),
                        published.map_or("—".into(), |l| cm(l[3])),
                        published.map_or("—".into(), |l| cm(l[2].hypot(l[3]))),
                    ]
                })
                .collect();
            out.push(NamedTable {
                title: format!("{} — {} ({}), {}", reference.label, algorithm.title(), map.title, point.label),
                caption: format!(
                    "Per landmark, in cm: true position, our estimate (mean over the replicates that mapped it, k/n), its error true − estimated (the bias over the replicates) and the RMS distance of the replicates' estimates (the typical error of one run), beside {}'s errors of its one real run and their Euclidean size. Landmarks are numbered in the map's order.",
                    reference.label
                ),
                table: TableView {
                    columns: ["Landmark", "X true", "X est.", "Error X", "Y true", "Y est.", "Error Y", "Mapped", "RMS error", "Published error X", "Published error Y", "Published error"].iter().map(|c| c.to_string()).collect(),
                    rows,
                    align: "rrrrrrrrrrrr".into(),
                },
            });
        }
    }
    out
}

/// `[[report.contrasts]]`: per contrast, metric and algorithm, one row per pair `cell − against`
/// and one column per map: the mean paired difference over the replicates both cells have, its
/// 95 % t interval, and the difference relative to the `against` cell's mean.
fn contrast_tables(study: &Study<'_>) -> Vec<NamedTable> {
    let spec = study.spec();
    let mut out = Vec::new();
    for c in &spec.report.contrasts {
        let metrics: Vec<&str> = if c.metrics.is_empty() {
            spec.report.metrics.iter().map(String::as_str).collect()
        } else {
            c.metrics.iter().map(String::as_str).collect()
        };
        for metric in metrics {
            let Some(def) = metric_def(metric) else { continue };
            for algorithm in study.algorithms() {
                let rows = c
                    .pairs
                    .iter()
                    .map(|[cell, against]| {
                        let mut row = vec![format!("{cell} − {against}")];
                        for (map, _) in &study.maps {
                            let a =
                                study.data.replicate_values(map, algorithm.name(), cell, metric);
                            let b =
                                study.data.replicate_values(map, algorithm.name(), against, metric);
                            row.push(contrast_entry(&stats::compare::paired_contrast(
                                &a, &b, 0.95,
                            )));
                        }
                        row
                    })
                    .collect();
                let algorithm_title = if spec.algorithms.len() > 1 {
                    format!(" — {}", algorithm.title())
                } else {
                    String::new()
                };
                out.push(NamedTable {
                    title: format!("{}: {} [{}]{algorithm_title}", c.title, def.title, def.unit),
                    caption: format!(
                        "{}{}Each entry: mean paired difference over the replicates both cells ran (replicate k of both sees the same world), its 95 % t interval, and the difference relative to the second cell's mean; — where fewer than two pairs or a non-finite value.",
                        c.caption,
                        if c.caption.is_empty() { "" } else { " " }
                    ),
                    table: TableView {
                        columns: std::iter::once("Cells".to_string()).chain(study.maps.iter().map(|(m, _)| m.clone())).collect(),
                        rows,
                        align: format!("l{}", "r".repeat(study.maps.len())),
                    },
                });
            }
        }
    }
    out
}

/// "+0.052 [+0.031, +0.073] (+21 %)": the mean paired difference, its interval and the change
/// relative to the compared cell; "—" where it has no interval.
fn contrast_entry(c: &stats::compare::PairedContrast) -> String {
    let (lo, hi) = c.ci;
    if lo.is_nan() {
        return "—".into();
    }
    let signed = |v: f64| if v > 0.0 { format!("+{}", sig(v, 2)) } else { sig(v, 2) };
    let rel = match (100.0 * c.mean / c.against_mean).round() {
        p if !p.is_finite() => String::new(),
        p if p == 0.0 => " (0 %)".to_string(),
        p if p > 0.0 => format!(" (+{p} %)"),
        p => format!(" (−{} %)", -p),
    };
    format!("{} [{}, {}]{rel}", signed(c.mean), signed(lo), signed(hi))
}

/// A published landmark is matched to a true one within this distance [m] (the tables give whole
/// centimetres).
const LANDMARK_MATCH_M: f64 = 0.02;

/// How a table's published cells came out against ours.
#[derive(Debug, Clone, Copy, Default)]
struct Tally {
    judged: usize,
    equivalent: usize,
    different: usize,
}

impl Tally {
    fn add(&mut self, outcome: Option<Outcome>) {
        if let Some(o) = outcome {
            self.judged += 1;
            self.equivalent += (o == Outcome::Equivalent) as usize;
            self.different += (o == Outcome::Different) as usize;
        }
    }
    /// The mark after a published value: ≠ shown different, ? unresolved.
    fn mark(outcome: Option<Outcome>) -> &'static str {
        match outcome {
            Some(Outcome::Different) => " ≠",
            Some(Outcome::Unresolved) => " ?",
            _ => "",
        }
    }
    fn sentence(&self) -> String {
        format!(
            "Of {} cells, {} are shown equivalent to the published value, {} shown different (≠) and {} unresolved (?)",
            self.judged,
            self.equivalent,
            self.different,
            self.judged - self.equivalent - self.different
        )
    }
}

fn failures_table(data: &StudyData) -> TableView {
    TableView {
        columns: vec!["Run".into(), "Status".into(), "Error".into()],
        rows: data
            .runs
            .iter()
            .filter(|r| r.status != RunStatus::Ok)
            .map(|r| {
                vec![
                    r.run_id.clone(),
                    r.status.as_str().into(),
                    r.error.clone().unwrap_or_default(),
                ]
            })
            .collect(),
        align: "llp{0.5\\linewidth}".into(),
    }
}

fn provenance(data: &StudyData) -> Vec<Kv> {
    let m = &data.manifest;
    let mut out = vec![
        kv("slamlab version", &m.crate_version),
        kv(
            "git commit (inputs)",
            format!("{}{}", m.git_commit, if m.git_dirty { " + uncommitted changes" } else { "" }),
        ),
        kv("rustc", &m.rustc),
        kv(
            "spec",
            format!("{} (blake3 {})", m.spec_path, &m.spec_blake3[..m.spec_blake3.len().min(16)]),
        ),
        kv("results schema", &m.schema_version),
    ];
    out.extend(m.code_versions.iter().map(|(k, v)| kv(&format!("code version: {k}"), v)));
    out.extend(
        m.maps
            .iter()
            .map(|(k, v)| kv(&format!("map {k}"), format!("blake3 {}", &v[..v.len().min(16)]))),
    );
    out
}

/// `summary.csv`: one row per (map, algorithm, point, metric) with n, mean, sd and CI.
fn summary_csv(study: &Study<'_>) -> String {
    let spec = study.spec();
    let swept: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for g in &study.data.resolved.groups {
            for p in &g.params {
                if !v.contains(p) {
                    v.push(p.clone());
                }
            }
        }
        v
    };
    let mut out = String::from("study,map,algorithm,point");
    for p in &swept {
        out.push(',');
        out.push_str(&csv_field(p));
    }
    out.push_str(",metric,n,failed,runs,mean,sd,ci95_low,ci95_high,median,min,max\n");
    for (map, _) in &study.maps {
        for algorithm in study.algorithms() {
            for p in &study.data.resolved.points {
                for m in &study.metrics {
                    let (s, failed, n) = study.cell(map, algorithm.name(), &p.label, m.name);
                    let mut fields = vec![
                        spec.id.clone(),
                        map.clone(),
                        algorithm.name().to_string(),
                        p.label.clone(),
                    ];
                    fields.extend(swept.iter().map(|k| {
                        study
                            .value_at(p, k)
                            .map(|v| crate::plan::format_value(&v))
                            .unwrap_or_default()
                    }));
                    fields.extend([
                        m.name.to_string(),
                        s.n.to_string(),
                        failed.to_string(),
                        n.to_string(),
                    ]);
                    fields.extend(
                        [s.mean, s.std, s.ci_low, s.ci_high, s.median, s.min, s.max]
                            .map(|v| sig_ascii(v, CSV_DIGITS)),
                    );
                    out.push_str(
                        &fields.iter().map(|f| csv_field(f)).collect::<Vec<_>>().join(","),
                    );
                    out.push('\n');
                }
            }
        }
    }
    out
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axis_only_for_positive_wide_ranges() {
        let f = |v: &[f64]| {
            x_axis(&v.iter().map(|&x| toml::Value::Float(x)).collect::<Vec<_>>(), false).0
        };
        assert_eq!(f(&[0.001, 0.01, 0.1]), XAxis::Log);
        assert_eq!(f(&[0.0, 0.05, 0.1]), XAxis::Linear);
        assert_eq!(f(&[1.0, 2.0, 5.0]), XAxis::Linear);
        let cat = x_axis(
            &[toml::Value::String("pose".into()), toml::Value::String("none".into())],
            false,
        )
        .0;
        assert_eq!(cat, XAxis::Categorical(vec!["pose".into(), "none".into()]));
        // a grid repeats values: positions follow the distinct values
        let s = |v: &str| toml::Value::String(v.into());
        let (axis, xs, ticks) = x_axis(&[s("std"), s("std"), s("variance"), s("variance")], false);
        assert_eq!(axis, XAxis::Categorical(vec!["std".into(), "variance".into()]));
        assert_eq!(xs, vec![0.0, 0.0, 1.0, 1.0]);
        assert_eq!(ticks.len(), 2);
    }

    #[test]
    fn a_squashing_baseline_gets_a_figure_without_it() {
        let series = |label: &str, color: usize, v: f64, dashed: bool| LineSeries {
            label: label.into(),
            color,
            points: vec![SeriesPoint { x: 1.0, mean: v, lo: v, hi: v }],
            dashed,
            scatter: false,
        };
        let fig = |s: Vec<LineSeries>| LineFigure {
            x_label: "x".into(),
            y_label: "y".into(),
            x_axis: XAxis::Linear,
            x_ticks: Vec::new(),
            series: s,
        };
        // PSM (and its published series) at 95, the others at most 15: a zoom without PSM
        let f = fig(vec![
            series("PSM", 0, 95.0, false),
            series("PSM (pub)", 0, 40.0, true),
            series("E-PSM", 1, 2.0, false),
            series("CRS2", 2, 15.0, false),
        ]);
        let (z, label, top) = zoomed(&f).expect("PSM squashes the others");
        assert_eq!((label.as_str(), top), ("PSM", 95.0));
        assert_eq!(
            z.series.iter().map(|s| s.label.as_str()).collect::<Vec<_>>(),
            ["E-PSM", "CRS2"]
        );
        // within the ratio, or fewer than three groups: no zoom
        assert!(
            zoomed(&fig(vec![
                series("A", 0, 90.0, false),
                series("B", 1, 20.0, false),
                series("C", 2, 5.0, false)
            ]))
            .is_none()
        );
        assert!(
            zoomed(&fig(vec![series("A", 0, 900.0, false), series("B", 1, 2.0, false)])).is_none()
        );
    }

    #[test]
    fn slugs_are_file_safe() {
        assert_eq!(slug("odometry.k--ate_rmse_m"), "odometry-k-ate-rmse-m");
        assert_eq!(slug("trajectory--Big Loop"), "trajectory-big-loop");
        // the alignment the metrics used is the one the report states
        assert!(alignment_sentence(&[], 2).contains("no alignment"));
        let all = alignment_sentence(&["victoria_park"], 1);
        assert!(
            all.contains("--align")
                && all.contains("victoria_park")
                && !all.contains("no alignment"),
            "{all}"
        );
        assert!(
            alignment_sentence(&["victoria_park"], 2)
                .contains("on the other maps with no alignment")
        );
        // a 15-parameter sweep's figure names stay within file-name limits, distinct and stable
        let long: Vec<String> = (0..15).map(|i| format!("fastslam.parameter_number_{i}")).collect();
        let (a, b) = (
            slug(&format!("{}--ate_rmse_m", long.join("-"))),
            slug(&format!("{}--landmark_error_m", long.join("-"))),
        );
        assert!(
            a.len() <= 120
                && b.len() <= 120
                && a != b
                && a.starts_with("fastslam-parameter-number-0"),
            "{a} {b}"
        );
        assert_eq!(a, slug(&format!("{}--ate_rmse_m", long.join("-"))));
    }

    #[test]
    fn csv_quotes_when_needed() {
        assert_eq!(csv_field("a,b"), "\"a,b\"");
        assert_eq!(csv_field("plain"), "plain");
    }

    #[test]
    fn contrast_entries_show_sign_interval_and_relative_change() {
        use crate::stats::compare::PairedContrast;
        let c = PairedContrast { pairs: 3, mean: 0.052, ci: (0.031, 0.073), against_mean: 0.25 };
        assert_eq!(contrast_entry(&c), "+0.052 [+0.031, +0.073] (+21 %)");
        let fall = PairedContrast { mean: -0.1, ci: (-0.2, 0.01), ..c };
        assert_eq!(contrast_entry(&fall), "−0.10 [−0.20, +0.010] (−40 %)");
        assert_eq!(
            contrast_entry(&PairedContrast { mean: -0.0004, ci: (-0.001, 0.0002), ..c }),
            "−0.00040 [−0.0010, +0.00020] (0 %)"
        );
        assert_eq!(contrast_entry(&PairedContrast { ci: (f64::NAN, f64::NAN), ..c }), "—");
    }
}
