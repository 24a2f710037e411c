use burn::tensor::{Device, Distribution, Tensor};

use super::*;
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
