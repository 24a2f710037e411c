//! Drivers that read MediaPipe Face Mesh (`sinew train driver --input mediapipe`): the driver's
//! 68 inputs are the MediaPipe points at the places of iBUG's 68 ([`IBUG_POINTS`]), so the core's
//! driver, calibration and lost-frame rules take them as they take iBUG's; the actor's vertex of
//! each is found by placing MediaPipe's canonical face on the actor (a similarity onto the
//! actor's iBUG landmarks, which the built-in face template's registration finds), and a track is
//! read as MediaPipe writes it (`io::mediapipe`).

use std::path::{Path, PathBuf};

use sinew_core::aim::AimActor;
use sinew_core::driver::{Intrinsics, LANDMARKS, Space, normalise_pixels};

use super::track::{Track, TrackError};
use crate::geometry::align::fit_similarity;
use crate::geometry::vec3::V3;
use crate::io::mediapipe::{self, FACE_POINTS};
use crate::io::mesh::{Mesh, MeshError};

/// The baked driver's metadata key that names the landmarks it reads, and its value for
/// MediaPipe's (a driver without it reads iBUG's 68).
pub const META: (&str, &str) = ("landmarks", "mediapipe");

/// The MediaPipe Face Mesh point at each of iBUG's 68 landmarks, in iBUG's order: the face's
/// outline (0–16; MediaPipe's outline is a fixed ring of the face, iBUG's the jaw's silhouette),
/// the brows, the nose's bridge and base, the eyelids, the lips' outer and inner contours. The
/// pairs across the face are mirror images in MediaPipe's canonical face (a test checks it).
pub const IBUG_POINTS: [u16; LANDMARKS] = [
    127, 234, 93, 132, 58, 136, 150, 176, 152, 400, 379, 365, 288, 361, 323, 454,
    356, // outline
    70, 63, 105, 66, 107, 336, 296, 334, 293, 300, // brows
    168, 197, 5, 4, 75, 97, 2, 326, 305, // nose
    33, 160, 158, 133, 153, 144, 362, 385, 387, 263, 373, 380, // eyes
    61, 39, 37, 0, 267, 269, 291, 405, 314, 17, 84, 181, // outer lips
    78, 82, 13, 312, 308, 317, 14, 87, // inner lips
];

/// Why the actor's MediaPipe vertices cannot be found.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CanonicalFaceError {
    /// The canonical face cannot be read.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The file is not MediaPipe's canonical face.
    #[error(
        "{}: {found} vertices; MediaPipe's canonical face (canonical_face_model.obj, in \
         MediaPipe's mediapipe/modules/face_geometry/data) has {FACE_POINTS}",
        path.display()
    )]
    NotCanonical {
        /// The file.
        path: PathBuf,
        /// Its vertices.
        found: usize,
    },
    /// The actor's iBUG landmarks cannot be found.
    #[error(transparent)]
    Landmarks(#[from] super::LandmarkError),
    /// The canonical face's points at iBUG's places do not determine a placement.
    #[error("{}: its points at iBUG's places do not place it on the actor", path.display())]
    Placement {
        /// The file.
        path: PathBuf,
    },
}

