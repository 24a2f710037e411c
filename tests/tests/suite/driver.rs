//! The core's landmark driver on files the host bakes: validation (kind, shapes, value bounds,
//! the binding to its actor), evaluation of a pose the actor accepts without allocation, the same
//! bits on every call, and refusal of a caller's non-finite landmarks.

use burn::tensor::Device;
use sinew_core::SinewFile;
use sinew_core::aim::AimActor;
use sinew_core::driver::{
    CALIBRATION_DEPTH, DriveBuffers, Driver, Intrinsics, LANDMARKS, STEADY, Space,
    drive_frame_hash, features, normalise_pixels,
};
use sinew_core::error::{Argument, Bound, InputError, InputErrorKind};
use sinew_core::replay::{ReplayError, model_hash};
use sinew_core::{EvalError, FormatError};
use sinew_host::SinewWriter;
use sinew_host::driver::bake::{BakeInputs, bake};
use sinew_host::driver::sample::Sampler;
use sinew_host::driver::train::{Normalisation, network};
use sinew_host::driver::{CALIBRATION_DEPTH_SHARE, DriverConfig};
use sinew_host::training::random::Stream;
use sinew_tests::golden_dir;

fn actor_bytes() -> Vec<u8> {
    std::fs::read(golden_dir().join("aim-ict.sinew")).unwrap()
}

/// A driver for the golden actor with random weights (16 hidden units), and the sampler.
fn baked(actor: &[u8], edit: impl FnOnce(&mut Normalisation)) -> (Vec<u8>, Sampler) {
    baked_with(
        actor,
        DriverConfig {
            hidden: 16,
            ..DriverConfig::default()
        },
        edit,
    )
}

/// [`baked`] with other settings.
fn baked_with(
    actor: &[u8],
    config: DriverConfig,
    edit: impl FnOnce(&mut Normalisation),
) -> (Vec<u8>, Sampler) {
    let a = AimActor::from_bytes(actor).unwrap();
    let vertices = sinew_host::driver::landmark_vertices(&golden_dir(), &a).unwrap();
    let sampler = Sampler::new(&a, &vertices, &config);
    let mut norm = Normalisation::measure(&sampler, 1);
    edit(&mut norm);
    let device: Device = sinew_host::training::backend::Backend::default()
        .device(3)
        .unwrap();
    let net = network(config.input.features(), 16, 18 + a.shape_count(), &device);
    let bytes = bake(
        &net,
        &norm,
        &config,
        &BakeInputs {
            actor_hash: model_hash(actor),
            units: "cm",
            vertices: &vertices,
            camera: sampler.camera,
        },
    )
    .unwrap();
    (bytes, sampler)
}

#[test]
fn a_driver_drives_its_actor_to_the_same_bits_every_time() {
    let actor_bytes = actor_bytes();
    let actor = AimActor::from_bytes(&actor_bytes).unwrap();
    let (bytes, sampler) = baked(&actor_bytes, |_| {});
    let driver = Driver::from_bytes(&bytes).unwrap();
    driver.check_actor(&actor_bytes, &actor).unwrap();
    assert_eq!(driver.input_len(), 136);
    assert_eq!(driver.output_len(), 18 + actor.shape_count());
    let sample = sampler.sample(&mut Stream::seed_from_u64(5));
    let v = actor.vertex_count();
    let run = || {
        let mut scratch = vec![0.0; driver.scratch_len()];
        let mut pose = vec![0.0; driver.output_len()];
        let (mut positions, mut normals) = (vec![0.0; 3 * v], vec![0.0; 3 * v]);
        let h = drive_frame_hash(
            &driver,
            &actor,
            &sample.input,
            &mut DriveBuffers {
                scratch: &mut scratch,
                pose: &mut pose,
                positions: &mut positions,
                normals: &mut normals,
            },
        )
        .unwrap();
        (h, pose)
    };
    let (h, pose) = run();
    assert_eq!(run(), (h, pose.clone()));
    assert!(pose.iter().all(|x| x.is_finite()));
    // The rotations come out orthonormal whatever the network says.
    for half in [0, 9] {
        let (a, b) = (&pose[half..half + 3], &pose[half + 3..half + 6]);
        let dot: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum();
        let na: f32 = a.iter().map(|x| x * x).sum();
        assert!(dot.abs() < 1e-5 && (na - 1.0).abs() < 1e-5, "{a:?} {b:?}");
    }
    // Landmarks of the actor come back from its vertices.
    let mut flat = vec![0.0; 3 * v];
    sinew_core::driver::play(&actor, &pose, &mut flat).unwrap();
    let mut lmk = vec![0.0; 3 * LANDMARKS];
    driver.landmarks_of(&flat, &mut lmk).unwrap();
    let l0 = driver.landmark_vertex(0).unwrap();
    assert_eq!(&lmk[..3], &flat[3 * l0..3 * l0 + 3]);
}

