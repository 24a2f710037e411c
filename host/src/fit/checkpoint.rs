//! A fit's checkpoints: every few hundred steps and on Ctrl-C the fitted variables (codes, F_T,
//! F_W), Adam's state and the step go into `FIT.ckpt/` (the shared checkpoint folder layout of
//! `training::checkpoint`), and `sinew fit --resume FIT.ckpt` continues from there, to the same
//! bits as a fit that was never stopped.

use std::path::Path;

use anyhow::{Context, Result, anyhow, ensure};
use burn::module::Module;
use burn::optim::ModuleOptimizer;
use serde::{Deserialize, Serialize};

use crate::fit::performance::Performance;
use crate::fit::setup::{FitConfig, FitNet};
use crate::training::checkpoint::{self, STATE_FILE, WeightFiles};

/// `format` of a fit checkpoint's `state.json`.
pub const CHECKPOINT_FORMAT: &str = "sinew-fit-checkpoint";

/// Steps between checkpoints.
pub const EVERY: usize = 200;

/// Where a fit keeps its checkpoints and whether it starts from one.
#[derive(Clone, Copy, Debug)]
pub struct Checkpointing<'a> {
    /// The checkpoint folder (`FIT.ckpt/`).
    pub dir: &'a Path,
    /// Continue from the checkpoint in `dir`.
    pub resume: bool,
}

/// A fit checkpoint's `state.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FitState {
    /// [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// The fit's settings; a resumed fit must have the same, its iterations aside.
    pub config: FitConfig,
    /// The actor's content hash, 16 hex digits.
    pub actor: String,
    /// CRC of the performance's meshes and landmark tracks.
    pub target_crc: String,
    /// Adam steps done.
    pub steps_done: usize,
    /// `(step, loss)` so far.
    pub loss_history: Vec<(usize, f64)>,
    /// `(step, mean error in mm)` so far.
    pub error_history: Vec<(usize, f64)>,
    /// Seconds of optimisation so far.
    pub seconds: f64,
    /// The weight files.
    pub files: WeightFiles,
}

/// CRC of a performance's meshes and landmark pixels, in order.
pub fn target_crc(perf: &Performance) -> String {
    let mut bytes = Vec::new();
    for x in perf.frames.iter().flatten().flatten() {
        bytes.extend(x.to_bits().to_le_bytes());
    }
    for x in perf.manifest.landmarks.pixels.iter().flatten().flatten() {
        bytes.extend(x.to_bits().to_le_bytes());
    }
    checkpoint::crc_hex(&bytes)
}

/// Writes `net`, `optim` and `state` into `dir` (created if missing).
pub fn save(dir: &Path, net: &FitNet, optim: &ModuleOptimizer, mut state: FitState) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let model = net
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| anyhow!("{}: cannot serialise the fit: {e:?}", dir.display()))?;
    let opt = optim
        .into_bytes()
        .map_err(|e| anyhow!("{}: cannot serialise the optimiser: {e:?}", dir.display()))?;
    let steps = state.steps_done;
    checkpoint::save(dir, steps, &model, &opt, &mut state, |s, f| s.files = f)
}

/// Loads the checkpoint in `dir` into `net` and `optim` (built as for a fresh fit), after
/// checking it belongs to `expected`'s settings (iterations aside), actor and performance.
pub fn load(
    dir: &Path,
    net: FitNet,
    optim: ModuleOptimizer,
    expected: &FitState,
) -> Result<(FitNet, ModuleOptimizer, FitState)> {
    let path = dir.join(STATE_FILE);
    let state: FitState = serde_json::from_value(checkpoint::read_state_value(dir)?)
        .with_context(|| format!("{}: not a fit checkpoint state", path.display()))?;
    ensure!(
        state.format == CHECKPOINT_FORMAT,
        "{}: format {:?}, expected {CHECKPOINT_FORMAT:?}",
        path.display(),
        state.format
    );
    state
        .files
        .validate()
        .with_context(|| format!("{}", path.display()))?;
    let same = FitConfig {
        iterations: expected.config.iterations,
        ..state.config.clone()
    };
    ensure!(
        same == expected.config,
        "{}: the checkpoint was fitted with other settings ({:?}) than this fit's ({:?})",
        path.display(),
        state.config,
        expected.config
    );
    ensure!(
        state.actor == expected.actor,
        "{}: the checkpoint fits actor {}, this fit actor {}",
        path.display(),
        state.actor,
        expected.actor
    );
    ensure!(
        state.target_crc == expected.target_crc,
        "{}: the checkpoint fits another performance (CRC {} here {})",
        path.display(),
        state.target_crc,
        expected.target_crc
    );
    ensure!(
        state.steps_done <= expected.config.iterations,
        "{}: {} steps done, more than the {} asked for",
        path.display(),
        state.steps_done,
        expected.config.iterations
    );
    let model_path = dir.join(&state.files.model_file);
    let record = burn::store::ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(
        state.files.read_model(dir)?,
    ))
    .map_err(|e| anyhow!("{}: invalid: {e:?}", model_path.display()))?;
    let net = net
        .try_load_record(record)
        .map_err(|e| anyhow!("{}: does not fit this fit: {e:?}", model_path.display()))?;
    let optim_path = dir.join(&state.files.optim_file);
    let optim = optim
        .from_bytes(burn::tensor::Bytes::from_bytes_vec(
            state.files.read_optim(dir)?,
        ))
        .map_err(|e| anyhow!("{}: invalid: {e:?}", optim_path.display()))?;
    Ok((net, optim, state))
}
