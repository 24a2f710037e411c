//! The AIM fit (AIM Sec. 4.2, eqs. 17–24) of a baked actor to a performance's meshes, on burn.
//!
//! Per frame j a code z_j ∈ R^f; F_T, a 4-layer GELU MLP, maps z_j to the head and jaw
//! transforms (6D rotation + translation each, added to the identity so that a zero output is
//! the rest pose); F_W, a 4-layer GELU MLP, maps (z_j, ĉ) to the corrective coefficients
//! w_j(c) ∈ R^(N−1) at each template point (local), or z_j alone to one w_j per frame (the
//! paper's "(G)"). The actor's baked cache (s0, k, B_e, the pivot) is fixed:
//! `s* = T_g(LBS(s0, T_b, k) + Σ w B_e)` (eq. 17). The objective (eq. 24 without the 2D term):
//! - eq. 20: `λ_3D · mean_points(|s* − s_GT|² + |s*_lbs − s_GT|²)`, in mm², where
//!   `s*_lbs = T_g(LBS(s0, T_b, k))` is the skinned shape without correctives;
//! - eq. 22: `λ_W · mean_points(|w|²)` (λ_W = 0.75; the sum over the N − 1 coefficients);
//! - eq. 23: `λ_T · mean_j |z_j − z_{j−1}|²` (λ_T = 0.05).
//!
//! Each step draws `points` template vertices (the same for every frame, seeded by the step)
//! and constrains every frame there; the reported error uses every vertex.
//!
//! `setup` builds the fixed tensors, the variables and the empty result; `objective` is one
//! step's loss; `checkpoint` saves and stops; `finish` the result after the last step; `posing`
//! the forward pass; `start` where each frame's head and jaw start (at rest, a rigid alignment,
//! or a landmark driver's answer, which the fit then refines).

use std::time::Instant;

use burn::module::Param;
use burn::optim::GradientsParams;
use burn::tensor::{Distribution, Tensor};
use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use sinew_core::replay::model_hash;

pub use crate::fit::setup::{Coefficients, Constrain, FitConfig, FitNet, Mode, Start};

use crate::fit::checkpoint::{CHECKPOINT_FORMAT, Checkpointing, EVERY, FitState, target_crc};
use crate::fit::setup::{fw_mlp, gelu_mlp};
use crate::io::performance::Performance;
use crate::training::adam::Adam;
use crate::training::backend::Backend;
use crate::training::nn::{LayerWeights, tensor, to_vec};

pub use cache::ActorCache;
pub use error::FitError;
use objective::{TwoDTargets, step_loss, step_rng};
use posing::{Fixed, evaluate};
#[cfg(test)]
use start::rigid_start;
use start::{constrained_vertices, starts};

/// The fit of one performance with one setting.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitResult {
    /// The settings.
    pub config: FitConfig,
    /// Mean per-vertex distance to the performance's meshes, in mm, after the last step.
    pub mean_error_mm: f64,
    /// The same per frame.
    pub frame_error_mm: Vec<f64>,
    /// `(step, mean error in mm)` before the first step, half way and after the last.
    pub error_history: Vec<(usize, f64)>,
    /// `(step, total loss)` every 10 steps.
    pub loss_history: Vec<(usize, f64)>,
    /// Wall-clock seconds of the optimisation divided by the frames.
    pub seconds_per_frame: f64,
    /// Per frame: head and jaw (6D + translation in the actor's units).
    pub head: Vec<[f32; 9]>,
    /// Per frame: jaw.
    pub jaw: Vec<[f32; 9]>,
    /// Per frame, the global coefficients (global fits only).
    pub weights: Option<Vec<Vec<f32>>>,
    /// Mean distance in pixels between the fitted meshes' landmarks, projected by the
    /// performance's camera, and the landmark tracks.
    pub reprojection_px: f64,
    /// Plausibility (AIM Fig. 7): how far edges stretch or shrink from the actor's neutral over
    /// the fitted frames, the 99th percentile over edges of `max_frames |ℓ/ℓ0 − 1|`.
    pub worst_edge_change: f64,
    /// The same for the performance's own meshes, the scale to read it against.
    pub target_worst_edge_change: f64,
    /// Per frame, the fitted skin `[V]` in the actor's units.
    #[serde(skip)]
    pub meshes: Vec<Vec<[f32; 3]>>,
    /// The frame codes z_j, `[J, f]` row-major.
    #[serde(skip)]
    pub codes: Vec<f32>,
    /// F_W's weights in the core's layout.
    #[serde(skip)]
    pub fw: Vec<LayerWeights>,
    /// The normalisation of template points F_W saw: centre x, y, z and half extent.
    #[serde(skip)]
    pub normalisation: [f32; 4],
}

