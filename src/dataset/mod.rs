//! Real datasets: the `[dataset]` table of a map file ([`DatasetSpec`]) + the files on disk →
//! [`World`], the same type the simulator produces, so every algorithm and metric runs on real
//! logs unchanged.
//!
//! Two logs are supported:
//! - [`mrclam`]: UTIAS MRCLAM (Leung et al., IJRR 2011) — one iRobot Create, commanded (v, ω)
//!   odometry, monocular range-bearing measurements of 15 barcoded landmarks, Vicon ground truth
//!   of the robot and of the landmarks.
//! - [`victoria_park`]: ACFR Victoria Park (Guivant & Nebot, T-RA 2001) — a utility car, speed
//!   and steering with the Ackermann model, tree detections from a SICK laser, GPS only as a
//!   partial position reference, no landmark identities and no landmark ground truth.
//!
//! - [`intel_lab`]: Intel Research Lab (Hähnel, 2003), the CARMEN log with GMapping-corrected
//!   poses — 910 laser scans for scan matching against the corrected relative poses.
//!
//! This is the one place real-log IO happens: [`load`] reads the files and hands their text to
//! pure parsers (`&str` → records, errors carry the line number) and pure assemblers (records →
//! [`World`]). Dataset files are read, never copied into the repository; [`DatasetSpec::files`]
//! lists them so that the run layer can hash their contents.

pub mod intel_lab;
pub mod mrclam;
pub mod psm_samples;
pub mod victoria_park;

use crate::config::{Checks, Violation};
use crate::world::{MAX_DT_S, MIN_DT_S, World};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Bump when a loader's output, or a metric only real data exercises, changes for the same files:
/// part of the content hash of every run on real data. datasets-3: the path length through sparse
/// (GPS) truth.
pub const DATASET_CODE_VERSION: &str = "datasets-3";

pub use crate::world::point_sensor::UNKNOWN_LANDMARK;

/// The `[dataset]` table of a map file (data/maps/<name>.toml) — how to read a real dataset.
///
/// `path` is relative to the repository root (the folder holding `Cargo.toml`); the shared data
/// live next to the repository, in `../shared/data`. `start_s` counts from the first odometry
/// record of the log (MRCLAM: the first `Robot<n>_Odometry.dat` row; Victoria Park: the first
/// `inputs.dat` row), `duration_s = 0` means "to the end of the log".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum DatasetSpec {
    /// UTIAS MRCLAM, one robot of one dataset folder ([`mrclam`]).
    Mrclam {
        /// The `MRCLAM_Dataset<n>` folder, relative to the repository root.
        #[serde(default = "default_mrclam_path")]
        path: String,
        /// Robot number n (1–5): reads `Robot<n>_{Odometry,Measurement,Groundtruth}.dat`.
        #[serde(default = "default_mrclam_robot")]
        robot: u32,
        /// Offset of the window into the log [s], from the first odometry record.
        #[serde(default)]
        start_s: f64,
        /// Length of the window [s]; 0 = to the end of the log.
        #[serde(default)]
        duration_s: f64,
        /// σr [m] the filters are told (default: see [`mrclam::DEFAULT_RANGE_SIGMA_M`]).
        #[serde(default = "mrclam_range_sigma")]
        range_sigma_m: f64,
        /// σb [rad] the filters are told (default: see [`mrclam::DEFAULT_BEARING_SIGMA_RAD`]).
        #[serde(default = "mrclam_bearing_sigma")]
        bearing_sigma_rad: f64,
        /// Δt [s]: the commanded (v, ω) records (irregular: median 10 ms apart, ~69 per second
        /// on average, gaps up to 1 s) are integrated exactly over fixed steps of this length
        /// (default: see [`mrclam::DEFAULT_STEP_S`]).
        #[serde(default = "mrclam_step")]
        step_s: f64,
    },
    /// ACFR Victoria Park ([`victoria_park`]).
    VictoriaPark {
        /// The folder holding `inputs.dat`, `measurements.dat` and `gps.dat`, relative to the
        /// repository root.
        #[serde(default = "default_victoria_park_path")]
        path: String,
        /// Offset of the window into the log [s], from the first `inputs.dat` record.
        #[serde(default)]
        start_s: f64,
        /// Length of the window [s]; 0 = to the end of the log.
        #[serde(default)]
        duration_s: f64,
        /// σr [m] the filters are told (default: see [`victoria_park::DEFAULT_RANGE_SIGMA_M`]).
        #[serde(default = "victoria_park_range_sigma")]
        range_sigma_m: f64,
        /// σb [rad] the filters are told (default: see
        /// [`victoria_park::DEFAULT_BEARING_SIGMA_RAD`]).
        #[serde(default = "victoria_park_bearing_sigma")]
        bearing_sigma_rad: f64,
        /// Tree detections farther than this [m] are dropped (default 30 m, the usual choice:
        /// far detections are few, noisy and often spurious; the laser reaches 80 m).
        #[serde(default = "victoria_park_max_range")]
        max_range_m: f64,
    },
    /// Intel Research Lab, corrected CARMEN log ([`intel_lab`]): laser scans only.
    IntelLab {
        /// The folder holding `intel-corrected.log.gz`, relative to the repository root.
        #[serde(default = "default_intel_lab_path")]
        path: String,
        /// Index of the first scan used (0-based).
        #[serde(default)]
        first_scan: usize,
        /// How many consecutive scans; 0 = to the end of the log.
        #[serde(default)]
        scans: usize,
        /// Ranges at or beyond this [m] are no return (the log writes 81.83 m for none).
        #[serde(default = "intel_lab_max_range")]
        max_range_m: f64,
    },
}

