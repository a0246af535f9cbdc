//! Point-landmark worlds end to end: on a noise-free world every landmark filter recovers the
//! trajectory and the landmarks; on a noisy one each beats dead reckoning; a point-world study runs
//! through the pipeline with its maps stored as `point` rows; a dataset map whose files are absent
//! skips its study with a message instead of failing.

use crate::util::{ok, repo, s, slamlab};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slamlab::metrics::{self, MAP_RMSE};
use slamlab::slam::ekf::{self, EkfAssociation, EkfParams};
use slamlab::slam::fastslam::{self, DataAssociation, FastSlamParams};
use slamlab::slam::fastslam2;
use slamlab::slam::motion::MotionModel;
use slamlab::slam::observations::{Source, stream};
use slamlab::slam::{Trace, odometry};
use slamlab::world::map::Map;
use slamlab::world::odometry::{OdometryNoise, Spread};
use slamlab::world::point_sensor::PointSensorParams;
use slamlab::world::{SimParams, World, WorldSpec, generate};

fn scatter_world(odometry: &OdometryNoise, sensor: &PointSensorParams, seed: u64) -> World {
    let map =
        Map::from_toml(&std::fs::read_to_string(repo().join("data/maps/scatter.toml")).unwrap())
            .unwrap();
    generate(
        &WorldSpec {
            map: &map,
            sim: &SimParams { dt_s: 0.1, ..SimParams::default() },
            odometry,
            laser: None,
            landmark_sensor: Some(sensor),
        },
        seed,
    )
    .unwrap()
}

fn get(world: &World, trace: &Trace, name: &str) -> f64 {
    metrics::compute(world, trace).into_iter().find(|(n, _)| *n == name).unwrap().1
}

/// Every landmark filter, known and own association.
fn filters(world: &World, motion: &MotionModel, known: bool) -> Vec<(&'static str, Trace)> {
    let z = stream(world, Source::Points).unwrap();
    let fs = FastSlamParams {
        particles: 10,
        association: if known {
            DataAssociation::Known
        } else {
            DataAssociation::MaximumLikelihood
        },
        ..FastSlamParams::default()
    };
    let ekf_params = EkfParams {
        association: if known { EkfAssociation::Known } else { EkfAssociation::NearestNeighbour },
        ..EkfParams::default()
    };
    vec![
        (
            "fastslam1",
            fastslam::run_on(
                world,
                &fs,
                Some(motion),
                &z,
                false,
                &mut ChaCha8Rng::seed_from_u64(1),
            )
            .unwrap(),
        ),
        (
            "fastslam2",
            fastslam2::run(world, &fs, motion, &z, false, &mut ChaCha8Rng::seed_from_u64(1))
                .unwrap(),
        ),
        ("ekf_slam", ekf::run(world, motion, &ekf_params, &z, false).unwrap()),
    ]
}

#[test]
fn noise_free_point_world_is_recovered_by_every_filter() {
    let sensor = PointSensorParams {
        range_sigma_m: 0.0,
        bearing_sigma_rad: 0.0,
        ..PointSensorParams::default()
    };
    let world = scatter_world(&OdometryNoise::None {}, &sensor, 1);
    // a tiny motion noise (the filters need a positive-definite Q) and a tiny sensor noise model
    let motion = MotionModel::Proportional {
        k_translation: 0.0,
        k_rotation: 0.0,
        floor_translation_m: 1e-6,
        floor_rotation_rad: 1e-6,
        floor_reason: None,
    };
    let world = World {
        point_noise: Some(
            PointSensorParams { range_sigma_m: 1e-4, bearing_sigma_rad: 1e-5, ..sensor }.noise(),
        ),
        ..world
    };
    let seen: std::collections::BTreeSet<usize> =
        world.point_scans.iter().flat_map(|s| s.observations.iter().map(|o| o.landmark)).collect();
    for known in [true, false] {
        for (name, trace) in filters(&world, &motion, known) {
            assert!(
                get(&world, &trace, "ate_max_m") < 1e-3,
                "{name} (known {known}): ATE max {}",
                get(&world, &trace, "ate_max_m")
            );
            assert!(
                get(&world, &trace, MAP_RMSE) < 1e-3,
                "{name} (known {known}): map RMS {}",
                get(&world, &trace, MAP_RMSE)
            );
            assert_eq!(
                trace.map.as_ref().unwrap().points.len(),
                seen.len(),
                "{name} (known {known}): one map landmark per landmark seen"
            );
        }
    }
}

