//! [`LoadedSpec`] → [`ExperimentPlan`]: the sweep points (deduplicated, with the plot groups they
//! belong to), the maps (read and hashed), and one [`RunSpec`] per (map, algorithm, point,
//! replicate) with its seeds, readable id and content hash.
//!
//! Seeds come from (study seed, map, replicate) only — never from the swept value or the
//! algorithm — so every point and algorithm of a study sees the same worlds (paired comparisons).

use crate::algo::{Algorithm, AlgorithmId};
use crate::dataset::DatasetSpec;
use crate::metrics::METRICS_VERSION;
use crate::scenario::Scenario;
use crate::spec::{InputErrors, LoadedSpec, Params, SpecError, SweepKind};
use crate::store::{ClaimCells, reference as reference_file};
use crate::world::WORLD_CODE_VERSION;
use crate::world::map::Map;
use serde::Serialize;
use std::path::{Path, PathBuf};

pub mod cost;
pub mod design;
pub mod shard;

/// Version of the results schema (`runs.parquet`, `traces.parquet`): part of every content hash.
pub const SCHEMA_VERSION: &str = "results-2";

/// A map a study uses, with the exact bytes that were hashed.
#[derive(Debug, Clone)]
pub struct MapEntry {
    pub name: String,
    pub path: PathBuf,
    pub text: String,
    /// blake3 of the file's bytes (for a dataset map, followed by every data file's bytes).
    pub hash: String,
    /// The map (a dataset's map has a name, title and notes, no route).
    pub map: Map,
    /// How to read a real dataset (`None` for a simulated world).
    pub dataset: Option<DatasetSpec>,
    /// A dataset map whose data files are absent: why (the study is skipped, not failed).
    pub missing_data: Option<String>,
}

impl MapEntry {
    /// Point-landmark world (point landmarks, or a dataset of them) or laser world.
    pub fn world_kind(&self) -> crate::world::WorldKind {
        match &self.dataset {
            Some(d) => d.world_kind(),
            None => self.map.world_kind(),
        }
    }
}

/// A set of points plotted together: x is `params[0]`; further params (grid/zip) split or label
/// the series.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepGroup {
    pub kind: SweepKind,
    pub params: Vec<String>,
    /// The group's points are named cells (a zip sweep with `labels`).
    pub named: bool,
    /// A morris / sobol group: the sweep point of each design row.
    pub design: Option<crate::store::DesignRecord>,
}

/// One parameter set of the study.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepPoint {
    /// `base`, or the assignments, e.g. `odometry.k=0.05`.
    pub label: String,
    pub assignments: Vec<(String, toml::Value)>,
    pub params: Params,
    /// Indices into [`ExperimentPlan::groups`].
    pub groups: Vec<usize>,
}

/// One run: everything needed to compute it, and its identity.
#[derive(Debug, Clone, PartialEq)]
pub struct RunSpec {
    /// `<map>--<algorithm>--<point label>--r<replicate>`: stable and readable.
    pub run_id: String,
    pub map: usize,
    pub point: usize,
    pub algorithm: AlgorithmId,
    pub replicate: u32,
    pub world_seed: u64,
    pub filter_seed: u64,
    /// Hash of the inputs (parameters read, map bytes, seeds).
    pub params_hash: String,
    /// Versions of the code that computes the run (shared by the runs of one map and algorithm).
    pub code_version: std::sync::Arc<str>,
    /// Content hash of everything the run reads: the cache key.
    pub hash: String,
}

#[derive(Debug, Clone)]
pub struct ExperimentPlan {
    pub spec: LoadedSpec,
    pub maps: Vec<MapEntry>,
    pub groups: Vec<SweepGroup>,
    pub points: Vec<SweepPoint>,
    pub runs: Vec<RunSpec>,
    /// The cells each claim refers to.
    pub claims: Vec<ClaimCells>,
    /// The reference rows of `[report] reference` (header + that experiment's lines, verbatim).
    pub reference: Option<String>,
    /// The sweep point label of each `[[report.landmark_reference]]`, in order.
    pub landmark_points: Vec<String>,
    /// The published result items a sequential study stages (`[sequential] items`): those this
    /// study answers by published cells.
    pub items: Vec<crate::spec::items::Item>,
}

impl ExperimentPlan {
    pub fn id(&self) -> &str {
        &self.spec.spec.id
    }

    /// The algorithm of `run`.
    pub fn algorithm(&self, run: &RunSpec) -> &dyn Algorithm {
        self.spec.catalogue.algorithm(&run.algorithm)
    }

    /// Whether the study lists a scan matcher (its results then carry match diagnostics).
    pub fn has_scan_matcher(&self) -> bool {
        self.spec.spec.algorithms.iter().any(|a| self.spec.catalogue.algorithm(a).is_scan_matcher())
    }
}

/// Derives a 64-bit seed from (study seed, map, replicate, stream name).
pub fn derive_seed(study_seed: u64, map: &str, replicate: u32, stream: &str) -> u64 {
    let mut h = blake3::Hasher::new();
    h.update(b"slamlab-seed-v1\0");
    h.update(&study_seed.to_le_bytes());
    h.update(map.as_bytes());
    h.update(b"\0");
    h.update(&replicate.to_le_bytes());
    h.update(stream.as_bytes());
    u64::from_le_bytes(h.finalize().as_bytes()[..8].try_into().expect("8 bytes"))
}

/// The largest plan `build` expands (runs); `build_limited` takes another (`--max-runs`).
pub const DEFAULT_MAX_RUNS: u64 = 1_000_000;

/// Expands a validated spec, reading its maps from `maps_dir` (at most [`DEFAULT_MAX_RUNS`] runs).
pub fn build(spec: LoadedSpec, maps_dir: &Path) -> Result<ExperimentPlan, InputErrors> {
    build_limited(spec, maps_dir, DEFAULT_MAX_RUNS)
}

/// Runs a spec would expand to, counted before expanding anything (saturating): sweep points
/// (one-at-a-time: the sum of the lists; grid: their product; zip: the list length; duplicates
/// counted; morris: trajectories × (d + 1); sobol: samples × (d + 2)) × maps × algorithms ×
/// replicates (a sequential study's whole budget).
pub fn planned_runs(spec: &LoadedSpec) -> u64 {
    let points = if spec.sweeps.is_empty() {
        1u64
    } else {
        spec.sweeps.iter().fold(0u64, |acc, block| {
            let lens = block.params.iter().map(|p| p.values.len() as u64);
            let d = block.design.as_ref().map_or(0, |d| d.params.len() as u64);
            let n = match (block.kind, &block.design) {
                (SweepKind::OneAtATime, _) => lens.sum(),
                (SweepKind::Grid, _) => lens.fold(1u64, u64::saturating_mul),
                (SweepKind::Zip, _) => lens.max().unwrap_or(0),
                (SweepKind::Morris, Some(g)) => (g.trajectories as u64).saturating_mul(d + 1),
                (SweepKind::Sobol, Some(g)) => (g.samples as u64).saturating_mul(d + 2),
                (_, None) => 0,
            };
            acc.saturating_add(n)
        })
    };
    [
        spec.spec.maps.len() as u64,
        spec.spec.algorithms.len() as u64,
        u64::from(spec.spec.replicate_budget()),
    ]
    .into_iter()
    .fold(points, u64::saturating_mul)
}

/// [`build`] with a limit on the number of runs: a larger spec is an error (naming the number and
/// how to raise the limit) before anything is expanded.
pub fn build_limited(
    spec: LoadedSpec,
    maps_dir: &Path,
    max_runs: u64,
) -> Result<ExperimentPlan, InputErrors> {
    build_observed(spec, maps_dir, max_runs, &|_, _, _| {})
}

/// What expansion is doing, for [`build_observed`]'s progress calls.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Resolving and checking sweep points.
    Points,
    /// Naming and hashing runs.
    Runs,
}

impl Stage {
    pub fn as_str(self) -> &'static str {
        match self {
            Stage::Points => "sweep points resolved and checked",
            Stage::Runs => "runs named and hashed",
        }
    }
}

/// The most sweep-point errors a spec reports one by one (the rest are counted).
const MAX_POINT_ERRORS: usize = 20;

/// Items between two progress calls.
const PROGRESS_EVERY: usize = 4096;

