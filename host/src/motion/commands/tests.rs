use super::*;
use crate::motion::train::TangentData;
use crate::training::checkpoint::{CheckpointError, InvalidState, STATE_FILE};
use sinew_core::error::Bound;
use std::path::Path;

/// Unit motions of two labels with 6 coordinates (2 landmarks) per frame.
fn toy() -> TangentData {
    TangentData::from_motions(&toy_motions(), (0..12).map(|k| k % 2).collect()).unwrap()
}

/// The unit motions of [`toy`], the even ones of one kind and the odd ones of another.
fn toy_motions() -> Vec<Vec<f32>> {
    let d = FRAMES * 6;
    (0..12)
        .map(|k| {
            let v: Vec<f32> = (0..d)
                .map(|i| ((i * (k % 2 + 1)) as f32 * 0.1 + k as f32 * 0.01).cos() + 0.5)
                .collect();
            let n = sinew_core::srvf::norm(&v).unwrap();
            v.into_iter().map(|x| x / n).collect()
        })
        .collect()
}

fn config() -> GanConfig {
    GanConfig {
        seed: 11,
        steps: 6,
        batch: 4,
        lr: 1e-3,
        noise: 4,
        hidden: vec![16],
        // The paper's losses: each test that wants a term of its own turns it on.
        diversity: 0.0,
        class_weight: 0.0,
        ..GanConfig::default()
    }
}

fn run_to(data: &TangentData, config: &GanConfig, run: Run, until: usize) -> Run {
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    run.advance(
        data,
        config,
        &device,
        until,
        &mut |_: usize, _: &StepLosses| {},
        &mut || false,
    )
}

