//! A fit baked into a `.sinew` performance (docs/FORMAT.md, "Performance"), and played back
//! through `sinew_core::performance`: the fitted meshes `sinew fit` writes are the core's, so
//! they are the bits every target plays.

use anyhow::{Context, Result, anyhow, ensure};
use sinew_core::aim::AimActor;
use sinew_core::format::ArtifactKind;
use sinew_core::performance::{self as perf, Performance};
use sinew_core::replay::{hash_words, model_hash};

use crate::fit::aim::{Coefficients, FitResult};
use crate::io::container::SinewWriter;
use crate::training::nn::write_mlp;

/// The `.sinew` bytes of `result`, a fit of the actor whose bytes are `actor_bytes`, with each
/// frame's f32 hash as the core computes it.
pub fn bake(actor_bytes: &[u8], result: &FitResult) -> Result<Vec<u8>> {
    let actor = AimActor::from_bytes(actor_bytes).map_err(|e| anyhow!("the actor: {e}"))?;
    let frames = result.head.len();
    let m = actor.shape_count();
    ensure!(
        frames > 0 && result.jaw.len() == frames,
        "a fit without frames cannot be baked"
    );
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
            ensure!(
                result.codes.len() == frames * f,
                "the fit's codes are not [frames, f]"
            );
            w.f32s(perf::CODES, &[frames, f], &result.codes)?;
            w.f32s(perf::BOX, &[4], &result.normalisation)?;
            write_mlp(&mut w, perf::F_W, &result.fw)?;
        }
        Coefficients::Global => {
            let weights = result
                .weights
                .as_ref()
                .ok_or_else(|| anyhow!("a global fit without coefficients"))?;
            let flat: Vec<f32> = weights.iter().flatten().copied().collect();
            ensure!(
                flat.len() == frames * m,
                "the fit's coefficients are not [frames, {m}]"
            );
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
pub fn play(actor_bytes: &[u8], perf_bytes: &[u8]) -> Result<(Vec<Vec<f32>>, Vec<u64>)> {
    let actor = AimActor::from_bytes(actor_bytes).map_err(|e| anyhow!("the actor: {e}"))?;
    let p = Performance::from_bytes(perf_bytes).map_err(|e| anyhow!("{e}"))?;
    p.check_actor(actor_bytes, &actor)
        .map_err(|e| anyhow!("{e}"))?;
    let v = actor.vertex_count();
    let mut scratch = vec![0.0; p.scratch_len()];
    let mut normals = vec![0.0; 3 * v];
    let mut frames = Vec::with_capacity(p.frames());
    let mut hashes = Vec::with_capacity(p.frames());
    for f in 0..p.frames() {
        let mut positions = vec![0.0; 3 * v];
        let h = perf::frame_hash(&p, &actor, f, &mut scratch, &mut positions, &mut normals)
            .with_context(|| format!("frame {f}"))?;
        frames.push(positions);
        hashes.push(h);
    }
    Ok((frames, hashes))
}

fn frame_hashes(actor_bytes: &[u8], perf_bytes: &[u8]) -> Result<Vec<u64>> {
    play(actor_bytes, perf_bytes).map(|(_, h)| h)
}
