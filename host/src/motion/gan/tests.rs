use burn::tensor::{Device, Distribution, Tensor};

use super::*;
use crate::motion::labels::one_hot;
use crate::training::backend::Backend;

fn device(seed: u64) -> Device {
    Backend::Flex.device(seed).unwrap()
}

#[test]
fn the_critic_input_gradient_matches_finite_differences() {
    eprintln!("seed 3");
    let dev = device(3);
    let critic = Critic::new(8, &[16, 12], 0.2, &dev);
    let x = Tensor::<2>::random([4, 8], Distribution::Normal(0.0, 1.0), &dev);
    let (_, slopes) = critic.forward_with_slopes(x.clone());
    let g = to_vec(critic.input_gradient(&slopes));
    let xs = to_vec(x);
    let h = 1e-2f32;
    let score = |v: Vec<f32>| to_vec(critic.forward(tensor(v, [4, 8], &dev)));
    let mut worst = 0.0f32;
    for i in 0..8 {
        let mut plus = xs.clone();
        let mut minus = xs.clone();
        for row in 0..4 {
            plus[row * 8 + i] += h;
            minus[row * 8 + i] -= h;
        }
        let (sp, sm) = (score(plus), score(minus));
        for row in 0..4 {
            let fd = (sp[row] - sm[row]) / (2.0 * h);
            let err = (fd - g[row * 8 + i]).abs() / (1e-3 + g[row * 8 + i].abs());
            worst = worst.max(err);
        }
    }
    eprintln!("worst relative difference from finite differences {worst:e}");
    assert!(worst < 4e-3, "{worst}");
}

#[test]
fn the_penalty_reaches_the_critic_weights() {
    // The penalty is differentiable through the explicit input gradient: a critic step with
    // only the penalty (real = fake) changes the first layer's weights.
    let dev = Backend::Flex.autodiff_device(4).unwrap();
    let critic = Critic::new(6, &[8], 0.2, &dev);
    let x = Tensor::<2>::random([5, 6], Distribution::Normal(0.0, 1.0), &dev);
    let (_, slopes) = critic.forward_with_slopes(x);
    let penalty = (critic
        .input_gradient(&slopes)
        .powi_scalar(2)
        .sum_dim(1)
        .sqrt()
        .sub_scalar(1.0))
    .powi_scalar(2)
    .mean();
    let grads = penalty.backward();
    let g = critic.hidden[0].weight.grad(&grads).expect("a gradient");
    assert!(to_vec(g).iter().any(|v| v.abs() > 1e-6));
}

#[test]
fn generated_vectors_are_tangent_at_p() {
    let dev = device(5);
    let d = FRAMES * 2;
    let p = tensor(
        (0..d).map(|i| ((i as f32) * 0.3).sin()).collect::<Vec<_>>(),
        [1, d],
        &dev,
    );
    let p = p
        .clone()
        .div_scalar(f64::from(to_vec(p.powi_scalar(2).sum())[0] / FRAMES as f32).sqrt());
    let generator = Generator::new(4, 2, d, &[8], 0.2, &dev);
    let z = Tensor::<2>::random([3, 4], Distribution::Normal(0.0, 1.0), &dev);
    let s = generator.forward(
        Tensor::cat(vec![z, one_hot(&[0, 1, 1], 2, &dev)], 1),
        p.clone(),
    );
    let pv = to_vec(p);
    for row in to_vec(s).chunks_exact(d) {
        let a = sinew_core::srvf::inner(row, &pv).unwrap();
        assert!(a.abs() < 1e-5, "{a}");
    }
}

/// A fixed unit motion of `d` coordinates, as a vector and as a `[1, d]` tensor.
fn reference_point(d: usize, dev: &Device) -> (Vec<f32>, Tensor<2>) {
    let v: Vec<f32> = (0..d).map(|i| ((i as f32) * 0.37).sin() + 0.2).collect();
    let n = (v.iter().map(|x| x * x).sum::<f32>() / FRAMES as f32).sqrt();
    let p: Vec<f32> = v.into_iter().map(|x| x / n).collect();
    let pt = tensor(p.clone(), [1, d], dev);
    (p, pt)
}