#[test]
fn a_resumed_run_continues_bit_for_bit() {
    eprintln!("seed {}", config().seed);
    let (data, config) = (toy(), config());
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let half = run_to(
        &data,
        &config,
        Run::new(&data, &config, &device).unwrap(),
        3,
    );
    let dir = tempfile::tempdir().unwrap();
    save_checkpoint(dir.path(), &half, &config, &data).unwrap();
    let straight = run_to(&data, &config, half, 6);

    let loaded = load_checkpoint(
        dir.path(),
        Run::new(&data, &config, &device).unwrap(),
        &config,
        &data,
    )
    .unwrap();
    assert_eq!(loaded.step, 3);
    let resumed = run_to(&data, &config, loaded, 6);
    let bits = |h: &[StepLosses]| -> Vec<u32> {
        h.iter()
            .flat_map(|l| [l.critic, l.generator, l.penalty, l.reconstruction])
            .map(f32::to_bits)
            .collect()
    };
    assert_eq!(resumed.history.len(), 6);
    assert_eq!(bits(&resumed.history), bits(&straight.history));
    assert_eq!(
        bake(&resumed.generator, &data, &config).unwrap(),
        bake(&straight.generator, &data, &config).unwrap()
    );

    // Another run's settings are refused, naming the state file and the setting.
    let other = GanConfig {
        lr: 2e-3,
        ..config.clone()
    };
    let e = load_checkpoint(
        dir.path(),
        Run::new(&data, &other, &device).unwrap(),
        &other,
        &data,
    )
    .unwrap_err();
    assert!(
        matches!(&e, CheckpointError::Invalid { path, source: InvalidState::OtherRun { differences } }
            if path.ends_with(STATE_FILE)
                && differences == &["settings.lr: 0.001 in the checkpoint, 0.002 now"]),
        "{e:?}"
    );
    assert!(format!("{e:#}").contains(STATE_FILE), "{e:#}");
    // So are other training motions, and a state whose history does not fit its steps.
    let mut moved = toy();
    moved.p[0] += 1.0;
    let e = load_checkpoint(
        dir.path(),
        Run::new(&moved, &config, &device).unwrap(),
        &config,
        &moved,
    )
    .unwrap_err();
    assert!(
        matches!(&e, CheckpointError::Invalid { source: InvalidState::OtherRun { differences }, .. }
            if differences.len() == 1 && differences[0].starts_with("training motions")),
        "{e:?}"
    );
    let path = dir.path().join(STATE_FILE);
    let mut state: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    state["steps_done"] = serde_json::json!(2);
    std::fs::write(&path, serde_json::to_vec(&state).unwrap()).unwrap();
    let e = load_checkpoint(
        dir.path(),
        Run::new(&data, &config, &device).unwrap(),
        &config,
        &data,
    )
    .unwrap_err();
    assert!(
        matches!(
            &e,
            CheckpointError::Invalid {
                source: InvalidState::History {
                    recorded: 3,
                    done: 2
                },
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn the_baked_generator_is_a_motion_generator_the_core_reads() {
    let (data, config) = (toy(), config());
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let run = run_to(
        &data,
        &config,
        Run::new(&data, &config, &device).unwrap(),
        1,
    );
    let bytes = bake(&run.generator, &data, &config).unwrap();
    let file =
        sinew_core::SinewFile::from_bytes_of_kind(&bytes, ArtifactKind::MotionGenerator).unwrap();
    assert_eq!(file.metadata().get("content"), Some(CONTENT));
    let mlp = sinew_core::network::load_mlp(&file, "motion.g").unwrap();
    assert_eq!(mlp.inputs(), config.noise + LABELS.len());
    assert_eq!(mlp.outputs(), data.dims());
    let p: Vec<f32> = file
        .f32_tensor("motion.p", &[FRAMES as u32, 6])
        .unwrap()
        .iter()
        .collect();
    assert_eq!(p, data.p);

    // The core generates what burn's generator gives for the core's noise, then the exp map.
    let core = sinew_core::motion::MotionGenerator::from_bytes(&bytes).unwrap();
    assert_eq!(core.noise_len(), config.noise);
    let mut scratch = vec![0.0f32; core.scratch_len()];
    let mut q = vec![0.0f32; core.motion_len()];
    for (label, seed) in [(0usize, 42u64), (1, 7), (11, 7)] {
        core.motion(label, seed, &mut scratch, &mut q).unwrap();
        let mut z = vec![0.0f32; config.noise];
        sinew_core::motion::gaussian_noise(seed, &mut z);
        let input = burn::tensor::Tensor::cat(
            vec![
                crate::training::nn::tensor(z, [1, config.noise], &device),
                crate::motion::labels::one_hot(&[label], LABELS.len(), &device),
            ],
            1,
        );
        let p_t = crate::training::nn::tensor(data.p.clone(), [1, data.dims()], &device);
        let s = crate::training::nn::to_vec(run.generator.forward(input, p_t));
        let expected = crate::motion::srvf::exp(&data.p, &s).unwrap();
        let worst = q
            .iter()
            .zip(&expected)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst < 1e-4,
            "label {label} seed {seed}: core differs from burn by {worst}"
        );
        assert!((sinew_core::srvf::norm(&q).unwrap() - 1.0).abs() < 1e-5);
        // Bit for bit again, and another seed gives another motion.
        let mut again = vec![0.0f32; q.len()];
        core.motion(label, seed, &mut scratch, &mut again).unwrap();
        assert_eq!(again, q);
        core.motion(label, seed + 1, &mut scratch, &mut again)
            .unwrap();
        assert_ne!(again, q);
    }
    // Landmarks: frame 0 is the neutral, and the intensity scales the motion.
    let neutral = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0];
    let mut curve = vec![0.0f32; core.curve_len()];
    let mut half = curve.clone();
    core.landmarks(3, 9, 1.0, &neutral, &mut scratch, &mut curve)
        .unwrap();
    core.landmarks(3, 9, 0.5, &neutral, &mut scratch, &mut half)
        .unwrap();
    assert_eq!(&curve[..6], &neutral);
    let last = FRAMES * 6;
    for k in 0..6 {
        let full = curve[last + k] - neutral[k];
        assert!((half[last + k] - neutral[k] - 0.5 * full).abs() < 1e-5);
    }
    assert_eq!(
        core.motion(12, 1, &mut scratch, &mut q),
        Err(sinew_core::BufferError::Input)
    );
    assert_eq!(
        core.landmarks(0, 1, 1.0, &neutral[..3], &mut scratch, &mut curve),
        Err(sinew_core::BufferError::Input.into())
    );

    // Diversity: different seeds give different motions of one label, at a positive mean
    // geodesic distance, per label and overall.
    let (per_label, mean) = crate::motion::diversity::diversity(&core, 4).unwrap();
    assert_eq!(per_label.len(), LABELS.len());
    assert!(
        per_label
            .iter()
            .all(|&d| d > 0.0 && d < std::f32::consts::PI)
    );
    let mut a = vec![0.0f32; core.motion_len()];
    let mut b = a.clone();
    let mut sum = 0.0f64;
    for (i, j) in [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)] {
        core.motion(5, i, &mut scratch, &mut a).unwrap();
        core.motion(5, j, &mut scratch, &mut b).unwrap();
        sum += f64::from(crate::motion::srvf::distance(&a, &b).unwrap());
    }
    assert!((per_label[5] - (sum / 6.0) as f32).abs() < 1e-6);
    assert!((mean - per_label.iter().sum::<f32>() / 12.0).abs() < 1e-5);
    assert_eq!(
        crate::motion::diversity::diversity(&core, 1),
        Err(crate::motion::diversity::DiversityError::TooFewSeeds)
    );
}

#[test]
fn a_damaged_optimiser_file_is_named() {
    let (data, config) = (toy(), config());
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let run = run_to(
        &data,
        &config,
        Run::new(&data, &config, &device).unwrap(),
        1,
    );
    let dir = tempfile::tempdir().unwrap();
    save_checkpoint(dir.path(), &run, &config, &data).unwrap();
    let state_path = dir.path().join(STATE_FILE);
    let state: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&state_path).unwrap()).unwrap();
    let name = state["files"]["optim_file"].as_str().unwrap().to_owned();
    let whole = std::fs::read(dir.path().join(&name)).unwrap();
    // Bytes whose CRC state.json records, so that only their layout is wrong.
    let rewrite = |bytes: &[u8]| {
        std::fs::write(dir.path().join(&name), bytes).unwrap();
        let mut state = state.clone();
        state["files"]["optim_crc"] =
            serde_json::json!(crate::training::checkpoint::crc_hex(bytes));
        std::fs::write(&state_path, serde_json::to_vec(&state).unwrap()).unwrap();
        load_checkpoint(
            dir.path(),
            Run::new(&data, &config, &device).unwrap(),
            &config,
            &data,
        )
        .unwrap_err()
    };
    let mut longer = whole.clone();
    longer.push(0);
    let e = rewrite(&longer);
    assert!(
        matches!(&e, CheckpointError::TrailingBytes { path } if path.ends_with(&name)),
        "{e:?}"
    );
    let e = rewrite(&whole[..whole.len() - 1]);
    assert!(
        matches!(&e, CheckpointError::Truncated { path } if path.ends_with(&name)),
        "{e:?}"
    );
    let e = rewrite(&whole[..4]);
    assert!(matches!(&e, CheckpointError::Truncated { .. }), "{e:?}");
    assert!(e.to_string().contains(&name), "{e}");
}

