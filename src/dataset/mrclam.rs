//! UTIAS MRCLAM (Leung, Halpern, Barfoot, Liu, "The UTIAS multi-robot cooperative localization
//! and mapping dataset", IJRR 30(8), 2011): one robot's log files → [`World`].
//!
//! Files (all whitespace-separated, `#` header lines; times are Unix seconds):
//! - `Robot<n>_Odometry.dat`: time, v [m/s], ω [rad/s] — *commanded* velocities, irregular
//!   (median 10 ms, gaps up to 1 s in Dataset6/Robot3);
//! - `Robot<n>_Measurement.dat`: time, **barcode** (the header says "Subject #", but the column
//!   holds barcodes), range [m], bearing [rad] — monocular camera, several rows per frame;
//! - `Robot<n>_Groundtruth.dat`: time, x [m], y [m], θ [rad] — Vicon, ~60 Hz;
//! - `Landmark_Groundtruth.dat`: subject, x, y, σx, σy [m] (σ ignored: ≤ 0.3 mm);
//! - `Barcodes.dat`: subject, barcode.
//!
//! Choices (each one a named constant or a spec field):
//! - **Time base.** Times are taken relative to the first odometry record; `start_s` counts
//!   from it. Step k starts at t_k = t_start + k·Δt, Δt = `step_s`; the window ends at
//!   t_start + `duration_s` or at the last odometry record, whichever is first, and holds
//!   ⌊(t_end − t_start)/Δt⌋ whole steps.
//! - **Odometry.** Each (v, ω) command holds from its time stamp until the next one (zero-order
//!   hold: commands are set-points). `odometry[k]` composes the exact arcs
//!   (`geom::unicycle_increment`) of the pieces of [t_k, t_{k+1}], so a filter composing the
//!   increments reproduces the commanded path exactly, whatever Δt. Default Δt = 0.02 s: the
//!   50 Hz of the official UTIAS MATLAB tools (README), finer than the ~6 Hz camera and close to
//!   the command rate, so the zero-order hold loses nothing.
//! - **Truth.** `truth[k]` is the Vicon pose interpolated at t_k (position linearly, heading
//!   along the shorter arc); NaN when t_k is outside the Vicon log or its two neighbouring
//!   samples are more than [`MAX_TRUTH_GAP_S`] apart. `truth[0]` — the start pose every
//!   algorithm is given — must be known, else loading fails.
//! - **Measurements.** A barcode maps to a subject through `Barcodes.dat`; subjects listed in
//!   `Landmark_Groundtruth.dat` are landmarks, all others (subjects 1–5) are robots, whose
//!   measurements are dropped. `landmark` indexes `truth_points`, which lists the landmark
//!   subjects in file order (subject 6 → 0, …, 20 → 14 in Dataset6; [`subject_of_landmark`]
//!   keeps the mapping). Unknown barcodes (Dataset6/Robot3 has two rows of barcode 34) and
//!   non-finite rows are dropped and counted in [`LoadStats`]. A measurement at time t goes to
//!   the step whose start t_k is nearest (|t − t_k| ≤ Δt/2: the pose it is taken from is at most
//!   half a step old); measurements more than half a step outside the window are dropped.
//!   Within a step, measurements keep their file order.
//! - **Sensor frame.** Range and bearing are taken as relative to the Vicon robot pose (the
//!   camera is on the robot's centre line): reprojecting them from the interpolated Vicon pose
//!   lands on the true landmark to within a few decimetres (see the real-data test).

use super::{DatasetError, LineError, LoadStats, Row, check_times, parse_table, read_text, whole};
use crate::geom::{Point2, Pose2, unicycle_increment, wrap_angle};
use crate::world::World;
use crate::world::point_sensor::{PointNoise, PointObservation, PointScan};
use std::collections::BTreeMap;
use std::path::Path;

/// Default odometry step Δt [s]: the official UTIAS tools resample every log to 50 Hz.
pub const DEFAULT_STEP_S: f64 = 0.02;

/// Default σr [m], measured on Dataset6/Robot3 against Vicon (the real-data test prints it):
/// the range residuals have 1.4826·MAD = 0.13 m, a 90th-percentile |deviation| of 0.28 m (σ ≈
/// 0.17 m if Gaussian) and a standard deviation of 0.17 m; 0.15 m. The dataset paper states no
/// sensor noise.
pub const DEFAULT_RANGE_SIGMA_M: f64 = 0.15;

