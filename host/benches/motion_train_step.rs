//! One Motion3DGAN training step at the default size: 68 landmarks × 30 frames (6,120
//! coordinates), noise 128, hidden 512, 512, batch 64; one generator step after its 4 critic
//! steps with the explicit gradient penalty (`Run::advance` by one step), on seeded unit motions
//! of 12 labels. How long the default `sinew train motion` takes follows from it (docs/MOTION.md,
//! "Training time").
//!
//! Run: `cargo bench -p sinew-host --bench motion_train_step`.

use criterion::{Criterion, criterion_group};
use rand_core::{RngCore, SeedableRng};
use sinew_core::srvf::{FRAMES, norm};
use sinew_host::motion::gan::{GanConfig, StepLosses};
use sinew_host::motion::train::{Run, TangentData};
use sinew_host::training::backend::Backend;

fn bench(c: &mut Criterion) {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    let d = FRAMES * 204;
    let qs: Vec<Vec<f32>> = (0..240)
        .map(|_| {
            let v: Vec<f32> = (0..d)
                .map(|_| (rng.next_u64() >> 40) as f32 / (1u64 << 24) as f32 + 0.5)
                .collect();
            let n = norm(&v).expect("whole frames");
            v.into_iter().map(|x| x / n).collect()
        })
        .collect();
    let labels = (0..qs.len()).map(|k| k % 12).collect();
    let data = TangentData::from_motions(&qs, labels).expect("motions");
    let config = GanConfig::default();
    let device = Backend::Flex
        .autodiff_device(config.seed)
        .expect("flex backend");
    let mut run = Some(Run::new(&data, &config, &device).unwrap());

    let mut group = c.benchmark_group("motion");
    group.sample_size(10);
    group.bench_function("train_step_batch64_critic4", |b| {
        b.iter(|| {
            let r = run.take().expect("run");
            let until = r.step + 1;
            let r = r.advance(
                &data,
                &config,
                &device,
                until,
                &mut |_: usize, _: &StepLosses| {},
                &mut || false,
            );
            run = Some(r);
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
