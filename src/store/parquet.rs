//! Typed rows ⇄ Parquet. The only polars code in slamlab. Column names and units are documented
//! in the book (docs/src/reference/results-schema.md).

use super::{
    LandmarkRow, MatchRows, ParamValue, RunLandmarks, RunRow, RunStatus, StoreError, Timing,
    TraceRows,
};
use crate::geom::Pose2;
use crate::trace::MatchRecord;
use polars::prelude::*;
use std::path::Path;

/// Fixed leading columns of `runs.parquet` (then parameters, then metrics).
const RUN_COLUMNS: &[&str] = &[
    "study",
    "run_id",
    "map",
    "algorithm",
    "point",
    "replicate",
    "world_seed",
    "filter_seed",
    "status",
    "error",
    "run_hash",
    "params_hash",
    "code_version",
];

fn err(path: &Path, e: PolarsError) -> StoreError {
    StoreError::Parquet { path: path.to_path_buf(), message: e.to_string() }
}

/// Polars runs its own rayon pool. A worker of another rayon pool that waits on it keeps executing
/// its own pool's jobs meanwhile, so Parquet IO inside a parallel loop nests job inside job until
/// the stack overflows: every read and write happens off rayon's workers (see `run::run_study`).
fn assert_off_worker_pool(path: &Path) {
    assert!(
        rayon::current_thread_index().is_none(),
        "Parquet IO on a rayon worker thread ({}): do it on the calling thread",
        path.display()
    );
}

pub(super) fn write(path: &Path, df: &mut DataFrame) -> Result<(), StoreError> {
    assert_off_worker_pool(path);
    let file = std::fs::File::create(path).map_err(|e| StoreError::io(path, e))?;
    let mut w = std::io::BufWriter::new(file);
    ParquetWriter::new(&mut w)
        .with_compression(ParquetCompression::Zstd(None))
        .set_parallel(false)
        .finish(df)
        .map_err(|e| err(path, e))?;
    std::io::Write::flush(&mut w).map_err(|e| StoreError::io(path, e))?;
    w.get_ref().sync_all().map_err(|e| StoreError::io(path, e))
}

/// A Parquet file written a batch of rows at a time, each batch its own row group, with
/// [`write`]'s settings: a file of one batch is byte for byte the file [`write`] gives for the
/// same rows (fewer than polars' 512² rows a row group). A study's results are written this way,
/// so that only one batch of runs is in memory at a time.
pub(super) struct Batched {
    path: std::path::PathBuf,
    writer: Option<(BatchedWriter<Sink>, Sink)>,
}

/// The buffered file a [`Batched`] writes to, shared with it so that the buffer can be flushed
/// (and its errors seen) once polars has written the footer.
#[derive(Clone)]
struct Sink(std::sync::Arc<std::sync::Mutex<std::io::BufWriter<std::fs::File>>>);

impl std::io::Write for Sink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().expect("one writer").write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.lock().expect("one writer").flush()
    }
}

impl Batched {
    pub(super) fn new(path: &Path) -> Self {
        Self { path: path.to_path_buf(), writer: None }
    }

    /// Appends `df` (one chunk per column, as the frame builders here make them); the first
    /// batch fixes the schema.
    pub(super) fn write(&mut self, df: &DataFrame) -> Result<(), StoreError> {
        assert_off_worker_pool(&self.path);
        let path = &self.path;
        if self.writer.is_none() {
            let file = std::fs::File::create(path).map_err(|e| StoreError::io(path, e))?;
            let sink =
                Sink(std::sync::Arc::new(std::sync::Mutex::new(std::io::BufWriter::new(file))));
            let writer = ParquetWriter::new(sink.clone())
                .with_compression(ParquetCompression::Zstd(None))
                .set_parallel(false)
                .batched(df.schema())
                .map_err(|e| err(path, e))?;
            self.writer = Some((writer, sink));
        }
        let (writer, _) = self.writer.as_mut().expect("created above");
        writer.write_batch(df).map_err(|e| err(path, e))
    }

    /// Closes the file; `empty` gives the (zero-row) frame written when no batch came.
    pub(super) fn finish(
        self,
        empty: impl FnOnce() -> PolarsResult<DataFrame>,
    ) -> Result<(), StoreError> {
        let path = &self.path;
        let Some((writer, sink)) = self.writer else {
            let mut df = empty().map_err(|e| err(path, e))?;
            return write(path, &mut df);
        };
        writer.finish().map_err(|e| err(path, e))?;
        drop(writer);
        let mut file = sink.0.lock().expect("one writer");
        std::io::Write::flush(&mut *file).map_err(|e| StoreError::io(path, e))?;
        file.get_ref().sync_all().map_err(|e| StoreError::io(path, e))
    }
}

/// Rows of a Parquet file, from its footer (nothing else is read).
pub(super) fn count_rows(path: &Path) -> Result<usize, StoreError> {
    assert_off_worker_pool(path);
    let file = std::fs::File::open(path).map_err(|e| StoreError::io(path, e))?;
    ParquetReader::new(file).num_rows().map_err(|e| err(path, e))
}

