//! slamlab: a reproducible-experiment pipeline and report generator for 2-D SLAM.
//!
//! Data flows one way (see `CONVENTIONS.md`):
//! `spec` (TOML as written) → `plan` (validated, expanded, hashed) → `run` (rayon; per run:
//! `world::generate` → algorithm in `slam` → `metrics::compute`) → `store` (Parquet) →
//! `report` (HTML, LaTeX, SVG, CSV); real logs enter through `dataset` (the run layer calls it).
//! `geom`, `world`, `features`, `slam`, `scanmatch` and `metrics` are pure: no IO, no
//! printing, no threads, no global RNG.

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