/// Fits `actor` (its bytes, `unit_mm` millimetres per unit) to every frame of `perf`.
pub fn fit(
    actor: &AimActor<'_>,
    perf: &Performance,
    config: &FitConfig,
    backend: Backend,
) -> Result<FitResult, FitError> {
    fit_resumable(actor, perf, config, backend, None)
}

/// [`fit`] with checkpoints: every [`EVERY`] steps and when Ctrl-C is pressed (the fit then
/// stops with an error that says how to resume), and from a checkpoint when `resume` is set.
pub fn fit_resumable(
    actor: &AimActor<'_>,
    perf: &Performance,
    config: &FitConfig,
    backend: Backend,
    checkpoints: Option<Checkpointing<'_>>,
) -> Result<FitResult, FitError> {
    fit_from(actor, perf, config, backend, checkpoints, None)
}

/// [`fit_resumable`] with, for [`Start::Driver`], each frame's head and jaw as a landmark
/// driver gave them (`[head 9, jaw 9]`, translations in the actor's units): the fit refines the
/// driver's answer.
///
/// # Errors
/// As [`fit_resumable`]; [`FitError::DriverStart`] without one driven pose per frame.
pub fn fit_from(
    actor: &AimActor<'_>,
    perf: &Performance,
    config: &FitConfig,
    backend: Backend,
    checkpoints: Option<Checkpointing<'_>>,
    driven: Option<&[[f32; 18]]>,
) -> Result<FitResult, FitError> {
    let Setup {
        cache,
        unit,
        device,
        subset,
        starts,
        fx,
        mut net,
        mut optim,
        mut result,
        mut state,
    } = setup(actor, perf, config, backend, driven)?;
    let mm = cache.mm;
    let evaluate = |net: &FitNet| -> (Vec<Vec<[f32; 3]>>, Vec<f64>) {
        evaluate(net, &fx, config.coefficients, perf, unit, mm)
    };
    match checkpoints {
        Some(c) if c.resume => {
            let (n, o, s) = crate::fit::checkpoint::load(c.dir, net, optim, &state)?;
            (net, optim) = (n, o);
            result.loss_history = s.loss_history.clone();
            result.error_history = s.error_history.clone();
            state = s;
            state.config = config.clone();
        }
        _ => {
            let (_, errors) = evaluate(&net);
            result.error_history.push((0, mean(&errors)));
        }
    }
    let start = Instant::now();
    let bar = crate::training::progress::bar(config.iterations as u64, true);
    bar.set_position(state.steps_done as u64);
    let camera = TwoDTargets::new(perf, config, mm, &device)?;
    for step in state.steps_done..config.iterations {
        let total = step_loss(
            &net,
            &fx,
            config,
            camera.as_ref(),
            subset.as_deref(),
            step,
            &mut result.loss_history,
        );
        let grads = GradientsParams::from_grads(total.backward(), &net);
        net = optim.step(config.lr_at(step), net, grads);
        bar.inc(1);
        if step + 1 == config.iterations / 2 && config.iterations >= 2 {
            let (_, errors) = evaluate(&net);
            result.error_history.push((step + 1, mean(&errors)));
        }
        if let Some(c) = checkpoints {
            let elapsed = start.elapsed().as_secs_f64();
            if let Err(e) = checkpoint(c, step, config, &net, &optim, &result, &mut state, elapsed)
            {
                bar.finish_and_clear();
                return Err(e);
            }
        }
    }
    bar.finish_and_clear();
    result.seconds_per_frame = (state.seconds + start.elapsed().as_secs_f64()) / fx.frames as f64;
    let (meshes, errors) = evaluate(&net);
    finish(
        result, &net, &fx, &cache, &starts, perf, config, meshes, errors,
    )
}

/// What a fit holds from its setup to its end.
struct Setup {
    cache: ActorCache,
    unit: crate::io::units::Unit,
    device: burn::tensor::Device,
    subset: Option<Vec<i64>>,
    starts: Vec<[f32; 18]>,
    fx: Fixed,
    net: FitNet,
    optim: Adam,
    result: FitResult,
    state: FitState,
}