#[test]
fn every_filter_beats_dead_reckoning_on_a_noisy_world() {
    let noise = OdometryNoise::Proportional { k: 0.1, k_is: Spread::Std };
    let sensor = PointSensorParams { max_range_m: 15.0, ..PointSensorParams::default() };
    let world = scatter_world(&noise, &sensor, 7);
    let dead = get(&world, &odometry::run(&world), "ate_rmse_m");
    for (name, trace) in filters(&world, &MotionModel::default(), true) {
        let ate = get(&world, &trace, "ate_rmse_m");
        assert!(ate < 0.5 * dead, "{name}: {ate} m against dead reckoning's {dead} m");
    }
}

#[test]
fn a_point_world_study_runs_end_to_end() {
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("pts.toml");
    std::fs::write(
        &spec,
        r#"id = "pts"
title = "points"
seed = 3
replicates = 2
maps = ["ev_maze"]
algorithms = ["ekf_slam", "fastslam1", "fastslam2", "odometry_map"]
[base.landmark_sensor]
max_range_m = 1.23
min_range_m = 0.13
fov_deg = 60.0
rate_hz = 1.0
max_observations = 5
[base.fastslam]
particles = 20
association = "known"
[base.ekf]
association = "known"
[report]
metrics = ["map_rmse_m", "nees_mean", "ate_rmse_m"]
"#,
    )
    .unwrap();
    let (results, cache, reports) =
        (dir.path().join("results"), dir.path().join("cache"), dir.path().join("reports"));
    ok(&["run", s(&spec), "--results", s(&results), "--cache", s(&cache), "--quiet"]);
    ok(&["report", "--results", s(&results), "--out", s(&reports)]);
    let runs = slamlab::store::read_runs(&results.join("pts")).unwrap();
    assert_eq!(runs.len(), 8);
    for r in &runs {
        assert_eq!(r.status, slamlab::store::RunStatus::Ok, "{}: {:?}", r.run_id, r.error);
        assert!(
            r.metric(MAP_RMSE).is_some_and(|v| v.is_finite() && v < 0.5),
            "{}: map RMS {:?}",
            r.run_id,
            r.metric(MAP_RMSE)
        );
        // EKF-SLAM and the particle filters report a pose covariance; one particle does not
        assert_eq!(r.metric("nees_mean").is_some(), r.algorithm != "odometry_map", "{}", r.run_id);
    }
    let summary = std::fs::read_to_string(reports.join("pts/summary.csv")).unwrap();
    assert!(summary.contains("ekf_slam") && summary.contains("fastslam2"));
}

