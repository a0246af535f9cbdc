//! Results on disk. A study's results live in `data/results/<study>/`:
//! `runs.parquet` (one row per run), `traces.parquet` (per-step poses), `timings.parquet` (wall
//! clock, kept apart so nothing deterministic depends on it), `resolved.toml` (the spec with every
//! default filled in, plus the expanded sweep points), `manifest.json` (provenance) and `maps/`
//! (the exact map files the runs read). Run results are also kept in a content-addressed cache,
//! `data/cache/<hh>/<hash>/`, keyed by each run's content hash.
//!
//! Every write is atomic: files are written into a temporary directory that is renamed into
//! place, so an interrupted run never leaves a half-written study or cache entry.

mod parquet;
pub mod reference;
pub mod scans;
pub mod select;
pub mod tum;

use crate::geom::Pose2;
use crate::spec::{ExperimentSpec, SweepKind};

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Parquet { path: PathBuf, message: String },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    /// A stored file whose bytes no longer match the checksum recorded when it was written.
    #[error("{path}: {message}")]
    Integrity { path: PathBuf, message: String },
}

impl StoreError {
    fn io(path: &Path, source: std::io::Error) -> Self {
        StoreError::Io { path: path.to_path_buf(), source }
    }
    pub(crate) fn format(path: &Path, message: impl ToString) -> Self {
        StoreError::Format { path: path.to_path_buf(), message: message.to_string() }
    }
}

/// Outcome of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    /// Finished with finite results.
    Ok,
    /// World generation or the algorithm returned an error (or panicked): see `error`.
    Failed,
    /// Finished, but the estimate went non-finite.
    Diverged,
}

impl RunStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            RunStatus::Ok => "ok",
            RunStatus::Failed => "failed",
            RunStatus::Diverged => "diverged",
        }
    }
    pub(crate) fn parse(s: &str) -> RunStatus {
        match s {
            "ok" => RunStatus::Ok,
            "diverged" => RunStatus::Diverged,
            _ => RunStatus::Failed,
        }
    }
}

/// A parameter value as stored in a `runs.parquet` column.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamValue {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
}

impl ParamValue {
    pub fn from_toml(v: &toml::Value) -> ParamValue {
        match v {
            toml::Value::Float(f) => ParamValue::Float(*f),
            toml::Value::Integer(i) => ParamValue::Int(*i),
            toml::Value::Boolean(b) => ParamValue::Bool(*b),
            toml::Value::String(s) => ParamValue::Str(s.clone()),
            other => ParamValue::Str(other.to_string()),
        }
    }
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            ParamValue::Float(f) => Some(*f),
            ParamValue::Int(i) => Some(*i as f64),
            _ => None,
        }
    }
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Str(v) => f.write_str(v),
        }
    }
}

/// One row of `runs.parquet`.
#[derive(Debug, Clone, PartialEq)]
pub struct RunRow {
    pub study: String,
    pub run_id: String,
    pub map: String,
    pub algorithm: String,
    /// Sweep point label.
    pub point: String,
    pub replicate: u32,
    pub world_seed: u64,
    pub filter_seed: u64,
    pub status: RunStatus,
    pub error: Option<String>,
    pub run_hash: String,
    pub params_hash: String,
    pub code_version: String,
    /// Parameters the run read, as dotted paths.
    pub params: Vec<(String, ParamValue)>,
    /// Metric values; empty for a failed run.
    pub metrics: Vec<(String, f64)>,
}

impl RunRow {
    pub fn metric(&self, name: &str) -> Option<f64> {
        self.metrics.iter().find(|(k, _)| k == name).map(|(_, v)| *v)
    }
    pub fn param(&self, path: &str) -> Option<&ParamValue> {
        self.params.iter().find(|(k, _)| k == path).map(|(_, v)| v)
    }
}

/// Per-step truth and estimate of one run (step k at t = k·Δt).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TraceRows {
    pub run_id: String,
    pub dt_s: f64,
    pub truth: Vec<Pose2>,
    pub estimate: Vec<Pose2>,
    /// N̂eff per step (`None` where nothing was weighted); empty when the algorithm has none.
    pub neff: Vec<Option<f64>>,
}

impl TraceRows {
    pub fn empty(run_id: &str) -> Self {
        Self {
            run_id: run_id.to_string(),
            dt_s: 0.0,
            truth: Vec::new(),
            estimate: Vec::new(),
            neff: Vec::new(),
        }
    }
}

/// One landmark of a run's final map (world frame): a line (ρ, θ) or a corner (x, y).
#[derive(Debug, Clone, PartialEq)]
pub enum LandmarkRow {
    Line {
        rho_m: f64,
        theta_rad: f64,
    },
    Corner {
        x_m: f64,
        y_m: f64,
    },
    /// A point landmark (point-landmark worlds and datasets), with the true landmark it was
    /// created from when the filter knew it (known association).
    Point {
        x_m: f64,
        y_m: f64,
        id: Option<u32>,
    },
}

/// A run's final map.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RunLandmarks {
    pub run_id: String,
    pub landmarks: Vec<LandmarkRow>,
}

/// A scan-matching run's matches (empty for the other algorithms).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MatchRows {
    pub run_id: String,
    pub matches: Vec<crate::trace::MatchRecord>,
}

/// Wall-clock time of a run (when it was computed; `cached` = taken from the cache this time),
/// and its number of odometry steps (wall_ms / steps = time per step).
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    pub run_id: String,
    pub wall_ms: f64,
    pub steps: u32,
    pub cached: bool,
}

/// `manifest.json`: where the results came from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    pub study: String,
    pub schema_version: String,
    pub crate_version: String,
    /// Last commit that touched the inputs of the results (code, maps, specs).
    pub git_commit: String,
    /// Whether those inputs had uncommitted changes.
    pub git_dirty: bool,
    pub rustc: String,
    /// The spec file, relative to the working directory.
    pub spec_path: String,
    pub spec_blake3: String,
    /// Code versions that enter the run hashes.
    pub code_versions: BTreeMap<String, String>,
    /// Map name → blake3 of the map file.
    pub maps: BTreeMap<String, String>,
    pub runs: usize,
    pub failed: usize,
}

/// A plot group of `resolved.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupRecord {
    pub kind: SweepKind,
    pub params: Vec<String>,
    /// The points are named cells (a zip sweep with `labels`): the report tabulates them as columns.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub named: bool,
    /// A morris / sobol group: its design rows' sweep points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design: Option<DesignRecord>,
}

/// What a design group of `resolved.toml` records: the ranged parameters, the sweep point of
/// every design row, and (Morris) the paths' moves and realised coordinates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignRecord {
    /// Sobol: base samples N (rows: A₁…A_N, B₁…B_N, then A with column i from B for each i).
    /// Morris: trajectories r (rows: the d + 1 points of each trajectory in turn).
    pub size: usize,
    /// Point label of each design row (two rows that round to the same parameters share one).
    pub rows: Vec<String>,
    /// Morris: the parameter each step of each trajectory moves.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub moved: Vec<Vec<usize>>,
    /// Morris: each row's realised coordinates in [0, 1] (after rounding).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unit: Vec<Vec<f64>>,
    /// Morris: the design's step Δ on the unit scale.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delta: Option<f64>,
}

/// A sweep point of `resolved.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointRecord {
    pub label: String,
    pub groups: Vec<usize>,
    pub assignments: toml::Table,
}

/// The sweep points (labels) a claim of the spec refers to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClaimCells {
    pub id: String,
    pub at: Option<String>,
    pub than: Option<String>,
    /// For `flat` claims: (value as written, point label) in the order given.
    pub over: Vec<(String, String)>,
}

