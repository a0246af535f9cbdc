//! Tests of EKF-SLAM on small hand-built worlds: exact recovery without noise, NEES consistency
//! (and that the check catches an over-confident filter), P symmetric PSD, the two gates,
//! nearest neighbour vs maximum likelihood, the faithful no-update option, line flips,
//! validation, and the report's sentence.

use super::*;
use crate::geom::Point2;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use statrs::distribution::{ChiSquared, ContinuousCDF};
use std::f64::consts::TAU;

/// Steps of one lap of the test circle.
const LAP_STEPS: usize = 120;
/// Distance driven per step [m].
const STEP_M: f64 = 0.2;
/// Range of the simulated point sensor [m].
const MAX_RANGE_M: f64 = 3.0;

/// The per-step increment of the circle (counter-clockwise).
fn circle_increment() -> Pose2 {
    Pose2::new(STEP_M, 0.0, TAU / LAP_STEPS as f64)
}

/// Radius of the circle the increments drive [m] (chord ≈ arc).
fn circle_radius() -> f64 {
    STEP_M / (TAU / LAP_STEPS as f64)
}

/// `n` landmarks alternating inside and outside the circle, `offset` metres from it.
fn ring_landmarks(n: usize, offset: f64) -> Vec<Point2> {
    let r = circle_radius();
    (0..n)
        .map(|i| {
            let a = TAU * (i as f64 + 0.5) / n as f64;
            let radius = if i % 2 == 0 { r + offset } else { r - offset };
            Point2::new(radius * a.sin(), r - radius * a.cos()) // the circle is centred at (0, r)
        })
        .collect()
}

/// A world with the given truth and odometry and no sensor data (observations are made here).
fn world(truth: Vec<Pose2>, odometry: Vec<Pose2>) -> World {
    World::from_odometry(truth, odometry)
}

/// Truth from composing the odometry exactly (noise-free world).
fn exact_truth(start: Pose2, odometry: &[Pose2]) -> Vec<Pose2> {
    let mut truth = vec![start];
    for u in odometry {
        truth.push(truth.last().unwrap().compose(*u));
    }
    truth
}

fn r_matrix(sigma_range_m: f64, sigma_bearing_rad: f64) -> Matrix2<f64> {
    Matrix2::new(sigma_range_m.powi(2), 0.0, 0.0, sigma_bearing_rad.powi(2))
}

/// z = h(m, pose) + v, v ~ N(0, R) (R diagonal) when `rng` is given.
fn measure(
    model: Model,
    m: &Vector2<f64>,
    pose: &Pose2,
    r: &Matrix2<f64>,
    id: usize,
    rng: Option<&mut ChaCha8Rng>,
) -> Observation {
    let mut z = model.predict(m, pose).z;
    if let Some(rng) = rng {
        let (a, b): (f64, f64) = (rng.sample(StandardNormal), rng.sample(StandardNormal));
        z += Vector2::new(r[(0, 0)].sqrt() * a, r[(1, 1)].sqrt() * b);
        z[1] = wrap_angle(z[1]);
    }
    Observation { model, z, r: *r, landmark: Some(id) }
}

/// Range-bearing readings of every point within `MAX_RANGE_M` at every step.
fn point_readings(
    truth: &[Pose2],
    points: &[Point2],
    r: &Matrix2<f64>,
    mut rng: Option<&mut ChaCha8Rng>,
) -> Vec<StepObservations> {
    truth
        .iter()
        .enumerate()
        .map(|(step, pose)| StepObservations {
            step,
            observations: points
                .iter()
                .enumerate()
                .filter(|(_, p)| pose.position().distance(**p) < MAX_RANGE_M)
                .map(|(id, p)| {
                    measure(Model::Point, &Vector2::new(p.x, p.y), pose, r, id, rng.as_deref_mut())
                })
                .collect(),
        })
        .collect()
}

fn params(association: EkfAssociation) -> EkfParams {
    EkfParams { association, ..EkfParams::default() }
}

fn pose_error(est: &Pose2, truth: &Pose2) -> Vector3<f64> {
    Vector3::new(est.x - truth.x, est.y - truth.y, wrap_angle(est.theta - truth.theta))
}

