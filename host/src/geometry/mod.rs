//! Geometry the anatomy, S2D, motions and figures share: deformation transfer, random identities
//! on the kit's face region, `f64` vector helpers, rigid and similarity alignment, mesh topology.
//! Imports only [`crate::io`] (the mesh type and the ICT-FaceKit loader).

pub mod align;
pub mod deformation;
pub mod identities;
pub(crate) mod nicp;
pub mod qem;
pub mod spatial;
pub mod surface;
pub mod symmetry;
pub mod topology;
pub mod uv;
pub mod vec3;
pub mod weld;