/// `intensity × max(0, m + s · g)`: the length or reach `seed` draws from a label's mean and
/// spread, g being the seed's Gaussian value right after its `noise` values.
fn drawn(seed: u64, noise: usize, [m, s]: [f32; 2], intensity: f32) -> f32 {
    let mut z = vec![0.0f32; noise + 1];
    sinew_core::motion::gaussian_noise(seed, &mut z);
    intensity * (m + s * z[noise]).max(0.0)
}

/// A generator file of `run`'s generator and `data`'s reference motion (6 coordinates a frame)
/// with the given `motion.length` and, if any, reaches (section name, shape, values), unchecked.
fn generator_file(
    run: &Run,
    data: &TangentData,
    length: (&[usize], &[f32]),
    reach: Option<(&str, &[usize], &[f32])>,
) -> Vec<u8> {
    let mut w = SinewWriter::new(ArtifactKind::MotionGenerator);
    w.meta("content", CONTENT);
    run.generator.mlp.export(&mut w, "motion.g").unwrap();
    w.f32s("motion.p", &[FRAMES, 6], &data.p).unwrap();
    w.f32s("motion.length", length.0, length.1).unwrap();
    if let Some((name, shape, values)) = reach {
        w.f32s(name, shape, values).unwrap();
    }
    w.to_bytes().unwrap()
}