/// Default σb [rad], measured the same way: the bearing residuals have 1.4826·MAD = 0.006 rad
/// and a 90th-percentile |deviation| of 0.014 rad (σ ≈ 0.009 rad), but a standard deviation of
/// 0.09 rad from a few gross outliers (≈ 3 % of the rows reproject more than 0.5 m off), which a
/// filter must gate rather than absorb; 0.02 rad (1.1°), about twice the Gaussian core, also
/// covers the time offset of attaching a measurement to the nearest step (≤ Δt/2 at up to
/// 0.56 rad/s).
pub const DEFAULT_BEARING_SIGMA_RAD: f64 = 0.02;

/// Vicon samples more than this [s] apart leave the truth between them unknown (NaN): the Vicon
/// log of Dataset6/Robot3 has no larger gap than 0.34 s, so this only marks the log's ends and
/// genuine dropouts, never normal sampling.
pub const MAX_TRUTH_GAP_S: f64 = 0.5;

/// Files read for robot `robot`, in hashing order.
pub fn file_names(robot: u32) -> [String; 5] {
    [
        "Barcodes.dat".to_string(),
        "Landmark_Groundtruth.dat".to_string(),
        format!("Robot{robot}_Odometry.dat"),
        format!("Robot{robot}_Groundtruth.dat"),
        format!("Robot{robot}_Measurement.dat"),
    ]
}

/// The part of the log to load and how to step it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// Offset [s] from the first odometry record.
    pub start_s: f64,
    /// Length [s]; 0 = to the end.
    pub duration_s: f64,
    /// Δt [s].
    pub step_s: f64,
}

/// A commanded velocity, held until the next record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryRecord {
    pub time_s: f64,
    pub v_mps: f64,
    pub omega_radps: f64,
}

/// A Vicon pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GroundTruthRecord {
    pub time_s: f64,
    pub pose: Pose2,
}

/// A camera measurement of a barcode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasurementRecord {
    pub time_s: f64,
    pub barcode: u32,
    pub range_m: f64,
    pub bearing_rad: f64,
}

/// A landmark's Vicon position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandmarkRecord {
    pub subject: u32,
    pub position: Point2,
}

/// One row of `Barcodes.dat`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BarcodeRecord {
    pub subject: u32,
    pub barcode: u32,
}

/// Parses `Robot<n>_Odometry.dat`: times must be ordered, velocities finite.
pub fn parse_odometry(text: &str) -> Result<Vec<OdometryRecord>, LineError> {
    let rows = parse_table::<3>(text)?;
    check_times(&rows)?;
    rows.iter()
        .map(|r| {
            let [time_s, v_mps, omega_radps] = r.values;
            if v_mps.is_finite() && omega_radps.is_finite() {
                Ok(OdometryRecord { time_s, v_mps, omega_radps })
            } else {
                Err(LineError::new(r.line, "velocity is not finite"))
            }
        })
        .collect()
}

/// Parses `Robot<n>_Groundtruth.dat`: times must be ordered; samples with a non-finite pose are
/// left out (the truth around them is then interpolated across, or unknown if the gap is long).
pub fn parse_ground_truth(text: &str) -> Result<Vec<GroundTruthRecord>, LineError> {
    let rows = parse_table::<4>(text)?;
    check_times(&rows)?;
    Ok(rows
        .iter()
        .map(|r| GroundTruthRecord {
            time_s: r.values[0],
            pose: Pose2::new(r.values[1], r.values[2], r.values[3]),
        })
        .filter(|g| g.pose.is_finite())
        .collect())
}

/// Parses `Robot<n>_Measurement.dat`: times must be ordered and barcodes whole numbers;
/// non-finite ranges and bearings are kept here and dropped (counted) when assembling.
pub fn parse_measurements(text: &str) -> Result<Vec<MeasurementRecord>, LineError> {
    let rows = parse_table::<4>(text)?;
    check_times(&rows)?;
    rows.iter()
        .map(|r| {
            Ok(MeasurementRecord {
                time_s: r.values[0],
                barcode: whole(r, 1)?,
                range_m: r.values[2],
                bearing_rad: r.values[3],
            })
        })
        .collect()
}

