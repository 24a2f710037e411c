//! One default AIM training step at the paper's size: five SIRENs 3→256→256→256→out (ω0 = 30),
//! batch 4096 (point, shape) samples drawn as 2,048 points with two shapes each, plus the
//! 512-point symmetry, forehead and jaw (L_J) terms, Adam; 20 shapes (E has 57 outputs) on a
//! template of about the ICT face region's size, as on the ICT actor. The comparison with
//! PyTorch is `scripts/bench_torch_aim_step.py --distinct --shapes-per-point 2 --jaw-term`;
//! results in docs/BENCHMARKS.md.
//!
//! Run: `cargo bench -p sinew-host --bench aim_train_step` (add `--features x86-v4` for the
//! AVX-512 kernels).

use criterion::{Criterion, criterion_group};
use sinew_host::aim::AimConfig;
use sinew_host::aim::data::training_set;
use sinew_host::aim::model::normalisation;
use sinew_host::aim::train::{init, step_once};
use sinew_host::training::backend::Backend;

fn bench(c: &mut Criterion) {
    // 84 rows of 113 vertices: 9,492, about the ICT face region's 9,409, so that the batch
    // holds as many distinct points as there (the networks run once per distinct point).
    let (mut actor, bones) = sinew_host::aim::procedural::actor(84);
    // 20 shapes like the ICT default actor: repeat the procedural expressions.
    while actor.shapes.len() < 20 {
        let i = 1 + (actor.shapes.len() - 1) % 6;
        actor.shapes.push(actor.shapes[i].clone());
        actor
            .names
            .push(format!("{}#{}", actor.names[i], actor.shapes.len()));
    }
    let set = training_set(&actor, &bones.skull, &bones.jaw, Some(bones.jaw_pivot), 2.5)
        .expect("training set");
    let config = AimConfig::default();
    let norm = normalisation(&set.template.positions);
    let (net, mut optim, device) = init(&set, &config, Backend::Flex).expect("flex backend");
    let mut net = Some(net);
    let mut step = 0;
    let mut group = c.benchmark_group("aim");
    group.sample_size(20);
    group.bench_function("train_step_5x256x3_batch4096", |b| {
        b.iter(|| {
            let (n, terms) = step_once(
                net.take().expect("model"),
                &mut optim,
                &set,
                &config,
                norm,
                step,
                &device,
            );
            // Reading the loss back forces the step to finish, as the training loop does.
            let _ = sinew_host::training::nn::to_vec(terms);
            net = Some(n);
            step += 1;
        })
    });
    group.finish();
}

/// The activation alone, forward and backward over one 4096×256 layer: burn's element-wise `sin`
/// against Sinew's vectorised sine (`sinew_host::training::sine`), the cost the step above pays 15 times.
fn sine(c: &mut Criterion) {
    let device = burn::tensor::Device::flex().autodiff();
    let values: Vec<f32> = (0..4096 * 256)
        .map(|i| ((i * 7919) % 20011) as f32 * 1e-4 - 1.0)
        .collect();
    let x = sinew_host::training::nn::tensor(values, [4096, 256], &device).require_grad();
    let mut group = c.benchmark_group("aim/sine_4096x256_forward_backward");
    group.sample_size(30);
    group.bench_function("burn_sin", |b| {
        b.iter(|| {
            let y = x.clone().mul_scalar(30.0).sin();
            let g = y.sum().backward();
            let _ = sinew_host::training::nn::to_vec(x.grad(&g).expect("gradient"));
        })
    });
    group.bench_function("sinew_sine", |b| {
        b.iter(|| {
            let y = sinew_host::training::sine::siren_sine(x.clone(), 30.0);
            let g = y.sum().backward();
            let _ = sinew_host::training::nn::to_vec(x.grad(&g).expect("gradient"));
        })
    });
    group.finish();
}

criterion_group!(benches, sine, bench);
fn main() {
    // As the `sinew` binary does: keep freed memory mapped (glibc), see `sinew_host::training::malloc`.
    sinew_host::training::malloc::keep_freed_memory();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
