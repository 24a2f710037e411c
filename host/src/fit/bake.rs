//! A fit baked into a `.sinew` performance (docs/FORMAT.md, "Performance"), and played back
//! through `sinew_core::performance`: the fitted meshes `sinew fit` writes are the core's, so
//! they are the bits every target plays.

use sinew_core::aim::AimActor;
use sinew_core::error::FormatError;
use sinew_core::format::ArtifactKind;
use sinew_core::performance::{self as perf, Performance};
use sinew_core::replay::{hash_words, model_hash};

use crate::fit::aim::{Coefficients, FitResult};
use crate::io::container::{SinewWriter, WriterError};
use crate::training::nn::write_mlp;

/// Why a fit could not be baked or a baked performance played. The bytes come from the caller,
/// which names their files.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BakeError {
    /// The actor's bytes are not a valid AIM actor.
    #[error("the actor")]
    Actor(#[source] FormatError),
    /// The performance's bytes are not a valid performance.
    #[error("the performance")]
    Performance(#[source] FormatError),
    /// The performance was baked for another actor or does not fit it.
    #[error("the performance does not play on this actor")]
    OtherActor(#[source] sinew_core::replay::ReplayError),
    /// A fit with no frames, or with fewer jaw poses than head poses.
    #[error("a fit without frames cannot be baked")]
    NoFrames,
    /// A fit whose per-frame arrays do not have the shape its settings imply.
    #[error("the fit's {what} are not [frames, {per_frame}]")]
    Shape {
        /// `codes` or `coefficients`.
        what: &'static str,
        /// The expected width.
        per_frame: usize,
    },
    /// A global fit that carries no coefficients.
    #[error("a global fit without coefficients")]
    NoCoefficients,
    /// The performance cannot be laid out as a `.sinew` file.
    #[error(transparent)]
    Encode(#[from] WriterError),
    /// A frame the core could not play.
    #[error("frame {frame}")]
    Frame {
        /// The frame.
        frame: usize,
        /// What the core said.
        #[source]
        source: sinew_core::EvalError,
    },
}

/// The `.sinew` bytes of `result`, a fit of the actor whose bytes are `actor_bytes`, with each
/// frame's f32 hash as the core computes it.
pub fn bake(actor_bytes: &[u8], result: &FitResult) -> Result<Vec<u8>, BakeError> {
    let actor = AimActor::from_bytes(actor_bytes).map_err(BakeError::Actor)?;
    let frames = result.head.len();
    let m = actor.shape_count();
    if frames == 0 || result.jaw.len() != frames {
        return Err(BakeError::NoFrames);
    }
    let mut w = SinewWriter::new(ArtifactKind::Performance);
    w.meta("source", "sinew fit")
        .meta(
            "coefficients",
            format!("{:?}", result.config.coefficients).to_lowercase(),
        )
        .meta("iterations", result.config.iterations)
        .meta("seed", result.config.seed)
        .meta("mean_error_mm", format!("{:.6}", result.mean_error_mm));
    w.u32s(perf::MODEL_HASH, &[2], &hash_words(model_hash(actor_bytes)))?;
    let poses: Vec<f32> = result
        .head
        .iter()
        .zip(&result.jaw)
        .flat_map(|(h, j)| h.iter().chain(j).copied())
        .collect();
    w.f32s(perf::POSES, &[frames, 18], &poses)?;
    match result.config.coefficients {
        Coefficients::Local => {
            let f = result.config.code;
            if result.codes.len() != frames * f {
                return Err(BakeError::Shape {
                    what: "codes",
                    per_frame: f,
                });
            }
            w.f32s(perf::CODES, &[frames, f], &result.codes)?;
            w.f32s(perf::BOX, &[4], &result.normalisation)?;
            write_mlp(&mut w, perf::F_W, &result.fw)?;
        }
        Coefficients::Global => {
            let weights = result.weights.as_ref().ok_or(BakeError::NoCoefficients)?;
            let flat: Vec<f32> = weights.iter().flatten().copied().collect();
            if flat.len() != frames * m {
                return Err(BakeError::Shape {
                    what: "coefficients",
                    per_frame: m,
                });
            }
            w.f32s(perf::WEIGHTS, &[frames, m], &flat)?;
        }
        Coefficients::Zero => {
            w.f32s(perf::WEIGHTS, &[frames, m], &vec![0.0; frames * m])?;
        }
    }
    let unhashed = w.to_bytes()?;
    let hashes = frame_hashes(actor_bytes, &unhashed)?;
    let words: Vec<u32> = hashes.iter().flat_map(|&h| hash_words(h)).collect();
    w.u32s(perf::HASHES, &[frames, 2], &words)?;
    Ok(w.to_bytes()?)
}

/// Every frame of a baked performance played on its actor through the core: the positions
/// (`[V, 3]` per frame) and each frame's f32 hash.
pub fn play(actor_bytes: &[u8], perf_bytes: &[u8]) -> Result<(Vec<Vec<f32>>, Vec<u64>), BakeError> {
    let actor = AimActor::from_bytes(actor_bytes).map_err(BakeError::Actor)?;
    let p = Performance::from_bytes(perf_bytes).map_err(BakeError::Performance)?;
    p.check_actor(actor_bytes, &actor)
        .map_err(BakeError::OtherActor)?;
    let v = actor.vertex_count();
    let mut scratch = vec![0.0; p.scratch_len()];
    let mut normals = vec![0.0; 3 * v];
    let mut frames = Vec::with_capacity(p.frames());
    let mut hashes = Vec::with_capacity(p.frames());
    for f in 0..p.frames() {
        let mut positions = vec![0.0; 3 * v];
        let h = perf::play_frame_hash(&p, &actor, f, &mut scratch, &mut positions, &mut normals)
            .map_err(|source| BakeError::Frame { frame: f, source })?;
        frames.push(positions);
        hashes.push(h);
    }
    Ok((frames, hashes))
}

fn frame_hashes(actor_bytes: &[u8], perf_bytes: &[u8]) -> Result<Vec<u64>, BakeError> {
    play(actor_bytes, perf_bytes).map(|(_, h)| h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_bytes_are_refused_by_variant() {
        assert!(matches!(play(b"junk", b"junk"), Err(BakeError::Actor(_))));
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data/aim-procedural.sinew");
        let actor = std::fs::read(path).unwrap();
        assert!(matches!(
            play(&actor, b"junk"),
            Err(BakeError::Performance(_))
        ));
        // An actor is not a performance.
        assert!(matches!(
            play(&actor, &actor),
            Err(BakeError::Performance(_))
        ));
    }
}
