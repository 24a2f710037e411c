//! `sinew-host`: the std side of Sinew. Reads meshes, trains and fits models with burn, bakes
//! them into the `.sinew` format that `sinew-core` plays back, and inspects and renders results.

pub mod atomic;
pub mod backend;
pub mod container;
pub mod inspect;
pub mod nn;
pub mod tolerance;

pub use container::SinewWriter;
