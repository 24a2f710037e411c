//! Motion3DGAN's side of S2D ("Sparse to Dense Dynamic 3D Facial Expression Generation",
//! sections 3.1, 4.3 and 4.4): labelled landmark motions, their square-root velocity functions on
//! the unit hypersphere, and what is built on them. See docs/MOTION.md.

pub mod checkpoint;
pub mod classes;
pub mod classifier;
pub mod commands;
pub mod data;
pub mod diversity;
pub mod evaluate;
pub mod frechet;
pub mod gan;
pub mod generate;
pub mod ground_truth;
pub mod guide;
pub mod labels;
pub mod lstm_baseline;
pub mod motions_file;
pub mod srvf;
pub mod train;
pub mod variation;