#[test]
fn a_dataset_study_without_its_data_is_skipped_not_failed() {
    let dir = tempfile::tempdir().unwrap();
    let maps = dir.path().join("maps");
    std::fs::create_dir(&maps).unwrap();
    std::fs::write(
        maps.join("gone.toml"),
        "name = \"gone\"\ntitle = \"Gone\"\nstart = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }\n[dataset]\nkind = \"mrclam\"\npath = \"/nonexistent/MRCLAM_Dataset6\"\n",
    )
    .unwrap();
    let spec = dir.path().join("gone.toml");
    std::fs::write(&spec, "id = \"gone\"\ntitle = \"g\"\nseed = 1\nreplicates = 1\nmaps = [\"gone\"]\nalgorithms = [\"odometry\"]\n").unwrap();
    let results = dir.path().join("results");
    // alone, the skipped study means nothing was done: a non-zero exit that says so
    let out = slamlab(&[
        "run",
        s(&spec),
        "--maps",
        s(&maps),
        "--results",
        s(&results),
        "--cache",
        s(&dir.path().join("cache")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("every study was skipped"), "{err}");
    assert!(err.contains("gone: skipped") && err.contains("/nonexistent/MRCLAM_Dataset6"), "{err}");
    assert!(!results.join("gone").exists(), "nothing is written for a skipped study");
    // beside a study that runs, it is skipped (and named), not failed
    let smoke = repo().join("experiments/smoke.toml");
    for m in ["bigloop2", "recinto_basico"] {
        std::fs::copy(repo().join(format!("data/maps/{m}.toml")), maps.join(format!("{m}.toml")))
            .unwrap();
    }
    let out = slamlab(&[
        "run",
        s(&spec),
        s(&smoke),
        "--quiet",
        "--maps",
        s(&maps),
        "--results",
        s(&results),
        "--cache",
        s(&dir.path().join("cache")),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && err.contains("skipped (data absent on this machine"), "{err}");
    assert!(results.join("smoke").exists() && !results.join("gone").exists());
    // validate says the data is absent, naming the file, and exits non-zero
    let out = slamlab(&["validate", s(&spec), "--maps", s(&maps)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains("its data is absent")
            && err.contains("/nonexistent/MRCLAM_Dataset6"),
        "{err}"
    );
}

#[test]
fn a_bad_dataset_table_names_the_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let maps = dir.path().join("maps");
    std::fs::create_dir(&maps).unwrap();
    std::fs::write(maps.join("bad.toml"), "name = \"bad\"\ntitle = \"Bad\"\nstart = { x_m = 0.0, y_m = 0.0, theta_deg = 0.0 }\n[dataset]\nkind = \"mrclam\"\nrobot = 9\n").unwrap();
    let spec = dir.path().join("bad.toml");
    std::fs::write(&spec, "id = \"bad\"\ntitle = \"b\"\nseed = 1\nreplicates = 1\nmaps = [\"bad\"]\nalgorithms = [\"odometry\"]\n").unwrap();
    let out = slamlab(&["validate", s(&spec), "--maps", s(&maps)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("bad.toml") && err.contains("dataset") && err.contains("robot"), "{err}");
}

#[test]
fn a_study_without_results_keeps_its_report_when_its_spec_remains() {
    // real-data studies on a machine without the data: `make report` must not delete them
    let dir = tempfile::tempdir().unwrap();
    let specs = dir.path().join("experiments");
    std::fs::create_dir(&specs).unwrap();
    std::fs::copy(repo().join("experiments/smoke.toml"), specs.join("smoke.toml")).unwrap();
    let (results, cache, reports) =
        (dir.path().join("results"), dir.path().join("cache"), dir.path().join("reports"));
    ok(&[
        "run",
        s(&specs.join("smoke.toml")),
        "--results",
        s(&results),
        "--cache",
        s(&cache),
        "--quiet",
    ]);
    ok(&["report", "--results", s(&results), "--out", s(&reports), "--specs", s(&specs)]);
    let before = crate::util::tree(&reports.join("smoke"));
    let index = std::fs::read(reports.join("index.html")).unwrap();
    std::fs::remove_dir_all(results.join("smoke")).unwrap();
    std::fs::create_dir_all(&results).unwrap();
    let out = ok(&["report", "--results", s(&results), "--out", s(&reports), "--specs", s(&specs)]);
    assert!(
        String::from_utf8_lossy(&out.stderr)
            .contains("1 study has no results here; its previous report is kept: smoke")
    );
    assert_eq!(crate::util::tree(&reports.join("smoke")), before, "kept byte for byte");
    assert_eq!(
        std::fs::read(reports.join("index.html")).unwrap(),
        index,
        "and listed in the index"
    );
    // its claims enter the scoreboard: unreadable, they are an error naming the file, not a
    // silent "claims not evaluated"
    let claims = reports.join("smoke/claims.json");
    let good = std::fs::read(&claims).unwrap();
    std::fs::write(&claims, "not json").unwrap();
    let out =
        slamlab(&["report", "--results", s(&results), "--out", s(&reports), "--specs", s(&specs)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("claims.json"), "{err}");
    std::fs::write(&claims, good).unwrap();
    // without its spec the study is retired, when asked to (--prune); never silently
    std::fs::remove_file(specs.join("smoke.toml")).unwrap();
    let out =
        slamlab(&["report", "--results", s(&results), "--out", s(&reports), "--specs", s(&specs)]);
    assert!(
        !out.status.success() && reports.join("smoke/index.html").is_file(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    ok(&[
        "report",
        "--results",
        s(&results),
        "--out",
        s(&reports),
        "--specs",
        s(&specs),
        "--prune",
    ]);
    assert!(!reports.join("smoke").exists());
}