/// [`build_limited`], calling `progress(stage, done, total)` every few thousand points and runs
/// (the caller decides what to show, and when).
pub fn build_observed(
    spec: LoadedSpec,
    maps_dir: &Path,
    max_runs: u64,
    progress: &dyn Fn(Stage, usize, usize),
) -> Result<ExperimentPlan, InputErrors> {
    let planned = planned_runs(&spec);
    if planned > max_runs {
        let key = if spec.sweeps.is_empty() { "replicates" } else { "sweeps" };
        let message = format!(
            "this spec expands to {planned} runs (sweep points × {} maps × {} algorithms × {} replicates), more than the limit of {max_runs}; reduce it, or raise the limit with --max-runs",
            spec.spec.maps.len(),
            spec.spec.algorithms.len(),
            spec.spec.replicate_budget()
        );
        return Err(SpecError::new(&spec.path, vec![spec.error_at(key, message)]).into());
    }
    let mut errors = Vec::new();
    let maps = load_maps(&spec, maps_dir, &mut errors);
    // The sensors the study simulates, from its algorithms and its maps' world kinds: a sensor rate
    // must fit the clock only where that sensor is simulated.
    let kinds: Vec<crate::world::WorldKind> = maps.iter().map(MapEntry::world_kind).collect();
    let sensors = spec.catalogue.sensors(&spec.spec.algorithms, &kinds);
    // An algorithm that reads landmark readings needs a world that has landmarks to read (an
    // external program can ask for them on a laser world, where it would see none).
    let mut blind = Vec::new();
    for (i, id) in spec.spec.algorithms.iter().enumerate() {
        for m in maps.iter().filter(|m| m.world_kind() == crate::world::WorldKind::Laser) {
            if spec.catalogue.algorithm(id).sensors(m.world_kind()).landmarks {
                blind.push(spec.error_at(
                    &format!("algorithms[{i}]"),
                    format!("`{id}` reads landmark readings, but map `{}` is a laser world (no point landmarks): it would see none", m.name),
                ));
            }
        }
    }
    if !blind.is_empty() {
        errors.push(SpecError::new(&spec.path, blind));
    }
    let base_errors: Vec<_> = spec
        .spec
        .base
        .validate(sensors)
        .into_iter()
        .map(|v| spec.error_at(&format!("base.{}", v.key), v.message))
        .collect();
    if !base_errors.is_empty() {
        errors.push(SpecError::new(&spec.path, base_errors));
    }
    let (groups, points, texts) = match expand(&spec, sensors, progress) {
        Ok(x) => x,
        Err(e) => {
            errors.push(e);
            (Vec::new(), Vec::new(), SweptTexts::of(&spec))
        }
    };
    // Walls given in bitmap pixels need each laser map's bitmap scale (else every run would fail).
    if sensors.laser && points.iter().any(|p| p.params.laser.wall_thickness_px > 0.0) {
        let unscaled: Vec<_> = spec.spec.maps.iter().enumerate().filter(|(_, name)| maps.iter().any(|m| &&m.name == name && m.world_kind() == crate::world::WorldKind::Laser && m.map.bitmap_m_per_px.is_none())).map(|(i, name)| spec.error_at(&format!("maps[{i}]"), format!("map `{name}` states no bitmap_m_per_px, which laser.wall_thickness_px needs"))).collect();
        if !unscaled.is_empty() {
            errors.push(SpecError::new(&spec.path, unscaled));
        }
    }
    if !errors.is_empty() {
        return Err(InputErrors(errors));
    }
    let claims = match claim_cells(&spec, &points) {
        Ok(c) => c,
        Err(e) => return Err(e.into()),
    };
    let reference = match reference(&spec) {
        Ok(r) => r,
        Err(e) => return Err(e.into()),
    };
    let items = match staged_items(&spec) {
        Ok(i) => i,
        Err(e) => return Err(e.into()),
    };
    let mut landmark_points = Vec::new();
    for (i, r) in spec.spec.report.landmark_reference.iter().enumerate() {
        match find_point(&spec, &points, &r.at, &format!("report.landmark_reference[{i}].at")) {
            Ok(p) => landmark_points.push(points[p].label.clone()),
            Err(e) => return Err(SpecError::new(&spec.path, vec![e]).into()),
        }
    }
    for (i, c) in spec.spec.report.contrasts.iter().enumerate() {
        for (j, pair) in c.pairs.iter().enumerate() {
            if let Some(name) = pair.iter().find(|n| !points.iter().any(|p| &p.label == *n)) {
                let known: Vec<&str> = points.iter().map(|p| p.label.as_str()).collect();
                let msg =
                    format!("no sweep point `{name}` (the study's points: {})", known.join(", "));
                return Err(SpecError::new(
                    &spec.path,
                    vec![spec.error_at(&format!("report.contrasts[{i}].pairs[{j}]"), msg)],
                )
                .into());
            }
        }
    }
    let runs = runs(&spec, &maps, &points, &texts, progress);
    let mut ids: Vec<&str> = runs.iter().map(|r| r.run_id.as_str()).collect();
    ids.sort_unstable();
    if let Some(w) = ids.windows(2).find(|w| w[0] == w[1]) {
        return Err(SpecError::new(
            &spec.path,
            vec![
                spec.error_at(
                    "sweeps",
                    format!("two sweep points give the same run id `{}`", w[0]),
                ),
            ],
        )
        .into());
    }
    Ok(ExperimentPlan {
        spec,
        maps,
        groups,
        points,
        runs,
        claims,
        reference,
        landmark_points,
        items,
    })
}

fn load_maps(spec: &LoadedSpec, maps_dir: &Path, errors: &mut Vec<SpecError>) -> Vec<MapEntry> {
    let mut out = Vec::new();
    for (i, name) in spec.spec.maps.iter().enumerate() {
        let path = maps_dir.join(format!("{name}.toml"));
        let read = crate::spec::read_text_bounded(
            &path,
            crate::spec::MAX_MAP_BYTES,
            "the most a map file may be",
        );
        let text = match read {
            Ok(t) => t,
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                errors.push(SpecError::new(
                    &spec.path,
                    vec![spec.error_at(
                        &format!("maps[{i}]"),
                        format!("map `{name}`: cannot read {}: {e}", path.display()),
                    )],
                ));
                continue;
            }
            Err(_) => {
                let available = available_maps(maps_dir);
                let msg = format!(
                    "no map `{name}`: {} does not exist (available in {}: {})",
                    path.display(),
                    maps_dir.display(),
                    if available.is_empty() { "none".into() } else { available.join(", ") }
                );
                errors.push(SpecError::new(
                    &spec.path,
                    vec![spec.error_at(&format!("maps[{i}]"), msg)],
                ));
                continue;
            }
        };
        match Scenario::from_toml(&text) {
            Ok(Scenario { map, dataset }) if map.name == *name => {
                let mut hasher = blake3::Hasher::new();
                hasher.update(text.as_bytes());
                let mut missing_data = None;
                for f in dataset.iter().flat_map(|d| d.files(Path::new("."))) {
                    match std::fs::read(&f) {
                        Ok(bytes) => {
                            hasher.update(&bytes);
                        }
                        Err(e) => {
                            missing_data = Some(format!(
                                "cannot read {} ({e}): the real datasets are read from ../shared/data next to the repository, or from the `path` in {}",
                                f.display(),
                                path.display()
                            ));
                            break;
                        }
                    }
                }
                let hash = hasher.finalize().to_hex().to_string();
                out.push(MapEntry {
                    name: name.clone(),
                    path,
                    text,
                    hash,
                    map,
                    dataset,
                    missing_data,
                });
            }
            Ok(other) => errors.push(SpecError::new(
                &path,
                vec![crate::source::SourceError::at_key(
                    &crate::source::Locator::new(&text),
                    "name",
                    format!("is `{}` but the file is {name}.toml", other.map.name),
                )],
            )),
            Err(e) => errors.push(SpecError::new(&path, e)),
        }
    }
    out
}

/// Names of the `*.toml` files in `dir`, sorted.
pub fn available_maps(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            e.path()
                .file_stem()
                .filter(|_| e.path().extension().is_some_and(|x| x == "toml"))
                .map(|s| s.to_string_lossy().into_owned())
        })
        .collect();
    names.sort();
    names
}

/// Sweep blocks → groups and deduplicated points (in first-appearance order).
/// The TOML text of the sections the sweeps set, per sweep point: the points' deduplication key,
/// and (with the base's texts of the other sections) the text their runs hash. Each distinct
/// section state's text is held once; a point holds an index per swept section.
struct SweptTexts {
    /// The sections any sweep sets, in declaration order: every other section is the base's in
    /// every point.
    sections: Vec<&'static str>,
    /// The section texts (the base's first, one per swept section).
    texts: Vec<String>,
    /// Per text, a hash of it with −0 written as 0 (−0 and 0 are equal parameters).
    keys: Vec<u64>,
    /// Per point, `sections.len()` indices into `texts`.
    ids: Vec<u32>,
}

