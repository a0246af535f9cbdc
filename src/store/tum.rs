//! TUM trajectory files (`timestamp tx ty tz qx qy qz qw`), so evo (`evo_ape tum gt est`) can
//! evaluate any run. Planar poses: z = 0, rotation about z.

use crate::geom::Pose2;
use std::fmt::Write;

/// TUM lines for poses at t = k·Δt.
pub fn tum_text(dt_s: f64, poses: &[Pose2]) -> String {
    let mut s = String::with_capacity(poses.len() * 64);
    for (k, p) in poses.iter().enumerate() {
        let (qz, qw) = (0.5 * p.theta).sin_cos();
        let _ = writeln!(s, "{:.6} {:.9} {:.9} 0 0 0 {:.12} {:.12}", k as f64 * dt_s, p.x, p.y, qz, qw);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_becomes_a_unit_quaternion_about_z() {
        let text = tum_text(0.1, &[Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2), Pose2::new(0.0, 0.0, 0.0)]);
        let lines: Vec<&str> = text.lines().collect();
        let f: Vec<f64> = lines[0].split(' ').map(|v| v.parse().unwrap()).collect();
        assert_eq!(f.len(), 8);
        assert_eq!((f[0], f[1], f[2], f[3]), (0.0, 1.0, 2.0, 0.0));
        assert!((f[6] - 0.5f64.sqrt()).abs() < 1e-9 && (f[7] - 0.5f64.sqrt()).abs() < 1e-9);
        assert!(lines[1].starts_with("0.100000 "));
    }
}
