//! `sinew-host`: the std side of Sinew. Reads meshes, trains and fits models with burn, bakes
//! them into the `.sinew` format that `sinew-core` plays back, and inspects and renders results.
//!
//! The folders are the architecture, each layer importing only the layers below it
//! (docs/ARCHITECTURE.md, "Code map"; `tests/tests/architecture.rs` keeps it so):
//! [`replay`] and [`export`] above [`aim`] and [`s2d`], above [`training`], [`figures`] and [`anatomy`], above
//! [`geometry`], above [`io`].

pub mod aim;
pub mod anatomy;
pub mod export;
pub mod figures;
pub mod geometry;
pub mod io;
pub mod replay;
pub mod s2d;
pub mod training;

pub use io::container::SinewWriter;
