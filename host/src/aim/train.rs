//! AIM training: the loop over eqs. 11–16 with Adam, seeded per step so that a resumed run
//! reaches the same weights as an uninterrupted one, with atomic checkpoints, Ctrl-C handling,
//! a progress bar and a loss history.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::optim::GradientsParams;
use burn::tensor::{Device, Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use super::config::{InvalidConfig, JawInit};
use super::draw::{Draw, distinct_points, draw};
pub use super::draw::{StepRows, step_rows};
use super::model::{AimNet, IDENTITY_9D, normalisation, normalise};
use super::prior::{Prior, PriorError};
use super::target::{Check, Ending, Target, measure};
use super::{AimConfig, InvalidTrainingSet, TrainingSet};
use crate::io::mesh::MeshError;
use crate::training::adam::Adam;
use crate::training::backend::Backend;
use crate::training::checkpoint::{self, CheckpointError, InvalidState, STATE_FILE, WeightFiles};
use crate::training::nn::to_vec;

/// Why AIM training could not start, continue or finish.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TrainError {
    /// The training set breaks a rule.
    #[error(transparent)]
    Set(#[from] InvalidTrainingSet),
    /// The configuration breaks a rule.
    #[error(transparent)]
    Config(#[from] InvalidConfig),
    /// The compute device could not be set up.
    #[error(transparent)]
    Backend(Box<dyn std::error::Error + Send + Sync>),
    /// The checkpoint folder could not be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// The configuration could not be recorded as JSON metadata.
    #[error(transparent)]
    Metadata(serde_json::Error),
    /// A checkpoint could not be written, read or resumed from.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The template could not be written beside the checkpoint.
    #[error(transparent)]
    Template(#[from] MeshError),
    /// The loss became NaN or infinite.
    #[error(
        "training diverged at step {step} (loss terms {}); lower the learning rate",
        named_terms(terms)
    )]
    Diverged {
        /// The step.
        step: usize,
        /// The loss terms logged at it ([`TERMS`] order).
        terms: [f32; 6],
    },
    /// The accuracy target makes no sense.
    #[error(transparent)]
    Target(#[from] super::target::InvalidTarget),
    /// The prior actor cannot start this run.
    #[error(transparent)]
    Prior(#[from] PriorError),
    /// Ctrl-C stopped the run after a checkpoint.
    #[error(
        "interrupted at step {step}; checkpoint saved in {} (continue with --resume)",
        dir.display()
    )]
    Interrupted {
        /// The steps done.
        step: usize,
        /// The checkpoint folder.
        dir: PathBuf,
    },
}

impl TrainError {
    /// A device set-up failure of [`Backend`], kept whole as the source.
    pub(crate) fn backend(e: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> Self {
        Self::Backend(e.into())
    }
}

/// Names of the logged loss terms, in [`LossRecord::terms`] order. "skinning" is eq. 15 (k = 0
/// on the forehead) plus L_J (k = 1 on the skin over the jaw, `lambda_jaw`); checkpoints written
/// before L_J existed called it "forehead" and hold eq. 15 alone there.
pub const TERMS: [&str; 6] = [
    "skin",
    "anatomy",
    "thickness_reg",
    "symmetry",
    "skinning",
    "total",
];

/// `terms` named in [`TERMS`] order: "skin 0.1, anatomy NaN, …".
fn named_terms(terms: &[f32; 6]) -> String {
    let named: Vec<String> = TERMS
        .iter()
        .zip(terms)
        .map(|(name, v)| format!("{name} {v}"))
        .collect();
    named.join(", ")
}

/// The loss terms at one step.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LossRecord {
    /// Step (0-based).
    pub step: usize,
    /// Learning rate used.
    pub lr: f64,
    /// L_S, L_A, L_D, L_Sym, L_K + L_J and their sum, as weighted in the objective.
    pub terms: [f32; 6],
}

/// What a checkpoint folder's `state.json` holds besides the weights.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CheckpointState {
    /// Steps completed.
    pub steps_done: usize,
    /// The configuration (a resumed run must use the same). Read with
    /// [`AimConfig::from_recorded`]: a checkpoint from before `jaw_init` and `lambda_jaw` keeps
    /// the paper's objective it was trained with.
    #[serde(deserialize_with = "super::config::deserialize_recorded")]
    pub config: AimConfig,
    /// Loss history so far.
    pub history: Vec<LossRecord>,
    /// Training seconds so far.
    pub seconds: f64,
    /// Input normalisation: centre xyz and scale.
    pub normalisation: [f32; 4],
    /// Shape names, neutral first.
    pub names: Vec<String>,
    /// The jaw pivot of the training set.
    pub jaw_pivot: [f32; 3],
    /// Metadata of the training set (units, source…), for baking from the checkpoint alone.
    pub metadata: Vec<(String, String)>,
    /// The weight files this state goes with (empty in checkpoints written before them, whose
    /// weights are `model.bpk` and `optim.bpk`).
    #[serde(flatten)]
    pub files: WeightFiles,
    /// The accuracy checks so far, when the run aims for a target (none in checkpoints written
    /// before targets).
    #[serde(default)]
    pub checks: Vec<Check>,
}

