//! ACFR Victoria Park (Guivant & Nebot, "Optimization of the simultaneous localization and
//! map-building algorithm for real-time implementation", IEEE T-RA 17(3), 2001), in the ASCII
//! form of RFS-SLAM (`tools/VictoriaPark/DataConvert_Matlab_to_ASCII.m`) → [`World`].
//!
//! Files (whitespace-separated, one time base: seconds since the start of the logs):
//! - `inputs.dat`: time, speed vₑ [m/s] (encoder on the rear-left wheel), steering α [rad] —
//!   every 25 ms, no gaps;
//! - `measurements.dat`: time, range [m], bearing [rad, laser frame: 0 = right, π/2 = forward],
//!   diameter [m] (ignored) — trees detected by ACFR's `detectTreesI16` in each laser frame;
//! - `gps.dat`: time, x [m], y [m] — GPS, already shifted and rotated by −33° by RFS-SLAM.
//!
//! Choices:
//! - **Pose tracked.** The pose is the *laser's* position with the car's heading φ, as in
//!   Guivant & Nebot, so observations are relative to the pose: a tree at world m is seen at
//!   range |m − p| and bearing atan2(m − p) − φ. The laser's bearing is turned into this
//!   robot-frame bearing by subtracting π/2 ([`LASER_BEARING_OFFSET_RAD`]; RFS-SLAM's
//!   `MeasurementModel_VictoriaPark` rotates the pose by −π/2, the same thing).
//! - **Motion model.** Guivant & Nebot's car: the rear-axle centre moves at
//!   v_c = vₑ / (1 − tan α · H/L) and turns at v_c tan α / L; the laser sits a ahead and b to
//!   the left of it. Their discrete equations
//!   x' = x + Δt (v_c cos φ − v_c/L tan α (a sin φ + b cos φ)),
//!   y' = y + Δt (v_c sin φ + v_c/L tan α (a cos φ − b sin φ)), φ' = φ + Δt v_c/L tan α
//!   are the Euler step of that rigid motion; [`ackermann_increment`] integrates it exactly
//!   (arc of the axle centre, carried to the laser), which agrees with them to O(Δt²) and makes
//!   `odometry` a composable body-frame increment. Parameters: [`VICTORIA_PARK_CAR`].
//! - **Steps.** One step per `inputs.dat` record in the window: step k starts at that record's
//!   time, and its (vₑ, α) hold until the next record (zero-order hold, as RFS-SLAM's dead
//!   reckoning does), so `odometry[k]` is exact for each record whatever its Δt. `World::dt_s` is
//!   the median Δt (the file's period is a constant 25 ms, so this is exact too). `start_s`
//!   counts from the first `inputs.dat` record.
//! - **Start pose.** `truth[0]` = the origin with φ = 0. RFS-SLAM rotated the GPS by −33° so
//!   that the car starts heading along +x in the GPS frame: dead reckoning from (0, 0, 0) stays
//!   within 3.5 m of every `gps.dat` fix of the first 80 s (see the real-data test), so for a window
//!   starting at the beginning of the log the frames coincide up to the GPS antenna's offset
//!   (the first fix is (−2.0, −1.9) m) and GPS noise. For a later window (`start_s` > 0) the
//!   origin is the laser's pose at the window start and the GPS frame does not match.
//! - **Truth.** No ground truth exists. `truth[k]` is NaN except at the steps nearest a GPS fix
//!   (within half a step), which get (x, y, NaN): GPS gives no heading. `truth[0]` is the start
//!   pose, never a fix. GPS positions are of the antenna, in the GPS frame: comparing an
//!   estimate with them requires a rigid 2-D alignment (metrics do it), which should leave out
//!   `truth[0]`.
//! - **Measurements.** Each detection goes to the step whose start is nearest its time;
//!   detections farther than `max_range_m`, non-finite ones, and those more than half a step
//!   outside the window are dropped and counted in [`LoadStats`]. Trees have no identities:
//!   `landmark` is [`UNKNOWN_LANDMARK`], so known data association is impossible, and
//!   `truth_points` is empty.