#[test]
fn noise_free_point_world_is_recovered_exactly() {
    let odometry = vec![circle_increment(); LAP_STEPS + LAP_STEPS / 2]; // 1.5 laps: closes the loop
    let truth = exact_truth(Pose2::IDENTITY, &odometry);
    let points = ring_landmarks(12, 1.2);
    let w = world(truth.clone(), odometry);
    let motion = MotionModel::Pose { sigma_x_m: 1e-3, sigma_y_m: 1e-3, sigma_theta_rad: 1e-3 };
    let readings = point_readings(&truth, &points, &r_matrix(1e-2, 1e-3), None);
    for association in
        [EkfAssociation::Known, EkfAssociation::NearestNeighbour, EkfAssociation::MaximumLikelihood]
    {
        let trace = run(&w, &motion, &params(association), &readings, false).unwrap();
        assert_eq!(trace.estimate.len(), truth.len());
        assert_eq!(trace.pose_belief.len(), truth.len());
        assert!(trace.pose_belief.iter().all(Option::is_some) && trace.neff.is_empty());
        assert_eq!(trace.numerical_failures, 0, "{association:?}");
        assert_eq!(
            trace.weighted_steps as usize,
            truth.len() - 1,
            "{association:?}: every step after the first re-observes"
        );
        for (k, (e, t)) in trace.estimate.iter().zip(&truth).enumerate() {
            assert!(pose_error(e, t).norm() < 1e-6, "{association:?} step {k}: {e:?} vs {t:?}");
        }
        let map = trace.map.unwrap();
        assert!(map.corners.is_empty() && map.lines.is_empty());
        assert_eq!(
            map.points.len(),
            points.len(),
            "{association:?}: one landmark per true point, no duplicates"
        );
        for (i, p) in map.points.iter().enumerate() {
            let (j, d) = points
                .iter()
                .enumerate()
                .map(|(j, t)| (j, t.distance(*p)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            assert!(
                d < 1e-6,
                "{association:?}: landmark {p:?} is {d} m from the nearest true point"
            );
            let expected_id = (association == EkfAssociation::Known).then_some(j);
            assert_eq!(map.point_ids[i], expected_id);
        }
    }
}

#[test]
fn noise_free_lines_and_corners_are_recovered_exactly() {
    // a 10 m × 8 m room centred on the circle: the robot stays inside, so every ρ' > 0
    let (cx, cy, hx, hy) = (0.0, circle_radius(), 5.0, 4.0);
    let lines = [
        Line::normalised(cx + hx, 0.0),
        Line::normalised(-(cx - hx), PI),
        Line::normalised(cy + hy, PI / 2.0),
        Line::normalised(-(cy - hy), -PI / 2.0),
    ];
    let corners: Vec<Point2> = [(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
        .iter()
        .map(|(sx, sy)| Point2::new(cx + sx * hx, cy + sy * hy))
        .collect();
    let odometry = vec![circle_increment(); LAP_STEPS];
    let truth = exact_truth(Pose2::new(0.0, 0.0, 0.0), &odometry);
    let w = world(truth.clone(), odometry);
    let r = r_matrix(1e-2, 1e-3);
    let readings: Vec<StepObservations> = truth
        .iter()
        .enumerate()
        .map(|(step, pose)| {
            let l = lines
                .iter()
                .map(|l| measure(Model::Line, &Vector2::new(l.rho, l.theta), pose, &r, 0, None));
            let c = corners
                .iter()
                .filter(|c| pose.position().distance(**c) < 2.0 * MAX_RANGE_M)
                .map(|c| measure(Model::Point, &Vector2::new(c.x, c.y), pose, &r, 0, None));
            StepObservations {
                step,
                observations: l.chain(c).map(|o| Observation { landmark: None, ..o }).collect(),
            }
        })
        .collect();
    let motion = MotionModel::Pose { sigma_x_m: 1e-3, sigma_y_m: 1e-3, sigma_theta_rad: 1e-3 };
    let trace =
        run(&w, &motion, &params(EkfAssociation::NearestNeighbour), &readings, true).unwrap();
    assert_eq!(trace.numerical_failures, 0);
    for (k, (e, t)) in trace.estimate.iter().zip(&truth).enumerate() {
        assert!(pose_error(e, t).norm() < 1e-6, "step {k}: {e:?} vs {t:?}");
    }
    let map = trace.map.unwrap();
    assert!(map.points.is_empty() && map.point_ids.is_empty());
    assert_eq!(map.lines.len(), lines.len());
    assert_eq!(map.corners.len(), corners.len());
    for t in &lines {
        assert!(map.lines.iter().any(|l| (l.rho - t.rho).abs() < 1e-6 && wrap_angle(l.theta - t.theta).abs() < 1e-6), "{t:?} not in {:?}", map.lines);
    }
    for t in &corners {
        assert!(
            map.corners.iter().any(|c| c.distance(*t) < 1e-6),
            "{t:?} not in {:?}",
            map.corners
        );
    }
}

/// The noise of the consistency worlds, told to the filter exactly.
const SIGMA_XY_M: f64 = 0.02;
const SIGMA_THETA_RAD: f64 = 0.005;
const SIGMA_RANGE_M: f64 = 0.05;
const SIGMA_BEARING_RAD: f64 = 0.02;
/// Monte-Carlo runs of the NEES test.
const NEES_RUNS: usize = 30;
/// Steps of each NEES run: 4 laps, re-observing every landmark (loop closures). Long enough that
/// the per-step means are many nearly independent stretches (over 1.5 laps the fraction inside
/// varied from 89 % to 98 % between seed sets). With this noise the filter stays consistent
/// over the 4 laps (4 disjoint seed sets: 95–99 % of steps inside, time averages 2.7–3.1);
/// with 8× the heading noise EKF-SLAM's known over-confidence from heading linearisation
/// (Bailey et al. 2006) shows (one seed set: time-averaged NEES 14), so the claim is made for
/// this noise level only.
const NEES_STEPS: usize = 4 * LAP_STEPS;

/// Per-step pose NEES of `filter_motion` on worlds whose truth follows `world_motion` exactly
/// (x' = x ⊕ u + ε, ε ~ N(0, Q)) and whose readings have noise R. Returns NEES[run][step]
/// for steps 1..=NEES_STEPS (step 0: P_rr = 0, the start pose is known).
fn nees_runs(world_motion: &MotionModel, filter_motion: &MotionModel) -> Vec<Vec<f64>> {
    let points = ring_landmarks(20, 1.5);
    let r = r_matrix(SIGMA_RANGE_M, SIGMA_BEARING_RAD);
    let u = circle_increment();
    (0..NEES_RUNS as u64)
        .map(|seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut truth = vec![Pose2::IDENTITY];
            for _ in 0..NEES_STEPS {
                let next = world_motion.sample(truth.last().unwrap(), &u, &mut rng);
                truth.push(next);
            }
            let readings = point_readings(&truth, &points, &r, Some(&mut rng));
            let w = world(truth.clone(), vec![u; NEES_STEPS]);
            let trace =
                run(&w, filter_motion, &params(EkfAssociation::Known), &readings, false).unwrap();
            assert_eq!(trace.numerical_failures, 0);
            (1..=NEES_STEPS)
                .map(|k| {
                    let e = pose_error(&trace.estimate[k], &truth[k]);
                    let p_inv = trace.pose_belief[k]
                        .unwrap()
                        .1
                        .try_inverse()
                        .expect("P_rr > 0 after a prediction");
                    (e.transpose() * p_inv * e)[0]
                })
                .collect()
        })
        .collect()
}

/// 95 % bounds of the mean of `NEES_RUNS` χ²(3) values: χ²_{3N}(0.025)/N, χ²_{3N}(0.975)/N.
fn nees_bounds() -> (f64, f64) {
    let chi2 = ChiSquared::new((3 * NEES_RUNS) as f64).unwrap();
    (chi2.inverse_cdf(0.025) / NEES_RUNS as f64, chi2.inverse_cdf(0.975) / NEES_RUNS as f64)
}

/// (fraction of steps whose run-averaged NEES lies within the bounds, time-averaged NEES).
fn nees_summary(nees: &[Vec<f64>]) -> (f64, f64) {
    let (lo, hi) = nees_bounds();
    let mean_per_step: Vec<f64> = (0..NEES_STEPS)
        .map(|k| nees.iter().map(|run| run[k]).sum::<f64>() / NEES_RUNS as f64)
        .collect();
    let inside =
        mean_per_step.iter().filter(|m| (lo..=hi).contains(*m)).count() as f64 / NEES_STEPS as f64;
    (inside, mean_per_step.iter().sum::<f64>() / NEES_STEPS as f64)
}

fn pose_noise(scale: f64) -> MotionModel {
    MotionModel::Pose {
        sigma_x_m: scale * SIGMA_XY_M,
        sigma_y_m: scale * SIGMA_XY_M,
        sigma_theta_rad: scale * SIGMA_THETA_RAD,
    }
}

#[test]
fn pose_nees_is_consistent_when_the_noise_is_modelled_exactly() {
    let (lo, hi) = nees_bounds();
    let (inside, average) = nees_summary(&nees_runs(&pose_noise(1.0), &pose_noise(1.0)));
    assert!(
        inside >= 0.9,
        "only {:.0} % of steps have their mean NEES in [{lo:.2}, {hi:.2}]",
        100.0 * inside
    );
    // the time average of correlated per-step means: held to the same per-step bounds
    assert!(
        (lo..=hi).contains(&average),
        "time-averaged NEES {average:.2} outside [{lo:.2}, {hi:.2}]"
    );
}

#[test]
fn the_nees_check_catches_a_filter_that_understates_its_motion_noise() {
    // same worlds, filter told σ/3: the check above must fail, or it could not fail at all
    let (_, hi) = nees_bounds();
    let (inside, average) = nees_summary(&nees_runs(&pose_noise(1.0), &pose_noise(1.0 / 3.0)));
    assert!(inside < 0.5 && average > hi, "{:.0} % inside, average {average:.2}", 100.0 * inside);
}

#[test]
fn covariance_stays_symmetric_psd_through_a_noisy_run() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let points = ring_landmarks(36, 1.0);
    let motion = pose_noise(1.0);
    let u = circle_increment();
    let r = r_matrix(SIGMA_RANGE_M, SIGMA_BEARING_RAD);
    let p = params(EkfAssociation::NearestNeighbour);
    let mut ekf = Ekf::new(&p, &motion, Pose2::IDENTITY);
    let mut truth = Pose2::IDENTITY;
    let mut min_eigenvalue = f64::INFINITY;
    for k in 0..=LAP_STEPS {
        if k > 0 {
            truth = motion.sample(&truth, &u, &mut rng);
        }
        let z = point_readings(&[truth], &points, &r, Some(&mut rng)).remove(0).observations;
        // prediction and correction checked apart (the update's symmetrisation would hide a
        // prediction that forgets P_mr)
        for (phase, control, readings) in
            [("predict", (k > 0).then_some(&u), &[][..]), ("update", None, &z[..])]
        {
            ekf.step(control, readings);
            let cov = ekf.covariance();
            assert!(
                (cov - cov.transpose()).abs().max() == 0.0,
                "step {k} {phase}: P not symmetric"
            );
            min_eigenvalue = min_eigenvalue.min(cov.clone().symmetric_eigenvalues().min());
            assert!(min_eigenvalue >= -1e-9, "step {k} {phase}: eigenvalue {min_eigenvalue}");
        }
    }
    assert!(ekf.landmarks().len() >= 30, "only {} landmarks were added", ekf.landmarks().len());
    assert_eq!(ekf.numerical_failures, 0);
}

#[test]
fn sparse_prediction_and_update_equal_the_dense_textbook_equations() {
    // a filter with correlated point and line landmarks, then one prediction and one update
    // done both ways: F = diag(F_r, I), P = F P Fᵀ + diag(Q, 0); full 2 × n H, Joseph form
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let (p, motion) = (params(EkfAssociation::Known), pose_noise(1.0));
    let r = r_matrix(SIGMA_RANGE_M, SIGMA_BEARING_RAD);
    let (u, truth) = (circle_increment(), Pose2::new(0.5, -0.2, 0.4));
    let marks: Vec<(Model, Vector2<f64>)> = vec![
        (Model::Point, Vector2::new(2.0, 1.0)),
        (Model::Line, Vector2::new(3.0, 0.2)),
        (Model::Point, Vector2::new(-1.0, 2.5)),
        (Model::Line, Vector2::new(4.0, 1.9)),
    ];
    let read = |pose: &Pose2, rng: &mut ChaCha8Rng| -> Vec<Observation> {
        marks
            .iter()
            .enumerate()
            .map(|(id, (model, m))| measure(*model, m, pose, &r, id, Some(&mut *rng)))
            .collect()
    };
    let mut ekf = Ekf::new(&p, &motion, truth);
    let z0 = read(&truth, &mut rng);
    ekf.step(None, &z0);
    ekf.step(Some(&u), &[]);
    let z1 = read(&truth.compose(u), &mut rng);
    ekf.step(None, &z1[..2]); // correlate everything
    let (x, cov) = (ekf.mean().clone(), ekf.covariance().clone());
    let n = x.len();

    ekf.step(Some(&u), &[]);
    let pose = Pose2::new(x[0], x[1], x[2]);
    let mut f = DMatrix::<f64>::identity(n, n);
    f.view_mut((0, 0), (3, 3)).copy_from(&motion.jacobian(&pose, &u));
    let mut q = DMatrix::<f64>::zeros(n, n);
    q.view_mut((0, 0), (3, 3)).copy_from(&motion.covariance(&pose, &u));
    let predicted = &f * &cov * f.transpose() + q;
    assert!((ekf.covariance() - &predicted).abs().max() < 1e-12, "prediction");

    let z2 = read(&truth.compose(u).compose(u), &mut rng);
    for (j, o) in z2.iter().enumerate() {
        let (x, cov) = (ekf.mean().clone(), ekf.covariance().clone());
        let pose = Pose2::new(x[0], x[1], x[2]);
        let i = ekf.landmarks()[j].index;
        let pred = o.model.predict_full(&Vector2::new(x[i], x[i + 1]), &pose);
        let mut h = DMatrix::<f64>::zeros(2, n);
        h.view_mut((0, 0), (2, 3)).copy_from(&pred.h_pose);
        h.view_mut((0, i), (2, 2)).copy_from(&pred.h_landmark);
        let s = &h * &cov * h.transpose() + o.r;
        let k = &cov * h.transpose() * s.try_inverse().unwrap();
        let mut x_dense = &x + &k * o.model.innovation(&o.z, &pred.z);
        x_dense[2] = wrap_angle(x_dense[2]);
        let i_kh = DMatrix::<f64>::identity(n, n) - &k * &h;
        let p_dense = &i_kh * &cov * i_kh.transpose() + &k * o.r * k.transpose();
        ekf.step(None, std::slice::from_ref(o));
        assert!((ekf.mean() - x_dense).abs().max() < 1e-12, "update {j}: mean");
        assert!((ekf.covariance() - p_dense).abs().max() < 1e-12, "update {j}: covariance");
    }
}

/// A filter at the origin (known pose, P_rr = 0) with one point landmark 5 m ahead, seen once
/// with noise R; a second reading with the same R then has S = H P Hᵀ + R = 2R.
fn one_landmark<'a>(p: &'a EkfParams, motion: &'a MotionModel, r: &Matrix2<f64>) -> Ekf<'a> {
    let mut ekf = Ekf::new(p, motion, Pose2::IDENTITY);
    ekf.step(
        None,
        &[Observation { model: Model::Point, z: Vector2::new(5.0, 0.0), r: *r, landmark: None }],
    );
    ekf
}

#[test]
fn an_observation_updates_is_ignored_or_creates_a_landmark_according_to_the_gates() {
    let p = EkfParams::default(); // gates 4 and 25
    let motion = pose_noise(1.0);
    let r = r_matrix(0.1, 0.01);
    for (nis, expected) in [(1.0, "update"), (10.0, "ignored"), (36.0, "new")] {
        let mut ekf = one_landmark(&p, &motion, &r);
        let (x0, p0) = (ekf.mean().clone(), ekf.covariance().clone());
        // range offset δ with δ² / (2σr²) = NIS
        let delta = (2.0 * r[(0, 0)] * nis).sqrt();
        ekf.step(
            None,
            &[Observation {
                model: Model::Point,
                z: Vector2::new(5.0 + delta, 0.0),
                r,
                landmark: None,
            }],
        );
        let got =
            match (ekf.landmarks().len(), ekf.mean().rows(0, x0.len()) == x0.rows(0, x0.len())) {
                (1, false) => "update",
                (1, true) if *ekf.covariance() == p0 => "ignored",
                (2, true) => "new",
                _ => "something else",
            };
        assert_eq!(got, expected, "NIS {nis}");
        assert_eq!(ekf.weighted_steps, (expected == "update") as u64);
    }
}

#[test]
fn maximum_likelihood_prefers_the_tighter_landmark_where_nearest_neighbour_does_not() {
    // A: initialised with 100 R (S_A = 101 R), its prediction exactly the reading (NIS 0);
    // B: initialised with R (S_B = 2 R), NIS 3. ln det S_A − ln det S_B = ln(101²/4) ≈ 7.8 > 3.
    let motion = pose_noise(1.0);
    let r = r_matrix(0.1, 0.01);
    let delta = (2.0 * r[(0, 0)] * 3.0).sqrt();
    let reading =
        Observation { model: Model::Point, z: Vector2::new(5.0 + delta, 0.0), r, landmark: None };
    for (association, expected) in
        [(EkfAssociation::NearestNeighbour, 0), (EkfAssociation::MaximumLikelihood, 1)]
    {
        let p = params(association);
        let mut ekf = Ekf::new(&p, &motion, Pose2::IDENTITY);
        ekf.step(
            None,
            &[
                Observation { r: r * 100.0, ..reading },
                Observation { z: Vector2::new(5.0, 0.0), ..reading },
            ],
        );
        assert_eq!(ekf.landmarks().len(), 2);
        assert_eq!(ekf.associate(&reading), Association::Update(expected), "{association:?}");
    }
}

#[test]
fn none_on_reobservation_leaves_p_to_prediction_and_augmentation() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let motion = pose_noise(1.0);
    let r = r_matrix(SIGMA_RANGE_M, SIGMA_BEARING_RAD);
    let points = ring_landmarks(12, 1.2);
    let u = circle_increment();
    let start =
        point_readings(&[Pose2::IDENTITY], &points, &r, Some(&mut rng)).remove(0).observations;
    let next = point_readings(&[Pose2::IDENTITY.compose(u)], &points, &r, Some(&mut rng))
        .remove(0)
        .observations;
    assert!(start.len() >= 2);
    for (update, p_changes) in
        [(CovarianceUpdate::NoneOnReobservation, false), (CovarianceUpdate::Joseph, true)]
    {
        let p = EkfParams {
            association: EkfAssociation::Known,
            covariance_update: update,
            ..EkfParams::default()
        };
        let mut ekf = Ekf::new(&p, &motion, Pose2::IDENTITY);
        ekf.step(None, &start);
        let mut predicted_only = ekf.clone();
        predicted_only.step(Some(&u), &[]);
        let reobserved: Vec<Observation> = next
            .iter()
            .filter(|o| start.iter().any(|s| s.landmark == o.landmark))
            .copied()
            .collect();
        ekf.step(Some(&u), &reobserved);
        assert_eq!(ekf.weighted_steps, 1);
        assert!(ekf.mean() != predicted_only.mean(), "{update:?}: the mean must move");
        assert_eq!(ekf.covariance() != predicted_only.covariance(), p_changes, "{update:?}");
    }
}

#[test]
fn a_line_with_negative_rho_is_flipped_with_its_covariance() {
    let (p, motion) = (EkfParams::default(), pose_noise(1.0));
    let mut ekf = Ekf::new(&p, &motion, Pose2::new(1.0, 2.0, 0.3));
    let r = r_matrix(0.05, 0.02);
    ekf.step(
        None,
        &[
            Observation { model: Model::Point, z: Vector2::new(2.0, 0.5), r, landmark: None },
            Observation { model: Model::Line, z: Vector2::new(3.0, 0.4), r, landmark: None },
        ],
    );
    ekf.step(Some(&circle_increment()), &[]); // correlate everything through the pose
    let i = ekf.landmarks()[1].index;
    // push the line to the other side of the origin: (ρ, θ) = (−0.5, θ)
    ekf.x[i] = -0.5;
    let (x0, p0) = (ekf.x.clone(), ekf.p.clone());
    ekf.normalise_lines();
    let mut j = DMatrix::identity(p0.nrows(), p0.ncols());
    j[(i, i)] = -1.0;
    assert!((&ekf.p - &j * &p0 * j.transpose()).abs().max() < 1e-15);
    assert_eq!(ekf.x[i], 0.5);
    assert!((wrap_angle(ekf.x[i + 1] - x0[i + 1] - PI)).abs() < 1e-12);
    assert_eq!(ekf.x.rows(0, i), x0.rows(0, i));
}

#[test]
fn known_association_without_identities_ignores_and_counts() {
    let (p, motion) = (params(EkfAssociation::Known), pose_noise(1.0));
    let mut ekf = Ekf::new(&p, &motion, Pose2::IDENTITY);
    ekf.step(
        None,
        &[Observation {
            model: Model::Point,
            z: Vector2::new(2.0, 0.5),
            r: r_matrix(0.05, 0.02),
            landmark: None,
        }],
    );
    assert_eq!((ekf.landmarks().len(), ekf.numerical_failures), (0, 1));
}

#[test]
fn validation_rejects_negative_and_inverted_gates() {
    assert!(EkfParams::default().validate().is_empty());
    let keys = |p: EkfParams| p.validate().into_iter().map(|v| v.key).collect::<Vec<_>>();
    assert_eq!(keys(EkfParams { gate_reject: -1.0, ..EkfParams::default() }), ["gate_reject"]);
    assert_eq!(
        keys(EkfParams { gate_create: -1.0, gate_reject: -2.0, ..EkfParams::default() }),
        ["gate_reject", "gate_create"]
    );
    assert_eq!(keys(EkfParams { gate_create: 3.0, ..EkfParams::default() }), ["gate_create"]);
    assert_eq!(
        keys(EkfParams { initial_pose_sigma_rad: -0.1, ..EkfParams::default() }),
        ["initial_pose_sigma_rad"]
    );
    assert!(
        keys(EkfParams { gate_reject: f64::NAN, ..EkfParams::default() })
            .contains(&"gate_reject".to_string())
    );
}

#[test]
fn params_read_from_toml_and_reject_unknown_keys() {
    let p: EkfParams = toml::from_str("association = \"maximum_likelihood\"\ncovariance_update = \"none_on_reobservation\"\ngate_reject = 9.0").unwrap();
    assert_eq!(
        p,
        EkfParams {
            association: EkfAssociation::MaximumLikelihood,
            covariance_update: CovarianceUpdate::NoneOnReobservation,
            gate_reject: 9.0,
            ..EkfParams::default()
        }
    );
    assert!(toml::from_str::<EkfParams>("gate = 4.0").is_err());
}

#[test]
fn describe_names_the_association_gates_and_update() {
    let s = EkfParams {
        gate_reject: 5.5,
        gate_create: 30.0,
        known_outlier_gate: 13.8,
        ..EkfParams::default()
    }
    .describe();
    assert!(
        s.contains(
            "nearest-neighbour association (NIS gates: update below 5.5, new landmark above 30)"
        ),
        "{s}"
    );
    assert!(
        s.contains("NIS above 13.8 ignored as outliers") && s.contains("in Joseph form"),
        "{s}"
    );
    assert!(!EkfParams::default().describe().contains("outliers"));
}

/// [EV] C004-4: the Kalman gain on the pose shrinks when the filter's odometry error shrinks —
/// one gain per successful update is recorded, and a filter told a 10× smaller motion noise moves
/// its pose less per observation.
#[test]
fn the_pose_gain_shrinks_with_the_odometry_noise() {
    let points = ring_landmarks(20, 1.5);
    let r = r_matrix(SIGMA_RANGE_M, SIGMA_BEARING_RAD);
    let u = circle_increment();
    let truth = exact_truth(Pose2::IDENTITY, &vec![u; LAP_STEPS]);
    let readings = point_readings(&truth, &points, &r, None);
    let w = world(truth, vec![u; LAP_STEPS]);
    let mean_gain = |sigma: f64| {
        let motion =
            MotionModel::Pose { sigma_x_m: sigma, sigma_y_m: sigma, sigma_theta_rad: sigma / 4.0 };
        let trace = run(&w, &motion, &params(EkfAssociation::Known), &readings, false).unwrap();
        let sightings: usize = readings.iter().map(|s| s.observations.len()).sum();
        let landmarks: std::collections::BTreeSet<_> =
            readings.iter().flat_map(|s| s.observations.iter().map(|o| o.landmark)).collect();
        assert_eq!(
            trace.kalman_gain.len(),
            sightings - landmarks.len(),
            "one gain per update (a first sighting adds the landmark instead)"
        );
        trace.kalman_gain.iter().sum::<f64>() / trace.kalman_gain.len() as f64
    };
    let (small, large) = (mean_gain(0.002), mean_gain(0.02));
    assert!(small < 0.5 * large, "mean ‖K_pose‖ {small} (small Q) vs {large} (large Q)");
}
