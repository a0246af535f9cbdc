//! Per-particle Maximum-Likelihood data association with a new-landmark likelihood P0 ([FT]
//! §5.4, Table 3.2, Eq. 5.6–5.8), and the thesis's rule for ambiguous associations as a named
//! option ([FT] §5.4.2, §10.5.2, §11.2.7).

use serde::{Deserialize, Serialize};

/// What an observed feature is, for one particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Association {
    /// No landmark is more likely than P0: add it to the map (weight factor P0).
    New,
    /// The most likely landmark (index in the particle's map of that type) and the log-likelihood.
    Known { landmark: usize, log_likelihood: f64 },
    /// Ambiguous: not used (weight factor 1).
    Ignored,
}

/// [FT]: "if an observed landmark could plausibly be associated with several map landmarks, the
/// observation is ignored" and "if the same observation is associated to distinct map features,
/// none of those associations is taken into account". The exact test is not given; these are the
/// readings, as options.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case")]
pub enum Ambiguity {
    /// Plain ML: always take the most likely landmark.
    None,
    /// Ignore a feature when more than one landmark has likelihood > P0.
    MultipleCandidates,
    /// Ignore features that chose the same landmark as another feature of the same scan.
    SharedLandmark,
    /// Both rules (the default: the thesis's conservative policy, read both ways).
    Both,
}

/// Accumulates the landmarks offered for one feature — those more likely than P0 — and keeps the
/// most likely with its payload (e.g. the EKF quantities needed to update it).
pub struct Candidates<T> {
    ln_p0: f64,
    best: Option<(usize, f64, T)>,
    count: usize,
}

impl<T> Candidates<T> {
    pub fn new(ln_p0: f64) -> Self {
        Self { ln_p0, best: None, count: 0 }
    }

    pub fn offer(&mut self, landmark: usize, log_likelihood: f64, payload: T) {
        if log_likelihood > self.ln_p0 {
            self.count += 1;
            if self.best.as_ref().is_none_or(|(_, b, _)| log_likelihood > *b) {
                self.best = Some((landmark, log_likelihood, payload));
            }
        }
    }

    /// The ML decision (argmax over the landmarks and the "new" hypothesis, likelihood P0).
    pub fn decide(self, rule: Ambiguity) -> (Association, Option<T>) {
        match self.best {
            None => (Association::New, None),
            Some(_)
                if self.count > 1
                    && matches!(rule, Ambiguity::MultipleCandidates | Ambiguity::Both) =>
            {
                (Association::Ignored, None)
            }
            Some((landmark, log_likelihood, payload)) => {
                (Association::Known { landmark, log_likelihood }, Some(payload))
            }
        }
    }
}

/// The ML decision for one feature from its log-likelihoods against every landmark of its type.
pub fn decide(
    log_likelihoods: impl Iterator<Item = f64>,
    ln_p0: f64,
    rule: Ambiguity,
) -> Association {
    let mut c = Candidates::new(ln_p0);
    for (j, ll) in log_likelihoods.enumerate() {
        c.offer(j, ll, ());
    }
    c.decide(rule).0
}

/// Applies the shared-landmark rule to the decisions of one scan's features (of one type).
pub fn resolve_shared(decisions: &mut [Association], rule: Ambiguity) {
    if !matches!(rule, Ambiguity::SharedLandmark | Ambiguity::Both) {
        return;
    }
    let chosen: Vec<Option<usize>> = decisions
        .iter()
        .map(|d| if let Association::Known { landmark, .. } = d { Some(*landmark) } else { None })
        .collect();
    for (i, d) in decisions.iter_mut().enumerate() {
        if let Some(l) = chosen[i]
            && chosen.iter().enumerate().any(|(k, c)| k != i && *c == Some(l))
        {
            *d = Association::Ignored;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const P0: f64 = -5.3; // ln 0.005

    #[test]
    fn ml_picks_the_most_likely_above_p0() {
        assert_eq!(
            decide([-9.0, -2.0, -7.0].into_iter(), P0, Ambiguity::None),
            Association::Known { landmark: 1, log_likelihood: -2.0 }
        );
        assert_eq!(decide([-9.0, -8.0].into_iter(), P0, Ambiguity::None), Association::New);
        assert_eq!(decide(std::iter::empty(), P0, Ambiguity::Both), Association::New);
    }

    #[test]
    fn two_plausible_landmarks_make_a_feature_ambiguous() {
        let lls = [-1.0, -3.0, -20.0];
        assert_eq!(
            decide(lls.into_iter(), P0, Ambiguity::MultipleCandidates),
            Association::Ignored
        );
        assert!(matches!(
            decide(lls.into_iter(), P0, Ambiguity::SharedLandmark),
            Association::Known { landmark: 0, .. }
        ));
    }

    #[test]
    fn two_features_on_one_landmark_are_both_ignored() {
        let mut d = vec![
            Association::Known { landmark: 2, log_likelihood: -1.0 },
            Association::New,
            Association::Known { landmark: 2, log_likelihood: -2.0 },
            Association::Known { landmark: 0, log_likelihood: -1.0 },
        ];
        resolve_shared(&mut d, Ambiguity::Both);
        assert_eq!(d[0], Association::Ignored);
        assert_eq!(d[1], Association::New);
        assert_eq!(d[2], Association::Ignored);
        assert!(matches!(d[3], Association::Known { landmark: 0, .. }));
    }
}
