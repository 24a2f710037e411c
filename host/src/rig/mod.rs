//! A studio's blendshape rig made ready for Sinew: where its coordinates sit (units, up and
//! forward axes, the node's place in its scene), its seam vertices welded, its shapes bound to
//! ARKit's names, and its 68 landmarks found by registering the built-in face template onto it.
//! Resolved here once; the result is Sinew's face frame (centimetres, +Y up, +Z forward, the
//! kit's), and [`Conventions`] maps back to the rig's own.

use std::path::{Path, PathBuf};

use crate::geometry::weld::{Weld, weld};
use crate::io::arkit::arkit_bindings;
use crate::io::mesh::Mesh;
use crate::io::rig::{IDENTITY, RigFile};
use crate::io::units::Unit;

mod conventions;
pub mod correspond;
mod error;
pub mod inspect;
pub mod landmarks;
pub mod record;
pub mod sample;
pub mod template;

pub use conventions::{Axis, Conventions};
use conventions::{CM_PER_MM, transform};
pub use error::RigError;

/// A head's width (cm, across x in the face frame) taken as the size a unit guess aims for.
const HEAD_WIDTH_CM: f64 = 16.0;

/// The way a rig's face looks when no option says: glTF's front, +z (VRM 1.0's too), or −z for a
/// VRM 0.x avatar, which that specification turns to face −z.
pub fn default_forward(file: &RigFile) -> Axis {
    if file.avatar.as_ref().is_some_and(|a| a.version == "0.x") {
        Axis::NegZ
    } else {
        Axis::PosZ
    }
}

/// How to read a rig: the options a command line gives.
#[derive(Clone, Debug, PartialEq)]
pub struct RigOptions {
    /// The skin mesh's name (glTF); `None`: the mesh with the most morph targets.
    pub mesh: Option<String>,
    /// The unit; `None`: glTF's metres, or guessed from an OBJ head's size.
    pub units: Option<Unit>,
    /// The up axis.
    pub up: Axis,
    /// The forward axis; `None`: the file's own, +z (glTF's front, VRM 1.0's), or −z for a VRM
    /// 0.x avatar, which its specification turns to face −z.
    pub forward: Option<Axis>,
    /// A file of the 68 landmarks (vertex indices or positions in the rig's own frame);
    /// `None`: found by registering the face template.
    pub landmarks: Option<PathBuf>,
}

impl Default for RigOptions {
    fn default() -> Self {
        Self {
            mesh: None,
            units: None,
            up: Axis::PosY,
            forward: None,
            landmarks: None,
        }
    }
}

/// A rig resolved: its file, conventions, welding, the welded skin in the face frame, and its
/// landmarks.
#[derive(Clone, Debug)]
pub struct Rig {
    /// The rig as read.
    pub file: RigFile,
    /// Where its coordinates sit.
    pub conventions: Conventions,
    /// Its seam vertices welded.
    pub weld: Weld,
    /// The welded neutral in the face frame (cm): positions and polygons.
    pub face: Mesh,
    /// Each shape's welded offsets in the face frame (cm).
    pub deltas: Vec<Vec<[f32; 3]>>,
    /// Per ARKit blendshape, the rig's shapes that play it.
    pub arkit: Vec<(String, Vec<usize>)>,
    /// The 68 landmarks, the registered template and the jaw hinge, in the face frame.
    pub landmarks: landmarks::Found,
}

