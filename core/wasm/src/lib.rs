//! `sinew-wasm`: Sinew's face models in a browser.
//!
//! `sinew-core` compiled to `wasm32-unknown-unknown`, with owned models, replays and fitted
//! performances (the core borrows a byte slice; here each value owns its bytes) and errors as
//! the core's messages. Two layers:
//!
//! - this module, plain safe Rust ([`Model`], [`Replay`], [`Performance`], [`frame_hash`]),
//!   tested on the host;
//! - [`exports`], the module's `extern "C"` functions, which a hand-written ES module
//!   (`core/wasm/js/sinew.mjs`) wraps into the JavaScript API of `docs/WASM.md`.
//!
//! Every value here is `f32`, computed by the core exactly as on every other target, so a frame
//! posed in the browser hashes as the host recorded it (`tests/data/*.hashes`).

mod driver;
mod error;
pub mod exports;
mod model;
mod modes;
mod motion;
mod performance;
mod replay;

pub use driver::Driver;
pub use error::{Error, Refused};
pub use model::{Kind, Model, POSE_9D, frame_hash};
pub use modes::frame_hash_q16;
pub use motion::Motion;
pub use performance::{Performance, PerformanceFrame};
pub use replay::{FrameInputs, Replay};
