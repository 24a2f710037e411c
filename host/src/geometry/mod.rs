//! Geometry the anatomy, S2D and figures share: `f64` vector helpers, rigid and similarity
//! alignment, mesh topology. Imports only [`crate::io`] (the mesh type).

pub mod align;
pub mod qem;
pub mod spatial;
pub mod topology;
pub mod vec3;
