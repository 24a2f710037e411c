//! A studio's blendshape rig made ready for Sinew: where its coordinates sit (units, up and
//! forward axes, the node's place in its scene), its seam vertices welded, its shapes bound to
//! ARKit's names, and its 68 landmarks found by registering the built-in face template onto it.
//! Resolved here once; the result is Sinew's face frame (centimetres, +Y up, +Z forward, the
//! kit's), and [`Conventions`] maps back to the rig's own.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::geometry::weld::{Weld, weld};
use crate::io::arkit::arkit_bindings;
use crate::io::mesh::Mesh;
use crate::io::rig::{IDENTITY, RigFile, RigReadError};
use crate::io::units::Unit;

pub mod correspond;
pub mod inspect;
pub mod landmarks;
pub mod record;
pub mod sample;
pub mod template;

/// Centimetres per millimetre: Sinew's face frame is in centimetres.
const CM_PER_MM: f64 = 0.1;

/// A head's width (cm, across x in the face frame) taken as the size a unit guess aims for.
const HEAD_WIDTH_CM: f64 = 16.0;

/// A coordinate axis with its direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// +x
    PosX,
    /// −x
    NegX,
    /// +y
    PosY,
    /// −y
    NegY,
    /// +z
    PosZ,
    /// −z
    NegZ,
}

impl Axis {
    /// `+x` … `-z`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::PosX => "+x",
            Self::NegX => "-x",
            Self::PosY => "+y",
            Self::NegY => "-y",
            Self::PosZ => "+z",
            Self::NegZ => "-z",
        }
    }

    /// The axis closest to the direction `v`.
    pub fn nearest(v: [f64; 3]) -> Self {
        let all = [
            Self::PosX,
            Self::NegX,
            Self::PosY,
            Self::NegY,
            Self::PosZ,
            Self::NegZ,
        ];
        all.into_iter()
            .max_by(|a, b| {
                crate::geometry::vec3::dot(a.vector(), v)
                    .total_cmp(&crate::geometry::vec3::dot(b.vector(), v))
            })
            .unwrap_or(Self::PosY)
    }

    /// The unit vector.
    pub const fn vector(self) -> [f64; 3] {
        match self {
            Self::PosX => [1.0, 0.0, 0.0],
            Self::NegX => [-1.0, 0.0, 0.0],
            Self::PosY => [0.0, 1.0, 0.0],
            Self::NegY => [0.0, -1.0, 0.0],
            Self::PosZ => [0.0, 0.0, 1.0],
            Self::NegZ => [0.0, 0.0, -1.0],
        }
    }
}

impl std::str::FromStr for Axis {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim().to_ascii_lowercase();
        let t = t.strip_prefix('+').unwrap_or(&t);
        Ok(match t {
            "x" => Self::PosX,
            "-x" => Self::NegX,
            "y" => Self::PosY,
            "-y" => Self::NegY,
            "z" => Self::PosZ,
            "-z" => Self::NegZ,
            _ => return Err(format!("{s:?} is not an axis (+x, -x, +y, -y, +z or -z)")),
        })
    }
}

impl Serialize for Axis {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Where a rig's coordinates sit, and the map between them and Sinew's face frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conventions {
    /// The rig's length unit.
    pub units: Unit,
    /// Whether the unit was guessed from the head's size (an OBJ rig without `--units`).
    pub units_guessed: bool,
    /// The rig's up axis.
    pub up: Axis,
    /// The axis the face looks along.
    pub forward: Axis,
    /// The skin mesh's coordinates to its scene's, column-major (glTF's node transforms).
    pub node_transform: [[f64; 4]; 4],
    /// The head's place in its scene: Sinew's face frame from the scene's (in centimetres, up
    /// and forward resolved), a rotation and a translation, column-major. Found by registering
    /// the face template, so that the face frame is the kit's whichever way the head turns.
    pub placement: [[f64; 4]; 4],
}

impl Conventions {
    /// The face frame's x axis in the scene: up × forward.
    pub(crate) fn right(&self) -> [f64; 3] {
        crate::geometry::vec3::cross(self.up.vector(), self.forward.vector())
    }

    fn scale(&self) -> f64 {
        self.units.mm() * CM_PER_MM
    }

    /// A point of the skin mesh in the face frame (cm).
    pub fn to_face(&self, p: [f32; 3]) -> [f64; 3] {
        let m = &self.node_transform;
        let q: [f64; 3] = std::array::from_fn(|r| {
            (0..3).map(|c| m[c][r] * f64::from(p[c])).sum::<f64>() + m[3][r]
        });
        transform(&self.placement, self.axes(q), true)
    }