impl SweptTexts {
    fn of(spec: &LoadedSpec) -> Self {
        let mut paths: Vec<&str> = Vec::new();
        for block in &spec.sweeps {
            paths.extend(block.params.iter().map(|p| p.path.as_str()));
            if let Some(d) = &block.design {
                paths.extend(d.params.iter().map(|p| p.path.as_str()));
                paths.extend(d.tied.iter().map(|(p, _)| p.as_str()));
            }
        }
        let sections: Vec<&'static str> = crate::params::SECTIONS
            .iter()
            .copied()
            .filter(|s| paths.iter().any(|p| p.split('.').next() == Some(*s)))
            .collect();
        let mut texts =
            Self { sections: Vec::new(), texts: Vec::new(), keys: Vec::new(), ids: Vec::new() };
        for s in &sections {
            texts.add(spec.spec.base.section_text(s));
        }
        texts.sections = sections;
        texts
    }

    /// Holds `text`; its index.
    fn add(&mut self, text: String) -> u32 {
        let normalised = text.replace("= -0.0\n", "= 0.0\n");
        let hash = blake3::hash(normalised.as_bytes());
        self.keys.push(u64::from_le_bytes(hash.as_bytes()[..8].try_into().expect("8 bytes")));
        self.texts.push(text);
        u32::try_from(self.texts.len() - 1).expect("fewer than 2³² section states")
    }

    /// The deduplication key of a point with these text indices: equal parameters, equal keys
    /// (the parameters themselves are compared on a match).
    fn key(&self, ids: &[u32]) -> u64 {
        let mut h = blake3::Hasher::new();
        for &i in ids {
            h.update(&self.keys[i as usize].to_le_bytes());
        }
        u64::from_le_bytes(h.finalize().as_bytes()[..8].try_into().expect("8 bytes"))
    }

    /// The text of point `point`'s swept section number `i`.
    fn text(&self, point: usize, i: usize) -> &str {
        &self.texts[self.ids[point * self.sections.len() + i] as usize]
    }
}

fn expand(
    spec: &LoadedSpec,
    sensors: crate::world::Sensors,
    progress: &dyn Fn(Stage, usize, usize),
) -> Result<(Vec<SweepGroup>, Vec<SweepPoint>, SweptTexts), SpecError> {
    // Each candidate: assignments with, for error placement, the key of each value.
    type Candidate = Vec<(String, toml::Value, String)>;
    let mut groups = Vec::new();
    // (assignments, group, name of a named cell)
    let mut candidates: Vec<(Candidate, usize, Option<String>)> = Vec::new();
    if spec.sweeps.is_empty() {
        groups.push(SweepGroup {
            kind: SweepKind::OneAtATime,
            params: Vec::new(),
            named: false,
            design: None,
        });
        candidates.push((Vec::new(), 0, None));
    }
    // A design's ranges are checked at their bounds first: an invalid bound is reported once, at
    // the bound, instead of once per sampled point that happens to fall outside the domain.
    let mut resolver = Resolver::new(spec, sensors);
    let mut bound_errors = Vec::new();
    // a tied parameter's values are blamed on its own `tied` entry
    let tied_key =
        |bi: usize, path: &str| crate::source::join_key(&format!("sweeps[{bi}].tied"), path);
    for (bi, block) in spec.sweeps.iter().enumerate() {
        let Some(d) = &block.design else { continue };
        for p in &d.params {
            for (end, u) in [("lower", 0.0), ("upper", 1.0)] {
                let (value, coord) = design::realise(p, u);
                if !coord.is_finite() || value.as_float().is_some_and(|v| !v.is_finite()) {
                    bound_errors.push(spec.error_at(
                        &p.key,
                        format!(
                            "the range's {end} bound gives a design coordinate that is not finite"
                        ),
                    ));
                    continue;
                }
                let mut at_bound: Candidate = vec![(p.path.clone(), value.clone(), p.key.clone())];
                for (path, j) in &d.tied {
                    if d.params[*j].path == p.path {
                        at_bound.push((path.clone(), value.clone(), tied_key(bi, path)));
                    }
                }
                if let Err(errs) = resolver.resolve(&at_bound) {
                    bound_errors.extend(errs.into_iter().map(|e| crate::source::SourceError {
                        message: format!(
                            "at the range's {end} bound, {}: {}",
                            format_value(&value),
                            e.message
                        ),
                        ..e
                    }));
                }
            }
        }
    }
    if !bound_errors.is_empty() {
        return Err(SpecError::new(&spec.path, bound_errors));
    }
    for (bi, block) in spec.sweeps.iter().enumerate() {
        if let Some(d) = &block.design {
            let unit = design::unit_rows(
                block.kind,
                d,
                derive_seed(spec.spec.seed, "sweeps", bi as u32, "design"),
            );
            let kind = if block.kind == SweepKind::Morris { "morris" } else { "sobol" };
            let mut realised = Vec::with_capacity(unit.rows.len());
            for (row, u) in unit.rows.iter().enumerate() {
                let (values, coords): (Vec<toml::Value>, Vec<f64>) =
                    d.params.iter().zip(u).map(|(p, &x)| design::realise(p, x)).unzip();
                let mut assignments: Candidate = d
                    .params
                    .iter()
                    .zip(&values)
                    .map(|(p, v)| (p.path.clone(), v.clone(), p.key.clone()))
                    .collect();
                for (path, j) in &d.tied {
                    assignments.push((path.clone(), values[*j].clone(), tied_key(bi, path)));
                }
                candidates.push((assignments, groups.len(), Some(format!("{kind}{bi}-{row:04}"))));
                realised.push(coords);
            }
            // Morris divides by the realised steps: it keeps each row's realised coordinates
            let unit_coords = if block.kind == SweepKind::Morris { realised } else { Vec::new() };
            groups.push(SweepGroup {
                kind: block.kind,
                params: d.params.iter().map(|p| p.path.clone()).collect(),
                named: false,
                design: Some(crate::store::DesignRecord {
                    size: unit.size,
                    rows: Vec::new(),
                    moved: unit.moved,
                    unit: unit_coords,
                    delta: unit.delta,
                }),
            });
            continue;
        }
        let at = |p: &crate::spec::SweptParam, i: usize| {
            (p.path.clone(), p.values[i].clone(), format!("{}[{i}]", p.key))
        };
        match block.kind {
            SweepKind::OneAtATime => {
                for p in &block.params {
                    groups.push(SweepGroup {
                        kind: block.kind,
                        params: vec![p.path.clone()],
                        named: false,
                        design: None,
                    });
                    for i in 0..p.values.len() {
                        candidates.push((vec![at(p, i)], groups.len() - 1, None));
                    }
                }
            }
            SweepKind::Grid => {
                groups.push(SweepGroup {
                    kind: block.kind,
                    params: block.params.iter().map(|p| p.path.clone()).collect(),
                    named: false,
                    design: None,
                });
                let mut combos: Vec<Candidate> = vec![Vec::new()];
                for p in &block.params {
                    combos = combos
                        .into_iter()
                        .flat_map(|c| {
                            (0..p.values.len()).map(move |i| [c.clone(), vec![at(p, i)]].concat())
                        })
                        .collect();
                }
                candidates.extend(combos.into_iter().map(|c| (c, groups.len() - 1, None)));
            }
            SweepKind::Zip => {
                groups.push(SweepGroup {
                    kind: block.kind,
                    params: block.params.iter().map(|p| p.path.clone()).collect(),
                    named: !block.labels.is_empty(),
                    design: None,
                });
                for i in 0..block.params[0].values.len() {
                    candidates.push((
                        block.params.iter().map(|p| at(p, i)).collect(),
                        groups.len() - 1,
                        block.labels.get(i).cloned(),
                    ));
                }
            }
            SweepKind::Morris | SweepKind::Sobol => {
                unreachable!("a design block without its design was rejected by the spec check")
            }
        }
    }

    let mut points: Vec<SweepPoint> = Vec::new();
    let mut texts = SweptTexts::of(spec);
    // resolved parameters (a hash of the swept sections' texts) → indices in `points`: one lookup
    // per candidate
    let mut seen: std::collections::HashMap<u64, Vec<usize>> = std::collections::HashMap::new();
    let mut errors = Vec::new();
    let total = candidates.len();
    for (done, (assignments, group, name)) in candidates.into_iter().enumerate() {
        if done % PROGRESS_EVERY == 0 {
            progress(Stage::Points, done, total);
        }
        let (params, ids) = match resolver.resolve_point(&assignments, &mut texts) {
            Ok(p) => p,
            Err(e) => {
                errors.extend(e);
                continue;
            }
        };
        // TOML spells ±inf and NaN apart (JSON would not); equal texts are equal parameters,
        // checked anyway (−0 and 0 are equal parameters: one key). Only the swept sections can
        // differ from the base.
        let key = texts.key(&ids);
        let same =
            seen.get(&key).into_iter().flatten().copied().find(|&i| points[i].params == params);
        if let Some(i) = same {
            let existing = &mut points[i];
            if !existing.groups.contains(&group) {
                existing.groups.push(group);
            }
            if let Some(d) = &mut groups[group].design {
                d.rows.push(existing.label.clone());
            }
            continue;
        }
        if let Some(d) = &mut groups[group].design {
            d.rows.push(name.clone().expect("design rows are named"));
        }
        seen.entry(key).or_default().push(points.len());
        texts.ids.extend(ids);
        let label = if let Some(name) = name {
            name
        } else if assignments.is_empty() {
            "base".to_string()
        } else {
            // one allocation, sized up front (growing strings is what a plan of 10⁶ points
            // spends its time on)
            let mut label = String::with_capacity(
                assignments.iter().map(|(p, ..)| p.len() + 2 + LABEL_VALUE_CHARS).sum(),
            );
            for (i, (p, v, _)) in assignments.iter().enumerate() {
                use std::fmt::Write as _;
                let sep = if i == 0 { "" } else { "," };
                match v {
                    toml::Value::String(t) => write!(label, "{sep}{p}={t}"),
                    other => write!(label, "{sep}{p}={}", FormattedValue(other)),
                }
                .expect("writing to a String");
            }
            label
        };
        points.push(SweepPoint {
            label,
            assignments: assignments.into_iter().map(|(p, v, _)| (p, v)).collect(),
            params,
            groups: vec![group],
        });
    }
    if !errors.is_empty() {
        // The same bad value can make several points invalid: report it once.
        let mut reported = std::collections::HashSet::new();
        let mut unique: Vec<crate::source::SourceError> = errors
            .into_iter()
            .filter(|e| reported.insert((e.line, e.column, e.key.clone(), e.message.clone())))
            .collect();
        // A long sweep can fail at every value: the first few say what is wrong, and the count
        // says how often.
        if unique.len() > MAX_POINT_ERRORS {
            let more = unique.len() - MAX_POINT_ERRORS;
            unique.truncate(MAX_POINT_ERRORS);
            let last = unique.last().expect("errors were reported").clone();
            unique.push(crate::source::SourceError {
                message: format!(
                    "and {more} more errors in this spec's sweep values (the first {MAX_POINT_ERRORS} are shown)"
                ),
                ..last
            });
        }
        return Err(SpecError::new(&spec.path, unique));
    }
    Ok((groups, points, texts))
}