#[test]
fn non_finite_landmarks_are_refused_and_nothing_is_written() {
    let actor_bytes = actor_bytes();
    let (bytes, sampler) = baked(&actor_bytes, |_| {});
    let driver = Driver::from_bytes(&bytes).unwrap();
    let mut input = sampler.sample(&mut Stream::seed_from_u64(1)).input;
    let mut scratch = vec![0.0; driver.scratch_len()];
    let mut pose = vec![7.0; driver.output_len()];
    for (bad, kind) in [
        (f32::NAN, InputErrorKind::NonFinite),
        (f32::INFINITY, InputErrorKind::NonFinite),
        (1e9, InputErrorKind::OutOfRange),
    ] {
        input[17] = bad;
        assert_eq!(
            driver.drive(&input, &mut scratch, &mut pose),
            Err(EvalError::Input(InputError::new(
                Argument::Landmarks,
                17,
                kind
            )))
        );
        assert!(pose.iter().all(|&x| x == 7.0), "nothing is written");
    }
    // Landmarks that all coincide have no spread to scale by.
    pose.fill(7.0);
    assert_eq!(
        driver.drive(&[0.01; 136], &mut scratch, &mut pose),
        Err(EvalError::Input(InputError::new(
            Argument::Landmarks,
            0,
            InputErrorKind::Degenerate
        )))
    );
    assert!(pose.iter().all(|&x| x == 7.0), "nothing is written");
    let mut out = vec![0.0; 136];
    let camera = Intrinsics {
        fx: 0.0,
        fy: 500.0,
        cx: 320.0,
        cy: 240.0,
    };
    assert_eq!(
        normalise_pixels(&vec![100.0; 136], &camera, &mut out),
        Err(EvalError::Input(InputError::new(
            Argument::Landmarks,
            136,
            InputErrorKind::OutOfRange
        )))
    );
}

#[test]
fn the_2d_features_separate_where_the_face_is_and_how_large_it_looks_from_its_shape() {
    let actor_bytes = actor_bytes();
    let (_, sampler) = baked(&actor_bytes, |_| {});
    let input = sampler.sample(&mut Stream::seed_from_u64(2)).input;
    let mut f = vec![0.0; Space::Image.features()];
    features(Space::Image, &input, &mut f).unwrap();
    // The steady landmarks are centred on the origin with unit spread.
    let steady = &f[2 * STEADY.start..2 * STEADY.end];
    let n = STEADY.len() as f32;
    let (cx, cy) = (
        steady.iter().step_by(2).sum::<f32>() / n,
        steady.iter().skip(1).step_by(2).sum::<f32>() / n,
    );
    assert!(cx.abs() < 1e-5 && cy.abs() < 1e-5, "{cx} {cy}");
    let spread = (steady.iter().map(|x| x * x).sum::<f32>() / n).sqrt();
    assert!((spread - 1.0).abs() < 1e-5, "{spread}");
    // The face twice as large and moved: the same shape, its centre and the spread's
    // logarithm follow.
    let moved: Vec<f32> = input
        .chunks_exact(2)
        .flat_map(|p| {
            [
                f[136] + 2.0 * (p[0] - f[136]) + 0.1,
                f[137] + 2.0 * (p[1] - f[137]) - 0.05,
            ]
        })
        .collect();
    let mut g = vec![0.0; Space::Image.features()];
    features(Space::Image, &moved, &mut g).unwrap();
    for (a, b) in f[..136].iter().zip(&g[..136]) {
        assert!((a - b).abs() < 1e-4, "{a} against {b}");
    }
    assert!((g[136] - f[136] - 0.1).abs() < 1e-5);
    assert!((g[137] - f[137] + 0.05).abs() < 1e-5);
    assert!((g[138] - f[138] - 2f32.ln()).abs() < 1e-5);
    // 3D landmarks are read as they are.
    let world: Vec<f32> = (0..204).map(|i| i as f32 * 0.1).collect();
    let mut w = vec![0.0; 204];
    features(Space::World, &world, &mut w).unwrap();
    assert_eq!(w, world);
}