/// Options of one training run.
#[derive(Clone, Debug)]
pub struct TrainOptions {
    /// The burn backend.
    pub backend: Backend,
    /// Folder for checkpoints (created).
    pub checkpoint_dir: PathBuf,
    /// Continue from the checkpoint in `checkpoint_dir`.
    pub resume: bool,
    /// Stop after this many steps in this invocation (tests of resumption); `None` runs to the end.
    pub stop_after: Option<usize>,
    /// Hide the progress bar.
    pub quiet: bool,
    /// Stop once this accuracy is reached ([`super::target`]); `None` runs every step.
    pub target: Option<Target>,
    /// Start from this actor's networks instead of random weights ([`super::prior`]); a resumed
    /// run continues from its checkpoint.
    pub prior: Option<Prior>,
}

/// A finished (or stopped) training run.
#[derive(Debug)]
pub struct Trained {
    /// The model, moved to an inference (non-autodiff) device.
    pub model: AimNet,
    /// Checkpoint state at the end.
    pub state: CheckpointState,
    /// Whether the run is finished: its target met, or all configured iterations run.
    pub complete: bool,
    /// What ended it, when complete.
    pub ending: Ending,
}

fn rows(values: Vec<f32>, width: usize, device: &Device) -> Tensor<2> {
    let n = values.len() / width;
    Tensor::from_data(TensorData::new(values, [n, width]), device)
}

