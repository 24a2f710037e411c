//! Skin landmarks derived from the 68 iBUG landmarks, and the face frame they span.

use super::error::BonesError;
use super::templates::{SkinRule, spec};
use crate::geometry::spatial::{components, nearest_in_component, oriented_normals};
use crate::geometry::vec3::{cross, dot, lerp, norm, normalize, scale, sub, to32, to64};
use crate::io::mesh::Mesh;
use serde::Serialize;
use std::collections::BTreeMap;

/// Skin landmarks on an actor's neutral mesh: landmark name (as in the bone landmark file) →
/// skin vertex, plus the mesh's unit.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinLandmarks {
    /// Skin vertex of each landmark by name.
    pub vertices: BTreeMap<String, u32>,
    /// Millimetres per mesh unit (10 for ICT's cm).
    pub mm_per_unit: f32,
}

impl SkinLandmarks {
    /// Derives the skin landmarks from the 68 iBUG landmark vertices (`None` where a landmark is
    /// not on the mesh; landmarks that need it are left out), following each bone landmark's
    /// [`SkinRule`].
    pub fn from_ibug68(
        neutral: &Mesh,
        ibug: &[Option<u32>],
        mm_per_unit: f32,
    ) -> Result<Self, BonesError> {
        if ibug.len() != 68 {
            return Err(BonesError::IbugCount { given: ibug.len() });
        }
        if !(mm_per_unit > 0.0 && mm_per_unit.is_finite()) {
            return Err(BonesError::MmPerUnit { mm_per_unit });
        }
        neutral
            .validate()
            .map_err(|source| BonesError::InvalidNeutral {
                purpose: "find skin landmarks on",
                source,
            })?;
        let nv = neutral.positions.len();
        if let Some(&v) = ibug.iter().flatten().find(|&&v| v as usize >= nv) {
            return Err(BonesError::IbugVertex {
                vertex: v,
                vertices: nv,
            });
        }
        let comp = components(neutral);
        let normals = oriented_normals(neutral, &comp);
        let p = |k: usize| ibug.get(k).copied().flatten();
        let spec = spec()?;
        let rules = spec
            .landmarks
            .iter()
            .filter_map(|l| Some((&l.name, l.skin.as_ref()?)))
            .chain(spec.patches.iter().map(|p| (&p.name, &p.skin)));
        let mut vertices = BTreeMap::new();
        for (name, rule) in rules {
            let v = match *rule {
                SkinRule::Ibug { ibug } => p(ibug),
                SkinRule::Between { between: [a, b], t } => match (p(a), p(b)) {
                    (Some(a), Some(b)) => {
                        let (pa, pb) = (
                            to64(neutral.positions[a as usize]),
                            to64(neutral.positions[b as usize]),
                        );
                        let q = lerp(pa, pb, t as f64);
                        nearest_in_component(neutral, &comp, comp[a as usize], q)
                    }
                    _ => None,
                },
                SkinRule::LowestNear {
                    lowest_near,
                    radius_mm,
                } => match (p(lowest_near), p(27), p(8)) {
                    (Some(c), Some(top), Some(chin)) => {
                        let down = normalize(sub(
                            to64(neutral.positions[chin as usize]),
                            to64(neutral.positions[top as usize]),
                        ));
                        let centre = to64(neutral.positions[c as usize]);
                        let r = (radius_mm / mm_per_unit) as f64;
                        (0..nv)
                            .filter(|&v| comp[v] == comp[c as usize])
                            .filter(|&v| norm(sub(to64(neutral.positions[v]), centre)) <= r)
                            .max_by(|&a, &b| {
                                dot(normals[a], down)
                                    .total_cmp(&dot(normals[b], down))
                                    .then(b.cmp(&a))
                            })
                            .map(|v| v as u32)
                    }
                    _ => None,
                },
            };
            if let Some(v) = v {
                vertices.insert(name.clone(), v);
            }
        }
        Ok(Self {
            vertices,
            mm_per_unit,
        })
    }
}

/// An orthonormal frame of the face from its skin landmarks: `up` from menton to nasion, `left`
/// from the right to the left zygion made orthogonal to `up`, and `forward = left × up`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct FaceFrame {
    /// The subject's left.
    pub left: [f32; 3],
    /// Up.
    pub up: [f32; 3],
    /// Anterior.
    pub forward: [f32; 3],
}

impl FaceFrame {
    /// The frame from the `nasion`, `menton`, `zygion_l` and `zygion_r` skin landmarks.
    pub fn new(neutral: &Mesh, skin: &SkinLandmarks) -> Result<Self, BonesError> {
        let get = |n: &str| -> Result<[f64; 3], BonesError> {
            let v = skin
                .vertices
                .get(n)
                .ok_or_else(|| BonesError::SkinLandmarkMissing {
                    name: n.to_string(),
                    needed_for: "the face frame",
                })?;
            neutral
                .positions
                .get(*v as usize)
                .map(|p| to64(*p))
                .ok_or_else(|| BonesError::SkinLandmarkVertex {
                    name: n.to_string(),
                    vertex: *v,
                    vertices: neutral.positions.len(),
                })
        };
        let up = normalize(sub(get("nasion")?, get("menton")?));
        let l = sub(get("zygion_l")?, get("zygion_r")?);
        let left = normalize(sub(l, scale(up, dot(l, up))));
        let forward = cross(left, up);
        if !(norm(up) > 0.5 && norm(left) > 0.5) {
            return Err(BonesError::DegenerateFrame);
        }
        Ok(Self {
            left: to32(left),
            up: to32(up),
            forward: to32(forward),
        })
    }
}
