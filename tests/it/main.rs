//! slamlab's integration tests: one binary (ripgrep-style), one module per contract.

mod bad_input;
mod code_versions;
mod csm_reference;
mod determinism;
mod diff;
mod docs;
mod export_tum;
mod external;
mod fastslam;
mod fidelity;
mod ft_maps;
mod layering;
mod memory;
mod nlopt_threads;
mod pipeline;
mod point_worlds;
mod pose_graph;
mod psm_reference;
mod psm_samples;
mod scan_matching;
mod sensitivity;
mod sharding;
mod specs;
mod util;
