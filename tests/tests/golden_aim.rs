//! Golden AIM playback: a small baked actor (the procedural face, trained briefly and committed,
//! since training is reproducible only per build) posed through a fixed sequence by the core;
//! the per-frame hashes are pinned. The same files drive the firmware replays.
//!
//! `UPDATE_EXPECT=1` retrains and rewrites both the model and the hash list.

use std::fmt::Write;

use sinew_core::aim::AimActor;
use sinew_core::hash::FrameHasher;
use sinew_tests::{check, check_bytes, golden_dir};

const MODEL: &str = "aim-procedural.sinew";

/// Trains and bakes the golden actor (only under `UPDATE_EXPECT=1`).
fn bake_golden() -> Vec<u8> {
    use sinew_host::aim::AimConfig;
    use sinew_host::aim::bake::{BakeInput, bake};
    use sinew_host::aim::data::training_set;
    use sinew_host::aim::train::{TrainOptions, train};
    use sinew_host::backend::Backend;
    let (actor, bones) = sinew_host::procedural::actor(16);
    let set = training_set(&actor, &bones.skull, &bones.jaw, Some(bones.jaw_pivot), 2.5).unwrap();
    let config = AimConfig {
        hidden: 32,
        layers: 2,
        batch: 1024,
        symmetry_batch: 64,
        forehead_batch: 64,
        iterations: 400,
        lr: 1e-3,
        lr_end: 1e-4,
        ..AimConfig::default()
    };
    let dir = tempfile::tempdir().unwrap();
    let options = TrainOptions {
        backend: Backend::Flex,
        checkpoint_dir: dir.path().to_path_buf(),
        resume: false,
        stop_after: None,
        quiet: true,
    };
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

/// Frame `f` of the golden sequence: head turn, jaw opening, coefficients ramping.
fn pose(actor: &AimActor<'_>, f: usize) -> (sinew_core::skinning::Pose, Vec<f32>) {
    let t = f as f32 / 16.0;
    let jaw = [
        1.0,
        0.0,
        0.0,
        0.0,
        1.0 - 0.1 * t,
        -0.25 * t,
        0.0,
        -0.05 * t,
        0.02 * t,
    ];
    let head = [1.0, 0.0, 0.05 * t, 0.0, 1.0, 0.0, 0.3 * t, -0.1 * t, 0.2];
    let weights = (0..actor.shape_count())
        .map(|j| ((j + 1) as f32 * 0.13 * t) % 1.0)
        .collect();
    (actor.pose_from_9d(&jaw, &head), weights)
}

#[test]
fn aim_playback_hashes_are_pinned() {
    let path = golden_dir().join(MODEL);
    let bytes = if std::env::var_os("UPDATE_EXPECT").is_some_and(|v| v == "1") {
        let b = bake_golden();
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
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let mut text = String::new();
    writeln!(
        text,
        "# {MODEL}: {} vertices, {} shapes; frame hash of positions then normals",
        actor.vertex_count(),
        actor.shape_count()
    )
    .unwrap();
    let mut positions = vec![0.0; 3 * actor.vertex_count()];
    let mut normals = vec![0.0; 3 * actor.vertex_count()];
    for f in 0..16 {
        let (p, w) = pose(&actor, f);
        actor.pose(&p, &w, &mut positions).unwrap();
        actor.normals(&positions, &mut normals).unwrap();
        let mut h = FrameHasher::new();
        h.write_f32s(&positions);
        h.write_f32s(&normals);
        writeln!(text, "{f} {:016x}", h.finish()).unwrap();
    }
    check("aim-procedural.hashes", &text);
}
