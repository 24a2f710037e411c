//! Files in and out: meshes (OBJ, PLY), the ICT-FaceKit reader, ARKit captures (Live Link Face CSV), landmark tracks (OpenFace 2.0 CSV, MediaPipe Face Mesh JSON lines), performance folders, the `.sinew` writer and
//! inspector, the data-set folders (manifest and numbers), the real-data folder, a baked S2D decoder's template face, atomic outputs, and
//! `y4m` video. The lowest layer of the host: it imports
//! nothing else of the crate.

pub mod arkit;
pub mod atomic;
pub mod container;
#[cfg(any(test, feature = "test-support"))]
pub mod data;
pub mod dataset;
pub mod decoder_face;
pub mod glb;
pub mod glb_compress;
pub mod ict;
pub mod inspect;
pub mod mediapipe;
pub mod mesh;
pub mod openface;
pub mod performance;
pub mod rig;
pub mod units;
pub mod y4m;