/// Parses `Landmark_Groundtruth.dat` (subject, x, y, σx, σy); subjects must be unique and
/// positions finite.
pub fn parse_landmarks(text: &str) -> Result<Vec<LandmarkRecord>, LineError> {
    let rows = parse_table::<5>(text)?;
    let mut out: Vec<LandmarkRecord> = Vec::with_capacity(rows.len());
    for r in &rows {
        let subject = whole(r, 0)?;
        let position = Point2::new(r.values[1], r.values[2]);
        if !(position.x.is_finite() && position.y.is_finite()) {
            return Err(LineError::new(r.line, "landmark position is not finite"));
        }
        if out.iter().any(|l| l.subject == subject) {
            return Err(LineError::new(r.line, format!("subject {subject} is listed twice")));
        }
        out.push(LandmarkRecord { subject, position });
    }
    Ok(out)
}

/// Parses `Barcodes.dat` (subject, barcode); barcodes must be unique.
pub fn parse_barcodes(text: &str) -> Result<Vec<BarcodeRecord>, LineError> {
    let rows: Vec<Row<2>> = parse_table(text)?;
    let mut out: Vec<BarcodeRecord> = Vec::with_capacity(rows.len());
    for r in &rows {
        let (subject, barcode) = (whole(r, 0)?, whole(r, 1)?);
        if out.iter().any(|b| b.barcode == barcode) {
            return Err(LineError::new(r.line, format!("barcode {barcode} is listed twice")));
        }
        out.push(BarcodeRecord { subject, barcode });
    }
    Ok(out)
}

/// One robot's parsed log.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    pub odometry: Vec<OdometryRecord>,
    pub ground_truth: Vec<GroundTruthRecord>,
    pub measurements: Vec<MeasurementRecord>,
    pub landmarks: Vec<LandmarkRecord>,
    pub barcodes: Vec<BarcodeRecord>,
}

/// The subject number of `truth_points[index]` (landmark subjects in file order).
pub fn subject_of_landmark(landmarks: &[LandmarkRecord], index: usize) -> Option<u32> {
    landmarks.get(index).map(|l| l.subject)
}

/// Reads and assembles robot `robot`'s log from the dataset folder `folder`.
pub fn load(
    folder: &Path,
    robot: u32,
    window: &Window,
    noise: PointNoise,
) -> Result<(World, LoadStats), DatasetError> {
    let [barcodes, landmarks, odometry, ground_truth, measurements] =
        file_names(robot).map(|name| folder.join(name));
    let log = Log {
        barcodes: parse_barcodes(&read_text(&barcodes)?).map_err(|e| e.in_file(&barcodes))?,
        landmarks: parse_landmarks(&read_text(&landmarks)?).map_err(|e| e.in_file(&landmarks))?,
        odometry: parse_odometry(&read_text(&odometry)?).map_err(|e| e.in_file(&odometry))?,
        ground_truth: parse_ground_truth(&read_text(&ground_truth)?)
            .map_err(|e| e.in_file(&ground_truth))?,
        measurements: parse_measurements(&read_text(&measurements)?)
            .map_err(|e| e.in_file(&measurements))?,
    };
    assemble(&log, window, noise)
        .map_err(|message| DatasetError::Empty { path: folder.to_path_buf(), message })
}

