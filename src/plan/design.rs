//! Global-sensitivity designs (`kind = "morris"` / `"sobol"` sweeps): the unit-cube design of
//! [`crate::stats::sensitivity`] mapped onto each parameter's range, and the record of which
//! sweep point every design row became. Pure.
//!
//! A design coordinate u ∈ [0, 1] becomes the value lo + u (hi − lo), or lo (hi/lo)ᵘ on a log
//! range; an integer parameter takes the nearest integer. The value actually run is mapped back
//! to the unit scale (its *realised* coordinate): Morris's elementary effects divide by the
//! realised step, so rounding never inflates an effect, and a step that rounding made vanish is
//! dropped and counted instead of divided by zero.

use crate::spec::{DesignSpec, RangedParam, SweepKind};
use crate::stats::sensitivity::{Morris, Saltelli};

/// A design's rows before they are realised.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitDesign {
    pub rows: Vec<Vec<f64>>,
    pub moved: Vec<Vec<usize>>,
    pub size: usize,
    pub delta: Option<f64>,
}

/// The unit-cube rows of a design block (seeded: the same spec gives the same rows).
pub fn unit_rows(kind: SweepKind, design: &DesignSpec, seed: u64) -> UnitDesign {
    let d = design.params.len();
    match kind {
        SweepKind::Sobol => {
            let s = Saltelli::new(design.samples, d, seed);
            let rows = s.a.iter().chain(&s.b).chain(s.ab.iter().flatten()).cloned().collect();
            UnitDesign { rows, moved: Vec::new(), size: design.samples, delta: None }
        }
        SweepKind::Morris => {
            let m = Morris::new(d, design.levels, design.trajectories, seed);
            UnitDesign {
                rows: m.points.into_iter().flatten().collect(),
                moved: m.moved,
                size: design.trajectories,
                delta: Some(m.delta),
            }
        }
        _ => unreachable!("only morris and sobol sweeps have a design"),
    }
}

/// The value a unit coordinate stands for, and that value's own coordinate. An integer parameter
/// is rounded to the nearest integer, so each end of its range takes half the weight of an
/// interior value (the coordinates within half a step of it): the sensitivity indices are those
/// of that distribution (docs/src/guide/sensitivity.md).
pub fn realise(p: &RangedParam, u: f64) -> (toml::Value, f64) {
    let x = if p.log { p.low * (p.high / p.low).powf(u) } else { p.low + u * (p.high - p.low) };
    // keep the ends exact (powf and the sum can miss them by an ulp)
    let x = if u <= 0.0 {
        p.low
    } else if u >= 1.0 {
        p.high
    } else {
        x.clamp(p.low, p.high)
    };
    if p.integer {
        let n = x.round();
        (toml::Value::Integer(n as i64), to_unit(p, n))
    } else {
        (toml::Value::Float(x), to_unit(p, x))
    }
}

/// The unit coordinate of a value of `p`.
pub fn to_unit(p: &RangedParam, x: f64) -> f64 {
    if p.log { (x / p.low).ln() / (p.high / p.low).ln() } else { (x - p.low) / (p.high - p.low) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(low: f64, high: f64, log: bool, integer: bool) -> RangedParam {
        RangedParam { path: "p".into(), key: "k".into(), low, high, log, integer }
    }

    #[test]
    fn linear_log_and_integer_ranges() {
        let (v, u) = realise(&param(0.0, 10.0, false, false), 0.25);
        assert_eq!((v, u), (toml::Value::Float(2.5), 0.25));
        let (v, u) = realise(&param(0.001, 0.1, true, false), 0.5);
        assert!((v.as_float().unwrap() - 0.01).abs() < 1e-15 && (u - 0.5).abs() < 1e-12);
        assert_eq!(realise(&param(0.001, 0.1, true, false), 1.0).0, toml::Value::Float(0.1));
        // 5·(100)^(1/3) = 23.2 → 23, whose own coordinate is slightly below 1/3
        let p = param(5.0, 500.0, true, true);
        let (v, u) = realise(&p, 1.0 / 3.0);
        assert_eq!(v, toml::Value::Integer(23));
        assert!((u - (23.0f64 / 5.0).ln() / 100f64.ln()).abs() < 1e-12 && u < 1.0 / 3.0);
    }

    /// What the book states (docs/src/guide/sensitivity.md): rounding a uniform coordinate gives each end of an integer range
    /// half the weight of an interior value (Pmin 5–25: 1/40 at 5 and 25, 1/20 between).
    #[test]
    fn integer_range_ends_take_half_weight() {
        let p = param(5.0, 25.0, false, true);
        let n = 400_000;
        let mut count = std::collections::BTreeMap::<i64, usize>::new();
        for k in 0..n {
            let u = (k as f64 + 0.5) / n as f64;
            *count.entry(realise(&p, u).0.as_integer().unwrap()).or_default() += 1;
        }
        let share = |v: i64| count[&v] as f64 / n as f64;
        assert!((share(5) - 1.0 / 40.0).abs() < 1e-4 && (share(25) - 1.0 / 40.0).abs() < 1e-4);
        assert!((share(15) - 1.0 / 20.0).abs() < 1e-4);
    }

    #[test]
    fn sobol_rows_are_a_b_then_each_ab_i() {
        let spec = DesignSpec {
            params: vec![param(0.0, 1.0, false, false); 3],
            tied: Vec::new(),
            levels: 4,
            trajectories: 4,
            samples: 8,
        };
        let d = unit_rows(SweepKind::Sobol, &spec, 3);
        assert_eq!(d.rows.len(), 8 * (3 + 2));
        let (a, b) = (&d.rows[..8], &d.rows[8..16]);
        for i in 0..3 {
            for k in 0..8 {
                let row = &d.rows[16 + i * 8 + k];
                for j in 0..3 {
                    assert_eq!(row[j], if j == i { b[k][j] } else { a[k][j] });
                }
            }
        }
        assert_eq!(unit_rows(SweepKind::Sobol, &spec, 3), d, "seeded");
        assert_ne!(unit_rows(SweepKind::Sobol, &spec, 4).rows, d.rows);
    }
}
