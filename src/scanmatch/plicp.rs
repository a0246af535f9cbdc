//! PL-ICP, point-to-line ICP (Censi, ICRA 2008): (reference scan, current scan, initial guess) →
//! the current scan's pose in the reference frame.
//!
//! Each iteration, as the paper's Algorithm 1:
//! 1. the current scan's points are moved by the pose estimate into the reference frame;
//! 2. each finds its closest reference point j₁ and the closer of j₁'s valid neighbours j₂: the
//!    segment j₁–j₂ is its correspondence (the search starts at the beam the point falls in and
//!    stops when the bearing difference alone rules out anything closer, which is exact);
//! 3. outliers are trimmed by their distance to the segment — beyond the `outliers_max_perc`
//!    order statistic or `outliers_adaptive_mult` × the `outliers_adaptive_order` one, whichever
//!    is smaller; correspondences whose j₁ is farther than `max_correspondence_dist_m`, and (CSM)
//!    points more than 3 times as far from a j₁ as the closest point that chose it, go first;
//! 4. the pose minimising Σ (nᵢᵀ(R(θ)pᵢ + t − qᵢ))² over the kept correspondences, nᵢ the segment's
//!    normal, is found in closed form ([`point_to_line_step`]);
//! 5. it stops at a fixed point — the correspondences repeat an earlier iteration's (PL-ICP
//!    converges in finitely many steps) — or when the step is below `epsilon_xy_m` and
//!    `epsilon_theta_rad`.
//!
//! CSM's `sm2` adds restarts: when the mean error exceeds a threshold, ICP is run again from six
//! perturbations of the solution and the lowest summed error wins (CSM compares sums, not means). They are kept as an option (on by
//! default, as in `sm2`). Every default is `sm2`'s; the details CSM settles that the paper does not
//! (the doubles rule, the order statistics, the fail fraction, the extreme beams) follow CSM, so
//! that `data/reference/csm-intel` can check this implementation match by match.

use super::scan::PolarScan;
use super::search::pairs_at;
use super::{Cost, MatchResult, Stop};
use crate::config::{Checks, Violation};
use crate::geom::{Pose2, wrap_angle};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};
use serde::{Deserialize, Serialize};

/// Code version of PL-ICP runs (joins the scan matchers' own in the run hash).
pub const CODE_VERSION: &str = "plicp-1";

/// `[pl_icp]`: PL-ICP's parameters; every default is CSM `sm2`'s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct PlIcpParams {
    /// Iteration budget per ICP run. Default 1000.
    pub max_iterations: u32,
    /// Convergence: the step's translation below this [m]. Default 1e-4.
    pub epsilon_xy_m: f64,
    /// Convergence: the step's rotation below this [rad]. Default 1e-4.
    pub epsilon_theta_rad: f64,
    /// Correspondences whose closest reference point is farther are dropped [m]. Default 2.
    pub max_correspondence_dist_m: f64,
    /// Keep at most this fraction of the correspondences, the closest. Default 0.95.
    pub outliers_max_perc: f64,
    /// Drop correspondences above `outliers_adaptive_mult` × this quantile of the errors. Default 0.7.
    pub outliers_adaptive_order: f64,
    /// Default 2.
    pub outliers_adaptive_mult: f64,
    /// Several current points on one j₁: keep the closest. Default true.
    pub outliers_remove_doubles: bool,
    /// Fewer correspondences than this fraction of the current scan's beams, before or after
    /// trimming, stop the match (`TooFewPairs`). Default 0.05.
    pub min_correspondence_fraction: f64,
    /// Restart from perturbed solutions when the mean error stays above the threshold. Default true.
    pub restart: bool,
    /// Default 0.01 m.
    pub restart_threshold_mean_error_m: f64,
    /// Perturbation of a restart in x and y [m]. Default 0.01.
    pub restart_dt_m: f64,
    /// Perturbation of a restart in θ [deg]. Default 1.5.
    pub restart_dtheta_deg: f64,
}

impl Default for PlIcpParams {
    fn default() -> Self {
        Self {
            max_iterations: 1000,
            epsilon_xy_m: 1e-4,
            epsilon_theta_rad: 1e-4,
            max_correspondence_dist_m: 2.0,
            outliers_max_perc: 0.95,
            outliers_adaptive_order: 0.7,
            outliers_adaptive_mult: 2.0,
            outliers_remove_doubles: true,
            min_correspondence_fraction: 0.05,
            restart: true,
            restart_threshold_mean_error_m: 0.01,
            restart_dt_m: 0.01,
            restart_dtheta_deg: 1.5,
        }
    }
}