#[test]
fn a_generator_the_core_refuses_is_not_baked() {
    let (mut data, config) = (toy(), config());
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let run = run_to(
        &data,
        &config,
        Run::new(&data, &config, &device).unwrap(),
        1,
    );
    data.lengths[0] = [-1.0, 0.0];
    let e = bake(&run.generator, &data, &config).unwrap_err();
    assert!(
        format!("{e:#}").contains("does not validate in sinew-core"),
        "{e:#}"
    );
}

#[test]
fn the_length_is_drawn_from_the_labels_training_lengths() {
    let (mut data, config) = (toy(), config());
    data.lengths[0] = [0.2, 0.05];
    data.lengths[1] = [0.5, 0.0];
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let run = run_to(
        &data,
        &config,
        Run::new(&data, &config, &device).unwrap(),
        1,
    );
    let bytes = bake(&run.generator, &data, &config).unwrap();
    let core = sinew_core::motion::MotionGenerator::from_bytes(&bytes).unwrap();
    assert_eq!((core.length(0), core.length_spread(0)), (0.2, 0.05));
    assert_eq!((core.length(1), core.length_spread(1)), (0.5, 0.0));
    assert_eq!((core.length(2), core.length_spread(2)), (1.0, 0.0));

    let neutral = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0];
    let mut scratch = vec![0.0f32; core.scratch_len()];
    let mut q = vec![0.0f32; core.motion_len()];
    let mut curve = vec![0.0f32; core.curve_len()];
    let mut expected = curve.clone();
    let mut lengths = Vec::new();
    for seed in [3u64, 4, 5] {
        for (label, intensity) in [(0usize, 1.0f32), (0, 0.5), (1, 1.0)] {
            core.landmarks(label, seed, intensity, &neutral, &mut scratch, &mut curve)
                .unwrap();
            let length = drawn(seed, config.noise, data.lengths[label], intensity);
            core.motion(label, seed, &mut scratch, &mut q).unwrap();
            sinew_core::srvf::decode(&q, &neutral, length, &mut expected).unwrap();
            assert_eq!(curve, expected, "label {label}, seed {seed}");
            if label == 0 && intensity == 1.0 {
                lengths.push(length);
            }
        }
    }
    // Label 0's lengths differ by seed; label 1 has no spread.
    assert!(lengths.windows(2).all(|w| w[0] != w[1]), "{lengths:?}");

    // A file with one length for every label (as generators were first baked) decodes every
    // label at that length, and broken lengths are refused.
    let with_lengths =
        |shape: &[usize], values: &[f32]| generator_file(&run, &data, (shape, values), None);
    let one = with_lengths(&[1], &[0.3]);
    let core = sinew_core::motion::MotionGenerator::from_bytes(&one).unwrap();
    for label in [0usize, 7] {
        assert_eq!((core.length(label), core.length_spread(label)), (0.3, 0.0));
        core.landmarks(label, 3, 1.0, &neutral, &mut scratch, &mut curve)
            .unwrap();
        core.motion(label, 3, &mut scratch, &mut q).unwrap();
        sinew_core::srvf::decode(&q, &neutral, 0.3, &mut expected).unwrap();
        assert_eq!(curve, expected);
    }
    let mut negative = data.lengths_flat();
    negative[3] = -0.1;
    for (shape, values) in [
        (vec![LABELS.len(), 2], negative),
        (vec![1], vec![0.0]),
        (vec![2], vec![0.3, 0.3]),
        (vec![LABELS.len(), 3], vec![0.3; 3 * LABELS.len()]),
    ] {
        assert!(
            sinew_core::motion::MotionGenerator::from_bytes(&with_lengths(&shape, &values))
                .is_err(),
            "{shape:?}"
        );
    }
}

