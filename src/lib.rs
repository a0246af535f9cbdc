//! slamlab: a reproducible-experiment pipeline and report generator for 2-D SLAM.
//!
//! Data flows one way (docs/src/development/architecture.md):
//! `spec` (TOML as written, algorithm names resolved against the `algo` catalogue) → `plan`
//! (validated, expanded, hashed) → `run` (rayon; per run: the world → `Algorithm::run` →
//! `metrics::compute`) → `store` (Parquet) → `judge` → `report` (HTML, LaTeX, SVG, CSV); a map
//! file is a `scenario`, simulated by `world` or read from a real log by `dataset`.
//! `geom`, `trace`, `world`, `features`, `slam`, `scanmatch`, `metrics` and `algo` are pure: no
//! IO, no printing, no threads, no global RNG; external programs are started by `run`.

pub mod algo;
pub mod cli;
pub mod config;
pub mod dataset;
pub mod diff;
pub mod features;
pub mod geom;
pub mod judge;
pub mod metrics;
pub mod params;
pub mod plan;
pub mod report;
pub mod run;
pub mod scanmatch;
pub mod scenario;
pub mod slam;
pub mod source;
pub mod spec;
pub mod stats;
pub mod store;
pub mod trace;
pub mod world;