/// `[base]` with the assignments applied, deserialised and validated; errors point at the
/// sweep value responsible.
/// Resolves sweep points: the base parameters with a point's assignments. Only the sections the
/// assignments touch are rebuilt from TOML (from the base's own sections, serialised once), so a
/// point costs its sections, not the whole parameter set.
struct Resolver<'s> {
    spec: &'s LoadedSpec,
    sensors: crate::world::Sensors,
    /// The resolved base as a table (every default written out), so `odometry.k` can be swept
    /// when `[base.odometry]` was left to its defaults.
    base: toml::Table,
    /// Sections already resolved, by section and the assignments that set it: that section (in
    /// otherwise default parameters) and its text's index in [`SweptTexts`]. A grid over
    /// parameters of different sections resolves each section state once, not once per point.
    memo: std::collections::HashMap<Vec<u8>, (Params, u32)>,
}

/// The most section states a [`Resolver`] keeps (a grid within one section has one per point).
const MEMO_LIMIT: usize = 1 << 16;

impl<'s> Resolver<'s> {
    fn new(spec: &'s LoadedSpec, sensors: crate::world::Sensors) -> Self {
        Self {
            spec,
            sensors,
            base: spec.spec.base.to_table(),
            memo: std::collections::HashMap::new(),
        }
    }

    /// [`Resolver::resolve`], and the index of each swept section's text in `texts`, each section
    /// state resolved once.
    fn resolve_point(
        &mut self,
        assignments: &[(String, toml::Value, String)],
        texts: &mut SweptTexts,
    ) -> Result<(Params, Vec<u32>), Vec<crate::source::SourceError>> {
        let mut params = self.spec.spec.base.clone();
        // the base's texts come first
        let mut ids: Vec<u32> = (0..texts.sections.len() as u32).collect();
        let mut sections: Vec<&str> = Vec::new();
        for (path, ..) in assignments {
            let section = path.split('.').next().unwrap_or(path);
            if !sections.contains(&section) {
                sections.push(section);
            }
        }
        for section in sections {
            let mine: Vec<&(String, toml::Value, String)> =
                assignments.iter().filter(|(p, ..)| p.split('.').next() == Some(section)).collect();
            let key = state_key(section, &mine);
            if !self.memo.contains_key(&key) {
                let owned: Vec<_> = mine.iter().map(|a| (*a).clone()).collect();
                let Ok(alone) = self.resolve_sections(&owned) else {
                    // the whole point's resolution names the culprits
                    return self.resolve(assignments).map(|p| {
                        let ids = texts.sections.clone();
                        let ids = ids.iter().map(|s| texts.add(p.section_text(s))).collect();
                        (p, ids)
                    });
                };
                let text = texts.add(alone.section_text(section));
                if self.memo.len() >= MEMO_LIMIT {
                    self.memo.clear();
                }
                self.memo.insert(key.clone(), (alone, text));
            }
            let (alone, text) = &self.memo[&key];
            let known = params.copy_section(alone, section);
            debug_assert!(known, "an unknown section does not deserialise");
            if let Some(i) = texts.sections.iter().position(|s| *s == section) {
                ids[i] = *text;
            }
        }
        let violations = params.validate(self.sensors);
        if violations.is_empty() {
            return Ok((params, ids));
        }
        Err(self.placed(assignments, violations))
    }

    /// The sections `assignments` touch, rebuilt from the base's with the assignments applied (in
    /// otherwise default parameters).
    fn resolve_sections(
        &self,
        assignments: &[(String, toml::Value, String)],
    ) -> Result<Params, toml::de::Error> {
        let mut table = toml::Table::new();
        for (path, ..) in assignments {
            let section = path.split('.').next().unwrap_or(path);
            if let Some(v) = self.base.get(section)
                && !table.contains_key(section)
            {
                table.insert(section.to_string(), v.clone());
            }
        }
        // Switching a tagged section's `model` starts that section afresh: the other variant's
        // fields would not apply. Its new fields come from the other assignments.
        for (path, value, _) in assignments {
            if let Some(section) = path.strip_suffix(".model")
                && get_path(&table, path) != Some(value)
            {
                let mut fresh = toml::Table::new();
                fresh.insert("model".into(), value.clone());
                set_path(&mut table, section, toml::Value::Table(fresh));
            }
        }
        for (path, value, _) in assignments {
            set_path(&mut table, path, value.clone());
        }
        toml::Value::Table(table).try_into()
    }

    /// Range violations placed at the sweep value that set the key, else at the first assignment.
    fn placed(
        &self,
        assignments: &[(String, toml::Value, String)],
        violations: Vec<crate::config::Violation>,
    ) -> Vec<crate::source::SourceError> {
        violations
            .into_iter()
            .map(|v| {
                let key = assignments
                    .iter()
                    .find(|(p, ..)| *p == v.key)
                    .or(assignments.first())
                    .map(|(_, _, k)| k.as_str())
                    .unwrap_or("sweeps");
                self.spec.error_at(key, format!("`{}` {}", v.key, v.message))
            })
            .collect()
    }

    fn resolve(
        &self,
        assignments: &[(String, toml::Value, String)],
    ) -> Result<Params, Vec<crate::source::SourceError>> {
        let spec = self.spec;
        if assignments.is_empty() {
            return Ok(spec.spec.base.clone());
        }
        let mut touched: Vec<&str> = Vec::new();
        for (path, ..) in assignments {
            let section = path.split('.').next().unwrap_or(path);
            if !touched.contains(&section) {
                touched.push(section);
            }
        }
        // The touched sections alone (the others keep their defaults there) …
        let params = self
            .resolve_sections(assignments)
            .map(|mut partial| {
                // … moved into the base
                let mut params = spec.spec.base.clone();
                for section in &touched {
                    let known = params.take_section(&mut partial, section);
                    debug_assert!(known, "an unknown section does not deserialise");
                }
                params
            })
            .map_err(|e: toml::de::Error| {
                // Blame the values that fail on their own; if only the combination fails, blame
                // all.
                let alone: Vec<&(String, toml::Value, String)> = assignments
                    .iter()
                    .filter(|a| {
                        assignments.len() > 1 && self.resolve(std::slice::from_ref(*a)).is_err()
                    })
                    .collect();
                let culprits: Vec<&(String, toml::Value, String)> =
                    if alone.is_empty() { assignments.iter().collect() } else { alone };
                let names: Vec<&str> = assignments.iter().map(|(p, ..)| p.as_str()).collect();
                culprits
                    .iter()
                    .map(|(_, _, key)| {
                        spec.error_at(
                            key,
                            format!(
                                "with {} set here, [base] does not deserialise: {}",
                                names.join(", "),
                                e.message().trim()
                            ),
                        )
                    })
                    .collect::<Vec<_>>()
            })?;
        let violations = params.validate(self.sensors);
        if violations.is_empty() {
            return Ok(params);
        }
        Err(self.placed(assignments, violations))
    }
}

