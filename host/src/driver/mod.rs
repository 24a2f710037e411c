//! The live driver (docs/FIT.md, "Live driver"): an amortised fit, a small network per actor
//! that maps one frame's 68 landmarks to the actor's head, jaw and coefficients in one forward
//! pass, evaluated by `sinew_core::driver`. `sample`: the training frames drawn from the actor
//! itself; `train`: the burn network, the Adam loop and its checkpoints; `bake`: the `drv.*`
//! sections; `track`: landmark tracks (an OpenFace 2.0 CSV, a performance folder's 2D track or
//! its meshes' 3D landmarks); `mediapipe`: drivers that read MediaPipe Face Mesh (the
//! canonical face registered onto the actor, the track as MediaPipe writes it); `drive`: `sinew drive`, tracks played through the core; `measure`:
//! the driver against the offline fit on held-out performances.

pub mod bake;
pub mod commands;
pub mod drive;
pub mod measure;
pub mod mediapipe;
pub mod metric;
pub mod sample;
pub mod track;
pub mod train;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;
use sinew_core::driver::{LANDMARKS, Space};

use crate::geometry::vec3::V3;
use crate::rig::RigError;
use crate::rig::template::FaceTemplate;

/// The share of its own answer in the head's depth that a 2D driver trained on trackers'
/// conventions asks the live calibration to take (`sinew_core::driver::CALIBRATION_DEPTH`):
/// measured on held-out conventions and on MediaPipe Face Mesh's tracks (docs/FIT.md, "The
/// head's depth").
pub const CALIBRATION_DEPTH_SHARE: f32 = 1.0 / 3.0;

/// `sinew train driver`'s settings (Sinew's own: no paper gives them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DriverConfig {
    /// 2D (normalised image coordinates) or 3D landmarks.
    #[serde(with = "space_name")]
    pub input: Space,
    /// Hidden units per layer (three hidden GELU layers).
    pub hidden: usize,
    /// Adam steps.
    pub steps: usize,
    /// Samples per step.
    pub batch: usize,
    /// Adam's learning rate at the first step; it decays exponentially to `lr_final`.
    pub lr: f64,
    /// Adam's learning rate at the last step.
    pub lr_final: f64,
    /// Seed of the weights and of every step's samples.
    pub seed: u64,
    /// Chance that a coefficient is active in a sample (then uniform in [0, 1]).
    pub active: f64,
    /// The head's rotation range about x, y, z, radians (uniform in ±).
    pub head_rotation: [f64; 3],
    /// The head's translation range in the actor's unit: ±x, ±y, then z from `[2]` to `[3]`
    /// (negative: away from the camera).
    pub head_translation: [f64; 4],
    /// The jaw's opening about x, radians (uniform in [0, this]).
    pub jaw_opening: f64,
    /// The jaw's yaw, radians (uniform in ±).
    pub jaw_yaw: f64,
    /// The jaw's translation, the actor's unit (uniform in ± per axis).
    pub jaw_translation: f64,
    /// The canonical camera's distance in front of the face, in the actor's unit.
    pub distance: f32,
    /// Focal lengths drawn, pixels.
    pub focal: [f64; 2],
    /// Largest landmark noise, pixels (each sample draws its standard deviation in [0, this]).
    pub noise: f64,
    /// Standard deviation of the 3D landmarks' noise, in the actor's unit.
    pub noise_3d: f64,
    /// Chance that a sample loses a run of 3–10 landmarks to the tracker's shape prior.
    pub dropout: f64,
    /// A tracker's convention drawn for each sample (`training::tracker::Convention`): its
    /// contour amplitude in the actor's unit (0: the landmark vertices themselves).
    #[serde(default)]
    pub convention_amplitude: f64,
    /// Weight of the pose's own squared error beside the posed vertices' (both normalised).
    pub pose_weight: f64,
    /// The tracker whose landmarks a 2D driver reads: iBUG's 68, or MediaPipe Face Mesh's points
    /// at their places (`mediapipe::IBUG_POINTS`). Written only for MediaPipe's, so that
    /// iBUG drivers' settings read as before.
    #[serde(default, skip_serializing_if = "Tracker::is_ibug")]
    pub tracker: Tracker,
}

/// The tracker whose landmarks a driver reads.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Tracker {
    /// iBUG's 68 (OpenFace 2.0, dlib, a performance folder's track).
    #[default]
    Ibug,
    /// MediaPipe Face Mesh (`driver::mediapipe`).
    MediaPipe,
}

impl Tracker {
    /// Whether it is iBUG's 68.
    pub fn is_ibug(&self) -> bool {
        *self == Tracker::Ibug
    }
}

