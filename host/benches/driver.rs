//! The live driver in `sinew-core`: one frame of a tracker's 68 landmarks to the golden ICT
//! actor's pose (the pixels through the camera, the features, the MLP, the pose made whole), on
//! the golden driver (`tests/data/driver-ict.sinew`, three hidden layers of 64) and on a driver of
//! the default size (`sinew train driver`'s 128, seeded weights: the cost does not depend on
//! their values); then the One Euro filter's step, and posing the actor with the pose for
//! comparison. The landmarks are row 8 of the golden track (`tests/data/driver-ict.csv`) through
//! the camera its hash list names.
//!
//! Run: `cargo bench -p sinew-host --bench driver`.

use std::path::{Path, PathBuf};

use burn::tensor::Device;
use criterion::{Criterion, criterion_group, criterion_main};
use sinew_core::aim::AimActor;
use sinew_core::driver::{Driver, Intrinsics, filter_pose, normalise_pixels, play};
use sinew_core::filter::OneEuro;
use sinew_core::replay::model_hash;
use sinew_host::driver::DriverConfig;
use sinew_host::driver::bake::{BakeInputs, bake};
use sinew_host::driver::sample::Sampler;
use sinew_host::driver::train::{Normalisation, network};

fn golden(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data")
        .join(name)
}

fn read(name: &str) -> Vec<u8> {
    std::fs::read(golden(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The camera of the hash list's `track` line.
fn camera() -> Intrinsics {
    let list = String::from_utf8(read("driver-ict.hashes")).expect("UTF-8");
    let line = list
        .lines()
        .find(|l| l.starts_with("track "))
        .expect("a track line");
    let k: Vec<f32> = line
        .split_whitespace()
        .skip(2)
        .map(|v| v.parse().expect("a number"))
        .collect();
    Intrinsics {
        fx: k[0],
        fy: k[1],
        cx: k[2],
        cy: k[3],
    }
}

/// A driver of the golden actor with `hidden` units per layer and seeded weights.
fn sized_driver(actor_bytes: &[u8], hidden: usize) -> Vec<u8> {
    let a = AimActor::from_bytes(actor_bytes).expect("valid actor");
    let vertices = sinew_host::driver::landmark_vertices(&golden(""), &a).expect("landmarks");
    let config = DriverConfig {
        hidden,
        ..DriverConfig::default()
    };
    let sampler = Sampler::new(&a, &vertices, &config);
    let norm = Normalisation::measure(&sampler, 1);
    let device: Device = sinew_host::training::backend::Backend::default()
        .device(3)
        .expect("the CPU backend");
    let net = network(
        config.input.features(),
        hidden,
        18 + a.shape_count(),
        &device,
    );
    bake(
        &net,
        &norm,
        &config,
        &BakeInputs {
            actor_hash: model_hash(actor_bytes),
            units: "cm",
            vertices: &vertices,
            camera: sampler.camera,
        },
    )
    .expect("a driver")
}

fn bench(c: &mut Criterion) {
    let actor_bytes = read("aim-ict.sinew");
    let actor = AimActor::from_bytes(&actor_bytes).expect("valid actor");
    let rows = sinew_host::io::openface::read(&golden("driver-ict.csv")).expect("the track");
    let pixels = rows[8].pixels.clone();
    let camera = camera();
    let golden_bytes = read("driver-ict.sinew");
    let default_bytes = sized_driver(&actor_bytes, DriverConfig::default().hidden);
    let mut group = c.benchmark_group("driver");
    for (name, bytes) in [
        ("drive_golden_hidden64", &golden_bytes),
        ("drive_default_hidden128", &default_bytes),
    ] {
        let driver = Driver::from_bytes(bytes).expect("valid driver");
        driver
            .check_actor(&actor_bytes, &actor)
            .expect("the golden actor's");
        let mut landmarks = vec![0.0; driver.input_len()];
        let mut scratch = vec![0.0; driver.scratch_len()];
        let mut pose = vec![0.0; driver.output_len()];
        group.bench_function(name, |b| {
            b.iter(|| {
                normalise_pixels(&pixels, &camera, &mut landmarks).expect("pixels");
                driver
                    .drive(&landmarks, &mut scratch, &mut pose)
                    .expect("a pose");
            })
        });
    }
    let driver = Driver::from_bytes(&golden_bytes).expect("valid driver");
    let mut landmarks = vec![0.0; driver.input_len()];
    let mut scratch = vec![0.0; driver.scratch_len()];
    let mut pose = vec![0.0; driver.output_len()];
    normalise_pixels(&pixels, &camera, &mut landmarks).expect("pixels");
    driver
        .drive(&landmarks, &mut scratch, &mut pose)
        .expect("a pose");
    let filter = OneEuro::new(1.0, 0.5, 1.0, 30.0).expect("settings");
    let mut state = vec![0.0; OneEuro::timed_state_len(pose.len())];
    let mut time = 0.0f32;
    group.bench_function("filter_step", |b| {
        b.iter(|| {
            // Time stamps stay within the filter's range (and keep a millisecond's resolution):
            // start again every 1,000 s of frames.
            time += 1.0 / 30.0;
            if time > 1000.0 {
                time = 0.0;
                state.fill(0.0);
            }
            let mut p = pose.clone();
            filter_pose(&filter, &mut state, time, &mut p).expect("a step");
            p
        })
    });
    let mut positions = vec![0.0; 3 * actor.vertex_count()];
    group.bench_function("pose_ict_4705v", |b| {
        b.iter(|| play(&actor, &pose, &mut positions).expect("a pose"))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
