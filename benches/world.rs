//! Micro-benchmarks of the simulation layer: laser ray casting, world generation, dead reckoning
//! with metrics, and figure rendering. `make bench` also times the whole pipeline.

use criterion::{Criterion, criterion_group, criterion_main};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use slamlab::geom::Pose2;
use slamlab::report::figure::{LineFigure, LineSeries, SeriesPoint, XAxis, line_svg};
use slamlab::slam::odometry;
use slamlab::world::laser::LaserParams;
use slamlab::world::map::Map;
use slamlab::world::odometry::OdometryNoise;
use slamlab::world::{SimParams, WorldSpec, generate};
use std::hint::black_box;

fn map(name: &str) -> Map {
    let path = format!("{}/data/maps/{name}.toml", env!("CARGO_MANIFEST_DIR"));
    Map::from_toml(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn laser(c: &mut Criterion) {
    let params = LaserParams::default();
    let geometry = params.geometry();
    for name in ["bigloop2", "complex"] {
        let m = map(name);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        c.bench_function(&format!("laser_scan_181_beams/{name}"), |b| {
            b.iter(|| {
                params.scan(&geometry, &m.walls, black_box(Pose2::new(9.0, 0.0, 0.3)), 0, &mut rng)
            })
        });
    }
}

fn worlds(c: &mut Criterion) {
    let m = map("complex");
    let sim = SimParams::default();
    let odometry = OdometryNoise::default();
    let laser = LaserParams::default();
    let spec =
        WorldSpec { map: &m, sim: &sim, odometry: &odometry, laser: None, landmark_sensor: None };
    c.bench_function("world_generate/complex_odometry_only", |b| {
        b.iter(|| generate(black_box(&spec), 7).unwrap())
    });
    let with_laser = WorldSpec { laser: Some(&laser), ..spec };
    c.bench_function("world_generate/complex_with_laser_5hz", |b| {
        b.iter(|| generate(black_box(&with_laser), 7).unwrap())
    });
    let world = generate(&spec, 7).unwrap();
    c.bench_function("odometry_run_and_metrics/complex", |b| {
        b.iter(|| {
            let trace = odometry::run(black_box(&world));
            slamlab::metrics::compute(&world, &trace)
        })
    });
}

fn figures(c: &mut Criterion) {
    let series = (0..5)
        .map(|s| LineSeries {
            label: format!("map {s}"),
            color: s,
            points: (0..7)
                .map(|i| SeriesPoint {
                    x: i as f64,
                    mean: (i * s) as f64,
                    lo: 0.0,
                    hi: (i * s + 1) as f64,
                })
                .collect(),
            dashed: false,
            scatter: false,
        })
        .collect();
    let fig = LineFigure {
        x_label: "x".into(),
        y_label: "y".into(),
        x_axis: XAxis::Linear,
        x_ticks: vec![],
        series,
    };
    c.bench_function("line_figure_svg/5_series_7_points", |b| b.iter(|| line_svg(black_box(&fig))));
}

criterion_group!(benches, laser, worlds, figures);
criterion_main!(benches);
