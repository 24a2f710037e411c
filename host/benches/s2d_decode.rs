//! Single-frame S2D decode in the core at the reference size: FLAME hierarchy shapes (5023/1256/
//! 314/79/20 vertices, spirals [15, 14, 9, 9, 7], synthetic connectivity with three up-sampling
//! parents per vertex), 666,083 random weights (PyTorch's default initialisation). The PyTorch
//! comparison is `scripts/bench_torch_s2d_decode.py`; results in docs/S2D.md.
//!
//! Run: `cargo bench -p sinew-host --bench s2d_decode`.

use criterion::{Criterion, criterion_group, criterion_main};
use sinew_host::backend::Backend;
use sinew_host::s2d::decoder::{DecoderConfig, S2dDecoder};
use sinew_host::s2d::synthetic::{self, REFERENCE_SIZES, REFERENCE_SPIRALS};

fn bench(c: &mut Criterion) {
    let device = Backend::Flex.device(1).expect("flex backend");
    let h = synthetic::hierarchy(&REFERENCE_SIZES, &REFERENCE_SPIRALS, 1);
    let dec = S2dDecoder::new(&DecoderConfig::default(), &h, &device).expect("decoder");
    let landmarks: Vec<u32> = (0..68).map(|i| i * 70).collect();
    let bytes = sinew_host::s2d::bake::bake(&dec, &h, &landmarks, &[]).expect("bake");
    let core = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).expect("valid decoder");
    let mut rng = synthetic::Rng::new(2);
    let input: Vec<f32> = (0..204).map(|_| rng.uniform(-0.05, 0.05)).collect();
    let mut scratch = vec![0.0; core.scratch_len()];
    let mut out = vec![0.0; 3 * core.vertex_count()];
    let mut group = c.benchmark_group("s2d");
    group.bench_function("core_decode_5023", |b| {
        b.iter(|| {
            core.decode(
                std::hint::black_box(&input),
                &mut scratch,
                std::hint::black_box(&mut out),
            )
            .expect("buffers sized by the model")
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