/// One step's objective, eq. 16 plus L_J: L_S + L_A + L_D + L_Sym + (L_K + L_J). Returns the
/// total and the terms.
fn objective(
    net: &AimNet,
    set: &TrainingSet,
    config: &AimConfig,
    norm: [f32; 4],
    d: &Draw,
    device: &Device,
) -> (Tensor<1>, Tensor<1>) {
    let tpl = &set.template.positions;
    let gather3 = |idx: &[u32], f: &dyn Fn(u32) -> [f32; 3]| {
        rows(idx.iter().flat_map(|&i| f(i)).collect(), 3, device)
    };
    // The networks run once per distinct point of the draw (about 80 % of the 4,096 samples
    // on the ICT face, fewer on smaller templates) and the samples take their rows: the same
    // objective and gradients as one evaluation per sample, for less work.
    let (distinct, slot) = distinct_points(&d.points, set.vertices());
    let x = gather3(&distinct, &|i| normalise(tpl[i as usize], norm));
    let c = gather3(&distinct, &|i| tpl[i as usize]);
    let slot = Tensor::<1, Int>::from_data(TensorData::new(slot, [d.points.len()]), device);
    let gt = rows(
        d.points
            .iter()
            .zip(&d.shapes)
            .flat_map(|(&v, &s)| set.shapes[s as usize][v as usize])
            .collect(),
        3,
        device,
    );
    let shape = Tensor::<1, Int>::from_data(
        TensorData::new(
            d.shapes.iter().map(|&s| i64::from(s)).collect::<Vec<_>>(),
            [d.shapes.len()],
        ),
        device,
    );
    let pivot = rows(set.jaw_pivot.to_vec(), 3, device);

    let p = net.predict(x, c).select(slot);
    // AIM eq. 11: L_S = λ_S ||s̃_i − s_i||²
    let skin = net
        .pose(&p, shape, pivot)
        .sub(gt)
        .square()
        .sum_dim(1)
        .mean()
        .mul_scalar(config.lambda_skin);

    // AIM eq. 12 on the constrained samples: λ_b||b̃0 − b0||² + λ_d||d̃0 − d0||² + λ_n||ñ0 − n0||²
    let anchor = |i: u32| set.anchors[i as usize];
    let mask: Vec<f32> = d
        .points
        .iter()
        .map(|&i| f32::from(u8::from(anchor(i).is_some())))
        .collect();
    let count = mask.iter().sum::<f32>().max(1.0);
    let mask = rows(mask, 1, device);
    let bone_t = gather3(&d.points, &|i| anchor(i).map_or([0.0; 3], |a| a.bone));
    let normal_t = gather3(&d.points, &|i| anchor(i).map_or([0.0; 3], |a| a.normal));
    let thick_t = rows(
        d.points
            .iter()
            .map(|&i| anchor(i).map_or(0.0, |a| a.thickness))
            .collect(),
        1,
        device,
    );
    let anatomy = (p
        .bone
        .clone()
        .sub(bone_t)
        .square()
        .sum_dim(1)
        .mul_scalar(config.lambda_bone)
        + p.thickness
            .clone()
            .sub(thick_t)
            .square()
            .mul_scalar(config.lambda_thickness)
        + p.normal
            .clone()
            .sub(normal_t)
            .square()
            .sum_dim(1)
            .mul_scalar(config.lambda_normal))
    .mul(mask)
    .sum()
    .div_scalar(count);

    // AIM eq. 13: L_D = λ_D ||d̃0||²
    let thickness_reg = p
        .thickness
        .square()
        .mean()
        .mul_scalar(config.lambda_thickness_reg);

    // AIM eq. 14: L_Sym = λ_sym ||B(R(c)) − R(B(c))||², B predicting b0 = c + B(ĉ).
    let refl = |q: [f32; 3]| set.symmetry.reflect(q);
    let cs = gather3(&d.symmetry, &|i| tpl[i as usize]);
    let xs = gather3(&d.symmetry, &|i| normalise(tpl[i as usize], norm));
    let cm = gather3(&d.symmetry, &|i| refl(tpl[i as usize]));
    let xm = gather3(&d.symmetry, &|i| normalise(refl(tpl[i as usize]), norm));
    let b_c = cs + net.b.forward(xs);
    let b_rc = cm + net.b.forward(xm);
    let (m, t) = set.symmetry.affine();
    let m = rows(m.iter().flatten().copied().collect(), 3, device);
    let t = rows(t.to_vec(), 3, device);
    let symmetry = (b_rc - (b_c.matmul(m) + t))
        .square()
        .sum_dim(1)
        .mean()
        .mul_scalar(config.lambda_symmetry);

    // AIM eq. 15: L_K = λ_K ||K(c*)||² on the forehead.
    let forehead = if d.forehead.is_empty() {
        Tensor::<1>::zeros([1], device)
    } else {
        let xf = gather3(&d.forehead, &|i| normalise(tpl[i as usize], norm));
        net.k
            .forward(xf)
            .square()
            .mean()
            .mul_scalar(config.lambda_forehead)
    };
    // Not in the paper, its counterpart: L_J = λ_J ||K(c_J) − 1||² on the skin over the jaw.
    // Without it (and with identity jaw transforms) k = 0 is a stationary point that training
    // does not leave: the correctives take the jaw's motion.
    let skinning = if d.jaw.is_empty() {
        forehead
    } else {
        let xj = gather3(&d.jaw, &|i| normalise(tpl[i as usize], norm));
        forehead
            + net
                .k
                .forward(xj)
                .sub_scalar(1.0)
                .square()
                .mean()
                .mul_scalar(config.lambda_jaw)
    };

    let total = skin.clone()
        + anatomy.clone()
        + thickness_reg.clone()
        + symmetry.clone()
        + skinning.clone();
    let terms = Tensor::cat(
        vec![
            skin,
            anatomy,
            thickness_reg,
            symmetry,
            skinning,
            total.clone(),
        ],
        0,
    )
    .detach();
    (total, terms)
}