/// Identifies a section state: the section and the assignments that set it (path, and the value's
/// bits or length-prefixed text: two values are one state only when equal, `-0.0` and `0.0`
/// apart).
fn state_key(section: &str, assignments: &[&(String, toml::Value, String)]) -> Vec<u8> {
    let mut key = Vec::with_capacity(128);
    key.extend_from_slice(section.as_bytes());
    for (path, value, _) in assignments {
        key.push(0);
        key.extend_from_slice(path.as_bytes());
        key.push(b'=');
        match value {
            toml::Value::Float(f) => {
                key.push(b'f');
                key.extend_from_slice(&f.to_bits().to_le_bytes());
            }
            toml::Value::Integer(i) => {
                key.push(b'i');
                key.extend_from_slice(&i.to_le_bytes());
            }
            toml::Value::Boolean(b) => key.extend_from_slice(if *b { b"T" } else { b"F" }),
            toml::Value::String(t) => {
                key.push(b's');
                key.extend_from_slice(&t.len().to_le_bytes());
                key.extend_from_slice(t.as_bytes());
            }
            other => {
                let text = other.to_string();
                key.push(b'v');
                key.extend_from_slice(&text.len().to_le_bytes());
                key.extend_from_slice(text.as_bytes());
            }
        }
    }
    key
}

fn get_path<'a>(table: &'a toml::Table, path: &str) -> Option<&'a toml::Value> {
    let mut parts = path.split('.');
    let mut value = table.get(parts.next()?)?;
    for part in parts {
        value = value.as_table()?.get(part)?;
    }
    Some(value)
}

/// The sweep point with the base parameters plus `table`'s assignments (`key` places errors).
fn find_point(
    spec: &LoadedSpec,
    points: &[SweepPoint],
    table: &toml::Table,
    key: &str,
) -> Result<usize, crate::source::SourceError> {
    let mut leaves = Vec::new();
    crate::params::flatten("", &toml::Value::Table(table.clone()), &mut leaves);
    let assignments: Vec<(String, toml::Value, String)> =
        leaves.into_iter().map(|(p, v)| (p.clone(), v, crate::source::join_key(key, &p))).collect();
    // only to find the point: the points themselves were checked with the study's sensors
    let params = Resolver::new(spec, crate::world::Sensors::default())
        .resolve(&assignments)
        .map_err(|mut e| e.remove(0))?;
    points.iter().position(|p| p.params == params).ok_or_else(|| {
        spec.error_at(key, "no sweep point of this study has these parameters (the others at base)")
    })
}

/// Resolves every claim's cells to sweep points.
fn claim_cells(spec: &LoadedSpec, points: &[SweepPoint]) -> Result<Vec<ClaimCells>, SpecError> {
    let mut out = Vec::new();
    let mut errors = Vec::new();
    for (i, c) in spec.spec.claims.iter().enumerate() {
        // An index claim is about a whole design, not cells; a claim across cells is about every
        // cell.
        if c.index.is_some() || c.across == crate::spec::Across::Cells {
            out.push(ClaimCells { id: c.id.clone(), at: None, than: None, over: Vec::new() });
            continue;
        }
        // An empty table means the base configuration.
        let mut cell = |t: &toml::Table, k: &str| match find_point(
            spec,
            points,
            t,
            &format!("claims[{i}].{k}"),
        ) {
            Ok(p) => Some(points[p].label.clone()),
            Err(e) => {
                errors.push(e);
                None
            }
        };
        // A flat claim is about its `over` cells only.
        let at = if c.test == crate::spec::ClaimTest::Flat && c.at.is_empty() {
            None
        } else {
            cell(&c.at, "at")
        };
        // Comparing algorithms without a `than` cell: the same cell.
        let than = if c.than.is_empty() {
            c.than_algorithm.as_ref().and(at.clone())
        } else {
            cell(&c.than, "than")
        };
        let mut over = Vec::new();
        if let Some((param, values)) = c.over.iter().next() {
            for (j, v) in
                values.as_array().map(Vec::as_slice).unwrap_or_default().iter().enumerate()
            {
                let mut t = toml::Table::new();
                t.insert(param.clone(), v.clone());
                match find_point(spec, points, &t, &format!("claims[{i}].over")) {
                    Ok(p) => over.push((format_value(v), points[p].label.clone())),
                    Err(mut e) => {
                        e.key =
                            format!("claims[{i}].over.{}[{j}]", crate::source::join_key("", param));
                        errors.push(e);
                    }
                }
            }
        }
        out.push(ClaimCells { id: c.id.clone(), at, than, over });
    }
    if errors.is_empty() { Ok(out) } else { Err(SpecError::new(&spec.path, errors)) }
}

/// Reads and checks `[report] reference`: the file parses, has rows of the experiment, and
/// those rows sweep a parameter the study sweeps.
fn reference(spec: &LoadedSpec) -> Result<Option<String>, SpecError> {
    let Some(r) = &spec.spec.report.reference else { return Ok(None) };
    let fail = |key: &str, msg: String| SpecError::new(&spec.path, vec![spec.error_at(key, msg)]);
    let text = std::fs::read_to_string(&r.file)
        .map_err(|e| fail("report.reference.file", format!("cannot read {}: {e}", r.file)))?;
    let rows = reference_file::parse(&text)
        .map_err(|e| fail("report.reference.file", format!("{}: {e}", r.file)))?;
    let swept: Vec<&str> =
        spec.sweeps.iter().flat_map(|b| &b.params).map(|p| p.path.as_str()).collect();
    for (i, e) in r.experiments.iter().enumerate() {
        let key = format!("report.reference.experiments[{i}]");
        let mine: Vec<_> = rows.iter().filter(|row| &row.experiment == e).collect();
        if mine.is_empty() {
            return Err(fail(&key, format!("{} has no rows of experiment `{e}`", r.file)));
        }
        // Long-layout rows name cells (sweep labels) instead of a parameter.
        let labels: Vec<&str> =
            spec.sweeps.iter().flat_map(|b| &b.labels).map(String::as_str).collect();
        if let Some(row) =
            mine.iter().find(|row| !row.cell.is_empty() && !labels.contains(&row.cell.as_str()))
        {
            return Err(fail(
                &key,
                format!(
                    "its rows name the cell `{}`, which no sweep `labels` of this study names",
                    row.cell
                ),
            ));
        }
        if let Some(row) =
            mine.iter().find(|row| row.cell.is_empty() && !swept.contains(&row.parameter.as_str()))
        {
            return Err(fail(
                &key,
                format!("its rows sweep `{}`, which this study does not sweep", row.parameter),
            ));
        }
    }
    Ok(Some(reference_file::select(&text, &r.experiments)))
}

/// Reads `[sequential] items`: the published result items this study answers by published
/// cells (rows of its `[report] reference`), which its looks stage beside its claims.
fn staged_items(spec: &LoadedSpec) -> Result<Vec<crate::spec::items::Item>, SpecError> {
    let Some(file) = spec.spec.sequential.as_ref().and_then(|s| s.items.as_ref()) else {
        return Ok(Vec::new());
    };
    let fail =
        |msg: String| SpecError::new(&spec.path, vec![spec.error_at("sequential.items", msg)]);
    let text =
        std::fs::read_to_string(file).map_err(|e| fail(format!("cannot read {file}: {e}")))?;
    let items = crate::spec::items::parse_items(&text).map_err(|e| fail(format!("{file}: {e}")))?;
    if spec.spec.looks().is_none() {
        return Err(fail("staged items need looks: a `max_replicates` above `replicates`".into()));
    }
    if spec.spec.report.reference.is_none() {
        return Err(fail(
            "items answered by published cells need the study's `[report] reference` rows".into(),
        ));
    }
    let id = &spec.spec.id;
    let mine: Vec<_> = items
        .into_iter()
        .filter(|it| it.study.as_ref() == Some(id) && it.cells.is_some() && it.missing.is_none())
        .collect();
    if let Some(it) = mine.iter().find(|it| {
        it.cells.as_ref().is_some_and(|c| {
            c.metrics.iter().any(|m| m.as_str() == crate::metrics::LANDMARK_ERROR_GROWTH)
        })
    }) {
        return Err(fail(format!(
            "item {} compares `{}`, which is derived from the stored maps after the runs, and the looks are taken while they run",
            it.id,
            crate::metrics::LANDMARK_ERROR_GROWTH
        )));
    }
    if mine.is_empty() {
        return Err(fail(format!(
            "{file} has no item this study answers by published cells (`study = \"{id}\"` with `cells`)"
        )));
    }
    Ok(mine)
}

