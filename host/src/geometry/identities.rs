//! Random identities on ICT-FaceKit's face region, each performing the kit's expressions in its
//! own way: what `sinew data s2d-pairs` and `sinew data motions` are both made of.
//!
//! An identity is the generic neutral plus Σ_m w_m · identity_m over the kit's identity modes
//! (weights in standard deviations, drawn by the caller); an expression delta of the generic face
//! is moved onto an identity by deformation transfer ([`super::deformation`]).

use std::ops::Range;
use std::path::PathBuf;

use crate::io::ict::{FACE_REGION, IctError, IctFaceKit};
use crate::io::mesh::Mesh;

/// A kit whose face region cannot carry identities, or expressions that cannot be transferred;
/// each names the kit's folder or the identity.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RegionError {
    /// A kit file cannot be read (the error names it).
    #[error(transparent)]
    Kit(#[from] IctError),
    /// A kit neutral smaller than the face region.
    #[error(
        "{}: the neutral has {found} vertices, the face region needs {needed}",
        path.display()
    )]
    NeutralVertices {
        /// The kit's folder.
        path: PathBuf,
        /// The neutral's vertices.
        found: usize,
        /// The face region's end.
        needed: usize,
    },
    /// A face region that does not keep the kit's vertex order.
    #[error("{}: the face region does not keep the kit's vertex order", path.display())]
    VertexOrder {
        /// The kit's folder.
        path: PathBuf,
    },
    /// A kit landmark outside the face region.
    #[error("{}: landmark vertex {vertex} lies outside the face region", path.display())]
    LandmarkOutside {
        /// The kit's folder.
        path: PathBuf,
        /// The landmark's vertex.
        vertex: u32,
    },
    /// The expressions cannot be transferred onto an identity.
    #[error("transferring the expressions onto identity {identity}")]
    Transfer {
        /// The identity.
        identity: usize,
        /// What the deformation transfer said.
        #[source]
        source: super::deformation::TransferError,
    },
}

/// The kit's face region ([`FACE_REGION`], a prefix of its vertices) with some of its
/// expressions, ready to be given identities.
#[derive(Clone, Debug)]
pub struct FaceRegion {
    /// The generic neutral's face region, triangulated.
    pub template: Mesh,
    /// Its triangles.
    pub triangles: Vec<[u32; 3]>,
    /// The 68 landmark vertices (iBUG order), indices into the region.
    pub landmarks: Vec<u32>,
    /// The expressions' deltas on the generic neutral's region, in the order asked for.
    pub deltas: Vec<Vec<[f32; 3]>>,
    /// The first identity modes' deltas on the region.
    modes: Vec<Vec<[f32; 3]>>,
}

impl FaceRegion {
    /// The face region of `kit` with the deltas of `expressions` and of its first `modes`
    /// identity modes.
    ///
    /// # Errors
    /// A kit file that cannot be read, a neutral smaller than the region, a region that does not
    /// keep the vertex order, a landmark outside the region; each naming the kit.
    pub fn of(
        kit: &IctFaceKit,
        expressions: &[impl AsRef<str>],
        modes: usize,
    ) -> Result<Self, RegionError> {
        let region = region();
        let full = kit.neutral();
        if full.positions.len() < region.end {
            return Err(RegionError::NeutralVertices {
                path: kit.dir().to_owned(),
                found: full.positions.len(),
                needed: region.end,
            });
        }
        let (template, old_index) = full.submesh(|v| FACE_REGION.contains(&v));
        // The face region is a prefix of the topology, so vertex indices are unchanged.
        if !old_index.iter().enumerate().all(|(i, &o)| i == o as usize) {
            return Err(RegionError::VertexOrder {
                path: kit.dir().to_owned(),
            });
        }
        let landmarks = kit.landmarks68()?;
        if let Some(&l) = landmarks.iter().find(|&&l| !FACE_REGION.contains(&l)) {
            return Err(RegionError::LandmarkOutside {
                path: kit.dir().to_owned(),
                vertex: l,
            });
        }
        let crop = |d: Vec<[f32; 3]>| d[region.clone()].to_vec();
        let deltas = kit
            .expression_deltas(expressions)?
            .into_iter()
            .map(crop)
            .collect();
        let modes = kit.identity_deltas(modes)?.into_iter().map(crop).collect();
        let triangles = template.triangles();
        let template = Mesh::new(
            template.positions.clone(),
            triangles.iter().map(|t| t.to_vec()).collect(),
        );
        Ok(Self {
            template,
            triangles,
            landmarks,
            deltas,
            modes,
        })
    }

    /// The region's vertices.
    pub fn vertices(&self) -> usize {
        self.template.positions.len()
    }

    /// The neutral of the identity with `weights` (one per mode, in standard deviations; missing
    /// ones are 0), summed in mode order in `f32`: the same sums on every run.
    pub fn neutral(&self, weights: &[f32]) -> Vec<[f32; 3]> {
        let mut p = self.template.positions.clone();
        for (wm, d) in weights.iter().zip(&self.modes) {
            for (p, d) in p.iter_mut().zip(d) {
                for c in 0..3 {
                    p[c] += wm * d[c];
                }
            }
        }
        p
    }

    /// Every expression delta transferred onto every neutral of `neutrals`, identity-major
    /// (`[identities × expressions][vertices]`); one factorisation per identity, identities in
    /// parallel.
    ///
    /// # Errors
    /// An identity the transfer cannot be set up on, naming it.
    pub fn transferred(
        &self,
        neutrals: &[Vec<[f32; 3]>],
    ) -> Result<Vec<Vec<[f32; 3]>>, RegionError> {
        use rayon::prelude::*;
        let sources: Vec<&[[f32; 3]]> = self.deltas.iter().map(Vec::as_slice).collect();
        let per_identity: Vec<Vec<Vec<[f32; 3]>>> = neutrals
            .par_iter()
            .enumerate()
            .map(|(i, n)| {
                let transfer = |source| RegionError::Transfer {
                    identity: i,
                    source,
                };
                super::deformation::Transfer::new(
                    &self.template.positions,
                    n,
                    &self.triangles,
                    &format!("identity {i}"),
                )
                .map_err(&transfer)?
                .apply(&sources)
                .map_err(transfer)
            })
            .collect::<Result<_, _>>()?;
        Ok(per_identity.into_iter().flatten().collect())
    }
}

/// [`FACE_REGION`] as vertex indices.
fn region() -> Range<usize> {
    FACE_REGION.start as usize..FACE_REGION.end as usize
}
