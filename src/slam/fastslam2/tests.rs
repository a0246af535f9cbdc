//! Tests of FastSLAM 2.0 on small hand-built worlds: noise-free tracking, the proposal's gain
//! over motion-model sampling, the importance factor's density, resampling bookkeeping,
//! numerical failures, and the proposal covariance.

use super::*;
use crate::geom::{Line, Point2};
use crate::slam::observations::Cursor;
use rand::SeedableRng;
use std::f64::consts::{PI, TAU};
use std::sync::Arc;

/// Steps of one lap of the test circle.
const LAP_STEPS: usize = 200;
/// Distance driven per step [m].
const STEP_M: f64 = 0.1;
/// Range of the simulated point sensor [m].
const MAX_RANGE_M: f64 = 3.5;
/// Identities of line landmarks start here (point landmarks use 0..).
const LINE_ID_OFFSET: usize = 100;

fn params(particles: u32, association: DataAssociation) -> FastSlamParams {
    FastSlamParams { particles, association, ..FastSlamParams::default() }
}

/// Point landmarks around the circle the robot drives: an outer ring and an inner one.
fn landmarks() -> Vec<Point2> {
    let radius = STEP_M / (TAU / LAP_STEPS as f64);
    let center = Point2::new(0.0, radius);
    let ring = |n: usize, r: f64, phase: f64| {
        (0..n).map(move |i| {
            let a = phase + TAU * i as f64 / n as f64;
            Point2::new(center.x + r * a.cos(), center.y + r * a.sin())
        })
    };
    ring(10, radius + 1.5, 0.1).chain(ring(5, radius - 1.5, 0.4)).collect()
}

/// Walls of a box around the circle, as (ρ, θ) lines.
fn walls() -> Vec<Line> {
    vec![
        Line::normalised(6.0, 0.0),
        Line::normalised(6.0, PI),
        Line::normalised(3.0, -PI / 2.0),
        Line::normalised(10.0, PI / 2.0),
    ]
}

/// A robot driving one lap of a circle; odometry = true increment + N(0, diag(σt², σt², σr²))
/// in the body frame (σ = `odometry_sigma` = [σt m, σr rad]).
fn circle_world(odometry_sigma: [f64; 2], seed: u64) -> World {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let u = Pose2::new(STEP_M, 0.0, TAU / LAP_STEPS as f64);
    let mut truth = vec![Pose2::IDENTITY];
    let mut odometry = Vec::new();
    for _ in 0..LAP_STEPS {
        truth.push(truth.last().unwrap().compose(u));
        let n: [f64; 3] =
            [rng.sample(StandardNormal), rng.sample(StandardNormal), rng.sample(StandardNormal)];
        odometry.push(Pose2::new(
            u.x + odometry_sigma[0] * n[0],
            u.y + odometry_sigma[0] * n[1],
            u.theta + odometry_sigma[1] * n[2],
        ));
    }
    World { truth_points: landmarks(), ..World::from_odometry(truth, odometry) }
}

/// Range-bearing observations of the point landmarks within range (and of `lines` as (ρ', θ'))
/// at every step, with N(0, R) noise if `noise` is given.
fn observe(
    world: &World,
    r: Matrix2<f64>,
    lines: &[Line],
    mut noise: Option<&mut ChaCha8Rng>,
) -> Vec<StepObservations> {
    let sd = [r[(0, 0)].sqrt(), r[(1, 1)].sqrt()];
    let mut measure = |model: Model, m: Vector2<f64>, pose: &Pose2, id: usize| {
        let mut z = model.predict(&m, pose).z;
        if let Some(rng) = noise.as_deref_mut() {
            let (a, b): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
            z += Vector2::new(sd[0] * a, sd[1] * b);
            z[1] = wrap_angle(z[1]);
        }
        Observation { model, z, r, landmark: Some(id) }
    };
    world
        .truth
        .iter()
        .enumerate()
        .map(|(k, pose)| {
            let points = world
                .truth_points
                .iter()
                .enumerate()
                .filter(|(_, p)| p.distance(pose.position()) <= MAX_RANGE_M);
            let mut observations: Vec<Observation> = points
                .map(|(j, p)| measure(Model::Point, Vector2::new(p.x, p.y), pose, j))
                .collect();
            observations.extend(lines.iter().enumerate().map(|(j, l)| {
                measure(Model::Line, Vector2::new(l.rho, l.theta), pose, LINE_ID_OFFSET + j)
            }));
            StepObservations { step: k, observations }
        })
        .filter(|s| !s.observations.is_empty())
        .collect()
}

/// Root mean square position error [m].
fn ate(truth: &[Pose2], estimate: &[Pose2]) -> f64 {
    assert_eq!(truth.len(), estimate.len());
    (truth
        .iter()
        .zip(estimate)
        .map(|(t, e)| (t.x - e.x).powi(2) + (t.y - e.y).powi(2))
        .sum::<f64>()
        / truth.len() as f64)
        .sqrt()
}