/// `resolved.toml`: the complete record of what a study ran.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResolvedStudy {
    pub spec: ExperimentSpec,
    pub groups: Vec<GroupRecord>,
    pub points: Vec<PointRecord>,
    #[serde(default)]
    pub claims: Vec<ClaimCells>,
    /// The sweep point label of each `[[report.landmark_reference]]` (written only when any).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub landmark_points: Vec<String>,
    /// The external algorithms the study lists, as declared when it ran (written only when any):
    /// the report knows them from here, never from `data/algorithms/`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub externals: Vec<crate::algo::external::ExternalSpec>,
    /// The published result items a sequential study staged (`[sequential] items`), as read when
    /// it ran (written only when any): the report replays the looks with these.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub items: Vec<crate::spec::items::Item>,
}

impl ResolvedStudy {
    /// The algorithms its names resolve against: the built-ins and its external ones.
    pub fn catalogue(&self) -> crate::algo::Catalogue {
        crate::algo::Catalogue::with_externals(self.externals.clone())
    }
}

/// Everything `write_study` puts in a study directory.
pub struct StudyOutput<'a> {
    /// Every run's row, sorted by run id.
    pub runs: &'a [RunRow],
    /// Their timings, in the same order.
    pub timings: &'a [Timing],
    pub resolved: &'a ResolvedStudy,
    pub manifest: &'a Manifest,
    /// (map name, exact file text).
    pub maps: &'a [(String, String)],
    /// The reference rows shown beside the results (`reference.csv`), if the study has any.
    pub reference: Option<&'a str>,
    /// Scan-matching studies (`Some`): the diagnosed matches and incremental maps, or `None`
    /// when none could be made (`diagnostics.json` then holds `null`).
    pub diagnostics: Option<Option<&'a crate::scanmatch::diagnose::Diagnostics>>,
}

/// The bulk of one run's results: what a study's results hold of it besides its row.
#[derive(Debug, Clone, Default)]
pub struct RunParts {
    pub trace: TraceRows,
    pub landmarks: RunLandmarks,
    pub matches: MatchRows,
}

/// Trace rows a study writes at a time (one row group of `traces.parquet`, with the landmarks and
/// matches of the same runs): polars' own row-group size. A study's memory holds one such batch,
/// not every run's results; a study smaller than this is written in one batch, exactly as a
/// single write would write it.
const BATCH_TRACE_ROWS: usize = 512 * 512;

/// Writes a study directory atomically (rows must already be sorted by run id). `parts(k)` gives
/// the trace, landmarks and matches of run `k` of `out.runs`; they are asked for in order and
/// written a batch at a time.
pub fn write_study(
    dir: &Path,
    out: &StudyOutput<'_>,
    parts: &mut dyn FnMut(usize) -> Result<RunParts, StoreError>,
) -> Result<(), StoreError> {
    write_dir_atomically(dir, |tmp| {
        let mut runs = parquet::runs_frame(out.runs).map_err(|e| StoreError::format(dir, e))?;
        parquet::write(&tmp.join("runs.parquet"), &mut runs)?;
        let mut traces = parquet::Batched::new(&tmp.join("traces.parquet"));
        let mut landmarks = parquet::Batched::new(&tmp.join("landmarks.parquet"));
        let mut matches = parquet::Batched::new(&tmp.join("matches.parquet"));
        let mut batch: Vec<RunParts> = Vec::new();
        let mut rows = 0;
        let mut flush = |batch: &mut Vec<RunParts>| -> Result<(), StoreError> {
            let t: Vec<TraceRows> =
                batch.iter_mut().map(|p| std::mem::take(&mut p.trace)).collect();
            traces.write(&parquet::traces_frame(&t).map_err(|e| StoreError::format(dir, e))?)?;
            let l: Vec<RunLandmarks> =
                batch.iter_mut().map(|p| std::mem::take(&mut p.landmarks)).collect();
            landmarks
                .write(&parquet::landmarks_frame(&l).map_err(|e| StoreError::format(dir, e))?)?;
            let m: Vec<MatchRows> =
                batch.iter_mut().map(|p| std::mem::take(&mut p.matches)).collect();
            matches.write(&parquet::matches_frame(&m).map_err(|e| StoreError::format(dir, e))?)?;
            batch.clear();
            Ok(())
        };
        for k in 0..out.runs.len() {
            let p = parts(k)?;
            rows += p.trace.truth.len();
            batch.push(p);
            if rows >= BATCH_TRACE_ROWS {
                flush(&mut batch)?;
                rows = 0;
            }
        }
        if !batch.is_empty() {
            flush(&mut batch)?;
        }
        drop(flush);
        traces.finish(|| parquet::traces_frame(&[]))?;
        landmarks.finish(|| parquet::landmarks_frame(&[]))?;
        matches.finish(|| parquet::matches_frame(&[]))?;
        let mut timings =
            parquet::timings_frame(out.timings).map_err(|e| StoreError::format(dir, e))?;
        parquet::write(&tmp.join("timings.parquet"), &mut timings)?;
        let resolved = toml::to_string(out.resolved).map_err(|e| StoreError::format(dir, e))?;
        write_file(&tmp.join("resolved.toml"), resolved.as_bytes())?;
        let manifest = serde_json::to_string_pretty(out.manifest)
            .map_err(|e| StoreError::format(dir, e))?
            + "\n";
        write_file(&tmp.join("manifest.json"), manifest.as_bytes())?;
        if let Some(text) = out.reference {
            write_file(&tmp.join("reference.csv"), text.as_bytes())?;
        }
        if let Some(d) = out.diagnostics {
            let text = serde_json::to_string(&d).map_err(|e| StoreError::format(dir, e))? + "\n";
            write_file(&tmp.join(DIAGNOSTICS), text.as_bytes())?;
        }
        let maps = tmp.join("maps");
        std::fs::create_dir(&maps).map_err(|e| StoreError::io(&maps, e))?;
        for (name, text) in out.maps {
            write_file(&maps.join(format!("{name}.toml")), text.as_bytes())?;
        }
        seal(tmp)
    })
}

/// Checks, before anything is computed, that studies can be written under `results_dir` (and into
/// the existing `studies` folders there): creates the folder if needed and writes and removes a
/// probe file in each. A folder that cannot be written is an error naming it.
pub fn check_writable(results_dir: &Path, studies: &[&str]) -> Result<(), StoreError> {
    std::fs::create_dir_all(results_dir).map_err(|e| StoreError::io(results_dir, e))?;
    let dirs = std::iter::once(results_dir.to_path_buf())
        .chain(studies.iter().map(|s| results_dir.join(s)).filter(|d| d.is_dir()));
    for dir in dirs {
        let probe = dir.join(format!(".slamlab-write-check-{}", std::process::id()));
        std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&probe)
            .map_err(|e| StoreError::io(&dir, e))?;
        std::fs::remove_file(&probe).map_err(|e| StoreError::io(&probe, e))?;
    }
    Ok(())
}

/// A scan-matching study's diagnostics file.
const DIAGNOSTICS: &str = "diagnostics.json";

/// A scan-matching study's diagnostics, verified; `None` when the study has none.
pub fn read_diagnostics(
    dir: &Path,
) -> Result<Option<crate::scanmatch::diagnose::Diagnostics>, StoreError> {
    let path = dir.join(DIAGNOSTICS);
    if !path.is_file() {
        return Ok(None);
    }
    verified(dir, Some(DIAGNOSTICS))?;
    let text = std::fs::read_to_string(&path).map_err(|e| StoreError::io(&path, e))?;
    serde_json::from_str(&text).map(Some).map_err(|e| StoreError::format(&path, e))
}

