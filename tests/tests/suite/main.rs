//! Sinew's cross-crate integration tests and goldens, as one test binary: every file here is a
//! module of it.
//!
//! One binary, not one per file: each test binary links the whole host with burn (about 50 MB),
//! so a binary per file multiplied the test build's disk use and link time by the number of files.
//! Run one file's tests with a filter: `cargo test -p sinew-tests --test suite golden_aim::`.

mod aim;
mod architecture;
mod corruption;
mod driver;
mod golden_aim;
mod golden_driver;
mod golden_fit;
mod golden_kernels;
mod golden_motion;
mod golden_s2d;
mod parity;
mod refuse;
mod s2d;
mod s2d_checkpoint;
