//! The host's integration tests, as one test binary: every file here is a module of it.
//!
//! One binary, not one per file: each test binary links the whole host with burn (about 50 MB),
//! so a binary per file multiplied the test build's disk use and link time by the number of files.
//! Run one file's tests with a filter: `cargo test -p sinew-host --test suite gltf_carry::`.

mod common;

mod arkit_jaw;
mod cli;
mod decoder_face;
mod driver_cli;
mod gltf;
mod gltf_carry;
mod gltf_seams;
mod gltfpack;
mod motion_cli;
mod obj_carry;
mod playback_cli;
mod retarget;
mod rig_formats;
mod rig_indices;
mod rigs;
mod s2d_cli;
mod vrm;
