//! What the trainers share on burn: the backend choice, Adam with its state on the training
//! device, layers with export to the core's sections, SIREN's sine, checkpoints, progress bars,
//! the Ctrl-C handler, the allocator tunables, the one table of core-versus-burn tolerances; and
//! the seeded random streams that every data generator and trainer draws from.

pub mod adam;
pub mod backend;
pub mod checkpoint;
pub mod interrupt;
pub mod malloc;
pub mod nn;
pub mod progress;
pub mod random;
pub mod rotation;
pub mod sine;
pub mod tensor;
pub mod tolerance;
pub mod tracker;
