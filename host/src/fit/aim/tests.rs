use super::cache::IDENTITY_18;
use super::*;
use crate::fit::aim::{Constrain, Mode, worst_edge_change};
use crate::io::data::data_dir;
use crate::performance::tests::golden_actor;
use crate::performance::{PerformanceConfig, generate};

fn short(coefficients: Coefficients) -> FitConfig {
    FitConfig {
        iterations: 150,
        hidden: 64,
        points: 512,
        coefficients,
        ..FitConfig::default()
    }
}

/// A synthetic performance of `frames` frames (seeded) on the golden actor, in a temporary
/// folder, and the actor's bytes; `None` without the data.
fn golden_performance(
    seed: u64,
    frames: usize,
) -> Option<(tempfile::TempDir, Performance, Vec<u8>)> {
    let data = data_dir()?;
    let dir = tempfile::tempdir().unwrap();
    let config = PerformanceConfig {
        seed,
        frames,
        ..PerformanceConfig::default()
    };
    generate(
        &data.join("ict-facekit"),
        Some(&golden_actor()),
        &config,
        dir.path(),
    )
    .unwrap();
    let perf = Performance::read(dir.path()).unwrap();
    Some((dir, perf, std::fs::read(golden_actor()).unwrap()))
}

#[test]
fn the_fit_reduces_its_error_and_beats_zero_coefficients() {
    let Some((_dir, perf, bytes)) = golden_performance(9, 3) else {
        return;
    };
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let mut errors = Vec::new();
    for c in [
        Coefficients::Zero,
        Coefficients::Global,
        Coefficients::Local,
    ] {
        let r = fit(&actor, &perf, &short(c), Backend::Flex).unwrap();
        eprintln!(
            "{c:?}: {:?} {:.3} s/frame",
            r.error_history, r.seconds_per_frame
        );
        let first = r.error_history[0].1;
        assert!(
            r.mean_error_mm < 0.5 * first,
            "{c:?}: {:?}",
            r.error_history
        );
        assert_eq!(r.meshes.len(), 3);
        assert_eq!(r.weights.is_some(), c == Coefficients::Global);
        // Baked, the fit plays through the core as burn evaluated it.
        let baked = crate::fit::bake::bake(&bytes, &r).unwrap();
        let (played, hashes) = crate::fit::bake::play(&bytes, &baked).unwrap();
        let core: Vec<f32> = played.concat();
        let burn: Vec<f32> = r.meshes.iter().flatten().flatten().copied().collect();
        let worst = core
            .iter()
            .zip(&burn)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        eprintln!("{c:?}: burn vs core playback, max difference {worst:e}");
        let tol = crate::training::tolerance::FIT_PLAYBACK;
        assert_eq!(tol.first_violation(&core, &burn), None, "{c:?}");
        let perf = sinew_core::performance::Performance::from_bytes(&baked).unwrap();
        assert_eq!(perf.is_local(), c == Coefficients::Local);
        assert_eq!(perf.expected(2), Some(hashes[2]));
        errors.push(r.mean_error_mm);
    }
    assert!(errors[1] < errors[0] && errors[2] < errors[0], "{errors:?}");
}

#[test]
fn frames_of_another_topology_are_refused_naming_the_file() {
    let Some(data) = data_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let config = PerformanceConfig {
        frames: 1,
        ..PerformanceConfig::default()
    };
    // The full face region: 9,409 vertices against the golden actor's 4,705.
    generate(&data.join("ict-facekit"), None, &config, dir.path()).unwrap();
    let perf = Performance::read(dir.path()).unwrap();
    let bytes = std::fs::read(golden_actor()).unwrap();
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let e = fit(&actor, &perf, &short(Coefficients::Local), Backend::Flex).unwrap_err();
    assert!(
        matches!(&e, FitError::VertexCount { path, frame_vertices: 9409, actor_vertices: 4705 }
            if path.ends_with("frame_00000.obj")),
        "{e:?}"
    );
}

#[test]
fn constraints_parse_and_refuse_nonsense() {
    assert_eq!("all".parse::<Constrain>(), Ok(Constrain::All));
    assert_eq!("landmarks".parse::<Constrain>(), Ok(Constrain::Landmarks));
    assert_eq!("0.1".parse::<Constrain>(), Ok(Constrain::Fraction(0.1)));
    assert_eq!("1".parse::<Constrain>(), Ok(Constrain::Fraction(1.0)));
    for bad in ["0", "-0.5", "1.5", "NaN", "some"] {
        let e = bad.parse::<Constrain>().unwrap_err();
        assert!(e.contains(bad) && e.contains("fraction"), "{e}");
    }
}

