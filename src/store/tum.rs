//! TUM trajectory files (`timestamp tx ty tz qx qy qz qw`), so evo (`evo_ape tum gt est`) can
//! evaluate any run. Planar poses: z = 0, rotation about z.

use crate::geom::Pose2;
use std::fmt::Write;

/// TUM lines for poses at t = k·Δt, only at the steps where `keep(k)` (evo rejects NaN lines:
/// a log with sparse truth, such as Victoria Park's GPS, writes both files at the steps that have
/// truth).
pub fn tum_text(dt_s: f64, poses: &[Pose2], keep: &dyn Fn(usize) -> bool) -> String {
    let mut s = String::with_capacity(poses.len() * 64);
    for (k, p) in poses.iter().enumerate().filter(|(k, _)| keep(*k)) {
        let (qz, qw) = (0.5 * p.theta).sin_cos();
        let _ =
            writeln!(s, "{:.6} {:.9} {:.9} 0 0 0 {:.12} {:.12}", k as f64 * dt_s, p.x, p.y, qz, qw);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_becomes_a_unit_quaternion_about_z() {
        let text = tum_text(
            0.1,
            &[Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2), Pose2::new(0.0, 0.0, 0.0)],
            &|_| true,
        );
        let lines: Vec<&str> = text.lines().collect();
        let f: Vec<f64> = lines[0].split(' ').map(|v| v.parse().unwrap()).collect();
        assert_eq!(f.len(), 8);
        assert_eq!((f[0], f[1], f[2], f[3]), (0.0, 1.0, 2.0, 0.0));
        assert!((f[6] - 0.5f64.sqrt()).abs() < 1e-9 && (f[7] - 0.5f64.sqrt()).abs() < 1e-9);
        assert!(lines[1].starts_with("0.100000 "));
        // only the kept steps, with their own timestamps
        let poses = [
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(f64::NAN, f64::NAN, 0.0),
            Pose2::new(2.0, 0.0, 0.0),
        ];
        let text = tum_text(0.5, &poses, &|k| poses[k].x.is_finite());
        let stamps: Vec<&str> = text.lines().map(|l| l.split(' ').next().unwrap()).collect();
        assert_eq!(stamps, ["0.000000", "1.000000"]);
        assert!(!text.contains("NaN"));
    }
}