#[test]
fn the_reach_is_drawn_from_the_labels_training_reaches() {
    let (mut data, config) = (toy(), config());
    let mut log_reaches = vec![[0.3f32.ln(), 0.0]; LABELS.len()];
    log_reaches[0] = [0.2f32.ln(), 0.25];
    data.log_reaches = Some(log_reaches.clone());
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let run = run_to(
        &data,
        &config,
        Run::new(&data, &config, &device).unwrap(),
        1,
    );
    let bytes = bake(&run.generator, &data, &config).unwrap();
    let core = sinew_core::motion::MotionGenerator::from_bytes(&bytes).unwrap();
    let typical = |label| (core.reach(label).unwrap() - [0.2, 0.3][label]).abs();
    assert!(typical(0) < 1e-6 && typical(1) < 1e-6);
    // A reach drawn log-normally: exp(m + s · g), times the intensity.
    let log_normal = |seed, [m, s]: [f32; 2], intensity| {
        intensity * (m + s * drawn(seed, config.noise, [0.0, 1.0], 1.0)).exp()
    };
    let apexes = check_apexes(&core, &log_reaches, &log_normal);
    // Label 0's reaches differ by seed.
    assert!(apexes.windows(2).all(|w| w[0] != w[1]), "{apexes:?}");
    // Never 0, even for a spread as wide as the mean, where a normal draw gives still faces.
    let mut z = vec![0.0f32; config.noise + 1];
    let (mut still, mut zero) = (0, 0);
    for seed in 0..400u64 {
        sinew_core::motion::gaussian_noise(seed, &mut z);
        still += usize::from((0.2 + 0.2 * z[config.noise]).max(0.0) == 0.0);
        zero += usize::from((0.2f32.ln() + 1.0 * z[config.noise]).exp() == 0.0);
    }
    assert!(still > 0 && zero == 0, "{still} {zero}");

    // Generators baked 2026-11-27 draw the reach normally from `motion.reach`, as before.
    let reaches = vec![[0.2f32, 0.05]; LABELS.len()];
    let flat: Vec<f32> = reaches.iter().flatten().copied().collect();
    let old = generator_file(
        &run,
        &data,
        (&[1], &[0.3]),
        Some(("motion.reach", &[LABELS.len(), 2], &flat)),
    );
    let core = sinew_core::motion::MotionGenerator::from_bytes(&old).unwrap();
    assert_eq!(core.reach(0), Some(0.2));
    check_apexes(&core, &reaches, &|seed, pair, intensity| {
        drawn(seed, config.noise, pair, intensity)
    });

    // Broken reaches are refused.
    let with = |name: &str, shape: &[usize], values: &[f32]| {
        let bytes = generator_file(&run, &data, (&[1], &[0.3]), Some((name, shape, values)));
        sinew_core::motion::MotionGenerator::from_bytes(&bytes).err()
    };
    let good = data.log_reaches_flat().unwrap();
    assert_eq!(with("motion.log_reach", &[LABELS.len(), 2], &good), None);
    let mut negative = good.clone();
    negative[3] = -0.1;
    let mut wide = good.clone();
    // exp(0 + 5.8 · 1.5) passes 1e3.
    (wide[4], wide[5]) = (0.0, 1.5);
    let mut zero = flat.clone();
    zero[2] = 0.0;
    for (name, shape, values, index, bound) in [
        (
            "motion.log_reach",
            vec![LABELS.len(), 2],
            negative,
            3,
            Bound::NonNegativeFactor,
        ),
        (
            "motion.log_reach",
            vec![LABELS.len(), 2],
            wide,
            5,
            Bound::LogNormalFactor,
        ),
        (
            "motion.reach",
            vec![LABELS.len(), 2],
            zero,
            2,
            Bound::PositiveFactor,
        ),
    ] {
        let e = with(name, &shape, &values);
        assert!(
            matches!(
                e,
                Some(sinew_core::FormatError::ValueOutOfRange { section, index: i, bound: b })
                    if section.as_str() == name && i == index && b == bound
            ),
            "{name}: {e:?}"
        );
    }
    for name in ["motion.log_reach", "motion.reach"] {
        for shape in [vec![1], vec![LABELS.len(), 3]] {
            let values = vec![0.3; shape.iter().product()];
            assert!(with(name, &shape, &values).is_some(), "{name} {shape:?}");
        }
    }
    // The host keeps every draw of a wide spread within the core's bound.
    data.log_reaches = Some(vec![[0.0, 3.0]; LABELS.len()]);
    assert!(bake(&run.generator, &data, &config).is_ok());
}