impl PlIcpParams {
    pub fn validate(&self) -> Vec<Violation> {
        let mut c = Checks::new();
        c.require(self.max_iterations >= 1, "max_iterations", || "must be at least 1".into());
        c.positive("epsilon_xy_m", self.epsilon_xy_m);
        c.positive("epsilon_theta_rad", self.epsilon_theta_rad);
        c.positive("max_correspondence_dist_m", self.max_correspondence_dist_m);
        c.in_range("outliers_max_perc", self.outliers_max_perc, 0.0, 1.0);
        c.in_range("outliers_adaptive_order", self.outliers_adaptive_order, 0.0, 1.0);
        c.positive("outliers_adaptive_mult", self.outliers_adaptive_mult);
        c.in_range("min_correspondence_fraction", self.min_correspondence_fraction, 0.0, 1.0);
        c.non_negative("restart_threshold_mean_error_m", self.restart_threshold_mean_error_m);
        c.non_negative("restart_dt_m", self.restart_dt_m);
        c.non_negative("restart_dtheta_deg", self.restart_dtheta_deg);
        c.finish()
    }

    /// The report's sentence on PL-ICP.
    pub fn describe(&self) -> String {
        let restarts = if self.restart {
            format!(
                "; when the mean error exceeds {} m it restarts from the solution moved by ±{} m in x and y and ±{}° and keeps the lowest summed error (CSM's restarts)",
                self.restart_threshold_mean_error_m, self.restart_dt_m, self.restart_dtheta_deg
            )
        } else {
            String::new()
        };
        format!(
            "PL-ICP (Censi, ICRA 2008) on the raw ranges: each current point is matched to the segment between its closest reference point and that point's closer valid neighbour; correspondences beyond {} m, more than 3 times as far as another point on the same closest point, or whose distance to the segment exceeds {} × the {} order statistic or the {} one are dropped; the point-to-line pose is solved in closed form, until the correspondences repeat or a step is below {} m and {} rad (at most {} iterations){restarts}. Parameters are CSM sm2's defaults.",
            self.max_correspondence_dist_m,
            self.outliers_adaptive_mult,
            self.outliers_adaptive_order,
            self.outliers_max_perc,
            self.epsilon_xy_m,
            self.epsilon_theta_rad,
            self.max_iterations
        )
    }
}

/// A scan's valid readings as points in its laser frame, with their beam indices and bearings.
struct Points {
    xy: Vec<Vector2<f64>>,
    /// Beam index of each point.
    beam: Vec<usize>,
    /// Point index of each beam (`None` for invalid beams).
    at_beam: Vec<Option<usize>>,
    angle_min_rad: f64,
    angle_increment_rad: f64,
}

impl Points {
    fn of(scan: &PolarScan) -> Self {
        let mut xy = Vec::with_capacity(scan.len());
        let mut beam = Vec::with_capacity(scan.len());
        let mut at_beam = vec![None; scan.len()];
        if scan.is_consistent() {
            for i in 0..scan.len() {
                if scan.valid[i] {
                    let (s, c) = scan.bearing(i).sin_cos();
                    at_beam[i] = Some(xy.len());
                    xy.push(Vector2::new(scan.ranges[i] * c, scan.ranges[i] * s));
                    beam.push(i);
                }
            }
        }
        Points {
            xy,
            beam,
            at_beam,
            angle_min_rad: scan.angle_min_rad,
            angle_increment_rad: scan.angle_increment_rad,
        }
    }

