//! SLAM filters: ([`World`](crate::world::World), observations, filter RNG) → [`Trace`]. Each is
//! pure and reads only its own parameters; `algo/` says which sensors and sections each reads and
//! runs them.

pub mod driver;
pub mod ekf;
pub mod fastslam;
pub mod fastslam2;
pub mod graph;
pub mod motion;
pub mod observations;
pub mod odometry;
pub mod pose_graph;

pub use fastslam::models;

pub use crate::trace::{LandmarkMap, SlamError, Trace};