/// For seeds 3 to 5, labels 0 and 1 and intensities 1 and 0.5, that the apex of the core's curve
/// on a small neutral lies the reach `draw(seed, reaches[label], intensity)` (times the neutral's
/// size) from the neutral, and that the label's mean length is that of its typical reach; the
/// apex distances of label 0 at intensity 1.
fn check_apexes(
    core: &sinew_core::motion::MotionGenerator<'_>,
    reaches: &[[f32; 2]],
    draw: &dyn Fn(u64, [f32; 2], f32) -> f32,
) -> Vec<f32> {
    let neutral = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0];
    let size = sinew_core::srvf::landmark_size(&neutral);
    let mut scratch = vec![0.0f32; core.scratch_len()];
    let mut q = vec![0.0f32; core.motion_len()];
    let mut curve = vec![0.0f32; core.curve_len()];
    let mut apexes = Vec::new();
    for seed in [3u64, 4, 5] {
        for (label, intensity) in [(0usize, 1.0f32), (0, 0.5), (1, 1.0)] {
            core.landmarks(label, seed, intensity, &neutral, &mut scratch, &mut curve)
                .unwrap();
            let reach = draw(seed, reaches[label], intensity);
            let apex = &curve[FRAMES * 6..];
            let d = apex
                .iter()
                .zip(&neutral)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>()
                .sqrt();
            assert!(
                (d - reach * size).abs() < 1e-4,
                "label {label}, seed {seed}: {d} against {}",
                reach * size
            );
            core.motion(label, seed, &mut scratch, &mut q).unwrap();
            let typical = core.reach(label).unwrap();
            let at_typical = sinew_core::srvf::length_for_reach(&q, 6, typical).unwrap();
            assert_eq!(core.mean_length(label, &q).unwrap(), at_typical);
            if label == 0 && intensity == 1.0 {
                apexes.push(d);
            }
        }
    }
    apexes
}

/// A generator file whose one identity layer outputs `bias` everywhere, whatever the noise and
/// label, on `data`'s reference motion.
fn constant_generator(data: &TangentData, noise: usize, bias: f32) -> Vec<u8> {
    let (inputs, outputs) = (noise + LABELS.len(), FRAMES * 6);
    let mut w = SinewWriter::new(ArtifactKind::MotionGenerator);
    w.meta("content", CONTENT);
    let layer = crate::training::nn::LayerWeights {
        weight: vec![0.0; outputs * inputs],
        bias: vec![bias; outputs],
        inputs,
        outputs,
        activation: sinew_core::nn::Activation::Identity,
    };
    crate::training::nn::write_mlp(&mut w, "motion.g", &[layer]).unwrap();
    w.f32s("motion.p", &[FRAMES, 6], &data.p).unwrap();
    w.f32s("motion.length", &[1], &[0.5]).unwrap();
    w.to_bytes().unwrap()
}

