//! `[base]`: every parameter a run reads, one section per layer. Each section is that layer's own
//! config struct; this type only composes them and checks cross-section constraints.

use crate::config::{Checks, Violation};
use crate::features::FeatureParams;
use crate::scanmatch::brute::BruteForceParams;
use crate::scanmatch::epsm::EpsmParams;
use crate::scanmatch::psm::PsmParams;
use crate::scanmatch::search::SearchParams;
use crate::scanmatch::track::ScanMatchingParams;
use crate::slam::ekf::EkfParams;
use crate::slam::fastslam::FastSlamParams;
use crate::slam::motion::MotionModel;
use crate::slam::{AlgorithmKind, Sensors};
use crate::world::WorldKind;
use crate::world::laser::LaserParams;
use crate::world::odometry::OdometryNoise;
use crate::world::point_sensor::PointSensorParams;
use crate::world::{SimParams, sensor_period_steps};
use serde::{Deserialize, Serialize};

/// The resolved parameters of one sweep point. Omitted sections and keys take their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Simulation clock.
    pub sim: SimParams,
    /// Odometry noise of the simulated logs.
    pub odometry: OdometryNoise,
    /// Simulated laser (read by laser-based algorithms only).
    pub laser: LaserParams,
    /// Simulated range-bearing landmark sensor (read by point-landmark algorithms only).
    pub landmark_sensor: PointSensorParams,
    /// Line and corner extraction from laser scans ([FT] Ch. 4).
    pub features: FeatureParams,
    /// FastSLAM 1.0 ([FT] Ch. 3, 6, 7) and 2.0 (particles, P0, resampling, association).
    pub fastslam: FastSlamParams,
    /// The motion model of EKF-SLAM, FastSLAM 2.0, and FastSLAM 1.0 on point-landmark worlds.
    pub motion_model: MotionModel,
    /// EKF-SLAM.
    pub ekf: EkfParams,
    /// What every scan matcher shares: trigger, initial guess, segmentation, objective ([EP]).
    pub scan_matching: ScanMatchingParams,
    /// Polar Scan Matching (Diosi & Kleeman's constants).
    pub psm: PsmParams,
    /// E-PSM's alternating search ([EP] §5.3.1); also the brute force's orientation search.
    pub epsm: EpsmParams,
    /// Simultaneous (x, y, θ) search with NLopt ([EP] §5.3.2).
    pub pose_search: SearchParams,
    /// The brute-force reference ([EP] §6.1).
    pub brute_force: BruteForceParams,
}

impl Params {
    /// Range checks of every section, and cross-section checks for the sensors in use (a laser
    /// rate that does not fit the clock does not matter to a study that simulates no laser).
    pub fn validate(&self, sensors: Sensors) -> Vec<Violation> {
        let mut c = Checks::new();
        c.nested("sim", self.sim.validate());
        c.nested("odometry", self.odometry.validate());
        c.nested("laser", self.laser.validate());
        c.nested("landmark_sensor", self.landmark_sensor.validate());
        c.nested("features", self.features.validate());
        c.nested("fastslam", self.fastslam.validate());
        c.nested("motion_model", self.motion_model.validate());
        c.nested("ekf", self.ekf.validate());
        c.nested("scan_matching", self.scan_matching.validate());
        c.nested("psm", self.psm.validate());
        c.nested("epsm", self.epsm.validate());
        c.nested("pose_search", self.pose_search.validate());
        c.nested("brute_force", self.brute_force.validate());
        let in_use = [
            ("laser", self.laser.rate_hz, sensors.laser),
            ("landmark_sensor", self.landmark_sensor.rate_hz, sensors.landmarks),
        ];
        for (section, rate, used) in in_use {
            if used
                && rate > 0.0
                && self.sim.dt_s > 0.0
                && sensor_period_steps(rate, self.sim.dt_s).is_none()
            {
                c.fail(&format!("{section}.rate_hz"), format!("1/(rate_hz·sim.dt_s) must be a whole number of odometry steps, got {rate} Hz at Δt = {} s", self.sim.dt_s));
            }
        }
        c.finish()
    }

    /// The parameters as a TOML table, sections and keys in declaration order.
    pub fn to_table(&self) -> toml::Table {
        toml::Table::try_from(self).expect("Params serialises to a TOML table")
    }

    /// The sections `algorithm` reads: the world's (only the sensors it uses) and its own. Their
    /// values — not the whole parameter set — go into a run's content hash, so changing laser
    /// settings does not invalidate odometry-only runs.
    pub fn sections_read_by(&self, algorithm: AlgorithmKind, kind: WorldKind) -> toml::Table {
        let wanted = algorithm.sections_read(kind);
        self.to_table().into_iter().filter(|(k, _)| wanted.contains(&k.as_str())).collect()
    }
}

/// Flattens a TOML tree into dotted leaf paths (`odometry.k`), in written order.
pub fn flatten(prefix: &str, value: &toml::Value, out: &mut Vec<(String, toml::Value)>) {
    match value {
        toml::Value::Table(map) => {
            for (k, v) in map {
                let p = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                flatten(&p, v, out);
            }
        }
        leaf => out.push((prefix.to_string(), leaf.clone())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        assert_eq!(Params::default().validate(Sensors { laser: true, landmarks: true }), vec![]);
    }

    #[test]
    fn odometry_baseline_reads_no_sensor_section() {
        let s = Params::default().sections_read_by(AlgorithmKind::Odometry, WorldKind::Laser);
        let keys: Vec<_> = s.keys().map(String::as_str).collect();
        // declaration order, not alphabetical
        assert_eq!(keys, vec!["sim", "odometry"]);
    }

    #[test]
    fn sensor_rate_must_fit_the_clock() {
        let mut p = Params::default();
        p.laser.rate_hz = 3.0;
        let v = p.validate(Sensors { laser: true, landmarks: false });
        assert_eq!(v.len(), 1);
        assert_eq!(v[0].key, "laser.rate_hz");
        // a study without a laser does not care
        assert_eq!(p.validate(Sensors::default()), vec![]);
    }

    #[test]
    fn flatten_gives_dotted_leaves() {
        let mut out = Vec::new();
        flatten("", &toml::Value::Table(Params::default().to_table()), &mut out);
        let names: Vec<_> = out.iter().map(|(k, _)| k.as_str()).collect();
        assert!(
            names.contains(&"odometry.model")
                && names.contains(&"odometry.k")
                && names.contains(&"laser.max_range_m")
        );
    }
}