/// The actor's vertex of each of [`IBUG_POINTS`]: MediaPipe's canonical face (`canonical`, as
/// MediaPipe ships it) placed on the actor's rest shape by a similarity fitted on its iBUG
/// landmarks (found by registering the built-in face template onto the actor, as
/// `landmark_vertices`), and the nearest actor vertex taken.
///
/// # Errors
/// [`CanonicalFaceError`], naming the file.
pub fn actor_vertices(
    model: &Path,
    actor: &AimActor<'_>,
    canonical: &Path,
) -> Result<Vec<u32>, CanonicalFaceError> {
    let face = Mesh::read(canonical)?;
    if face.positions.len() != FACE_POINTS {
        return Err(CanonicalFaceError::NotCanonical {
            path: canonical.to_owned(),
            found: face.positions.len(),
        });
    }
    let tpl = actor.template();
    let points: Vec<V3> = (0..actor.vertex_count())
        .map(|i| std::array::from_fn(|c| f64::from(tpl.at(3 * i + c))))
        .collect();
    // The canonical face is placed on the actor by the similarity that takes its points at
    // iBUG's places (brows, nose, eyes, lips: the outline's conventions differ) onto the actor's
    // iBUG landmarks (the built-in face template registered onto it), then each point is the
    // nearest actor vertex. (Registering the face template onto the canonical face as well and
    // carrying the points through it, as `rig::correspond` carries points between two faces, put
    // them 17 cm off on the golden actor: the template's registration does not hold on the
    // canonical face.)
    let ibug = super::landmark_vertices(model, actor)?;
    let raw: Vec<V3> = face.positions.iter().map(|p| p.map(f64::from)).collect();
    let inner = 17..LANDMARKS;
    let from: Vec<V3> = inner
        .clone()
        .map(|l| raw[usize::from(IBUG_POINTS[l])])
        .collect();
    let to: Vec<V3> = inner.map(|l| points[ibug[l] as usize]).collect();
    let place = fit_similarity(&from, &to, &vec![1.0; from.len()]);
    if !(place.scale() > 0.0 && place.scale().is_finite()) {
        return Err(CanonicalFaceError::Placement {
            path: canonical.to_owned(),
        });
    }
    let face_points: Vec<V3> = raw.iter().map(|&p| place.apply(p)).collect();
    Ok(IBUG_POINTS
        .iter()
        .map(|&i| super::nearest(&points, face_points[usize::from(i)]).0)
        .collect())
}

/// The intrinsics taken for a MediaPipe track when none are given: a webcam's usual field of
/// view, the focal length the image's width (about 53° across), the principal point at the
/// image's centre.
pub fn webcam_intrinsics(size: [u32; 2]) -> Intrinsics {
    let [w, h] = size.map(|s| s as f32);
    Intrinsics {
        fx: w,
        fy: w,
        cx: w / 2.0,
        cy: h / 2.0,
    }
}

/// A MediaPipe track as a driver's 2D track: per frame the [`IBUG_POINTS`] in pixels (x times
/// the width, y times the height) normalised by `intrinsics` (default
/// [`webcam_intrinsics`]); a frame without a face is lost. Time stamps as the file gives them,
/// else 1/30 s apart.
///
/// # Errors
/// [`TrackError`] naming the file (and the row and point of a bad value).
pub fn read_track(path: &Path, intrinsics: Option<Intrinsics>) -> Result<Track, TrackError> {
    let t = mediapipe::read(path)?;
    let camera = intrinsics.unwrap_or_else(|| webcam_intrinsics(t.size));
    let [w, h] = t.size.map(|s| s as f32);
    let times: Vec<f32> = t
        .frames
        .iter()
        .enumerate()
        .map(|(f, fr)| fr.timestamp.unwrap_or(f as f32 / super::track::DEFAULT_FPS))
        .collect();
    super::track::check_times(path, &times, 1)?;
    let frames = t
        .frames
        .iter()
        .enumerate()
        .map(|(f, fr)| {
            let Some(points) = &fr.points else {
                return Ok(None);
            };
            let pixels: Vec<f32> = IBUG_POINTS
                .iter()
                .flat_map(|&i| {
                    let p = points[usize::from(i)];
                    [p[0] * w, p[1] * h]
                })
                .collect();
            let mut out = vec![0.0; 2 * LANDMARKS];
            normalise_pixels(&pixels, &camera, &mut out).map_err(|source| TrackError::Refused {
                path: path.to_owned(),
                frame: f,
                source,
            })?;
            Ok(Some(out))
        })
        .collect::<Result<Vec<_>, TrackError>>()?;
    Ok(Track {
        space: Space::Image,
        frames,
        times,
    })
}

/// Whether the baked driver `bytes` reads MediaPipe's points ([`META`]).
pub fn reads_mediapipe(bytes: &[u8]) -> bool {
    sinew_core::SinewFile::from_bytes(bytes)
        .ok()
        .and_then(|f| f.metadata().get(META.0).map(|v| v == META.1))
        .unwrap_or(false)
}

#[cfg(test)]
mod tests;