pub(super) fn read(path: &Path) -> Result<DataFrame, StoreError> {
    assert_off_worker_pool(path);
    let file = std::fs::File::open(path).map_err(|e| StoreError::io(path, e))?;
    ParquetReader::new(file).finish().map_err(|e| err(path, e))
}

/// Runs → DataFrame. Parameter columns are the union of every row's keys (first appearance in
/// row order); metric columns the union of metric names; absent values are null.
pub(super) fn runs_frame(rows: &[RunRow]) -> PolarsResult<DataFrame> {
    let n = rows.len();
    let strs = |f: &dyn Fn(&RunRow) -> String| rows.iter().map(f).collect::<Vec<String>>();
    let mut cols = vec![
        Column::new("study".into(), strs(&|r| r.study.clone())),
        Column::new("run_id".into(), strs(&|r| r.run_id.clone())),
        Column::new("map".into(), strs(&|r| r.map.clone())),
        Column::new("algorithm".into(), strs(&|r| r.algorithm.clone())),
        Column::new("point".into(), strs(&|r| r.point.clone())),
        Column::new("replicate".into(), rows.iter().map(|r| r.replicate).collect::<Vec<u32>>()),
        Column::new("world_seed".into(), rows.iter().map(|r| r.world_seed).collect::<Vec<u64>>()),
        Column::new("filter_seed".into(), rows.iter().map(|r| r.filter_seed).collect::<Vec<u64>>()),
        Column::new("status".into(), strs(&|r| r.status.as_str().to_string())),
        Column::new(
            "error".into(),
            rows.iter().map(|r| r.error.clone()).collect::<Vec<Option<String>>>(),
        ),
        Column::new("run_hash".into(), strs(&|r| r.run_hash.clone())),
        Column::new("params_hash".into(), strs(&|r| r.params_hash.clone())),
        Column::new("code_version".into(), strs(&|r| r.code_version.clone())),
    ];
    for name in union_of_names(rows.iter().map(|r| r.params.iter().map(|(k, _)| k.as_str()))) {
        let values: Vec<Option<&ParamValue>> =
            rows.iter().map(|r| r.params.iter().find(|(k, _)| k == name).map(|(_, v)| v)).collect();
        let col = match values.iter().flatten().next() {
            Some(ParamValue::Float(_)) => Column::new(
                name.into(),
                values.iter().map(|v| v.and_then(ParamValue::as_f64)).collect::<Vec<Option<f64>>>(),
            ),
            Some(ParamValue::Int(_)) => Column::new(
                name.into(),
                values
                    .iter()
                    .map(|v| match v {
                        Some(ParamValue::Int(i)) => Some(*i),
                        _ => None,
                    })
                    .collect::<Vec<Option<i64>>>(),
            ),
            Some(ParamValue::Bool(_)) => Column::new(
                name.into(),
                values
                    .iter()
                    .map(|v| match v {
                        Some(ParamValue::Bool(b)) => Some(*b),
                        _ => None,
                    })
                    .collect::<Vec<Option<bool>>>(),
            ),
            _ => Column::new(
                name.into(),
                values
                    .iter()
                    .map(|v| v.map(ParamValue::to_string))
                    .collect::<Vec<Option<String>>>(),
            ),
        };
        cols.push(col);
    }
    for name in union_of_names(rows.iter().map(|r| r.metrics.iter().map(|(k, _)| k.as_str()))) {
        let values: Vec<Option<f64>> = rows
            .iter()
            .map(|r| r.metrics.iter().find(|(k, _)| k == name).map(|(_, v)| *v))
            .collect();
        cols.push(Column::new(name.into(), values));
    }
    DataFrame::new(n, cols)
}

/// Every name that occurs in any row, in order of first appearance.
fn union_of_names<'a, R: Iterator<Item = &'a str>>(rows: impl Iterator<Item = R>) -> Vec<&'a str> {
    let mut names: Vec<&str> = Vec::new();
    for name in rows.flatten() {
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
}

/// `(run_id, run_hash, status)` of every row of `runs.parquet`, reading those columns only.
pub(super) fn read_run_keys(path: &Path) -> Result<Vec<(String, String, RunStatus)>, StoreError> {
    assert_off_worker_pool(path);
    let e = |x: PolarsError| err(path, x);
    let file = std::fs::File::open(path).map_err(|e| StoreError::io(path, e))?;
    let df = ParquetReader::new(file)
        .with_columns(Some(vec!["run_id".into(), "run_hash".into(), "status".into()]))
        .finish()
        .map_err(e)?;
    let column = |name: &str| df.column(name).map_err(e)?.str().map_err(e).cloned();
    let (id, hash, status) = (column("run_id")?, column("run_hash")?, column("status")?);
    Ok(id
        .iter()
        .zip(hash.iter())
        .zip(status.iter())
        .map(|((id, hash), status)| {
            (
                id.unwrap_or_default().to_string(),
                hash.unwrap_or_default().to_string(),
                RunStatus::parse(status.unwrap_or_default()),
            )
        })
        .collect())
}

