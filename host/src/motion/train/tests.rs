use rand_core::{RngCore, SeedableRng};

use super::*;
use crate::training::backend::Backend;
use crate::training::nn::to_vec;

/// Two classes of unit motions with 2 coordinates per frame: each a distinct fixed motion bent a
/// little by seeded noise.
fn toy(seed: u64) -> TangentData {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let unit = |v: Vec<f32>| -> Vec<f32> {
        let n = sinew_core::srvf::norm(&v).unwrap();
        v.into_iter().map(|x| x / n).collect()
    };
    let d = FRAMES * 2;
    let base = |c: usize| -> Vec<f32> {
        (0..d)
            .map(|i| ((i as f32) * (0.2 + 0.5 * c as f32)).cos() + 0.3)
            .collect()
    };
    let mut qs = Vec::new();
    let mut labels = Vec::new();
    for k in 0..40 {
        let c = k % 2;
        let noisy: Vec<f32> = base(c)
            .into_iter()
            .map(|x| x + ((rng.next_u64() >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.1)
            .collect();
        qs.push(unit(noisy));
        labels.push(c);
    }
    TangentData::from_motions(&qs, labels).unwrap()
}

#[test]
fn tangent_data_lies_at_the_mean() {
    let data = toy(1);
    assert!((sinew_core::srvf::norm(&data.p).unwrap() - 1.0).abs() < 1e-5);
    for t in &data.tangents {
        assert!(sinew_core::srvf::inner(t, &data.p).unwrap().abs() < 1e-4);
    }
}

#[test]
fn batches_are_seeded_by_step_alone() {
    assert_eq!(
        batch_indices(50, 8, 3, 10, 2),
        batch_indices(50, 8, 3, 10, 2)
    );
    assert_ne!(
        batch_indices(50, 8, 3, 10, 2),
        batch_indices(50, 8, 3, 11, 2)
    );
    assert_ne!(
        batch_indices(50, 8, 3, 10, 2),
        batch_indices(50, 8, 3, 10, 3)
    );
    assert!(batch_indices(50, 64, 3, 0, 0).iter().all(|&i| i < 50));
}

#[test]
fn a_short_run_generates_each_label_nearer_its_own_class() {
    let config = GanConfig {
        seed: 7,
        steps: 150,
        batch: 16,
        lr: 1e-3,
        noise: 8,
        hidden: vec![32],
        // The paper's losses alone.
        diversity: 0.0,
        class_weight: 0.0,
        ..GanConfig::default()
    };
    eprintln!("seed {}", config.seed);
    let data = toy(2);
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let mut last = StepLosses::default();
    let trained = Run::new(&data, &config, &device).unwrap().advance(
        &data,
        &config,
        &device,
        config.steps,
        &mut |_: usize, l: &StepLosses| last = *l,
        &mut || false,
    );
    assert_eq!(trained.history.len(), 150);
    assert!(last.penalty.is_finite() && last.critic.is_finite() && last.generator.is_finite());
    let first = trained.history[0].reconstruction;
    eprintln!("L_r {first} → {}", last.reconstruction);
    assert!(last.reconstruction < 0.5 * first);

    // Generated tangent vectors of each label lie nearer that label's class mean.
    let d = data.dims();
    let p = tensor(data.p.clone(), [1, d], &device);
    let mean = |c: usize| -> Vec<f32> {
        let members: Vec<&Vec<f32>> = data
            .tangents
            .iter()
            .zip(&data.labels)
            .filter(|(_, l)| **l == c)
            .map(|(t, _)| t)
            .collect();
        (0..d)
            .map(|i| members.iter().map(|t| t[i]).sum::<f32>() / members.len() as f32)
            .collect()
    };
    let means = [mean(0), mean(1)];
    for c in 0..2 {
        let z = Tensor::<2>::random(
            [10, config.noise],
            burn::tensor::Distribution::Normal(0.0, 1.0),
            &device,
        );
        let s = trained.generator.forward(
            Tensor::cat(vec![z, one_hot(&[c; 10], LABELS.len(), &device)], 1),
            p.clone(),
        );
        for row in to_vec(s).chunks_exact(d) {
            let dist =
                |m: &[f32]| -> f32 { row.iter().zip(m).map(|(a, b)| (a - b) * (a - b)).sum() };
            assert!(dist(&means[c]) < dist(&means[1 - c]), "label {c}");
        }
    }
}

/// Asserts that `[mean, spread]` are the mean and the (population) standard deviation of `xs`.
fn same_mean_and_spread([mean, spread]: [f32; 2], xs: &[f64], label: usize) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let sd = (xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / n).sqrt();
    assert!(
        (f64::from(mean) - m).abs() < 1e-6 * m.abs(),
        "label {label}"
    );
    assert!(
        (f64::from(spread) - sd).abs() < 1e-6 * m.abs(),
        "label {label}"
    );
}

#[test]
fn each_label_keeps_its_training_curves_length() {
    let Some(root) = crate::io::data::data_dir() else {
        return;
    };
    let kit = crate::io::ict::IctFaceKit::open(&root.join("ict-facekit")).unwrap();
    let config = crate::motion::data::MotionsConfig {
        seed: 5,
        identities: 2,
        per_class: 3,
        ..Default::default()
    };
    let set = crate::motion::data::generate(&kit, &config).unwrap();
    let data = TangentData::from_set(&set).unwrap();
    assert_eq!(data.lengths.len(), LABELS.len());
    let train = set.split(Split::Train);
    for (label, &[mean, spread]) in data.lengths.iter().enumerate() {
        let mine: Vec<f64> = train
            .iter()
            .filter(|&&s| set.label(s) == label)
            .map(|&s| f64::from(srvf::encode(&set.landmark_frames(s)).unwrap().length))
            .collect();
        same_mean_and_spread([mean, spread], &mine, label);
        assert!(
            spread > 0.0,
            "label {label}: random apex intensities spread the lengths"
        );
    }
    // Each label's reach: the logarithm of its training curves' apex distances from the
    // neutral, never more than their lengths.
    let reaches = data.log_reaches.as_ref().unwrap();
    for (label, &[mean, spread]) in reaches.iter().enumerate() {
        let mine: Vec<f64> = train
            .iter()
            .filter(|&&s| set.label(s) == label)
            .map(|&s| {
                let frames = set.landmark_frames(s);
                let (first, last) = (
                    srvf::normalise_frame(frames[0], 0).unwrap(),
                    srvf::normalise_frame(frames[frames.len() - 1], 1).unwrap(),
                );
                let d = first
                    .iter()
                    .zip(&last)
                    .map(|(a, b)| (b - a) * (b - a))
                    .sum::<f64>()
                    .sqrt();
                let reach = f64::from(srvf::encode(&frames).unwrap().reach);
                assert!((reach - d).abs() < 1e-6 * d, "{reach} {d}");
                d.ln()
            })
            .collect();
        same_mean_and_spread([mean, spread], &mine, label);
        assert!(mean.exp() < data.lengths[label][0], "label {label}");
    }
    // The classes reach different distances (eyebrow little, mouth_extreme much). Their arc
    // lengths differ less: every class's wanders by the same tracking noise.
    let means: Vec<f32> = reaches.iter().map(|l| l[0].exp()).collect();
    let (lo, hi) = means
        .iter()
        .fold((f32::MAX, 0.0f32), |(lo, hi), &m| (lo.min(m), hi.max(m)));
    assert!(hi > 2.0 * lo, "{means:?}");
}

#[test]
fn motions_without_a_tangent_space_are_refused_by_variant() {
    assert_eq!(
        TangentData::from_motions(&[], Vec::new()),
        Err(TangentError::NoMotions)
    );
    let q = vec![1.0f32; FRAMES * 3];
    assert_eq!(
        TangentData::from_motions(&[q.clone(), q[..FRAMES].to_vec()], vec![0, 1]),
        Err(TangentError::Shapes)
    );
    assert_eq!(
        TangentData::from_motions(&[vec![0.0; FRAMES * 3]], vec![0]),
        Err(TangentError::ZeroMean)
    );
}