/// Whether `dir` already holds exactly this study: the same runs (by id and content hash), and
/// byte-identical resolved spec, manifest, maps and reference rows, and diagnostics when
/// `diagnostics` (a scan-matching study). Then rewriting it would change nothing.
pub fn is_up_to_date(
    dir: &Path,
    runs: &[(String, String)],
    resolved: &ResolvedStudy,
    manifest: &Manifest,
    maps: &[(String, String)],
    reference: Option<&str>,
    diagnostics: bool,
) -> bool {
    let same_text =
        |name: &str, text: &str| std::fs::read_to_string(dir.join(name)).is_ok_and(|t| t == text);
    let resolved_ok = toml::to_string(resolved).is_ok_and(|t| same_text("resolved.toml", &t));
    let manifest_ok = serde_json::to_string_pretty(manifest)
        .is_ok_and(|t| same_text("manifest.json", &(t + "\n")));
    let maps_ok = maps.iter().all(|(name, text)| same_text(&format!("maps/{name}.toml"), text))
        && std::fs::read_dir(dir.join("maps")).map(|d| d.count()).unwrap_or(0) == maps.len();
    let reference_ok = match reference {
        Some(text) => same_text("reference.csv", text),
        None => !dir.join("reference.csv").exists(),
    };
    let diagnostics_ok = !diagnostics || dir.join(DIAGNOSTICS).is_file();
    if !(resolved_ok
        && manifest_ok
        && maps_ok
        && reference_ok
        && diagnostics_ok
        && dir.join("traces.parquet").is_file()
        && dir.join("landmarks.parquet").is_file())
    {
        return false;
    }
    // a directory whose files changed (or that predates checksums) is rewritten
    if !matches!(check_seal(dir), Ok(Seal::Intact)) {
        return false;
    }
    let Ok(stored) = read_run_keys(dir) else { return false };
    let mut stored: Vec<(String, String)> =
        stored.into_iter().map(|(id, hash, _)| (id, hash)).collect();
    let mut wanted = runs.to_vec();
    stored.sort();
    wanted.sort();
    stored == wanted
}

/// A study read back for reporting (traces are read separately, on demand).
#[derive(Debug, Clone)]
pub struct StudyData {
    pub dir: PathBuf,
    pub resolved: ResolvedStudy,
    pub manifest: Manifest,
    /// Never changed after reading: [`StudyData::runs_in`] indexes it.
    pub runs: Vec<RunRow>,
    /// (map name, file text), sorted by name.
    pub maps: Vec<(String, String)>,
    /// Published results shown beside these (parsed `reference.csv`).
    pub reference: Vec<reference::ReferenceRow>,
    /// Indices into `runs` of each cell's runs (key [`cell_key`]), in run order: reports and
    /// verdicts look cells up thousands of times.
    cells: std::collections::HashMap<String, Vec<usize>>,
}

/// The key of a cell (map, algorithm, sweep point) in [`StudyData`]'s index.
fn cell_key(map: &str, algorithm: &str, point: &str) -> String {
    format!("{map}\u{0}{algorithm}\u{0}{point}")
}

impl Manifest {
    /// A manifest that records nothing but the study and its run count: what judging a study
    /// still running (a sequential look) or a test needs, since verdicts never read it.
    pub fn blank(study: &str, runs: usize) -> Manifest {
        Manifest {
            study: study.to_string(),
            schema_version: String::new(),
            crate_version: String::new(),
            git_commit: String::new(),
            git_dirty: false,
            rustc: String::new(),
            spec_path: String::new(),
            spec_blake3: String::new(),
            code_versions: Default::default(),
            maps: Default::default(),
            runs,
            failed: 0,
        }
    }
}

impl StudyData {
    /// A study's data from its parts (what [`read_study`] read, or a study still running).
    pub fn new(
        dir: PathBuf,
        resolved: ResolvedStudy,
        manifest: Manifest,
        runs: Vec<RunRow>,
        maps: Vec<(String, String)>,
        reference: Vec<reference::ReferenceRow>,
    ) -> StudyData {
        let mut cells: std::collections::HashMap<String, Vec<usize>> = Default::default();
        for (k, r) in runs.iter().enumerate() {
            cells.entry(cell_key(&r.map, &r.algorithm, &r.point)).or_default().push(k);
        }
        StudyData { dir, resolved, manifest, runs, maps, reference, cells }
    }

    /// The same study as it stood with replicates 0 … n − 1 only (a sequential study's look at n).
    pub fn up_to(&self, n: u32) -> StudyData {
        StudyData::new(
            self.dir.clone(),
            self.resolved.clone(),
            self.manifest.clone(),
            self.runs.iter().filter(|r| r.replicate < n).cloned().collect(),
            self.maps.clone(),
            self.reference.clone(),
        )
    }

    /// The runs of one cell (map, algorithm, sweep point), in run order.
    pub fn runs_in<'a>(
        &'a self,
        map: &str,
        algorithm: &str,
        point: &str,
    ) -> impl Iterator<Item = &'a RunRow> + 'a {
        let at = self.cells.get(&cell_key(map, algorithm, point)).map_or(&[][..], Vec::as_slice);
        at.iter().map(|&k| &self.runs[k])
    }

    /// Replicate → value of `metric` over the successful runs of one cell (map, algorithm, sweep
    /// point): what every verdict compares (replicate k of two cells saw the same world).
    pub fn replicate_values(
        &self,
        map: &str,
        algorithm: &str,
        point: &str,
        metric: &str,
    ) -> std::collections::BTreeMap<u32, f64> {
        self.runs_in(map, algorithm, point)
            .filter(|r| r.status == RunStatus::Ok)
            .filter_map(|r| r.metric(metric).map(|v| (r.replicate, v)))
            .collect()
    }
}

pub fn read_study(dir: &Path) -> Result<StudyData, StoreError> {
    // everything the study holds is there (a reader must never take a missing file for an
    // optional one), and what this reads is intact (traces and the rest are verified when read)
    listed_files_present(dir)?;
    for file in ["resolved.toml", "manifest.json", "runs.parquet"] {
        verified(dir, Some(file))?;
    }
    let resolved_path = dir.join("resolved.toml");
    let text =
        std::fs::read_to_string(&resolved_path).map_err(|e| StoreError::io(&resolved_path, e))?;
    let resolved: ResolvedStudy =
        toml::from_str(&text).map_err(|e| StoreError::format(&resolved_path, e))?;
    let manifest_path = dir.join("manifest.json");
    let text =
        std::fs::read_to_string(&manifest_path).map_err(|e| StoreError::io(&manifest_path, e))?;
    let manifest: Manifest =
        serde_json::from_str(&text).map_err(|e| StoreError::format(&manifest_path, e))?;
    let runs_path = dir.join("runs.parquet");
    let runs = in_range(&runs_path, parquet::read_runs(&runs_path)?)?;
    let maps_dir = dir.join("maps");
    let mut maps = Vec::new();
    for entry in std::fs::read_dir(&maps_dir).map_err(|e| StoreError::io(&maps_dir, e))? {
        let path = entry.map_err(|e| StoreError::io(&maps_dir, e))?.path();
        if path.extension().is_some_and(|x| x == "toml") {
            let name = path.file_stem().unwrap_or_default().to_string_lossy().into_owned();
            verified(dir, Some(&format!("maps/{name}.toml")))?;
            maps.push((
                name,
                std::fs::read_to_string(&path).map_err(|e| StoreError::io(&path, e))?,
            ));
        }
    }
    maps.sort();
    let reference_path = dir.join("reference.csv");
    if reference_path.is_file() {
        verified(dir, Some("reference.csv"))?;
    }
    let reference = match std::fs::read_to_string(&reference_path) {
        Ok(text) => reference::parse(&text).map_err(|e| StoreError::format(&reference_path, e))?,
        Err(_) => Vec::new(),
    };
    let mut runs = runs;
    derive_metrics(dir, &resolved, &maps, &mut runs)?;
    Ok(StudyData::new(dir.to_path_buf(), resolved, manifest, runs, maps, reference))
}

