//! `[base]`: every parameter a run reads, one section per layer. Each section is that layer's own
//! config struct; this type only composes them and checks cross-section constraints.

use crate::config::{Checks, Violation};
use crate::features::FeatureParams;
use crate::scanmatch::brute::BruteForceParams;
use crate::scanmatch::epsm::EpsmParams;
use crate::scanmatch::plicp::PlIcpParams;
use crate::scanmatch::psm::PsmParams;
use crate::scanmatch::search::SearchParams;
use crate::scanmatch::track::ScanMatchingParams;
use crate::slam::ekf::EkfParams;
use crate::slam::fastslam::FastSlamParams;
use crate::slam::graph::GraphParams;
use crate::slam::motion::MotionModel;
use crate::slam::pose_graph::PoseGraphParams;
use crate::world::Sensors;
use crate::world::laser::LaserParams;
use crate::world::odometry::OdometryNoise;
use crate::world::point_sensor::PointSensorParams;
use crate::world::{SimParams, sensor_period_steps};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The resolved parameters of one sweep point. Omitted sections and keys take their defaults.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default, schemars::JsonSchema)]
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
    /// Graph-based SLAM (smoothing).
    pub graph: GraphParams,
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
    /// PL-ICP, point-to-line ICP (Censi, ICRA 2008).
    pub pl_icp: PlIcpParams,
    /// The laser pose graph: its front end, edges and loop closures.
    pub pose_graph: PoseGraphParams,
    /// External algorithms' own parameters, `[base.external.<name>]`, handed to the program as
    /// written (docs/src/guide/external-algorithms.md). Not written out when empty, so the studies without
    /// one keep their run hashes.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    #[schemars(skip)]
    pub external: BTreeMap<String, toml::Table>,
}

impl Params {
    /// Range checks of every section, and cross-section checks for the sensors in use (a laser
    /// rate that does not fit the clock does not matter to a study that simulates no laser).
    pub fn validate(&self, sensors: Sensors) -> Vec<Violation> {
        // every section named (no `..`): a new one cannot be left unchecked
        let Params {
            sim,
            odometry,
            laser,
            landmark_sensor,
            features,
            fastslam,
            motion_model,
            ekf,
            graph,
            scan_matching,
            psm,
            epsm,
            pose_search,
            brute_force,
            pl_icp,
            pose_graph,
            external: _, // the program's own: handed over as written
        } = self;
        let mut c = Checks::new();
        c.nested("sim", sim.validate());
        c.nested("odometry", odometry.validate());
        c.nested("laser", laser.validate());
        c.nested("landmark_sensor", landmark_sensor.validate());
        c.nested("features", features.validate());
        c.nested("fastslam", fastslam.validate());
        c.nested("motion_model", motion_model.validate());
        c.nested("ekf", ekf.validate());
        c.nested("graph", graph.validate());
        c.nested("scan_matching", scan_matching.validate());
        c.nested("psm", psm.validate());
        c.nested("epsm", epsm.validate());
        c.nested("pose_search", pose_search.validate());
        c.nested("brute_force", brute_force.validate());
        c.nested("pl_icp", pl_icp.validate());
        c.nested("pose_graph", pose_graph.validate());
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

    /// The sections named in `wanted` (top-level sections, or `external.<name>` for one external
    /// algorithm's table), in declaration order. Their values — not the whole parameter set — go
    /// into a run's content hash, so changing laser settings does not invalidate odometry-only
    /// runs.
    pub fn sections(&self, wanted: &[String]) -> toml::Table {
        let mut out = toml::Table::new();
        for (section, value) in self.to_table() {
            if wanted.contains(&section) {
                out.insert(section, value);
            } else if let toml::Value::Table(table) = value {
                let picked: toml::Table = table
                    .into_iter()
                    .filter(|(sub, _)| wanted.contains(&format!("{section}.{sub}")))
                    .collect();
                if !picked.is_empty() {
                    out.insert(section, toml::Value::Table(picked));
                }
            }
        }
        out
    }
}

/// Declares the top-level sections once: their names in declaration order ([`SECTIONS`]) and the
/// by-name access that resolving a sweep point and hashing a run use instead of serialising the
/// whole parameter set (a test checks the list against `Params`' own fields).
macro_rules! sections {
    ($($field:ident),* $(,)?) => {
        /// The top-level sections, in declaration order.
        pub const SECTIONS: &[&str] = &[$(stringify!($field)),*];

        impl Params {
            /// Moves section `name` of `from` into `self`; false when `name` is not a section.
            pub fn take_section(&mut self, from: &mut Params, name: &str) -> bool {
                match name {
                    $(stringify!($field) => self.$field = std::mem::take(&mut from.$field),)*
                    _ => return false,
                }
                true
            }

            /// The TOML text of section `name` alone (`[name]` and its keys), serialised
            /// directly; `None` when `name` is not a section.
            fn section_table_text(&self, name: &str) -> Option<String> {
                match name {
                    $(stringify!($field) => Some(
                        toml::to_string(&std::collections::BTreeMap::from([(name, &self.$field)]))
                            .expect("a section serialises to TOML"),
                    ),)*
                    _ => None,
                }
            }

            /// Copies section `name` of `from` into `self`; false when `name` is not a section.
            pub fn copy_section(&mut self, from: &Params, name: &str) -> bool {
                match name {
                    $(stringify!($field) => self.$field.clone_from(&from.$field),)*
                    _ => return false,
                }
                true
            }
        }
    };
}

sections!(
    sim,
    odometry,
    laser,
    landmark_sensor,
    features,
    fastslam,
    motion_model,
    ekf,
    graph,
    scan_matching,
    psm,
    epsm,
    pose_search,
    brute_force,
    pl_icp,
    pose_graph,
    external,
);

impl Params {
    /// `toml::to_string(&self.sections(wanted))`, built from one text per section: a section's
    /// text is `[name]` and its keys (`section_text`), and the texts of a table of sections are
    /// those texts joined by a blank line. `text_of` gives a section's text (a caller may
    /// reuse the texts of sections it knows are unchanged). `None` when `wanted` names a
    /// sub-table (`external.<name>`), which only `sections` picks.
    pub fn sections_text<S: AsRef<str>>(
        wanted: &[String],
        mut text_of: impl FnMut(&str) -> S,
    ) -> Option<String> {
        if wanted.iter().any(|w| w.contains('.')) {
            return None;
        }
        let parts: Vec<S> = SECTIONS
            .iter()
            .filter(|s| wanted.iter().any(|w| w == *s))
            .map(|s| text_of(s))
            .filter(|t| !t.as_ref().is_empty())
            .collect();
        Some(parts.iter().map(AsRef::as_ref).collect::<Vec<&str>>().join("\n"))
    }

