//! `sinew-host`: the std side of Sinew. Reads meshes, trains and fits models with burn, bakes
//! them into the `.sinew` format that `sinew-core` plays back, and inspects and renders results.

pub mod aim;
pub mod atomic;
pub mod backend;
pub mod badin;
pub mod bones;
pub mod checkpoint;
pub mod commands;
pub mod constraints;
pub mod container;
pub mod ict;
pub mod inspect;
pub mod interrupt;
pub mod malloc;
pub mod mesh;
pub mod nn;
pub mod plot;
pub mod procedural;
pub mod progress;
pub mod render;
pub mod replay;
pub mod s2d;
pub mod sine;
pub mod testing;
pub mod tolerance;
pub(crate) mod vec3;

pub use container::SinewWriter;
