use super::*;
use crate::io::data::data_dir;
use crate::performance::tests::golden_actor;
use crate::performance::{PerformanceConfig, generate};

/// A short performance on the golden ICT actor and the actor's basis, or `None` without data.
fn performance(frames: usize) -> Option<(tempfile::TempDir, Performance, Basis)> {
    let kit = data_dir()?.join("ict-facekit");
    let dir = tempfile::tempdir().unwrap();
    let config = PerformanceConfig {
        seed: 5,
        frames,
        ..PerformanceConfig::default()
    };
    generate(&kit, Some(&golden_actor()), &config, dir.path()).unwrap();
    let perf = Performance::read(dir.path()).unwrap();
    let bytes = std::fs::read(golden_actor()).unwrap();
    let names = actor_shape_names(&golden_actor(), &bytes).unwrap();
    assert_eq!(names.len(), 20);
    let basis = Basis::of_performance(&perf, &names).unwrap();
    Some((dir, perf, basis))
}

#[test]
fn gbs_recovers_the_actors_own_shapes() {
    let Some((_dir, mut perf, basis)) = performance(2) else {
        return;
    };
    // Frames made only of the actor's 19 training deltas, moved rigidly.
    let rigid = |a: f64| RigidFit {
        rotation: [
            [a.cos(), 0.0, a.sin()],
            [0.0, 1.0, 0.0],
            [-a.sin(), 0.0, a.cos()],
        ],
        translation: [0.5, -0.3, 0.2],
    };
    for (f, frame) in perf.frames.iter_mut().enumerate() {
        let w = DVector::from_fn(basis.deltas.len(), |i, _| {
            ((i * 7 + f * 3) % 10) as f64 / 10.0
        });
        let r = rigid(0.05 + 0.05 * f as f64);
        *frame = basis
            .shape(&w)
            .iter()
            .map(|&x| r.apply(x).map(|c| c as f32))
            .collect();
    }
    let (_, gbs) = fit_performance(&Gbs::new(basis.clone()), &perf).unwrap();
    let (_, pbs) = fit_performance(&Pbs::new(basis, PATCH_GRID), &perf).unwrap();
    eprintln!("own shapes: GBS {gbs:?}, PBS {pbs:?}");
    assert!(gbs.mean_error_mm < 1e-3, "{gbs:?}");
    assert!(pbs.mean_error_mm < 1e-3, "{pbs:?}");
}

#[test]
fn local_blendshapes_fit_unseen_shapes_better_than_global() {
    let Some((_dir, perf, basis)) = performance(3) else {
        return;
    };
    let (gbs_fit, gbs) = fit_performance(&Gbs::new(basis.clone()), &perf).unwrap();
    let (_, pbs) = fit_performance(&Pbs::new(basis.clone(), PATCH_GRID), &perf).unwrap();
    eprintln!("53-shape performance: GBS {gbs:?}, PBS {pbs:?}");
    assert_eq!(gbs_fit.len(), 3);
    assert!(gbs.mean_error_mm > 0.01, "{gbs:?}");
    assert!(pbs.mean_error_mm < gbs.mean_error_mm, "{pbs:?} vs {gbs:?}");
    // Both beat the rigidly aligned neutral.
    let neutral = Gbs::new(Basis {
        deltas: Vec::new(),
        ..basis
    });
    let (_, rigid_only) = fit_performance(&neutral, &perf).unwrap();
    assert!(
        gbs.mean_error_mm < rigid_only.mean_error_mm,
        "{rigid_only:?}"
    );
}

#[test]
fn a_non_finite_target_is_an_error_naming_the_frame() {
    let Some((_dir, mut perf, basis)) = performance(1) else {
        return;
    };
    perf.frames[0][10][1] = f32::NAN;
    let e = fit_performance(&Gbs::new(basis), &perf).unwrap_err();
    assert!(
        matches!(&e, BaselineError::Frame { path, source: NoRigidAlignment }
            if path.ends_with("frame_00000.obj")),
        "{e:?}"
    );
}

#[test]
fn an_actor_whose_shapes_do_not_start_with_the_neutral_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let mut w = crate::io::container::SinewWriter::new(sinew_core::format::ArtifactKind::AimActor);
    w.u32s("tpl.tri", &[1, 3], &[0, 1, 2]).unwrap();
    w.meta("shapes", "jawOpen,neutral");
    let path = dir.path().join("actor.sinew");
    w.write(&path).unwrap();
    let written = std::fs::read(&path).unwrap();
    let e = actor_shape_names(&path, &written).unwrap_err();
    assert!(
        matches!(&e, BaselineError::ShapesMetadata { path: p, first: Some(first) }
            if *p == path && first == "jawOpen"),
        "{e:?}"
    );
    let damaged = dir.path().join("damaged.sinew");
    std::fs::write(&damaged, &written[..written.len() / 2]).unwrap();
    let e = actor_shape_names(&damaged, &std::fs::read(&damaged).unwrap()).unwrap_err();
    assert!(
        matches!(&e, BaselineError::NotASinewFile { path, .. } if *path == damaged),
        "{e:?}"
    );
}