    /// The TOML text of one section, as [`Params::sections_text`] joins them (empty for an empty
    /// `external`, which `to_table` leaves out).
    pub fn section_text(&self, name: &str) -> String {
        if name == "external" && self.external.is_empty() {
            return String::new();
        }
        self.section_table_text(name).unwrap_or_default()
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

    /// The section list is `Params`' own fields, in declaration order, and each is reachable by
    /// name: a new section cannot be left out of sweep resolution or run hashing.
    #[test]
    fn every_section_is_listed_in_declaration_order() {
        let mut p = Params::default();
        p.external.insert("x".into(), toml::toml! { gate = 1.0 });
        let keys: Vec<String> = p.to_table().keys().cloned().collect();
        assert_eq!(keys, SECTIONS.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        let mut from = p.clone();
        let mut to = Params::default();
        let mut copied = Params::default();
        for s in SECTIONS {
            assert!(copied.copy_section(&p, s), "{s}");
            assert!(to.take_section(&mut from, s), "{s}");
            assert_eq!(to.section_text(s), p.section_text(s), "{s}");
        }
        assert_eq!(to, p);
        assert_eq!(copied, p);
        assert!(!to.take_section(&mut from, "nope"));
        assert!(!to.copy_section(&p, "nope"));
    }

    /// The text joined from one text per section is the text of the table of those sections,
    /// for every subset of sections (the run hashes depend on it byte for byte).
    #[test]
    fn sections_text_is_the_sections_table_text() {
        let mut varied = Params::default();
        varied.odometry = crate::world::odometry::OdometryNoise::None {};
        varied.sim.dt_s = -0.0;
        varied.fastslam.neff_threshold = 3.5;
        for p in [Params::default(), varied] {
            let names: Vec<&str> = SECTIONS.iter().copied().filter(|s| *s != "external").collect();
            for mask in 0u32..(1 << names.len()) {
                let wanted: Vec<String> = names
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| mask & (1 << i) != 0)
                    .map(|(_, s)| s.to_string())
                    .collect();
                let slow = toml::to_string(&p.sections(&wanted)).unwrap();
                let fast = Params::sections_text(&wanted, |s| p.section_text(s)).unwrap();
                assert_eq!(fast, slow, "{wanted:?}");
            }
        }
        assert_eq!(Params::sections_text(&["external.a".into()], |_| String::new()), None);
    }

    #[test]
    fn defaults_are_valid() {
        assert_eq!(Params::default().validate(Sensors { laser: true, landmarks: true }), vec![]);
    }

    #[test]
    fn sections_come_in_declaration_order() {
        let wanted = ["odometry".to_string(), "sim".to_string()];
        let s = Params::default().sections(&wanted);
        let keys: Vec<_> = s.keys().map(String::as_str).collect();
        // declaration order, not alphabetical nor the order asked
        assert_eq!(keys, vec!["sim", "odometry"]);
    }

    #[test]
    fn one_external_table_is_picked_by_its_dotted_name() {
        let mut p = Params::default();
        p.external.insert("a".into(), toml::toml! { gate = 4.0 });
        p.external.insert("b".into(), toml::toml! { gate = 9.0 });
        let s = p.sections(&["sim".to_string(), "external.b".to_string()]);
        assert_eq!(
            toml::to_string(&s).unwrap(),
            toml::to_string(&toml::toml! {
                [sim]
                dt_s = 0.1
                route_inset_m = 0.0
                [external.b]
                gate = 9.0
            })
            .unwrap()
        );
        // without external tables nothing is written: older studies keep their hashes
        assert!(!Params::default().to_table().contains_key("external"));
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
