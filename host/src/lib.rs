//! `sinew-host`: the std side of Sinew. Reads meshes, trains and fits models with burn, bakes
//! them into the `.sinew` format that `sinew-core` plays back, and inspects and renders results.
//!
//! The folders are the architecture, each layer importing only the layers below it
//! (docs/ARCHITECTURE.md, "Code map"; `tests/tests/suite/architecture.rs` keeps it so):
//! [`view`] above [`replay`] and [`export`], above [`aim`], [`s2d`], [`fit`], [`motion`],
//! [`driver`] and [`performance`], above [`anatomy`], [`training`] and [`rig`], above
//! [`figures`], above [`geometry`], above [`io`]; the binary's `cli` above them all.

pub mod aim;
pub mod anatomy;
pub mod driver;
pub mod export;
pub mod figures;
pub mod fit;
pub mod geometry;
pub mod io;
pub mod motion;
pub mod performance;
pub mod replay;
pub mod rig;
pub mod s2d;
pub mod training;
pub mod view;

pub use io::container::SinewWriter;
