//! Ground truth: a unicycle (v, ω, Δt) driven through the map's waypoints by a
//! turn-then-drive heading controller. Deterministic — truth is identical for every replicate;
//! only the sensor and odometry noise differ.

use super::WorldError;
use super::map::TrajectorySpec;
use crate::geom::{Point2, Pose2, Segment, unicycle_increment, wrap_angle};

/// Proportional gain from heading error [rad] to turn rate [rad/s].
const HEADING_GAIN_PER_S: f64 = 1.5;
/// Above this heading error [rad] the robot turns in place (v = 0); below it, forward speed
/// falls linearly with the error, so corners are taken as short arcs.
const TURN_IN_PLACE_RAD: f64 = 0.5;
/// Safety factor on the time the path should take before the controller is declared stuck.
const TIMEOUT_FACTOR: f64 = 4.0;
/// Extra time [s] allowed per waypoint for turning in place.
const TURN_ALLOWANCE_S: f64 = 30.0;
/// Longest simulation, in steps (55 h at 10 Hz): a bound on memory per run.
pub const MAX_STEPS: usize = 2_000_000;

/// The true path: `poses[k]` is the pose at time k·Δt; `controls[k]` = (v [m/s], ω [rad/s]) moves
/// `poses[k]` to `poses[k + 1]`.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthRun {
    pub poses: Vec<Pose2>,
    pub controls: Vec<(f64, f64)>,
}

/// The route with every waypoint moved `inset_m` towards the centre of the walls' bounding box,
/// separately in x and in y (a coordinate on the centre stays).
pub fn inset(spec: &TrajectorySpec, walls: &[Segment], inset_m: f64) -> TrajectorySpec {
    if inset_m == 0.0 || walls.is_empty() {
        return spec.clone();
    }
    let (xs, ys): (Vec<f64>, Vec<f64>) =
        walls.iter().flat_map(|w| [(w.a.x, w.a.y), (w.b.x, w.b.y)]).unzip();
    let mid = |v: &[f64]| {
        (v.iter().copied().fold(f64::INFINITY, f64::min)
            + v.iter().copied().fold(f64::NEG_INFINITY, f64::max))
            / 2.0
    };
    let (cx, cy) = (mid(&xs), mid(&ys));
    // never past the centre: a coordinate nearer to it than the inset stops on it
    let towards = |v: f64, c: f64| v + inset_m.min((c - v).abs()) * (c - v).signum();
    TrajectorySpec {
        waypoints: spec.waypoints.iter().map(|w| [towards(w[0], cx), towards(w[1], cy)]).collect(),
        ..spec.clone()
    }
}

/// Drives from `start` through `spec.waypoints`, `spec.laps` times.
pub fn drive(start: Pose2, spec: &TrajectorySpec, dt_s: f64) -> Result<TruthRun, WorldError> {
    let waypoints: Vec<Point2> = spec.waypoints.iter().map(|w| Point2::new(w[0], w[1])).collect();
    let omega_max = spec.max_turn_rate_dps.to_radians();
    let lap_length: f64 = std::iter::once(start.position())
        .chain(waypoints.iter().copied())
        .collect::<Vec<_>>()
        .windows(2)
        .map(|w| w[0].distance(w[1]))
        .sum();
    let legs = waypoints.len() * spec.laps as usize;
    let budget_s = TIMEOUT_FACTOR * (lap_length * spec.laps as f64 / spec.max_speed_mps)
        + TURN_ALLOWANCE_S * legs as f64;
    let expected_steps = lap_length * spec.laps as f64 / spec.max_speed_mps / dt_s;
    if !(expected_steps <= MAX_STEPS as f64) {
        return Err(WorldError::TooLong { steps: expected_steps, max: MAX_STEPS });
    }
    let max_steps = ((budget_s / dt_s).ceil() as usize).min(MAX_STEPS);

    let mut pose = start;
    let mut poses = vec![pose];
    let mut controls = Vec::new();
    for leg in 0..legs {
        let target = waypoints[leg % waypoints.len()];
        while pose.position().distance(target) > spec.waypoint_tolerance_m {
            if controls.len() >= max_steps {
                return Err(WorldError::TrajectoryStuck {
                    waypoint: leg % waypoints.len(),
                    lap: leg / waypoints.len() + 1,
                    steps: max_steps,
                });
            }
            let (v, omega) = control(pose, target, spec.max_speed_mps, omega_max, dt_s);
            pose = pose.compose(unicycle_increment(v, omega, dt_s));
            poses.push(pose);
            controls.push((v, omega));
        }
    }
    Ok(TruthRun { poses, controls })
}