fn is_symmetric_pd(m: &Matrix3<f64>) -> bool {
    (m - m.transpose()).abs().max() == 0.0 && m.symmetric_eigenvalues().iter().all(|&e| e > 0.0)
}

#[test]
fn noise_free_world_is_tracked_and_mapped_exactly() {
    // σ = 1e-4 per step would drift ~1.4 mm over the lap on its own: the observations hold it.
    let motion = MotionModel::Pose { sigma_x_m: 1e-4, sigma_y_m: 1e-4, sigma_theta_rad: 1e-4 };
    let r = Matrix2::new(1e-10, 0.0, 0.0, 1e-10);
    let world = circle_world([0.0, 0.0], 1);
    let walls = walls();
    let observations = observe(&world, r, &walls, None);
    let seen: Vec<usize> = (0..world.truth_points.len())
        .filter(|j| {
            observations.iter().any(|s| {
                s.observations.iter().any(|o| o.model == Model::Point && o.landmark == Some(*j))
            })
        })
        .collect();
    assert!(seen.len() >= 10, "the test world must show most landmarks, saw {}", seen.len());
    for association in [DataAssociation::Known, DataAssociation::MaximumLikelihood] {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let trace =
            run(&world, &params(10, association), &motion, &observations, false, &mut rng).unwrap();
        assert_eq!(trace.numerical_failures, 0, "{association:?}");
        assert_eq!(trace.estimate.len(), world.truth.len());
        for (k, (t, e)) in world.truth.iter().zip(&trace.estimate).enumerate() {
            assert!(
                t.position().distance(e.position()) < 1e-3
                    && wrap_angle(t.theta - e.theta).abs() < 1e-3,
                "{association:?} step {k}: {t:?} vs {e:?}"
            );
        }
        let map = trace.map.unwrap();
        assert_eq!(map.points.len(), seen.len(), "{association:?}: one landmark per true landmark");
        for (i, p) in map.points.iter().enumerate() {
            let nearest =
                world.truth_points.iter().map(|t| t.distance(*p)).fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-3, "{association:?} landmark {p:?}: {nearest} m off");
            if association == DataAssociation::Known {
                assert!(world.truth_points[map.point_ids[i].unwrap()].distance(*p) < 1e-3);
            } else {
                assert_eq!(
                    map.point_ids[i], None,
                    "identities are kept only under known association"
                );
            }
        }
        assert_eq!(map.lines.len(), walls.len(), "{association:?}");
        for l in &map.lines {
            assert!(
                walls
                    .iter()
                    .any(|w| (w.rho - l.rho).abs() < 1e-3
                        && wrap_angle(w.theta - l.theta).abs() < 1e-3),
                "{association:?} line {l:?}"
            );
        }
        assert!(
            trace
                .pose_belief
                .iter()
                .all(|c| c.is_some_and(|(m, c)| m.is_finite() && c.iter().all(|v| v.is_finite())))
        );
    }
}

#[test]
fn the_proposal_beats_motion_sampling_with_few_particles() {
    // Odometry 2 cm and 0.02 rad per step, sensor 1 cm and 0.002 rad: the observations pin the
    // pose far tighter than the motion model, where FastSLAM 1.0 degenerates ([FS2] §5).
    let sigma = [0.02, 0.02];
    let motion = MotionModel::Proportional {
        k_translation: 0.0,
        k_rotation: 0.0,
        floor_translation_m: sigma[0],
        floor_rotation_rad: sigma[1],
        floor_reason: None,
    };
    let r = Matrix2::new(1e-4, 0.0, 0.0, 4e-6);
    let p = params(5, DataAssociation::Known);
    let seeds = 10;
    let (mut fs2, mut fs1) = (0.0, 0.0);
    for seed in 0..seeds {
        let world = circle_world(sigma, 10 + seed);
        let observations =
            observe(&world, r, &[], Some(&mut ChaCha8Rng::seed_from_u64(100 + seed)));
        let ate_of = |proposal| {
            let trace = run_with(
                &world,
                &p,
                &motion,
                &observations,
                false,
                proposal,
                &mut ChaCha8Rng::seed_from_u64(200 + seed),
            )
            .unwrap();
            ate(&world.truth, &trace.estimate)
        };
        fs2 += ate_of(Proposal::Observations) / seeds as f64;
        fs1 += ate_of(Proposal::Motion) / seeds as f64;
    }
    assert!(fs2 < 0.25 * fs1, "mean ATE: FastSLAM 2.0 {fs2} m, motion-model sampling {fs1} m");
}