#[test]
fn edge_change_is_the_largest_relative_stretch() {
    // Four edges: the 99th percentile of four is the largest.
    let square = vec![vec![0, 1, 2, 3]];
    let neutral = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    assert_eq!(
        worst_edge_change(&square, &neutral, std::slice::from_ref(&neutral)),
        0.0
    );
    // One frame stretched by 10 % along x, another squeezed by 30 % along y.
    let wide: Vec<[f32; 3]> = neutral.iter().map(|p| [1.1 * p[0], p[1], p[2]]).collect();
    let flat: Vec<[f32; 3]> = neutral.iter().map(|p| [p[0], 0.7 * p[1], p[2]]).collect();
    let w = worst_edge_change(&square, &neutral, &[wide, flat]);
    assert!((w - 0.3).abs() < 1e-6, "{w}");
}

#[test]
fn sparse_and_2d_fits_recover_the_face_from_little() {
    let Some((_dir, perf, bytes)) = golden_performance(4, 2) else {
        return;
    };
    let actor = AimActor::from_bytes(&bytes).unwrap();
    for (mode, constrain) in [
        (Mode::ThreeD, Constrain::Landmarks),
        (Mode::ThreeD, Constrain::Fraction(0.1)),
        (Mode::TwoD, Constrain::All),
    ] {
        let cfg = FitConfig {
            mode,
            constrain,
            ..short(Coefficients::Local)
        };
        let r = fit(&actor, &perf, &cfg, Backend::Flex).unwrap();
        eprintln!(
            "{mode:?} {constrain:?}: {:?}, {:.2} px, edges {:.2} (target {:.2})",
            r.error_history, r.reprojection_px, r.worst_edge_change, r.target_worst_edge_change
        );
        // Fitting a few points still moves the whole face towards the performance.
        let first = r.error_history[0].1;
        assert!(
            r.mean_error_mm < 0.7 * first,
            "{mode:?} {constrain:?}: {:?}",
            r.error_history
        );
        assert!(r.reprojection_px.is_finite() && r.reprojection_px < 10.0);
        // No broken shapes: no edge stretches further than the performance's own do.
        // No broken shapes: edges stretch about as far as the performance's own do.
        assert!(
            r.worst_edge_change < 1.25 * r.target_worst_edge_change,
            "{mode:?} {constrain:?}: edges {} against {}",
            r.worst_edge_change,
            r.target_worst_edge_change
        );
    }
}

#[test]
fn a_resumed_fit_ends_where_an_unbroken_one_does() {
    use crate::fit::checkpoint::Checkpointing;
    let Some((dir, perf, bytes)) = golden_performance(6, 2) else {
        return;
    };
    let actor = AimActor::from_bytes(&bytes).unwrap();
    // A constant rate: a decaying one follows --iterations, so a raised count changes the
    // schedule of the steps already taken.
    let config = |iterations| FitConfig {
        iterations,
        hidden: 16,
        code: 8,
        points: 256,
        lr_final: FitConfig::default().lr,
        ..FitConfig::default()
    };
    let (a_dir, b_dir) = (dir.path().join("a.ckpt"), dir.path().join("b.ckpt"));
    fn ck(dir: &std::path::Path, resume: bool) -> Option<Checkpointing<'_>> {
        Some(Checkpointing { dir, resume })
    }
    let a = fit_resumable(&actor, &perf, &config(40), Backend::Flex, ck(&a_dir, false)).unwrap();
    // Stopped at step 20, then continued to 40.
    fit_resumable(&actor, &perf, &config(20), Backend::Flex, ck(&b_dir, false)).unwrap();
    let b = fit_resumable(&actor, &perf, &config(40), Backend::Flex, ck(&b_dir, true)).unwrap();
    assert_eq!(a.meshes, b.meshes, "the resumed fit differs");
    assert_eq!(a.loss_history, b.loss_history);
    // Other settings are refused, naming the checkpoint's state file.
    let other = FitConfig {
        hidden: 32,
        ..config(40)
    };
    let e = fit_resumable(&actor, &perf, &other, Backend::Flex, ck(&b_dir, true)).unwrap_err();
    use crate::training::checkpoint::{CheckpointError, InvalidState, STATE_FILE};
    assert!(
        matches!(&e, FitError::Checkpoint(CheckpointError::Invalid { path, source: InvalidState::OtherRun { differences } })
            if path.ends_with(STATE_FILE) && *differences == ["settings.hidden: 16 in the checkpoint, 32 now"]),
        "{e:?}"
    );
}