/// One optimisation step (the draw of `step`, the objective, backward, Adam at the scheduled
/// rate). Returns the updated model and the detached loss terms ([`TERMS`] order).
pub fn step_once(
    net: AimNet,
    optim: &mut Adam,
    set: &TrainingSet,
    config: &AimConfig,
    norm: [f32; 4],
    step: usize,
    device: &Device,
) -> (AimNet, Tensor<1>) {
    let d = draw(set, config, step);
    let (total, terms) = objective(&net, set, config, norm, &d, device);
    let grads = GradientsParams::from_grads(total.backward(), &net);
    (optim.step(config.lr_at(step), net, grads), terms)
}

/// The jaw transforms a fresh run starts from (`config.jaw_init`), one per expression.
pub fn initial_jaw(set: &TrainingSet, config: &AimConfig) -> Vec<[f32; 9]> {
    let m = set.shapes.len().saturating_sub(1);
    match config.jaw_init {
        JawInit::Identity => vec![IDENTITY_9D; m],
        JawInit::Bones => super::data::jaw_transforms(set)
            .into_iter()
            .map(|t| t.unwrap_or(IDENTITY_9D))
            .collect(),
    }
}

/// A fresh model and Adam optimiser for `set` (for benchmarks and custom loops), its jaw
/// transforms initialised as `config.jaw_init` says.
pub fn init(
    set: &TrainingSet,
    config: &AimConfig,
    backend: Backend,
) -> Result<(AimNet, Adam, Device), TrainError> {
    let device = backend
        .autodiff_device(config.seed)
        .map_err(TrainError::backend)?;
    Ok((
        AimNet::with_jaw(config, &initial_jaw(set, config), &device),
        Adam::new(1e-8),
        device,
    ))
}