use super::{
    DatasetError, LineError, LoadStats, UNKNOWN_LANDMARK, check_times, parse_table, read_text,
};
use crate::geom::{Point2, Pose2, unicycle_increment, wrap_angle};
use crate::world::World;
use crate::world::point_sensor::{PointNoise, PointObservation, PointScan};
use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;
use std::path::Path;

/// Files read, in hashing order.
pub const FILE_NAMES: [&str; 3] = ["inputs.dat", "measurements.dat", "gps.dat"];

/// Default σr [m]: RFS-SLAM's Victoria Park configuration (`cfg/fastslam_VictoriaPark.xml`)
/// states a range variance of 0.025 m² and runs with a measurement-noise inflation factor of 75,
/// so its filters are told σr = √(0.025·75) ≈ 1.37 m.
pub const DEFAULT_RANGE_SIGMA_M: f64 = 1.37;

/// Default σb [rad]: the same configuration, bearing variance 2.5·10⁻⁵ rad² inflated 75×:
/// σb = √(2.5·10⁻⁵·75) ≈ 0.0433 rad (2.5°).
pub const DEFAULT_BEARING_SIGMA_RAD: f64 = 0.0433;

/// Default maximum range [m] of the detections kept (the usual 30 m; the laser reaches 80 m).
pub const DEFAULT_MAX_RANGE_M: f64 = 30.0;

/// Laser bearing of the car's forward axis [rad]: the laser's bearings run from 0 (right) to π
/// (left), so robot-frame bearing = laser bearing − π/2.
pub const LASER_BEARING_OFFSET_RAD: f64 = FRAC_PI_2;

/// The start pose every algorithm is given: the origin, heading along +x (see the module doc).
pub const START_POSE: Pose2 = Pose2::IDENTITY;

/// Geometry of a car-like vehicle with an encoder on a rear wheel and a sensor ahead of the rear
/// axle (Guivant & Nebot's model).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarGeometry {
    /// L [m]: distance between the front and rear axles.
    pub wheelbase_m: f64,
    /// H [m]: lateral offset of the encoder wheel from the centre line.
    pub encoder_offset_m: f64,
    /// a [m]: the laser's distance ahead of the rear axle.
    pub laser_ahead_m: f64,
    /// b [m]: the laser's lateral offset (to the left, in the equations' convention).
    pub laser_left_m: f64,
}

/// The Victoria Park utility car: L = 2.83 m, H = 0.76 m, a = 3.78 m, b = 0.50 m (ACFR
/// `info.txt`, quoted in the dataset README; RFS-SLAM's configuration uses the same values).
pub const VICTORIA_PARK_CAR: CarGeometry = CarGeometry {
    wheelbase_m: 2.83,
    encoder_offset_m: 0.76,
    laser_ahead_m: 3.78,
    laser_left_m: 0.50,
};

impl CarGeometry {
    /// The rear-axle centre's speed v_c = vₑ / (1 − tan α · H/L) and turn rate v_c tan α / L.
    pub fn axle_velocity(&self, speed_mps: f64, steering_rad: f64) -> (f64, f64) {
        let tan = steering_rad.tan();
        let v_c = speed_mps / (1.0 - tan * self.encoder_offset_m / self.wheelbase_m);
        (v_c, v_c * tan / self.wheelbase_m)
    }

    /// Whether the model is defined at steering α: |α| < π/2 and 1 − tan α · H/L > 0.
    pub fn steering_is_valid(&self, steering_rad: f64) -> bool {
        steering_rad.abs() < FRAC_PI_2
            && 1.0 - steering_rad.tan() * self.encoder_offset_m / self.wheelbase_m > 0.0
    }
}

/// Body-frame increment of the laser pose over Δt with (vₑ, α) held constant: the rear-axle
/// centre follows the exact arc `unicycle_increment(v_c, ω, Δt)`, and the laser frame is that
/// frame moved by T = (a, b, 0), so the laser's increment is T⁻¹ ⊕ Δ_axle ⊕ T. Its Euler
/// approximation is Guivant & Nebot's discrete model (see the module doc).
pub fn ackermann_increment(
    car: &CarGeometry,
    speed_mps: f64,
    steering_rad: f64,
    dt_s: f64,
) -> Pose2 {
    let (v_c, omega) = car.axle_velocity(speed_mps, steering_rad);
    let laser = Pose2::new(car.laser_ahead_m, car.laser_left_m, 0.0);
    let laser_inverse = Pose2::new(-car.laser_ahead_m, -car.laser_left_m, 0.0);
    laser_inverse.compose(unicycle_increment(v_c, omega, dt_s)).compose(laser)
}

