//! What AIM and S2D training share on burn: the backend choice, layers with export to the core's
//! sections, SIREN's sine, checkpoints, progress bars, the Ctrl-C handler, the allocator tunables,
//! and the one table of core-versus-burn tolerances.

pub mod backend;
pub mod checkpoint;
pub mod interrupt;
pub mod malloc;
pub mod nn;
pub mod progress;
pub mod rotation;
pub mod sine;
pub mod tensor;
pub mod tolerance;