pub(super) fn read_runs(path: &Path) -> Result<Vec<RunRow>, StoreError> {
    let df = read(path)?;
    let e = |x: PolarsError| err(path, x);
    let s = |name: &str| -> Result<Vec<String>, StoreError> {
        Ok(df
            .column(name)
            .map_err(e)?
            .str()
            .map_err(e)?
            .iter()
            .map(|v| v.unwrap_or_default().to_string())
            .collect())
    };
    let (study, run_id, map, algorithm, point, status, run_hash, params_hash, code_version) = (
        s("study")?,
        s("run_id")?,
        s("map")?,
        s("algorithm")?,
        s("point")?,
        s("status")?,
        s("run_hash")?,
        s("params_hash")?,
        s("code_version")?,
    );
    let error: Vec<Option<String>> = df
        .column("error")
        .map_err(e)?
        .str()
        .map_err(e)?
        .iter()
        .map(|v| v.map(str::to_string))
        .collect();
    let replicate: Vec<u32> =
        df.column("replicate").map_err(e)?.u32().map_err(e)?.into_no_null_iter().collect();
    let world_seed: Vec<u64> =
        df.column("world_seed").map_err(e)?.u64().map_err(e)?.into_no_null_iter().collect();
    let filter_seed: Vec<u64> =
        df.column("filter_seed").map_err(e)?.u64().map_err(e)?.into_no_null_iter().collect();

    let mut rows: Vec<RunRow> = (0..df.height())
        .map(|i| RunRow {
            study: study[i].clone(),
            run_id: run_id[i].clone(),
            map: map[i].clone(),
            algorithm: algorithm[i].clone(),
            point: point[i].clone(),
            replicate: replicate[i],
            world_seed: world_seed[i],
            filter_seed: filter_seed[i],
            status: RunStatus::parse(&status[i]),
            error: error[i].clone(),
            run_hash: run_hash[i].clone(),
            params_hash: params_hash[i].clone(),
            code_version: code_version[i].clone(),
            params: Vec::new(),
            metrics: Vec::new(),
        })
        .collect();
    for col in df.columns() {
        let name = col.name().as_str();
        if RUN_COLUMNS.contains(&name) {
            continue;
        }
        // Parameters are dotted paths (`odometry.k`); metrics never contain a dot.
        if name.contains('.') {
            let values: Vec<Option<ParamValue>> = match col.dtype() {
                DataType::Float64 => {
                    col.f64().map_err(e)?.iter().map(|v| v.map(ParamValue::Float)).collect()
                }
                DataType::Int64 => {
                    col.i64().map_err(e)?.iter().map(|v| v.map(ParamValue::Int)).collect()
                }
                DataType::Boolean => {
                    col.bool().map_err(e)?.iter().map(|v| v.map(ParamValue::Bool)).collect()
                }
                _ => col
                    .str()
                    .map_err(e)?
                    .iter()
                    .map(|v| v.map(|s| ParamValue::Str(s.to_string())))
                    .collect(),
            };
            for (row, v) in rows.iter_mut().zip(values) {
                if let Some(v) = v {
                    row.params.push((name.to_string(), v));
                }
            }
        } else {
            for (row, v) in rows.iter_mut().zip(col.f64().map_err(e)?.iter()) {
                if let Some(v) = v {
                    row.metrics.push((name.to_string(), v));
                }
            }
        }
    }
    Ok(rows)
}

const TRACE_COLUMNS: [&str; 8] = [
    "truth_x_m",
    "truth_y_m",
    "truth_theta_rad",
    "est_x_m",
    "est_y_m",
    "est_theta_rad",
    "t_s",
    "step",
];

pub(super) fn traces_frame(traces: &[TraceRows]) -> PolarsResult<DataFrame> {
    let n: usize = traces.iter().map(|t| t.truth.len()).sum();
    let mut run_id = Vec::with_capacity(n);
    let mut step = Vec::with_capacity(n);
    let mut t_s = Vec::with_capacity(n);
    let mut cols: [Vec<f64>; 6] = Default::default();
    for t in traces {
        for (k, (truth, est)) in t.truth.iter().zip(&t.estimate).enumerate() {
            run_id.push(t.run_id.as_str());
            step.push(k as u32);
            t_s.push(k as f64 * t.dt_s);
            for (c, v) in
                cols.iter_mut().zip([truth.x, truth.y, truth.theta, est.x, est.y, est.theta])
            {
                c.push(v);
            }
        }
    }
    let neff: Vec<Option<f64>> = traces
        .iter()
        .flat_map(|t| {
            (0..t.truth.len().min(t.estimate.len())).map(|k| t.neff.get(k).copied().flatten())
        })
        .collect();
    let mut columns = vec![
        Column::new("run_id".into(), run_id),
        Column::new("step".into(), step),
        Column::new("t_s".into(), t_s),
    ];
    for (name, c) in TRACE_COLUMNS.iter().zip(cols) {
        columns.push(Column::new((*name).into(), c));
    }
    columns.push(Column::new("neff".into(), neff));
    DataFrame::new(n, columns)
}