/// Builds the [`World`] of `window` from a parsed log (see the module doc for every choice).
/// Fails, with a message, only when the window holds no whole step or no start pose.
pub fn assemble(
    log: &Log,
    window: &Window,
    noise: PointNoise,
) -> Result<(World, LoadStats), String> {
    let dt = window.step_s;
    let (Some(first), Some(last)) = (log.odometry.first(), log.odometry.last()) else {
        return Err("the odometry file holds no record".to_string());
    };
    let t0 = first.time_s;
    let t_start = t0 + window.start_s;
    let log_end = last.time_s;
    let t_end =
        if window.duration_s > 0.0 { (t_start + window.duration_s).min(log_end) } else { log_end };
    let steps = ((t_end - t_start) / dt + STEP_COUNT_SLACK).floor();
    if !(steps >= 1.0) {
        return Err(format!(
            "the window [{:.3} s, {:.3} s] after the first odometry record holds no whole step of {dt} s (the log lasts {:.3} s)",
            window.start_s,
            window.start_s + window.duration_s,
            log_end - t0
        ));
    }
    let steps = steps as usize;
    let step_time = |k: usize| t_start + k as f64 * dt;

    let odometry = integrate_commands(&log.odometry, t_start, dt, steps);
    let truth: Vec<Pose2> =
        (0..=steps).map(|k| interpolate_truth(&log.ground_truth, step_time(k))).collect();
    if !truth[0].is_finite() {
        return Err(format!(
            "no Vicon ground truth at the window start ({:.3} s after the first odometry record)",
            window.start_s
        ));
    }

    let mut stats =
        LoadStats { steps, measurements_read: log.measurements.len(), ..LoadStats::default() };
    stats.truth_known = truth.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).count();
    let landmark_of_barcode = |barcode: u32| -> Option<Option<usize>> {
        let subject = log.barcodes.iter().find(|b| b.barcode == barcode)?.subject;
        Some(log.landmarks.iter().position(|l| l.subject == subject))
    };
    let mut by_step: BTreeMap<usize, Vec<PointObservation>> = BTreeMap::new();
    for m in &log.measurements {
        if !(m.range_m.is_finite() && m.bearing_rad.is_finite()) {
            stats.dropped_non_finite += 1;
            continue;
        }
        let landmark = match landmark_of_barcode(m.barcode) {
            None => {
                stats.dropped_unknown_barcode += 1;
                continue;
            }
            Some(None) => {
                stats.dropped_robot += 1;
                continue;
            }
            Some(Some(i)) => i,
        };
        let k = ((m.time_s - t_start) / dt).round();
        if !(k >= 0.0 && k <= steps as f64) {
            stats.dropped_outside_window += 1;
            continue;
        }
        by_step.entry(k as usize).or_default().push(PointObservation {
            landmark,
            range_m: m.range_m,
            bearing_rad: wrap_angle(m.bearing_rad),
        });
    }
    stats.measurements_kept = by_step.values().map(Vec::len).sum();

    let world = World {
        dt_s: dt,
        truth,
        odometry,
        laser: None,
        scans: Vec::new(),
        point_scans: by_step
            .into_iter()
            .map(|(step, observations)| PointScan { step, observations })
            .collect(),
        truth_lines: Vec::new(),
        truth_corners: Vec::new(),
        truth_points: log.landmarks.iter().map(|l| l.position).collect(),
        point_noise: Some(noise),
    };
    Ok((world, stats))
}

/// Rounding slack when counting whole steps in a window: a window of exactly n·Δt holds n steps
/// despite floating-point error in the time stamps.
const STEP_COUNT_SLACK: f64 = 1e-9;

/// `odometry[k]`: the zero-order-hold commands integrated exactly over [t_k, t_k + Δt], t_k =
/// `t_start` + k·Δt; `t_start` must not precede the first command.
fn integrate_commands(
    commands: &[OdometryRecord],
    t_start: f64,
    dt: f64,
    steps: usize,
) -> Vec<Pose2> {
    // i: the command in force at time t (the last one stamped at or before t).
    let mut i = commands.partition_point(|c| c.time_s <= t_start).saturating_sub(1);
    (0..steps)
        .map(|k| {
            let (mut t, end) = (t_start + k as f64 * dt, t_start + (k + 1) as f64 * dt);
            let mut increment = Pose2::IDENTITY;
            while t < end {
                let next = commands.get(i + 1).map_or(f64::INFINITY, |c| c.time_s);
                if next <= t {
                    i += 1;
                    continue;
                }
                let piece_end = next.min(end);
                increment = increment.compose(unicycle_increment(
                    commands[i].v_mps,
                    commands[i].omega_radps,
                    piece_end - t,
                ));
                t = piece_end;
            }
            increment
        })
        .collect()
}

