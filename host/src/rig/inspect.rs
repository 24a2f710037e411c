//! `sinew rig inspect`: what Sinew understood of a rig, as a report (units, axes, vertex counts,
//! shapes, the ARKit binding, the 68 landmarks, the symmetry plane, the jaw hinge) and pictures
//! of the neutral from the front and the side with the landmarks drawn.

use std::collections::BTreeMap;
use std::path::Path;

use serde::Serialize;

use super::landmarks::{Found, Landmark, Method};
use super::{Axis, Rig, RigError};
use crate::figures::render::{Image, PngError, View, render};
use crate::geometry::symmetry::symmetry_plane;
use crate::geometry::vec3::{norm, sub, to64};
use crate::io::atomic::{AtomicWriteError, WriteStep};
use crate::io::rig::{Avatar, ExtensionUse};

/// Why `rig inspect` could not finish.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum InspectError {
    /// The rig could not be read or resolved.
    #[error(transparent)]
    Rig(#[from] RigError),
    /// The report could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// The report could not be laid out as JSON.
    #[error("laying out the rig report as JSON")]
    Encode(#[source] serde_json::Error),
    /// A picture could not be written.
    #[error(transparent)]
    Png(#[from] PngError),
}

/// The ARKit binding: which rig shapes play each ARKit blendshape, and which the rig lacks.
#[derive(Clone, Debug, Serialize)]
pub struct ArkitReport {
    /// ARKit name → the rig's shapes that play it.
    pub bound: BTreeMap<String, Vec<String>>,
    /// The ARKit blendshapes no shape plays.
    pub missing: Vec<String>,
}

/// A plane in the rig's own frame.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct PlaneReport {
    /// Unit normal.
    pub normal: [f64; 3],
    /// A point on it.
    pub origin: [f64; 3],
}

/// `rig.json`.
#[derive(Clone, Debug, Serialize)]
pub struct RigReport {
    /// The rig's file or folder.
    pub rig: String,
    /// `gltf` or `obj`.
    pub format: &'static str,
    /// The skin mesh.
    pub mesh: String,
    /// The glTF extensions the rig uses, each with whether it is required and what Sinew made
    /// of it (`decoded`, or `not_read`: it concerns only what Sinew does not read).
    pub extensions: Vec<ExtensionUse>,
    /// A VRM avatar's expressions as shapes: each one's morph target binds and weights, and
    /// the expressions not taken and why.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vrm: Option<Avatar>,
    /// The rig's length unit.
    pub units: &'static str,
    /// Whether the unit was guessed from the head's size.
    pub units_guessed: bool,
    /// The up axis.
    pub up: Axis,
    /// The forward axis.
    pub forward: Axis,
    /// The skin mesh's node transform, column-major.
    pub node_transform: [[f64; 4]; 4],
    /// Vertices as the rig has them (seam copies counted).
    pub vertex_count: usize,
    /// Vertices once seams are welded.
    pub welded_vertex_count: usize,
    /// The shapes' names, as the rig names them.
    pub shapes: Vec<String>,
    /// The ARKit binding.
    pub arkit: ArkitReport,
    /// The 68 iBUG landmarks, in order, in the rig's own frame and units.
    pub landmarks: Vec<Landmark>,
    /// How they were found.
    pub landmark_method: Method,
    /// The plane of left-right symmetry, in the rig's own frame.
    pub symmetry_plane: PlaneReport,
    /// The jaw's hinge, in the rig's own frame.
    pub jaw_pivot: [f64; 3],
    /// Against known landmarks (`--truth`): each landmark's distance from its true place.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub landmark_error_mm: Option<LandmarkError>,
}

/// The landmarks' distances from where they truly are, in millimetres.
#[derive(Clone, Debug, Serialize)]
pub struct LandmarkError {
    /// The mean.
    pub mean: f64,
    /// The median.
    pub median: f64,
    /// The largest.
    pub max: f64,
    /// Per landmark, in iBUG order.
    pub per_landmark: Vec<f64>,
}

/// The distance of each found landmark from `truth` (68 positions in the rig's own frame), mm.
pub fn landmark_error(rig: &Rig, truth: &[[f64; 3]]) -> LandmarkError {
    let per_landmark: Vec<f64> = rig
        .landmarks
        .landmarks
        .iter()
        .zip(truth)
        .map(|(l, t)| {
            let t = rig.conventions.to_face(t.map(|v| v as f32));
            norm(sub(l.face, t)) * 10.0
        })
        .collect();
    let mut sorted = per_landmark.clone();
    sorted.sort_by(f64::total_cmp);
    LandmarkError {
        mean: per_landmark.iter().sum::<f64>() / per_landmark.len().max(1) as f64,
        median: sorted.get(sorted.len() / 2).copied().unwrap_or(0.0),
        max: sorted.last().copied().unwrap_or(0.0),
        per_landmark,
    }
}

/// The report of a resolved rig and its landmarks.
pub fn report(rig: &Rig, found: &Found) -> Result<RigReport, RigError> {
    let back = |p: [f64; 3]| {
        rig.conventions
            .from_face(p)
            .ok_or_else(|| RigError::NodeTransform {
                path: rig.path().to_owned(),
            })
    };
    let landmarks: Vec<Option<u32>> = found.welded_vertices().into_iter().map(Some).collect();
    let plane = symmetry_plane(&rig.face.positions, &landmarks);
    let origin = to64(plane.origin);
    let o = back(origin)?;
    let tip = back(std::array::from_fn(|k| {
        origin[k] + f64::from(plane.normal[k])
    }))?;
    let d = sub(tip, o);
    let n = norm(d).max(f64::MIN_POSITIVE);
    let names = rig.names();
    Ok(RigReport {
        rig: rig.path().display().to_string(),
        format: rig.file.format.name(),
        mesh: rig.file.mesh_name.clone(),
        extensions: rig.file.extensions.clone(),
        vrm: rig.file.avatar.clone(),
        units: rig.conventions.units.name(),
        units_guessed: rig.conventions.units_guessed,
        up: rig.conventions.up,
        forward: rig.conventions.forward,
        node_transform: rig.conventions.node_transform,
        vertex_count: rig.file.vertex_count(),
        welded_vertex_count: rig.weld.len(),
        shapes: names.to_vec(),
        arkit: ArkitReport {
            bound: rig
                .arkit
                .iter()
                .filter(|(_, s)| !s.is_empty())
                .map(|(a, s)| (a.clone(), s.iter().map(|&i| names[i].clone()).collect()))
                .collect(),
            missing: rig
                .arkit_missing()
                .iter()
                .map(|s| (*s).to_owned())
                .collect(),
        },
        landmarks: found.landmarks.clone(),
        landmark_method: found.method.clone(),
        symmetry_plane: PlaneReport {
            normal: d.map(|v| v / n),
            origin: o,
        },
        jaw_pivot: back(found.jaw_pivot)?,
        landmark_error_mm: None,
    })
}

/// The neutral from the front and the side, the landmarks drawn as red patches.
pub fn picture(rig: &Rig, found: &Found) -> Image {
    let (lo, hi) = rig.face.bounds();
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    let radius = f64::from(size) * 0.012;
    let colors: Vec<[u8; 3]> = rig
        .face
        .positions
        .iter()
        .map(|&p| {
            let near = found
                .landmarks
                .iter()
                .any(|l| norm(sub(to64(p), l.face)) <= radius);
            if near { [220, 40, 40] } else { [205, 200, 195] }
        })
        .collect();
    let triangles = rig.face.triangles();
    let front = render(
        &rig.face.positions,
        &triangles,
        &colors,
        &View::front(480, 560),
    );
    let side = render(
        &rig.face.positions,
        &triangles,
        &colors,
        &View {
            yaw_deg: 90.0,
            ..View::front(480, 560)
        },
    );
    Image::hstack(&[front, side])
}

/// `sinew rig inspect`: writes the report of a resolved rig (with the landmarks' error against
/// `truth` when given), and `landmarks.png` into `pictures` when given.
pub fn inspect(
    rig: &Rig,
    truth: Option<&[[f64; 3]]>,
    report_path: &Path,
    pictures: Option<&Path>,
) -> Result<RigReport, InspectError> {
    let found = &rig.landmarks;
    let mut report = report(rig, found)?;
    report.landmark_error_mm = truth.map(|t| landmark_error(rig, t));
    let json = serde_json::to_vec_pretty(&report).map_err(InspectError::Encode)?;
    if let Some(dir) = pictures {
        std::fs::create_dir_all(dir).map_err(|source| AtomicWriteError {
            path: dir.to_owned(),
            step: WriteStep::CreateFolder,
            source,
        })?;
        picture(rig, found).save_png(&dir.join("landmarks.png"))?;
    }
    crate::io::atomic::write(report_path, &json)?;
    Ok(report)
}