    /// The reference point closest to `p` (reference frame): exact, starting at the beam `p`'s
    /// bearing falls in and walking outwards until the bearing difference alone bounds the
    /// distance above the best found (|p|·sin Δφ for Δφ < 90°, |p| beyond).
    fn closest(&self, p: Vector2<f64>) -> Option<(usize, f64)> {
        let beams = self.at_beam.len();
        if self.xy.is_empty() {
            return None;
        }
        let rho = p.norm();
        let phi = p.y.atan2(p.x);
        let start = ((phi - self.angle_min_rad) / self.angle_increment_rad).round();
        let start = start.clamp(0.0, (beams - 1) as f64) as usize;
        let mut best: Option<(usize, f64)> = None;
        let consider = |j: usize, best: &mut Option<(usize, f64)>| {
            if let Some(k) = self.at_beam[j] {
                let d2 = (self.xy[k] - p).norm_squared();
                if best.is_none_or(|(_, b)| d2 < b) {
                    *best = Some((k, d2));
                }
            }
        };
        let bound = |j: usize| {
            let dphi = (self.angle_min_rad + j as f64 * self.angle_increment_rad - phi).abs();
            if dphi >= std::f64::consts::FRAC_PI_2 { rho } else { rho * dphi.sin() }
        };
        consider(start, &mut best);
        let (mut up, mut down) = (start + 1, start.checked_sub(1));
        loop {
            let best_d = best.map_or(f64::INFINITY, |(_, d2)| d2.sqrt());
            let up_open = up < beams && bound(up) < best_d;
            let down_open = down.is_some_and(|j| bound(j) < best_d);
            if !up_open && !down_open {
                break;
            }
            if up_open {
                consider(up, &mut best);
                up += 1;
            }
            if let Some(j) = down.filter(|_| down_open) {
                consider(j, &mut best);
                down = j.checked_sub(1);
            }
        }
        best
    }
}

/// One point-to-line correspondence: the current point (current frame), the reference point q
/// (j₁) on the segment's line and the line's unit normal n, the point's distance to the segment
/// j₁–j₂ (what trimming ranks) and to j₁.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Correspondence {
    /// Index of the current point.
    i: usize,
    p: Vector2<f64>,
    q: Vector2<f64>,
    n: Vector2<f64>,
    j1: usize,
    j2: usize,
    error: f64,
    dist: f64,
}

fn rotation(theta: f64) -> Matrix2<f64> {
    let (s, c) = theta.sin_cos();
    Matrix2::new(c, -s, s, c)
}

/// Distance from `p` to the segment a–b.
fn distance_to_segment(a: Vector2<f64>, b: Vector2<f64>, p: Vector2<f64>) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    (a + ab * t - p).norm()
}

/// The correspondences of `current` at `pose`, before trimming: j₁ the closest reference point
/// within `max_dist` (not the scan's first or last beam, whose neighbourhood is one-sided), j₂ the
/// closer of the next valid reference points on either side of j₁.
fn correspond(
    reference: &Points,
    current: &Points,
    pose: Pose2,
    max_dist: f64,
) -> Vec<Correspondence> {
    let r = rotation(pose.theta);
    let t = Vector2::new(pose.x, pose.y);
    let last_beam = reference.at_beam.len().saturating_sub(1);
    let mut out = Vec::with_capacity(current.xy.len());
    for (i, &p) in current.xy.iter().enumerate() {
        let pw = r * p + t;
        let Some((j1, d2)) = reference.closest(pw) else { continue };
        let dist = d2.sqrt();
        let b = reference.beam[j1];
        if dist > max_dist || b == 0 || b == last_beam {
            continue;
        }
        // the next valid points below and above j₁ (points are in beam order)
        let below = j1.checked_sub(1);
        let above = Some(j1 + 1).filter(|&j| j < reference.xy.len());
        let closer = |a: usize, c: usize| {
            let (da, dc) =
                ((reference.xy[a] - pw).norm_squared(), (reference.xy[c] - pw).norm_squared());
            if da < dc { a } else { c }
        };
        let j2 = match (below, above) {
            (Some(a), Some(c)) => closer(c, a),
            (Some(a), None) | (None, Some(a)) => a,
            (None, None) => continue,
        };
        let (q1, q2) = (reference.xy[j1], reference.xy[j2]);
        let along = q2 - q1;
        let len = along.norm();
        if len <= 0.0 {
            continue;
        }
        let n = Vector2::new(-along.y, along.x) / len;
        let error = distance_to_segment(q1, q2, pw);
        out.push(Correspondence { i, p, q: q1, n, j1, j2, error, dist });
    }
    out
}

