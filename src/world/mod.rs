//! Simulated worlds: (map, world parameters, world seed) → [`World`] — the true trajectory, noisy
//! odometry increments, and the sensor data an algorithm asked for. Pure and deterministic.
//!
//! Every noise source draws from its own ChaCha8 stream of the world seed, and each draws a fixed
//! number of normals per step/beam/landmark whatever the parameter values. So two sweep points
//! that share a (study seed, map, replicate) see the same underlying random numbers (common
//! random numbers: paired comparisons), and turning the laser on or off leaves the odometry
//! unchanged.

pub mod laser;
pub mod map;
pub mod odometry;
pub mod point_sensor;
pub mod trajectory;

use crate::config::{Checks, Violation};
use crate::geom::{Line, Point2, Pose2};
use laser::{LaserGeometry, LaserParams, Scan};
use map::Map;
use odometry::OdometryNoise;
use point_sensor::{PointScan, PointSensorParams};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// What a world's landmarks are, which decides the sensor every landmark filter reads. A map
/// with point landmarks (or a dataset) is a point-landmark world; a map of walls alone is seen by
/// the laser, whose scans yield line and corner landmarks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorldKind {
    Laser,
    Points,
}

impl WorldKind {
    pub const ALL: [WorldKind; 2] = [WorldKind::Laser, WorldKind::Points];
}

/// Which simulated sensors a run reads: the world simulates nothing more.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sensors {
    pub laser: bool,
    pub landmarks: bool,
}

impl Sensors {
    pub const NONE: Sensors = Sensors { laser: false, landmarks: false };
    pub const LASER: Sensors = Sensors { laser: true, landmarks: false };
    pub const LANDMARKS: Sensors = Sensors { laser: false, landmarks: true };

    /// Both sets together.
    pub fn or(self, other: Sensors) -> Sensors {
        Sensors { laser: self.laser || other.laser, landmarks: self.landmarks || other.landmarks }
    }
}

/// Bump when world generation changes what it produces for the same inputs: it is part of every
/// run's content hash, so cached runs are recomputed.
pub const WORLD_CODE_VERSION: &str = "world-2";

/// ChaCha8 stream numbers of the noise sources.
const ODOMETRY_STREAM: u64 = 1;
const LASER_STREAM: u64 = 2;
const POINT_SENSOR_STREAM: u64 = 3;

/// Bounds of the odometry period [s]: 1 kHz to 1 Hz covers every real odometry source; outside
/// them a run would take unbounded memory or model nothing.
pub const MIN_DT_S: f64 = 1e-3;
pub const MAX_DT_S: f64 = 1.0;

/// `[base.sim]`: simulation clock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct SimParams {
    /// Odometry/control period Δt [s]. [FT] gives no rate; the per-step motion noise means the
    /// rate matters, so it is stated here (default 10 Hz).
    pub dt_s: f64,
    /// Moves every waypoint of the map's route this far [m] towards the centre of the walls'
    /// bounding box, in x and in y (the start pose stays): the same route with another clearance
    /// from the walls. [FT] gives no waypoints, so the routes are ours; this measures how much
    /// that choice matters. 0 = the map's route.
    pub route_inset_m: f64,
}

/// Largest route inset accepted [m] (half the narrowest [FT] corridor is 1.5 m).
const MAX_ROUTE_INSET_M: f64 = 1.0;

impl Default for SimParams {
    fn default() -> Self {
        Self { dt_s: 0.1, route_inset_m: 0.0 }
    }
}

impl SimParams {
    /// The report's sentence on the ground truth: the unicycle, its waypoint controller
    /// ([`trajectory`]) and the clock. `rate_hz` is 1/Δt as the caller formats numbers (the
    /// report: three significant figures).
    pub fn describe(&self, rate_hz: &str) -> String {
        let inset = if self.route_inset_m != 0.0 {
            format!(
                " (each waypoint moved {} m towards the map's centre in x and y)",
                self.route_inset_m
            )
        } else {
            String::new()
        };
        format!(
            "Ground truth: a unicycle driven through each map's waypoints{inset} by a turn-then-drive heading controller, integrated exactly at Δt = {} s ({rate_hz} Hz odometry).",
            self.dt_s
        )
    }

    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.in_range("dt_s", self.dt_s, MIN_DT_S, MAX_DT_S);
        c.in_range("route_inset_m", self.route_inset_m, 0.0, MAX_ROUTE_INSET_M);
        c.finish()
    }
}

