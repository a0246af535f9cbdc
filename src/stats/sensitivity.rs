//! Global sensitivity analysis, the statistical core of issue 16: Morris's elementary-effects
//! screening (μ, μ*, σ), and variance-based Sobol' indices — a scrambled Sobol' sequence,
//! Saltelli's sampling design and the first-order and total indices S1 (Saltelli et al. 2010)
//! and ST (Jansen 1999) with percentile-bootstrap intervals. Pure: the
//! caller evaluates the model at the design's points (for slamlab: the runs of a sweep) and hands
//! the outputs back.
//!
//! Wired into studies by the `morris` / `sobol` sweep kinds (`plan::design`, `judge::sensitivity`).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Bits of every Sobol' coordinate.
const BITS: usize = 32;

/// Primitive polynomials (degree s, coefficients a) and initial direction numbers m₁…m_s of the
/// Sobol' dimensions after the first (which is the van der Corput sequence): Joe & Kuo's
/// new-joe-kuo-6.21201, checked against SciPy's sequence by `direction_numbers_are_joe_and_kuos`.
/// Any odd mₖ < 2ᵏ gives a valid Sobol' sequence; these set its quality.
const DIRECTIONS: [(u32, u32, &[u32]); 20] = [
    (1, 0, &[1]),
    (2, 1, &[1, 3]),
    (3, 1, &[1, 3, 1]),
    (3, 2, &[1, 1, 1]),
    (4, 1, &[1, 1, 3, 3]),
    (4, 4, &[1, 3, 5, 13]),
    (5, 2, &[1, 1, 5, 5, 17]),
    (5, 4, &[1, 1, 5, 5, 5]),
    (5, 7, &[1, 1, 7, 11, 19]),
    (5, 11, &[1, 1, 5, 1, 1]),
    (5, 13, &[1, 1, 1, 3, 11]),
    (5, 14, &[1, 3, 5, 5, 31]),
    (6, 1, &[1, 3, 3, 9, 7, 49]),
    (6, 13, &[1, 1, 1, 15, 21, 21]),
    (6, 16, &[1, 3, 1, 13, 27, 49]),
    (6, 19, &[1, 1, 1, 15, 7, 5]),
    (6, 22, &[1, 3, 1, 15, 13, 25]),
    (6, 25, &[1, 1, 5, 5, 19, 61]),
    (7, 1, &[1, 3, 7, 11, 23, 15, 103]),
    (7, 4, &[1, 3, 7, 13, 13, 15, 69]),
];

/// The most dimensions [`sobol`] provides.
pub const MAX_DIMENSIONS: usize = DIRECTIONS.len() + 1;

/// Direction numbers v₁…v₃₂ of dimension `dim` (0-based), left-aligned in 32 bits.
fn direction_numbers(dim: usize) -> [u32; BITS] {
    let mut v = [0u32; BITS];
    if dim == 0 {
        for (k, x) in v.iter_mut().enumerate() {
            *x = 1 << (BITS - 1 - k);
        }
        return v;
    }
    let (s, a, m) = DIRECTIONS[dim - 1];
    let s = s as usize;
    for k in 0..s.min(BITS) {
        v[k] = m[k] << (BITS - 1 - k);
    }
    for k in s..BITS {
        // vₖ = a₁vₖ₋₁ ⊕ … ⊕ a_{s−1}vₖ₋ₛ₊₁ ⊕ vₖ₋ₛ ⊕ (vₖ₋ₛ >> s)
        let mut x = v[k - s] ^ (v[k - s] >> s);
        for j in 1..s {
            if (a >> (s - 1 - j)) & 1 == 1 {
                x ^= v[k - j];
            }
        }
        v[k] = x;
    }
    v
}