fn default_mrclam_path() -> String {
    "../shared/data/utias-mrclam/MRCLAM_Dataset6".to_string()
}
fn default_mrclam_robot() -> u32 {
    3
}
fn mrclam_range_sigma() -> f64 {
    mrclam::DEFAULT_RANGE_SIGMA_M
}
fn mrclam_bearing_sigma() -> f64 {
    mrclam::DEFAULT_BEARING_SIGMA_RAD
}
fn mrclam_step() -> f64 {
    mrclam::DEFAULT_STEP_S
}
fn default_victoria_park_path() -> String {
    "../shared/data/victoria-park".to_string()
}
fn victoria_park_range_sigma() -> f64 {
    victoria_park::DEFAULT_RANGE_SIGMA_M
}
fn victoria_park_bearing_sigma() -> f64 {
    victoria_park::DEFAULT_BEARING_SIGMA_RAD
}
fn default_intel_lab_path() -> String {
    "../shared/data/intel-lab".to_string()
}
fn intel_lab_max_range() -> f64 {
    intel_lab::DEFAULT_MAX_RANGE_M
}
fn victoria_park_max_range() -> f64 {
    victoria_park::DEFAULT_MAX_RANGE_M
}

/// Robots of an MRCLAM dataset: subjects 1–5.
const MRCLAM_ROBOTS: std::ops::RangeInclusive<u32> = 1..=5;

impl DatasetSpec {
    /// The MRCLAM spec with every default (Dataset6, robot 3, the whole log).
    pub fn mrclam_default() -> Self {
        DatasetSpec::Mrclam {
            path: default_mrclam_path(),
            robot: default_mrclam_robot(),
            start_s: 0.0,
            duration_s: 0.0,
            range_sigma_m: mrclam_range_sigma(),
            bearing_sigma_rad: mrclam_bearing_sigma(),
            step_s: mrclam_step(),
        }
    }

    /// The Victoria Park spec with every default (the whole log).
    pub fn victoria_park_default() -> Self {
        DatasetSpec::VictoriaPark {
            path: default_victoria_park_path(),
            start_s: 0.0,
            duration_s: 0.0,
            range_sigma_m: victoria_park_range_sigma(),
            bearing_sigma_rad: victoria_park_bearing_sigma(),
            max_range_m: victoria_park_max_range(),
        }
    }

    /// The dataset folder, resolved against the repository root.
    pub fn folder(&self, root: &Path) -> PathBuf {
        match self {
            DatasetSpec::Mrclam { path, .. }
            | DatasetSpec::VictoriaPark { path, .. }
            | DatasetSpec::IntelLab { path, .. } => root.join(path),
        }
    }

