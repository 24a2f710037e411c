//! Real-time AIM playback in `sinew-core`: one frame of eq. 17 (jaw LBS + 19 correctives + head
//! transform) over the ICT face region's 9,409 vertices, and the per-vertex normals. The cache's
//! values do not change the cost, so the actor is synthetic (seeded) at the real size.
//!
//! Run: `cargo bench -p sinew-host --bench aim_playback`.

use criterion::{Criterion, criterion_group, criterion_main};
use rand_core::{RngCore, SeedableRng};
use sinew_core::aim::AimActor;
use sinew_core::format::{ArtifactKind, FLAG_PLAYBACK_ONLY};
use sinew_host::SinewWriter;

fn synthetic_actor(vertices: usize, shapes: usize) -> Vec<u8> {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
    let mut u = |n: usize, scale: f32| {
        (0..n)
            .map(|_| (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32 * scale)
            .collect::<Vec<f32>>()
    };
    let side = (vertices as f64).sqrt() as u32;
    let tri: Vec<u32> = (0..side - 1)
        .flat_map(|r| (0..side - 1).map(move |c| (r, c)))
        .flat_map(|(r, c)| {
            let v = r * side + c;
            [v, v + 1, v + side, v + 1, v + side + 1, v + side]
        })
        .collect();
    let mut w = SinewWriter::new(ArtifactKind::AimActor);
    w.flags(FLAG_PLAYBACK_ONLY);
    w.f32s("tpl.pos", &[vertices, 3], &u(vertices * 3, 18.0))
        .unwrap();
    w.u32s("tpl.tri", &[tri.len() / 3, 3], &tri).unwrap();
    w.f32s("cache.s0", &[vertices, 3], &u(vertices * 3, 18.0))
        .unwrap();
    w.f32s("cache.k", &[vertices], &u(vertices, 1.0)).unwrap();
    w.f32s(
        "cache.e",
        &[vertices, shapes, 3],
        &u(vertices * shapes * 3, 1.0),
    )
    .unwrap();
    w.f32s("cache.b0", &[vertices, 3], &u(vertices * 3, 18.0))
        .unwrap();
    w.f32s("cache.d0", &[vertices], &u(vertices, 1.0)).unwrap();
    w.f32s("cache.n0", &[vertices, 3], &u(vertices * 3, 1.0))
        .unwrap();
    w.f32s("jaw.pivot", &[3], &[0.0, 1.0, -5.0]).unwrap();
    w.f32s("train.jaw", &[shapes, 9], &u(shapes * 9, 1.0))
        .unwrap();
    w.to_bytes().unwrap()
}

fn bench(c: &mut Criterion) {
    let bytes = synthetic_actor(9409, 19);
    let actor = AimActor::from_bytes(&bytes).expect("valid actor");
    let weights: Vec<f32> = (0..19).map(|j| j as f32 / 19.0).collect();
    let pose = actor
        .pose_from_9d(
            &[1.0, 0.0, 0.0, 0.0, 0.98, -0.2, 0.0, -0.1, 0.05],
            &[0.99, 0.0, 0.1, 0.0, 1.0, 0.0, 1.0, 2.0, 3.0],
        )
        .expect("a valid pose");
    let mut out = vec![0.0; 3 * actor.vertex_count()];
    let mut normals = vec![0.0; 3 * actor.vertex_count()];
    let mut group = c.benchmark_group("aim_playback");
    group.bench_function("pose_9409v_19shapes", |b| {
        b.iter(|| actor.pose(&pose, &weights, &mut out).expect("sizes"))
    });
    group.bench_function("normals_9409v", |b| {
        b.iter(|| actor.normals(&out, &mut normals).expect("sizes"))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