/// Sets `a.b.c = value`, creating intermediate tables.
fn set_path(table: &mut toml::Table, path: &str, value: toml::Value) {
    let mut parts = path.split('.').peekable();
    let mut current = table;
    while let Some(part) = parts.next() {
        if parts.peek().is_none() {
            current.insert(part.to_string(), value);
            return;
        }
        let entry = current
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        if !entry.is_table() {
            *entry = toml::Value::Table(toml::Table::new());
        }
        current = entry.as_table_mut().expect("just made a table");
    }
}

/// A sweep value as shown in labels and reports: numbers in shortest round-trip form, strings bare.
pub fn format_value(v: &toml::Value) -> String {
    FormattedValue(v).to_string()
}

/// Room for a value's text when sizing a label (a shortest round-trip f64 has at most 24).
const LABEL_VALUE_CHARS: usize = 24;

/// [`format_value`] as a `Display`, written without an intermediate string.
struct FormattedValue<'v>(&'v toml::Value);

impl std::fmt::Display for FormattedValue<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            toml::Value::Float(x) => write!(f, "{x}"),
            toml::Value::Integer(i) => write!(f, "{i}"),
            toml::Value::String(s) => f.write_str(s),
            toml::Value::Boolean(b) => write!(f, "{b}"),
            other => write!(f, "{other}"),
        }
    }
}

/// Keeps run ids filename-safe (they name TUM files).
fn sanitize(label: &str) -> String {
    label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || "._=,+-".contains(c) { c } else { '_' })
        .collect()
}