    /// Every file [`load`] reads, in a fixed order, for content hashing.
    pub fn files(&self, root: &Path) -> Vec<PathBuf> {
        let folder = self.folder(root);
        match self {
            DatasetSpec::Mrclam { robot, .. } => {
                mrclam::file_names(*robot).into_iter().map(|f| folder.join(f)).collect()
            }
            DatasetSpec::VictoriaPark { .. } => {
                victoria_park::FILE_NAMES.iter().map(|f| folder.join(f)).collect()
            }
            DatasetSpec::IntelLab { .. } => vec![folder.join(intel_lab::FILE_NAME)],
        }
    }

    /// Whether the log's odometry is its ground truth (the Intel lab's corrected poses, no raw
    /// odometry): a study then makes its odometry by perturbing it with its `[odometry]` model.
    pub fn odometry_is_truth(&self) -> bool {
        matches!(self, DatasetSpec::IntelLab { .. })
    }

    /// Whether the log's truth is positions only in its own frame (Victoria Park's GPS): the
    /// metrics then align the estimate to it rigidly first (`metrics::compute`).
    pub fn truth_is_positions_only(&self) -> bool {
        matches!(self, DatasetSpec::VictoriaPark { .. })
    }

    /// What the dataset's sensor sees: laser scans (Intel lab) or point landmarks.
    pub fn world_kind(&self) -> crate::world::WorldKind {
        match self {
            DatasetSpec::IntelLab { .. } => crate::world::WorldKind::Laser,
            DatasetSpec::Mrclam { .. } | DatasetSpec::VictoriaPark { .. } => {
                crate::world::WorldKind::Points
            }
        }
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        match self {
            DatasetSpec::Mrclam {
                path,
                robot,
                start_s,
                duration_s,
                range_sigma_m,
                bearing_sigma_rad,
                step_s,
            } => {
                c.require(!path.trim().is_empty(), "path", || {
                    "must name the dataset folder".to_string()
                });
                c.require(MRCLAM_ROBOTS.contains(robot), "robot", || {
                    format!("must be one of the MRCLAM robots 1–5, got {robot}")
                });
                c.non_negative("start_s", *start_s);
                c.non_negative("duration_s", *duration_s);
                c.positive("range_sigma_m", *range_sigma_m);
                c.positive("bearing_sigma_rad", *bearing_sigma_rad);
                c.in_range("step_s", *step_s, MIN_DT_S, MAX_DT_S);
            }
            DatasetSpec::VictoriaPark {
                path,
                start_s,
                duration_s,
                range_sigma_m,
                bearing_sigma_rad,
                max_range_m,
            } => {
                c.require(!path.trim().is_empty(), "path", || {
                    "must name the dataset folder".to_string()
                });
                c.non_negative("start_s", *start_s);
                c.non_negative("duration_s", *duration_s);
                c.positive("range_sigma_m", *range_sigma_m);
                c.positive("bearing_sigma_rad", *bearing_sigma_rad);
                c.positive("max_range_m", *max_range_m);
            }
            DatasetSpec::IntelLab { path, max_range_m, .. } => {
                c.require(!path.trim().is_empty(), "path", || {
                    "must name the dataset folder".to_string()
                });
                c.positive("max_range_m", *max_range_m);
            }
        }
        c.finish()
    }
}

/// Why a dataset could not be read.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error("dataset not found: {path} does not exist ({hint})")]
    Missing { path: PathBuf, hint: String },
    #[error("cannot read {path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}, line {line}: {message}")]
    Malformed { path: PathBuf, line: usize, message: String },
    #[error("invalid [dataset] table: {}", .0.iter().map(|v| format!("{}: {}", v.key, v.message)).collect::<Vec<_>>().join("; "))]
    Invalid(Vec<Violation>),
    /// The files are well formed but the requested window holds nothing usable (no odometry
    /// step, no ground truth at the start, …).
    #[error("{path}: {message}")]
    Empty { path: PathBuf, message: String },
}