/// Trains AIM on `set` (or resumes), checkpointing to `options.checkpoint_dir`.
pub fn train(
    set: &TrainingSet,
    config: &AimConfig,
    options: &TrainOptions,
) -> Result<Trained, TrainError> {
    set.validate()?;
    config.validate()?;
    let device = options
        .backend
        .autodiff_device(config.seed)
        .map_err(TrainError::backend)?;
    let dir = &options.checkpoint_dir;
    crate::io::atomic::create_folder(dir, "checkpoint folder")?;
    // A resumed run replaces the initial model and normalisation with its checkpoint's.
    let (mut net, mut norm) = match (&options.prior, options.resume) {
        (_, true) => (
            AimNet::with_jaw(config, &vec![IDENTITY_9D; set.shapes.len() - 1], &device),
            normalisation(&set.template.positions),
        ),
        (Some(prior), false) => (
            prior.start(
                config,
                &set.names,
                set.units.name(),
                &initial_jaw(set, config),
                &device,
            )?,
            prior.normalisation,
        ),
        (None, false) => (
            AimNet::with_jaw(config, &initial_jaw(set, config), &device),
            normalisation(&set.template.positions),
        ),
    };
    let mut optim = Adam::new(1e-8);
    let mut state = CheckpointState {
        steps_done: 0,
        config: config.clone(),
        history: Vec::new(),
        seconds: 0.0,
        normalisation: norm,
        names: set.names.clone(),
        jaw_pivot: set.jaw_pivot,
        metadata: super::bake::metadata(set, config).map_err(TrainError::Metadata)?,
        files: WeightFiles::default(),
        checks: Vec::new(),
    };
    if let (Some(prior), false) = (&options.prior, options.resume) {
        // Where the run started, for the record (the prior's file name and what it shared).
        state.metadata.push((
            super::prior::METADATA_KEY.into(),
            format!(
                "{} ({} of {} shapes)",
                prior.path().file_name().map_or_else(
                    || prior.path().display().to_string(),
                    |n| n.to_string_lossy().into_owned()
                ),
                prior.shared(&set.names),
                set.names.len() - 1
            ),
        ));
    }
    if options.resume {
        let (n, o, s) = load_checkpoint(dir, net, optim, &device)?;
        check_same_run(dir, &s, config, &set.names)?;
        norm = s.normalisation;
        (net, optim, state) = (n, o, s);
    } else {
        // The template travels with the checkpoint so that `sinew bake` needs nothing else.
        set.template.write(&dir.join("template.obj"))?;
    }

    if let Some(target) = &options.target {
        target.validate()?;
        // A resumed run may already be where its target asks: measured before any step.
        if options.resume
            && state
                .checks
                .last()
                .is_none_or(|c| c.step != state.steps_done)
        {
            let check = measure(&net.clone().valid(), set, norm, state.steps_done);
            state.checks.push(check);
        }
        if options.resume && target_met(target, &state.checks) {
            return Ok(finished(net, state, Ending::AlreadyMet));
        }
    }

    crate::training::interrupt::watch_ctrl_c();
    let bar = crate::training::progress::bar(config.iterations as u64, options.quiet);
    bar.set_position(state.steps_done as u64);
    let start = Instant::now();
    let seconds_before = state.seconds;
    let first = state.steps_done;
    let last = options
        .stop_after
        .map_or(config.iterations, |n| (first + n).min(config.iterations));
    let mut met = false;
    for step in first..last {
        let lr = config.lr_at(step);
        let terms;
        (net, terms) = step_once(net, &mut optim, set, config, norm, step, &device);
        state.steps_done = step + 1;
        if step % 10 == 0 || step + 1 == config.iterations {
            let t = to_vec(terms);
            let mut record = LossRecord {
                step,
                lr,
                terms: [0.0; 6],
            };
            record.terms.copy_from_slice(&t[..6]);
            if !record.terms[5].is_finite() {
                return Err(TrainError::Diverged {
                    step,
                    terms: record.terms,
                });
            }
            bar.set_message(format!(
                "skin {:.3e} anat {:.3e} sym {:.2e} K {:.2e}",
                t[0], t[1], t[3], t[4]
            ));
            state.history.push(record);
        }
        if let Some(target) = &options.target
            && (state.steps_done.is_multiple_of(target.every)
                || state.steps_done == config.iterations)
        {
            let check = measure(&net.clone().valid(), set, norm, state.steps_done);
            if !options.quiet {
                let line = format!(
                    "step {}: mean {:.3} mm, p95 {:.3} mm{}",
                    check.step,
                    check.mean_mm,
                    check.p95_mm,
                    check
                        .jaw_open_degrees
                        .map_or(String::new(), |d| format!(", jawOpen {d:.2}°"))
                );
                // A hidden bar (stderr not a terminal) prints nothing of its own.
                if bar.is_hidden() {
                    eprintln!("{line}");
                } else {
                    bar.println(line);
                }
            }
            state.checks.push(check);
            met = target_met(target, &state.checks);
        }
        bar.inc(1);
        let interrupt = crate::training::interrupt::take_stop_request();
        if state.steps_done.is_multiple_of(config.checkpoint_every)
            || interrupt
            || met
            || state.steps_done == last
        {
            state.seconds = seconds_before + start.elapsed().as_secs_f64();
            save_checkpoint(dir, &net, &optim, &mut state)?;
        }
        if interrupt {
            bar.abandon();
            return Err(TrainError::Interrupted {
                step: state.steps_done,
                dir: dir.clone(),
            });
        }
        if met {
            break;
        }
    }
    bar.finish_and_clear();
    state.seconds = seconds_before + start.elapsed().as_secs_f64();
    let ending = if met { Ending::Target } else { Ending::Steps };
    Ok(finished(net, state, ending))
}

/// Whether the last of `checks` meets `target` (the one before it tells whether the jaw moved).
fn target_met(target: &Target, checks: &[Check]) -> bool {
    match checks {
        [.., previous, last] => target.met(last, Some(previous)),
        [last] => target.met(last, None),
        [] => false,
    }
}

/// The run as it stands, ended by `ending` (complete when the target is met or every step ran).
fn finished(net: AimNet, state: CheckpointState, ending: Ending) -> Trained {
    let complete = ending != Ending::Steps || state.steps_done >= state.config.iterations;
    Trained {
        model: net.valid(),
        state,
        complete,
        ending,
    }
}