/// Adds the metrics derived from the stored final maps ([`crate::metrics::LANDMARK_ERROR_GROWTH`])
/// to the successful runs, when the study names one (in a claim or the report's metrics). They
/// are computed here, from what the runs stored, so adding one leaves every cached run valid.
fn derive_metrics(
    dir: &Path,
    resolved: &ResolvedStudy,
    maps: &[(String, String)],
    runs: &mut [RunRow],
) -> Result<(), StoreError> {
    use crate::metrics::{GROWTH_FIRST_LANDMARKS, LANDMARK_ERROR_GROWTH, landmark_error_growth};
    let spec = &resolved.spec;
    let wanted = spec.claims.iter().any(|c| c.metric == LANDMARK_ERROR_GROWTH)
        || spec.report.metrics.iter().any(|m| m == LANDMARK_ERROR_GROWTH);
    if !wanted {
        return Ok(());
    }
    let truths: BTreeMap<&str, Vec<crate::geom::Point2>> = maps
        .iter()
        .filter_map(|(name, text)| {
            crate::world::map::Map::from_toml(text).ok().map(|m| (name.as_str(), m.point_landmarks))
        })
        .collect();
    let ok: std::collections::BTreeSet<String> =
        runs.iter().filter(|r| r.status == RunStatus::Ok).map(|r| r.run_id.clone()).collect();
    let finals: BTreeMap<String, Vec<LandmarkRow>> = read_landmarks(dir, &|id| ok.contains(id))?
        .into_iter()
        .map(|f| (f.run_id, f.landmarks))
        .collect();
    for r in runs.iter_mut().filter(|r| r.status == RunStatus::Ok) {
        let (Some(truth), Some(estimated)) = (truths.get(r.map.as_str()), finals.get(&r.run_id))
        else {
            continue;
        };
        let errors: Vec<Option<f64>> = truth
            .iter()
            .enumerate()
            .map(|(i, t)| {
                estimated.iter().find_map(|l| match *l {
                    LandmarkRow::Point { x_m, y_m, id: Some(id) } if id as usize == i => {
                        Some((x_m - t.x).hypot(y_m - t.y))
                    }
                    _ => None,
                })
            })
            .collect();
        r.metrics.push((
            LANDMARK_ERROR_GROWTH.to_string(),
            landmark_error_growth(&errors, GROWTH_FIRST_LANDMARKS),
        ));
    }
    Ok(())
}

/// Reads the traces of the runs `keep` accepts.
pub fn read_traces(dir: &Path, keep: &dyn Fn(&str) -> bool) -> Result<Vec<TraceRows>, StoreError> {
    verified(dir, Some("traces.parquet"))?;
    parquet::read_traces(&dir.join("traces.parquet"), keep)
}

/// Reads the final maps of the runs `keep` accepts.
pub fn read_landmarks(
    dir: &Path,
    keep: &dyn Fn(&str) -> bool,
) -> Result<Vec<RunLandmarks>, StoreError> {
    verified(dir, Some("landmarks.parquet"))?;
    parquet::read_landmarks(&dir.join("landmarks.parquet"), keep)
}

/// Per-match rows of a study's scan-matching runs (none for studies written before them).
pub fn read_matches(dir: &Path, keep: &dyn Fn(&str) -> bool) -> Result<Vec<MatchRows>, StoreError> {
    let path = dir.join("matches.parquet");
    if !path.is_file() {
        return Ok(Vec::new());
    }
    verified(dir, Some("matches.parquet"))?;
    parquet::read_matches(&path, keep)
}

/// A set of run ids.
pub type RunIds<'a> = std::collections::BTreeSet<&'a str>;

/// A study's per-run files — traces, final maps, matches — for a reader that asks for a few runs
/// at a time (the report). Each file's checksum is verified once, on first use, and an index of
/// where each run's rows lie is kept, so every later request decodes only the rows it wants.
pub struct RunFiles {
    dir: PathBuf,
    traces: std::cell::OnceCell<parquet::RunIndex>,
    landmarks: std::cell::OnceCell<parquet::RunIndex>,
    matches: std::cell::OnceCell<parquet::RunIndex>,
}

impl RunFiles {
    pub fn new(dir: &Path) -> Self {
        Self {
            dir: dir.to_path_buf(),
            traces: Default::default(),
            landmarks: Default::default(),
            matches: Default::default(),
        }
    }

    /// The verified index of `file`, built on first use.
    fn index<'a>(
        &self,
        cell: &'a std::cell::OnceCell<parquet::RunIndex>,
        file: &str,
    ) -> Result<&'a parquet::RunIndex, StoreError> {
        if cell.get().is_none() {
            verified(&self.dir, Some(file))?;
            let _ = cell.set(parquet::RunIndex::build(&self.dir.join(file))?);
        }
        Ok(cell.get().expect("set above"))
    }

    /// The traces of the runs `ids`, as [`read_traces`] reads them.
    pub fn traces(&self, ids: &RunIds<'_>) -> Result<Vec<TraceRows>, StoreError> {
        let file = "traces.parquet";
        self.index(&self.traces, file)?.traces(&self.dir.join(file), ids)
    }

    /// The final maps of the runs `ids`, as [`read_landmarks`] reads them.
    pub fn landmarks(&self, ids: &RunIds<'_>) -> Result<Vec<RunLandmarks>, StoreError> {
        let file = "landmarks.parquet";
        self.index(&self.landmarks, file)?.landmarks(&self.dir.join(file), ids)
    }

    /// The matches of the runs `ids`, as [`read_matches`] reads them.
    pub fn matches(&self, ids: &RunIds<'_>) -> Result<Vec<MatchRows>, StoreError> {
        let file = "matches.parquet";
        if !self.dir.join(file).is_file() {
            return Ok(Vec::new());
        }
        self.index(&self.matches, file)?.matches(&self.dir.join(file), ids)
    }
}

pub fn read_timings(dir: &Path) -> Result<Vec<Timing>, StoreError> {
    verified(dir, Some("timings.parquet"))?;
    parquet::read_timings(&dir.join("timings.parquet"))
}

/// Reads `runs.parquet` alone (e.g. to compare a new plan with the previous results).
/// `(run_id, run_hash, status)` of every stored run, in row order: what deciding whether a study
/// is up to date needs, without parsing parameters and metrics.
pub fn read_run_keys(dir: &Path) -> Result<Vec<(String, String, RunStatus)>, StoreError> {
    verified(dir, Some("runs.parquet"))?;
    parquet::read_run_keys(&dir.join("runs.parquet"))
}

pub fn read_runs(dir: &Path) -> Result<Vec<RunRow>, StoreError> {
    verified(dir, Some("runs.parquet"))?;
    let path = dir.join("runs.parquet");
    in_range(&path, parquet::read_runs(&path)?)
}

/// Rows whose status is ok and whose metrics are in range (see `metrics::out_of_range`); else an
/// error naming the file, the run and the metric.
fn in_range(path: &Path, rows: Vec<RunRow>) -> Result<Vec<RunRow>, StoreError> {
    for r in rows.iter().filter(|r| r.status == RunStatus::Ok) {
        if let Some((name, value)) =
            crate::metrics::out_of_range(r.metrics.iter().map(|(k, v)| (k.as_str(), *v)))
        {
            return Err(StoreError::Integrity {
                path: path.to_path_buf(),
                message: format!(
                    "run {}: {name} = {value} is negative, which no metric can be; refusing to use it",
                    r.run_id
                ),
            });
        }
    }
    Ok(rows)
}

/// Study directories under `results_dir` (those with a manifest), sorted by name.
pub fn list_studies(results_dir: &Path) -> Result<Vec<PathBuf>, StoreError> {
    let entries = match std::fs::read_dir(results_dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(StoreError::io(results_dir, e)),
    };
    let mut dirs: Vec<PathBuf> = entries
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.join("manifest.json").is_file()
                && !p.file_name().unwrap_or_default().to_string_lossy().starts_with('.')
        })
        .collect();
    dirs.sort();
    Ok(dirs)
}

/// The content-addressed run cache.
#[derive(Debug, Clone)]
pub struct Cache {
    dir: PathBuf,
}