#[test]
fn the_importance_factor_is_the_predictive_density_of_the_measurement() {
    // N(z; ẑ(x̂), S) must integrate to 1 over z, and its covariance must be that of z when the
    // pose ~ N(x̂, Q), the landmark ~ N(μ, Σ) and the noise ~ N(0, R): the pose term dominates,
    // so dropping H_x Q H_xᵀ (or using Q in place of S) fails the moment check.
    let pose = Pose2::new(0.5, -0.2, 0.3);
    let q = Matrix3::new(0.004, 0.001, 0.0005, 0.001, 0.003, -0.0004, 0.0005, -0.0004, 0.002);
    let l = Landmark::new(Vector2::new(3.5, 1.0), Matrix2::new(2e-3, 5e-4, 5e-4, 1e-3));
    let r = Matrix2::new(1e-3, 0.0, 0.0, 2e-4);
    let zhat = Model::Point.predict(&l.mean, &pose).z;

    // Monte Carlo covariance of z
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let (lq, ll, lr) =
        (q.cholesky().unwrap().l(), l.cov.cholesky().unwrap().l(), r.cholesky().unwrap().l());
    let n = 40_000;
    let mut samples = Vec::with_capacity(n);
    for _ in 0..n {
        let mut normal = || -> f64 { rng.sample(StandardNormal) };
        let dp = lq * Vector3::new(normal(), normal(), normal());
        let m = l.mean + ll * Vector2::new(normal(), normal());
        let x = Pose2::new(pose.x + dp[0], pose.y + dp[1], pose.theta + dp[2]);
        samples.push(Model::Point.innovation(
            &(Model::Point.predict(&m, &x).z + lr * Vector2::new(normal(), normal())),
            &zhat,
        ));
    }
    let mean = samples.iter().sum::<Vector2<f64>>() / n as f64;
    let mc = samples.iter().map(|s| (s - mean) * (s - mean).transpose()).sum::<Matrix2<f64>>()
        / (n - 1) as f64;

    // Riemann sums of the density and its second moment over ±7σ
    let (cells, span) = (300, 7.0);
    let h = [
        2.0 * span * mc[(0, 0)].sqrt() / cells as f64,
        2.0 * span * mc[(1, 1)].sqrt() / cells as f64,
    ];
    let (mut mass, mut moment) = (0.0, Matrix2::zeros());
    for i in 0..cells {
        for j in 0..cells {
            let d = Vector2::new(
                (i as f64 + 0.5 - cells as f64 / 2.0) * h[0],
                (j as f64 + 0.5 - cells as f64 / 2.0) * h[1],
            );
            let o = Observation { model: Model::Point, z: zhat + d, r, landmark: None };
            let density = evaluate(&o, &l, &pose, &q).unwrap().log_likelihood.exp() * h[0] * h[1];
            mass += density;
            moment += density * d * d.transpose();
        }
    }
    assert!((mass - 1.0).abs() < 1e-3, "∫ N dz = {mass}");
    assert!(
        (moment - mc).abs().max() < 0.05 * mc.abs().max(),
        "density covariance\n{moment}\nMonte Carlo\n{mc}"
    );
    let s =
        evaluate(&Observation { model: Model::Point, z: zhat, r, landmark: None }, &l, &pose, &q)
            .unwrap()
            .s;
    assert!((moment - s).abs().max() < 1e-3 * s.abs().max(), "the second moment is S");
}

#[test]
fn resampling_keeps_the_particle_count_and_follows_the_best_particle() {
    let sigma = [0.02, 0.02];
    let motion = MotionModel::Proportional {
        k_translation: 0.0,
        k_rotation: 0.0,
        floor_translation_m: sigma[0],
        floor_rotation_rad: sigma[1],
        floor_reason: None,
    };
    let world = circle_world(sigma, 4);
    let observations = observe(
        &world,
        Matrix2::new(1e-4, 0.0, 0.0, 4e-6),
        &[],
        Some(&mut ChaCha8Rng::seed_from_u64(5)),
    );
    let p = params(20, DataAssociation::Known);
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let mut f = FastSlam2::new(&p, &motion, Proposal::Observations, world.truth[0]);
    let mut next = observations.iter().peekable();
    for k in 0..=world.odometry.len() {
        let control = k.checked_sub(1).map(|j| &world.odometry[j]);
        let z: &[Observation] = next.next_if(|s| s.step == k).map_or(&[], |s| &s.observations);
        for i in 0..f.particles.len() {
            f.advance(i, control, z, &mut rng);
        }
        if z.is_empty() {
            continue;
        }
        let best = particle::argmax(&f.particles.iter().map(|p| p.log_weight).collect::<Vec<_>>());
        let (pose, map) = (f.particles[best].pose, Arc::clone(&f.particles[best].map));
        let before = f.resamples;
        f.select(&mut rng);
        assert_eq!(f.resamples, before + 1, "threshold ∞: every weighted step resamples");
        assert_eq!(f.particles.len(), 20);
        assert_eq!(
            f.particles[f.best].pose, pose,
            "step {k}: the best particle is followed through resampling"
        );
        assert!(
            Arc::ptr_eq(&f.particles[f.best].map, &map),
            "step {k}: resampling shares maps, never copies them"
        );
        assert!(f.weights.iter().all(|&w| w == 1.0 / 20.0));
    }
    assert_eq!(f.numerical_failures, 0);

    // the trace's bookkeeping, resampling always and never
    for (threshold, resamples) in [(f64::INFINITY, observations.len() as u64), (0.0, 0)] {
        let p = FastSlamParams { neff_threshold: threshold, ..p.clone() };
        let trace =
            run(&world, &p, &motion, &observations, true, &mut ChaCha8Rng::seed_from_u64(7))
                .unwrap();
        assert_eq!(trace.weighted_steps, observations.len() as u64);
        assert_eq!(trace.resamples, resamples);
        assert!(
            trace
                .neff
                .iter()
                .enumerate()
                .all(|(k, n)| n.is_some() == observations.iter().any(|s| s.step == k))
        );
        assert!(trace.neff.iter().flatten().all(|&n| (1.0 - 1e-9..=20.0 + 1e-9).contains(&n)));
        assert_eq!(trace.pose_belief.len(), world.truth.len());
        let map = trace.map.unwrap();
        assert!(map.points.is_empty() && !map.corners.is_empty(), "points_as_corners");
    }
}