impl Default for DriverConfig {
    fn default() -> Self {
        Self {
            input: Space::Image,
            hidden: 128,
            steps: 6000,
            batch: 256,
            lr: 2e-3,
            lr_final: 2e-5,
            seed: 1,
            active: 0.35,
            head_rotation: [0.25, 0.35, 0.15],
            head_translation: [3.0, 3.0, -10.0, 10.0],
            jaw_opening: 0.12,
            jaw_yaw: 0.03,
            jaw_translation: 0.05,
            distance: 60.0,
            focal: [500.0, 1500.0],
            noise: 3.0,
            noise_3d: 0.05,
            dropout: 0.2,
            convention_amplitude: 0.2,
            pose_weight: 0.1,
            tracker: Tracker::Ibug,
        }
    }
}

impl DriverConfig {
    /// Adam's rate at `step`: `lr · (lr_final / lr)^(step / (steps − 1))`.
    pub fn lr_at(&self, step: usize) -> f64 {
        let last = self.steps.saturating_sub(1).max(1) as f64;
        self.lr * (self.lr_final / self.lr).powf((step as f64 / last).min(1.0))
    }
}

mod space_name {
    use serde::{Deserialize, Deserializer, Serializer};
    use sinew_core::driver::Space;

    pub fn serialize<S: Serializer>(space: &Space, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(space.name())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Space, D::Error> {
        match String::deserialize(d)?.as_str() {
            "2d" => Ok(Space::Image),
            "3d" => Ok(Space::World),
            other => Err(serde::de::Error::custom(format!(
                "input {other:?}: expected 2d or 3d"
            ))),
        }
    }
}

/// Why a driver cannot be made for an actor.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LandmarkError {
    /// The built-in face template cannot be registered onto the actor.
    #[error("{}: finding the 68 landmarks on the actor", path.display())]
    Register {
        /// The actor.
        path: PathBuf,
        /// Why.
        #[source]
        source: RigError,
    },
}

/// Landmarks nearer than this to an actor vertex (cm) mean the actor is in the kit's frame, and
/// its vertices are taken as they are, without registering the template.
const KIT_FRAME_CM: f64 = 0.05;

/// The actor's vertex of each of the 68 iBUG landmarks: the template vertex nearest the built-in
/// face template's landmark (ties to the lower index), as `sinew data performance` picks them on
/// a kit actor; on an actor of another shape the template is registered onto its rest shape first
/// (`rig::correspond`).
pub fn landmark_vertices(path: &Path, actor: &AimActor<'_>) -> Result<Vec<u32>, LandmarkError> {
    let template = FaceTemplate::builtin().map_err(|e| LandmarkError::Register {
        path: path.to_owned(),
        source: RigError::from(e),
    })?;
    let tpl = actor.template();
    let points: Vec<V3> = (0..actor.vertex_count())
        .map(|i| {
            [
                f64::from(tpl.at(3 * i)),
                f64::from(tpl.at(3 * i + 1)),
                f64::from(tpl.at(3 * i + 2)),
            ]
        })
        .collect();
    let on = |template_points: &[V3]| -> Vec<(u32, f64)> {
        template
            .landmarks
            .iter()
            .map(|&(t, w)| {
                let tri = template.triangles[t as usize];
                let p: V3 = std::array::from_fn(|c| {
                    (0..3)
                        .map(|k| w[k] * template_points[tri[k] as usize][c])
                        .sum()
                });
                nearest(&points, p)
            })
            .collect()
    };
    let direct = on(&template.points());
    if direct.iter().all(|&(_, d)| d < KIT_FRAME_CM) {
        return Ok(direct.into_iter().map(|(v, _)| v).collect());
    }
    let tri = actor.triangles().indices();
    let triangles: Vec<[u32; 3]> = (0..tri.len() / 3)
        .map(|t| [tri.at(3 * t), tri.at(3 * t + 1), tri.at(3 * t + 2)])
        .collect();
    let registered =
        crate::rig::correspond::register_face(path, &points, &triangles).map_err(|source| {
            LandmarkError::Register {
                path: path.to_owned(),
                source,
            }
        })?;
    let found = on(&registered.points);
    debug_assert_eq!(found.len(), LANDMARKS);
    Ok(found.into_iter().map(|(v, _)| v).collect())
}

/// The index of the point of `points` nearest `p` and its distance (ties to the lower index).
pub(crate) fn nearest(points: &[V3], p: V3) -> (u32, f64) {
    let (best, d2) = points
        .iter()
        .enumerate()
        .fold((0, f64::INFINITY), |best, (i, q)| {
            let d = (0..3).map(|c| (q[c] - p[c]) * (q[c] - p[c])).sum::<f64>();
            if d < best.1 { (i, d) } else { best }
        });
    (best as u32, d2.sqrt())
}