/// Range noise of a range sensor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum RangeNoise {
    /// σ(r) = σ.
    Constant,
    /// σ(r) = σ₁·r, σ₁ being "σ at 1 m" ([EP] Table 1).
    Proportional,
    /// σ(r) = σ₁·r², σ₁ being "σ at 1 m": stereo depth error, σ_Z = Z² σ_d / (f B) ([PF]
    /// Eq. 12), so σ₁ = σ_d / (f B).
    Quadratic,
}

impl RangeNoise {
    /// How the report names the model: "constant", or the growth with range and the 1 m
    /// reference of σ.
    pub fn describe(self) -> &'static str {
        match self {
            RangeNoise::Constant => "constant",
            RangeNoise::Proportional => "proportional to range, at 1 m",
            RangeNoise::Quadratic => "quadratic in range (stereo), at 1 m",
        }
    }

    pub fn sigma(self, sigma_m: f64, range_m: f64) -> f64 {
        match self {
            RangeNoise::Constant => sigma_m,
            RangeNoise::Proportional => sigma_m * range_m,
            RangeNoise::Quadratic => sigma_m * range_m * range_m,
        }
    }
}

/// Odometry steps between two sensor readings at `rate_hz`, when that is a whole number.
pub fn sensor_period_steps(rate_hz: f64, dt_s: f64) -> Option<usize> {
    let steps = 1.0 / (rate_hz * dt_s);
    let rounded = steps.round();
    (rounded >= 1.0 && (steps - rounded).abs() < 1e-6 * rounded).then_some(rounded as usize)
}

/// Everything that defines one simulated world. Sensors an algorithm does not read are `None`
/// and are not simulated.
#[derive(Debug, Clone, Copy)]
pub struct WorldSpec<'a> {
    pub map: &'a Map,
    pub sim: &'a SimParams,
    pub odometry: &'a OdometryNoise,
    pub laser: Option<&'a LaserParams>,
    pub landmark_sensor: Option<&'a PointSensorParams>,
}

/// One simulated run's data. Step k lasts Δt; `truth[k]` is the pose at its start.
#[derive(Debug, Clone)]
pub struct World {
    pub dt_s: f64,
    /// True poses, one per step plus the start: `truth.len() == odometry.len() + 1`.
    pub truth: Vec<Pose2>,
    /// Measured body-frame increments: `odometry[k]` moves the estimate from step k to k + 1.
    pub odometry: Vec<Pose2>,
    pub laser: Option<LaserGeometry>,
    pub scans: Vec<Scan>,
    pub point_scans: Vec<PointScan>,
    /// Ground-truth landmarks: lines and corners of the walls, and point landmarks.
    pub truth_lines: Vec<Line>,
    pub truth_corners: Vec<Point2>,
    pub truth_points: Vec<Point2>,
    /// The range-bearing sensor's noise model, which filters are told (simulated worlds: the
    /// `[landmark_sensor]` settings; datasets: the noise their map file states).
    pub point_noise: Option<point_sensor::PointNoise>,
}

impl World {
    /// A world of the given truth and odometry, with no sensor data (tests make their own
    /// observations), 0.1 s steps.
    #[cfg(test)]
    pub fn from_odometry(truth: Vec<Pose2>, odometry: Vec<Pose2>) -> World {
        assert_eq!(truth.len(), odometry.len() + 1);
        World {
            dt_s: 0.1,
            truth,
            odometry,
            laser: None,
            scans: Vec::new(),
            point_scans: Vec::new(),
            truth_lines: Vec::new(),
            truth_corners: Vec::new(),
            truth_points: Vec::new(),
            point_noise: None,
        }
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WorldError {
    #[error(
        "trajectory controller did not reach waypoint {waypoint} of lap {lap} within {steps} steps"
    )]
    TrajectoryStuck { waypoint: usize, lap: usize, steps: usize },
    #[error("the trajectory would take about {steps:.0} steps, more than the limit of {max}")]
    TooLong { steps: f64, max: usize },
    #[error("the map has no trajectory to simulate (a dataset map is read, not simulated)")]
    NoTrajectory,
    #[error("{sensor} rate must be a whole number of odometry steps")]
    SensorRate { sensor: &'static str },
    #[error(
        "laser.wall_thickness_px needs the map's bitmap scale, but map `{map}` states no bitmap_m_per_px"
    )]
    NoBitmapScale { map: String },
}