/// What loading kept and dropped — for logs and for tests; the [`World`] itself only holds what
/// was kept.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadStats {
    /// Odometry steps (`world.odometry.len()`).
    pub steps: usize,
    /// Poses of `world.truth` with a finite position (MRCLAM: Vicon; Victoria Park: GPS fixes
    /// plus the start pose).
    pub truth_known: usize,
    /// Measurement records read from the file (whole log).
    pub measurements_read: usize,
    /// Measurements put into `world.point_scans`.
    pub measurements_kept: usize,
    /// Records outside the window (more than half a step before the first or after the last step).
    pub dropped_outside_window: usize,
    /// Records with a non-finite range or bearing.
    pub dropped_non_finite: usize,
    /// MRCLAM: barcodes absent from `Barcodes.dat`.
    pub dropped_unknown_barcode: usize,
    /// MRCLAM: measurements of the other robots (subjects that are not landmarks).
    pub dropped_robot: usize,
    /// Victoria Park: detections beyond `max_range_m`.
    pub dropped_beyond_max_range: usize,
}

/// Loads the dataset `spec` describes; `root` is the repository root its `path` is relative to.
pub fn load(spec: &DatasetSpec, root: &Path) -> Result<World, DatasetError> {
    load_with_stats(spec, root).map(|(world, _)| world)
}

/// [`load`], also returning what was kept and dropped.
pub fn load_with_stats(
    spec: &DatasetSpec,
    root: &Path,
) -> Result<(World, LoadStats), DatasetError> {
    let violations = spec.validate();
    if !violations.is_empty() {
        return Err(DatasetError::Invalid(violations));
    }
    let folder = spec.folder(root);
    if !folder.is_dir() {
        return Err(missing(folder));
    }
    match *spec {
        DatasetSpec::Mrclam {
            robot,
            start_s,
            duration_s,
            range_sigma_m,
            bearing_sigma_rad,
            step_s,
            ..
        } => {
            let window = mrclam::Window { start_s, duration_s, step_s };
            let noise = noise(range_sigma_m, bearing_sigma_rad);
            mrclam::load(&folder, robot, &window, noise)
        }
        DatasetSpec::VictoriaPark {
            start_s,
            duration_s,
            range_sigma_m,
            bearing_sigma_rad,
            max_range_m,
            ..
        } => {
            let window = victoria_park::Window { start_s, duration_s, max_range_m };
            victoria_park::load(&folder, &window, noise(range_sigma_m, bearing_sigma_rad))
        }
        DatasetSpec::IntelLab { first_scan, scans, max_range_m, .. } => {
            let world = intel_lab::load(&folder, first_scan, scans, max_range_m)?;
            let stats = LoadStats {
                steps: world.odometry.len(),
                truth_known: world.truth.len(),
                ..LoadStats::default()
            };
            Ok((world, stats))
        }
    }
}

fn noise(range_sigma_m: f64, bearing_sigma_rad: f64) -> crate::world::point_sensor::PointNoise {
    crate::world::point_sensor::PointNoise {
        range_noise: crate::world::RangeNoise::Constant,
        range_sigma_m,
        bearing_sigma_rad,
    }
}

fn missing(path: PathBuf) -> DatasetError {
    DatasetError::Missing {
        path,
        hint: "the shared data folder `../shared/data` is expected next to the repository; \
               otherwise set `path` in the map file's [dataset] table to where the dataset is"
            .to_string(),
    }
}

/// Reads one dataset file as text.
fn read_text(path: &Path) -> Result<String, DatasetError> {
    std::fs::read_to_string(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => missing(path.to_path_buf()),
        _ => DatasetError::Io { path: path.to_path_buf(), source },
    })
}

/// Reads one gzip-compressed dataset file as text.
fn read_gz_text(path: &Path) -> Result<String, DatasetError> {
    use std::io::Read;
    let file = std::fs::File::open(path).map_err(|source| match source.kind() {
        std::io::ErrorKind::NotFound => missing(path.to_path_buf()),
        _ => DatasetError::Io { path: path.to_path_buf(), source },
    })?;
    let mut text = String::new();
    flate2::read::GzDecoder::new(std::io::BufReader::new(file))
        .read_to_string(&mut text)
        .map_err(|source| DatasetError::Io { path: path.to_path_buf(), source })?;
    Ok(text)
}

