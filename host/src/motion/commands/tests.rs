use super::*;
use crate::motion::train::TangentData;

/// Unit motions of two labels with 2 coordinates per frame.
fn toy() -> TangentData {
    let d = FRAMES * 2;
    let qs: Vec<Vec<f32>> = (0..12)
        .map(|k| {
            let v: Vec<f32> = (0..d)
                .map(|i| ((i * (k % 2 + 1)) as f32 * 0.1 + k as f32 * 0.01).cos() + 0.5)
                .collect();
            let n = sinew_core::srvf::norm(&v).unwrap();
            v.into_iter().map(|x| x / n).collect()
        })
        .collect();
    TangentData::from_motions(&qs, (0..12).map(|k| k % 2).collect()).unwrap()
}

fn config() -> GanConfig {
    GanConfig {
        seed: 11,
        steps: 6,
        batch: 4,
        lr: 1e-3,
        noise: 4,
        hidden: vec![16],
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
    let half = run_to(&data, &config, Run::new(&data, &config, &device), 3);
    let dir = tempfile::tempdir().unwrap();
    save_checkpoint(dir.path(), &half, &config, &data).unwrap();
    let straight = run_to(&data, &config, half, 6);

    let loaded = load_checkpoint(
        dir.path(),
        Run::new(&data, &config, &device),
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

    // Another run's settings are refused, naming the state file.
    let other = GanConfig {
        lr: 2e-3,
        ..config.clone()
    };
    let err = format!(
        "{:#}",
        load_checkpoint(dir.path(), Run::new(&data, &other, &device), &other, &data).unwrap_err()
    );
    assert!(
        err.contains(STATE_FILE) && err.contains("other settings"),
        "{err}"
    );
}

#[test]
fn the_baked_generator_is_a_motion_generator_the_core_reads() {
    let (data, config) = (toy(), config());
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let run = run_to(&data, &config, Run::new(&data, &config, &device), 1);
    let bytes = bake(&run.generator, &data, &config).unwrap();
    let file =
        sinew_core::SinewFile::from_bytes_of_kind(&bytes, ArtifactKind::MotionGenerator).unwrap();
    assert_eq!(file.metadata().get("content"), Some(CONTENT));
    let mlp = sinew_core::network::load_mlp(&file, "motion.g").unwrap();
    assert_eq!(mlp.inputs(), config.noise + LABELS.len());
    assert_eq!(mlp.outputs(), data.dims());
    let p: Vec<f32> = file
        .f32_tensor("motion.p", &[FRAMES as u32, 2])
        .unwrap()
        .iter()
        .collect();
    assert_eq!(p, data.p);
}