#[test]
fn singular_covariances_are_counted_not_panicking() {
    // R = 0: a new landmark gets Σ = 0, so its next sighting has Z = 0 (the EKF update is
    // singular) — and an observation taken at the landmark itself has no bearing at all.
    let motion = MotionModel::Pose { sigma_x_m: 0.01, sigma_y_m: 0.01, sigma_theta_rad: 0.01 };
    let world = circle_world([0.0, 0.0], 8);
    let mut observations = observe(&world, Matrix2::zeros(), &[], None);
    observations[0].observations.push(Observation {
        model: Model::Point,
        z: Vector2::zeros(),
        r: Matrix2::zeros(),
        landmark: Some(99),
    });
    for association in [DataAssociation::Known, DataAssociation::MaximumLikelihood] {
        let trace = run(
            &world,
            &params(10, association),
            &motion,
            &observations,
            false,
            &mut ChaCha8Rng::seed_from_u64(9),
        )
        .unwrap();
        assert!(trace.numerical_failures > 0, "{association:?}");
        assert!(trace.estimate.iter().all(|e| e.is_finite()), "{association:?}");
        assert!(trace.map.unwrap().points.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
    }
}

#[test]
fn known_association_needs_identities() {
    let world = circle_world([0.0, 0.0], 1);
    let mut observations = observe(&world, Matrix2::identity(), &[], None);
    observations[3].observations[0].landmark = None;
    let r = run(
        &world,
        &params(3, DataAssociation::Known),
        &MotionModel::default(),
        &observations,
        false,
        &mut ChaCha8Rng::seed_from_u64(1),
    );
    assert_eq!(r, Err(SlamError::NoIdentities));
}

#[test]
fn a_precise_observation_shrinks_the_proposal() {
    let q = Matrix3::new(0.01, 0.002, 0.001, 0.002, 0.008, -0.001, 0.001, -0.001, 0.004);
    let predicted = Pose2::new(1.0, 0.5, 0.3);
    let r = Matrix2::new(1e-4, 0.0, 0.0, 1e-5);
    let (mut mu, mut sigma) = (predicted, q);
    let mut previous = q;
    for (k, (model, m)) in [
        (Model::Point, Vector2::new(4.0, 2.0)),
        (Model::Line, Vector2::new(5.0, 0.2)),
        (Model::Point, Vector2::new(0.0, 4.0)),
    ]
    .into_iter()
    .enumerate()
    {
        let l = Landmark::new(m, Matrix2::new(1e-4, 0.0, 0.0, 1e-4));
        // measured from a pose 5 cm off the prediction
        let z = model.predict(&m, &Pose2::new(1.05, 0.45, 0.32)).z;
        let o = Observation { model, z, r, landmark: None };
        let before = (mu, sigma);
        assert!(refine(&mut mu, &mut sigma, &o, &l).is_some());
        assert!(
            sigma.trace() < previous.trace(),
            "observation {k}: {} → {}",
            previous.trace(),
            sigma.trace()
        );
        assert!(is_symmetric_pd(&sigma), "observation {k}: {sigma}");
        // the information form of Eqs. (4)–(5), linearised at the previous mean
        let full = model.predict_full(&m, &before.0);
        let z_cov = full.h_landmark * l.cov * full.h_landmark.transpose() + r;
        let z_inv = z_cov.try_inverse().unwrap();
        let info = (full.h_pose.transpose() * z_inv * full.h_pose
            + before.1.try_inverse().unwrap())
        .try_inverse()
        .unwrap();
        assert!(
            (info - sigma).abs().max() < 1e-9 * q.abs().max(),
            "Kalman and information forms agree\n{info}\n{sigma}"
        );
        let step = info * full.h_pose.transpose() * z_inv * model.innovation(&z, &full.z);
        let expected =
            Vector3::new(before.0.x + step[0], before.0.y + step[1], before.0.theta + step[2]);
        assert!((Vector3::new(mu.x, mu.y, mu.theta) - expected).abs().max() < 1e-9, "mean update");
        previous = sigma;
    }
    assert!(
        sigma.trace() < 0.05 * q.trace(),
        "three precise observations pin the pose: {}",
        sigma.trace()
    );
    assert!(mu.position().distance(Pose2::new(1.05, 0.45, 0.32).position()) < 0.01, "{mu:?}");
}

#[test]
fn the_proposal_factor_accepts_semidefinite_and_rejects_indefinite_matrices() {
    let pd = Matrix3::new(4.0, 2.0, 0.4, 2.0, 3.0, 0.1, 0.4, 0.1, 1.0);
    let l = psd_cholesky(&pd).unwrap();
    assert!((l * l.transpose() - pd).abs().max() < 1e-12);
    assert_eq!(
        l,
        pd.cholesky().unwrap().l(),
        "the ordinary Cholesky factor when positive definite"
    );
    // no uncertainty in θ (a motion model with σθ = 0): a zero column, not a failure
    let psd = Matrix3::new(0.01, 0.002, 0.0, 0.002, 0.02, 0.0, 0.0, 0.0, 0.0);
    let l = psd_cholesky(&psd).unwrap();
    assert!((l * l.transpose() - psd).abs().max() < 1e-15);
    assert!(psd_cholesky(&Matrix3::zeros()).is_some_and(|l| l == Matrix3::zeros()));
    for bad in [
        Matrix3::new(1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.5, 1.0),
        Matrix3::from_diagonal_element(f64::NAN),
    ] {
        assert!(psd_cholesky(&bad).is_none(), "{bad}");
    }
}

/// One particle with one known point landmark (identity 0), about to move by `u`.
fn one_particle<'a>(p: &'a FastSlamParams, motion: &'a MotionModel) -> (FastSlam2<'a>, Landmark) {
    let mut f = FastSlam2::new(p, motion, Proposal::Observations, Pose2::new(0.2, -0.1, 0.4));
    let l = Landmark {
        id: Some(0),
        ..Landmark::new(Vector2::new(3.0, 2.5), Matrix2::new(4e-4, 1e-4, 1e-4, 2e-4))
    };
    f.particles[0].map_mut().push(Model::Point, l);
    (f, l)
}

