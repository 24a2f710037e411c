//! The AIM fit's step time (AIM eqs. 17–24, docs/FIT.md): the golden actor
//! (`tests/data/aim-ict.sinew`, 4,705 vertices, 19 correctives) fitted to a 30-frame synthetic
//! performance with the default settings (local coefficients, 96 points a step, code 32,
//! hidden 64, F_W's sine first layer, flex backend). `fit` runs 2 and then 52 Adam steps;
//! everything else it does (the actor's cache, the rigid start, the errors before, half way and
//! after) is the same in both, so the step time is the difference over 50. Reads ICT-FaceKit from `../shared/data` or `SINEW_DATA`, and
//! says so and skips without it.
//!
//! Run: `cargo bench -p sinew-host --bench fit_step`.

use std::path::Path;

use criterion::{Criterion, criterion_group};
use sinew_core::aim::AimActor;
use sinew_host::fit::aim::fit;
use sinew_host::fit::setup::FitConfig;
use sinew_host::io::performance::Performance;
use sinew_host::performance::{PerformanceConfig, generate};
use sinew_host::training::backend::Backend;

fn bench(c: &mut Criterion) {
    let Some(data) = sinew_host::io::data::data_dir() else {
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let actor_path = root.join("tests/data/aim-ict.sinew");
    let dir = tempfile::tempdir().expect("a temporary folder");
    let config = PerformanceConfig {
        seed: 1,
        frames: 30,
        ..PerformanceConfig::default()
    };
    generate(
        &data.join("ict-facekit"),
        Some(&actor_path),
        &config,
        dir.path(),
    )
    .expect("a synthetic performance");
    let perf = Performance::read(dir.path()).expect("the performance reads back");
    let bytes = std::fs::read(&actor_path).expect("the golden actor");
    let actor = AimActor::from_bytes(&bytes).expect("a valid actor");

    let mut group = c.benchmark_group("fit");
    group.sample_size(10);
    for steps in [2, 52] {
        let fit_config = FitConfig {
            iterations: steps,
            ..FitConfig::default()
        };
        group.bench_function(format!("local_30_frames_{steps}_steps"), |b| {
            b.iter(|| fit(&actor, &perf, &fit_config, Backend::Flex).expect("the fit"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
fn main() {
    // As the `sinew` binary does: keep freed memory mapped (glibc), see `sinew_host::training::malloc`.
    sinew_host::training::malloc::keep_freed_memory();
    benches();
    Criterion::default().configure_from_args().final_summary();
}