#[test]
fn the_head_starts_where_a_rigid_alignment_puts_it() {
    let Some((_dir, perf, bytes)) = golden_performance(4, 3) else {
        return;
    };
    let actor = AimActor::from_bytes(&bytes).unwrap();
    let mm = perf.unit.mm() as f32;
    let cache = ActorCache::new(&actor, mm);
    let starts = rigid_start(&cache, &perf, Mode::ThreeD, None, mm);
    let column = |r6: &[f32], c: usize| -> [f32; 3] { std::array::from_fn(|i| r6[3 * c + i]) };
    let angle = |a: [f32; 3], b: [f32; 3]| {
        let dot: f32 = (0..3).map(|i| a[i] * b[i]).sum();
        let n = |v: [f32; 3]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
        (dot / (n(a) * n(b))).clamp(-1.0, 1.0).acos()
    };
    for (start, truth) in starts.iter().zip(&perf.manifest.parameters) {
        // The head that posed the frame, up to what the expressions and the jaw tilt (the jaw
        // opens about x: measured 0.03 rad on the second column; a transposed rotation would be
        // twice the head's own 0.07 rad off, a start at the identity as far off as that).
        for c in 0..2 {
            let off = angle(column(start, c), column(&truth.head, c));
            let rest = angle(column(&IDENTITY_18, c), column(&truth.head, c));
            assert!(
                off < 0.05 && off < rest,
                "column {c}: {off} rad from the truth"
            );
        }
        let shift: f32 = (0..3)
            .map(|i| (start[6 + i] - truth.head[6 + i] * mm).powi(2))
            .sum::<f32>()
            .sqrt();
        assert!(shift < 3.0, "translation {shift} mm from the truth");
        // The jaw starts at rest.
        assert_eq!(start[9..], IDENTITY_18[9..]);
    }
    // A 2D fit has no 3D target to align to and starts at the identity.
    let flat = rigid_start(&cache, &perf, Mode::TwoD, None, mm);
    assert!(flat.iter().all(|s| *s == IDENTITY_18));
}

#[test]
fn the_sine_layer_is_for_dense_constraints() {
    let with = |mode, constrain| FitConfig {
        mode,
        constrain,
        ..FitConfig::default()
    };
    let dense = FitConfig::DENSE_OMEGA0;
    assert_eq!(with(Mode::ThreeD, Constrain::All).omega0(), dense);
    assert_eq!(with(Mode::ThreeD, Constrain::Fraction(0.1)).omega0(), dense);
    assert_eq!(with(Mode::ThreeD, Constrain::Landmarks).omega0(), 0.0);
    assert_eq!(with(Mode::TwoD, Constrain::All).omega0(), 0.0);
    let set = FitConfig {
        fw_omega0: Some(7.0),
        mode: Mode::TwoD,
        ..FitConfig::default()
    };
    assert_eq!(set.omega0(), 7.0);
    // F_W's first activation follows it; a global F_W has no template point and stays GELU.
    let device = Backend::Flex.device(1).unwrap();
    let first = |c: &FitConfig| fw_mlp(c, 35, 19, &device).activations[0];
    use sinew_core::nn::Activation;
    assert_eq!(
        first(&FitConfig::default()),
        Activation::Sine { omega0: dense }
    );
    assert_eq!(first(&with(Mode::TwoD, Constrain::All)), Activation::Gelu);
    let global = FitConfig {
        coefficients: Coefficients::Global,
        ..FitConfig::default()
    };
    assert_eq!(first(&global), Activation::Gelu);
    // A checkpoint from before the sine layer reads as all-GELU.
    let mut old = serde_json::to_value(FitConfig::default()).unwrap();
    old.as_object_mut().unwrap().remove("fw_omega0");
    let old: FitConfig = serde_json::from_value(old).unwrap();
    assert_eq!(old.omega0(), 0.0);
}
