//! Rigs made from a face whose landmarks are known, to try Sinew's rig path and to measure it:
//! the face re-meshed by quadric decimation (another topology than the source's), a UV seam cut
//! down the middle of the face (its vertices split, as exporters split them), and the result
//! written in a rig's own frame: any unit, axes and node transform. `sinew data rig` writes one
//! from ICT-FaceKit; the tests build theirs the same way.

use super::{Axis, Conventions};
use crate::geometry::qem::DecimateError;
use crate::io::mesh::Mesh;
use crate::io::rig::{IDENTITY, RigFile, RigFormat};
use crate::io::units::Unit;

/// Where a sample rig sits.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// Its unit.
    pub units: Unit,
    /// Its up axis.
    pub up: Axis,
    /// Its forward axis.
    pub forward: Axis,
    /// Its node transform (glTF), column-major.
    pub node_transform: [[f64; 4]; 4],
    /// Whether to cut a UV seam down the face's middle.
    pub seam: bool,
}

impl Placement {
    /// Centimetres, +y up, +z forward, at the origin.
    pub fn kit() -> Self {
        Self {
            units: Unit::Centimetre,
            up: Axis::PosY,
            forward: Axis::PosZ,
            node_transform: IDENTITY,
            seam: false,
        }
    }

    /// Metres, +y up, +z forward, the head turned by `yaw_deg` about +y and standing at `at`
    /// (metres): a character's head in a glTF scene.
    pub fn scene(yaw_deg: f64, at: [f64; 3]) -> Self {
        let (s, c) = yaw_deg.to_radians().sin_cos();
        Self {
            units: Unit::Metre,
            up: Axis::PosY,
            forward: Axis::PosZ,
            node_transform: [
                [c, 0.0, -s, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [s, 0.0, c, 0.0],
                [at[0], at[1], at[2], 1.0],
            ],
            seam: true,
        }
    }
}

/// A sample rig and where its landmarks truly are.
#[derive(Clone, Debug)]
pub struct Sample {
    /// The rig.
    pub file: RigFile,
    /// The 68 landmarks in the rig's own frame and units.
    pub landmarks: Vec<[f64; 3]>,
}

/// Makes a rig from a face in Sinew's face frame (centimetres, +y up, +z forward): its neutral
/// (`positions`, `triangles`), shapes (full positions, named), and landmarks (positions),
/// decimated to `vertices` and placed as `placement` says.
pub fn sample(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    shapes: &[(String, Vec<[f32; 3]>)],
    landmarks: &[[f64; 3]],
    vertices: usize,
    placement: &Placement,
) -> Result<Sample, DecimateError> {
    let (kept, tris) = if vertices < positions.len() {
        crate::geometry::qem::decimate(positions, triangles, vertices)?
    } else {
        ((0..positions.len() as u32).collect(), triangles.to_vec())
    };
    let pick = |s: &[[f32; 3]]| -> Vec<[f32; 3]> { kept.iter().map(|&v| s[v as usize]).collect() };
    let mut neutral = pick(positions);
    let mut shape_positions: Vec<Vec<[f32; 3]>> = shapes.iter().map(|(_, s)| pick(s)).collect();
    let mut polygons: Vec<Vec<u32>> = tris.iter().map(|t| t.to_vec()).collect();
    let (lo, hi) = Mesh::new(neutral.clone(), Vec::new()).bounds();
    let span = [hi[0] - lo[0], hi[1] - lo[1]].map(|v| v.max(f32::MIN_POSITIVE));
    let mut uvs: Vec<[f32; 2]> = neutral
        .iter()
        .map(|p| [0.5 * (p[0] - lo[0]) / span[0], (p[1] - lo[1]) / span[1]])
        .collect();
    if placement.seam {
        // Triangles right of the middle take their own copies of the vertices they share with
        // the left, with texture coordinates half a sheet over.
        let mid = 0.5 * (lo[0] + hi[0]);
        let right =
            |t: &Vec<u32>| t.iter().map(|&v| neutral[v as usize][0]).sum::<f32>() > 3.0 * mid;
        let mut left_uses = vec![false; neutral.len()];
        for t in polygons.iter().filter(|t| !right(t)) {
            for &v in t {
                left_uses[v as usize] = true;
            }
        }
        let mut copy: Vec<Option<u32>> = vec![None; neutral.len()];
        let rights: Vec<bool> = polygons.iter().map(right).collect();
        for (t, is_right) in polygons.iter_mut().zip(rights) {
            if !is_right {
                continue;
            }
            for v in t.iter_mut() {
                let i = *v as usize;
                if !left_uses[i] {
                    continue;
                }
                let c = *copy[i].get_or_insert_with(|| {
                    neutral.push(neutral[i]);
                    for s in &mut shape_positions {
                        s.push(s[i]);
                    }
                    uvs.push([uvs[i][0] + 0.5, uvs[i][1]]);
                    (neutral.len() - 1) as u32
                });
                *v = c;
            }
        }
    }
    // The mesh holds the face in its own unit and axes; the node transform then places it in
    // the scene, as a character's head.
    let conventions = Conventions {
        units: placement.units,
        units_guessed: false,
        up: placement.up,
        forward: placement.forward,
        node_transform: IDENTITY,
        placement: IDENTITY,
    };
    let back = |p: [f64; 3]| -> [f64; 3] {
        // Without a node transform the map always inverts.
        conventions.from_face(p).unwrap_or(p)
    };
    let own = |p: [f32; 3]| back(p.map(f64::from));
    let neutral_own: Vec<[f64; 3]> = neutral.iter().map(|&p| own(p)).collect();
    let deltas = shape_positions
        .iter()
        .map(|s| {
            s.iter()
                .zip(&neutral_own)
                .map(|(&p, n)| {
                    let q = own(p);
                    [0, 1, 2].map(|k| (q[k] - n[k]) as f32)
                })
                .collect()
        })
        .collect();
    let mut mesh = Mesh::new(
        neutral_own.iter().map(|p| p.map(|v| v as f32)).collect(),
        polygons,
    );
    mesh.uvs = uvs;
    Ok(Sample {
        file: RigFile {
            path: "sample".into(),
            format: RigFormat::Gltf,
            mesh_name: "head".into(),
            neutral: mesh,
            shape_names: shapes.iter().map(|(n, _)| n.clone()).collect(),
            deltas,
            node_transform: placement.node_transform,
            units: Some(placement.units),
            extensions: Vec::new(),
            avatar: None,
        },
        landmarks: landmarks.iter().map(|&p| back(p)).collect(),
    })
}

/// Why a sample rig could not be made from the kit.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SampleError {
    /// The kit could not be read.
    #[error(transparent)]
    Kit(#[from] crate::io::ict::IctError),
    /// The face could not be decimated.
    #[error("decimating the ICT-FaceKit face region")]
    Decimate(#[from] DecimateError),
    /// A kit landmark off the face region.
    #[error("the kit's landmark {0} is not on the face region")]
    Landmark(usize),
}

/// A sample rig from ICT-FaceKit in `data`: an identity (`identity`: weights of the kit's
/// identity modes), the face region with all of the kit's expression shapes, decimated to
/// `vertices` and placed as `placement` says; its landmarks are the kit's.
pub fn from_kit(
    data: &std::path::Path,
    identity: &[f32],
    vertices: usize,
    placement: &Placement,
) -> Result<Sample, SampleError> {
    use crate::io::ict::{FACE_REGION, IctFaceKit};
    let kit = IctFaceKit::open(data)?;
    let names = kit.expression_names();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let actor = kit.actor(identity, &refs, FACE_REGION)?;
    let landmarks = actor
        .landmarks
        .iter()
        .enumerate()
        .map(|(k, l)| {
            l.map(|l| actor.template.positions[l as usize].map(f64::from))
                .ok_or(SampleError::Landmark(k))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let shapes: Vec<(String, Vec<[f32; 3]>)> = actor.names[1..]
        .iter()
        .cloned()
        .zip(actor.shapes[1..].iter().cloned())
        .collect();
    Ok(sample(
        &actor.template.positions,
        &actor.template.triangles(),
        &shapes,
        &landmarks,
        vertices,
        placement,
    )?)
}