/// A cached run: its row (study-specific fields as first computed), trace and compute time.
#[derive(Debug, Clone)]
pub struct CachedRun {
    pub row: RunRow,
    pub trace: TraceRows,
    pub landmarks: RunLandmarks,
    pub matches: MatchRows,
    pub wall_ms: f64,
}

/// Column under which a cache entry keeps the run's compute time (never in study results).
const CACHE_WALL_MS: &str = "cache_wall_ms";

/// What a study keeps of a cached run while it writes its results: the row, its compute time
/// and its trace's length; the rest is read again when written ([`Cache::parts`]).
#[derive(Debug, Clone)]
pub struct CachedSummary {
    pub row: RunRow,
    pub wall_ms: f64,
    /// Rows of its trace.
    pub trace_rows: usize,
}

/// A cache lookup.
#[derive(Debug, Clone)]
pub enum Lookup<T = CachedRun> {
    /// Sealed and intact.
    Hit(T),
    /// A file changed since it was written, or the checksum list is missing, incomplete or lists
    /// less than the entry holds (named): the run is recomputed. Every entry is sealed when it is
    /// written, so an entry without its full list is never trusted.
    Corrupt(String),
    Absent,
}

impl Cache {
    pub fn new(dir: &Path) -> Self {
        Self { dir: dir.to_path_buf() }
    }

    fn entry(&self, hash: &str) -> PathBuf {
        self.dir.join(&hash[..2.min(hash.len())]).join(hash)
    }

    pub fn contains(&self, hash: &str) -> bool {
        self.entry(hash).join("trace.parquet").is_file()
    }

    /// The cached run and whether it is sealed (see [`Lookup`]).
    pub fn lookup(&self, hash: &str) -> Lookup {
        match self.lookup_with(hash, |c| c.get(hash)) {
            Lookup::Hit(Some(c)) => Lookup::Hit(c),
            Lookup::Hit(None) | Lookup::Absent => Lookup::Absent,
            Lookup::Corrupt(why) => Lookup::Corrupt(why),
        }
    }

    /// Checks an entry's seal, then reads what `read` reads of it.
    fn lookup_with<T>(&self, hash: &str, read: impl FnOnce(&Self) -> T) -> Lookup<T> {
        let dir = self.entry(hash);
        if !self.contains(hash) {
            return Lookup::Absent;
        }
        match check_seal(&dir) {
            Ok(Seal::Intact) => Lookup::Hit(read(self)),
            Ok(Seal::Unsealed) => Lookup::Corrupt(format!(
                "{}: missing (every cache entry is sealed when written)",
                dir.join(CHECKSUMS).display()
            )),
            Ok(Seal::Broken { path, message }) => {
                Lookup::Corrupt(format!("{}: {message}", path.display()))
            }
            Err(e) => Lookup::Corrupt(e.to_string()),
        }
    }

    /// [`Cache::lookup`], keeping only the row, compute time and trace length of a hit (the
    /// checksums of every file are checked all the same).
    pub fn lookup_summary(&self, hash: &str) -> Lookup<CachedSummary> {
        match self.lookup_with(hash, |c| c.summary(hash)) {
            Lookup::Hit(Some(s)) => Lookup::Hit(s),
            Lookup::Hit(None) | Lookup::Absent => Lookup::Absent,
            Lookup::Corrupt(why) => Lookup::Corrupt(why),
        }
    }

    fn summary(&self, hash: &str) -> Option<CachedSummary> {
        let dir = self.entry(hash);
        let (row, wall_ms) = self.row(hash)?;
        let trace_rows = parquet::count_rows(&dir.join("trace.parquet")).ok()?;
        Some(CachedSummary { row, wall_ms, trace_rows })
    }

    fn row(&self, hash: &str) -> Option<(RunRow, f64)> {
        let dir = self.entry(hash);
        let mut rows = parquet::read_runs(&dir.join("run.parquet")).ok()?;
        let mut row = rows.pop()?;
        let wall_ms = row.metric(CACHE_WALL_MS).unwrap_or(f64::NAN);
        row.metrics.retain(|(k, _)| k != CACHE_WALL_MS);
        Some((row, wall_ms))
    }

    /// The cached run, or `None` when absent or unreadable (then it is simply recomputed). Does
    /// not check the checksums: [`Cache::lookup`] does.
    pub fn get(&self, hash: &str) -> Option<CachedRun> {
        let (row, wall_ms) = self.row(hash)?;
        let RunParts { trace, landmarks, matches } = self.parts(hash, &row.run_id)?;
        Some(CachedRun { row, trace, landmarks, matches, wall_ms })
    }

    /// The trace, landmarks and matches of a cached run (labelled `run_id`), or `None` when
    /// absent or unreadable. Does not check the checksums: [`Cache::lookup`] does.
    pub fn parts(&self, hash: &str, run_id: &str) -> Option<RunParts> {
        let dir = self.entry(hash);
        let trace = parquet::read_traces(&dir.join("trace.parquet"), &|_| true)
            .ok()?
            .pop()
            .unwrap_or_else(|| TraceRows::empty(run_id));
        let landmarks = parquet::read_landmarks(&dir.join("landmarks.parquet"), &|_| true)
            .ok()?
            .pop()
            .unwrap_or_else(|| RunLandmarks { run_id: run_id.to_string(), landmarks: Vec::new() });
        // Entries written before scan matching existed have no matches file: no matches.
        let matches = match dir.join("matches.parquet") {
            p if p.is_file() => {
                parquet::read_matches(&p, &|_| true).ok()?.pop().unwrap_or_default()
            }
            _ => MatchRows::default(),
        };
        Some(RunParts {
            trace: TraceRows { run_id: run_id.to_string(), ..trace },
            landmarks: RunLandmarks { run_id: run_id.to_string(), ..landmarks },
            matches: MatchRows { run_id: run_id.to_string(), ..matches },
        })
    }

    /// Stores a run. An existing entry is kept unless `replace` (a forced recomputation, or an
    /// entry that could not be read).
    pub fn put(&self, hash: &str, run: &CachedRun, replace: bool) -> Result<(), StoreError> {
        let dir = self.entry(hash);
        if !replace && self.contains(hash) {
            return Ok(());
        }
        let mut row = run.row.clone();
        row.metrics.push((CACHE_WALL_MS.to_string(), run.wall_ms));
        write_dir_atomically(&dir, |tmp| {
            let mut df = parquet::runs_frame(std::slice::from_ref(&row))
                .map_err(|e| StoreError::format(&dir, e))?;
            parquet::write(&tmp.join("run.parquet"), &mut df)?;
            let mut df = parquet::landmarks_frame(std::slice::from_ref(&run.landmarks))
                .map_err(|e| StoreError::format(&dir, e))?;
            parquet::write(&tmp.join("landmarks.parquet"), &mut df)?;
            if !run.matches.matches.is_empty() {
                let mut df = parquet::matches_frame(std::slice::from_ref(&run.matches))
                    .map_err(|e| StoreError::format(&dir, e))?;
                parquet::write(&tmp.join("matches.parquet"), &mut df)?;
            }
            let mut df = parquet::traces_frame(std::slice::from_ref(&run.trace))
                .map_err(|e| StoreError::format(&dir, e))?;
            parquet::write(&tmp.join("trace.parquet"), &mut df)?;
            seal(tmp)
        })
    }
}

/// The longest file-name stem slamlab derives from labels (run ids, figure names): file systems
/// allow 255 bytes per name, and suffixes and temporary prefixes need room.
pub const MAX_NAME: usize = 120;

/// `name` if it is at most [`MAX_NAME`] bytes, else a readable prefix and the blake3 of the
/// whole name (16 hex digits): short, stable and distinct. The full label stays inside the file.
pub fn short_name(name: &str) -> String {
    if name.len() <= MAX_NAME {
        return name.to_string();
    }
    let mut cut = MAX_NAME - 17;
    while !name.is_char_boundary(cut) {
        cut -= 1;
    }
    format!("{}-{}", &name[..cut], &blake3::hash(name.as_bytes()).to_hex()[..16])
}