    /// An offset of the skin mesh in the face frame (cm).
    pub fn offset_to_face(&self, d: [f32; 3]) -> [f64; 3] {
        let m = &self.node_transform;
        let q: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| m[c][r] * f64::from(d[c])).sum::<f64>());
        transform(&self.placement, self.axes(q), false)
    }

    fn axes(&self, q: [f64; 3]) -> [f64; 3] {
        use crate::geometry::vec3::dot;
        let s = self.scale();
        [
            dot(q, self.right()) * s,
            dot(q, self.up.vector()) * s,
            dot(q, self.forward.vector()) * s,
        ]
    }

    /// A point of the face frame back in the skin mesh's own coordinates; `None` when the node
    /// transform cannot be inverted.
    pub fn from_face(&self, f: [f64; 3]) -> Option<[f64; 3]> {
        // The placement is rigid: its inverse is its transpose.
        let p = &self.placement;
        let g = [f[0] - p[3][0], f[1] - p[3][1], f[2] - p[3][2]];
        let f: [f64; 3] = std::array::from_fn(|k| (0..3).map(|r| p[k][r] * g[r]).sum());
        let s = self.scale();
        let (r, u, w) = (self.right(), self.up.vector(), self.forward.vector());
        let q: [f64; 3] = std::array::from_fn(|k| (f[0] * r[k] + f[1] * u[k] + f[2] * w[k]) / s);
        let m = &self.node_transform;
        let a: crate::geometry::align::M3 =
            std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]));
        let inv = crate::geometry::align::inv3(a)?;
        let t = [q[0] - m[3][0], q[1] - m[3][1], q[2] - m[3][2]];
        Some(crate::geometry::align::mat_vec(inv, t))
    }
}

/// `m` (column-major 4 × 4) applied to a point (`point`) or a direction.
fn transform(m: &[[f64; 4]; 4], v: [f64; 3], point: bool) -> [f64; 3] {
    let w = if point { 1.0 } else { 0.0 };
    std::array::from_fn(|r| (0..3).map(|c| m[c][r] * v[c]).sum::<f64>() + w * m[3][r])
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
    /// The forward axis.
    pub forward: Axis,
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
            forward: Axis::PosZ,
            landmarks: None,
        }
    }
}

/// Why a rig cannot be used, always naming the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    /// The files could not be read.
    #[error(transparent)]
    Read(#[from] RigReadError),
    /// Up and forward are the same line.
    #[error("{}: up {} and forward {} are not perpendicular", path.display(), up.name(), forward.name())]
    Axes {
        /// The rig.
        path: PathBuf,
        /// Up.
        up: Axis,
        /// Forward.
        forward: Axis,
    },
    /// No unit makes the head a head's size.
    #[error(
        "{}: cannot tell the unit: the head is {width} units wide, which is no head's width in \
         mm, cm or m; pass --units",
        path.display()
    )]
    Units {
        /// The rig.
        path: PathBuf,
        /// The width across the face frame's x, in the file's units.
        width: f64,
    },
    /// The node transform flattens the mesh.
    #[error("{}: the skin mesh's node transform cannot be inverted", path.display())]
    NodeTransform {
        /// The rig.
        path: PathBuf,
    },
    /// The registration cannot start or did not hold on the rig's surface.
    #[error("{}: {what}", path.display())]
    Registration {
        /// The rig.
        path: PathBuf,
        /// What went wrong.
        what: String,
    },
    /// A landmarks file that cannot be used.
    #[error("{}: {what}", path.display())]
    Landmarks {
        /// The landmarks file.
        path: PathBuf,
        /// What is wrong.
        what: String,
    },
    /// The built-in face template is broken.
    #[error(transparent)]
    Template(#[from] template::TemplateError),
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
        if crate::geometry::vec3::norm(crate::geometry::vec3::cross(
            options.up.vector(),
            options.forward.vector(),
        )) < 0.5
        {
            return Err(RigError::Axes {
                path: path.to_owned(),
                up: options.up,
                forward: options.forward,
            });
        }
        let mut conventions = Conventions {
            units: options.units.or(file.units).unwrap_or(Unit::Centimetre),
            units_guessed: options.units.is_none() && file.units.is_none(),
            up: options.up,
            forward: options.forward,
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