/// A parse error in a text table: 1-based line number and what is wrong. The loader adds the
/// file's path ([`LineError::in_file`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LineError {
    pub line: usize,
    pub message: String,
}

impl LineError {
    pub fn new(line: usize, message: impl Into<String>) -> Self {
        Self { line, message: message.into() }
    }

    pub fn in_file(self, path: &Path) -> DatasetError {
        DatasetError::Malformed { path: path.to_path_buf(), line: self.line, message: self.message }
    }
}

/// One data row of a whitespace-separated numeric table, with its 1-based line number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row<const N: usize> {
    pub line: usize,
    pub values: [f64; N],
}

/// Parses a table of `N` whitespace-separated numbers per line. Blank lines and comment lines
/// (first non-blank character `#` or `%`: the UTIAS and ACFR headers) are skipped; any other line
/// must hold exactly `N` numbers. Non-finite values (`nan`, `inf`) parse: each loader decides
/// what they mean.
pub fn parse_table<const N: usize>(text: &str) -> Result<Vec<Row<N>>, LineError> {
    let mut rows = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.trim();
        if content.is_empty() || content.starts_with('#') || content.starts_with('%') {
            continue;
        }
        let mut values = [0.0; N];
        let mut n = 0;
        for token in content.split_whitespace() {
            if n < N {
                values[n] = token.parse().map_err(|_| {
                    LineError::new(line, format!("column {}: `{token}` is not a number", n + 1))
                })?;
            }
            n += 1;
        }
        if n != N {
            return Err(LineError::new(line, format!("expected {N} columns, found {n}")));
        }
        rows.push(Row { line, values });
    }
    Ok(rows)
}

/// Checks that the times (column 0) are finite and never decrease.
fn check_times<const N: usize>(rows: &[Row<N>]) -> Result<(), LineError> {
    let mut previous = f64::NEG_INFINITY;
    for r in rows {
        let t = r.values[0];
        if !t.is_finite() {
            return Err(LineError::new(r.line, format!("time `{t}` is not finite")));
        }
        if t < previous {
            return Err(LineError::new(
                r.line,
                format!("time {t} is before the previous record's {previous}"),
            ));
        }
        previous = t;
    }
    Ok(())
}

