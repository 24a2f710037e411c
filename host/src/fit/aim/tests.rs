use super::*;
use crate::fit::aim::{Constrain, Mode, worst_edge_change};
use crate::fit::performance::tests::golden_actor;
use crate::fit::performance::{PerformanceConfig, generate};
use crate::io::data::data_dir;

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
    let config = |iterations| FitConfig {
        iterations,
        hidden: 16,
        code: 8,
        points: 256,
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
            if path.ends_with(STATE_FILE) && differences.len() == 1 && differences[0].starts_with("settings:")),
        "{e:?}"
    );
}