/// The first `n` points of a `d`-dimensional Sobol' sequence in [0, 1)ᵈ, scrambled with
/// Matoušek's random linear matrix scramble and a digital shift drawn from `seed` (the same seed,
/// the same points). Scrambling keeps every net property of the sequence and makes the points
/// an unbiased randomised QMC design. Panics if `d` > [`MAX_DIMENSIONS`].
pub fn sobol(n: usize, d: usize, seed: u64) -> Vec<Vec<f64>> {
    assert!(d <= MAX_DIMENSIONS, "at most {MAX_DIMENSIONS} dimensions");
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let dims: Vec<[u32; BITS]> = (0..d)
        .map(|dim| {
            let v = direction_numbers(dim);
            // lower-triangular random binary matrix with a unit diagonal, applied to each vₖ:
            // output digit i (from the most significant) = parity(row i · v)
            let rows: [u32; BITS] = std::array::from_fn(|i| {
                let above = if i == 0 { 0 } else { rng.random::<u32>() & (!0u32 << (BITS - i)) };
                above | (1 << (BITS - 1 - i))
            });
            v.map(|x| {
                (0..BITS)
                    .fold(0u32, |acc, i| acc | ((rows[i] & x).count_ones() & 1) << (BITS - 1 - i))
            })
        })
        .collect();
    let shifts: Vec<u32> = (0..d).map(|_| rng.random::<u32>()).collect();
    let mut x: Vec<u32> = shifts.clone();
    let mut points = Vec::with_capacity(n);
    for i in 0..n {
        points.push(x.iter().map(|&b| (f64::from(b) + 0.5) / 4_294_967_296.0).collect());
        // Gray-code order: flip the direction number of the lowest zero bit of i
        let c = (!i).trailing_zeros() as usize;
        if c < BITS {
            for (xj, v) in x.iter_mut().zip(&dims) {
                *xj ^= v[c];
            }
        }
    }
    points
}

/// Saltelli's design for `d` parameters in [0, 1)ᵈ: matrices A and B (the two halves of a
/// 2d-dimensional Sobol' sequence of `n` points) and, for each i, A with its column i from B.
#[derive(Debug, Clone, PartialEq)]
pub struct Saltelli {
    pub a: Vec<Vec<f64>>,
    pub b: Vec<Vec<f64>>,
    /// `ab[i][k]` = row k of A with column i taken from B.
    pub ab: Vec<Vec<Vec<f64>>>,
}

impl Saltelli {
    /// `n` base points (a power of two keeps the Sobol' balance), `d` ≤ [`MAX_DIMENSIONS`]/2.
    pub fn new(n: usize, d: usize, seed: u64) -> Self {
        let points = sobol(n, 2 * d, seed);
        let a: Vec<Vec<f64>> = points.iter().map(|p| p[..d].to_vec()).collect();
        let b: Vec<Vec<f64>> = points.iter().map(|p| p[d..].to_vec()).collect();
        let ab = (0..d)
            .map(|i| {
                a.iter()
                    .zip(&b)
                    .map(|(ra, rb)| {
                        let mut r = ra.clone();
                        r[i] = rb[i];
                        r
                    })
                    .collect()
            })
            .collect();
        Self { a, b, ab }
    }
}

/// An index with its 95 % percentile-bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub value: f64,
    pub low: f64,
    pub high: f64,
}

/// First-order and total indices per parameter.
#[derive(Debug, Clone, PartialEq)]
pub struct Indices {
    pub s1: Vec<Estimate>,
    pub st: Vec<Estimate>,
    /// The bootstrap replicates behind the intervals, `boot_s1[i][b]` (the same resampled rows
    /// for every parameter): intervals of differences (ST − S1, STᵢ − STⱼ) come from them.
    pub boot_s1: Vec<Vec<f64>>,
    pub boot_st: Vec<Vec<f64>>,
}

impl Indices {
    /// STᵢ − S1ᵢ (the share of variance in interactions) and its bootstrap replicates.
    pub fn interaction(&self, i: usize) -> (f64, Vec<f64>) {
        (
            self.st[i].value - self.s1[i].value,
            self.boot_st[i].iter().zip(&self.boot_s1[i]).map(|(t, s)| t - s).collect(),
        )
    }
}

/// The 95 % percentile interval of bootstrap replicates (NaN when there are none).
pub fn percentile_interval(value: f64, boot: &[f64]) -> Estimate {
    let mut b = boot.to_vec();
    b.sort_by(f64::total_cmp);
    let q = |p: f64| {
        if b.is_empty() {
            f64::NAN
        } else {
            b[((p * (b.len() - 1) as f64).round() as usize).min(b.len() - 1)]
        }
    };
    Estimate { value, low: q(0.025), high: q(0.975) }
}