/// A whole, non-negative number in column `col` (0-based) of `row` (subject and barcode ids).
fn whole<const N: usize>(row: &Row<N>, col: usize) -> Result<u32, LineError> {
    let v = row.values[col];
    if v.fract() == 0.0 && (0.0..=u32::MAX as f64).contains(&v) {
        Ok(v as u32)
    } else {
        Err(LineError::new(
            row.line,
            format!("column {}: expected a whole number, found {v}", col + 1),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_skips_comments_and_blank_lines_and_names_the_bad_line() {
        let text = "# header\n% acfr\n\n 1.0 \t 2 3\n4 5 6\n";
        let rows = parse_table::<3>(text).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[0], Row { line: 4, values: [1.0, 2.0, 3.0] });
        assert_eq!(rows[1].line, 5);
        let err = parse_table::<3>("1 2 3\n4 5\n").unwrap_err();
        assert_eq!(err.line, 2);
        assert!(err.message.contains("expected 3 columns, found 2"), "{}", err.message);
        let err = parse_table::<3>("1 2 3\n4 5 6 7\n").unwrap_err();
        assert_eq!(err.line, 2);
        let err = parse_table::<2>("# h\n1 x\n").unwrap_err();
        assert_eq!((err.line, err.message.as_str()), (2, "column 2: `x` is not a number"));
    }

    #[test]
    fn times_must_be_finite_and_ordered() {
        let rows = parse_table::<2>("1 0\n1 0\n2 0\n").unwrap();
        assert!(check_times(&rows).is_ok());
        let rows = parse_table::<2>("1 0\n0.5 0\n").unwrap();
        assert_eq!(check_times(&rows).unwrap_err().line, 2);
        let rows = parse_table::<2>("nan 0\n").unwrap();
        assert_eq!(check_times(&rows).unwrap_err().line, 1);
    }

    #[test]
    fn spec_defaults_and_unknown_keys() {
        let spec: DatasetSpec = toml::from_str("kind = \"mrclam\"").unwrap();
        assert_eq!(spec, DatasetSpec::mrclam_default());
        assert!(spec.validate().is_empty());
        let spec: DatasetSpec =
            toml::from_str("kind = \"victoria_park\"\nduration_s = 100.0").unwrap();
        let DatasetSpec::VictoriaPark { duration_s, max_range_m, .. } = spec else { panic!() };
        assert_eq!((duration_s, max_range_m), (100.0, 30.0));
        let err = toml::from_str::<DatasetSpec>("kind = \"mrclam\"\nrobbot = 2").unwrap_err();
        assert!(err.to_string().contains("robbot"), "{err}");
        let err =
            toml::from_str::<DatasetSpec>("kind = \"victoria_park\"\nstep_s = 0.1").unwrap_err();
        assert!(err.to_string().contains("step_s"), "{err}");
    }

    #[test]
    fn validation_names_each_bad_key() {
        let DatasetSpec::Mrclam { path, range_sigma_m, bearing_sigma_rad, .. } =
            DatasetSpec::mrclam_default()
        else {
            panic!()
        };
        let spec = DatasetSpec::Mrclam {
            path,
            robot: 6,
            start_s: -1.0,
            duration_s: f64::NAN,
            range_sigma_m,
            bearing_sigma_rad,
            step_s: 0.0,
        };
        let keys: Vec<String> = spec.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["robot", "start_s", "duration_s", "step_s"]);
        let spec = DatasetSpec::VictoriaPark {
            path: " ".into(),
            start_s: 0.0,
            duration_s: 0.0,
            range_sigma_m: 0.0,
            bearing_sigma_rad: 0.1,
            max_range_m: -3.0,
        };
        let keys: Vec<String> = spec.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["path", "range_sigma_m", "max_range_m"]);
        assert!(
            matches!(load(&spec, Path::new(".")), Err(DatasetError::Invalid(v)) if v.len() == 3)
        );
    }

    #[test]
    fn files_are_listed_for_hashing() {
        let root = Path::new("/repo");
        let files = DatasetSpec::mrclam_default().files(root);
        let names: Vec<_> =
            files.iter().map(|f| f.file_name().unwrap().to_str().unwrap()).collect();
        assert_eq!(
            names,
            [
                "Barcodes.dat",
                "Landmark_Groundtruth.dat",
                "Robot3_Odometry.dat",
                "Robot3_Groundtruth.dat",
                "Robot3_Measurement.dat"
            ]
        );
        assert!(files[0].starts_with("/repo/../shared/data/utias-mrclam/MRCLAM_Dataset6"));
        let files = DatasetSpec::victoria_park_default().files(root);
        assert_eq!(files.len(), 3);
    }

    #[test]
    fn missing_folder_says_where_it_looked() {
        let spec = DatasetSpec::Mrclam {
            path: "no/such/folder".into(),
            robot: 3,
            start_s: 0.0,
            duration_s: 0.0,
            range_sigma_m: 0.1,
            bearing_sigma_rad: 0.1,
            step_s: 0.02,
        };
        let err = load(&spec, Path::new("/nonexistent-root")).unwrap_err();
        let message = err.to_string();
        assert!(matches!(err, DatasetError::Missing { .. }));
        assert!(
            message.contains("/nonexistent-root/no/such/folder")
                && message.contains("../shared/data"),
            "{message}"
        );
    }
}

/// Helpers shared by the real-data tests of both loaders.
#[cfg(test)]
pub(crate) mod test_data {
    use std::path::{Path, PathBuf};

    /// The repository root the specs' default paths are relative to.
    pub fn repository_root() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }

    /// Whether the shared data folder `sub` (under `../shared/data`) exists; if not, says the
    /// test is skipped.
    pub fn available(sub: &str, test: &str) -> bool {
        let folder = repository_root().join("../shared/data").join(sub);
        let ok = Path::new(&folder).is_dir();
        if !ok {
            eprintln!("skipped: {test}: real dataset folder {} is absent", folder.display());
        }
        ok
    }
}
