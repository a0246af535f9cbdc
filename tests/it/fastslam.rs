//! FastSLAM 1.0 on the five [FT] maps with noise-free laser and odometry: the landmark error must
//! be ≈ 0 and the landmark counts exact (8, 9, 16, 22, 26). With perfect data and no motion
//! noise every particle stays on the true path, so this checks extraction, the observation
//! models, association and the landmark EKFs end to end.

use crate::util::repo;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slamlab::features::FeatureParams;
use slamlab::metrics::{self, LANDMARK_ERROR, LANDMARKS_DETECTED};
use slamlab::slam::fastslam::{self, FastSlamParams};
use slamlab::world::laser::LaserParams;
use slamlab::world::map::Map;
use slamlab::world::odometry::OdometryNoise;
use slamlab::world::{SimParams, WorldSpec, generate};

#[test]
fn noise_free_worlds_give_exact_maps_on_all_five_thesis_maps() {
    let sim = SimParams { dt_s: 0.2, ..SimParams::default() };
    let laser = LaserParams { range_sigma_m: 0.0, rate_hz: 5.0, ..LaserParams::default() };
    let params = FastSlamParams {
        particles: 10,
        motion_x: 0.0,
        motion_y: 0.0,
        motion_theta: 0.0,
        ..FastSlamParams::default()
    };
    for (name, count) in [
        ("recinto_basico", 8.0),
        ("lineamedia", 9.0),
        ("bigloop", 16.0),
        ("bigloop2", 22.0),
        ("complex", 26.0),
    ] {
        let map = Map::from_toml(
            &std::fs::read_to_string(repo().join(format!("data/maps/{name}.toml"))).unwrap(),
        )
        .unwrap();
        let world = generate(
            &WorldSpec {
                map: &map,
                sim: &sim,
                odometry: &OdometryNoise::None {},
                laser: Some(&laser),
                landmark_sensor: None,
            },
            1,
        )
        .unwrap();
        let trace = fastslam::run(
            &world,
            &params,
            &FeatureParams::default(),
            &mut ChaCha8Rng::seed_from_u64(2),
        )
        .unwrap();
        let m = metrics::compute(&world, &trace);
        let get = |k: &str| m.iter().find(|(n, _)| *n == k).unwrap().1;
        assert_eq!(get(LANDMARKS_DETECTED), count, "{name}: landmark count");
        assert!(get(LANDMARK_ERROR) < 0.01, "{name}: landmark error {} m", get(LANDMARK_ERROR));
        assert_eq!(get("landmark_recall"), 1.0, "{name}");
        assert!(get("ate_rmse_m") < 1e-9, "{name}: the particles stay on the true path");
        assert_eq!(trace.numerical_failures, 0);
    }
}

#[test]
fn fastslam_beats_dead_reckoning_on_a_noisy_world() {
    // [FT] claim 15, as a regression guard: with the thesis's odometry noise, FastSLAM's
    // trajectory error is well below dead reckoning's.
    let map =
        Map::from_toml(&std::fs::read_to_string(repo().join("data/maps/bigloop2.toml")).unwrap())
            .unwrap();
    let sim = SimParams { dt_s: 0.2, ..SimParams::default() };
    let laser = LaserParams {
        range_sigma_m: 0.0,
        rate_hz: 5.0,
        resolution_deg: 0.5,
        ..LaserParams::default()
    };
    let odometry = OdometryNoise::default();
    let world = generate(
        &WorldSpec {
            map: &map,
            sim: &sim,
            odometry: &odometry,
            laser: Some(&laser),
            landmark_sensor: None,
        },
        3,
    )
    .unwrap();
    let params = FastSlamParams {
        motion_x: 0.01,
        motion_y: 0.01,
        motion_theta: 0.008,
        ..FastSlamParams::default()
    };
    let slam = fastslam::run(
        &world,
        &params,
        &FeatureParams::default(),
        &mut ChaCha8Rng::seed_from_u64(4),
    )
    .unwrap();
    let dead = slamlab::slam::odometry::run(&world);
    let ate =
        |t: &slamlab::slam::Trace| metrics::trajectory_metrics(&world.truth, &t.estimate)[0].1;
    assert!(
        ate(&slam) < 0.5 * ate(&dead),
        "FastSLAM {} m vs dead reckoning {} m",
        ate(&slam),
        ate(&dead)
    );
}