/// Trims the outliers (module doc, step 3); returns the kept correspondences and their summed
/// error. Of several points on one j₁, those more than 3 times as far as the closest are dropped
/// (CSM's rule); then those above the smaller of the `outliers_max_perc` order statistic and
/// `outliers_adaptive_mult` × the `outliers_adaptive_order` one.
fn trim(
    mut c: Vec<Correspondence>,
    reference_points: usize,
    params: &PlIcpParams,
) -> (Vec<Correspondence>, f64) {
    if c.is_empty() {
        return (c, 0.0);
    }
    if params.outliers_remove_doubles {
        const RATIO: f64 = 3.0;
        let mut nearest = vec![f64::INFINITY; reference_points];
        for x in &c {
            nearest[x.j1] = nearest[x.j1].min(x.dist);
        }
        c.retain(|x| x.dist <= RATIO * nearest[x.j1]);
    }
    let mut errors: Vec<f64> = c.iter().map(|x| x.error).collect();
    let k = errors.len();
    let order = |q: f64| ((k as f64 * q).floor() as usize).min(k - 1);
    let mut nth = |n: usize| *errors.select_nth_unstable_by(n, f64::total_cmp).1;
    let limit = nth(order(params.outliers_max_perc))
        .min(params.outliers_adaptive_mult * nth(order(params.outliers_adaptive_order)));
    c.retain(|x| x.error <= limit);
    let total = c.iter().map(|x| x.error).sum();
    (c, total)
}

/// The closed-form point-to-line step: the pose (t, θ) minimising Σ (nᵢᵀ(R(θ)pᵢ + t − qᵢ))².
///
/// With c = cos θ, s = sin θ each residual is linear in (t, c, s): eᵢ = nᵢᵀt + aᵢc + bᵢs − dᵢ,
/// aᵢ = nᵢᵀpᵢ, bᵢ = nᵢᵀ(−pᵢ,y, pᵢ,x), dᵢ = nᵢᵀqᵢ. Eliminating t (the linear least-squares part)
/// leaves J(c, s) = vᵀG₂v − 2gᵀv + const over v = (c, s) on the unit circle, minimised by
/// v = (G₂ − λI)⁻¹g for the smallest root λ of |(G₂ − λI)⁻¹g|² = 1 (a quartic; Censi's
/// appendix solves the same constrained problem with a Lagrange multiplier). The eigenvectors
/// of G₂ are candidates too (the degenerate case g ⟂ eigenvector); the lowest J wins.
/// `None` when the translation part is singular (all normals parallel).
fn point_to_line_step(c: &[Correspondence]) -> Option<Pose2> {
    // normal equations of e = N t + H (c, s, −1)ᵀ, N rows nᵢᵀ, H rows (aᵢ, bᵢ, dᵢ)
    let mut ntn = Matrix2::zeros();
    let mut nth = nalgebra::Matrix2x3::zeros();
    let mut hth = Matrix3::zeros();
    for x in c {
        let n = x.n;
        let h = Vector3::new(n.dot(&x.p), n.x * -x.p.y + n.y * x.p.x, n.dot(&x.q));
        ntn += n * n.transpose();
        nth += n * h.transpose();
        hth += h * h.transpose();
    }
    let ntn_inv = ntn.try_inverse()?;
    // J(c, s) = wᵀ G w with w = (c, s, −1): G = HᵀH − HᵀN (NᵀN)⁻¹ NᵀH
    let g = hth - nth.transpose() * ntn_inv * nth;
    let g2 = Matrix2::new(g[(0, 0)], g[(0, 1)], g[(1, 0)], g[(1, 1)]);
    let lin = Vector2::new(g[(0, 2)], g[(1, 2)]);
    let cost = |v: Vector2<f64>| (v.transpose() * g2 * v)[0] - 2.0 * lin.dot(&v) + g[(2, 2)];
    let mut candidates: Vec<Vector2<f64>> = Vec::with_capacity(8);
    // |(G₂ − λI)⁻¹ g|² = 1 ⇔ |adj(G₂ − λI) g|² = det(G₂ − λI)²
    let (p, q, r) = (g2[(0, 0)], g2[(0, 1)], g2[(1, 1)]);
    let (g0, g1) = (lin.x, lin.y);
    // adj(G₂ − λI) g = ((r − λ)g0 − q g1, −q g0 + (p − λ)g1)
    let u = [r * g0 - q * g1, -g0]; // coefficients in λ⁰, λ¹
    let w = [-q * g0 + p * g1, -g1];
    let det = [p * r - q * q, -(p + r), 1.0];
    let sq = |a: [f64; 2]| [a[0] * a[0], 2.0 * a[0] * a[1], a[1] * a[1]];
    let (us, ws) = (sq(u), sq(w));
    let lhs = [us[0] + ws[0], us[1] + ws[1], us[2] + ws[2], 0.0, 0.0];
    let det2 = [
        det[0] * det[0],
        2.0 * det[0] * det[1],
        det[1] * det[1] + 2.0 * det[0] * det[2],
        2.0 * det[1] * det[2],
        det[2] * det[2],
    ];
    let quartic: [f64; 5] = std::array::from_fn(|k| det2[k] - lhs[k]);
    for lambda in real_roots_quartic(quartic) {
        let m = Matrix2::new(p - lambda, q, q, r - lambda);
        if let Some(v) = m.try_inverse().map(|mi| mi * lin) {
            let norm = v.norm();
            if norm.is_finite() && norm > 0.0 {
                candidates.push(v / norm);
            }
        }
    }
    let eig = nalgebra::SymmetricEigen::new(g2);
    for k in 0..2 {
        let e = eig.eigenvectors.column(k).into_owned();
        candidates.push(e);
        candidates.push(-e);
    }
    let v = candidates
        .into_iter()
        .filter(|v| v.iter().all(|x| x.is_finite()))
        .min_by(|a, b| cost(*a).total_cmp(&cost(*b)))?;
    let theta = v.y.atan2(v.x);
    // t from the normal equations at this (c, s): NᵀN t = −NᵀH (c, s, −1)ᵀ
    let t = -ntn_inv * nth * Vector3::new(v.x, v.y, -1.0);
    Some(Pose2::new(t.x, t.y, theta))
}

