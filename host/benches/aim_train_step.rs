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
use sinew_host::aim::train::{StepRows, init, step_once, step_rows};
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
    arithmetic_rate(
        &set,
        &config,
        norm,
        &device,
        net.take().expect("model"),
        &mut optim,
    );
}

/// Multiply-adds of one row through a SIREN 3 → hidden × layers → `out`.
fn mlp_macs(config: &AimConfig, out: usize) -> f64 {
    let h = config.hidden as f64;
    3.0 * h + (config.layers.saturating_sub(1)) as f64 * h * h + h * out as f64
}

/// The floating-point operations of one training step: the matrix products of its network rows
/// (2 per multiply-add), forward, and twice that backward (the gradients with respect to the
/// activations and to the weights): 3 × forward. The element-wise work (sines, the losses, Adam's
/// update) is left out: it is a few per cent of the products' at this width.
fn step_flops(rows: StepRows, config: &AimConfig, shapes: usize) -> f64 {
    let all =
        mlp_macs(config, 3) * 2.0 + mlp_macs(config, 1) * 2.0 + mlp_macs(config, 3 * (shapes - 1));
    let forward = rows.distinct as f64 * all
        + 2.0 * rows.symmetry as f64 * mlp_macs(config, 3)
        + (rows.forehead + rows.jaw) as f64 * mlp_macs(config, 1);
    3.0 * 2.0 * forward
}

/// The machine's peak f32 rate: cores × clock × FLOPs a cycle (two fused multiply-add pipes of
/// 256 bits, 8 lanes × 2 operations each, on a core with AVX2 and FMA; AMD's Zen 4 runs
/// AVX-512 on the same 256-bit pipes). The clock is `/proc/cpuinfo`'s `cpu MHz` of the first core.
fn peak_flops() -> Option<(f64, usize, f64, f64)> {
    let cores = std::thread::available_parallelism().ok()?.get();
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    let mhz: f64 = info
        .lines()
        .find(|l| l.starts_with("cpu MHz"))?
        .split(':')
        .nth(1)?
        .trim()
        .parse()
        .ok()?;
    #[cfg(target_arch = "x86_64")]
    let per_cycle = if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
        32.0
    } else {
        8.0
    };
    #[cfg(not(target_arch = "x86_64"))]
    let per_cycle = 8.0;
    Some((cores as f64 * mhz * 1e6 * per_cycle, cores, mhz, per_cycle))
}

/// The step as a fraction of the machine's peak: its FLOPs counted, the median of 20 more steps
/// timed (after criterion's warm-up and samples), against [`peak_flops`].
fn arithmetic_rate(
    set: &sinew_host::aim::TrainingSet,
    config: &AimConfig,
    norm: [f32; 4],
    device: &burn::tensor::Device,
    mut net: sinew_host::aim::model::AimNet,
    optim: &mut sinew_host::training::adam::Adam,
) {
    let mut seconds = Vec::new();
    let mut flops = Vec::new();
    for step in 10_000..10_020 {
        flops.push(step_flops(
            step_rows(set, config, step),
            config,
            set.shapes.len(),
        ));
        let start = std::time::Instant::now();
        let (n, terms) = step_once(net, optim, set, config, norm, step, device);
        let _ = sinew_host::training::nn::to_vec(terms);
        seconds.push(start.elapsed().as_secs_f64());
        net = n;
    }
    seconds.sort_by(f64::total_cmp);
    let median = seconds[seconds.len() / 2];
    let per_step = flops.iter().sum::<f64>() / flops.len() as f64;
    println!(
        "aim/train_step: {:.2} GFLOP a step (matrix products, forward and backward), median {:.1} ms of 20 steps: {:.1} GFLOP/s",
        per_step * 1e-9,
        median * 1e3,
        per_step / median * 1e-9
    );
    if let Some((peak, cores, mhz, per_cycle)) = peak_flops() {
        println!(
            "aim/train_step: {:.1} % of the peak {:.1} GFLOP/s ({cores} cores × {:.3} GHz × {per_cycle} FLOP a cycle)",
            100.0 * per_step / median / peak,
            peak * 1e-9,
            mhz * 1e-3
        );
    }
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