/// Checks the settings and the frames, and builds the fixed tensors, the variables (seeded),
/// Adam, the empty result and the checkpoint state.
fn setup(
    actor: &AimActor<'_>,
    perf: &Performance,
    config: &FitConfig,
    backend: Backend,
    driven: Option<&[[f32; 18]]>,
) -> Result<Setup, FitError> {
    if !(config.iterations > 0 && config.points > 0 && config.code > 0 && config.hidden > 0) {
        return Err(FitError::EmptyConfig);
    }
    let unit = perf.unit;
    let v = actor.vertex_count();
    for (f, frame) in perf.frames.iter().enumerate() {
        if frame.len() != v {
            return Err(FitError::VertexCount {
                path: perf.frame_path(f),
                frame_vertices: frame.len(),
                actor_vertices: v,
            });
        }
    }
    let mm = unit.mm() as f32;
    let cache = ActorCache::new(actor, mm);
    let (j, m) = (perf.frames.len(), cache.shapes);
    let device = backend.autodiff_device(config.seed)?;
    let targets: Vec<f32> = perf
        .frames
        .iter()
        .flatten()
        .flatten()
        .map(|x| x * mm)
        .collect();
    let subset = constrained_vertices(perf, config, &mut step_rng(config.seed, u64::MAX))?;
    let starts = starts(&cache, perf, config, subset.as_deref(), driven)?;
    let fx = Fixed {
        start: tensor(starts.iter().flatten().copied().collect(), [j, 18], &device),
        rest: tensor(cache.rest.clone(), [v, 3], &device),
        k: tensor(cache.k.clone(), [v, 1], &device),
        correctives: tensor(cache.correctives.clone(), [v, 3 * m], &device),
        normalised: tensor(cache.normalised.clone(), [v, 3], &device),
        pivot: tensor(cache.pivot.to_vec(), [1, 3], &device),
        targets: tensor(targets, [j, v, 3], &device),
        frames: j,
        vertices: v,
        shapes: m,
    };
    let fw_inputs = match config.coefficients {
        Coefficients::Local => config.code + 3,
        _ => config.code,
    };
    let net = FitNet {
        codes: Param::from_tensor(Tensor::random(
            [j, config.code],
            Distribution::Normal(0.0, 0.01),
            &device,
        )),
        ft: gelu_mlp(config.code, config.hidden, 18, &device),
        fw: fw_mlp(config, fw_inputs, m.max(1), &device),
    };
    let optim = Adam::new(1e-8);
    let result = FitResult {
        config: config.clone(),
        mean_error_mm: 0.0,
        frame_error_mm: Vec::new(),
        error_history: Vec::new(),
        loss_history: Vec::new(),
        seconds_per_frame: 0.0,
        head: Vec::new(),
        jaw: Vec::new(),
        weights: None,
        reprojection_px: 0.0,
        worst_edge_change: 0.0,
        target_worst_edge_change: 0.0,
        meshes: Vec::new(),
        codes: Vec::new(),
        fw: Vec::new(),
        normalisation: [
            cache.centre[0],
            cache.centre[1],
            cache.centre[2],
            cache.half,
        ],
    };
    let state = FitState {
        format: CHECKPOINT_FORMAT.to_owned(),
        config: config.clone(),
        actor: format!("{:016x}", model_hash(actor.file().bytes())),
        target_crc: target_crc(perf),
        steps_done: 0,
        loss_history: Vec::new(),
        error_history: Vec::new(),
        seconds: 0.0,
        files: Default::default(),
    };
    Ok(Setup {
        cache,
        unit,
        device,
        subset,
        starts,
        fx,
        net,
        optim,
        result,
        state,
    })
}

/// After step `step`: saves a checkpoint every [`EVERY`] steps, after the last and when Ctrl-C
/// asks to stop (`elapsed`: this invocation's seconds so far), and then stops with
/// [`FitError::Stopped`].
#[allow(clippy::too_many_arguments)]
fn checkpoint(
    c: Checkpointing<'_>,
    step: usize,
    config: &FitConfig,
    net: &FitNet,
    optim: &Adam,
    result: &FitResult,
    state: &mut FitState,
    elapsed: f64,
) -> Result<(), FitError> {
    let stop = crate::training::interrupt::take_stop_request();
    if stop || (step + 1).is_multiple_of(EVERY) || step + 1 == config.iterations {
        state.steps_done = step + 1;
        state.loss_history = result.loss_history.clone();
        state.error_history = result.error_history.clone();
        let saved = FitState {
            seconds: state.seconds + elapsed,
            ..state.clone()
        };
        crate::fit::checkpoint::save(c.dir, net, optim, saved)?;
        if stop {
            return Err(FitError::Stopped {
                step: step + 1,
                iterations: config.iterations,
                dir: c.dir.to_owned(),
            });
        }
    }
    Ok(())
}

