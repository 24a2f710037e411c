//! Where an exported actor's coordinates go. A kit actor's face frame is scaled into glTF's
//! metres; an actor learned from a rig (metadata `rig`) goes back into the rig's own skin-mesh
//! frame (in metres), onto the rig's own vertices (seam copies split again) and triangles, with
//! its texture coordinates, and its node transform above the skeleton. Either kind of actor with
//! texture coordinates per corner (a rig's OBJ `vt`, a kit actor's metadata `uv`) has its
//! vertices split where its corners disagree (`geometry::uv`).

use sinew_core::aim::AimActor;
use sinew_core::linalg::{Mat3, Vec3};

use crate::geometry::align::{M3, inv3, mat_mul, mat_vec, transpose};
use crate::geometry::uv::{self, CornerUvs};
use crate::rig::record::{Record, RecordError};

/// Why an actor's placement cannot be made.
#[derive(Debug, thiserror::Error)]
pub(crate) enum PlaceError {
    /// The actor's record of its rig is broken.
    #[error(transparent)]
    Rig(#[from] RecordError),
    /// Its texture coordinates do not fit it.
    #[error(transparent)]
    Uv(#[from] crate::geometry::uv::UvError),
}

/// The map from the actor's face frame to the exported file's.
#[derive(Debug)]
pub(crate) struct Place {
    /// Metres per actor unit (a kit actor's whole map).
    scale: f32,
    /// A rig actor's map: `x ↦ a x + c` (face frame in actor units to the rig's frame in
    /// metres), `a`'s inverse transpose for normals, and the rig.
    rig: Option<(M3, M3, [f64; 3], Record)>,
    /// Per exported vertex, the actor's vertex.
    source: Vec<u32>,
    /// The exported triangles, flat.
    triangles: Vec<u32>,
    /// Per exported vertex, its texture coordinate, when the actor has them.
    uvs: Option<Vec<[f32; 2]>>,
    /// The copies made where a vertex's corners disagree.
    seam_copies: usize,
}

impl Place {
    /// The map for `actor`, whose unit is `scale` metres.
    pub(crate) fn of(actor: &AimActor<'_>, scale: f32) -> Result<Self, PlaceError> {
        let Some(record) = crate::aim::play::rig_record(actor)? else {
            let triangles: Vec<u32> = actor.triangles().indices().iter().collect();
            let v = actor.vertex_count();
            let (source, triangles, uvs) = match actor.file().metadata().get(uv::KEY) {
                Some(value) => {
                    let split = CornerUvs::parse(value, &triangles, v)?.split(&triangles, v);
                    (split.source, split.triangles, Some(split.uvs))
                }
                None => ((0..v as u32).collect(), triangles, None),
            };
            return Ok(Self {
                scale,
                rig: None,
                seam_copies: source.len() - v,
                source,
                triangles,
                uvs,
            });
        };
        let conventions = record.conventions();
        let metres = record.units.mm() / 1000.0;
        let back = |p: [f64; 3]| -> Result<[f64; 3], RecordError> {
            conventions
                .from_face(p)
                .map(|q| q.map(|v| v * metres))
                .ok_or_else(|| RecordError::Invalid("its node transform cannot be inverted".into()))
        };
        let c = back([0.0; 3])?;
        let cols: Vec<[f64; 3]> = (0..3)
            .map(|k| {
                let mut e = [0.0; 3];
                e[k] = 1.0;
                back(e).map(|q| [q[0] - c[0], q[1] - c[1], q[2] - c[2]])
            })
            .collect::<Result<_, _>>()?;
        let a: M3 = std::array::from_fn(|r| std::array::from_fn(|k| cols[k][r]));
        let inverse =
            inv3(a).ok_or_else(|| RecordError::Invalid("its frame is degenerate".into()))?;
        // The rig's own mesh: its vertices (each an actor vertex through `welded`), triangles and
        // coordinates, per vertex or per corner; split where corners disagree.
        let mesh = record.mesh(&vec![[0.0; 3]; actor.vertex_count()]);
        let triangles: Vec<u32> = mesh.triangles().into_iter().flatten().collect();
        let rig_vertices = record.welded.len();
        let (rig_source, triangles, uvs) = match CornerUvs::of_mesh(&mesh) {
            Some(corner_uvs) => {
                let split = corner_uvs.split(&triangles, rig_vertices);
                (split.source, split.triangles, Some(split.uvs))
            }
            None => ((0..rig_vertices as u32).collect(), triangles, None),
        };
        let seam_copies = rig_source.len() - rig_vertices;
        let source = rig_source
            .iter()
            .map(|&r| record.welded[r as usize])
            .collect();
        Ok(Self {
            scale,
            seam_copies,
            rig: Some((a, transpose(inverse), c, record)),
            source,
            triangles,
            uvs,
        })
    }

    /// The exported vertex count.
    pub(crate) fn vertices(&self) -> usize {
        self.source.len()
    }

    /// The vertices added where texture coordinates disagree at a vertex.
    pub(crate) fn seam_copies(&self) -> usize {
        self.seam_copies
    }

    /// Per exported vertex, `width` values of a per-actor-vertex flat list.
    pub(crate) fn spread<T: Copy>(&self, values: &[T], width: usize) -> Vec<T> {
        self.source
            .iter()
            .flat_map(|&w| {
                values[w as usize * width..(w as usize + 1) * width]
                    .iter()
                    .copied()
            })
            .collect()
    }

    /// Flat points (`[V, 3]`, actor units) in the exported frame.
    pub(crate) fn points(&self, flat: &[f32]) -> Vec<f32> {
        match &self.rig {
            None => flat.iter().map(|x| x * self.scale).collect(),
            Some((a, _, c, _)) => self.each(flat, |p| {
                let q = mat_vec(*a, p);
                [q[0] + c[0], q[1] + c[1], q[2] + c[2]]
            }),
        }
    }

    /// Flat offsets (`[V, 3]`, actor units) in the exported frame.
    pub(crate) fn offsets(&self, flat: &[f32]) -> Vec<f32> {
        match &self.rig {
            None => flat.iter().map(|x| x * self.scale).collect(),
            Some((a, _, _, _)) => self.each(flat, |d| mat_vec(*a, d)),
        }
    }

    /// Flat unit normals in the exported frame.
    pub(crate) fn normals(&self, flat: &[f32]) -> Vec<f32> {
        match &self.rig {
            None => flat.to_vec(),
            Some((_, n, _, _)) => self.each(flat, |v| {
                let m = mat_vec(*n, v);
                let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                if len > 0.0 { m.map(|x| x / len) } else { m }
            }),
        }
    }

    fn each(&self, flat: &[f32], f: impl Fn([f64; 3]) -> [f64; 3]) -> Vec<f32> {
        flat.chunks_exact(3)
            .flat_map(|p| f([p[0], p[1], p[2]].map(f64::from)).map(|v| v as f32))
            .collect()
    }

    /// A rotation of the face frame in the exported frame (`a R a⁻¹`).
    pub(crate) fn rotation(&self, r: &Mat3) -> Mat3 {
        match &self.rig {
            None => *r,
            Some((a, n, _, _)) => {
                let m: M3 = std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        let c = r.cols[j];
                        f64::from([c.x, c.y, c.z][i])
                    })
                });
                let out = mat_mul(mat_mul(*a, m), transpose(*n));
                let col =
                    |j: usize| Vec3::new(out[0][j] as f32, out[1][j] as f32, out[2][j] as f32);
                Mat3 {
                    cols: [col(0), col(1), col(2)],
                }
            }
        }
    }

    /// The head's translation in the exported frame, for a head transform `x ↦ R x + t` of the
    /// face frame whose rotation in the exported frame is `r_out`.
    pub(crate) fn head_translation(&self, r_out: &Mat3, t: Vec3) -> [f32; 3] {
        match &self.rig {
            None => [t.x, t.y, t.z].map(|x| x * self.scale),
            Some((a, _, c, _)) => {
                let at = mat_vec(*a, [t.x, t.y, t.z].map(f64::from));
                let rc = r_out.mul_vec(Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32));
                [
                    (c[0] + at[0]) as f32 - rc.x,
                    (c[1] + at[1]) as f32 - rc.y,
                    (c[2] + at[2]) as f32 - rc.z,
                ]
            }
        }
    }

    /// The exported triangles over the exported vertices, flat.
    pub(crate) fn triangles(&self) -> &[u32] {
        &self.triangles
    }

    /// Per exported vertex, its texture coordinate, flat (none for an actor without them).
    pub(crate) fn uvs(&self) -> Option<Vec<f32>> {
        self.uvs
            .as_ref()
            .map(|uvs| uvs.iter().flatten().copied().collect())
    }

    /// The rig's node transform, column-major, when it is not the identity.
    pub(crate) fn node_transform(&self) -> Option<[f32; 16]> {
        let r = &self.rig.as_ref()?.3;
        (r.node_transform != crate::io::rig::IDENTITY).then(|| {
            let flat: Vec<f32> = r
                .node_transform
                .iter()
                .flatten()
                .map(|&v| v as f32)
                .collect();
            std::array::from_fn(|k| flat[k])
        })
    }
}
