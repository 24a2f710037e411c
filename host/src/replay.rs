//! Recording and verifying replays (`sinew replay record|verify`): a model's content hash, a pose
//! sequence and the hash of every frame `sinew-core` computes from it, in one numeric mode. The
//! frames are hashed by `sinew_core::replay::frame_hash`, the same function every firmware target
//! runs, so a replay recorded here verifies bit for bit anywhere.

use anyhow::{Result, anyhow, bail};
use sinew_core::aim::AimActor;
use sinew_core::format::ArtifactKind;
use sinew_core::q16::Q16;
use sinew_core::replay::{
    AimReplay, FrameBuffers, FrameCheck, Mode, frame_hash, model_hash, verify as core_verify,
};

use crate::SinewWriter;
use crate::commands::Frame;

/// Buffers for one frame of `actor` in every mode.
struct Buffers {
    positions: Vec<f32>,
    normals: Vec<f32>,
    positions_q16: Vec<Q16>,
    weights: Vec<f32>,
    weights_q16: Vec<Q16>,
}

impl Buffers {
    fn for_actor(actor: &AimActor<'_>) -> Self {
        let (v, m) = (actor.vertex_count(), actor.shape_count());
        Self {
            positions: vec![0.0; 3 * v],
            normals: vec![0.0; 3 * v],
            positions_q16: vec![Q16::ZERO; 3 * v],
            weights: vec![0.0; m],
            weights_q16: vec![Q16::ZERO; m],
        }
    }

    fn view(&mut self) -> FrameBuffers<'_> {
        FrameBuffers {
            positions: &mut self.positions,
            normals: &mut self.normals,
            positions_q16: &mut self.positions_q16,
            weights: &mut self.weights,
            weights_q16: &mut self.weights_q16,
        }
    }
}

/// Records a replay of `frames` through the actor in `model` in `mode`.
///
/// # Errors
/// If `model` is not an AIM actor, a frame's coefficient count differs from the actor's, or
/// `mode` is Q16 and the actor has no Q16.16 cache (`sinew bake --q16`).
pub fn record(model: &[u8], mode: Mode, frames: &[Frame]) -> Result<Vec<u8>> {
    let actor = AimActor::from_bytes(model).map_err(|e| anyhow!("model: {e}"))?;
    if frames.is_empty() {
        bail!("a replay needs at least one frame");
    }
    let m = actor.shape_count();
    let mut buf = Buffers::for_actor(&actor);
    let mut inputs = Vec::with_capacity(frames.len() * (18 + m));
    let mut hashes = Vec::with_capacity(2 * frames.len());
    for (i, f) in frames.iter().enumerate() {
        if f.weights.len() != m {
            bail!(
                "frame {i} has {} weights, the model {m} shapes",
                f.weights.len()
            );
        }
        buf.weights.copy_from_slice(&f.weights);
        let h = frame_hash(&actor, mode, &f.head, &f.jaw, &mut buf.view())
            .map_err(|e| anyhow!("frame {i}: {e}"))?;
        inputs.extend(f.head.iter().chain(&f.jaw).chain(&f.weights));
        hashes.extend([h as u32, (h >> 32) as u32]);
    }
    let content = model_hash(model);
    let mut w = SinewWriter::new(ArtifactKind::Replay);
    w.meta("mode", mode.name())
        .meta("model", format!("{content:016x}"))
        .meta("frames", frames.len());
    w.u32s(
        "replay.model",
        &[2],
        &[content as u32, (content >> 32) as u32],
    )?;
    w.f32s("replay.aim", &[frames.len(), 18 + m], &inputs)?;
    w.u32s("replay.hash", &[frames.len(), 2], &hashes)?;
    w.to_bytes()
}

/// The outcome of [`verify`].
#[derive(Clone, Debug)]
pub struct Verification {
    /// The replay's numeric mode.
    pub mode: Mode,
    /// Every frame's check, in order.
    pub frames: Vec<FrameCheck>,
    /// The first frame whose hash differs, if any.
    pub first_mismatch: Option<usize>,
}