/// The result after the last step: every frame's error (`meshes`, `errors`: the fit at every
/// vertex), the plausibility measures, the head and jaw per frame, the codes, F_W and, for a
/// global fit, its coefficients.
#[allow(clippy::too_many_arguments)]
fn finish(
    mut result: FitResult,
    net: &FitNet,
    fx: &Fixed,
    cache: &ActorCache,
    starts: &[[f32; 18]],
    perf: &Performance,
    config: &FitConfig,
    meshes: Vec<Vec<[f32; 3]>>,
    errors: Vec<f64>,
) -> Result<FitResult, FitError> {
    let (mm, m) = (cache.mm, fx.shapes);
    result.mean_error_mm = mean(&errors);
    result
        .error_history
        .push((config.iterations, result.mean_error_mm));
    if !result.mean_error_mm.is_finite() {
        return Err(FitError::Diverged {
            mean_error_mm: result.mean_error_mm,
        });
    }
    result.frame_error_mm = errors;
    result.reprojection_px = reprojection_px(perf, &meshes);
    let neutral: Vec<[f32; 3]> = cache
        .rest
        .chunks_exact(3)
        .map(|p| [p[0] / mm, p[1] / mm, p[2] / mm])
        .collect();
    result.worst_edge_change = worst_edge_change(&perf.polygons, &neutral, &meshes);
    result.target_worst_edge_change = worst_edge_change(&perf.polygons, &neutral, &perf.frames);
    result.meshes = meshes;
    let t = to_vec(net.ft.forward(net.codes.val()));
    for (row, start) in t.chunks_exact(18).zip(starts) {
        let add = |o: usize| -> [f32; 9] {
            std::array::from_fn(|i| {
                let x = row[o + i] + start[o + i];
                // Translations back into the actor's units.
                if i >= 6 { x / mm } else { x }
            })
        };
        result.head.push(add(0));
        result.jaw.push(add(9));
    }
    result.codes = to_vec(net.codes.val());
    result.fw = net.fw.weights();
    if config.coefficients == Coefficients::Global {
        let w = to_vec(net.fw.forward(net.codes.val()));
        result.weights = Some(w.chunks_exact(m.max(1)).map(<[f32]>::to_vec).collect());
    }
    Ok(result)
}

/// Mean pixel distance between the landmark vertices of `meshes`, projected by the performance's
/// camera, and its landmark tracks (a vertex behind the camera counts as infinitely far).
pub fn reprojection_px(perf: &Performance, meshes: &[Vec<[f32; 3]>]) -> f64 {
    let l = &perf.manifest.landmarks;
    let mut sum = 0.0;
    let mut n = 0usize;
    for (mesh, track) in meshes.iter().zip(&l.pixels) {
        for (&i, px) in l.vertices.iter().zip(track) {
            let d = mesh
                .get(i as usize)
                .and_then(|&p| perf.manifest.camera.project(p))
                .map_or(f64::INFINITY, |uv| {
                    f64::from(uv[0] - px[0]).hypot(f64::from(uv[1] - px[1]))
                });
            sum += d;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

/// The 99th percentile over the polygons' edges of each edge's largest `|ℓ/ℓ0 − 1|` over the
/// frames, ℓ0 on `neutral` (a percentile, so that a few slivers of the template do not decide).
pub fn worst_edge_change(
    polygons: &[Vec<u32>],
    neutral: &[[f32; 3]],
    frames: &[Vec<[f32; 3]>],
) -> f64 {
    let len = |m: &[[f32; 3]], a: u32, b: u32| -> Option<f64> {
        let (p, q) = (m.get(a as usize)?, m.get(b as usize)?);
        Some(
            (0..3)
                .map(|c| f64::from(p[c] - q[c]).powi(2))
                .sum::<f64>()
                .sqrt(),
        )
    };
    let mut edges = Vec::new();
    for poly in polygons {
        for (k, &a) in poly.iter().enumerate() {
            let b = poly[(k + 1) % poly.len()];
            let Some(l0) = len(neutral, a, b).filter(|&l| l > 0.0) else {
                continue;
            };
            let worst = frames
                .iter()
                .filter_map(|f| len(f, a, b))
                .map(|l| (l / l0 - 1.0).abs())
                .fold(0.0f64, f64::max);
            edges.push(worst);
        }
    }
    if edges.is_empty() {
        return 0.0;
    }
    edges.sort_by(f64::total_cmp);
    edges[(edges.len() - 1) * 99 / 100]
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

mod cache;
mod error;
mod objective;
mod posing;
mod start;

#[cfg(test)]
mod tests;
