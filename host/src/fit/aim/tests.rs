use super::*;
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

#[test]
fn the_fit_reduces_its_error_and_beats_zero_coefficients() {
    let Some(data) = data_dir() else { return };
    let dir = tempfile::tempdir().unwrap();
    let config = PerformanceConfig {
        seed: 9,
        frames: 3,
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
    let bytes = std::fs::read(golden_actor()).unwrap();
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
    let e = format!("{e:#}");
    assert!(e.contains("frame_00000.obj") && e.contains("4705"), "{e}");
}