/// One controller step: turn towards the target, drive when roughly facing it.
fn control(pose: Pose2, target: Point2, v_max: f64, omega_max: f64, dt_s: f64) -> (f64, f64) {
    let distance = pose.position().distance(target);
    let error = wrap_angle((target.y - pose.y).atan2(target.x - pose.x) - pose.theta);
    let omega = (HEADING_GAIN_PER_S * error).clamp(-omega_max, omega_max);
    let v = if error.abs() >= TURN_IN_PLACE_RAD {
        0.0
    } else {
        // never overshoot the waypoint within one step
        (v_max * (1.0 - error.abs() / TURN_IN_PLACE_RAD)).min(distance / dt_s)
    };
    (v, omega)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> TrajectorySpec {
        TrajectorySpec {
            max_speed_mps: 0.5,
            max_turn_rate_dps: 45.0,
            laps: 2,
            waypoint_tolerance_m: 0.2,
            waypoints: vec![[4.0, 0.0], [4.0, 4.0], [0.0, 4.0], [0.0, 0.0]],
        }
    }

    #[test]
    fn an_inset_moves_each_waypoint_towards_the_walls_centre_in_x_and_y() {
        let p = Point2::new;
        // room [-1, 5] × [-1, 7]: centre (2, 3)
        let walls = [
            Segment::new(p(-1.0, -1.0), p(5.0, -1.0)),
            Segment::new(p(5.0, -1.0), p(5.0, 7.0)),
            Segment::new(p(-1.0, 7.0), p(-1.0, -1.0)),
        ];
        let mut spec = square();
        spec.waypoints.push([2.0, 3.0]);
        spec.waypoints.push([2.2, 3.3]);
        let moved = inset(&spec, &walls, 0.5);
        // the last waypoint, within 0.5 m of the centre, stops on it instead of crossing it
        assert_eq!(
            moved.waypoints,
            vec![[3.5, 0.5], [3.5, 3.5], [0.5, 3.5], [0.5, 0.5], [2.0, 3.0], [2.0, 3.0]]
        );
        assert_eq!(inset(&spec, &walls, 0.0), spec);
    }

    #[test]
    fn visits_every_waypoint_within_limits() {
        let spec = square();
        let run = drive(Pose2::IDENTITY, &spec, 0.1).unwrap();
        assert_eq!(run.poses.len(), run.controls.len() + 1);
        for &(v, w) in &run.controls {
            assert!((0.0..=spec.max_speed_mps + 1e-12).contains(&v));
            assert!(w.abs() <= spec.max_turn_rate_dps.to_radians() + 1e-12);
        }
        let end = run.poses.last().unwrap();
        assert!(end.position().distance(Point2::new(0.0, 0.0)) <= spec.waypoint_tolerance_m);
        // two laps of a 4 m square: about 32 m, a little less for the rounded corners
        let length: f64 =
            run.poses.windows(2).map(|p| p[0].position().distance(p[1].position())).sum();
        assert!((28.0..33.0).contains(&length), "{length}");
        // every waypoint was passed within tolerance
        for w in &spec.waypoints {
            let p = Point2::new(w[0], w[1]);
            assert!(
                run.poses.iter().any(|q| q.position().distance(p) <= spec.waypoint_tolerance_m)
            );
        }
    }

    #[test]
    fn absurdly_long_runs_are_refused() {
        let mut spec = square();
        spec.laps = 100_000;
        assert!(matches!(drive(Pose2::IDENTITY, &spec, 0.1), Err(WorldError::TooLong { .. })));
    }

    #[test]
    fn unreachable_waypoint_is_an_error_not_a_hang() {
        // A waypoint behind the robot with an almost zero turn rate cannot be reached in time.
        let mut spec = square();
        spec.max_turn_rate_dps = 1e-4;
        spec.waypoints = vec![[-5.0, 0.0]];
        assert!(matches!(
            drive(Pose2::IDENTITY, &spec, 0.1),
            Err(WorldError::TrajectoryStuck { .. })
        ));
    }
}
