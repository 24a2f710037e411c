//! Geometry the anatomy, S2D, motions and figures share: deformation transfer, `f64` vector
//! helpers, rigid and similarity alignment, mesh topology. Imports only [`crate::io`] (the mesh type).

pub mod align;
pub mod deformation;
pub mod qem;
pub mod spatial;
pub mod topology;
pub mod vec3;