/// The checksum file of every store directory (a study's results, a cache entry): one line
/// `<blake3 hex>  <path>` per file written, in `b3sum` format (`b3sum --check checksums.b3`).
pub const CHECKSUMS: &str = "checksums.b3";

/// Every file under `root` except the checksum file, as (relative path with `/`, absolute path),
/// sorted.
fn files_under(root: &Path) -> Result<Vec<(String, PathBuf)>, StoreError> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, PathBuf)>) -> Result<(), StoreError> {
        for entry in std::fs::read_dir(dir).map_err(|e| StoreError::io(dir, e))? {
            let path = entry.map_err(|e| StoreError::io(dir, e))?.path();
            if path.is_dir() {
                walk(root, &path, out)?;
            } else {
                let rel = path
                    .strip_prefix(root)
                    .expect("below root")
                    .to_string_lossy()
                    .replace('\\', "/");
                if rel != CHECKSUMS {
                    out.push((rel, path));
                }
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(root, root, &mut out)?;
    out.sort();
    Ok(out)
}

/// The blake3 of a file, memory-mapped (a study's traces can be larger than the memory it may
/// use) and hashed on every core: the reports verify every results file they read.
fn file_hash(path: &Path) -> Result<String, StoreError> {
    let mut hasher = blake3::Hasher::new();
    hasher.update_mmap_rayon(path).map_err(|e| StoreError::io(path, e))?;
    Ok(hasher.finalize().to_hex().to_string())
}

/// Records the checksum of every file of a directory being written (the last step of a fill).
fn seal(dir: &Path) -> Result<(), StoreError> {
    let mut text = String::new();
    for (rel, path) in files_under(dir)? {
        text.push_str(&format!("{}  {rel}\n", file_hash(&path)?));
    }
    write_file(&dir.join(CHECKSUMS), text.as_bytes())
}

/// Files written beside a study's results after they were sealed, which the store never reads:
/// the machine-dependent timing page of `slamlab report`.
pub const ADDED_LATER: [&str; 1] = [TIMINGS];

/// The timing page's file name in a study's results folder.
pub const TIMINGS: &str = "timings.html";

/// What a store directory's checksums say about it.
#[derive(Debug, Clone, PartialEq)]
pub enum Seal {
    /// Every listed file is present and matches.
    Intact,
    /// Written before checksums existed.
    Unsealed,
    /// The first listed file that does not match (or is missing), and why.
    Broken { path: PathBuf, message: String },
}

/// Checks `dir` against its checksum file.
pub fn check_seal(dir: &Path) -> Result<Seal, StoreError> {
    seal_of(dir, None)
}

/// Checks every listed file of `dir`, or only `file` (which must be listed).
fn seal_of(dir: &Path, file: Option<&str>) -> Result<Seal, StoreError> {
    let list = dir.join(CHECKSUMS);
    let text = match std::fs::read_to_string(&list) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Seal::Unsealed),
        Err(e) => return Err(StoreError::io(&list, e)),
    };
    let mut recorded: BTreeMap<String, String> = BTreeMap::new();
    for (n, line) in text.lines().enumerate() {
        let Some((hash, rel)) = line.split_once("  ") else {
            return Ok(Seal::Broken {
                path: list.clone(),
                message: format!("line {}: not `<hash>  <path>`", n + 1),
            });
        };
        recorded.insert(rel.to_string(), hash.to_string());
    }
    if let Some(f) = file.filter(|f| !recorded.contains_key(*f)) {
        return Ok(Seal::Broken {
            path: dir.join(f),
            message: format!("not listed in {CHECKSUMS}: added after the directory was written"),
        });
    }
    // Every file the directory holds must be listed: a list emptied or missing a line covers
    // nothing. Files added beside a study's results later (the timing page of `slamlab report`)
    // are not the store's and are not read by it.
    if file.is_none() {
        for (rel, path) in files_under(dir)? {
            if !recorded.contains_key(&rel) && !ADDED_LATER.contains(&rel.as_str()) {
                return Ok(Seal::Broken {
                    path,
                    message: format!(
                        "not listed in {CHECKSUMS}: the list is incomplete, or the file was added after the directory was written"
                    ),
                });
            }
        }
    }
    for (rel, hash) in recorded.iter().filter(|(rel, _)| file.is_none_or(|f| f == rel.as_str())) {
        let path = dir.join(rel);
        if !path.is_file() {
            return Ok(Seal::Broken {
                path,
                message: format!("listed in {CHECKSUMS} but missing"),
            });
        }
        if *hash != file_hash(&path)? {
            return Ok(Seal::Broken {
                path,
                message: format!(
                    "content does not match its checksum in {CHECKSUMS}: the file changed after it was written"
                ),
            });
        }
    }
    Ok(Seal::Intact)
}

/// Every file a sealed directory's checksum list names is present (without hashing them): a study
/// that lost `diagnostics.json`, `matches.parquet` or `reference.csv` is refused, naming the
/// file, rather than rendered without it.
fn listed_files_present(dir: &Path) -> Result<(), StoreError> {
    let list = dir.join(CHECKSUMS);
    let Ok(text) = std::fs::read_to_string(&list) else {
        return verified(dir, Some("manifest.json")); // says why (missing, unreadable)
    };
    for rel in text.lines().filter_map(|l| l.split_once("  ").map(|(_, rel)| rel)) {
        let path = dir.join(rel);
        if !path.is_file() {
            return Err(StoreError::Integrity {
                path,
                message: format!(
                    "listed in {CHECKSUMS} but missing: the study is incomplete; refusing to use it (rewrite it with `slamlab run`)"
                ),
            });
        }
    }
    Ok(())
}