#[test]
fn one_step_weights_at_the_prediction_and_updates_from_the_sample() {
    let motion = MotionModel::Pose { sigma_x_m: 0.05, sigma_y_m: 0.03, sigma_theta_rad: 0.02 };
    let u = Pose2::new(0.3, 0.02, 0.05);
    let r = Matrix2::new(1e-3, 0.0, 0.0, 1e-4);
    let truth = Pose2::new(0.48, 0.1, 0.47); // off the prediction
    let seen = |id: usize, m: Vector2<f64>| Observation {
        model: Model::Point,
        z: Model::Point.predict(&m, &truth).z,
        r,
        landmark: Some(id),
    };
    for association in [DataAssociation::Known, DataAssociation::MaximumLikelihood] {
        let p = params(1, association);
        let (mut f, l) = one_particle(&p, &motion);
        let z = [seen(0, l.mean), seen(1, Vector2::new(-2.0, 4.0))];
        let previous = f.particles[0].pose;
        f.advance(0, Some(&u), &z, &mut ChaCha8Rng::seed_from_u64(1));
        assert_eq!(f.numerical_failures, 0);

        // Eq. (8) written out: N(z; ẑ(x̂), H_x Q H_xᵀ + H_m Σ H_mᵀ + R) for the known landmark,
        // P0 for the new one
        let predicted = previous.compose(u);
        let q = motion.covariance(&previous, &u);
        let full = Model::Point.predict_full(&l.mean, &predicted);
        let s = full.h_pose * q * full.h_pose.transpose()
            + full.h_landmark * l.cov * full.h_landmark.transpose()
            + r;
        let nu = Model::Point.innovation(&z[0].z, &full.z);
        let expected = -0.5 * (nu.transpose() * s.try_inverse().unwrap() * nu)[0]
            - 0.5 * (TAU * TAU * s.determinant()).ln()
            + p.p0.ln();
        assert!(
            (f.particles[0].log_weight - expected).abs() < 1e-9,
            "{association:?}: log weight {} vs {expected}",
            f.particles[0].log_weight
        );

        // Eq. (7) from the sampled pose, not from the prediction
        let x = f.particles[0].pose;
        assert!(
            x.position().distance(predicted.position()) > 1e-3,
            "the sample moved off the prediction"
        );
        let h = Model::Point.predict(&l.mean, &x);
        let k =
            l.cov * h.h.transpose() * (h.h * l.cov * h.h.transpose() + r).try_inverse().unwrap();
        let mean = l.mean + k * Model::Point.innovation(&z[0].z, &h.z);
        let map = f.particles[0].map.corners();
        assert_eq!(map.len(), 2);
        assert!((map[0].mean - mean).norm() < 1e-12, "{association:?}: {} vs {mean}", map[0].mean);
        let cov = (Matrix2::identity() - k * h.h) * l.cov; // the standard form, equal to Joseph's
        assert!(
            (map[0].cov - cov).abs().max() < 1e-12 * l.cov.abs().max(),
            "{association:?}: {} vs {cov}",
            map[0].cov
        );
        assert!((map[1].mean - Model::Point.inverse(&z[1].z, &x)).norm() < 1e-12);
    }
}