/// The generator's outputs are held to what the exponential map needs, ±1e18 / outputs (here
/// 180 outputs): just inside it every motion is a finite unit motion, just outside it the file is
/// refused, naming the limit.
#[test]
fn a_generator_is_held_to_the_limit_its_exponential_map_needs() {
    let data = toy();
    let limit = sinew_core::NetworkLimit::Tangent {
        outputs: (FRAMES * 6) as u32,
    }
    .value();
    assert!(limit > 1e15, "{limit}");
    // The bound adds the roundings of a sum of `inputs + 2` terms to the bias.
    let inside = constant_generator(&data, 4, limit * 0.999);
    let core = sinew_core::motion::MotionGenerator::from_bytes(&inside).unwrap();
    let mut scratch = vec![0.0f32; core.scratch_len()];
    let mut q = vec![0.0f32; core.motion_len()];
    for seed in [1u64, 2] {
        core.motion(3, seed, &mut scratch, &mut q).unwrap();
        assert!(q.iter().all(|x| x.is_finite()), "seed {seed}");
        let n = sinew_core::srvf::norm(&q).unwrap();
        assert!((n - 1.0).abs() < 1e-3, "seed {seed}: norm {n}");
    }
    let outside = constant_generator(&data, 4, limit * 1.001);
    let e = sinew_core::motion::MotionGenerator::from_bytes(&outside).unwrap_err();
    assert!(
        matches!(
            e,
            sinew_core::FormatError::Unbounded {
                limit: sinew_core::NetworkLimit::Tangent { outputs: 180 },
                ..
            }
        ),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .contains("outputs exceed ±1e18 / 180, the limit of a tangent vector"),
        "{e}"
    );
}

/// λ_div adds minus the geodesic distance between two motions of each label from different noise
/// to the generator's loss (at the first step, where the networks are still the same, the loss
/// is lower by about that), and a run with it resumes bit for bit.
#[test]
fn the_diversity_term_lowers_the_generator_loss_and_resumes_bit_for_bit() {
    let data = toy();
    let device = Backend::Flex.autodiff_device(config().seed).unwrap();
    let with = GanConfig {
        diversity: 1.0,
        ..config()
    };
    let plain = run_to(
        &data,
        &config(),
        Run::new(&data, &config(), &device).unwrap(),
        1,
    );
    let diverse = run_to(&data, &with, Run::new(&data, &with, &device).unwrap(), 1);
    let (a, b) = (plain.history[0], diverse.history[0]);
    assert_eq!(a.critic.to_bits(), b.critic.to_bits());
    assert_eq!(a.reconstruction.to_bits(), b.reconstruction.to_bits());
    let drop = a.generator - b.generator;
    assert!(drop > 1e-3 && drop < std::f32::consts::PI, "{drop}");

    let dir = tempfile::tempdir().unwrap();
    save_checkpoint(dir.path(), &diverse, &with, &data).unwrap();
    let straight = run_to(&data, &with, diverse, 3);
    resumes_as(dir.path(), &data, &with, &straight, 3);
}

/// `--steps` may be raised on resume: a 4-step run's checkpoint at step 3 goes on to 6 steps as
/// the 6-step run does (every step depends on the seed and the step alone), and a count below
/// the steps done is refused.
#[test]
fn a_resumed_run_may_be_asked_for_more_steps() {
    let (data, six) = (toy(), config());
    let four = GanConfig {
        steps: 4,
        ..six.clone()
    };
    let fresh = |config: &GanConfig| {
        let device = Backend::Flex.autodiff_device(config.seed).unwrap();
        Run::new(&data, config, &device).unwrap()
    };
    let short = run_to(&data, &four, fresh(&four), 3);
    let dir = tempfile::tempdir().unwrap();
    save_checkpoint(dir.path(), &short, &four, &data).unwrap();
    let straight = run_to(&data, &six, fresh(&six), 6);
    let loaded = load_checkpoint(dir.path(), fresh(&six), &six, &data).unwrap();
    assert_eq!(loaded.step, 3);
    let raised = run_to(&data, &six, loaded, 6);
    assert_eq!(
        bake(&raised.generator, &data, &six).unwrap(),
        bake(&straight.generator, &data, &six).unwrap()
    );

    let two = GanConfig {
        steps: 2,
        ..six.clone()
    };
    let e = load_checkpoint(dir.path(), fresh(&two), &two, &data).unwrap_err();
    assert!(
        matches!(
            &e,
            CheckpointError::Invalid {
                source: InvalidState::StepsDone { done: 3, asked: 2 },
                ..
            }
        ),
        "{e:?}"
    );
}

