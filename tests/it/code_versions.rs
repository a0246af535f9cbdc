//! Cache safety: a run's cache key includes hand-maintained code versions. If world generation,
//! an algorithm or a metric changes its output without a version bump, stale cached results would
//! be served silently. This test fingerprints a fixed-seed run and fails until the versions (and
//! then the fingerprint) are updated.

use crate::util::repo;
use slamlab::algo::Algorithm;
use slamlab::geom::Pose2;
use slamlab::metrics::{self, METRICS_VERSION};
use slamlab::slam::odometry;
use slamlab::world::laser::LaserParams;
use slamlab::world::map::Map;
use slamlab::world::odometry::{OdometryNoise, Spread};
use slamlab::world::point_sensor::{POINT_SENSOR_CODE_VERSION, PointSensorParams};
use slamlab::world::{RangeNoise, SimParams, WORLD_CODE_VERSION, WorldSpec, generate};

/// The code versions the fingerprint below was taken with.
const VERSIONS: &str = "world-2+points-3+metrics-3+odometry-1";
const FINGERPRINT: &str = "7f233df581a60ca4e1754b8e195e2cc214b5e94725fda455b005bf092a23c69c";

fn fingerprint() -> String {
    let text = std::fs::read_to_string(repo().join("data/maps/bigloop2.toml")).unwrap();
    let mut map = Map::from_toml(&text).unwrap();
    map.point_landmarks =
        vec![slamlab::geom::Point2::new(4.0, 1.0), slamlab::geom::Point2::new(12.0, 7.0)];
    let mut h = blake3::Hasher::new();
    // Every odometry noise model and reading, and both sensors with both range-noise models.
    let models = [
        OdometryNoise::None {},
        OdometryNoise::Proportional { k: 0.1, k_is: Spread::Std },
        OdometryNoise::Proportional { k: 0.1, k_is: Spread::Variance },
        OdometryNoise::Pose { var_x_m2: 1e-4, var_y_m2: 2e-4, var_theta_rad2: 1e-5 },
        OdometryNoise::Systematic {
            k: 0.05,
            heading_bias_deg_per_m: 0.6,
            turn_slip_m_per_rad: 0.06,
        },
    ];
    for (i, noise) in models.iter().enumerate() {
        let sim = SimParams::default();
        let range_noise =
            [RangeNoise::Constant, RangeNoise::Proportional, RangeNoise::Quadratic][i % 3];
        let laser = LaserParams { range_noise, ..LaserParams::default() };
        // occlusion by the walls, a minimum range and a per-reading limit
        let sensor = PointSensorParams {
            range_noise,
            min_range_m: 0.5,
            max_observations: 1,
            ..PointSensorParams::default()
        };
        let world = generate(
            &WorldSpec {
                map: &map,
                sim: &sim,
                odometry: noise,
                laser: Some(&laser),
                landmark_sensor: Some(&sensor),
            },
            42,
        )
        .unwrap();
        hash_run(&mut h, &world);
    }
    h.finalize().to_hex().to_string()
}

fn hash_run(h: &mut blake3::Hasher, world: &slamlab::world::World) {
    let trace = odometry::run(world);
    let pose = |h: &mut blake3::Hasher, p: &Pose2| {
        for v in [p.x, p.y, p.theta] {
            h.update(&v.to_le_bytes());
        }
    };
    world.truth.iter().chain(&world.odometry).chain(&trace.estimate).for_each(|p| pose(h, p));
    for s in &world.scans {
        h.update(&(s.step as u64).to_le_bytes());
        for r in &s.ranges_m {
            h.update(&r.unwrap_or(-1.0).to_le_bytes());
        }
    }
    for s in &world.point_scans {
        for o in &s.observations {
            h.update(&(o.landmark as u64).to_le_bytes());
            h.update(&o.range_m.to_le_bytes());
            h.update(&o.bearing_rad.to_le_bytes());
        }
    }
    for (name, v) in metrics::compute(world, &trace) {
        h.update(name.as_bytes());
        h.update(&v.to_le_bytes());
    }
}

#[test]
fn outputs_change_only_with_a_code_version_bump() {
    let versions = format!(
        "{WORLD_CODE_VERSION}+{POINT_SENSOR_CODE_VERSION}+{METRICS_VERSION}+{}",
        slamlab::algo::filters::Odometry.code_version()
    );
    let now = fingerprint();
    assert_eq!(
        versions,
        VERSIONS,
        "code versions changed: set VERSIONS = \"{versions}\" and FINGERPRINT = \"{now}\" in {}",
        file!()
    );
    assert_eq!(
        now, FINGERPRINT,
        "world/odometry/metrics output changed with the same code versions ({versions}): bump the version of the layer you changed \
         (WORLD_CODE_VERSION, METRICS_VERSION or the algorithm's CODE_VERSION) so cached runs are recomputed, then update VERSIONS and FINGERPRINT"
    );
}
