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

use std::path::PathBuf;
use std::time::Instant;

use burn::module::Param;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Distribution, Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use sinew_core::replay::model_hash;

pub use crate::fit::setup::{Coefficients, Constrain, FitConfig, FitNet, Mode, Start};

use crate::fit::baseline::{BaselineError, mean_error_mm, performance_unit};
use crate::fit::checkpoint::{CHECKPOINT_FORMAT, Checkpointing, EVERY, FitState, target_crc};
use crate::fit::performance::Performance;
use crate::fit::setup::{fw_mlp, gelu_mlp};
use crate::geometry::align::fit_rigid;
use crate::training::backend::{Backend, BackendError};
use crate::training::checkpoint::CheckpointError;
use crate::training::nn::{LayerWeights, tensor, to_vec};
use crate::training::random::Stream;
use crate::training::rotation::rotate_6d;

/// The identity head and jaw, `[6D, t]` twice.
const IDENTITY_18: [f32; 18] = [
    1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0,
];

/// The baked actor's playback cache, in mm (the fit's unit).
#[derive(Clone, Debug)]
pub struct ActorCache {
    /// Vertices V.
    pub vertices: usize,
    /// Corrective shapes M = N − 1.
    pub shapes: usize,
    /// Neutral skin s0, `[V·3]`, mm.
    pub rest: Vec<f32>,
    /// Jaw skinning weight k, `[V]`.
    pub k: Vec<f32>,
    /// B_e, `[V·M·3]`, mm.
    pub correctives: Vec<f32>,
    /// Jaw pivot, mm.
    pub pivot: [f32; 3],
    /// Template points normalised to [−1, 1]: `(c − centre) / half`.
    pub normalised: Vec<f32>,
    /// The template's bounding-box centre (the actor's units).
    pub centre: [f32; 3],
    /// Half the bounding box's largest extent (the actor's units).
    pub half: f32,
    /// Millimetres per unit of the actor.
    pub mm: f32,
}