/// A study directory's files (or only `file`, what the caller reads) may be read: intact, or an
/// error naming the file (an unsealed directory predates checksums and must be rewritten by
/// `slamlab run`, which finds its runs cached). Each read hashes only what it reads.
fn verified(dir: &Path, file: Option<&str>) -> Result<(), StoreError> {
    match seal_of(dir, file)? {
        Seal::Intact => Ok(()),
        Seal::Unsealed => Err(StoreError::Integrity {
            path: dir.join(CHECKSUMS),
            message: "missing: these results predate checksums and cannot be verified; run `slamlab run` on the study's spec to rewrite them (cached runs make it quick)".into(),
        }),
        Seal::Broken { path, message } => Err(StoreError::Integrity { path, message: format!("{message}; refusing to use it (recompute with `slamlab run`)") }),
    }
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<(), StoreError> {
    std::fs::write(path, bytes).map_err(|e| StoreError::io(path, e))
}

/// Distinguishes the temporary directories of concurrent writers within one process.
static WRITE_COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// Temporary directories older than this are left-overs of an interrupted write and removed.
const STALE_AFTER: std::time::Duration = std::time::Duration::from_secs(3600);

/// Fills a fresh temporary directory beside `dir`, then renames it into place (replacing an old
/// `dir`). Temporary names are unique per process and write, so concurrent writers never share
/// one; left-overs of interrupted writes (older than an hour) are removed.
pub fn write_dir_atomically(
    dir: &Path,
    fill: impl FnOnce(&Path) -> Result<(), StoreError>,
) -> Result<(), StoreError> {
    // A symbolic link (a study folder or `report --out` kept elsewhere) is followed: the folder it
    // points to is replaced, and the link stays valid. A dangling link is an error.
    let followed;
    let dir = if dir.symlink_metadata().is_ok_and(|m| m.file_type().is_symlink()) {
        followed = std::fs::canonicalize(dir).map_err(|e| {
            StoreError::io(dir, std::io::Error::new(e.kind(), format!("a link to nowhere: {e}")))
        })?;
        followed.as_path()
    } else {
        dir
    };
    let parent = dir.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let name = dir
        .file_name()
        .ok_or_else(|| StoreError::format(dir, "not a directory name"))?
        .to_string_lossy()
        .into_owned();
    std::fs::create_dir_all(parent).map_err(|e| StoreError::io(parent, e))?;
    remove_stale(parent, &name);
    // unique among the processes of every node writing to a shared filesystem (pids repeat across nodes)
    let unique = format!(
        "{}-{}-{}",
        host_tag(),
        std::process::id(),
        WRITE_COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    );
    let tmp = parent.join(format!(".{name}.tmp-{unique}"));
    std::fs::create_dir(&tmp).map_err(|e| StoreError::io(&tmp, e))?;
    if let Err(e) = fill(&tmp) {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    // Move whatever is at `dir` aside, then rename ours into place. A concurrent writer of the
    // same directory can slip in between the two renames; then try again (the last one wins —
    // concurrent writers of one directory write the same content).
    let mut last_error = None;
    for attempt in 0..SWAP_ATTEMPTS {
        let old = parent.join(format!(".{name}.old-{unique}-{attempt}"));
        let _ = std::fs::rename(dir, &old);
        let placed = std::fs::rename(&tmp, dir);
        let _ = std::fs::remove_dir_all(&old);
        match placed {
            Ok(()) => return Ok(()),
            Err(e) => last_error = Some(e),
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    Err(StoreError::io(dir, last_error.expect("at least one attempt")))
}

/// This machine's host name, reduced to `[A-Za-z0-9-]` (for temporary file names).
fn host_tag() -> &'static str {
    static TAG: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TAG.get_or_init(|| {
        let name = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_default();
        let tag: String = name
            .trim()
            .chars()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
            .take(40)
            .collect();
        if tag.is_empty() { "host".to_string() } else { tag }
    })
}

/// How often a directory swap is retried when concurrent writers race for it.
const SWAP_ATTEMPTS: usize = 100;

/// Removes `.{name}.tmp-*` / `.{name}.old-*` siblings that an interrupted write left behind.
fn remove_stale(parent: &Path, name: &str) {
    let prefixes = [format!(".{name}.tmp-"), format!(".{name}.old-")];
    for e in std::fs::read_dir(parent).into_iter().flatten().flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let old_enough = e
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| t.elapsed().ok())
            .is_some_and(|age| age > STALE_AFTER);
        if old_enough && prefixes.iter().any(|p| file.starts_with(p.as_str())) {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_labels_get_short_stable_distinct_file_names() {
        assert_eq!(short_name("bigloop2--fastslam1--base--r00"), "bigloop2--fastslam1--base--r00");
        let long = |i: u32| {
            format!(
                "bigloop2--fastslam1--{}--r00",
                (0..15)
                    .map(|k| format!("fastslam.param_{k}={}", i + k))
                    .collect::<Vec<_>>()
                    .join(",")
            )
        };
        let (a, b) = (short_name(&long(1)), short_name(&long(2)));
        assert!(a.len() <= MAX_NAME && b.len() <= MAX_NAME && a != b, "{a} {b}");
        assert!(a.starts_with("bigloop2--fastslam1--fastslam.param_0=1"));
        assert_eq!(a, short_name(&long(1)));
        // never cuts inside a character
        let accents = "é".repeat(100);
        assert!(short_name(&accents).len() <= MAX_NAME);
    }

    #[test]
    fn a_sealed_directory_detects_any_change_to_its_files() {
        let work = tempfile::tempdir().unwrap();
        let dir = work.path().join("study");
        write_dir_atomically(&dir, |tmp| {
            write_file(&tmp.join("runs.parquet"), b"rows")?;
            std::fs::create_dir(tmp.join("maps")).map_err(|e| StoreError::io(tmp, e))?;
            write_file(&tmp.join("maps/a.toml"), b"name = 'a'")?;
            seal(tmp)
        })
        .unwrap();
        assert_eq!(check_seal(&dir).unwrap(), Seal::Intact);
        assert!(verified(&dir, None).is_ok() && verified(&dir, Some("runs.parquet")).is_ok());
        // a file written beside them later is not the store's (the timing page)
        std::fs::write(dir.join("timings.html"), "<html>").unwrap();
        assert_eq!(check_seal(&dir).unwrap(), Seal::Intact);
        // one flipped bit
        std::fs::write(dir.join("maps/a.toml"), b"name = 'b'").unwrap();
        match check_seal(&dir).unwrap() {
            Seal::Broken { path, message } => assert!(
                path.ends_with("maps/a.toml") && message.contains("does not match"),
                "{message}"
            ),
            other => panic!("{other:?}"),
        }
        let err = verified(&dir, None).unwrap_err().to_string();
        assert!(err.contains("a.toml") && err.contains("refusing"), "{err}");
        // a read of another file hashes only that one; an unlisted file is refused
        assert!(verified(&dir, Some("runs.parquet")).is_ok());
        assert!(
            verified(&dir, Some("timings.html")).unwrap_err().to_string().contains("not listed")
        );
        // a missing file
        std::fs::write(dir.join("maps/a.toml"), b"name = 'a'").unwrap();
        std::fs::remove_file(dir.join("runs.parquet")).unwrap();
        assert!(
            matches!(check_seal(&dir).unwrap(), Seal::Broken { ref message, .. } if message.contains("missing"))
        );
        // no checksum file: written before checksums
        std::fs::remove_file(dir.join(CHECKSUMS)).unwrap();
        assert_eq!(check_seal(&dir).unwrap(), Seal::Unsealed);
        assert!(verified(&dir, None).unwrap_err().to_string().contains("predate checksums"));
    }

    fn row(id: &str, status: RunStatus) -> RunRow {
        RunRow {
            study: "s".into(),
            run_id: id.into(),
            map: "m".into(),
            algorithm: "odometry".into(),
            point: "base".into(),
            replicate: 3,
            world_seed: u64::MAX - 1,
            filter_seed: 42,
            status,
            error: (status == RunStatus::Failed).then(|| "boom".into()),
            run_hash: "ab".into(),
            params_hash: "cd".into(),
            code_version: "v".into(),
            params: vec![
                ("odometry.model".into(), ParamValue::Str("proportional".into())),
                ("odometry.k".into(), ParamValue::Float(0.1)),
                ("trajectory.laps".into(), ParamValue::Int(2)),
            ],
            metrics: if status == RunStatus::Failed {
                vec![]
            } else {
                vec![("ate_rmse_m".into(), 1.5), ("landmark_error_m".into(), f64::INFINITY)]
            },
        }
    }

    #[test]
    fn a_negative_metric_is_refused_on_read() {
        let good = vec![row("a", RunStatus::Ok), row("b", RunStatus::Failed)];
        assert!(in_range(Path::new("runs.parquet"), good.clone()).is_ok());
        let mut bad = good;
        bad[0].metrics.push(("ate_rmse_m".into(), -3.1e58));
        let err = in_range(Path::new("runs.parquet"), bad).unwrap_err().to_string();
        assert!(
            err.contains("runs.parquet")
                && err.contains("run a: ate_rmse_m = -31")
                && err.contains("negative"),
            "{err}"
        );
    }

    #[test]
    fn runs_round_trip_with_nulls_and_infinities() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![row("a", RunStatus::Ok), row("b", RunStatus::Failed)];
        let mut df = parquet::runs_frame(&rows).unwrap();
        let path = dir.path().join("runs.parquet");
        parquet::write(&path, &mut df).unwrap();
        assert_eq!(parquet::read_runs(&path).unwrap(), rows);
        let keys: Vec<(String, String, RunStatus)> =
            rows.iter().map(|r| (r.run_id.clone(), r.run_hash.clone(), r.status)).collect();
        assert_eq!(parquet::read_run_keys(&path).unwrap(), keys);
    }

    #[test]
    fn traces_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let t = |id: &str, n: usize| TraceRows {
            run_id: id.into(),
            dt_s: 0.1,
            truth: (0..n).map(|i| Pose2::new(i as f64, 0.5, 0.1)).collect(),
            estimate: (0..n).map(|i| Pose2::new(i as f64 + 0.25, 0.0, -0.1)).collect(),
            neff: if id == "a" {
                (0..n).map(|i| (i % 2 == 0).then_some(i as f64)).collect()
            } else {
                Vec::new()
            },
        };
        let traces = vec![t("a", 5), t("b", 3)];
        let mut df = parquet::traces_frame(&traces).unwrap();
        let path = dir.path().join("traces.parquet");
        parquet::write(&path, &mut df).unwrap();
        let back = parquet::read_traces(&path, &|_| true).unwrap();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0].truth, traces[0].truth);
        assert_eq!(back[1].estimate, traces[1].estimate);
        assert_eq!(back[0].neff, traces[0].neff);
        assert!(back[1].neff.iter().all(Option::is_none));
        assert!((back[0].dt_s - 0.1).abs() < 1e-12);
        assert_eq!(parquet::read_traces(&path, &|id| id == "b").unwrap().len(), 1);
        // a one-row run ending the file (its Δt is unknown: 0) — this read used to panic
        let mut df = parquet::traces_frame(&[t("a", 5), t("c", 1)]).unwrap();
        parquet::write(&path, &mut df).unwrap();
        let back = parquet::read_traces(&path, &|_| true).unwrap();
        assert_eq!((back[1].truth.len(), back[1].dt_s), (1, 0.0));
    }

    #[test]
    fn cache_round_trip_keeps_compute_time_apart() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::new(dir.path());
        assert!(!cache.contains("abcdef"));
        let landmarks = RunLandmarks {
            run_id: "a".into(),
            landmarks: vec![
                LandmarkRow::Line { rho_m: 1.0, theta_rad: -1.5 },
                LandmarkRow::Corner { x_m: 2.0, y_m: 3.0 },
            ],
        };
        let run = CachedRun {
            row: row("a", RunStatus::Ok),
            trace: TraceRows { neff: vec![], ..TraceRows::empty("a") },
            landmarks,
            matches: MatchRows::default(),
            wall_ms: 12.5,
        };
        cache.put("abcdef", &run, false).unwrap();
        assert!(cache.contains("abcdef"));
        let back = cache.get("abcdef").unwrap();
        assert_eq!(back.row, run.row);
        assert_eq!(back.wall_ms, 12.5);
        assert_eq!(back.landmarks, run.landmarks);
        // an existing entry is kept, unless replaced (forced recomputation)
        let newer = CachedRun { wall_ms: 99.0, ..run.clone() };
        cache.put("abcdef", &newer, false).unwrap();
        assert_eq!(cache.get("abcdef").unwrap().wall_ms, 12.5);
        cache.put("abcdef", &newer, true).unwrap();
        assert_eq!(cache.get("abcdef").unwrap().wall_ms, 99.0);
    }

    /// A cache entry's checksum list cannot be bypassed: deleted, emptied or missing a line, the
    /// entry is corrupt (recomputed), never trusted and resealed over a corrupt file.
    /// A study folder that lost a file it holds (an optional one such as `reference.csv`) is
    /// refused, naming it, never read as if the file had never been there.
    #[test]
    fn a_study_missing_a_listed_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        for f in ["manifest.json", "reference.csv", "diagnostics.json"] {
            std::fs::write(d.join(f), "x").unwrap();
        }
        seal(d).unwrap();
        assert!(listed_files_present(d).is_ok());
        std::fs::remove_file(d.join("reference.csv")).unwrap();
        let err = listed_files_present(d).unwrap_err().to_string();
        assert!(err.contains("reference.csv") && err.contains("missing"), "{err}");
        let err = read_study(d).unwrap_err().to_string();
        assert!(err.contains("reference.csv"), "{err}");
    }

    #[test]
    fn a_cache_entry_without_its_full_checksum_list_is_corrupt() {
        let dir = tempfile::tempdir().unwrap();
        let cache = Cache::new(dir.path());
        let run = CachedRun {
            row: row("a", RunStatus::Ok),
            trace: TraceRows { neff: vec![], ..TraceRows::empty("a") },
            landmarks: RunLandmarks { run_id: "a".into(), landmarks: Vec::new() },
            matches: MatchRows::default(),
            wall_ms: 1.0,
        };
        let entry = cache.entry("abcdef");
        let list = entry.join(CHECKSUMS);
        let corrupt = |what: &str| {
            assert!(
                matches!(cache.lookup("abcdef"), Lookup::Corrupt(_)),
                "{what}: the entry was trusted"
            );
        };
        let fresh = || cache.put("abcdef", &run, true).unwrap();
        fresh();
        assert!(matches!(cache.lookup("abcdef"), Lookup::Hit(_)));
        std::fs::remove_file(&list).unwrap();
        corrupt("checksum list deleted");
        fresh();
        std::fs::write(&list, "").unwrap();
        corrupt("checksum list emptied");
        fresh();
        let text = std::fs::read_to_string(&list).unwrap();
        let kept: String = text
            .lines()
            .filter(|l| !l.ends_with("trace.parquet"))
            .map(|l| format!("{l}\n"))
            .collect();
        std::fs::write(&list, kept).unwrap();
        corrupt("trace.parquet's line removed");
        fresh();
        std::fs::write(entry.join("extra.parquet"), b"x").unwrap();
        corrupt("an unlisted file in the entry");
    }

    /// A symlinked output folder is followed: its target is replaced, the link stays a link.
    #[test]
    fn a_symlinked_folder_is_followed_not_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("elsewhere/reports");
        std::fs::create_dir_all(&target).unwrap();
        std::fs::write(target.join("old.txt"), "old").unwrap();
        let link = dir.path().join("reports");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_dir_atomically(&link, |tmp| write_file(&tmp.join("new.txt"), b"new")).unwrap();
        assert!(link.symlink_metadata().unwrap().file_type().is_symlink(), "the link was replaced");
        assert_eq!(std::fs::read_to_string(target.join("new.txt")).unwrap(), "new");
        assert!(!target.join("old.txt").exists());
        // a link to nowhere is refused
        let dangling = dir.path().join("dangling");
        std::os::unix::fs::symlink(dir.path().join("nowhere"), &dangling).unwrap();
        assert!(write_dir_atomically(&dangling, |_| Ok(())).is_err());
    }

    #[test]
    fn concurrent_writers_of_one_entry_leave_one_complete_entry() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("entry");
        std::thread::scope(|s| {
            for i in 0..8 {
                let target = &target;
                s.spawn(move || {
                    write_dir_atomically(target, |t| {
                        write_file(&t.join("x"), format!("{i}").as_bytes())
                    })
                    .unwrap()
                });
            }
        });
        assert!(target.join("x").is_file());
        let names: Vec<_> =
            std::fs::read_dir(dir.path()).unwrap().flatten().map(|e| e.file_name()).collect();
        assert_eq!(
            names,
            vec![std::ffi::OsString::from("entry")],
            "no temporary directory left behind"
        );
    }

    #[test]
    fn failed_atomic_write_leaves_the_old_directory() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("study");
        write_dir_atomically(&target, |t| write_file(&t.join("a"), b"1")).unwrap();
        let err = write_dir_atomically(&target, |t| {
            write_file(&t.join("a"), b"2")?;
            Err(StoreError::format(t, "interrupted"))
        });
        assert!(err.is_err());
        assert_eq!(std::fs::read(target.join("a")).unwrap(), b"1");
        let leftovers: Vec<_> =
            std::fs::read_dir(dir.path()).unwrap().flatten().map(|e| e.file_name()).collect();
        assert_eq!(leftovers.len(), 1, "{leftovers:?}");
    }
}