/// The real roots of a₀ + a₁x + a₂x² + a₃x³ + a₄x⁴ (a₄ ≠ 0): eigenvalues of the companion matrix
/// with a negligible imaginary part.
fn real_roots_quartic(a: [f64; 5]) -> Vec<f64> {
    if a[4] == 0.0 || !a.iter().all(|x| x.is_finite()) {
        return Vec::new();
    }
    // companion matrix: ones below the diagonal, −aᵢ/a₄ in the last column
    let m = nalgebra::Matrix4::from_fn(|r, c| match c {
        3 => -a[r] / a[4],
        _ if r == c + 1 => 1.0,
        _ => 0.0,
    });
    m.complex_eigenvalues()
        .iter()
        .filter(|z| z.im.abs() <= 1e-9 * (1.0 + z.re.abs()))
        .map(|z| z.re)
        .collect()
}

/// One ICP run from `start`: the pose, the summed error and the number of the last iteration's
/// kept correspondences, iterations and why it stopped. PL-ICP reaches a fixed point in finitely many
/// steps: it stops when an iteration's correspondences repeat an earlier iteration's, or when the
/// step (x_old⁻¹ ⊕ x_new) is below `epsilon_xy_m` (its norm, θ included, as CSM computes it) and
/// `epsilon_theta_rad`.
fn icp(
    reference: &Points,
    current: &Points,
    start: Pose2,
    params: &PlIcpParams,
    observe: &mut dyn FnMut(Pose2),
) -> (Pose2, (f64, usize), u32, Stop) {
    let min_count = (params.min_correspondence_fraction * current.at_beam.len() as f64).ceil();
    let min_count = (min_count as usize).max(3);
    let mut pose = start;
    let mut error = (f64::INFINITY, 0);
    let mut seen: Vec<Vec<(usize, usize, usize)>> = Vec::new();
    for iteration in 1..=params.max_iterations {
        let all = correspond(reference, current, pose, params.max_correspondence_dist_m);
        if all.len() < min_count {
            return (pose, error, iteration, Stop::TooFewPairs);
        }
        let (kept, total) = trim(all, reference.xy.len(), params);
        if kept.len() < min_count {
            return (pose, error, iteration, Stop::TooFewPairs);
        }
        error = (total, kept.len());
        let Some(next) = point_to_line_step(&kept) else {
            return (pose, error, iteration, Stop::Singular);
        };
        let step = next.relative_to(pose);
        pose = Pose2::new(next.x, next.y, wrap_angle(next.theta));
        observe(pose);
        let set: Vec<(usize, usize, usize)> = kept.iter().map(|x| (x.i, x.j1, x.j2)).collect();
        if seen.contains(&set) {
            return (pose, error, iteration, Stop::Converged);
        }
        seen.push(set);
        let norm = (step.x * step.x + step.y * step.y + step.theta * step.theta).sqrt();
        if norm < params.epsilon_xy_m && step.theta.abs() < params.epsilon_theta_rad {
            return (pose, error, iteration, Stop::Converged);
        }
    }
    (pose, error, params.max_iterations, Stop::Budget)
}