impl ActorCache {
    /// The cache of a baked actor whose lengths are in `unit_mm` millimetres.
    pub fn new(actor: &AimActor<'_>, unit_mm: f32) -> Self {
        let scaled = |v: sinew_core::tensor::F32s<'_>| v.iter().map(|x| x * unit_mm).collect();
        let tpl: Vec<f32> = actor.template().iter().collect();
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in tpl.chunks_exact(3) {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let centre = [0, 1, 2].map(|c| 0.5 * (lo[c] + hi[c]));
        let half = (0..3).map(|c| 0.5 * (hi[c] - lo[c])).fold(1e-12, f32::max);
        let normalised = tpl
            .chunks_exact(3)
            .flat_map(|p| [0, 1, 2].map(|c| (p[c] - centre[c]) / half))
            .collect();
        Self {
            vertices: actor.vertex_count(),
            shapes: actor.shape_count(),
            rest: scaled(actor.rest()),
            k: actor.skinning_weights().iter().collect(),
            correctives: scaled(actor.correctives()),
            pivot: actor.jaw_pivot().to_array().map(|x| x * unit_mm),
            normalised,
            centre,
            half,
            mm: unit_mm,
        }
    }
}

/// The fixed tensors of a fit.
struct Fixed {
    rest: Tensor<2>,
    k: Tensor<2>,
    correctives: Tensor<2>,
    normalised: Tensor<2>,
    pivot: Tensor<2>,
    /// Per frame, the head and jaw that a zero F_T output means, `[J, 18]`.
    start: Tensor<2>,
    targets: Tensor<3>,
    frames: usize,
    shapes: usize,
}

/// The fit at vertices `idx` of every frame.
struct Posed {
    /// s*, `[J·P, 3]`.
    skin: Tensor<2>,
    /// s*_lbs, `[J·P, 3]`.
    lbs: Tensor<2>,
    /// w, `[J·P, M]` (local) or `[J, M]` (global); `None` for zero coefficients.
    weights: Option<Tensor<2>>,
}

fn pose(net: &FitNet, fx: &Fixed, idx: Tensor<1, Int>, coefficients: Coefficients) -> Posed {
    let (j, m) = (fx.frames, fx.shapes);
    let p = idx.dims()[0];
    let per_frame = |t: Tensor<2>| {
        let [_, w] = t.dims();
        t.reshape([1, p, w]).repeat_dim(0, j).reshape([j * p, w])
    };
    let per_point = |t: Tensor<2>| {
        let [_, w] = t.dims();
        t.reshape([j, 1, w]).repeat_dim(1, p).reshape([j * p, w])
    };
    let codes = net.codes.val();
    // AIM eq. 18: [T_g, T_b] = F_T(z_j), from the frame's start
    let t = per_point(net.ft.forward(codes.clone()) + fx.start.clone());
    let (head, jaw) = (t.clone().narrow(1, 0, 9), t.narrow(1, 9, 9));
    let s0 = per_frame(fx.rest.clone().select(0, idx.clone()));
    let k = per_frame(fx.k.clone().select(0, idx.clone()));
    let rel = s0.clone() - fx.pivot.clone();
    let moved =
        rotate_6d(jaw.clone().narrow(1, 0, 6), rel) + fx.pivot.clone() + jaw.narrow(1, 6, 3);
    // LBS(s0, T_b, k) = k T_b(s0) + (1 − k) s0
    let lbs = moved * k.clone() + s0 * k.neg().add_scalar(1.0);
    let global =
        |x: Tensor<2>| rotate_6d(head.clone().narrow(1, 0, 6), x) + head.clone().narrow(1, 6, 3);
    let (weights, per_row) = match coefficients {
        Coefficients::Zero => (None, None),
        // AIM eq. 19: w_j = F_W(z_j, c)
        Coefficients::Local => {
            let c = per_frame(fx.normalised.clone().select(0, idx.clone()));
            let w = net.fw.forward(Tensor::cat(vec![per_point(codes), c], 1));
            (Some(w.clone()), Some(w))
        }
        Coefficients::Global => {
            let w = net.fw.forward(codes);
            (Some(w.clone()), Some(per_point(w)))
        }
    };
    let body = match per_row {
        Some(w) => {
            let e = per_frame(fx.correctives.clone().select(0, idx)).reshape([j * p, m, 3]);
            let corr = (w.reshape([j * p, m, 1]) * e)
                .sum_dim(1)
                .reshape([j * p, 3]);
            lbs.clone() + corr
        }
        None => lbs.clone(),
    };
    // AIM eq. 17: s* = T_g(LBS(s0, T_b, k) + Σ w B_e)
    Posed {
        skin: global(body),
        lbs: global(lbs),
        weights,
    }
}

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

/// An AIM fit that was refused or failed; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// Settings with no iteration, point, code dimension or hidden unit.
    #[error("the fit needs at least one iteration, point, code dimension and hidden unit")]
    EmptyConfig,
    /// The performance's unit cannot be read.
    #[error(transparent)]
    Unit(#[from] BaselineError),
    /// A frame with another vertex count than the actor's.
    #[error("{}: {frame_vertices} vertices, the actor has {actor_vertices}", path.display())]
    VertexCount {
        /// The frame's mesh.
        path: PathBuf,
        /// Its vertices.
        frame_vertices: usize,
        /// The actor's vertices.
        actor_vertices: usize,
    },
    /// The backend cannot run.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// A checkpoint that cannot be saved or resumed (the error names the file).
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// Landmark vertices that do not index the performance's meshes.
    #[error("{}: the landmark vertices do not index the meshes", path.display())]
    Landmarks {
        /// The performance's manifest.
        path: PathBuf,
    },
    /// Landmark tracks without one pixel per landmark and frame.
    #[error(
        "{}: the landmark tracks do not have one pixel per landmark and frame",
        path.display()
    )]
    LandmarkTracks {
        /// The performance's manifest.
        path: PathBuf,
    },
    /// Ctrl-C: the fit stopped after saving a checkpoint.
    #[error(
        "stopped after step {step} of {iterations}; the fit is saved in {}: continue with \
         --resume {}",
        dir.display(),
        dir.display()
    )]
    Stopped {
        /// Steps done.
        step: usize,
        /// Steps asked for.
        iterations: usize,
        /// The checkpoint folder.
        dir: PathBuf,
    },
    /// The fit's mean error is not finite.
    #[error(
        "the fit diverged (mean error {mean_error_mm}); try fewer points or a smaller learning rate"
    )]
    Diverged {
        /// The mean error, mm.
        mean_error_mm: f64,
    },
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
    if !(config.iterations > 0 && config.points > 0 && config.code > 0 && config.hidden > 0) {
        return Err(FitError::EmptyConfig);
    }
    let unit = performance_unit(perf)?;
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
    let starts = match config.start {
        Start::Rigid => rigid_start(&cache, perf, config.mode, subset.as_deref(), mm),
        Start::Identity => vec![IDENTITY_18; j],
    };
    let fx = Fixed {
        start: tensor(starts.iter().flatten().copied().collect(), [j, 18], &device),
        rest: tensor(cache.rest.clone(), [v, 3], &device),
        k: tensor(cache.k.clone(), [v, 1], &device),
        correctives: tensor(cache.correctives.clone(), [v, 3 * m], &device),
        normalised: tensor(cache.normalised.clone(), [v, 3], &device),
        pivot: tensor(cache.pivot.to_vec(), [1, 3], &device),
        targets: tensor(targets, [j, v, 3], &device),
        frames: j,
        shapes: m,
    };
    let fw_inputs = match config.coefficients {
        Coefficients::Local => config.code + 3,
        _ => config.code,
    };
    let mut net = FitNet {
        codes: Param::from_tensor(Tensor::random(
            [j, config.code],
            Distribution::Normal(0.0, 0.01),
            &device,
        )),
        ft: gelu_mlp(config.code, config.hidden, 18, &device),
        fw: fw_mlp(config, fw_inputs, m.max(1), &device),
    };
    let mut optim: ModuleOptimizer = AdamConfig::new().with_epsilon(1e-8).init();
    let mut result = FitResult {
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
    let evaluate = |net: &FitNet| -> (Vec<Vec<[f32; 3]>>, Vec<f64>) {
        evaluate(net, &fx, config.coefficients, perf, unit, mm)
    };
    let mut state = FitState {
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
        // Each step's draw is its own (seed, step), so a resumed fit draws what an unbroken one does.
        let mut rng = step_rng(config.seed, step as u64);
        let draw: Vec<i64> = match &subset {
            None => (0..config.points).map(|_| rng.below(v) as i64).collect(),
            Some(s) if s.len() <= config.points || camera.is_some() => s.clone(),
            Some(s) => (0..config.points).map(|_| s[rng.below(s.len())]).collect(),
        };
        let n = draw.len();
        let idx = Tensor::<1, Int>::from_data(TensorData::new(draw, [n]), &device);
        let posed = pose(&net, &fx, idx.clone(), config.coefficients);
        let mut total = match &camera {
            None => {
                let gt = fx.targets.clone().select(1, idx).reshape([j * n, 3]);
                let sq = |a: Tensor<2>| (a - gt.clone()).square().sum_dim(1).mean();
                // AIM eq. 20
                (sq(posed.skin) + sq(posed.lbs)).mul_scalar(config.lambda_3d)
            }
            Some(c) => {
                let sq =
                    |a: Tensor<2>| (c.project(a) - c.pixels.clone()).square().sum_dim(1).mean();
                // AIM eq. 21
                (sq(posed.skin) + sq(posed.lbs)).mul_scalar(config.lambda_2d)
            }
        };
        // AIM eq. 22
        if let Some(w) = posed.weights {
            total = total + w.square().sum_dim(1).mean().mul_scalar(config.lambda_w);
        }
        // AIM eq. 23
        if j > 1 {
            let z = net.codes.val();
            let d = z.clone().narrow(0, 1, j - 1) - z.narrow(0, 0, j - 1);
            total = total + d.square().sum_dim(1).mean().mul_scalar(config.lambda_t);
        }
        if step % 10 == 0 {
            let loss = to_vec(total.clone()).first().copied().unwrap_or(f32::NAN);
            result.loss_history.push((step, f64::from(loss)));
        }
        let grads = GradientsParams::from_grads(total.backward(), &net);
        net = optim.step(config.lr_at(step), net, grads);
        bar.inc(1);
        if step + 1 == config.iterations / 2 && config.iterations >= 2 {
            let (_, errors) = evaluate(&net);
            result.error_history.push((step + 1, mean(&errors)));
        }
        if let Some(c) = checkpoints {
            let stop = crate::training::interrupt::take_stop_request();
            if stop || (step + 1) % EVERY == 0 || step + 1 == config.iterations {
                state.steps_done = step + 1;
                state.loss_history = result.loss_history.clone();
                state.error_history = result.error_history.clone();
                let seconds = state.seconds + start.elapsed().as_secs_f64();
                let saved = FitState {
                    seconds,
                    ..state.clone()
                };
                crate::fit::checkpoint::save(c.dir, &net, &optim, saved)?;
                if stop {
                    bar.finish_and_clear();
                    return Err(FitError::Stopped {
                        step: step + 1,
                        iterations: config.iterations,
                        dir: c.dir.to_owned(),
                    });
                }
            }
        }
    }
    bar.finish_and_clear();
    result.seconds_per_frame = (state.seconds + start.elapsed().as_secs_f64()) / j as f64;
    let (meshes, errors) = evaluate(&net);
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
    for (row, start) in t.chunks_exact(18).zip(&starts) {
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

/// Per frame, where F_T starts (its zero output): the head at the rigid motion (Horn) that best
/// takes the actor's neutral s0 to the frame's constrained vertices, and the jaw at rest; the
/// identity for both in a 2D fit, or when no rigid motion aligns them.
fn rigid_start(
    cache: &ActorCache,
    perf: &Performance,
    mode: Mode,
    subset: Option<&[i64]>,
    mm: f32,
) -> Vec<[f32; 18]> {
    if mode == Mode::TwoD {
        return vec![IDENTITY_18; perf.frames.len()];
    }
    let rest: Vec<[f32; 3]> = cache
        .rest
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    let chosen: Vec<usize> = match subset {
        Some(s) => s.iter().map(|&i| i as usize).collect(),
        None => (0..rest.len()).collect(),
    };
    let from: Vec<[f32; 3]> = chosen.iter().map(|&i| rest[i]).collect();
    perf.frames
        .iter()
        .map(|frame| {
            let to: Vec<[f32; 3]> = chosen.iter().map(|&i| frame[i].map(|x| x * mm)).collect();
            match fit_rigid(&from, &to) {
                Some(r) => {
                    let mut start = IDENTITY_18;
                    for i in 0..3 {
                        // 6D: the rotation's first two columns.
                        start[i] = r.rotation[i][0] as f32;
                        start[3 + i] = r.rotation[i][1] as f32;
                        start[6 + i] = r.translation[i] as f32;
                    }
                    start
                }
                None => IDENTITY_18,
            }
        })
        .collect()
}

/// The vertices a 3D fit may draw from (`None`: all of them), or the landmark vertices of a 2D
/// fit; a fraction is drawn once, seeded.
fn constrained_vertices(
    perf: &Performance,
    config: &FitConfig,
    rng: &mut Stream,
) -> Result<Option<Vec<i64>>, FitError> {
    let v = perf.frames.first().map_or(0, Vec::len);
    let landmarks = || -> Result<Vec<i64>, FitError> {
        let l = &perf.manifest.landmarks.vertices;
        if l.is_empty() || !l.iter().all(|&i| (i as usize) < v) {
            return Err(FitError::Landmarks {
                path: perf.dir.join("performance.json"),
            });
        }
        Ok(l.iter().map(|&i| i64::from(i)).collect())
    };
    Ok(match (config.mode, config.constrain) {
        (Mode::TwoD, _) | (Mode::ThreeD, Constrain::Landmarks) => Some(landmarks()?),
        (Mode::ThreeD, Constrain::All) => None,
        (Mode::ThreeD, Constrain::Fraction(p)) => {
            let n = ((p * v as f32).round() as usize).clamp(1, v.max(1));
            // A seeded partial Fisher–Yates shuffle: the first n of a random permutation.
            let mut all: Vec<i64> = (0..v as i64).collect();
            for i in 0..n {
                let r = i + rng.below(v - i);
                all.swap(i, r);
            }
            all.truncate(n);
            Some(all)
        }
    })
}

/// A 2D fit's targets: the landmarks' pixels per frame and the camera, in mm.
struct TwoDTargets {
    /// `[J·L, 2]`, frame-major as `pose` orders its rows.
    pixels: Tensor<2>,
    /// Camera centre in mm, `[1, 3]`.
    position: Tensor<2>,
    focal: [f32; 2],
    principal: [f32; 2],
}

impl TwoDTargets {
    fn new(
        perf: &Performance,
        config: &FitConfig,
        mm: f32,
        device: &Device,
    ) -> Result<Option<Self>, FitError> {
        if config.mode != Mode::TwoD {
            return Ok(None);
        }
        let m = &perf.manifest;
        let l = m.landmarks.vertices.len();
        let pixels: Vec<f32> = m
            .landmarks
            .pixels
            .iter()
            .flatten()
            .flatten()
            .copied()
            .collect();
        if !(m.landmarks.pixels.len() == perf.frames.len()
            && pixels.len() == perf.frames.len() * l * 2)
        {
            return Err(FitError::LandmarkTracks {
                path: perf.dir.join("performance.json"),
            });
        }
        let c = &m.camera;
        Ok(Some(Self {
            pixels: tensor(pixels, [perf.frames.len() * l, 2], device),
            position: tensor(c.position.iter().map(|x| x * mm).collect(), [1, 3], device),
            focal: [c.fx, c.fy],
            principal: [c.cx, c.cy],
        }))
    }

    /// `Camera::project` on rows of mm positions: `[n, 3]` → `[n, 2]`.
    fn project(&self, x: Tensor<2>) -> Tensor<2> {
        let rel = x - self.position.clone();
        let depth = rel.clone().narrow(1, 2, 1).neg();
        let u = (rel.clone().narrow(1, 0, 1) / depth.clone())
            .mul_scalar(self.focal[0])
            .add_scalar(self.principal[0]);
        let v = (rel.narrow(1, 1, 1) / depth)
            .mul_scalar(-self.focal[1])
            .add_scalar(self.principal[1]);
        Tensor::cat(vec![u, v], 1)
    }
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

/// The random stream of one step of a fit (and `u64::MAX`'s, the constrained subset's).
fn step_rng(seed: u64, step: u64) -> Stream {
    Stream::new(seed, step, 0x00a0_2bdb_0000_0000_0000_0000_0000_0f17)
}

fn mean(x: &[f64]) -> f64 {
    x.iter().sum::<f64>() / x.len().max(1) as f64
}

/// Every frame's fitted skin over all vertices (in chunks), in the actor's units, and each
/// frame's mean error in mm.
fn evaluate(
    net: &FitNet,
    fx: &Fixed,
    coefficients: Coefficients,
    perf: &Performance,
    unit: crate::io::units::Unit,
    mm: f32,
) -> (Vec<Vec<[f32; 3]>>, Vec<f64>) {
    let v = perf.frames.first().map_or(0, Vec::len);
    let j = fx.frames;
    let device = fx.rest.device();
    let mut meshes = vec![Vec::with_capacity(v); j];
    for start in (0..v).step_by(2048) {
        let n = 2048.min(v - start);
        let idx: Vec<i64> = (start..start + n).map(|i| i as i64).collect();
        let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [n]), &device);
        let skin = to_vec(pose(net, fx, idx, coefficients).skin);
        for (f, rows) in skin.chunks_exact(3 * n).enumerate() {
            meshes[f].extend(
                rows.chunks_exact(3)
                    .map(|p| [p[0] / mm, p[1] / mm, p[2] / mm]),
            );
        }
    }
    let errors = meshes
        .iter()
        .zip(&perf.frames)
        .map(|(a, b)| mean_error_mm(a, b, unit))
        .collect();
    (meshes, errors)
}

#[cfg(test)]
mod tests;