#[test]
fn a_driver_refuses_another_actor_and_bad_values() {
    let actor_bytes = actor_bytes();
    let (bytes, _) = baked(&actor_bytes, |_| {});
    let driver = Driver::from_bytes(&bytes).unwrap();
    let other = std::fs::read(golden_dir().join("aim-procedural.sinew")).unwrap();
    let actor = AimActor::from_bytes(&other).unwrap();
    assert!(matches!(
        driver.check_actor(&other, &actor),
        Err(ReplayError::WrongModel { .. })
    ));
    let (bytes, _) = baked(&actor_bytes, |n| n.input_scale[3] = 0.0);
    let e = Driver::from_bytes(&bytes).unwrap_err();
    assert!(
        matches!(
            e,
            FormatError::ValueOutOfRange {
                index: 142,
                bound: Bound::PositiveFactor,
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("drv.in"), "{e}");
    let (bytes, _) = baked(&actor_bytes, |n| n.output_offset[20] = 1e9);
    let e = Driver::from_bytes(&bytes).unwrap_err();
    assert!(e.to_string().contains("drv.out"), "{e}");
    assert_eq!(
        Driver::from_bytes(&actor_bytes).unwrap_err(),
        FormatError::WrongKind
    );
}

/// A 2D driver trained on trackers' conventions records the share of its own answer in the
/// calibrated head's depth, one trained without them records none (the calibration's head then
/// as before); the core reads it and refuses an entry that is not a number from 0 to 1, naming
/// the key.
#[test]
fn a_driver_records_its_calibration_depth_share() {
    let actor_bytes = actor_bytes();
    let (bytes, _) = baked(&actor_bytes, |_| {});
    let driver = Driver::from_bytes(&bytes).unwrap();
    assert_eq!(driver.calibration_depth(), CALIBRATION_DEPTH_SHARE);
    let plain = DriverConfig {
        hidden: 16,
        convention_amplitude: 0.0,
        ..DriverConfig::default()
    };
    let (bytes_plain, _) = baked_with(&actor_bytes, plain, |_| {});
    let file = SinewFile::from_bytes(&bytes_plain).unwrap();
    assert!(file.metadata().get(CALIBRATION_DEPTH).is_none());
    assert_eq!(
        Driver::from_bytes(&bytes_plain)
            .unwrap()
            .calibration_depth(),
        0.0
    );
    for (value, ok) in [
        ("0", true),
        ("1", true),
        ("0.25", true),
        ("1.5", false),
        ("-0.1", false),
        ("NaN", false),
        ("a third", false),
    ] {
        let file = SinewFile::from_bytes(&bytes).unwrap();
        let mut w = SinewWriter::from_file(&file).unwrap();
        w.meta(CALIBRATION_DEPTH, value);
        let edited = w.to_bytes().unwrap();
        match Driver::from_bytes(&edited) {
            Ok(d) => {
                assert!(ok, "{value} was read");
                assert_eq!(d.calibration_depth(), value.parse::<f32>().unwrap());
            }
            Err(e) => {
                assert!(!ok, "{value}: {e}");
                assert!(matches!(e, FormatError::BadMetadata { .. }), "{e:?}");
                assert!(e.to_string().contains(CALIBRATION_DEPTH), "{e}");
            }
        }
    }
}