/// S1 and ST from the model's outputs at a [`Saltelli`] design: `fa[k]`, `fb[k]`, `fab[i][k]`.
/// S1ᵢ = mean((f_B − f̄) (f_ABᵢ − f_A)) / V (Saltelli et al. 2010, with f_B centred at the mean
/// f̄ of f_A and f_B, as SALib 1.6 standardises its outputs first: uncentred, the estimate has
/// the same expectation but a variance that grows with f̄²), STᵢ = mean((f_A − f_ABᵢ)²) / 2V (Jansen 1999), V the variance of f_A
/// and f_B together. Intervals: `resamples` bootstrap
/// resamples of the rows (seeded), 2.5 and 97.5 percentiles.
pub fn sobol_indices(
    fa: &[f64],
    fb: &[f64],
    fab: &[Vec<f64>],
    resamples: usize,
    seed: u64,
) -> Indices {
    let n = fa.len();
    let estimate = |rows: &[usize]| -> (Vec<f64>, Vec<f64>) {
        let m = rows.len() as f64;
        let mean = rows.iter().map(|&k| fa[k] + fb[k]).sum::<f64>() / (2.0 * m);
        let var =
            rows.iter().map(|&k| (fa[k] - mean).powi(2) + (fb[k] - mean).powi(2)).sum::<f64>()
                / (2.0 * m);
        // f_B centred: E[f_ABᵢ − f_A] = 0, so centring leaves the estimator unbiased and removes
        // the variance a large output mean (ln of an error, a landmark count) would add
        let s1 = fab
            .iter()
            .map(|f| rows.iter().map(|&k| (fb[k] - mean) * (f[k] - fa[k])).sum::<f64>() / m / var)
            .collect();
        let st = fab
            .iter()
            .map(|f| rows.iter().map(|&k| (fa[k] - f[k]).powi(2)).sum::<f64>() / m / (2.0 * var))
            .collect();
        (s1, st)
    };
    let all: Vec<usize> = (0..n).collect();
    let (s1, st) = estimate(&all);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut boot_s1 = vec![Vec::with_capacity(resamples); fab.len()];
    let mut boot_st = vec![Vec::with_capacity(resamples); fab.len()];
    for _ in 0..resamples {
        let rows: Vec<usize> = (0..n).map(|_| rng.random_range(0..n)).collect();
        let (b1, bt) = estimate(&rows);
        for i in 0..fab.len() {
            boot_s1[i].push(b1[i]);
            boot_st[i].push(bt[i]);
        }
    }
    let with_ci = |values: Vec<f64>, boot: &[Vec<f64>]| -> Vec<Estimate> {
        values.into_iter().zip(boot).map(|(value, b)| percentile_interval(value, b)).collect()
    };
    Indices { s1: with_ci(s1, &boot_s1), st: with_ci(st, &boot_st), boot_s1, boot_st }
}

/// Morris's elementary-effects design (Morris 1991): `trajectories` one-at-a-time paths on a grid
/// of `levels` levels per parameter in [0, 1]ᵈ (`levels` even, step Δ = levels / (2 (levels − 1))).
/// Each path starts at a random grid point whose coordinates keep x ± Δ inside [0, 1], then moves
/// one parameter at a time, in a random order, by +Δ or −Δ (random, kept inside). Seeded.
#[derive(Debug, Clone, PartialEq)]
pub struct Morris {
    /// `points[t]`: the d + 1 points of trajectory t.
    pub points: Vec<Vec<Vec<f64>>>,
    /// `moved[t][k]`: the parameter that step k (from point k to k + 1) moves.
    pub moved: Vec<Vec<usize>>,
    pub delta: f64,
}

impl Morris {
    pub fn new(d: usize, levels: usize, trajectories: usize, seed: u64) -> Self {
        assert!(levels >= 2 && levels % 2 == 0, "an even number of levels");
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let step = 1.0 / (levels - 1) as f64;
        let delta = levels as f64 * step / 2.0;
        let mut points = Vec::with_capacity(trajectories);
        let mut moved = Vec::with_capacity(trajectories);
        for _ in 0..trajectories {
            // a grid level from which both x and x + Δ are on the grid, then either end of that pair
            let mut x: Vec<f64> =
                (0..d).map(|_| rng.random_range(0..levels / 2) as f64 * step).collect();
            let up: Vec<bool> = (0..d).map(|_| rng.random::<bool>()).collect();
            for (xi, &u) in x.iter_mut().zip(&up) {
                if !u {
                    *xi += delta;
                }
            }
            let mut order: Vec<usize> = (0..d).collect();
            for i in (1..d).rev() {
                order.swap(i, rng.random_range(0..=i));
            }
            let mut path = vec![x.clone()];
            for &i in &order {
                x[i] += if up[i] { delta } else { -delta };
                path.push(x.clone());
            }
            points.push(path);
            moved.push(order);
        }
        Self { points, moved, delta }
    }
}

