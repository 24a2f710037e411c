//! One S2D-Dec training step at the reference size: the FLAME hierarchy's shapes (5023/1256/314/
//! 79/20 vertices, spirals [15, 14, 9, 9, 7], random connectivity: the cost depends on sizes
//! only), 666,083 parameters, batch 16, the code's loss, Adam with weight decay.
//!
//! Two layouts of the same network: `vertex_major` and `batch_major` (the straightforward
//! `[batch, vertices, features]` layout whose gathers select along dimension 1); and
//! `vertex_major_halves`, what training runs on the CPU: the vertex-major step with the batch's
//! two halves at once on two threads (`step_once` with `Halves`). Results in docs/S2D.md.
//!
//! Run: `cargo bench -p sinew-host --bench s2d_train_step`.

use burn::tensor::Tensor;
use criterion::{Criterion, criterion_group};
use sinew_host::s2d::decoder::{DecoderConfig, S2dDecoder};
use sinew_host::s2d::synthetic::{self, REFERENCE_SIZES, REFERENCE_SPIRALS};
use sinew_host::s2d::train::{
    Batch, Halves, LossVariant, Sample, TrainConfig, loss, step_once, weights_tensor,
};
use sinew_host::training::backend::Backend;

fn bench(c: &mut Criterion) {
    let device = Backend::Flex.autodiff_device(1).expect("flex backend");
    let h = synthetic::hierarchy(&REFERENCE_SIZES, &REFERENCE_SPIRALS, 1);
    let config = DecoderConfig::default();
    let mut rng = synthetic::Rng::new(2);
    let v = REFERENCE_SIZES[0];
    let set: Vec<Sample> = (0..16)
        .map(|_| Sample {
            input: (0..204).map(|_| rng.uniform(-0.05, 0.05)).collect(),
            displacement: (0..3 * v).map(|_| rng.uniform(-0.01, 0.01)).collect(),
        })
        .collect();
    let indices: Vec<usize> = (0..16).collect();
    let batch = Batch::new(&set, &indices, &device);
    let weights = weights_tensor(&vec![0.5; v], &device);
    let tc = TrainConfig::default();

    let mut group = c.benchmark_group("s2d");
    group.sample_size(20);
    let halves = Halves::new().expect("threads");
    for (name, split) in [
        ("train_step_batch16_vertex_major", false),
        ("train_step_batch16_vertex_major_halves", true),
    ] {
        let mut optim = tc.optimizer();
        let mut net = Some(S2dDecoder::new(&config, &h, &device).expect("decoder"));
        group.bench_function(name, |b| {
            b.iter(|| {
                let d = net.take().expect("model");
                let (n, l) = step_once(
                    d,
                    &mut optim,
                    &batch,
                    &weights,
                    LossVariant::Code,
                    1e-3,
                    split.then_some(&halves),
                );
                // Reading the loss back forces the step to finish, as the training loop does.
                let _ = sinew_host::training::nn::to_vec(l);
                net = Some(n);
            })
        });
    }
    let mut optim = tc.optimizer();
    let mut net = Some(S2dDecoder::new(&config, &h, &device).expect("decoder"));
    group.bench_function("train_step_batch16_batch_major", |b| {
        b.iter(|| {
            let d = net.take().expect("model");
            let predicted = d.forward_batch_major(batch.input.clone());
            let l: Tensor<1> = loss(
                LossVariant::Code,
                predicted,
                batch.target.clone(),
                weights.clone(),
            );
            let grads = burn::optim::GradientsParams::from_grads(l.backward(), &d);
            let d = optim.step(1e-3, d, grads);
            let _ = sinew_host::training::nn::to_vec(l.detach());
            net = Some(d);
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
fn main() {
    // As the `sinew` binary does: keep freed memory mapped (glibc), see `sinew_host::training::malloc`.
    sinew_host::training::malloc::keep_freed_memory();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