/// Simulates one world.
pub fn generate(spec: &WorldSpec<'_>, world_seed: u64) -> Result<World, WorldError> {
    let dt = spec.sim.dt_s;
    let path = spec.map.trajectory.as_ref().ok_or(WorldError::NoTrajectory)?;
    let path = trajectory::inset(path, &spec.map.walls, spec.sim.route_inset_m);
    let truth = trajectory::drive(spec.map.start, &path, dt)?;
    let stream = |n| {
        let mut rng = ChaCha8Rng::seed_from_u64(world_seed);
        rng.set_stream(n);
        rng
    };
    let odometry =
        spec.odometry.measure(spec.map.start, &truth.controls, dt, &mut stream(ODOMETRY_STREAM));

    let (laser, scans) = match spec.laser {
        Some(params) => {
            let period = sensor_period_steps(params.rate_hz, dt)
                .ok_or(WorldError::SensorRate { sensor: "laser" })?;
            let geometry = params.geometry();
            let thickness = params
                .wall_thickness_on(spec.map.bitmap_m_per_px)
                .ok_or_else(|| WorldError::NoBitmapScale { map: spec.map.name.clone() })?;
            let surfaces = LaserParams::surfaces(thickness, &spec.map.walls);
            let mut rng = stream(LASER_STREAM);
            let scans = (0..truth.poses.len())
                .step_by(period)
                .map(|k| params.scan(&geometry, &surfaces, truth.poses[k], k, &mut rng))
                .collect();
            (Some(geometry), scans)
        }
        None => (None, Vec::new()),
    };
    let point_scans = match spec.landmark_sensor {
        Some(params) => {
            let period = sensor_period_steps(params.rate_hz, dt)
                .ok_or(WorldError::SensorRate { sensor: "landmark sensor" })?;
            let mut rng = stream(POINT_SENSOR_STREAM);
            (0..truth.poses.len())
                .step_by(period)
                .map(|k| {
                    params.observe(
                        &spec.map.point_landmarks,
                        &spec.map.walls,
                        truth.poses[k],
                        k,
                        &mut rng,
                    )
                })
                .collect()
        }
        None => Vec::new(),
    };
    Ok(World {
        dt_s: dt,
        truth: truth.poses,
        odometry,
        laser,
        scans,
        point_scans,
        truth_lines: spec.map.lines.clone(),
        truth_corners: spec.map.corners.clone(),
        truth_points: spec.map.point_landmarks.clone(),
        point_noise: spec.landmark_sensor.map(|p| p.noise()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const MAP: &str = r#"
name = "t"
title = "T"
start = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }
landmarks = [[3, 1], [8, -0.5]]
[[walls]]
points = [[-1, -1], [11, -1], [11, 3], [-1, 3], [-1, -1]]
[trajectory]
max_speed_mps = 0.5
laps = 1
waypoints = [[9, 0], [9, 2], [0, 2], [0, 0]]
"#;

    fn world(odometry: &OdometryNoise, laser: bool, seed: u64) -> World {
        let map = Map::from_toml(MAP).unwrap();
        let lp = LaserParams::default();
        let pp = PointSensorParams::default();
        let spec = WorldSpec {
            map: &map,
            sim: &SimParams::default(),
            odometry,
            laser: laser.then_some(&lp),
            landmark_sensor: Some(&pp),
        };
        generate(&spec, seed).unwrap()
    }

    #[test]
    fn same_seed_same_world_and_laser_does_not_perturb_odometry() {
        let noise = OdometryNoise::default();
        let a = world(&noise, true, 11);
        let b = world(&noise, false, 11);
        assert_eq!(a.odometry, b.odometry);
        assert_eq!(a.point_scans, b.point_scans);
        assert!(b.scans.is_empty() && !a.scans.is_empty());
        assert_eq!(a.scans[1].step, 2); // 5 Hz laser at 10 Hz odometry
        let c = world(&noise, true, 12);
        assert_ne!(a.odometry, c.odometry);
        assert_eq!(a.truth, c.truth); // truth does not depend on the seed
    }

    #[test]
    fn noise_free_odometry_integrates_to_truth() {
        let w = world(&OdometryNoise::None {}, false, 1);
        let mut p = w.truth[0];
        for (k, d) in w.odometry.iter().enumerate() {
            p = p.compose(*d);
            assert!(p.position().distance(w.truth[k + 1].position()) < 1e-9);
        }
    }

    #[test]
    fn sensor_period() {
        assert_eq!(sensor_period_steps(5.0, 0.1), Some(2));
        assert_eq!(sensor_period_steps(10.0, 0.1), Some(1));
        assert_eq!(sensor_period_steps(3.0, 0.1), None);
        assert_eq!(sensor_period_steps(20.0, 0.1), None);
    }

    #[test]
    fn sim_describe_names_the_period_and_rate() {
        let s = SimParams { dt_s: 0.05, ..SimParams::default() }.describe("20.0");
        assert!(s.contains("at Δt = 0.05 s (20.0 Hz odometry)"), "{s}");
    }
}