/// Writes a checkpoint into `dir`: `model-<step>.bpk`, `optim-<step>.bpk`, then `state.json`
/// naming them with their CRCs, each atomically; an interruption at any moment leaves the
/// previous checkpoint whole ([`crate::training::checkpoint::save`]).
pub fn save_checkpoint(
    dir: &Path,
    net: &AimNet,
    optim: &Adam,
    state: &mut CheckpointState,
) -> Result<(), CheckpointError> {
    let model = net
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "model", e))?;
    let opt = optim
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "optimiser", e))?;
    checkpoint::save(dir, state.steps_done, &model, &opt, state, |s, f| {
        s.files = f;
    })
}

/// Reads a checkpoint folder's `state.json`; the error names the file.
pub fn read_state(dir: &Path) -> Result<CheckpointState, CheckpointError> {
    Ok(checkpoint::read_state(dir, "an AIM checkpoint state")?.0)
}

/// Loads a checkpoint folder into a model of the right shape.
pub fn load_checkpoint(
    dir: &Path,
    net: AimNet,
    optim: Adam,
    device: &Device,
) -> Result<(AimNet, Adam, CheckpointState), CheckpointError> {
    let state = read_state(dir)?;
    let (model_path, optim_path, model, opt) = if state.files.is_legacy() {
        let read = |name: &str| {
            let path = dir.join(name);
            match std::fs::read(&path) {
                Ok(bytes) => Ok((path, bytes)),
                Err(source) => Err(CheckpointError::WeightRead { path, source }),
            }
        };
        let ((model_path, model), (optim_path, opt)) = (read("model.bpk")?, read("optim.bpk")?);
        (model_path, optim_path, model, opt)
    } else {
        state
            .files
            .validate()
            .map_err(|reason| checkpoint::invalid(dir, reason))?;
        (
            dir.join(&state.files.model_file),
            dir.join(&state.files.optim_file),
            state.files.read_model(dir)?,
            state.files.read_optim(dir)?,
        )
    };
    let net = if net.corrective_shapes() + 1 == state.names.len() {
        net
    } else {
        AimNet::new(&state.config, state.names.len(), device)
    };
    let net = checkpoint::load_module(net, model_path, model, "the model")?;
    let optim = optim.load(opt, &net).map_err(|e| CheckpointError::Record {
        path: optim_path,
        detail: e.to_string(),
    })?;
    Ok((net, optim, state))
}

/// Checks that the checkpoint `state` read from `dir` belongs to a run of `config` on the
/// shapes `names`; the error names `state.json` and every difference.
pub fn check_same_run(
    dir: &Path,
    state: &CheckpointState,
    config: &AimConfig,
    names: &[String],
) -> Result<(), CheckpointError> {
    let mut differences = Vec::new();
    checkpoint::serialised_differences("config", &state.config, config, &mut differences).map_err(
        |source| CheckpointError::EncodeState {
            path: dir.join(STATE_FILE),
            source,
        },
    )?;
    if differences.is_empty() && state.config != *config {
        // Configurations that differ yet write the same JSON: named whole.
        differences.push(format!(
            "config: {:?} in the checkpoint, {config:?} now",
            state.config
        ));
    }
    if state.names != names {
        differences.push(format!(
            "shapes: {:?} in the checkpoint, {names:?} now",
            state.names
        ));
    }
    if differences.is_empty() {
        Ok(())
    } else {
        Err(checkpoint::invalid(
            dir,
            InvalidState::OtherRun { differences },
        ))
    }
}

/// Loads only the model and state of a checkpoint (for baking), on an inference device.
pub fn load_model(dir: &Path, backend: Backend) -> Result<(AimNet, CheckpointState), TrainError> {
    let state = read_state(dir)?;
    let device = backend
        .device(state.config.seed)
        .map_err(TrainError::backend)?;
    let net = AimNet::new(&state.config, state.names.len(), &device);
    let (net, _, state) = load_checkpoint(dir, net, Adam::default(), &device)?;
    Ok((net, state))
}

#[cfg(test)]
mod tests;