/// Reads traces, keeping only the runs `keep` accepts. Rows of one run are contiguous and in
/// step order (as written).
pub(super) fn read_traces(
    path: &Path,
    keep: &dyn Fn(&str) -> bool,
) -> Result<Vec<TraceRows>, StoreError> {
    Ok(finish_traces(read_whole(path, keep, parse_traces)?))
}

/// Appends the rows of a frame of whole runs (in file order) whose run `keep` accepts.
type Parse<T> = fn(&Path, &DataFrame, &dyn Fn(&str) -> bool, &mut Vec<T>) -> Result<(), StoreError>;

/// Every row of the file at `path` whose run `keep` accepts, parsed by `parse`.
fn read_whole<T>(
    path: &Path,
    keep: &dyn Fn(&str) -> bool,
    parse: Parse<T>,
) -> Result<Vec<T>, StoreError> {
    let mut out = Vec::new();
    parse(path, &read(path)?, keep, &mut out)?;
    Ok(out)
}

/// Appends the rows of `df` (whole runs, in file order) whose run `keep` accepts to `out`.
fn parse_traces(
    path: &Path,
    df: &DataFrame,
    keep: &dyn Fn(&str) -> bool,
    out: &mut Vec<TraceRows>,
) -> Result<(), StoreError> {
    let e = |x: PolarsError| err(path, x);
    let ids = df.column("run_id").map_err(e)?.str().map_err(e)?;
    let t = df.column("t_s").map_err(e)?.f64().map_err(e)?;
    let f = |name: &str| -> Result<Vec<f64>, StoreError> {
        Ok(df
            .column(name)
            .map_err(e)?
            .f64()
            .map_err(e)?
            .iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    };
    let (tx, ty, tt, ex, ey, et) = (
        f("truth_x_m")?,
        f("truth_y_m")?,
        f("truth_theta_rad")?,
        f("est_x_m")?,
        f("est_y_m")?,
        f("est_theta_rad")?,
    );
    let neff: Vec<Option<f64>> = df.column("neff").map_err(e)?.f64().map_err(e)?.iter().collect();
    let ids: Vec<&str> = ids.iter().map(Option::unwrap_or_default).collect();
    // a run's rows are consecutive: `keep` is asked once per run, not once per step
    let mut last: Option<(&str, bool)> = None;
    for i in 0..df.height() {
        let id = ids[i];
        let kept = match last {
            Some((prev, kept)) if prev == id => kept,
            _ => keep(id),
        };
        last = Some((id, kept));
        if !kept {
            continue;
        }
        if out.last().is_none_or(|r| r.run_id != id) {
            // (polars' `get` panics past the end: a one-row run may end the frame)
            let next = (i + 1 < df.height()).then(|| (t.get(i + 1), ids[i + 1]));
            let dt_s = match (t.get(i), next) {
                (Some(a), Some((Some(b), next))) if next == id => b - a,
                _ => 0.0,
            };
            out.push(TraceRows { dt_s, ..TraceRows::empty(id) });
        }
        let r = out.last_mut().expect("just pushed");
        r.truth.push(Pose2::new(tx[i], ty[i], tt[i]));
        r.estimate.push(Pose2::new(ex[i], ey[i], et[i]));
        r.neff.push(neff[i]);
    }
    Ok(())
}

/// A run without any N̂eff (no particle filter) keeps an empty series.
fn finish_traces(mut out: Vec<TraceRows>) -> Vec<TraceRows> {
    for r in &mut out {
        if r.neff.iter().all(Option::is_none) {
            r.neff.clear();
        }
    }
    out
}

/// Final maps: one row per landmark; lines fill `rho_m`/`theta_rad`, corners `x_m`/`y_m`.
pub(super) fn landmarks_frame(maps: &[RunLandmarks]) -> PolarsResult<DataFrame> {
    let rows: Vec<(&str, &LandmarkRow)> =
        maps.iter().flat_map(|m| m.landmarks.iter().map(move |l| (m.run_id.as_str(), l))).collect();
    let get = |f: &dyn Fn(&LandmarkRow) -> Option<f64>| {
        rows.iter().map(|(_, l)| f(l)).collect::<Vec<Option<f64>>>()
    };
    DataFrame::new(
        rows.len(),
        vec![
            Column::new("run_id".into(), rows.iter().map(|(id, _)| *id).collect::<Vec<_>>()),
            Column::new(
                "kind".into(),
                rows.iter()
                    .map(|(_, l)| match l {
                        LandmarkRow::Line { .. } => "line",
                        LandmarkRow::Corner { .. } => "corner",
                        LandmarkRow::Point { .. } => "point",
                    })
                    .collect::<Vec<_>>(),
            ),
            Column::new(
                "rho_m".into(),
                get(&|l| if let LandmarkRow::Line { rho_m, .. } = l { Some(*rho_m) } else { None }),
            ),
            Column::new(
                "theta_rad".into(),
                get(&|l| {
                    if let LandmarkRow::Line { theta_rad, .. } = l {
                        Some(*theta_rad)
                    } else {
                        None
                    }
                }),
            ),
            Column::new(
                "x_m".into(),
                get(&|l| {
                    if let LandmarkRow::Corner { x_m, .. } | LandmarkRow::Point { x_m, .. } = l {
                        Some(*x_m)
                    } else {
                        None
                    }
                }),
            ),
            Column::new(
                "y_m".into(),
                get(&|l| {
                    if let LandmarkRow::Corner { y_m, .. } | LandmarkRow::Point { y_m, .. } = l {
                        Some(*y_m)
                    } else {
                        None
                    }
                }),
            ),
            Column::new(
                "landmark_id".into(),
                rows.iter()
                    .map(|(_, l)| if let LandmarkRow::Point { id, .. } = l { *id } else { None })
                    .collect::<Vec<Option<u32>>>(),
            ),
        ],
    )
}

pub(super) fn read_landmarks(
    path: &Path,
    keep: &dyn Fn(&str) -> bool,
) -> Result<Vec<RunLandmarks>, StoreError> {
    read_whole(path, keep, parse_landmarks)
}

/// Appends the rows of `df` (whole runs, in file order) whose run `keep` accepts to `out`.
fn parse_landmarks(
    path: &Path,
    df: &DataFrame,
    keep: &dyn Fn(&str) -> bool,
    out: &mut Vec<RunLandmarks>,
) -> Result<(), StoreError> {
    let e = |x: PolarsError| err(path, x);
    let ids = df.column("run_id").map_err(e)?.str().map_err(e)?;
    let kind = df.column("kind").map_err(e)?.str().map_err(e)?;
    let f = |name: &str| -> Result<Vec<f64>, StoreError> {
        Ok(df
            .column(name)
            .map_err(e)?
            .f64()
            .map_err(e)?
            .iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    };
    let (rho, theta, x, y) = (f("rho_m")?, f("theta_rad")?, f("x_m")?, f("y_m")?);
    // files written before point landmarks had identities lack the column: no identities
    let landmark_id: Vec<Option<u32>> = match df.column("landmark_id") {
        Ok(c) => c.u32().map_err(e)?.iter().collect(),
        Err(_) => vec![None; df.height()],
    };
    let mut last: Option<(&str, bool)> = None;
    for (i, (id, kind)) in ids.iter().zip(kind.iter()).enumerate() {
        let id = id.unwrap_or_default();
        let kept = match last {
            Some((prev, kept)) if prev == id => kept,
            _ => keep(id),
        };
        last = Some((id, kept));
        if !kept {
            continue;
        }
        if out.last().is_none_or(|m| m.run_id != id) {
            out.push(RunLandmarks { run_id: id.to_string(), landmarks: Vec::new() });
        }
        let l = match kind {
            Some("line") => LandmarkRow::Line { rho_m: rho[i], theta_rad: theta[i] },
            Some("point") => LandmarkRow::Point { x_m: x[i], y_m: y[i], id: landmark_id[i] },
            _ => LandmarkRow::Corner { x_m: x[i], y_m: y[i] },
        };
        out.last_mut().expect("just pushed").landmarks.push(l);
    }
    Ok(())
}

/// Scan matches: one row per match, poses of the current scan in the reference frame.
const MATCH_POSE_COLUMNS: [&str; 9] = [
    "truth_dx_m",
    "truth_dy_m",
    "truth_dtheta_rad",
    "initial_dx_m",
    "initial_dy_m",
    "initial_dtheta_rad",
    "est_dx_m",
    "est_dy_m",
    "est_dtheta_rad",
];

pub(super) fn matches_frame(runs: &[MatchRows]) -> PolarsResult<DataFrame> {
    let rows: Vec<(&str, usize, &MatchRecord)> = runs
        .iter()
        .flat_map(|r| r.matches.iter().enumerate().map(move |(i, m)| (r.run_id.as_str(), i, m)))
        .collect();
    let f =
        |g: &dyn Fn(&MatchRecord) -> f64| rows.iter().map(|(_, _, m)| g(m)).collect::<Vec<f64>>();
    let pose = |m: &MatchRecord, i: usize| {
        let p = [m.truth, m.initial, m.estimate][i / 3];
        [p.x, p.y, p.theta][i % 3]
    };
    let mut columns = vec![
        Column::new("run_id".into(), rows.iter().map(|(id, _, _)| *id).collect::<Vec<_>>()),
        Column::new("match".into(), rows.iter().map(|(_, i, _)| *i as u32).collect::<Vec<_>>()),
        Column::new(
            "reference_step".into(),
            rows.iter().map(|(_, _, m)| m.reference_step as u32).collect::<Vec<_>>(),
        ),
        Column::new(
            "current_step".into(),
            rows.iter().map(|(_, _, m)| m.current_step as u32).collect::<Vec<_>>(),
        ),
    ];
    for (i, name) in MATCH_POSE_COLUMNS.iter().enumerate() {
        columns.push(Column::new((*name).into(), f(&|m| pose(m, i))));
    }
    columns.extend([
        Column::new("f".into(), f(&|m| m.f)),
        Column::new("f_initial".into(), f(&|m| m.f_initial)),
        Column::new("pairs".into(), rows.iter().map(|(_, _, m)| m.pairs).collect::<Vec<_>>()),
        Column::new(
            "iterations".into(),
            rows.iter().map(|(_, _, m)| m.iterations).collect::<Vec<_>>(),
        ),
        Column::new(
            "evaluations".into(),
            rows.iter().map(|(_, _, m)| m.evaluations).collect::<Vec<_>>(),
        ),
        Column::new("fallback".into(), rows.iter().map(|(_, _, m)| m.fallback).collect::<Vec<_>>()),
        Column::new(
            "stop".into(),
            rows.iter().map(|(_, _, m)| m.stop.as_str()).collect::<Vec<_>>(),
        ),
        Column::new("time_s".into(), f(&|m| m.time_s)),
    ]);
    DataFrame::new(rows.len(), columns)
}

pub(super) fn read_matches(
    path: &Path,
    keep: &dyn Fn(&str) -> bool,
) -> Result<Vec<MatchRows>, StoreError> {
    read_whole(path, keep, parse_matches)
}

/// Appends the rows of `df` (whole runs, in file order) whose run `keep` accepts to `out`.
fn parse_matches(
    path: &Path,
    df: &DataFrame,
    keep: &dyn Fn(&str) -> bool,
    out: &mut Vec<MatchRows>,
) -> Result<(), StoreError> {
    let e = |x: PolarsError| err(path, x);
    let ids = df.column("run_id").map_err(e)?.str().map_err(e)?;
    let f = |name: &str| -> Result<Vec<f64>, StoreError> {
        Ok(df
            .column(name)
            .map_err(e)?
            .f64()
            .map_err(e)?
            .iter()
            .map(|v| v.unwrap_or(f64::NAN))
            .collect())
    };
    let u = |name: &str| -> Result<Vec<u32>, StoreError> {
        Ok(df.column(name).map_err(e)?.u32().map_err(e)?.iter().map(|v| v.unwrap_or(0)).collect())
    };
    let poses: Vec<Vec<f64>> = MATCH_POSE_COLUMNS.iter().map(|c| f(c)).collect::<Result<_, _>>()?;
    let (fv, fi, time) = (f("f")?, f("f_initial")?, f("time_s")?);
    let (rs, cs, pairs, iters) =
        (u("reference_step")?, u("current_step")?, u("pairs")?, u("iterations")?);
    let evals: Vec<u64> = df
        .column("evaluations")
        .map_err(e)?
        .u64()
        .map_err(e)?
        .iter()
        .map(|v| v.unwrap_or(0))
        .collect();
    let fallback: Vec<bool> = df
        .column("fallback")
        .map_err(e)?
        .bool()
        .map_err(e)?
        .iter()
        .map(|v| v.unwrap_or(false))
        .collect();
    let stop = df.column("stop").map_err(e)?.str().map_err(e)?;
    for i in 0..df.height() {
        let id = ids.get(i).unwrap_or_default();
        if !keep(id) {
            continue;
        }
        if out.last().is_none_or(|r| r.run_id != id) {
            out.push(MatchRows { run_id: id.to_string(), matches: Vec::new() });
        }
        let pose = |k: usize| Pose2::new(poses[3 * k][i], poses[3 * k + 1][i], poses[3 * k + 2][i]);
        out.last_mut().expect("just pushed").matches.push(MatchRecord {
            reference_step: rs[i] as usize,
            current_step: cs[i] as usize,
            truth: pose(0),
            initial: pose(1),
            estimate: pose(2),
            f: fv[i],
            f_initial: fi[i],
            pairs: pairs[i],
            iterations: iters[i],
            evaluations: evals[i],
            fallback: fallback[i],
            stop: stop.get(i).unwrap_or_default().to_string(),
            time_s: time[i],
        });
    }
    Ok(())
}

pub(super) fn timings_frame(timings: &[Timing]) -> PolarsResult<DataFrame> {
    DataFrame::new(
        timings.len(),
        vec![
            Column::new(
                "run_id".into(),
                timings.iter().map(|t| t.run_id.as_str()).collect::<Vec<_>>(),
            ),
            Column::new("wall_ms".into(), timings.iter().map(|t| t.wall_ms).collect::<Vec<_>>()),
            Column::new("steps".into(), timings.iter().map(|t| t.steps).collect::<Vec<_>>()),
            Column::new("cached".into(), timings.iter().map(|t| t.cached).collect::<Vec<_>>()),
        ],
    )
}

pub(super) fn read_timings(path: &Path) -> Result<Vec<Timing>, StoreError> {
    let df = read(path)?;
    let e = |x: PolarsError| err(path, x);
    let ids = df.column("run_id").map_err(e)?.str().map_err(e)?;
    let ms = df.column("wall_ms").map_err(e)?.f64().map_err(e)?;
    let cached = df.column("cached").map_err(e)?.bool().map_err(e)?;
    let steps = df.column("steps").map_err(e)?.u32().map_err(e)?;
    Ok((0..df.height())
        .map(|i| Timing {
            run_id: ids.get(i).unwrap_or_default().to_string(),
            wall_ms: ms.get(i).unwrap_or(f64::NAN),
            steps: steps.get(i).unwrap_or(0),
            cached: cached.get(i).unwrap_or(false),
        })
        .collect())
}

/// Where the runs lie in a per-run file (traces, final maps, matches), so that a reader wanting a
/// few runs decodes only their rows. Each row group's statistics bound the run ids it holds; the
/// `run_id` column of a row group that may hold a wanted run is read (once) to find each run's
/// block of consecutive rows, and only those blocks are decoded.
pub(super) struct RunIndex {
    metadata: std::sync::Arc<polars::io::parquet::read::FileMetadata>,
    groups: Vec<RowGroup>,
}

struct RowGroup {
    /// First row and number of rows.
    start: usize,
    rows: usize,
    /// The smallest and largest run id in the group; `None` without statistics (may hold any).
    bounds: Option<(String, String)>,
    /// `(run_id, first row, rows)` of each block of consecutive rows of one run, in file order;
    /// read when first needed.
    blocks: std::cell::OnceCell<Vec<(String, usize, usize)>>,
}

/// Kept blocks closer than this many rows are read as one slice (the rows between are decoded and
/// dropped): fewer, larger reads.
const MERGE_GAP_ROWS: usize = 4096;

impl RunIndex {
    /// Reads the file's metadata only.
    pub(super) fn build(path: &Path) -> Result<Self, StoreError> {
        assert_off_worker_pool(path);
        let file = std::fs::File::open(path).map_err(|e| StoreError::io(path, e))?;
        let metadata = ParquetReader::new(file).get_metadata().map_err(|x| err(path, x))?.clone();
        let mut start = 0;
        let groups = metadata
            .row_groups
            .iter()
            .map(|g| {
                let bounds = g
                    .columns_under_root_iter("run_id")
                    .and_then(|mut c| c.next())
                    .and_then(|c| c.statistics(&metadata.footer_buf))
                    .and_then(Result::ok)
                    .and_then(|s| match s {
                        polars_parquet::parquet::statistics::Statistics::Binary(b) => {
                            let text = |v: Option<Vec<u8>>| String::from_utf8(v?).ok();
                            Some((text(b.min_value)?, text(b.max_value)?))
                        }
                        _ => None,
                    });
                let group =
                    RowGroup { start, rows: g.num_rows(), bounds, blocks: Default::default() };
                start += g.num_rows();
                group
            })
            .collect();
        Ok(Self { metadata, groups })
    }

    /// Reads `rows` rows from `start` (of the columns `columns`, or all).
    fn slice(
        &self,
        path: &Path,
        (start, rows): (usize, usize),
        columns: Option<Vec<String>>,
    ) -> Result<DataFrame, StoreError> {
        assert_off_worker_pool(path);
        let file = std::fs::File::open(path).map_err(|e| StoreError::io(path, e))?;
        let mut reader = ParquetReader::new(file);
        reader.set_metadata(self.metadata.clone());
        reader
            .with_columns(columns)
            .with_slice(Some((start, rows)))
            .finish()
            .map_err(|x| err(path, x))
    }

    /// The blocks of runs of row group `g`, reading its `run_id` column the first time.
    fn blocks<'a>(
        &self,
        path: &Path,
        g: &'a RowGroup,
    ) -> Result<&'a [(String, usize, usize)], StoreError> {
        if g.blocks.get().is_none() {
            let df = self.slice(path, (g.start, g.rows), Some(vec!["run_id".into()]))?;
            let ids = df.column("run_id").map_err(|x| err(path, x))?;
            let mut blocks: Vec<(String, usize, usize)> = Vec::new();
            for (k, id) in ids.str().map_err(|x| err(path, x))?.iter().enumerate() {
                let id = id.unwrap_or_default();
                match blocks.last_mut() {
                    Some((last, _, n)) if last == id => *n += 1,
                    _ => blocks.push((id.to_string(), g.start + k, 1)),
                }
            }
            let _ = g.blocks.set(blocks);
        }
        Ok(g.blocks.get().expect("set above"))
    }

    /// The row ranges holding every run of `ids`, merged where close, in file order.
    fn ranges(
        &self,
        path: &Path,
        ids: &std::collections::BTreeSet<&str>,
    ) -> Result<Vec<(usize, usize)>, StoreError> {
        let mut out: Vec<(usize, usize)> = Vec::new();
        for g in &self.groups {
            let may_hold = match &g.bounds {
                Some((lo, hi)) => ids.range(lo.as_str()..=hi.as_str()).next().is_some(),
                None => !ids.is_empty(),
            };
            if !may_hold {
                continue;
            }
            for (_, start, n) in
                self.blocks(path, g)?.iter().filter(|(id, _, _)| ids.contains(id.as_str()))
            {
                match out.last_mut() {
                    Some((s, len)) if *s + *len + MERGE_GAP_ROWS >= *start => *len = start + n - *s,
                    _ => out.push((*start, *n)),
                }
            }
        }
        Ok(out)
    }

    /// The rows of the runs `ids`, parsed by `parse` from the slices that hold them, in file
    /// order.
    fn rows<T>(
        &self,
        path: &Path,
        ids: &std::collections::BTreeSet<&str>,
        parse: Parse<T>,
    ) -> Result<Vec<T>, StoreError> {
        let (keep, mut out) = (|id: &str| ids.contains(id), Vec::new());
        for range in self.ranges(path, ids)? {
            parse(path, &self.slice(path, range, None)?, &keep, &mut out)?;
        }
        Ok(out)
    }

    pub(super) fn traces(
        &self,
        path: &Path,
        ids: &std::collections::BTreeSet<&str>,
    ) -> Result<Vec<TraceRows>, StoreError> {
        Ok(finish_traces(self.rows(path, ids, parse_traces)?))
    }

    pub(super) fn landmarks(
        &self,
        path: &Path,
        ids: &std::collections::BTreeSet<&str>,
    ) -> Result<Vec<RunLandmarks>, StoreError> {
        self.rows(path, ids, parse_landmarks)
    }

    pub(super) fn matches(
        &self,
        path: &Path,
        ids: &std::collections::BTreeSet<&str>,
    ) -> Result<Vec<MatchRows>, StoreError> {
        self.rows(path, ids, parse_matches)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::seq::SliceRandom;
    use rand::{Rng, SeedableRng};

    fn trace(id: &str, n: usize) -> TraceRows {
        TraceRows {
            run_id: id.into(),
            dt_s: 0.5,
            truth: (0..n).map(|k| Pose2::new(k as f64, 1.0, 0.0)).collect(),
            estimate: (0..n).map(|k| Pose2::new(k as f64, 2.0, 0.1)).collect(),
            neff: if n % 2 == 0 { (0..n).map(|k| Some(k as f64)).collect() } else { Vec::new() },
        }
    }

    /// Reading some runs through the index gives exactly what a whole-file read filtered to them
    /// gives: runs of 1–40 rows over many row groups, written sorted and shuffled (overlapping
    /// statistics), asking for absent ids, none, one and all.
    #[test]
    fn run_index_reads_what_a_full_read_filters() {
        let dir = tempfile::tempdir().unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let ids: Vec<String> = (0..60).map(|k| format!("map--alg--p{k:03}--r00")).collect();
        for shuffled in [false, true] {
            let mut order = ids.clone();
            if shuffled {
                order.shuffle(&mut rng);
            }
            let traces: Vec<TraceRows> =
                order.iter().map(|id| trace(id, rng.random_range(1..40))).collect();
            let maps: Vec<RunLandmarks> = order
                .iter()
                .map(|id| RunLandmarks {
                    run_id: id.clone(),
                    landmarks: (0..rng.random_range(0..4))
                        .map(|k| LandmarkRow::Corner { x_m: k as f64, y_m: 1.0 })
                        .collect(),
                })
                .collect();
            let (tp, lp) =
                (dir.path().join("traces.parquet"), dir.path().join("landmarks.parquet"));
            for (path, mut df) in
                [(&tp, traces_frame(&traces).unwrap()), (&lp, landmarks_frame(&maps).unwrap())]
            {
                let file = std::fs::File::create(path).unwrap();
                ParquetWriter::new(file).with_row_group_size(Some(37)).finish(&mut df).unwrap();
            }
            let (ti, li) = (RunIndex::build(&tp).unwrap(), RunIndex::build(&lp).unwrap());
            assert!(ti.groups.len() > 10, "the test needs many row groups");
            let mut asks: Vec<Vec<&str>> = vec![vec![], vec!["absent"], vec![ids[0].as_str()]];
            asks.push(ids.iter().map(String::as_str).collect());
            for _ in 0..20 {
                let n = rng.random_range(1..8);
                asks.push((0..n).map(|_| ids[rng.random_range(0..ids.len())].as_str()).collect());
            }
            for ask in asks {
                let set: std::collections::BTreeSet<&str> = ask.iter().copied().collect();
                let keep = |id: &str| set.contains(id);
                assert_eq!(ti.traces(&tp, &set).unwrap(), read_traces(&tp, &keep).unwrap());
                assert_eq!(li.landmarks(&lp, &set).unwrap(), read_landmarks(&lp, &keep).unwrap());
            }
        }
    }
}