#[test]
fn the_reconstruction_loss_measures_the_geodesic_on_the_sphere() {
    let dev = device(6);
    let d = FRAMES * 3;
    let (p, pt) = reference_point(d, &dev);
    // Two tangent vectors at p of different lengths and directions.
    let mut a: Vec<f32> = (0..d).map(|i| ((i as f32) * 0.11).cos() * 0.09).collect();
    let mut b: Vec<f32> = (0..d).map(|i| ((i as f32) * 0.23).sin() * 0.05).collect();
    sinew_core::srvf::project_tangent(&p, &mut a).unwrap();
    sinew_core::srvf::project_tangent(&p, &mut b).unwrap();
    let on = |s: &[f32]| crate::motion::srvf::exp(&p, s).unwrap();
    let (qa, qb) = (on(&a), on(&b));
    // exp_rows is the core's exponential map.
    let ea = to_vec(exp_rows(tensor(a.clone(), [1, d], &dev), pt.clone()));
    for (x, y) in ea.iter().zip(&qa) {
        assert!((x - y).abs() < 1e-5, "{x} {y}");
    }
    // geodesic_rows is the host's geodesic distance, and L_r adds the mean |a − b|.
    let want = crate::motion::srvf::distance(&qa, &qb).unwrap();
    let got = to_vec(geodesic_rows(
        tensor(qa.clone(), [1, d], &dev),
        tensor(qb.clone(), [1, d], &dev),
    ))[0];
    assert!(want > 0.1 && (got - want).abs() < 1e-4, "{got} {want}");
    let l1 = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum::<f32>() / d as f32;
    let rec = to_vec(reconstruction(
        tensor(a.clone(), [1, d], &dev),
        tensor(b.clone(), [1, d], &dev),
        &pt,
    ))[0];
    assert!((rec - (l1 + want)).abs() < 1e-4, "{rec} {}", l1 + want);
    // It vanishes where the two motions meet.
    let same = to_vec(reconstruction(
        tensor(a.clone(), [1, d], &dev),
        tensor(a.clone(), [1, d], &dev),
        &pt,
    ))[0];
    assert!(same.abs() < 1e-5, "{same}");
    // The diversity term is minus the geodesic distance between the two motions: 0 for one
    // motion twice.
    let div = |x: &[f32], y: &[f32]| {
        to_vec(diversity_term(
            tensor(x.to_vec(), [1, d], &dev),
            tensor(y.to_vec(), [1, d], &dev),
            &pt,
        ))[0]
    };
    assert!((div(&a, &b) + want).abs() < 1e-4, "{} {want}", div(&a, &b));
    assert!(div(&a, &a).abs() < 1e-5);
}

#[test]
fn a_fresh_generator_follows_its_label_and_starts_near_p() {
    let dev = device(8);
    let config = GanConfig::default();
    let d = FRAMES * 204;
    let mut p = vec![0.0f32; d];
    p[0] = (FRAMES as f32).sqrt();
    let p = tensor(p, [1, d], &dev);
    let generator = Generator::new(config.noise, 12, d, &config.hidden, config.slope, &dev);
    let n = 16;
    let z = Tensor::<2>::random([n, config.noise], Distribution::Normal(0.0, 1.0), &dev);
    let of = |label: usize, z: Tensor<2>| {
        to_vec(generator.forward(
            Tensor::cat(vec![z, one_hot(&vec![label; n], 12, &dev)], 1),
            p.clone(),
        ))
    };
    let (a, b) = (of(0, z.clone()), of(1, z));
    // ‖·‖ of the hypersphere's inner product.
    let norm = |v: &[f32]| (v.iter().map(|x| x * x).sum::<f32>() / FRAMES as f32).sqrt();
    let rows = |v: &[f32]| -> Vec<Vec<f32>> { v.chunks_exact(d).map(<[f32]>::to_vec).collect() };
    let (a, b) = (rows(&a), rows(&b));
    let diff =
        |x: &[f32], y: &[f32]| norm(&x.iter().zip(y).map(|(u, v)| u - v).collect::<Vec<_>>());
    // Another label moves the motion about as far as other noise does (PyTorch's initialisation
    // alone would leave the label's effect √128 ≈ 11 times smaller).
    let by_label = (0..n).map(|i| diff(&a[i], &b[i])).sum::<f32>() / n as f32;
    let by_noise = (1..n).map(|i| diff(&a[i], &a[i - 1])).sum::<f32>() / (n - 1) as f32;
    eprintln!("label {by_label}, noise {by_noise}");
    assert!(by_label > 0.4 * by_noise, "{by_label} {by_noise}");
    // The first motions lie near p: a tenth of PyTorch's scale, which would put them about 1.5
    // rad away, beyond most training motions.
    let mean_norm = a.iter().map(|r| norm(r)).sum::<f32>() / n as f32;
    eprintln!("distance from p {mean_norm}");
    assert!(mean_norm < 0.5, "{mean_norm}");
}