/// A dead-reckoning input, held until the next record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputRecord {
    pub time_s: f64,
    /// vₑ [m/s], measured at the rear-left wheel.
    pub speed_mps: f64,
    /// α [rad].
    pub steering_rad: f64,
}

/// A tree detection, in the laser's own bearing convention.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectionRecord {
    pub time_s: f64,
    pub range_m: f64,
    /// [rad], 0 = right, π/2 = forward.
    pub laser_bearing_rad: f64,
    pub diameter_m: f64,
}

/// A GPS fix (of the antenna, in the GPS frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GpsRecord {
    pub time_s: f64,
    pub position: Point2,
}

/// Parses `inputs.dat`: times ordered, speed finite, steering where the car model is defined.
pub fn parse_inputs(text: &str) -> Result<Vec<InputRecord>, LineError> {
    let rows = parse_table::<3>(text)?;
    check_times(&rows)?;
    rows.iter()
        .map(|r| {
            let [time_s, speed_mps, steering_rad] = r.values;
            if !speed_mps.is_finite() {
                return Err(LineError::new(r.line, "speed is not finite"));
            }
            if !VICTORIA_PARK_CAR.steering_is_valid(steering_rad) {
                return Err(LineError::new(
                    r.line,
                    format!("steering {steering_rad} rad is outside the car model's domain"),
                ));
            }
            Ok(InputRecord { time_s, speed_mps, steering_rad })
        })
        .collect()
}

/// Parses `measurements.dat`: times ordered; non-finite values are kept here and dropped
/// (counted) when assembling.
pub fn parse_detections(text: &str) -> Result<Vec<DetectionRecord>, LineError> {
    let rows = parse_table::<4>(text)?;
    check_times(&rows)?;
    Ok(rows
        .iter()
        .map(|r| {
            let [time_s, range_m, laser_bearing_rad, diameter_m] = r.values;
            DetectionRecord { time_s, range_m, laser_bearing_rad, diameter_m }
        })
        .collect())
}

/// Parses `gps.dat`: times ordered; fixes with a non-finite position are left out.
pub fn parse_gps(text: &str) -> Result<Vec<GpsRecord>, LineError> {
    let rows = parse_table::<3>(text)?;
    check_times(&rows)?;
    Ok(rows
        .iter()
        .map(|r| GpsRecord { time_s: r.values[0], position: Point2::new(r.values[1], r.values[2]) })
        .filter(|g| g.position.x.is_finite() && g.position.y.is_finite())
        .collect())
}

/// The parsed log.
#[derive(Debug, Clone, PartialEq)]
pub struct Log {
    pub inputs: Vec<InputRecord>,
    pub detections: Vec<DetectionRecord>,
    pub gps: Vec<GpsRecord>,
}

/// The part of the log to load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    /// Offset [s] from the first input record.
    pub start_s: f64,
    /// Length [s]; 0 = to the end.
    pub duration_s: f64,
    /// Detections farther than this [m] are dropped.
    pub max_range_m: f64,
}

/// Reads and assembles the log in the dataset folder `folder`.
pub fn load(
    folder: &Path,
    window: &Window,
    noise: PointNoise,
) -> Result<(World, LoadStats), DatasetError> {
    let [inputs, detections, gps] = FILE_NAMES.map(|name| folder.join(name));
    let log = Log {
        inputs: parse_inputs(&read_text(&inputs)?).map_err(|e| e.in_file(&inputs))?,
        detections: parse_detections(&read_text(&detections)?)
            .map_err(|e| e.in_file(&detections))?,
        gps: parse_gps(&read_text(&gps)?).map_err(|e| e.in_file(&gps))?,
    };
    assemble(&log, window, noise)
        .map_err(|message| DatasetError::Empty { path: folder.to_path_buf(), message })
}

