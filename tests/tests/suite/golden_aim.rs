//! Golden AIM replays: small baked actors (the procedural face, trained briefly, and a decimated
//! ICT face; committed, since training is reproducible only per build) posed through a fixed
//! sequence by the core in every numeric mode. Each replay (`*.replay.sinew`: the model's
//! content hash, the inputs, the per-frame hashes) is pinned byte for byte, with a readable hash
//! list beside it. The same replays run on every firmware target.
//!
//! `UPDATE_EXPECT=1` retrains the procedural actor and rewrites the replays and hash lists.

use std::fmt::Write;

use sinew_core::aim::AimActor;
use sinew_core::replay::Mode;
use sinew_host::aim::bake::with_q16_cache;
use sinew_host::aim::play::Frame;
use sinew_host::replay::{record, verify};
use sinew_tests::{check, check_bytes, golden_dir};

const MODEL: &str = "aim-procedural.sinew";

/// Trains and bakes the golden actor (only under `UPDATE_EXPECT=1`).
fn bake_golden() -> Vec<u8> {
    use sinew_host::aim::AimConfig;
    use sinew_host::aim::bake::{BakeInput, bake};
    use sinew_host::aim::train::train;
    use sinew_host::training::backend::Backend;
    let set = sinew_host::aim::testing::procedural_training_set(16);
    let config = AimConfig {
        hidden: 32,
        layers: 2,
        batch: 1024,
        symmetry_batch: 64,
        forehead_batch: 64,
        iterations: 400,
        lr: 1e-3,
        lr_end: 1e-4,
        // The golden model was trained with the paper's jaw (identity start, no L_J); keep
        // regenerating it the same way.
        jaw_init: sinew_host::aim::config::JawInit::Identity,
        lambda_jaw: 0.0,
        // ... and without the final anneal, which came later still.
        anneal_fraction: 0.0,
        ..AimConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let options = sinew_host::aim::testing::aim_train_options(dir.path(), false, None);
    let trained = train(&set, &config, &options).unwrap();
    let tri = set.template.triangles();
    let input = BakeInput {
        points: &set.template.positions,
        triangles: &tri,
        jaw_pivot: set.jaw_pivot,
        normalisation: trained.state.normalisation,
        playback_only: true,
        metadata: vec![
            ("units".into(), "cm".into()),
            (
                "source".into(),
                "sinew procedural demo actor, resolution 16".into(),
            ),
        ],
    };
    bake(&trained.model, &input, &Backend::Flex.device(0).unwrap())
        .unwrap()
        .0
}

/// The golden sequence for an actor with `m` coefficients: 16 frames of head turn, jaw opening
/// and coefficients ramping (`t = f / 16` over `[0, 1)`).
fn sequence(m: usize) -> Vec<Frame> {
    (0..16)
        .map(|f| {
            let t = f as f32 / 16.0;
            Frame {
                jaw: [
                    1.0,
                    0.0,
                    0.0,
                    0.0,
                    1.0 - 0.1 * t,
                    -0.25 * t,
                    0.0,
                    -0.05 * t,
                    0.02 * t,
                ],
                head: [1.0, 0.0, 0.05 * t, 0.0, 1.0, 0.0, 0.3 * t, -0.1 * t, 0.2],
                weights: (0..m).map(|j| ((j + 1) as f32 * 0.13 * t) % 1.0).collect(),
            }
        })
        .collect()
}

/// Records the golden sequence in every mode, pins each replay's bytes and the hash list, and
/// verifies the committed replays through the core.
fn pin_replays(name: &str, model: &[u8]) {
    let actor = AimActor::from_bytes(model).unwrap();
    assert!(
        actor.q16().is_some(),
        "{name}: golden models carry the Q16.16 cache"
    );
    let mut text = String::new();
    writeln!(
        text,
        "# {name}.sinew: {} vertices, {} shapes; per mode and frame: f32/fast hash positions then \
         normals, q16 the positions' raw bits",
        actor.vertex_count(),
        actor.shape_count()
    )
    .unwrap();
    for mode in [Mode::F32, Mode::Q16, Mode::Fast] {
        let file = format!("{name}.{mode}.replay.sinew");
        let replay = record(model, mode, &sequence(actor.shape_count())).unwrap();
        check_bytes(&file, &replay);
        let committed = std::fs::read(golden_dir().join(&file)).unwrap();
        let v = verify(model, &committed).unwrap();
        assert_eq!(v.first_mismatch, None, "{file}");
        for c in &v.frames {
            writeln!(text, "{mode} {} {:016x}", c.frame, c.hash).unwrap();
        }
    }
    // The jaw of a pose given by coefficients alone (`sinew_core::jaw`): each frame's
    // coefficients blended over the actor's learned jaws (the frame's own jaw set aside), the
    // jaw's 9 values hashed, then the f32 frame posed with it and the frame's head.
    writeln!(
        text,
        "# jaw: per frame, the hash of jaw_from_weights(coefficients), then the f32 frame hash \
         with that jaw"
    )
    .unwrap();
    let (v, m) = (actor.vertex_count(), actor.shape_count());
    for (f, frame) in sequence(m).iter().enumerate() {
        let jaw = actor.jaw_from_weights(&frame.weights).unwrap();
        let (mut positions, mut normals) = (vec![0.0; 3 * v], vec![0.0; 3 * v]);
        let mut weights = frame.weights.clone();
        let mut buf = sinew_core::replay::FrameBuffers {
            positions: &mut positions,
            normals: &mut normals,
            positions_q16: &mut [],
            weights: &mut weights,
            weights_q16: &mut [],
        };
        let hash =
            sinew_core::replay::pose_frame_hash(&actor, Mode::F32, &frame.head, &jaw, &mut buf)
                .unwrap();
        writeln!(
            text,
            "jaw {f} {:016x} {hash:016x}",
            sinew_core::hash::frame_hash(&jaw)
        )
        .unwrap();
    }
    check(&format!("{name}.hashes"), &text);
}

#[test]
fn procedural_actor_replays_are_pinned() {
    let path = golden_dir().join(MODEL);
    let bytes = if std::env::var_os("UPDATE_EXPECT").is_some_and(|v| v == "1") {
        let b = with_q16_cache(&bake_golden()).unwrap();
        check_bytes(MODEL, &b);
        b
    } else {
        std::fs::read(&path).unwrap_or_else(|e| {
            panic!(
                "{}: golden model missing ({e}); run with UPDATE_EXPECT=1",
                path.display()
            )
        })
    };
    pin_replays("aim-procedural", &bytes);
}

/// The ICT actor: a decimated ICT-FaceKit face baked from a trained checkpoint (see NOTICE and
/// docs/BENCHMARKS.md for the command); not retrainable in a test, so only its replays are
/// re-recorded under `UPDATE_EXPECT=1`.
#[test]
fn ict_actor_replays_are_pinned() {
    let path = golden_dir().join("aim-ict.sinew");
    let bytes = std::fs::read(&path)
        .unwrap_or_else(|e| panic!("{}: golden model missing ({e})", path.display()));
    pin_replays("aim-ict", &bytes);
}