/// Checks that the checkpoint in `dir`, of a run with the settings `with`, resumes to `straight`
/// (the same run carried on uninterrupted to `until` steps) bit for bit, and that a run with the
/// paper's losses ([`config`]) refuses it as another run's.
fn resumes_as(dir: &Path, data: &TangentData, with: &GanConfig, straight: &Run, until: usize) {
    let device = Backend::Flex.autodiff_device(with.seed).unwrap();
    let loaded = load_checkpoint(dir, Run::new(data, with, &device).unwrap(), with, data).unwrap();
    let resumed = run_to(data, with, loaded, until);
    assert_eq!(
        bake(&resumed.generator, data, with).unwrap(),
        bake(&straight.generator, data, with).unwrap()
    );
    assert!(
        load_checkpoint(
            dir,
            Run::new(data, &config(), &device).unwrap(),
            &config(),
            data
        )
        .is_err()
    );
}

#[test]
fn the_label_guide_pulls_the_generator_towards_its_labels_and_resumes_bit_for_bit() {
    // The toy motions with two of them labelled the other way: each label is mostly one kind
    // of motion and a little of the other, as classes that overlap are.
    let labels = (0..12)
        .map(|k| if k < 2 { 1 - k % 2 } else { k % 2 })
        .collect();
    let data = TangentData::from_motions(&toy_motions(), labels).unwrap();
    let device = Backend::Flex.autodiff_device(config().seed).unwrap();
    let with = GanConfig {
        class_weight: 5.0,
        ..config()
    };
    let plain = run_to(
        &data,
        &config(),
        Run::new(&data, &config(), &device).unwrap(),
        1,
    );
    let guided = run_to(&data, &with, Run::new(&data, &with, &device).unwrap(), 1);
    assert!(plain.guide.is_none());
    let (a, b) = (plain.history[0], guided.history[0]);
    // The guide moves the generator only: the first step's critic and L_r are the plain run's,
    // and its loss is the plain loss plus λ_cls times the guide's cross-entropy.
    assert_eq!(a.critic.to_bits(), b.critic.to_bits());
    assert_eq!(a.reconstruction.to_bits(), b.reconstruction.to_bits());
    assert_eq!(a.classes, 0.0);
    assert!(b.classes > 0.0 && b.classes.is_finite(), "{}", b.classes);
    let expected = a.generator + with.class_weight * b.classes;
    assert!(
        (b.generator - expected).abs() < 1e-4 * expected.abs().max(1.0),
        "{b:?} {a:?}"
    );

    // After some steps the guided generator's motions look more like their labels to the guide.
    let guide = guided.guide.clone().unwrap();
    let ce = |run: &Run| {
        let labels: Vec<usize> = (0..32).map(|k| k % 2).collect();
        let mut rng = crate::training::random::Stream::seed_from_u64(4);
        let z: Vec<f32> = (0..32 * with.noise).map(|_| rng.normal() as f32).collect();
        let onehot = crate::motion::labels::one_hot(&labels, LABELS.len(), &device);
        let input = burn::tensor::Tensor::cat(
            vec![
                crate::training::nn::tensor(z, [32, with.noise], &device),
                onehot.clone(),
            ],
            1,
        );
        let p = crate::training::nn::tensor(data.p.clone(), [1, data.dims()], &device);
        let fake = run.generator.forward(input, p);
        crate::training::nn::to_vec(guide.cross_entropy(fake, onehot))[0]
    };
    let plain_later = run_to(&data, &config(), plain, 100);
    let dir = tempfile::tempdir().unwrap();
    save_checkpoint(dir.path(), &guided, &with, &data).unwrap();
    let guided_later = run_to(&data, &with, guided, 100);
    assert!(
        ce(&guided_later) < 0.5 * ce(&plain_later),
        "{} {}",
        ce(&guided_later),
        ce(&plain_later)
    );

    // The guide is rebuilt, not saved: a resumed run is the same run, and another run's for a
    // run without the guide.
    resumes_as(dir.path(), &data, &with, &guided_later, 100);
}