/// Slack [s] on the window's ends: time stamps are printed to the millisecond, so a record
/// within a microsecond of an end is on it.
const TIME_SLACK_S: f64 = 1e-6;

/// Builds the [`World`] of `window` from a parsed log (see the module doc for every choice).
/// Fails, with a message, only when the window holds fewer than two input records.
pub fn assemble(
    log: &Log,
    window: &Window,
    noise: PointNoise,
) -> Result<(World, LoadStats), String> {
    let (Some(first), Some(last)) = (log.inputs.first(), log.inputs.last()) else {
        return Err("inputs.dat holds no record".to_string());
    };
    let t_start = first.time_s + window.start_s;
    let t_end = if window.duration_s > 0.0 { t_start + window.duration_s } else { last.time_s };
    let i0 = log.inputs.partition_point(|r| r.time_s < t_start - TIME_SLACK_S);
    let i1 = log.inputs.partition_point(|r| r.time_s <= t_end + TIME_SLACK_S);
    if i1 < i0 + 2 {
        return Err(format!(
            "the window [{:.3} s, {:.3} s] after the first input record holds fewer than two input records (the log lasts {:.3} s)",
            window.start_s,
            window.start_s + window.duration_s,
            last.time_s - first.time_s
        ));
    }
    let records = &log.inputs[i0..i1];
    let times: Vec<f64> = records.iter().map(|r| r.time_s).collect();
    let steps = records.len() - 1;
    let odometry: Vec<Pose2> = records
        .windows(2)
        .map(|w| {
            ackermann_increment(
                &VICTORIA_PARK_CAR,
                w[0].speed_mps,
                w[0].steering_rad,
                w[1].time_s - w[0].time_s,
            )
        })
        .collect();
    let mut periods: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    periods.sort_by(f64::total_cmp);
    let dt_s = periods[periods.len() / 2];
    let nearest = |t: f64| nearest_step(&times, dt_s / 2.0, t);

    // Truth: GPS fixes at their nearest step (the nearest fix wins), heading unknown.
    let mut truth = vec![Pose2::new(f64::NAN, f64::NAN, f64::NAN); steps + 1];
    let mut fix_offset = vec![f64::INFINITY; steps + 1];
    for g in &log.gps {
        if let Some(k) = nearest(g.time_s).filter(|&k| k > 0) {
            let offset = (g.time_s - times[k]).abs();
            if offset < fix_offset[k] {
                fix_offset[k] = offset;
                truth[k] = Pose2::new(g.position.x, g.position.y, f64::NAN);
            }
        }
    }
    truth[0] = START_POSE;

    let mut stats =
        LoadStats { steps, measurements_read: log.detections.len(), ..LoadStats::default() };
    stats.truth_known = truth.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).count();
    let mut by_step: BTreeMap<usize, Vec<PointObservation>> = BTreeMap::new();
    for d in &log.detections {
        if !(d.range_m.is_finite() && d.laser_bearing_rad.is_finite()) {
            stats.dropped_non_finite += 1;
            continue;
        }
        let Some(k) = nearest(d.time_s) else {
            stats.dropped_outside_window += 1;
            continue;
        };
        if d.range_m > window.max_range_m {
            stats.dropped_beyond_max_range += 1;
            continue;
        }
        let bearing_rad = wrap_angle(d.laser_bearing_rad - LASER_BEARING_OFFSET_RAD);
        by_step.entry(k).or_default().push(PointObservation {
            landmark: UNKNOWN_LANDMARK,
            range_m: d.range_m,
            bearing_rad,
        });
    }
    stats.measurements_kept = by_step.values().map(Vec::len).sum();

    let world = World {
        dt_s,
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
        truth_points: Vec::new(),
        point_noise: Some(noise),
    };
    Ok((world, stats))
}

