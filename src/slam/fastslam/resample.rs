//! Effective sample size and systematic (low-variance) resampling ([FT] §6.5, Table 6.2,
//! Eq. 6.14): normalised weights → ancestor indices. O(M).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// N̂eff = 1 / Σ wᵢ² for normalised weights ([FT] Eq. 6.14).
pub fn effective_sample_size(weights: &[f64]) -> f64 {
    1.0 / weights.iter().map(|w| w * w).sum::<f64>()
}

/// Systematic resampling ([FT] Table 6.2, 0-based): one uniform draw r ∈ [0, 1/M), then the
/// comb u_m = r + m/M picks the particle whose cumulative-weight interval contains it.
/// Returns M ancestor indices in non-decreasing order. `weights` must be normalised.
pub fn low_variance(weights: &[f64], rng: &mut ChaCha8Rng) -> Vec<usize> {
    let m = weights.len();
    let step = 1.0 / m as f64;
    let r: f64 = rng.random_range(0.0..step);
    let mut out = Vec::with_capacity(m);
    let mut c = weights[0];
    let mut i = 0;
    for k in 0..m {
        let u = r + k as f64 * step;
        while u > c && i + 1 < m {
            i += 1;
            c += weights[i];
        }
        out.push(i);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn keeps_the_particle_count_and_covers_systematically() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let w = [0.1, 0.4, 0.0, 0.3, 0.2];
        for _ in 0..100 {
            let a = low_variance(&w, &mut rng);
            assert_eq!(a.len(), w.len());
            assert!(a.windows(2).all(|x| x[0] <= x[1]));
            // each particle gets ⌊M w⌋ or ⌈M w⌉ copies (systematic coverage); zero weight: none
            for (i, &wi) in w.iter().enumerate() {
                let n = a.iter().filter(|&&x| x == i).count() as f64;
                assert!(
                    n >= (5.0 * wi - 1e-9).floor() && n <= (5.0 * wi + 1e-9).ceil(),
                    "particle {i}: {n} copies of weight {wi}"
                );
            }
        }
    }

    #[test]
    fn equal_weights_eliminate_nothing() {
        // [FT] §1.7: with equal weights no particle is eliminated
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let w = vec![0.01; 100];
        assert_eq!(low_variance(&w, &mut rng), (0..100).collect::<Vec<_>>());
    }

    #[test]
    fn frequencies_follow_the_weights() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let w = [0.05, 0.15, 0.5, 0.3];
        let mut counts = [0usize; 4];
        for _ in 0..2000 {
            for i in low_variance(&w, &mut rng) {
                counts[i] += 1;
            }
        }
        for (c, wi) in counts.iter().zip(w) {
            assert!((*c as f64 / 8000.0 - wi).abs() < 0.01);
        }
    }

    #[test]
    fn neff_extremes() {
        assert!((effective_sample_size(&[0.25; 4]) - 4.0).abs() < 1e-12);
        assert!((effective_sample_size(&[1.0, 0.0, 0.0]) - 1.0).abs() < 1e-12);
    }
}