/// The Vicon pose at time `t`: linear in position, shorter arc in heading; NaN outside the log
/// or across a gap longer than [`MAX_TRUTH_GAP_S`].
fn interpolate_truth(samples: &[GroundTruthRecord], t: f64) -> Pose2 {
    const UNKNOWN: Pose2 = Pose2::new(f64::NAN, f64::NAN, f64::NAN);
    let j = samples.partition_point(|g| g.time_s <= t);
    if j == 0 {
        return UNKNOWN;
    }
    let lo = samples[j - 1];
    if lo.time_s == t {
        return lo.pose;
    }
    let Some(hi) = samples.get(j) else { return UNKNOWN };
    let gap = hi.time_s - lo.time_s;
    if gap > MAX_TRUTH_GAP_S {
        return UNKNOWN;
    }
    let s = (t - lo.time_s) / gap;
    Pose2::new(
        lo.pose.x + s * (hi.pose.x - lo.pose.x),
        lo.pose.y + s * (hi.pose.y - lo.pose.y),
        wrap_angle(lo.pose.theta + s * wrap_angle(hi.pose.theta - lo.pose.theta)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::test_data;
    use crate::dataset::{DatasetSpec, load_with_stats};
    use crate::world::RangeNoise;

    const NOISE: PointNoise = PointNoise {
        range_noise: RangeNoise::Constant,
        range_sigma_m: 0.1,
        bearing_sigma_rad: 0.05,
    };

    const HEADER: &str =
        "# UTIAS Multi-Robot Cooperative Localization and Mapping Dataset\n# Time [s]    x [m]\n";

    fn tiny_log() -> Log {
        // A robot driving at 0.1 m/s, turning at 0.2 rad/s for the first second, then straight.
        let odometry = format!(
            "{HEADER}1000.000 \t 0.1 \t 0.2\n1000.500 \t 0.1 \t 0.2\n1001.000 \t 0.1 \t 0.0\n1003.000 \t 0.0 \t 0.0\n"
        );
        let truth = format!(
            "{HEADER}999.9 0 0 3.1\n1000.1 1 2 -3.1\n1000.25 1 2 -3.1\n1000.63 1 2 -3.1\n1001.55 2 2 0\n1002.55 3 2 0\n"
        );
        let measurements = format!(
            "{HEADER}1000.04 63 2.0 0.1\n1000.04 14 1.0 0.0\n1000.06 81 3.0 -0.2\n1000.06 34 3.0 -0.2\n1001.0 63 nan 0.0\n1010.0 63 1.0 0.0\n"
        );
        let barcodes = "# Subject # Barcode #\n 1 5\n 2 14\n 6 63\n 7 81\n";
        let landmarks = "# Subject # x y sx sy\n 6 1.0 2.0 0.0 0.0\n 7 3.0 4.0 0.0 0.0\n";
        Log {
            odometry: parse_odometry(&odometry).unwrap(),
            ground_truth: parse_ground_truth(&truth).unwrap(),
            measurements: parse_measurements(&measurements).unwrap(),
            landmarks: parse_landmarks(landmarks).unwrap(),
            barcodes: parse_barcodes(barcodes).unwrap(),
        }
    }

    #[test]
    fn parsers_read_the_columns_and_name_bad_lines() {
        let log = tiny_log();
        assert_eq!(
            log.odometry[1],
            OdometryRecord { time_s: 1000.5, v_mps: 0.1, omega_radps: 0.2 }
        );
        assert_eq!(log.ground_truth[1].pose, Pose2::new(1.0, 2.0, -3.1));
        assert_eq!(
            log.measurements[2],
            MeasurementRecord { time_s: 1000.06, barcode: 81, range_m: 3.0, bearing_rad: -0.2 }
        );
        assert!(log.measurements[4].range_m.is_nan());
        assert_eq!(
            log.landmarks[1],
            LandmarkRecord { subject: 7, position: Point2::new(3.0, 4.0) }
        );
        assert_eq!(log.barcodes[2], BarcodeRecord { subject: 6, barcode: 63 });

        let err = parse_odometry(&format!("{HEADER}1 0.1 0.0\n2 0.1\n")).unwrap_err();
        assert_eq!(err.line, 4);
        let err = parse_odometry(&format!("{HEADER}1 0.1 0.0\n2 inf 0.0\n")).unwrap_err();
        assert_eq!((err.line, err.message.as_str()), (4, "velocity is not finite"));
        assert_eq!(parse_measurements(&format!("{HEADER}1 6.5 1 0\n")).unwrap_err().line, 3);
        assert_eq!(parse_ground_truth(&format!("{HEADER}2 0 0 0\n1 0 0 0\n")).unwrap_err().line, 4);
        assert_eq!(parse_barcodes("1 5\n2 5\n").unwrap_err().line, 2);
        assert_eq!(parse_landmarks("6 0 0 0 0\n6 1 1 0 0\n").unwrap_err().line, 2);
        // A NaN Vicon sample is a gap, not an error.
        assert_eq!(parse_ground_truth("1 0 0 0\n2 nan 0 0\n3 0 0 0\n").unwrap().len(), 2);
    }

    #[test]
    fn odometry_integrates_the_held_commands_exactly() {
        let log = tiny_log();
        let window = Window { start_s: 0.0, duration_s: 0.0, step_s: 0.3 };
        let (world, stats) = assemble(&log, &window, NOISE).unwrap();
        assert_eq!(world.odometry.len(), 10); // ⌊3 s / 0.3 s⌋
        assert_eq!(stats.steps, 10);
        // Composing the steps equals the exact path: 1 s of arc, then 2 s straight at 0.1 m/s.
        let end = world.odometry.iter().fold(Pose2::IDENTITY, |p, d| p.compose(*d));
        let exact = unicycle_increment(0.1, 0.2, 1.0).compose(unicycle_increment(0.1, 0.0, 2.0));
        assert!(
            (end.x - exact.x).abs() < 1e-12
                && (end.y - exact.y).abs() < 1e-12
                && (end.theta - exact.theta).abs() < 1e-12
        );
        // Step 3 = [0.9, 1.2] s straddles the command change at 1.0 s.
        let split = unicycle_increment(0.1, 0.2, 0.1).compose(unicycle_increment(0.1, 0.0, 0.2));
        assert!(
            (world.odometry[3].x - split.x).abs() < 1e-12
                && (world.odometry[3].theta - 0.02).abs() < 1e-12
        );
        // A window from 0.5 s for 1 s: 3 steps of 0.3 s.
        let (w, _) =
            assemble(&log, &Window { start_s: 0.5, duration_s: 1.0, step_s: 0.3 }, NOISE).unwrap();
        assert_eq!(w.odometry.len(), 3);
        assert!(
            (w.odometry[0].theta - 0.06).abs() < 1e-12 && (w.odometry[2].theta - 0.0).abs() < 1e-12
        );
    }

    #[test]
    fn truth_is_interpolated_with_wrapping_and_unknown_across_gaps() {
        let log = tiny_log();
        let (world, stats) =
            assemble(&log, &Window { start_s: 0.0, duration_s: 0.0, step_s: 0.1 }, NOISE).unwrap();
        // t = 0 is halfway between 999.9 (θ 3.1) and 1000.1 (θ −3.1): heading crosses ±π.
        let p = world.truth[0];
        assert!((p.x - 0.5).abs() < 1e-9 && (p.y - 1.0).abs() < 1e-9);
        assert!((p.theta.abs() - std::f64::consts::PI).abs() < 1e-9, "{}", p.theta);
        // Samples up to 1000.63 are ≤ 0.38 s apart: steps 0–6 known. 1000.63 → 1001.55 (0.92 s)
        // and 1001.55 → 1002.55 (1 s) are gaps: unknown; after 1002.55: outside the log.
        assert!(world.truth[..=6].iter().all(|p| p.is_finite()));
        assert!(
            world.truth[7].x.is_nan()
                && world.truth[20].x.is_nan()
                && world.truth[30].theta.is_nan()
        );
        assert_eq!(stats.truth_known, 7);
        // The start pose must be known.
        let err = assemble(&log, &Window { start_s: 1.0, duration_s: 0.0, step_s: 0.1 }, NOISE)
            .unwrap_err();
        assert!(err.contains("no Vicon ground truth"), "{err}");
        let err = assemble(&log, &Window { start_s: 5.0, duration_s: 0.0, step_s: 0.1 }, NOISE)
            .unwrap_err();
        assert!(err.contains("no whole step"), "{err}");
    }

    #[test]
    fn measurements_map_barcodes_to_landmarks_and_attach_to_the_nearest_step() {
        let log = tiny_log();
        let (world, stats) =
            assemble(&log, &Window { start_s: 0.0, duration_s: 0.0, step_s: 0.1 }, NOISE).unwrap();
        assert_eq!(world.truth_points, vec![Point2::new(1.0, 2.0), Point2::new(3.0, 4.0)]);
        assert_eq!(subject_of_landmark(&log.landmarks, 1), Some(7));
        // 1000.04 → step 0 (0.04 from t_0), 1000.06 → step 1 (0.04 from t_1).
        assert_eq!(world.point_scans.len(), 2);
        assert_eq!(
            world.point_scans[0],
            PointScan {
                step: 0,
                observations: vec![PointObservation {
                    landmark: 0,
                    range_m: 2.0,
                    bearing_rad: 0.1
                }]
            }
        );
        assert_eq!(world.point_scans[1].step, 1);
        assert_eq!(
            world.point_scans[1].observations,
            vec![PointObservation { landmark: 1, range_m: 3.0, bearing_rad: -0.2 }]
        );
        assert_eq!(
            (
                stats.measurements_read,
                stats.measurements_kept,
                stats.dropped_robot,
                stats.dropped_unknown_barcode,
                stats.dropped_non_finite,
                stats.dropped_outside_window
            ),
            (6, 2, 1, 1, 1, 1)
        );
        assert_eq!(world.point_noise, Some(NOISE));
        assert_eq!(world.truth.len(), world.odometry.len() + 1);
    }

    #[test]
    fn malformed_file_names_path_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let files = [
            ("Barcodes.dat", "1 5\n6 63\n"),
            ("Landmark_Groundtruth.dat", "6 1 2 0 0\n"),
            ("Robot2_Odometry.dat", "# h\n0 0.1 0\n1 0.1\n"),
            ("Robot2_Groundtruth.dat", "0 0 0 0\n2 0 0 0\n"),
            ("Robot2_Measurement.dat", "0.5 63 1 0\n"),
        ];
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text).unwrap();
        }
        let spec = DatasetSpec::Mrclam {
            path: ".".into(),
            robot: 2,
            start_s: 0.0,
            duration_s: 0.0,
            range_sigma_m: 0.1,
            bearing_sigma_rad: 0.1,
            step_s: 0.1,
        };
        match load_with_stats(&spec, dir.path()) {
            Err(DatasetError::Malformed { path, line, .. }) => {
                assert!(path.ends_with("Robot2_Odometry.dat"));
                assert_eq!(line, 3);
            }
            other => panic!("expected Malformed, got {other:?}"),
        }
        std::fs::write(dir.path().join("Robot2_Odometry.dat"), "0 0.1 0\n1 0.1 0\n").unwrap();
        let (world, _) = load_with_stats(&spec, dir.path()).unwrap();
        assert_eq!(world.odometry.len(), 10);
        std::fs::remove_file(dir.path().join("Robot2_Measurement.dat")).unwrap();
        let err = load_with_stats(&spec, dir.path()).unwrap_err();
        assert!(
            matches!(&err, DatasetError::Missing { path, .. } if path.ends_with("Robot2_Measurement.dat")),
            "{err}"
        );
    }

    /// Loads Robot 3 of the shared Dataset6 (the whole log, or the first `duration_s`).
    fn real(duration_s: f64) -> Option<(World, LoadStats)> {
        if !test_data::available("utias-mrclam/MRCLAM_Dataset6", "MRCLAM real-data test") {
            return None;
        }
        let DatasetSpec::Mrclam { path, robot, range_sigma_m, bearing_sigma_rad, step_s, .. } =
            DatasetSpec::mrclam_default()
        else {
            unreachable!()
        };
        let spec = DatasetSpec::Mrclam {
            path,
            robot,
            start_s: 0.0,
            duration_s,
            range_sigma_m,
            bearing_sigma_rad,
            step_s,
        };
        Some(load_with_stats(&spec, &test_data::repository_root()).unwrap())
    }

    #[test]
    fn real_dead_reckoning_follows_vicon_for_a_minute() {
        let Some((world, stats)) = real(60.0) else { return };
        assert_eq!(world.odometry.len(), 3000);
        assert_eq!(stats.truth_known, world.truth.len(), "Vicon covers the first minute");
        let mut pose = world.truth[0];
        let mut worst: f64 = 0.0;
        for (k, d) in world.odometry.iter().enumerate() {
            pose = pose.compose(*d);
            worst = worst.max(pose.position().distance(world.truth[k + 1].position()));
        }
        let end = pose.position().distance(world.truth.last().unwrap().position());
        eprintln!(
            "MRCLAM Robot3, first 60 s: dead-reckoning drift at 60 s = {end:.3} m, worst = {worst:.3} m"
        );
        assert!(worst < 3.0, "dead reckoning drifted {worst} m from Vicon within 60 s");
    }

    #[test]
    fn real_measurements_reproject_onto_their_landmarks() {
        let t = std::time::Instant::now();
        let Some((world, stats)) = real(0.0) else { return };
        eprintln!("MRCLAM Robot3, whole log loaded in {:.2?}", t.elapsed());
        let known = stats.truth_known as f64 / world.truth.len() as f64;
        eprintln!(
            "MRCLAM Robot3, whole log: {} steps, truth known on {:.2} %, {stats:?}",
            stats.steps,
            100.0 * known
        );
        assert!(known > 0.95);
        assert_eq!(world.truth_points.len(), 15, "subjects 6–20 are the landmarks");
        // Subjects 1–5 are robots (barcodes 5, 14, 41, 32, 23); barcode 34 is in no table.
        assert_eq!(stats.dropped_unknown_barcode, 2);
        assert_eq!(stats.dropped_robot, 1277);
        assert_eq!(stats.measurements_read, 5627);
        assert_eq!(
            stats.measurements_kept
                + stats.dropped_robot
                + stats.dropped_unknown_barcode
                + stats.dropped_non_finite
                + stats.dropped_outside_window,
            5627
        );

        let (mut n, mut near) = (0usize, 0usize);
        let (mut range_residuals, mut bearing_residuals) = (Vec::new(), Vec::new());
        for scan in &world.point_scans {
            let pose = world.truth[scan.step];
            if !pose.is_finite() {
                continue;
            }
            for o in &scan.observations {
                let m = world.truth_points[o.landmark];
                let seen = pose.transform_point(Point2::new(
                    o.range_m * o.bearing_rad.cos(),
                    o.range_m * o.bearing_rad.sin(),
                ));
                n += 1;
                near += usize::from(seen.distance(m) < 0.5);
                range_residuals.push(o.range_m - pose.position().distance(m));
                bearing_residuals.push(wrap_angle(
                    o.bearing_rad - ((m.y - pose.y).atan2(m.x - pose.x) - pose.theta),
                ));
            }
        }
        let share = near as f64 / n as f64;
        let (rm, rs, rmad, r90) = spread(&mut range_residuals);
        let (bm, bs, bmad, b90) = spread(&mut bearing_residuals);
        eprintln!(
            "MRCLAM Robot3: {:.1} % of {n} measurements reproject within 0.5 m of their landmark; \
             range residual median {rm:.3} m, std {rs:.3} m, 1.4826·MAD {rmad:.3} m, |dev| p90 {r90:.3} m; \
             bearing residual median {bm:.4} rad, std {bs:.4} rad, 1.4826·MAD {bmad:.4} rad, |dev| p90 {b90:.4} rad",
            100.0 * share
        );
        assert!(share >= 0.8, "only {:.1} % reproject within 0.5 m", 100.0 * share);
    }

    /// (median, standard deviation, 1.4826·median absolute deviation, 90th percentile of the
    /// absolute deviation from the median).
    fn spread(v: &mut [f64]) -> (f64, f64, f64, f64) {
        let quantile = |v: &mut [f64], q: f64| {
            v.sort_by(f64::total_cmp);
            v[((v.len() - 1) as f64 * q).round() as usize]
        };
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let std = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt();
        let med = quantile(v, 0.5);
        let mut dev: Vec<f64> = v.iter().map(|x| (x - med).abs()).collect();
        (med, std, 1.4826 * quantile(&mut dev, 0.5), quantile(&mut dev, 0.9))
    }
}