impl Rig {
    /// Reads the rig at `path` and resolves it: conventions, welding, landmarks and the head's
    /// placement.
    pub fn open(path: &Path, options: &RigOptions) -> Result<Self, RigError> {
        let file = RigFile::read(path, options.mesh.as_deref())?;
        let forward = options.forward.unwrap_or_else(|| default_forward(&file));
        if crate::geometry::vec3::norm(crate::geometry::vec3::cross(
            options.up.vector(),
            forward.vector(),
        )) < 0.5
        {
            return Err(RigError::Axes {
                path: path.to_owned(),
                up: options.up,
                forward,
            });
        }
        let mut conventions = Conventions {
            units: options.units.or(file.units).unwrap_or(Unit::Centimetre),
            units_guessed: options.units.is_none() && file.units.is_none(),
            up: options.up,
            forward,
            node_transform: file.node_transform,
            placement: IDENTITY,
        };
        if conventions.from_face([0.0; 3]).is_none() {
            return Err(RigError::NodeTransform {
                path: path.to_owned(),
            });
        }
        if conventions.units_guessed {
            conventions.units = guess_units(&file, &conventions)?;
        }
        let diagonal = {
            let (lo, hi) = file.neutral.bounds();
            (0..3)
                .map(|k| f64::from(hi[k] - lo[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let weld = weld(&file.neutral.positions, &file.deltas, diagonal * 1e-6);
        // The scene's frame first (placement still the identity); the landmarks place the head.
        let scene: Vec<[f64; 3]> = weld
            .pick(&file.neutral.positions)
            .iter()
            .map(|&p| conventions.to_face(p))
            .collect();
        let polygons = weld.polygons(&file.neutral.polygons);
        let template = template::FaceTemplate::builtin()?;
        let target = landmarks::Target {
            path,
            surface: crate::geometry::surface::Surface::new(
                scene.clone(),
                Mesh::new(Vec::new(), polygons.clone()).triangles(),
            ),
            weld: &weld,
            conventions: &conventions,
            vertices: file.vertex_count(),
        };
        let found = match &options.landmarks {
            Some(list) => landmarks::from_file(&target, list, &template)?,
            None => landmarks::register_template(&target, &template)?,
        };
        conventions.placement = found.placement();
        let place = |p: [f64; 3]| transform(&conventions.placement, p, true);
        let face = Mesh::new(
            scene.iter().map(|&p| place(p).map(|v| v as f32)).collect(),
            polygons,
        );
        let found = found.placed(&place);
        let deltas = file
            .deltas
            .iter()
            .map(|d| {
                weld.pick(d)
                    .iter()
                    .map(|&d| conventions.offset_to_face(d).map(|v| v as f32))
                    .collect()
            })
            .collect();
        let arkit = arkit_bindings(&file.shape_names);
        Ok(Self {
            file,
            conventions,
            weld,
            face,
            deltas,
            arkit,
            landmarks: found,
        })
    }

    /// The rig's file or folder.
    pub fn path(&self) -> &Path {
        &self.file.path
    }

    /// The shapes' names, as the rig names them.
    pub fn names(&self) -> &[String] {
        &self.file.shape_names
    }

    /// The ARKit blendshapes the rig has no shape for.
    pub fn arkit_missing(&self) -> Vec<&str> {
        self.arkit
            .iter()
            .filter(|(_, s)| s.is_empty())
            .map(|(a, _)| a.as_str())
            .collect()
    }
}

/// The unit that makes the head's width (across the face frame's x) closest to a head's.
fn guess_units(file: &RigFile, conventions: &Conventions) -> Result<Unit, RigError> {
    let as_cm = Conventions {
        units: Unit::Centimetre,
        ..conventions.clone()
    };
    let xs: Vec<f64> = file
        .neutral
        .positions
        .iter()
        .map(|&p| as_cm.to_face(p)[0])
        .collect();
    let width = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - xs.iter().copied().fold(f64::INFINITY, f64::min);
    [Unit::Millimetre, Unit::Centimetre, Unit::Metre]
        .into_iter()
        .map(|u| (u, width * u.mm() * CM_PER_MM))
        .filter(|&(_, cm)| (4.0..=80.0).contains(&cm))
        .min_by(|a, b| {
            let off = |cm: f64| (cm / HEAD_WIDTH_CM).ln().abs();
            off(a.1).total_cmp(&off(b.1))
        })
        .map(|(u, _)| u)
        .ok_or(RigError::Units {
            path: file.path.clone(),
            width,
        })
}
