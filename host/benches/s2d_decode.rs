//! Single-frame S2D decode in the core, one thread, on two networks (the default decoder
//! configuration: FC 204 → (n_L + 1)·128, stages of 64, 32, 32, 16 filters, output 3; random
//! weights with PyTorch's default initialisation):
//!
//! - `core_decode_5023`: the reference size, FLAME's hierarchy shapes (5023/1256/314/79/20
//!   vertices, spirals [15, 14, 9, 9, 7]) with synthetic connectivity (three up-sampling parents
//!   per vertex), 666,083 parameters;
//! - `core_decode_ict_9409`: the ICT-FaceKit face region's real hierarchy (9409/2353/589/148/37
//!   vertices, spirals [12, 14, 9, 10, 9], built from `$SINEW_DATA/ict-facekit`; skipped without
//!   the data), 1,118,675 parameters;
//! - `core_decode_ict_synthetic`: the same sizes with synthetic connectivity, the like-for-like
//!   partner of the PyTorch script's `--ict` (which draws random spirals too).
//!
//! The PyTorch comparison is `scripts/bench_torch_s2d_decode.py --threads 1 [--ict]`; results in
//! docs/S2D.md and docs/BENCHMARKS.md.
//!
//! Run: `cargo bench -p sinew-host --bench s2d_decode`.

use burn::tensor::Device;
use criterion::{Criterion, criterion_group, criterion_main};
use sinew_host::s2d::Hierarchy;
use sinew_host::s2d::decoder::{DecoderConfig, S2dDecoder};
use sinew_host::s2d::hierarchy::DEFAULT_FACTORS;
use sinew_host::s2d::synthetic::{self, REFERENCE_SIZES, REFERENCE_SPIRALS};
use sinew_host::training::backend::Backend;

/// The ICT face region's level sizes and spiral lengths (docs/S2D.md, "Levels").
const ICT_SIZES: [usize; 5] = [9409, 2353, 589, 148, 37];
const ICT_SPIRALS: [usize; 5] = [12, 14, 9, 10, 9];

/// A freshly initialised default decoder on `h`, baked.
fn baked(h: &Hierarchy, landmarks: &[u32], device: &Device) -> Vec<u8> {
    let dec = S2dDecoder::new(&DecoderConfig::default(), h, device).expect("decoder");
    sinew_host::s2d::bake::bake(&dec, h, landmarks, &[]).expect("bake")
}

/// The ICT face region's hierarchy and landmarks, or `None` without the data.
fn ict() -> Option<(Hierarchy, Vec<u32>)> {
    let root = sinew_host::io::data::data_dir()?;
    let kit =
        sinew_host::io::ict::IctFaceKit::open(&root.join("ict-facekit")).expect("ICT-FaceKit");
    let region = sinew_host::io::ict::FACE_REGION;
    let (face, _) = kit.neutral().submesh(|v| region.contains(&v));
    let h = sinew_host::s2d::hierarchy::build(&face, &DEFAULT_FACTORS).expect("hierarchy");
    Some((h, kit.landmarks68().expect("landmarks")))
}

fn bench(c: &mut Criterion) {
    let device = Backend::Flex.device(1).expect("flex backend");
    let spread: Vec<u32> = (0..68).map(|i| i * 70).collect();
    let mut cases = vec![(
        "core_decode_5023",
        baked(
            &synthetic::hierarchy(&REFERENCE_SIZES, &REFERENCE_SPIRALS, 1),
            &spread,
            &device,
        ),
    )];
    if let Some((h, landmarks)) = ict() {
        let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
        let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
        assert_eq!(
            (sizes.as_slice(), lens.as_slice()),
            (&ICT_SIZES[..], &ICT_SPIRALS[..]),
            "the ICT hierarchy changed; update ICT_SIZES and ICT_SPIRALS"
        );
        cases.push(("core_decode_ict_9409", baked(&h, &landmarks, &device)));
    }
    cases.push((
        "core_decode_ict_synthetic",
        baked(
            &synthetic::hierarchy(&ICT_SIZES, &ICT_SPIRALS, 1),
            &spread,
            &device,
        ),
    ));
    let mut group = c.benchmark_group("s2d");
    for (name, bytes) in &cases {
        let core = sinew_core::s2d::S2dDecoder::from_bytes(bytes).expect("valid decoder");
        let mut rng = synthetic::Rng::new(2);
        let input: Vec<f32> = (0..204).map(|_| rng.uniform(-0.05, 0.05)).collect();
        let mut scratch = vec![0.0; core.scratch_len()];
        let mut out = vec![0.0; 3 * core.vertex_count()];
        group.bench_function(*name, |b| {
            b.iter(|| {
                core.decode(
                    std::hint::black_box(&input),
                    &mut scratch,
                    std::hint::black_box(&mut out),
                )
                .expect("buffers sized by the model")
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