#[test]
fn poses_are_drawn_from_the_proposal() {
    // The sampled poses' mean and covariance are those of N(μ, Σx) from Eqs. (4)–(5).
    let motion = MotionModel::Pose { sigma_x_m: 0.05, sigma_y_m: 0.03, sigma_theta_rad: 0.02 };
    let u = Pose2::new(0.3, 0.02, 0.05);
    let p = params(1, DataAssociation::Known);
    let (f, l) = one_particle(&p, &motion);
    let o = Observation {
        model: Model::Point,
        z: Model::Point.predict(&l.mean, &Pose2::new(0.48, 0.1, 0.47)).z,
        r: Matrix2::new(1e-3, 0.0, 0.0, 1e-4),
        landmark: Some(0),
    };
    let previous = f.particles[0].pose;
    let (mut mu, mut sigma) = (previous.compose(u), motion.covariance(&previous, &u));
    assert!(refine(&mut mu, &mut sigma, &o, &l).is_some());
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let n = 20_000;
    let d: Vec<Vector3<f64>> = (0..n)
        .map(|_| {
            let mut g =
                FastSlam2 { particles: f.particles.clone(), weights: f.weights.clone(), ..f };
            g.advance(0, Some(&u), std::slice::from_ref(&o), &mut rng);
            let x = g.particles[0].pose;
            Vector3::new(x.x - mu.x, x.y - mu.y, wrap_angle(x.theta - mu.theta))
        })
        .collect();
    let mean = d.iter().sum::<Vector3<f64>>() / n as f64;
    let cov = d.iter().map(|e| (e - mean) * (e - mean).transpose()).sum::<Matrix3<f64>>()
        / (n - 1) as f64;
    let sd = sigma.diagonal().map(f64::sqrt);
    assert!((0..3).all(|i| mean[i].abs() < 0.03 * sd[i]), "mean offset {mean} vs σ {sd}");
    assert!(
        (cov - sigma).abs().max() < 0.05 * sigma.abs().max(),
        "sample covariance\n{cov}\nproposal\n{sigma}"
    );
    // Σx differs from Q far beyond the 5 % tolerance: sampling from Q would fail
    assert!(
        sigma.trace() < 0.75 * motion.covariance(&previous, &u).trace(),
        "the observation matters here"
    );
}

#[test]
fn the_association_bound_never_underestimates_the_likelihood() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut u = |a: f64, b: f64| rng.random_range(a..b);
    let mut tight = 0;
    for _ in 0..4000 {
        let pose = Pose2::new(u(-5.0, 5.0), u(-5.0, 5.0), u(-3.1, 3.1));
        let a = Matrix3::new(
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
            u(-0.1, 0.1),
        );
        let q = a * a.transpose();
        let b = Matrix2::new(u(-0.1, 0.1), u(-0.1, 0.1), u(-0.1, 0.1), u(-0.1, 0.1));
        let r = Matrix2::new(u(1e-4, 0.05), 0.0, 0.0, u(1e-5, 0.01));
        for model in [Model::Point, Model::Line] {
            let (m, z) = match model {
                Model::Point => (
                    Vector2::new(u(-10.0, 10.0), u(-10.0, 10.0)),
                    Vector2::new(u(0.1, 15.0), u(-3.1, 3.1)),
                ),
                Model::Line => (
                    Vector2::new(u(0.5, 20.0), u(-3.1, 3.1)),
                    Vector2::new(u(0.0, 10.0), u(-3.1, 3.1)),
                ),
            };
            let l = Landmark::new(m, b * b.transpose());
            let o = Observation { model, z, r, landmark: None };
            let exact = evaluate(&o, &l, &pose, &q).unwrap().log_likelihood;
            let bound = log_likelihood_bound(&o, &l, &pose, &q, r.determinant().ln());
            assert!(
                bound.is_finite() && bound >= exact - 1e-9,
                "{model:?}: bound {bound} < {exact}"
            );
            tight += (bound < exact + 1.0) as usize;
        }
    }
    assert!(tight > 20, "the bound should sometimes be close: {tight}");
}

