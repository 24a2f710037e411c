//! `sinew-core`: loads baked Sinew face models from bytes, validates them once, and evaluates them
//! with deterministic, allocation-free arithmetic.
//!
//! Every float operation goes through `libm` free functions in a fixed order, so the same model
//! and inputs give the same output bits on every target (x86_64, Cortex-M, RISC-V, wasm). See
//! `docs/ARCHITECTURE.md` for the invariants and `docs/FORMAT.md` for the byte format.
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
pub mod error;
pub mod fast;
pub mod format;
pub mod hash;
pub mod layout;
pub mod linalg;
pub mod network;
pub mod nn;
pub mod q16;
pub mod replay;
pub mod rotation;
pub mod s2d;
pub mod skinning;
pub mod sparse;
pub mod spiral;
pub mod tensor;

pub use error::{BufferError, FormatError};
pub use format::{ArtifactKind, Dtype, Section, SinewFile};
pub use tensor::{F32s, I32s, U32s};