/// Plays the replay in `replay` through the actor in `model` with `sinew-core` and compares every
/// frame's hash with the recorded one.
///
/// # Errors
/// If either file is invalid, the replay was recorded with another model, or the mode is
/// unavailable for this model. A differing frame is not an error: see
/// [`Verification::first_mismatch`].
pub fn verify(model: &[u8], replay: &[u8]) -> Result<Verification> {
    let actor = AimActor::from_bytes(model).map_err(|e| anyhow!("model: {e}"))?;
    let r = AimReplay::from_bytes(replay).map_err(|e| anyhow!("replay: {e}"))?;
    let mut buf = Buffers::for_actor(&actor);
    let mut frames = Vec::with_capacity(r.frames());
    let first_mismatch = core_verify(model, &actor, &r, &mut buf.view(), |c| frames.push(*c))
        .map_err(|e| anyhow!("{e}"))?;
    Ok(Verification {
        mode: r.mode(),
        frames,
        first_mismatch,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aim::model::IDENTITY_9D;

    fn golden() -> Vec<u8> {
        std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/data/aim-procedural.sinew"
        ))
        .unwrap()
    }

    fn frames(m: usize, n: usize) -> Vec<Frame> {
        (0..n)
            .map(|f| Frame {
                head: IDENTITY_9D,
                jaw: IDENTITY_9D,
                weights: (0..m).map(|j| (f * j) as f32 * 0.1).collect(),
            })
            .collect()
    }

    #[test]
    fn record_then_verify_passes_and_a_changed_model_is_refused() {
        let model = crate::aim::bake::with_q16_cache(&golden()).unwrap();
        let m = AimActor::from_bytes(&model).unwrap().shape_count();
        for mode in [Mode::F32, Mode::Q16, Mode::Fast] {
            let r = record(&model, mode, &frames(m, 3)).unwrap();
            let v = verify(&model, &r).unwrap();
            assert_eq!(v.mode, mode);
            assert_eq!(v.frames.len(), 3);
            assert_eq!(v.first_mismatch, None);
            // Another model (one byte of metadata differs) is refused by content hash.
            let other = golden();
            let err = verify(&other, &r).unwrap_err().to_string();
            assert!(err.contains("recorded with model"), "{err}");
        }
        // Q16 needs the cache.
        let err = record(&golden(), Mode::Q16, &frames(m, 1)).unwrap_err();
        assert!(err.to_string().contains("Q16.16 cache"), "{err}");
    }

    #[test]
    fn a_corrupted_hash_names_its_frame() {
        let model = golden();
        let m = AimActor::from_bytes(&model).unwrap().shape_count();
        let good = record(&model, Mode::F32, &frames(m, 4)).unwrap();
        // Re-record with frame 2's input changed, but frame 2's hash from the good recording:
        // verification must name frame 2 as the first that differs.
        let mut changed = frames(m, 4);
        changed[2].weights[0] += 0.5;
        let bad = record(&model, Mode::F32, &changed).unwrap();
        let good_r = AimReplay::from_bytes(&good).unwrap();
        let bad_r = AimReplay::from_bytes(&bad).unwrap();
        assert_ne!(good_r.expected(2), bad_r.expected(2));
        let file = sinew_core::SinewFile::from_bytes(&bad).unwrap();
        let mut w = SinewWriter::from_file(&file).unwrap();
        let mut hashes: Vec<u32> = Vec::new();
        for f in 0..4 {
            let h = if f == 2 {
                good_r.expected(f)
            } else {
                bad_r.expected(f)
            }
            .unwrap();
            hashes.extend([h as u32, (h >> 32) as u32]);
        }
        // Swap the hash section for the mixed list.
        let mut w2 = SinewWriter::new(ArtifactKind::Replay);
        w2.meta("mode", "f32");
        for s in file.sections().filter(|s| s.name().starts_with("replay.")) {
            if s.name() == "replay.hash" {
                w2.u32s("replay.hash", &[4, 2], &hashes).unwrap();
            } else {
                let dims: Vec<usize> = s.dims().iter().map(|&d| d as usize).collect();
                match s.f32s() {
                    Some(v) => w2.f32s(s.name(), &dims, &v.iter().collect::<Vec<_>>()),
                    None => w2.u32s(
                        s.name(),
                        &dims,
                        &s.u32s().unwrap().iter().collect::<Vec<_>>(),
                    ),
                }
                .unwrap();
            }
        }
        let _ = &mut w;
        let v = verify(&model, &w2.to_bytes().unwrap()).unwrap();
        assert_eq!(v.first_mismatch, Some(2));
        assert!(v.frames[2].to_string().contains("DIFFERS"));
        assert!(v.frames[3].ok());
    }
}