/// With two matched observations in one step the importance weight is their *joint* predictive
/// density N(z; ẑ(x̂), H_x Q H_xᵀ + blockdiag(Z₁, Z₂)) (Montemerlo 2003; Probabilistic Robotics
/// Table 13.3): the pose error is shared, so the product of the two marginals, each carrying the
/// whole H_x Q H_xᵀ, counts it twice. The chain-rule factors of the proposal give the joint up to
/// the relinearisation at μ₁ (a few hundredths here).
#[test]
fn two_matched_observations_weigh_by_their_joint_density() {
    // precise sensing against a loose motion model: the regime FastSLAM 2.0 is for
    let motion = MotionModel::Pose { sigma_x_m: 0.08, sigma_y_m: 0.08, sigma_theta_rad: 0.03 };
    let u = Pose2::new(0.3, 0.02, 0.05);
    let r = Matrix2::new(1e-4, 0.0, 0.0, 1e-5);
    let truth = Pose2::new(0.55, 0.12, 0.47);
    let p = params(1, DataAssociation::Known);
    let (mut f, l1) = one_particle(&p, &motion);
    let l2 = Landmark {
        id: Some(2),
        ..Landmark::new(Vector2::new(-1.5, 3.0), Matrix2::new(3e-5, 0.0, 0.0, 3e-5))
    };
    f.particles[0].map_mut().push(Model::Point, l2);
    let seen = |l: &Landmark| Observation {
        model: Model::Point,
        z: Model::Point.predict(&l.mean, &truth).z,
        r,
        landmark: l.id,
    };
    let z = [seen(&l1), seen(&l2)];
    let previous = f.particles[0].pose;
    f.advance(0, Some(&u), &z, &mut ChaCha8Rng::seed_from_u64(1));
    assert_eq!(f.numerical_failures, 0);

    let predicted = previous.compose(u);
    let q = motion.covariance(&previous, &u);
    let (a, b) = (
        Model::Point.predict_full(&l1.mean, &predicted),
        Model::Point.predict_full(&l2.mean, &predicted),
    );
    let mut hx = nalgebra::Matrix4x3::zeros();
    hx.fixed_view_mut::<2, 3>(0, 0).copy_from(&a.h_pose);
    hx.fixed_view_mut::<2, 3>(2, 0).copy_from(&b.h_pose);
    let mut s = hx * q * hx.transpose();
    let (z1, z2) = (
        a.h_landmark * l1.cov * a.h_landmark.transpose() + r,
        b.h_landmark * l2.cov * b.h_landmark.transpose() + r,
    );
    for i in 0..2 {
        for j in 0..2 {
            s[(i, j)] += z1[(i, j)];
            s[(2 + i, 2 + j)] += z2[(i, j)];
        }
    }
    let (n1, n2) = (Model::Point.innovation(&z[0].z, &a.z), Model::Point.innovation(&z[1].z, &b.z));
    let nu = nalgebra::Vector4::new(n1[0], n1[1], n2[0], n2[1]);
    let joint = -0.5 * (nu.transpose() * s.try_inverse().unwrap() * nu)[0]
        - 0.5 * (TAU.powi(4) * s.determinant()).ln();
    let marginals: f64 = [(&l1, &z[0]), (&l2, &z[1])]
        .iter()
        .map(|(l, o)| evaluate(o, l, &predicted, &q).unwrap().log_likelihood)
        .sum();
    assert!(
        (marginals - joint).abs() > 1.0,
        "the test must tell the two apart: marginals {marginals}, joint {joint}"
    );
    let w = f.particles[0].log_weight;
    assert!(
        (w - joint).abs() < 0.05 * joint.abs().max(1.0),
        "log weight {w}, joint density {joint}, product of marginals {marginals}"
    );
}

/// ln of the joint density of two readings `z` of landmark `l` (shared pose error H_x Q H_xᵀ and
/// shared landmark error H_m P H_mᵀ, each reading's own R), linearised at `predicted`.
fn read_twice_joint(
    l: &Landmark,
    predicted: &Pose2,
    q: &Matrix3<f64>,
    r: Matrix2<f64>,
    z: [&Observation; 2],
) -> f64 {
    let a = Model::Point.predict_full(&l.mean, predicted);
    let mut hx = nalgebra::Matrix4x3::zeros();
    let mut hm = nalgebra::Matrix4x2::zeros();
    for k in 0..2 {
        hx.fixed_view_mut::<2, 3>(2 * k, 0).copy_from(&a.h_pose);
        hm.fixed_view_mut::<2, 2>(2 * k, 0).copy_from(&a.h_landmark);
    }
    let mut s = hx * q * hx.transpose() + hm * l.cov * hm.transpose();
    for k in 0..2 {
        let mut block = s.fixed_view_mut::<2, 2>(2 * k, 2 * k);
        block += r;
    }
    let (n1, n2) = (Model::Point.innovation(&z[0].z, &a.z), Model::Point.innovation(&z[1].z, &a.z));
    let nu = nalgebra::Vector4::new(n1[0], n1[1], n2[0], n2[1]);
    -0.5 * (nu.transpose() * s.try_inverse().unwrap() * nu)[0]
        - 0.5 * (TAU.powi(4) * s.determinant()).ln()
}

