//! The floating-point type PSM computes in: Diosi's C code is written over `PM_TYPE`, `float` as
//! shipped ("change it to double for higher accuracy and lower speed"). [`Precision`] is the
//! spec's choice; [`Real`] the few operations the PSM code needs, for `f32` and `f64`.
//!
//! Where the C code mixes a `float` with a `double` literal (`2.0*err`, `< 0.4`, `+= 2.0*M_PI`),
//! C promotes to double; [`Real::to_f64`] / [`Real::from_f64`] let the Rust code say the same.

use serde::{Deserialize, Serialize};

/// Arithmetic of PSM (and of its preprocessing): `single` = C `float` (v0.3's `PM_TYPE`), `double`.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, schemars::JsonSchema,
)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// IEEE single precision, as v0.3 ships (`PM_TYPE float`).
    #[default]
    Single,
    /// IEEE double precision (`PM_TYPE double`).
    Double,
}

impl Precision {
    pub fn name(self) -> &'static str {
        match self {
            Precision::Single => "single",
            Precision::Double => "double",
        }
    }
}

/// `f32` or `f64`, with the operations PSM uses (libm's `sinf`/`sin`, `atan2f`/`atan2`, … through
/// the standard library, as the C code calls them).
pub trait Real:
    Copy
    + PartialOrd
    + std::fmt::Debug
    + std::ops::Add<Output = Self>
    + std::ops::Sub<Output = Self>
    + std::ops::Mul<Output = Self>
    + std::ops::Div<Output = Self>
    + std::ops::Neg<Output = Self>
    + std::ops::AddAssign
{
    const ZERO: Self;
    /// Rounds to nearest, like a C conversion from `double`.
    fn from_f64(x: f64) -> Self;
    /// Exact.
    fn to_f64(self) -> f64;
    fn from_usize(i: usize) -> Self;
    fn abs(self) -> Self;
    fn sqrt(self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn is_finite(self) -> bool;
}

macro_rules! impl_real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_usize(i: usize) -> Self {
                i as $t
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            #[inline]
            fn atan2(self, x: Self) -> Self {
                <$t>::atan2(self, x)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}

impl_real!(f32);
impl_real!(f64);

/// Whether this CPU runs x86-64-v3 code (AVX2, FMA, …), for the hot loops (PSM's passes, the
/// objective's projection) that are compiled a second time for it and chosen at run time; the
/// baseline build stays x86-64, so no CPU is excluded. Both builds give the same results bit for
/// bit: Rust never fuses a multiply and an add (the fused instructions exist but are not
/// emitted), every operation is an IEEE basic operation or the same libm call, and only the
/// instructions that carry them differ. Tests run both builds on the same inputs and compare.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(crate) fn has_x86_64_v3() -> bool {
    std::is_x86_feature_detected!("avx2")
        && std::is_x86_feature_detected!("fma")
        && std::is_x86_feature_detected!("bmi1")
        && std::is_x86_feature_detected!("bmi2")
        && std::is_x86_feature_detected!("popcnt")
        && std::is_x86_feature_detected!("lzcnt")
        && std::is_x86_feature_detected!("sse4.2")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_rounds_like_a_c_float() {
        // 0.1 is not a float: the conversion rounds to the nearest one, as `(float)0.1` does
        assert_eq!(<f32 as Real>::from_f64(0.1).to_f64(), 0.100_000_001_490_116_12);
        assert_eq!(<f64 as Real>::from_f64(0.1), 0.1);
        // cm ranges of a metre log: (float)(1.3·100)
        assert_eq!(<f32 as Real>::from_f64(1.3 * 100.0), 130.0f32);
        assert_eq!(serde_json::to_string(&Precision::Single).unwrap(), "\"single\"");
        assert_eq!(Precision::default().name(), "single");
    }
}