/// The step whose start time (`times`, ordered) is nearest `t`, or `None` when `t` is more than
/// `half_step_s` before the first or after the last.
fn nearest_step(times: &[f64], half_step_s: f64, t: f64) -> Option<usize> {
    let (first, last) = (*times.first()?, *times.last()?);
    if !(t >= first - half_step_s && t <= last + half_step_s) {
        return None;
    }
    let j = times.partition_point(|&s| s <= t);
    Some(match j {
        0 => 0,
        j if j == times.len() => j - 1,
        j => {
            if t - times[j - 1] <= times[j] - t {
                j - 1
            } else {
                j
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::test_data;
    use crate::dataset::{DatasetSpec, load_with_stats};
    use crate::world::RangeNoise;

    const NOISE: PointNoise = PointNoise {
        range_noise: RangeNoise::Constant,
        range_sigma_m: 1.0,
        bearing_sigma_rad: 0.05,
    };

    /// Guivant & Nebot's discrete model, one Euler step, from pose `p` (the laser's).
    fn guivant_nebot(car: &CarGeometry, p: Pose2, speed: f64, steering: f64, dt: f64) -> Pose2 {
        let (l, a, b) = (car.wheelbase_m, car.laser_ahead_m, car.laser_left_m);
        let tan = steering.tan();
        let vc = speed / (1.0 - tan * car.encoder_offset_m / l);
        let (s, c) = p.theta.sin_cos();
        Pose2::new(
            p.x + dt * (vc * c - vc / l * tan * (a * s + b * c)),
            p.y + dt * (vc * s + vc / l * tan * (a * c - b * s)),
            p.theta + dt * vc / l * tan,
        )
    }

    #[test]
    fn exact_increment_agrees_with_the_euler_equations_to_second_order() {
        let car = VICTORIA_PARK_CAR;
        let start = Pose2::new(1.0, -2.0, 0.7);
        for &(speed, steering) in &[(3.0, 0.0), (3.0, 0.3), (2.0, -0.5), (0.0, 0.4)] {
            let mut errors = Vec::new();
            for &dt in &[0.02, 0.01] {
                let exact = start.compose(ackermann_increment(&car, speed, steering, dt));
                let euler = guivant_nebot(&car, start, speed, steering, dt);
                errors.push(
                    exact.position().distance(euler.position()) + (exact.theta - euler.theta).abs(),
                );
            }
            // Halving Δt quarters the difference (O(Δt²)), and it is tiny at 25 ms.
            assert!(errors[0] < 2e-3, "{speed} {steering}: {errors:?}");
            assert!(
                errors[1] <= errors[0] / 3.5 || errors[0] < 1e-12,
                "{speed} {steering}: {errors:?}"
            );
        }
        // Exact: two half steps are one whole step.
        let half = ackermann_increment(&car, 4.0, 0.35, 0.5);
        let whole = ackermann_increment(&car, 4.0, 0.35, 1.0);
        let twice = half.compose(half);
        assert!(
            (twice.x - whole.x).abs() < 1e-12
                && (twice.y - whole.y).abs() < 1e-12
                && (twice.theta - whole.theta).abs() < 1e-12
        );
        // Straight ahead the laser moves like the axle.
        let straight = ackermann_increment(&car, 5.0, 0.0, 0.1);
        assert!(
            (straight.x - 0.5).abs() < 1e-12 && straight.y.abs() < 1e-12 && straight.theta == 0.0
        );
    }

    #[test]
    fn parsers_read_the_columns_and_name_bad_lines() {
        let inputs =
            parse_inputs("     0.973      0.000    -0.0035\n     0.998      1.500    0.1\n")
                .unwrap();
        assert_eq!(inputs[1], InputRecord { time_s: 0.998, speed_mps: 1.5, steering_rad: 0.1 });
        let err = parse_inputs("0.973 0.0 0.0\n0.998 0.0\n").unwrap_err();
        assert_eq!(err.line, 2);
        let err = parse_inputs("0.973 0.0 0.0\n0.998 0.0 1.4\n").unwrap_err();
        assert!(err.line == 2 && err.message.contains("steering"), "{err:?}");
        let d = parse_detections("     0.852   20.46202    0.88575    0.35404\n").unwrap();
        assert_eq!(
            d[0],
            DetectionRecord {
                time_s: 0.852,
                range_m: 20.46202,
                laser_bearing_rad: 0.88575,
                diameter_m: 0.35404
            }
        );
        assert_eq!(parse_detections("0.8 1 2 3\n0.7 1 2 3\n").unwrap_err().line, 2);
        let g = parse_gps("     0.000     -2.023     -1.923\n 1.0 nan 0\n").unwrap();
        assert_eq!(g, vec![GpsRecord { time_s: 0.0, position: Point2::new(-2.023, -1.923) }]);
        assert_eq!(parse_gps("0 1 2\n1 x 2\n").unwrap_err().line, 2);
    }

    fn tiny_log() -> Log {
        // 11 records 25 ms apart, driving straight at 4 m/s.
        let inputs = (0..=10)
            .map(|i| format!("{:.3} 4.0 0.0\n", 1.0 + 0.025 * i as f64))
            .collect::<String>();
        let detections = "0.95 10.0 1.5707963 0.3\n1.011 10.0 0.0 0.3\n1.011 40.0 3.14 0.3\n1.030 nan 1.0 0.3\n1.30 5.0 1.0 0.3\n";
        let gps = "0.9 -1 -1\n1.048 5 6\n1.051 7 8\n1.1 9 9\n";
        Log {
            inputs: parse_inputs(&inputs).unwrap(),
            detections: parse_detections(detections).unwrap(),
            gps: parse_gps(gps).unwrap(),
        }
    }

    #[test]
    fn steps_truth_and_detections() {
        let log = tiny_log();
        let (world, stats) =
            assemble(&log, &Window { start_s: 0.0, duration_s: 0.0, max_range_m: 30.0 }, NOISE)
                .unwrap();
        assert_eq!(world.odometry.len(), 10);
        assert!((world.dt_s - 0.025).abs() < 1e-9);
        assert!((world.odometry[0].x - 0.1).abs() < 1e-9 && world.odometry[0].y.abs() < 1e-12);
        // Truth: start pose, then GPS at the nearest steps with unknown heading. The fixes at
        // 1.048 and 1.051 both fall nearest step 2 (1.050): the nearer, 1.051, is kept. 0.9 is
        // outside the window; 1.1 is step 4.
        assert_eq!(world.truth[0], START_POSE);
        assert_eq!((world.truth[2].x, world.truth[2].y), (7.0, 8.0));
        assert!(world.truth[2].theta.is_nan());
        assert_eq!((world.truth[4].x, world.truth[4].y), (9.0, 9.0));
        assert_eq!(stats.truth_known, 3);
        // Detections: 0.95 and 1.30 are more than half a step outside [1.000, 1.250]; 1.011 is
        // nearer step 0 (1.000) than step 1 (1.025); laser bearing 0 (right) → −π/2.
        assert_eq!(world.point_scans.len(), 1);
        let scan = &world.point_scans[0];
        assert_eq!(scan.step, 0);
        assert_eq!(scan.observations.len(), 1);
        let o = scan.observations[0];
        assert_eq!(o.landmark, UNKNOWN_LANDMARK);
        assert!((o.range_m - 10.0).abs() < 1e-12 && (o.bearing_rad + FRAC_PI_2).abs() < 1e-12);
        assert_eq!(
            (
                stats.measurements_read,
                stats.measurements_kept,
                stats.dropped_outside_window,
                stats.dropped_beyond_max_range,
                stats.dropped_non_finite
            ),
            (5, 1, 2, 1, 1)
        );
        assert!(world.truth_points.is_empty());
        // A later window restarts at the start pose.
        let (w, _) =
            assemble(&log, &Window { start_s: 0.1, duration_s: 0.1, max_range_m: 30.0 }, NOISE)
                .unwrap();
        assert_eq!((w.odometry.len(), w.truth[0]), (4, START_POSE));
        assert!(
            assemble(&log, &Window { start_s: 0.25, duration_s: 0.0, max_range_m: 30.0 }, NOISE)
                .is_err()
        );
    }

    #[test]
    fn nearest_step_rounds_to_the_closer_start() {
        let times = [0.0, 1.0, 2.0];
        assert_eq!(nearest_step(&times, 0.5, -0.5), Some(0));
        assert_eq!(nearest_step(&times, 0.5, -0.6), None);
        assert_eq!(nearest_step(&times, 0.5, 0.4), Some(0));
        assert_eq!(nearest_step(&times, 0.5, 0.6), Some(1));
        assert_eq!(nearest_step(&times, 0.5, 2.5), Some(2));
        assert_eq!(nearest_step(&times, 0.5, 2.6), None);
        assert_eq!(nearest_step(&times, 0.5, f64::NAN), None);
    }

    fn real(duration_s: f64) -> Option<(World, LoadStats)> {
        if !test_data::available("victoria-park", "Victoria Park real-data test") {
            return None;
        }
        let DatasetSpec::VictoriaPark {
            path, range_sigma_m, bearing_sigma_rad, max_range_m, ..
        } = DatasetSpec::victoria_park_default()
        else {
            unreachable!()
        };
        let spec = DatasetSpec::VictoriaPark {
            path,
            start_s: 0.0,
            duration_s,
            range_sigma_m,
            bearing_sigma_rad,
            max_range_m,
        };
        Some(load_with_stats(&spec, &test_data::repository_root()).unwrap())
    }

    #[test]
    fn real_dead_reckoning_is_plausible_and_starts_in_the_gps_frame() {
        let Some((world, stats)) = real(100.0) else { return };
        assert!((world.dt_s - 0.025).abs() < 1e-9);
        assert_eq!(world.odometry.len(), 4000);
        // Path length of the laser vs ∫vₑ dt from the raw file.
        let text = std::fs::read_to_string(
            test_data::repository_root().join("../shared/data/victoria-park/inputs.dat"),
        )
        .unwrap();
        let inputs = parse_inputs(&text).unwrap();
        let odometer: f64 = inputs
            .windows(2)
            .take(4000)
            .map(|w| w[0].speed_mps.abs() * (w[1].time_s - w[0].time_s))
            .sum();
        let path: f64 = world.odometry.iter().map(|d| d.x.hypot(d.y)).sum();
        // Dead reckoning vs GPS over the first 80 s (no alignment: the frames coincide).
        let mut pose = world.truth[0];
        let (mut worst, mut fixes): (f64, usize) = (0.0, 0);
        for (k, d) in world.odometry.iter().enumerate() {
            pose = pose.compose(*d);
            let fix = world.truth[k + 1];
            if fix.x.is_finite() && (k + 1) as f64 * world.dt_s <= 80.0 {
                worst = worst.max(pose.position().distance(fix.position()));
                fixes += 1;
            }
        }
        eprintln!(
            "Victoria Park, first 100 s: laser path {path:.1} m, ∫vₑ dt {odometer:.1} m (ratio {:.3}); \
             dead reckoning vs {fixes} GPS fixes over 80 s: worst {worst:.2} m; {stats:?}",
            path / odometer
        );
        assert!(odometer > 100.0, "the car drives in the first 100 s");
        assert!(
            (0.97..1.15).contains(&(path / odometer)),
            "laser path {path} m vs odometer {odometer} m"
        );
        assert!(fixes > 100 && worst < 6.0, "{fixes} fixes, worst {worst} m");
    }

    #[test]
    fn real_detections_are_in_range() {
        let t = std::time::Instant::now();
        let Some((world, stats)) = real(0.0) else { return };
        let elapsed = t.elapsed();
        let all: Vec<&PointObservation> =
            world.point_scans.iter().flat_map(|s| &s.observations).collect();
        eprintln!(
            "Victoria Park, whole log ({elapsed:.2?} to load): {} steps, {} scans, {} detections kept; {stats:?}",
            world.odometry.len(),
            world.point_scans.len(),
            all.len()
        );
        assert!(all.len() > 10_000);
        assert!(all.iter().all(|o| o.range_m > 0.0
            && o.range_m <= 30.0
            && o.bearing_rad.abs() <= FRAC_PI_2
            && o.landmark == UNKNOWN_LANDMARK));
        assert!(world.truth.iter().skip(1).all(|p| p.theta.is_nan()));
        assert_eq!(stats.measurements_read, 52974);
        // And with the laser's full reach every range is within (0, 80] m.
        let text = std::fs::read_to_string(
            test_data::repository_root().join("../shared/data/victoria-park/measurements.dat"),
        )
        .unwrap();
        assert!(
            parse_detections(&text).unwrap().iter().all(|d| d.range_m > 0.0 && d.range_m <= 80.0)
        );
    }
}