/// One landmark read twice in a step (known association): its readings share the landmark's
/// error as well as the pose's, so the joint density has the cross term H_m P H_mᵀ between them.
/// The filter reads them fused (`Cursor`), and its weight is that joint density up to the factor
/// N(z₂ − z₁; 0, 2R), the same for every particle. Weighing the two readings against the same
/// unchanged landmark, as the proposal would, misses the cross term.
#[test]
fn one_landmark_read_twice_weighs_by_the_joint_density() {
    let motion = MotionModel::Pose { sigma_x_m: 0.08, sigma_y_m: 0.08, sigma_theta_rad: 0.03 };
    let u = Pose2::new(0.3, 0.02, 0.05);
    let r = Matrix2::new(1e-4, 0.0, 0.0, 1e-5);
    let truth = Pose2::new(0.55, 0.12, 0.47);
    let p = params(1, DataAssociation::Known);
    let (mut f, l) = one_particle(&p, &motion);
    let loose = Landmark { cov: Matrix2::new(0.04, 0.0, 0.0, 0.04), ..l }; // an uncertain landmark
    f.particles[0].map_mut().of_mut(Model::Point)[0] = loose;
    let reading = |dz: f64| Observation {
        model: Model::Point,
        z: Model::Point.predict(&loose.mean, &truth).z + Vector2::new(dz, -dz / 10.0),
        r,
        landmark: loose.id,
    };
    let (z1, z2) = (reading(0.004), reading(-0.003));
    let stream = [StepObservations { step: 1, observations: vec![z1, z2] }];
    let mut cursor = Cursor::new(&stream, true);
    let fused = cursor.at(1).to_vec();
    assert_eq!(fused.len(), 1);
    let previous = f.particles[0].pose;
    f.advance(0, Some(&u), &fused, &mut ChaCha8Rng::seed_from_u64(1));
    assert_eq!(f.numerical_failures, 0);

    let predicted = previous.compose(u);
    let q = motion.covariance(&previous, &u);
    let joint = read_twice_joint(&loose, &predicted, &q, r, [&z1, &z2]);
    let d = Model::Point.innovation(&z2.z, &z1.z);
    let common = -0.5 * (d.transpose() * (2.0 * r).try_inverse().unwrap() * d)[0]
        - 0.5 * (TAU.powi(2) * (2.0 * r).determinant()).ln();
    let unchanged: f64 = [&z1, &z2]
        .iter()
        .map(|o| evaluate(o, &loose, &predicted, &q).unwrap().log_likelihood)
        .sum();
    assert!(
        (unchanged - joint).abs() > 1.0,
        "the test must tell the two apart: {unchanged} vs {joint}"
    );
    let w = f.particles[0].log_weight + common;
    assert!(
        (w - joint).abs() < 0.05 * joint.abs().max(1.0),
        "log weight + common factor {w}, joint density {joint}"
    );
    assert_eq!(f.particles[0].map.corners().len(), 1);
}

/// Two features of one scan that maximum-likelihood association sends to the same landmark
/// (`ambiguity = "none"`: nothing stops it). Their joint density has the landmark's error shared
/// between them (the cross term H_m P H_mᵀ); the proposal folds the second reading against the
/// landmark as the first corrected it, so the chain-rule factors give that joint density. Folding
/// both against the unchanged landmark, as it once did, counts the landmark's uncertainty twice.
#[test]
fn two_features_on_one_landmark_fold_into_the_proposal_once_each() {
    let motion = MotionModel::Pose { sigma_x_m: 0.08, sigma_y_m: 0.08, sigma_theta_rad: 0.03 };
    let u = Pose2::new(0.3, 0.02, 0.05);
    let r = Matrix2::new(1e-4, 0.0, 0.0, 1e-5);
    let truth = Pose2::new(0.55, 0.12, 0.47);
    let p = FastSlamParams {
        ambiguity: crate::slam::fastslam::association::Ambiguity::None,
        p0: 1e-30,
        ..params(1, DataAssociation::MaximumLikelihood)
    };
    let (mut f, l) = one_particle(&p, &motion);
    let loose = Landmark { cov: Matrix2::new(0.04, 0.0, 0.0, 0.04), id: None, ..l };
    f.particles[0].map_mut().of_mut(Model::Point)[0] = loose;
    let reading = |dz: f64| Observation {
        model: Model::Point,
        z: Model::Point.predict(&loose.mean, &truth).z + Vector2::new(dz, -dz / 10.0),
        r,
        landmark: None,
    };
    let (z1, z2) = (reading(0.004), reading(-0.003));
    let previous = f.particles[0].pose;
    f.advance(0, Some(&u), &[z1, z2], &mut ChaCha8Rng::seed_from_u64(1));
    assert_eq!(f.numerical_failures, 0);
    assert_eq!(f.particles[0].map.corners().len(), 1, "both readings went to the one landmark");

    let predicted = previous.compose(u);
    let q = motion.covariance(&previous, &u);
    let joint = read_twice_joint(&loose, &predicted, &q, r, [&z1, &z2]);
    // both folded against the unchanged landmark: the chain factors without the cross term
    let (mut mu, mut sigma) = (predicted, q);
    let stale: f64 =
        [&z1, &z2].iter().map(|o| refine(&mut mu, &mut sigma, o, &loose).unwrap()).sum();
    assert!((stale - joint).abs() > 1.0, "the test must tell the two apart: {stale} vs {joint}");
    let w = f.particles[0].log_weight;
    assert!(
        (w - joint).abs() < 0.05 * joint.abs().max(1.0),
        "log weight {w}, joint density {joint}, both against the unchanged landmark {stale}"
    );
}