/// Morris's statistics of one parameter: μ (mean elementary effect), μ* (mean absolute,
/// Campolongo et al. 2007) with its 95 % percentile-bootstrap interval over trajectories, and σ
/// (standard deviation: non-linearity or interactions), over the `effects` kept; `dropped`
/// steps had no realised move (rounding of an integer parameter) and give no effect.
#[derive(Debug, Clone, PartialEq)]
pub struct Screening {
    pub mu: f64,
    pub mu_star: Estimate,
    pub sigma: f64,
    pub effects: usize,
    pub dropped: usize,
    /// μ*'s bootstrap replicates (resampled trajectories; the same for every parameter).
    pub boot_mu_star: Vec<f64>,
}

/// The elementary effects EEᵢ = (f(after) − f(before)) / (±Δ) of the outputs `f[t][k]` at the
/// design's points, summarised per parameter.
pub fn morris_indices(
    design: &Morris,
    f: &[Vec<f64>],
    resamples: usize,
    seed: u64,
) -> Vec<Screening> {
    screen(&design.points, &design.moved, f, resamples, seed)
}

/// Morris's statistics from the trajectories' realised coordinates `points[t][k]` (what was
/// run, after rounding), the parameter each step moves, and the outputs `f[t][k]`: each
/// effect divides by its realised step; a step of zero is dropped and counted; a trajectory
/// whose `f` is not finite at either end of a step loses that effect only.
pub fn screen(
    points: &[Vec<Vec<f64>>],
    moved: &[Vec<usize>],
    f: &[Vec<f64>],
    resamples: usize,
    seed: u64,
) -> Vec<Screening> {
    let d = moved.first().map_or(0, Vec::len);
    // effects[i][t]
    let mut effects = vec![Vec::with_capacity(f.len()); d];
    let mut dropped = vec![0usize; d];
    for (t, ((path, order), y)) in points.iter().zip(moved).zip(f).enumerate() {
        for (k, &i) in order.iter().enumerate() {
            let step = path[k + 1][i] - path[k][i];
            if step == 0.0 {
                dropped[i] += 1;
            } else if y[k].is_finite() && y[k + 1].is_finite() {
                effects[i].push((t, (y[k + 1] - y[k]) / step));
            }
        }
    }
    // resample trajectories (the same ones for every parameter, so that differences of μ* have
    // intervals too); a trajectory contributes the effects it has
    let t = f.len();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let picks: Vec<Vec<usize>> = if t == 0 {
        Vec::new()
    } else {
        (0..resamples).map(|_| (0..t).map(|_| rng.random_range(0..t)).collect()).collect()
    };
    effects
        .iter()
        .zip(dropped)
        .map(|(ee, dropped)| {
            let n = ee.len() as f64;
            let values: Vec<f64> = ee.iter().map(|e| e.1).collect();
            let mu = values.iter().sum::<f64>() / n;
            let mu_star = values.iter().map(|v| v.abs()).sum::<f64>() / n;
            let sigma = if ee.len() > 1 {
                (values.iter().map(|e| (e - mu).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
            } else {
                f64::NAN
            };
            let mut by_trajectory: Vec<Vec<f64>> = vec![Vec::new(); t];
            for &(tj, e) in ee {
                by_trajectory[tj].push(e.abs());
            }
            let boot: Vec<f64> = if ee.is_empty() {
                Vec::new()
            } else {
                picks
                    .iter()
                    .map(|pick| {
                        let (sum, count) = pick
                            .iter()
                            .flat_map(|&tj| &by_trajectory[tj])
                            .fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
                        if count == 0 { f64::NAN } else { sum / count as f64 }
                    })
                    .collect()
            };
            Screening {
                mu,
                mu_star: percentile_interval(mu_star, &boot),
                sigma,
                effects: ee.len(),
                dropped,
                boot_mu_star: boot,
            }
        })
        .collect()
}

/// How the variance of a metric over a design's points × replicates splits (two-way ANOVA
/// without replication, replicate k of every point seeing the same world): the points (the
/// parameters), the replicate seed (the world's main effect), and the residual — run-to-run
/// noise and world × parameter interaction. Shares of the total sum of squares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VarianceShares {
    pub params: f64,
    pub world: f64,
    pub residual: f64,
    /// Residual mean square: the variance of one run around its point's and world's effects.
    pub residual_var: f64,
}

/// [`VarianceShares`] of `y[point][replicate]` (complete: every point has every replicate;
/// at least 2 points and 2 replicates, else None).
pub fn variance_shares(y: &[Vec<f64>]) -> Option<VarianceShares> {
    let p = y.len();
    let r = y.first()?.len();
    if p < 2 || r < 2 || y.iter().any(|row| row.len() != r) {
        return None;
    }
    let grand = y.iter().flatten().sum::<f64>() / (p * r) as f64;
    let point_means: Vec<f64> = y.iter().map(|row| row.iter().sum::<f64>() / r as f64).collect();
    let rep_means: Vec<f64> =
        (0..r).map(|k| y.iter().map(|row| row[k]).sum::<f64>() / p as f64).collect();
    let total: f64 = y.iter().flatten().map(|v| (v - grand).powi(2)).sum();
    let ss_points = r as f64 * point_means.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_world = p as f64 * rep_means.iter().map(|m| (m - grand).powi(2)).sum::<f64>();
    let ss_res = (total - ss_points - ss_world).max(0.0);
    if total <= 0.0 {
        return None;
    }
    Some(VarianceShares {
        params: ss_points / total,
        world: ss_world / total,
        residual: ss_res / total,
        residual_var: ss_res / ((p - 1) * (r - 1)) as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn every_dimension_is_stratified_and_the_first_two_form_a_net() {
        let m = 10;
        let n = 1 << m;
        let p = sobol(n, MAX_DIMENSIONS, 7);
        for dim in 0..MAX_DIMENSIONS {
            // each of the 2^m intervals [k/2^m, (k+1)/2^m) holds exactly one point
            let mut seen = vec![false; n];
            for x in &p {
                let k = (x[dim] * n as f64) as usize;
                assert!(!seen[k], "dimension {dim}: two points in interval {k}");
                seen[k] = true;
            }
        }
        // dimensions 1 and 2 form a (0, m, 2)-net: one point in every 2^-j × 2^-(m−j) box
        for j in 0..=m {
            let (cols, rows) = (1usize << j, 1usize << (m - j));
            let mut seen = vec![false; n];
            for x in &p {
                let k = (x[0] * cols as f64) as usize * rows + (x[1] * rows as f64) as usize;
                assert!(!seen[k], "box {k} of {cols} × {rows} twice");
                seen[k] = true;
            }
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_points_and_another_seed_others() {
        assert_eq!(sobol(64, 5, 1), sobol(64, 5, 1));
        assert_ne!(sobol(64, 5, 1), sobol(64, 5, 2));
        assert!(sobol(256, 6, 3).iter().flatten().all(|x| (0.0..1.0).contains(x)));
    }

    fn screen(model: impl Fn(&[f64]) -> f64, d: usize) -> Vec<Screening> {
        let design = Morris::new(d, 4, 50, 5);
        let f: Vec<Vec<f64>> =
            design.points.iter().map(|path| path.iter().map(|x| model(x)).collect()).collect();
        morris_indices(&design, &f, 500, 3)
    }

    #[test]
    fn morris_paths_stay_on_the_grid_and_move_each_parameter_once() {
        let m = Morris::new(5, 4, 20, 9);
        assert_eq!(m.delta, 4.0 / 6.0);
        for (path, order) in m.points.iter().zip(&m.moved) {
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, [0, 1, 2, 3, 4]);
            for x in path.iter().flatten() {
                let level = x * 3.0;
                assert!(
                    (level - level.round()).abs() < 1e-12 && (0.0..=1.0).contains(x),
                    "{x} is off the grid"
                );
            }
            for (k, &i) in order.iter().enumerate() {
                let changed: Vec<usize> =
                    (0..5).filter(|&j| path[k][j] != path[k + 1][j]).collect();
                assert_eq!(changed, [i]);
                assert!(((path[k + 1][i] - path[k][i]).abs() - m.delta).abs() < 1e-12);
            }
        }
        assert_eq!(Morris::new(5, 4, 20, 9), m, "seeded");
    }

    #[test]
    fn a_linear_model_has_exact_effects_and_no_spread() {
        let c = [3.0, -2.0, 0.5, 0.0];
        let s = screen(|x| x.iter().zip(&c).map(|(x, c)| x * c).sum(), 4);
        for (si, ci) in s.iter().zip(c) {
            assert!(
                (si.mu - ci).abs() < 1e-9
                    && (si.mu_star.value - ci.abs()).abs() < 1e-9
                    && si.sigma < 1e-9,
                "{si:?} for c = {ci}"
            );
        }
    }

    #[test]
    fn morris_ranks_the_g_function_by_its_coefficients_and_sees_interactions() {
        let a = [0.0, 1.0, 4.5, 9.0, 99.0];
        let s = screen(
            |x| x.iter().zip(&a).map(|(x, a)| ((4.0 * x - 2.0).abs() + a) / (1.0 + a)).product(),
            5,
        );
        for w in s.windows(2) {
            assert!(w[0].mu_star.value > w[1].mu_star.value, "μ* must fall as a grows: {s:?}");
        }
        assert!(s[4].mu_star.high < 0.1 * s[0].mu_star.low, "a = 99 is negligible: {s:?}");
        // f = x₁x₂: each effect depends on the other parameter (σ > 0); x₃ does nothing
        let s = screen(|x| x[0] * x[1], 3);
        assert!(
            s[0].sigma > 0.1 && s[1].sigma > 0.1 && s[2].mu_star.value == 0.0 && s[2].sigma == 0.0,
            "{s:?}"
        );
    }

    fn run(model: impl Fn(&[f64]) -> f64, n: usize, d: usize) -> Indices {
        let design = Saltelli::new(n, d, 2026);
        let fa: Vec<f64> = design.a.iter().map(|x| model(x)).collect();
        let fb: Vec<f64> = design.b.iter().map(|x| model(x)).collect();
        let fab: Vec<Vec<f64>> =
            design.ab.iter().map(|m| m.iter().map(|x| model(x)).collect()).collect();
        sobol_indices(&fa, &fb, &fab, 500, 11)
    }

    fn assert_covers(what: &str, got: &[Estimate], truth: &[f64], tolerance: f64) {
        for (i, (e, t)) in got.iter().zip(truth).enumerate() {
            assert!(
                e.low <= *t && *t <= e.high,
                "{what}[{i}] = {} [{}, {}] misses the analytic {t}",
                e.value,
                e.low,
                e.high
            );
            assert!((e.value - t).abs() < tolerance, "{what}[{i}] = {} against {t}", e.value);
            // an interval that covers by being wide proves nothing
            assert!(
                e.high - e.low < 4.0 * tolerance,
                "{what}[{i}]: interval [{}, {}] too wide to test",
                e.low,
                e.high
            );
        }
    }

    /// Ishigami & Homma (1990), a = 7, b = 0.1 on [−π, π]³: S1 = (0.3139, 0.4424, 0),
    /// ST = (0.5576, 0.4424, 0.2437) (Saltelli et al. 2008, §4.6).
    #[test]
    fn ishigami_indices_match_the_analytic_ones() {
        let (a, b) = (7.0, 0.1);
        let ishigami = |u: &[f64]| {
            let x: Vec<f64> = u.iter().map(|v| -PI + 2.0 * PI * v).collect();
            x[0].sin() + a * x[1].sin().powi(2) + b * x[2].powi(4) * x[0].sin()
        };
        let v1 = 0.5 * (1.0 + b * PI.powi(4) / 5.0).powi(2);
        let v2 = a * a / 8.0;
        let v13 = b * b * PI.powi(8) * 8.0 / 225.0;
        let v = v1 + v2 + v13;
        let got = run(ishigami, 1 << 13, 3);
        assert_covers("S1", &got.s1, &[v1 / v, v2 / v, 0.0], 0.03);
        assert_covers("ST", &got.st, &[(v1 + v13) / v, v2 / v, v13 / v], 0.03);
    }

    /// Sobol's G function with a = (0, 1, 4.5, 9, 99, 99, 99, 99) on [0, 1]⁸: Vᵢ = 1/(3(1 + aᵢ)²),
    /// S1ᵢ = Vᵢ/V, STᵢ = Vᵢ Π_{j≠i}(1 + Vⱼ)/V with V = Π(1 + Vⱼ) − 1.
    #[test]
    fn g_function_indices_match_the_analytic_ones() {
        let a = [0.0, 1.0, 4.5, 9.0, 99.0, 99.0, 99.0, 99.0];
        let g = |x: &[f64]| {
            x.iter().zip(&a).map(|(x, a)| ((4.0 * x - 2.0).abs() + a) / (1.0 + a)).product::<f64>()
        };
        let vi: Vec<f64> = a.iter().map(|a| 1.0 / (3.0 * (1.0 + a) * (1.0 + a))).collect();
        let v = vi.iter().map(|x| 1.0 + x).product::<f64>() - 1.0;
        let s1: Vec<f64> = vi.iter().map(|x| x / v).collect();
        let st: Vec<f64> = vi.iter().map(|x| x * (v + 1.0) / (1.0 + x) / v).collect();
        let got = run(g, 1 << 13, 8);
        assert_covers("S1", &got.s1, &s1, 0.03);
        assert_covers("ST", &got.st, &st, 0.03);
    }

    /// Writes the Ishigami outputs in SALib's order (per base row: A, AB₁…AB_d, B) and our
    /// indices, for the comparison with SALib outside the test suite (README of issue 16's note):
    /// `SLAMLAB_SALIB_OUT=/tmp/ishigami cargo test --release --lib salib_export`, then
    /// `SALib.analyze.sobol.analyze(problem, numpy.loadtxt("/tmp/ishigami/y.txt"),
    /// calc_second_order=False)`. Checks the layout it writes.
    #[test]
    fn salib_export() {
        let out =
            std::env::var_os("SLAMLAB_SALIB_OUT").map(std::path::PathBuf::from).unwrap_or_else(
                || std::env::temp_dir().join(format!("slamlab-salib-{}", std::process::id())),
            );
        let ishigami = |u: &[f64]| {
            let x: Vec<f64> = u.iter().map(|v| -PI + 2.0 * PI * v).collect();
            x[0].sin() + 7.0 * x[1].sin().powi(2) + 0.1 * x[2].powi(4) * x[0].sin()
        };
        let design = Saltelli::new(1 << 13, 3, 2026);
        let fa: Vec<f64> = design.a.iter().map(|x| ishigami(x)).collect();
        let fb: Vec<f64> = design.b.iter().map(|x| ishigami(x)).collect();
        let fab: Vec<Vec<f64>> =
            design.ab.iter().map(|m| m.iter().map(|x| ishigami(x)).collect()).collect();
        let mut y = String::new();
        for k in 0..fa.len() {
            y.push_str(&format!("{:e}\n", fa[k]));
            for f in &fab {
                y.push_str(&format!("{:e}\n", f[k]));
            }
            y.push_str(&format!("{:e}\n", fb[k]));
        }
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join("y.txt"), &y).unwrap();
        let got = sobol_indices(&fa, &fb, &fab, 1000, 11);
        let line = |e: &[Estimate]| {
            e.iter()
                .map(|e| format!("{:.4} [{:.4}, {:.4}]", e.value, e.low, e.high))
                .collect::<Vec<_>>()
                .join("  ")
        };
        std::fs::write(
            out.join("ours.txt"),
            format!("S1 {}\nST {}\n", line(&got.s1), line(&got.st)),
        )
        .unwrap();
        // SALib's layout: d + 2 lines per base row, A first and B last
        let back: Vec<f64> = std::fs::read_to_string(out.join("y.txt"))
            .unwrap()
            .lines()
            .map(|l| l.parse().unwrap())
            .collect();
        assert_eq!(back.len(), fa.len() * 5);
        for k in [0, 1, fa.len() - 1] {
            assert_eq!((back[5 * k], back[5 * k + 2], back[5 * k + 4]), (fa[k], fab[1][k], fb[k]));
        }
        if std::env::var_os("SLAMLAB_SALIB_OUT").is_none() {
            std::fs::remove_dir_all(&out).unwrap();
        }
    }

    /// y = point effect + replicate effect: no residual, and the shares are the two effects'
    /// sums of squares; noise on top moves share into the residual.
    #[test]
    fn variance_shares_split_points_world_and_residual() {
        let y: Vec<Vec<f64>> =
            (0..6).map(|i| (0..3).map(|k| i as f64 + 0.5 * k as f64).collect()).collect();
        let s = variance_shares(&y).unwrap();
        // SS_points = 3·Σ(i − 2.5)² = 52.5; SS_world = 6·Σ(0.5k − 0.5)² = 3
        assert!(
            (s.params - 52.5 / 55.5).abs() < 1e-12
                && (s.world - 3.0 / 55.5).abs() < 1e-12
                && s.residual.abs() < 1e-12,
            "{s:?}"
        );
        let mut noisy = y.clone();
        noisy[2][1] += 1.0;
        assert!(variance_shares(&noisy).unwrap().residual > 0.0);
        assert!(
            variance_shares(&y[..1]).is_none()
                && variance_shares(&[vec![1.0], vec![2.0]]).is_none(),
            "needs 2 points and 2 replicates"
        );
    }

    /// Each effect divides by its realised step; a step that rounding made zero is dropped and
    /// counted, not divided by zero.
    #[test]
    fn screening_divides_by_realised_steps_and_drops_vanished_ones() {
        // one trajectory over 2 parameters: x₀ moves 0 → 0.5 (realised 0.4), then x₁ 0 → 0 (rounded away)
        let points = vec![vec![vec![0.0, 0.0], vec![0.4, 0.0], vec![0.4, 0.0]]];
        let moved = vec![vec![0, 1]];
        let f = vec![vec![1.0, 3.0, 3.0]];
        let s = super::screen(&points, &moved, &f, 10, 1);
        assert_eq!((s[0].mu, s[0].effects, s[0].dropped), (5.0, 1, 0));
        assert_eq!((s[1].effects, s[1].dropped), (0, 1));
        assert!(s[1].mu_star.value.is_nan() && s[1].boot_mu_star.is_empty());
    }

    /// The direction numbers are Joe & Kuo's (new-joe-kuo-6.21201): the unscrambled sequence, in
    /// Gray-code order, equals SciPy 1.17.1's `qmc.Sobol(d=21, scramble=False).random(1024)`
    /// (which reads Joe & Kuo's file) at these rows, bit for bit (values × 2³²).
    #[test]
    fn direction_numbers_are_joe_and_kuos() {
        let v: Vec<[u32; BITS]> = (0..MAX_DIMENSIONS).map(direction_numbers).collect();
        let mut x = [0u32; MAX_DIMENSIONS];
        let mut rows = std::collections::BTreeMap::new();
        for i in 0u32..1024 {
            rows.insert(i, x);
            let c = (!i & (i + 1)).trailing_zeros() as usize;
            for (xj, vj) in x.iter_mut().zip(&v) {
                *xj ^= vj[c];
            }
        }
        let scipy: [(u32, [u32; 21]); 3] = [
            (
                5,
                [
                    3758096384, 3758096384, 536870912, 1610612736, 3758096384, 2684354560,
                    3758096384, 1610612736, 1610612736, 536870912, 1610612736, 3758096384,
                    3758096384, 536870912, 3758096384, 1610612736, 3758096384, 1610612736,
                    1610612736, 2684354560, 2684354560,
                ],
            ),
            (
                700,
                [
                    1203765248, 423624704, 591396864, 2025848832, 239075328, 1505755136, 339738624,
                    3015704576, 4022337536, 4013948928, 1799356416, 2361393152, 3015704576,
                    3200253952, 1363148800, 339738624, 448790528, 1589641216, 3544186880, 54525952,
                    1396703232,
                ],
            ),
            (
                1023,
                [
                    4194304, 3233808384, 2629828608, 624951296, 801112064, 1883242496, 599785472,
                    2654994432, 1480589312, 3653238784, 2915041280, 155189248, 557842432,
                    2856321024, 1556086784, 1992294400, 1346371584, 3762290688, 2512388096,
                    1371537408, 3720347648,
                ],
            ),
        ];
        for (i, expected) in scipy {
            assert_eq!(rows[&i], expected, "row {i}");
        }
    }
}
