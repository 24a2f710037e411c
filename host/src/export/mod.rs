//! Baked actors out to other engines: glTF 2.0 binary (`.glb`) with the correctives as morph
//! targets, the jaw as a skin joint and poses as an animation (docs/ENGINES.md). Above the models,
//! whose actors and pose frames it reads; below the command line.

mod animation;
mod carry;
mod error;
mod face;
pub mod gltf;
mod jaw;
pub mod names;
mod place;
mod vrm;
