//! `sinew-core`: loads baked Sinew face models from bytes, validates them once, and evaluates them
//! with deterministic, allocation-free arithmetic.
//!
//! Every float operation goes through `libm` free functions in a fixed order, so the same model
//! and inputs give the same output bits on every target (x86_64, Cortex-M, RISC-V, wasm). See
//! `docs/ARCHITECTURE.md` for the invariants and `docs/FORMAT.md` for the byte format.
//!
//! A model is loaded once with `from_bytes`, which validates everything; playing a frame then only
//! fills buffers the caller owns (`static` arrays on a microcontroller, vectors below) and cannot
//! fail on model data. [`hash`] holds the definitions of a frame's hash (a posed actor's
//! positions then normals, its Q16.16 positions, an S2D frame's vertices), which every target
//! compares with the hashes the host recorded; the `*_frame_hash` functions of [`replay`],
//! [`performance`], [`driver`] and [`sequence`] play one frame and hash it so.
//!
//! # Playing an AIM actor
//!
//! Load the actor, pose it for one frame (head and jaw transforms, the corrective coefficients),
//! compute its vertex normals and hash the frame. Here the frame is the first of the actor's
//! golden replay, so the hash must be the one the host recorded:
//!
//! ```
//! use sinew_core::aim::AimActor;
//! use sinew_core::hash::posed_frame_hash;
//! use sinew_core::replay::AimReplay;
//!
//! let actor = AimActor::from_bytes(include_bytes!("../../tests/data/aim-procedural.sinew"))?;
//! let replay = AimReplay::from_bytes(include_bytes!(
//!     "../../tests/data/aim-procedural.f32.replay.sinew"
//! ))?;
//! let mut weights = vec![0.0f32; actor.shape_count()];
//! // Head and jaw: a 6D rotation and a translation each; the coefficients go into `weights`.
//! let (head, jaw) = replay.frame(0, &mut weights).ok_or("the replay has no frame 0")?;
//!
//! let mut positions = vec![0.0f32; 3 * actor.vertex_count()];
//! let mut normals = vec![0.0f32; 3 * actor.vertex_count()];
//! actor.pose(&actor.pose_from_9d(&jaw, &head)?, &weights, &mut positions)?;
//! actor.normals(&positions, &mut normals)?;
//!
//! // The f32 frame hash: the positions, then the normals.
//! assert_eq!(Some(posed_frame_hash(&positions, &normals)), replay.expected(0));
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```
//!
//! # Decoding an S2D frame
//!
//! Load the decoder, decode one frame's input (landmark displacements, see
//! [`s2d::landmark_input`]) onto a neutral face and hash the vertices. The frame is the first of
//! the decoder's golden replay, which also carries the neutral:
//!
//! ```
//! use sinew_core::hash::frame_hash;
//! use sinew_core::replay::S2dReplay;
//! use sinew_core::s2d::S2dDecoder;
//!
//! let decoder = S2dDecoder::from_bytes(include_bytes!("../../tests/data/s2d-ict.sinew"))?;
//! let replay = S2dReplay::from_bytes(include_bytes!("../../tests/data/s2d-ict.replay.sinew"))?;
//! let mut input = vec![0.0f32; decoder.input_len()];
//! replay.frame(0, &mut input).ok_or("the replay has no frame 0")?;
//! let neutral: Vec<f32> = replay.neutral().ok_or("the replay has no neutral")?.iter().collect();
//!
//! let mut scratch = vec![0.0f32; decoder.scratch_len()];
//! let mut vertices = vec![0.0f32; 3 * decoder.vertex_count()];
//! decoder.decode_onto(&neutral, &input, &mut scratch, &mut vertices)?;
//!
//! // The S2D frame hash: the decoded vertices.
//! assert_eq!(Some(frame_hash(&vertices)), replay.expected(0));
//! # Ok::<(), Box<dyn core::error::Error>>(())
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]
#![cfg_attr(
    test,
    allow(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::panic,
        clippy::indexing_slicing
    )
)]

#[cfg(test)]
extern crate std;

pub mod aim;
pub mod driver;
pub mod error;
pub mod fast;
pub mod filter;
pub mod format;
pub mod hash;
pub mod input;
pub mod jaw;
pub mod layout;
pub mod linalg;
pub mod live;
pub mod motion;
pub mod network;
pub mod nn;
pub mod performance;
pub mod q16;
pub mod replay;
pub mod rotation;
pub mod s2d;
pub mod sequence;
pub mod skinning;
pub mod sparse;
pub mod spiral;
pub mod srvf;
pub mod tensor;

pub use error::{BufferError, EvalError, FormatError, InputError, NetworkLimit};
pub use format::{ArtifactKind, Dtype, Section, SinewFile};
pub use tensor::{F32s, I32s, U32s};