#[test]
fn nearest_pairing_picks_the_closest_real_motion_of_the_same_label() {
    let dev = device(1);
    // Real rows: label 0 at x = 0 and x = 10, label 1 at x = 1 and x = 9.
    let real = tensor(vec![0.0, 0.0, 10.0, 0.0, 1.0, 0.0, 9.0, 0.0], [4, 2], &dev);
    let labels = one_hot(&[0, 0, 1, 1], 2, &dev);
    // Fakes conditioned on those labels: near 9 (label 0), near 0.5 (label 0), near 10
    // (label 1), near 2 (label 1).
    let fake = tensor(vec![9.0, 0.5, 0.5, 0.0, 10.0, 0.0, 2.0, 0.0], [4, 2], &dev);
    let idx: Vec<i64> = nearest_of_label(&fake, &real, &labels)
        .into_data()
        .convert::<i64>()
        .try_to_vec::<i64>()
        .unwrap();
    // Across labels row 0's nearest would be real row 3 (x = 9), row 2's real row 1 (x = 10).
    assert_eq!(idx, vec![1, 0, 3, 2]);
}

#[test]
fn chamfer_pairing_counts_the_real_motions_no_generated_one_covers() {
    let dev = device(2);
    let d = FRAMES * 3;
    let (p, pt) = reference_point(d, &dev);
    let tangent = |f: &dyn Fn(usize) -> f32| {
        let mut v: Vec<f32> = (0..d).map(f).collect();
        sinew_core::srvf::project_tangent(&p, &mut v).unwrap();
        v
    };
    // One label with two kinds of real motion, a and its opposite (as mouth_side's left and
    // right), and small offsets to generate near them.
    let a = tangent(&|i| ((i as f32) * 0.11).cos() * 0.3);
    let e = tangent(&|i| ((i as f32) * 0.23).sin() * 0.01);
    let minus_a: Vec<f32> = a.iter().map(|x| -x).collect();
    let near =
        |m: &[f32], k: f32| -> Vec<f32> { m.iter().zip(&e).map(|(x, y)| x + k * y).collect() };
    let real = tensor([a.clone(), minus_a.clone()].concat(), [2, d], &dev);
    let labels = one_hot(&[0, 0], 1, &dev);
    let loss = |fakes: Vec<f32>, pairing| {
        to_vec(paired_reconstruction(
            tensor(fakes, [2, d], &dev),
            &real,
            &labels,
            &pt,
            pairing,
        ))[0]
    };
    let rec = |x: &[f32], y: &[f32]| {
        to_vec(reconstruction(
            tensor(x.to_vec(), [1, d], &dev),
            tensor(y.to_vec(), [1, d], &dev),
            &pt,
        ))[0]
    };
    // Both generated motions near a: each is near a real one (Nearest sees nothing wrong), but
    // -a has no generated motion near it, and Chamfer adds its distance to the nearer of them.
    let one_kind = [near(&a, 1.0), near(&a, 2.0)];
    let nearest = loss(one_kind.concat(), Pairing::Nearest);
    let expected_nearest = 0.5 * (rec(&one_kind[0], &a) + rec(&one_kind[1], &a));
    assert!(
        (nearest - expected_nearest).abs() < 1e-5,
        "{nearest} {expected_nearest}"
    );
    let chamfer = loss(one_kind.concat(), Pairing::Chamfer);
    let expected =
        0.5 * (expected_nearest + 0.5 * (rec(&one_kind[0], &a) + rec(&one_kind[0], &minus_a)));
    assert!((chamfer - expected).abs() < 1e-5, "{chamfer} {expected}");
    assert!(chamfer > 5.0 * nearest, "{chamfer} {nearest}");
    // One generated motion near each kind: both pairings see the same small loss.
    let both_kinds = [near(&minus_a, 1.0), near(&a, 1.0)];
    let (n, c) = (
        loss(both_kinds.concat(), Pairing::Nearest),
        loss(both_kinds.concat(), Pairing::Chamfer),
    );
    assert!((n - c).abs() < 1e-5 && c < 0.1, "{n} {c}");
}

#[test]
fn settings_saved_before_the_pairing_and_the_guide_existed_read_as_the_batch_pairing_unguided() {
    let mut json = serde_json::to_value(GanConfig::default()).unwrap();
    assert_eq!(json["pairing"], "chamfer");
    json.as_object_mut().unwrap().remove("pairing");
    json.as_object_mut().unwrap().remove("diversity");
    json.as_object_mut().unwrap().remove("class_weight");
    let old: GanConfig = serde_json::from_value(json).unwrap();
    assert_eq!(old.pairing, Pairing::Batch);
    assert_eq!(old.diversity, 0.0);
    assert_eq!(old.class_weight, 0.0);
    assert_eq!(
        GanConfig {
            pairing: Pairing::Chamfer,
            diversity: GanConfig::default().diversity,
            class_weight: GanConfig::default().class_weight,
            ..old
        },
        GanConfig::default()
    );
}
