//! An AIM actor's other numeric modes and what an engine binds curves with: a frame posed in
//! Q16.16 fixed point or in the fast mode (the very arithmetic of the Q16 and fast replays,
//! `sinew_core::replay::pose_frame`), the Q16 frame hash, and the corrective shapes' names.

use fixed::types::I16F16;
use sinew_core::hash::FrameHasher;
use sinew_core::replay::{self, FrameBuffers, Mode};

use crate::error::Error;
use crate::model::{Model, check_len, pose_9d};

/// The name of corrective shape `i` when the file records none: `shape_1` … `shape_M`, the names
/// `sinew export gltf` gives such morph targets.
fn fallback_shape_name(i: usize) -> String {
    format!("shape_{}", i + 1)
}

/// One frame posed in a mode: the positions and normals (f32 and fast modes) or the raw Q16.16
/// positions (Q16 mode); the others empty.
struct Posed {
    positions: Vec<f32>,
    normals: Vec<f32>,
    fixed: Vec<i32>,
}

impl Model {
    /// The names of an AIM actor's corrective shapes in coefficient order (the order of
    /// [`Model::pose`]'s coefficients): the training shapes' names the file records (metadata
    /// `shapes`, the neutral first and skipped), or `shape_1` … `shape_M` when it records none.
    /// Empty for an S2D decoder.
    pub fn shape_names(&self) -> Vec<String> {
        match self.aim("shapeNames") {
            Ok(actor) => (0..actor.shape_count())
                .map(|i| {
                    actor
                        .shape_name(i)
                        .map_or_else(|| fallback_shape_name(i), str::to_owned)
                })
                .collect(),
            Err(_) => Vec::new(),
        }
    }

    /// Poses an AIM actor in `mode` (`pose_frame`): the positions and normals of the f32 or
    /// fast mode, or the raw Q16.16 positions of the Q16 mode.
    fn pose_mode(
        &self,
        mode: Mode,
        head: &[f32],
        jaw: &[f32],
        coefficients: &[f32],
    ) -> Result<Posed, Error> {
        let call = if mode == Mode::Q16 {
            "poseQ16"
        } else {
            "poseFast"
        };
        let actor = self.aim(call)?;
        let head = pose_9d("head", head)?;
        let jaw = pose_9d("jaw", jaw)?;
        check_len("coefficients", coefficients.len(), actor.shape_count())?;
        let v3 = 3 * actor.vertex_count();
        let mut weights = coefficients.to_vec();
        let q16 = mode == Mode::Q16;
        let mut positions = vec![0.0; if q16 { 0 } else { v3 }];
        let mut normals = vec![0.0; positions.len()];
        let mut fixed = vec![I16F16::ZERO; if q16 { v3 } else { 0 }];
        let mut weights_q16 = vec![I16F16::ZERO; if q16 { weights.len() } else { 0 }];
        let mut buf = FrameBuffers {
            positions: &mut positions,
            normals: &mut normals,
            positions_q16: &mut fixed,
            weights: &mut weights,
            weights_q16: &mut weights_q16,
        };
        replay::pose_frame(actor, mode, &head, &jaw, &mut buf)?;
        Ok(Posed {
            positions,
            normals,
            fixed: fixed.iter().map(|v| v.to_bits()).collect(),
        })
    }

    /// Poses an AIM actor in Q16.16 fixed point (the Q16 replays' mode, for parts without an
    /// FPU): the positions' raw Q16.16 values (value × 65536).
    ///
    /// # Shapes
    /// `head`, `jaw`: `[9]`; `coefficients`: `[M]`; returns `[V, 3]`.
    ///
    /// # Errors
    /// As [`Model::pose`]; an actor baked without the Q16.16 cache.
    pub fn pose_q16(
        &self,
        head: &[f32],
        jaw: &[f32],
        coefficients: &[f32],
    ) -> Result<Vec<i32>, Error> {
        Ok(self.pose_mode(Mode::Q16, head, jaw, coefficients)?.fixed)
    }

    /// Poses an AIM actor in the fast mode: the positions of [`Model::pose`] and the vertex
    /// normals normalised with micromath's approximate inverse square root.
    ///
    /// # Shapes
    /// As [`Model::pose`]; returns `[V, 3]` positions and `[V, 3]` normals.
    ///
    /// # Errors
    /// As [`Model::pose`].
    pub fn pose_fast(
        &self,
        head: &[f32],
        jaw: &[f32],
        coefficients: &[f32],
    ) -> Result<(Vec<f32>, Vec<f32>), Error> {
        let posed = self.pose_mode(Mode::Fast, head, jaw, coefficients)?;
        Ok((posed.positions, posed.normals))
    }
}

/// The hash of a Q16 frame: each raw Q16.16 value's 32 bits in order, as
/// [`sinew_core::hash::q16_frame_hash`] hashes the Q16 mode's positions.
pub fn frame_hash_q16(values: &[i32]) -> u64 {
    let mut h = FrameHasher::new();
    for v in values {
        h.write_u32(*v as u32);
    }
    h.finish()
}