/// PL-ICP from `initial` (module doc); `cost` scores the estimate with the common objective.
pub fn pl_icp(
    reference: &PolarScan,
    current: &PolarScan,
    initial: Pose2,
    params: &PlIcpParams,
    cost: &mut impl Cost,
) -> MatchResult {
    pl_icp_observed(reference, current, initial, params, cost, &mut |_| {})
}

/// [`pl_icp`], telling `observe` every iterate (restarts included).
pub fn pl_icp_observed(
    reference: &PolarScan,
    current: &PolarScan,
    initial: Pose2,
    params: &PlIcpParams,
    cost: &mut impl Cost,
    observe: &mut dyn FnMut(Pose2),
) -> MatchResult {
    let (ref_points, cur_points) = (Points::of(reference), Points::of(current));
    let (mut pose, (mut error, count), mut iterations, mut stop) =
        icp(&ref_points, &cur_points, initial, params, observe);
    let restart = matches!(stop, Stop::Converged | Stop::Budget);
    let mean = error / count.max(1) as f64;
    if params.restart && restart && mean > params.restart_threshold_mean_error_m {
        let (dt, dth) = (params.restart_dt_m, params.restart_dtheta_deg.to_radians());
        let base = pose;
        for (dx, dy, dtheta) in [
            (dt, 0.0, 0.0),
            (-dt, 0.0, 0.0),
            (0.0, dt, 0.0),
            (0.0, -dt, 0.0),
            (0.0, 0.0, dth),
            (0.0, 0.0, -dth),
        ] {
            let start = Pose2::new(base.x + dx, base.y + dy, base.theta + dtheta);
            let (p, (e, _), n, s) = icp(&ref_points, &cur_points, start, params, observe);
            iterations += n;
            if matches!(s, Stop::TooFewPairs | Stop::Singular) {
                break;
            }
            // CSM compares the summed errors (not their means) between restarts
            if e < error {
                (pose, error, stop) = (p, e, s);
            }
        }
    }
    let f_initial = cost.f(initial);
    let f = cost.f(pose);
    let pairs = pairs_at(cost, pose);
    MatchResult {
        pose,
        f,
        f_initial,
        pairs,
        iterations,
        evaluations: cost.evaluations(),
        fallback: false,
        stop,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scanmatch::objective::{Objective, ObjectiveParams};
    use crate::scanmatch::scan::testing::room_pair;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn run(truth: Pose2, guess: Pose2, params: &PlIcpParams) -> MatchResult {
        let (reference, current) = room_pair(truth);
        let mut cost = Objective::new(&reference, &current, &ObjectiveParams::default());
        pl_icp(&reference, &current, guess, params, &mut cost)
    }

    fn off(a: Pose2, b: Pose2) -> (f64, f64) {
        ((a.x - b.x).hypot(a.y - b.y), wrap_angle(a.theta - b.theta).abs().to_degrees())
    }

    /// Noise-free, pure translation, guess 5 cm off: the first closed-form step lands on the
    /// truth to within the stopping tolerance (the points slide along the walls they were matched
    /// to; the few matched across a corner or the column's edge leave micrometres), and the second
    /// confirms it.
    #[test]
    fn a_pure_translation_is_recovered_in_one_step_on_a_noise_free_pair() {
        let truth = Pose2::new(0.3, -0.1, 0.0);
        let guess = Pose2::new(0.34, -0.07, 0.0);
        let one = PlIcpParams { max_iterations: 1, restart: false, ..PlIcpParams::default() };
        let r = run(truth, guess, &one);
        let (dt, dth) = off(r.pose, truth);
        let eps = PlIcpParams::default();
        assert!(
            dt < eps.epsilon_xy_m && dth.to_radians() < eps.epsilon_theta_rad,
            "after one step {:?}: {dt} m, {dth}°",
            r.pose
        );
        let r = run(truth, guess, &PlIcpParams { restart: false, ..PlIcpParams::default() });
        assert_eq!((&r.stop, r.iterations), (&Stop::Converged, 2), "{r:?}");
        assert!(off(r.pose, truth).0 < 1e-4);
    }

    /// A 10° rotation with a translation, from the origin as the guess.
    #[test]
    fn a_known_rotation_is_recovered() {
        let truth = Pose2::new(0.15, 0.05, 10f64.to_radians());
        let r = run(truth, Pose2::IDENTITY, &PlIcpParams::default());
        let (dt, dth) = off(r.pose, truth);
        assert!(r.stop == Stop::Converged && dt < 1e-4 && dth < 1e-3, "{r:?}: {dt} m, {dth}°");
        assert!(r.f.is_finite() && r.f < r.f_initial);
    }

    /// The closed-form step equals a numerical minimisation of the same cost: θ on a fine grid
    /// refined by golden section, t by least squares at each θ.
    #[test]
    fn the_closed_form_step_minimises_the_point_to_line_cost() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..50 {
            let c: Vec<Correspondence> = (0..12)
                .map(|_| {
                    let a: f64 = rng.random_range(-3.14..3.14);
                    Correspondence {
                        i: 0,
                        j2: 0,
                        p: Vector2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0)),
                        q: Vector2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0)),
                        n: Vector2::new(a.cos(), a.sin()),
                        j1: 0,
                        error: 0.0,
                        dist: 0.0,
                    }
                })
                .collect();
            let cost = |pose: Pose2| {
                let r = rotation(pose.theta);
                let t = Vector2::new(pose.x, pose.y);
                c.iter().map(|x| x.n.dot(&(r * x.p + t - x.q)).powi(2)).sum::<f64>()
            };
            let best_t = |theta: f64| {
                // t minimising the cost at θ: (Σ n nᵀ) t = −Σ n nᵀ(R p − q)
                let r = rotation(theta);
                let (mut a, mut b) = (Matrix2::zeros(), Vector2::zeros());
                for x in &c {
                    a += x.n * x.n.transpose();
                    b -= x.n * x.n.dot(&(r * x.p - x.q));
                }
                let t = a.try_inverse().unwrap() * b;
                Pose2::new(t.x, t.y, theta)
            };
            let profile = |theta: f64| cost(best_t(theta));
            let grid = (0..3600)
                .map(|k| -std::f64::consts::PI + k as f64 * std::f64::consts::TAU / 3600.0);
            let start = grid.min_by(|a, b| profile(*a).total_cmp(&profile(*b))).unwrap();
            let (mut lo, mut hi) = (start - 0.002, start + 0.002);
            for _ in 0..200 {
                let (m1, m2) = (lo + (hi - lo) * 0.382, lo + (hi - lo) * 0.618);
                if profile(m1) < profile(m2) { hi = m2 } else { lo = m1 }
            }
            let numeric = best_t(0.5 * (lo + hi));
            let closed = point_to_line_step(&c).unwrap();
            assert!(
                cost(closed) <= cost(numeric) + 1e-9 * (1.0 + cost(numeric)),
                "closed form {closed:?} ({}) vs numeric {numeric:?} ({})",
                cost(closed),
                cost(numeric)
            );
        }
    }

    /// The bearing-bounded search finds the same closest point as a scan of every point.
    #[test]
    fn the_closest_point_search_is_exact() {
        let (reference, _) = room_pair(Pose2::IDENTITY);
        let points = Points::of(&reference);
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        for _ in 0..2000 {
            let p = Vector2::new(rng.random_range(-2.0..9.0), rng.random_range(-3.0..3.0));
            let brute = (0..points.xy.len())
                .map(|k| (k, (points.xy[k] - p).norm_squared()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            let found = points.closest(p).unwrap();
            assert!((found.1 - brute.1).abs() <= 1e-12, "{p:?}: {found:?} vs {brute:?}");
        }
    }

    #[test]
    fn defaults_validate_and_bad_values_are_named() {
        assert!(PlIcpParams::default().validate().is_empty());
        let bad = PlIcpParams {
            outliers_max_perc: 1.5,
            min_correspondence_fraction: -0.1,
            ..PlIcpParams::default()
        };
        let keys: Vec<String> = bad.validate().into_iter().map(|v| v.key).collect();
        assert_eq!(keys, ["outliers_max_perc", "min_correspondence_fraction"]);
        assert!(PlIcpParams::default().describe().contains("CSM sm2's defaults"));
    }
}