fn runs(
    spec: &LoadedSpec,
    maps: &[MapEntry],
    points: &[SweepPoint],
    texts: &SweptTexts,
    progress: &dyn Fn(Stage, usize, usize),
) -> Vec<RunSpec> {
    let s = &spec.spec;
    // a sequential study plans its whole budget; `run` takes the stages it needs
    let replicates = s.replicate_budget();
    let width = (replicates.saturating_sub(1)).to_string().len().max(2);
    let total = maps.len() * s.algorithms.len() * points.len() * replicates as usize;
    let mut runs = Vec::with_capacity(total);
    // the base's text of each section (the sections no sweep sets)
    let base_texts: Vec<String> =
        crate::params::SECTIONS.iter().map(|n| s.base.section_text(n)).collect();
    let labels: Vec<String> = points.iter().map(|p| sanitize(&p.label)).collect();
    for (mi, map) in maps.iter().enumerate() {
        // (world, filter) seed of each replicate: from the study seed, map and replicate only
        let seeds: Vec<(u64, u64)> = (0..replicates)
            .map(|replicate| {
                let world = if s.fixed_world { 0 } else { replicate };
                (
                    derive_seed(s.seed, &map.name, world, "world"),
                    derive_seed(s.seed, &map.name, replicate, "filter"),
                )
            })
            .collect();
        for id in &s.algorithms {
            let algorithm = spec.catalogue.algorithm(id);
            // The world's parts this run reads: the point sensor's and the dataset loaders'
            // versions enter only the hashes of the runs that use them.
            let mut code_version = format!(
                "{SCHEMA_VERSION}+{WORLD_CODE_VERSION}+{METRICS_VERSION}+{}",
                algorithm.code_version()
            );
            // The scan matchers share their code version and (by kind) their parameter
            // sections: the algorithm's name keeps their runs apart.
            if algorithm.is_scan_matcher() {
                code_version.push_str(&format!(":{}", algorithm.name()));
            }
            if map.dataset.is_some() {
                code_version.push_str(&format!("+{}", crate::dataset::DATASET_CODE_VERSION));
            } else if algorithm.sensors(map.world_kind()).landmarks {
                code_version.push_str(&format!(
                    "+{}",
                    crate::world::point_sensor::POINT_SENSOR_CODE_VERSION
                ));
            }
            let wanted = algorithm.sections_read(map.world_kind());
            let code_version: std::sync::Arc<str> = code_version.into();
            // one point's runs
            let of_point = |pi: usize| {
                let point = &points[pi];
                // The sections the algorithm reads, as TOML text (not JSON: it keeps `inf`,
                // e.g. fastslam.neff_threshold, distinct): the swept ones from the point, the
                // others from the base.
                let params = crate::params::Params::sections_text(&wanted, |name| {
                    match texts.sections.iter().position(|t| *t == name) {
                        Some(i) => texts.text(pi, i),
                        None => {
                            let i = crate::params::SECTIONS.iter().position(|t| *t == name);
                            base_texts[i.expect("a listed section")].as_str()
                        }
                    }
                })
                .unwrap_or_else(|| {
                    toml::to_string(&point.params.sections(&wanted))
                        .expect("parameters serialise to TOML")
                });
                let mut out = Vec::with_capacity(replicates as usize);
                for replicate in 0..replicates {
                    let (world_seed, filter_seed) = seeds[replicate as usize];
                    let inputs = format!(
                        "map_blake3 = {:?}\nworld_seed = {world_seed}\nfilter_seed = {filter_seed}\n{params}",
                        map.hash
                    );
                    let params_hash = blake3::hash(inputs.as_bytes()).to_hex().to_string();
                    let hash = blake3::hash(format!("{code_version}\n{params_hash}").as_bytes())
                        .to_hex()
                        .to_string();
                    out.push(RunSpec {
                        run_id: format!(
                            "{}--{}--{}--r{:0width$}",
                            map.name,
                            algorithm.name(),
                            labels[pi],
                            replicate
                        ),
                        map: mi,
                        point: pi,
                        algorithm: id.clone(),
                        replicate,
                        world_seed,
                        filter_seed,
                        params_hash,
                        code_version: code_version.clone(),
                        hash,
                    });
                }
                out
            };
            for pi in 0..points.len() {
                if pi % PROGRESS_EVERY == 0 {
                    progress(Stage::Runs, runs.len(), total);
                }
                runs.extend(of_point(pi));
            }
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan_of(text: &str) -> Result<ExperimentPlan, InputErrors> {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("box.toml"),
            "name = \"box\"\ntitle = \"Box\"\nstart = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }\n[[walls]]\npoints = [[-1, -1], [5, -1], [5, 5], [-1, 5], [-1, -1]]\n[trajectory]\nmax_speed_mps = 0.5\nlaps = 1\nwaypoints = [[4, 0], [0, 0]]\n",
        )
        .unwrap();
        let spec = crate::spec::parse(Path::new("s.toml"), text, &Default::default())
            .map_err(InputErrors::from)?;
        build(spec, dir.path())
    }

    const HEAD: &str = "id = \"t\"\ntitle = \"T\"\nseed = 5\nreplicates = 3\nmaps = [\"box\"]\nalgorithms = [\"odometry\"]\n";

    /// `[[report.contrasts]]` pairs name sweep points: a named zip cell or a plan label; an unknown
    /// one is an error at the pair's key.
    /// Every point of every committed study resolves to what resolving it alone gives, and every
    /// run hashes the text of the whole `sections` table: the section-at-a-time expansion (memo,
    /// shared texts, parallel hashing) changes no plan.
    #[test]
    fn fast_expansion_equals_resolving_each_point_alone() {
        let catalogue = crate::spec::algorithms::catalogue(&[PathBuf::from("data/algorithms")])
            .expect("the committed algorithms");
        let mut specs: Vec<PathBuf> = std::fs::read_dir("experiments")
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        specs.sort();
        assert!(specs.len() > 40);
        for path in specs {
            let spec = crate::spec::load(&path, &catalogue).unwrap();
            let plan = build(spec, Path::new("data/maps")).unwrap();
            let sensors = crate::world::Sensors { laser: true, landmarks: true };
            let resolver = Resolver::new(&plan.spec, sensors);
            for point in &plan.points {
                let assignments: Vec<_> = point
                    .assignments
                    .iter()
                    .map(|(p, v)| (p.clone(), v.clone(), "sweeps".to_string()))
                    .collect();
                // (the study's own sensors may accept what these reject: compare when both do)
                if let Ok(alone) = resolver.resolve(&assignments) {
                    assert_eq!(alone, point.params, "{}: {}", path.display(), point.label);
                }
            }
            for run in &plan.runs {
                let map = &plan.maps[run.map];
                let wanted = plan.algorithm(run).sections_read(map.world_kind());
                let params =
                    toml::to_string(&plan.points[run.point].params.sections(&wanted)).unwrap();
                let inputs = format!(
                    "map_blake3 = {:?}\nworld_seed = {}\nfilter_seed = {}\n{params}",
                    map.hash, run.world_seed, run.filter_seed
                );
                assert_eq!(
                    run.params_hash,
                    blake3::hash(inputs.as_bytes()).to_hex().to_string(),
                    "{}: {}",
                    path.display(),
                    run.run_id
                );
            }
        }
    }

    /// A grid over two sections resolves each section state once, and its points are those of
    /// resolving each alone — a `model` switch (which starts its section afresh) and a value equal
    /// to the base (one point with the base) included.
    #[test]
    fn grid_points_are_resolved_section_by_section() {
        let spec = format!(
            "{HEAD}[base.odometry]\nmodel = \"proportional\"\nk = 0.1\nk_is = \"std\"\n[base.sim]\ndt_s = 0.1\n[[sweeps]]\nkind = \"grid\"\nvalues = {{ \"odometry.k\" = [0.1, 0.2, 0.3], \"sim.dt_s\" = [0.1, 0.2] }}\n[[sweeps]]\nkind = \"zip\"\nvalues = {{ \"odometry.model\" = [\"proportional\", \"none\"] }}\n"
        );
        let plan = plan_of(&spec).unwrap();
        let resolver = Resolver::new(&plan.spec, crate::world::Sensors::default());
        for p in &plan.points {
            let a: Vec<_> =
                p.assignments.iter().map(|(x, v)| (x.clone(), v.clone(), String::new())).collect();
            assert_eq!(resolver.resolve(&a).unwrap(), p.params, "{}", p.label);
        }
        // 6 grid points; the zip's `proportional` is the grid's first point (k = 0.1, dt = 0.1)
        assert_eq!(
            plan.points.len(),
            7,
            "{:?}",
            plan.points.iter().map(|p| &p.label).collect::<Vec<_>>()
        );
        let none = plan.points.iter().find(|p| p.label == "odometry.model=none").unwrap();
        assert_eq!(none.params.odometry, crate::world::odometry::OdometryNoise::None {});
        // distinct parameters, distinct hashes
        let mut hashes: Vec<&str> = plan.runs.iter().map(|r| r.params_hash.as_str()).collect();
        hashes.sort_unstable();
        hashes.dedup();
        assert_eq!(hashes.len(), plan.runs.len());
    }

    #[test]
    fn contrast_pairs_must_name_sweep_points() {
        let spec = format!(
            "{HEAD}[[sweeps]]\nkind = \"zip\"\nlabels = [\"low\", \"high\"]\nvalues = {{ \"odometry.k\" = [0.05, 0.2] }}\n[report]\nmetrics = [\"ate_rmse_m\"]\n[[report.contrasts]]\ntitle = \"c\"\npairs = [[\"high\", \"low\"], [\"high\", \"middle\"]]\n"
        );
        let e = plan_of(&spec).unwrap_err();
        let err = &e.0[0].errors[0];
        assert_eq!(err.key, "report.contrasts[0].pairs[1]");
        assert!(
            err.message.contains("no sweep point `middle`") && err.message.contains("low, high"),
            "{}",
            err.message
        );
        assert!(plan_of(&spec.replace(", [\"high\", \"middle\"]", "")).is_ok());
    }

    /// Walls in bitmap pixels on a map without a bitmap scale: an input error naming the map, not
    /// a failure of every run.
    #[test]
    fn wall_pixels_need_the_maps_bitmap_scale() {
        let spec = format!("{HEAD}[base.laser]\nwall_thickness_px = 2.5\n")
            .replace("[\"odometry\"]", "[\"fastslam1\"]");
        let e = plan_of(&spec).unwrap_err();
        assert_eq!(e.0[0].errors[0].key, "maps[0]");
        assert!(e.0[0].errors[0].message.contains("no bitmap_m_per_px"));
        assert!(
            plan_of(&spec.replace("wall_thickness_px = 2.5", "wall_thickness_m = 0.05")).is_ok()
        );
    }

    /// A sensor's rate must fit the clock only where the study simulates that sensor: EKF-SLAM on
    /// a point-landmark map reads no laser, so the laser's default 5 Hz at Δt = 0.3 s is no error
    /// there ([EV]'s 1 s steps), but is one on a laser map.
    #[test]
    fn sensor_rates_are_checked_against_the_maps_world_kinds() {
        let dir = tempfile::tempdir().unwrap();
        let map = |name: &str, extra: &str| {
            format!(
                "name = \"{name}\"\ntitle = \"M\"\nstart = {{ x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }}\n{extra}[[walls]]\npoints = [[-1, -1], [5, -1], [5, 5], [-1, 5], [-1, -1]]\n[trajectory]\nmax_speed_mps = 0.5\nlaps = 1\nwaypoints = [[4, 0], [0, 0]]\n"
            )
        };
        std::fs::write(dir.path().join("dots.toml"), map("dots", "landmarks = [[2.0, 2.0]]\n"))
            .unwrap();
        std::fs::write(dir.path().join("box.toml"), map("box", "")).unwrap();
        let text = |m: &str| {
            format!(
                "id = \"t\"\ntitle = \"T\"\nseed = 5\nreplicates = 3\nmaps = [\"{m}\"]\nalgorithms = [\"ekf_slam\"]\n[base.sim]\ndt_s = 0.3\n[base.landmark_sensor]\nrate_hz = 1.0\n"
            )
        };
        let plan = |m: &str| {
            build(
                crate::spec::parse(Path::new("s.toml"), &text(m), &Default::default())
                    .map_err(InputErrors::from)
                    .unwrap(),
                dir.path(),
            )
        };
        // 1/(1 Hz · 0.3 s) is not whole either: the point map's sensor is checked
        let e = plan("dots").unwrap_err();
        assert_eq!(
            e.0[0].errors.iter().map(|e| e.key.as_str()).collect::<Vec<_>>(),
            ["base.landmark_sensor.rate_hz"]
        );
        let fits = text("dots")
            .replace("dt_s = 0.3", "dt_s = 0.25")
            .replace("rate_hz = 1.0", "rate_hz = 2.0");
        assert!(
            build(
                crate::spec::parse(Path::new("s.toml"), &fits, &Default::default()).unwrap(),
                dir.path()
            )
            .is_ok(),
            "the laser's 5 Hz at Δt = 0.25 s is not checked on a point map"
        );
        let e = build(
            crate::spec::parse(
                Path::new("s.toml"),
                &fits.replace("\"dots\"", "\"box\""),
                &Default::default(),
            )
            .unwrap(),
            dir.path(),
        )
        .unwrap_err();
        assert_eq!(e.0[0].errors[0].key, "base.laser.rate_hz");
    }

    #[test]
    fn one_at_a_time_shares_the_base_point() {
        let text = format!(
            "{HEAD}[base.odometry]\nmodel = \"proportional\"\nk = 0.1\nk_is = \"std\"\n[[sweeps]]\nkind = \"one_at_a_time\"\nvalues = {{ \"odometry.k\" = [0.05, 0.1], \"sim.dt_s\" = [0.1, 0.2] }}\n"
        );
        let plan = plan_of(&text).unwrap();
        // k=0.1 and dt=0.1 are both the base configuration: one point, in both groups
        let labels: Vec<_> =
            plan.points.iter().map(|p| (p.label.as_str(), p.groups.clone())).collect();
        assert_eq!(
            labels,
            vec![
                ("odometry.k=0.05", vec![0]),
                ("odometry.k=0.1", vec![0, 1]),
                ("sim.dt_s=0.2", vec![1])
            ]
        );
        assert_eq!(plan.runs.len(), 3 * 3);
        assert_eq!(plan.runs[0].run_id, "box--odometry--odometry.k=0.05--r00");
    }

    #[test]
    fn seeds_do_not_depend_on_the_swept_value() {
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"grid\"\nvalues = {{ \"odometry.k\" = [0.0, 0.2], \"sim.dt_s\" = [0.1, 0.2] }}\n"
        );
        let plan = plan_of(&text).unwrap();
        assert_eq!(plan.points.len(), 4);
        for r in &plan.runs {
            assert_eq!(r.world_seed, derive_seed(5, "box", r.replicate, "world"));
            assert_ne!(r.world_seed, r.filter_seed);
        }
        let hashes: std::collections::BTreeSet<_> = plan.runs.iter().map(|r| &r.hash).collect();
        assert_eq!(hashes.len(), plan.runs.len());
    }

    #[test]
    fn zip_pairs_values() {
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"zip\"\nvalues = {{ \"odometry.k\" = [0.0, 0.2], \"sim.dt_s\" = [0.1, 0.2] }}\n"
        );
        let plan = plan_of(&text).unwrap();
        let labels: Vec<_> = plan.points.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(labels, vec!["odometry.k=0,sim.dt_s=0.1", "odometry.k=0.2,sim.dt_s=0.2"]);
    }

    #[test]
    fn invalid_sweep_value_points_at_the_value() {
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"one_at_a_time\"\nvalues = {{ \"odometry.k\" = [0.1, -0.5] }}\n"
        );
        let err = plan_of(&text).unwrap_err();
        let e = &err.0[0].errors[0];
        assert_eq!(e.key, "sweeps[0].values.\"odometry.k\"[1]");
        assert_eq!(e.line, 9);
        assert!(e.message.contains("≥ 0"), "{}", e.message);
    }

    /// A sweep that fails at every one of its values reports the first few, each at its value,
    /// and counts the rest (10⁵ failing values once printed 10⁵ lines in 15 s).
    #[test]
    fn a_sweep_failing_everywhere_reports_the_first_errors_and_counts_the_rest() {
        let values: Vec<String> = (1..=30).map(|i| format!("-{i}.0")).collect();
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"one_at_a_time\"\nvalues = {{ \"odometry.k\" = [{}] }}\n",
            values.join(", ")
        );
        let err = plan_of(&text).unwrap_err();
        let errors = &err.0[0].errors;
        assert_eq!(errors.len(), MAX_POINT_ERRORS + 1);
        assert_eq!(errors[0].key, "sweeps[0].values.\"odometry.k\"[0]");
        assert_eq!(errors[19].key, "sweeps[0].values.\"odometry.k\"[19]");
        assert!(errors[20].message.starts_with("and 10 more errors"), "{}", errors[20].message);
    }

    /// An integer parameter tied to a float range fails at its `tied` entry, not at the range
    /// it follows (which is valid on its own).
    #[test]
    fn a_tied_parameter_is_blamed_at_its_tied_entry() {
        let head = HEAD.replace("[\"odometry\"]", "[\"fastslam1\"]");
        let text = format!(
            "{head}[[sweeps]]\nkind = \"sobol\"\nsamples = 8\nranges = {{ \"fastslam.p0\" = [0.001, 0.01], \"fastslam.motion_x\" = [0.001, 0.02] }}\ntied = {{ \"fastslam.particles\" = \"fastslam.motion_x\" }}\n"
        );
        let err = plan_of(&text).unwrap_err();
        let keys: Vec<&str> = err.0[0].errors.iter().map(|e| e.key.as_str()).collect();
        assert!(!keys.is_empty());
        assert!(
            keys.iter().all(|k| *k == "sweeps[0].tied.\"fastslam.particles\""),
            "{:?}",
            err.0[0].errors
        );
    }

    /// A map file is read up to a limit (a link to /dev/zero once grew to 4 GB and was then
    /// called missing): a larger one is refused at the spec's `maps` entry, and it is not called
    /// missing.
    #[test]
    fn a_map_file_beyond_the_size_limit_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let comment = format!("# {}\n", "x".repeat(crate::spec::MAX_MAP_BYTES as usize));
        std::fs::write(dir.path().join("huge.toml"), comment).unwrap();
        let text = HEAD.replace("[\"box\"]", "[\"huge\"]");
        let spec = crate::spec::parse(Path::new("s.toml"), &text, &Default::default()).unwrap();
        let err = build(spec, dir.path()).unwrap_err();
        let e = &err.0[0].errors[0];
        assert_eq!(e.key, "maps[0]");
        assert!(
            e.message.contains("larger than") && !e.message.contains("does not exist"),
            "{}",
            e.message
        );
    }

    #[test]
    fn wrong_type_in_sweep_is_reported_at_the_value() {
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"one_at_a_time\"\nvalues = {{ \"sim.dt_s\" = [0.1, \"fast\"] }}\n"
        );
        let err = plan_of(&text).unwrap_err();
        assert_eq!(err.0[0].errors[0].key, "sweeps[0].values.\"sim.dt_s\"[1]");
    }

    #[test]
    fn switching_the_odometry_model_starts_its_section_afresh() {
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"zip\"\nvalues = {{ \"odometry.model\" = [\"proportional\", \"pose\"], \"odometry.var_theta_rad2\" = [0.0, 0.001] }}\n"
        );
        // proportional has no var_theta_rad2: that point is invalid and named
        let err = plan_of(&text).unwrap_err();
        assert!(
            err.0[0].errors[0].message.contains("var_theta_rad2"),
            "{}",
            err.0[0].errors[0].message
        );
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"zip\"\nvalues = {{ \"odometry.model\" = [\"pose\"], \"odometry.var_x_m2\" = [0.01], \"odometry.var_y_m2\" = [0.01], \"odometry.var_theta_rad2\" = [0.001] }}\n"
        );
        let plan = plan_of(&text).unwrap();
        assert!(
            matches!(plan.points[0].params.odometry, crate::world::odometry::OdometryNoise::Pose { var_theta_rad2, .. } if var_theta_rad2 == 0.001)
        );
    }

    #[test]
    fn a_bad_value_in_a_grid_is_blamed_on_its_own_key() {
        let text = format!(
            "{HEAD}[[sweeps]]\nkind = \"grid\"\nvalues = {{ \"odometry.k\" = [0.1], \"sim.dt_s\" = [\"fast\"] }}\n"
        );
        let err = plan_of(&text).unwrap_err();
        let keys: Vec<&str> = err.0[0].errors.iter().map(|e| e.key.as_str()).collect();
        assert_eq!(keys, ["sweeps[0].values.\"sim.dt_s\"[0]"]);
    }

    #[test]
    fn missing_map_lists_what_exists() {
        let err = plan_of(&HEAD.replace("[\"box\"]", "[\"box\", \"nowhere\"]")).unwrap_err();
        let e = &err.0[0].errors[0];
        assert_eq!((e.key.as_str(), e.line), ("maps[1]", 5));
        assert!(e.message.contains("available") && e.message.contains("box"), "{}", e.message);
    }

    #[test]
    fn odometry_runs_ignore_laser_settings() {
        let a = plan_of(HEAD).unwrap();
        let b = plan_of(&format!("{HEAD}[base.laser]\nmax_range_m = 30.0\n")).unwrap();
        assert_eq!(a.runs[0].hash, b.runs[0].hash);
    }

    /// A morris sweep expands to r (d + 1) design rows; integer rounding merges equal rows into
    /// one point (one run per replicate) and the record keeps each row's point and realised
    /// coordinates; tied keys follow their parameter; the same spec gives the same design.
    #[test]
    fn morris_rows_become_deduplicated_points() {
        let text = HEAD.replace("[\"odometry\"]", "[\"fastslam1\"]")
            + "[[sweeps]]\nkind = \"morris\"\ntrajectories = 6\nlevels = 4\nranges = { \"fastslam.particles\" = [1, 3], \"fastslam.motion_x\" = [0.001, 0.1] }\nlog = [\"fastslam.motion_x\"]\ntied = { \"fastslam.motion_y\" = \"fastslam.motion_x\" }\n";
        let plan = plan_of(&text).unwrap();
        let d = plan.groups[0].design.as_ref().unwrap();
        assert_eq!((d.rows.len(), d.unit.len(), d.moved.len(), d.size), (6 * 3, 6 * 3, 6, 6));
        let distinct: std::collections::BTreeSet<&String> = d.rows.iter().collect();
        assert_eq!(distinct.len(), plan.points.len(), "every point is some row's");
        assert!(
            plan.points.len() < d.rows.len(),
            "particles 1.67 and 2.33 both round to 2 (and trajectories share grid points)"
        );
        for (row, label) in d.rows.iter().enumerate() {
            let p = &plan.points.iter().find(|p| &p.label == label).unwrap().params.fastslam;
            assert_eq!(p.motion_y, p.motion_x, "tied");
            // the realised coordinate is the run's own value on the unit scale
            assert!((d.unit[row][0] - (p.particles as f64 - 1.0) / 2.0).abs() < 1e-12);
            assert!((d.unit[row][1] - (p.motion_x / 0.001).ln() / 100f64.ln()).abs() < 1e-9);
        }
        assert!(plan.points.iter().all(|p| p.label.starts_with("morris0-")));
        assert_eq!(plan.runs.len(), plan.points.len() * 3);
        assert_eq!(plan_of(&text).unwrap().groups, plan.groups, "seeded by the spec");
        let other = plan_of(&text.replace("seed = 5", "seed = 6")).unwrap();
        assert_ne!(other.groups[0].design.as_ref().unwrap().unit, d.unit);
    }

    /// planned_runs counts a sobol design as N (d + 2) points before expanding it.
    #[test]
    fn sobol_designs_are_counted_before_expansion() {
        let text = HEAD.replace("[\"odometry\"]", "[\"fastslam1\"]")
            + "[[sweeps]]\nkind = \"sobol\"\nsamples = 8\nranges = { \"fastslam.p0\" = [0.001, 1.0], \"fastslam.motion_x\" = [0.001, 0.1] }\n";
        let spec = crate::spec::parse(Path::new("s.toml"), &text, &Default::default()).unwrap();
        assert_eq!(planned_runs(&spec), 8 * 4 * 3);
        let plan = plan_of(&text).unwrap();
        assert_eq!(plan.groups[0].design.as_ref().unwrap().rows.len(), 32);
        assert!(
            plan.groups[0].design.as_ref().unwrap().unit.is_empty(),
            "sobol keeps no coordinates"
        );
    }
}
