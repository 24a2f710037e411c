//! A fit's checkpoints: every few hundred steps and on Ctrl-C the fitted variables (codes, F_T,
//! F_W), Adam's state and the step go into `FIT.ckpt/` (the shared checkpoint folder layout of
//! `training::checkpoint`), and `sinew fit --resume FIT.ckpt` continues from there, to the same
//! bits as a fit that was never stopped.

use std::path::Path;

use burn::module::Module;
use serde::{Deserialize, Serialize};

use crate::fit::setup::{FitConfig, FitNet};
use crate::io::performance::Performance;
use crate::training::adam::Adam;
use crate::training::checkpoint::{self, CheckpointError, InvalidState, WeightFiles};

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
pub fn save(
    dir: &Path,
    net: &FitNet,
    optim: &Adam,
    mut state: FitState,
) -> Result<(), CheckpointError> {
    std::fs::create_dir_all(dir).map_err(|source| CheckpointError::CreateDir {
        path: dir.to_owned(),
        source,
    })?;
    let model = net
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "fit", e))?;
    let opt = optim
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "optimiser", e))?;
    let steps = state.steps_done;
    checkpoint::save(dir, steps, &model, &opt, &mut state, |s, f| s.files = f)
}

/// Loads the checkpoint in `dir` into `net` and `optim` (built as for a fresh fit), after
/// checking it belongs to `expected`'s settings (iterations aside), actor and performance.
pub fn load(
    dir: &Path,
    net: FitNet,
    optim: Adam,
    expected: &FitState,
) -> Result<(FitNet, Adam, FitState), CheckpointError> {
    let (state, _): (FitState, _) = checkpoint::read_state(dir, "a fit checkpoint state")?;
    check(&state, expected).map_err(|reason| checkpoint::invalid(dir, reason))?;
    let model_path = dir.join(&state.files.model_file);
    let net = checkpoint::load_module(net, model_path, state.files.read_model(dir)?, "this fit")?;
    let optim_path = dir.join(&state.files.optim_file);
    let optim = optim
        .load(state.files.read_optim(dir)?, &net)
        .map_err(|e| CheckpointError::Record {
            path: optim_path,
            detail: e.to_string(),
        })?;
    Ok((net, optim, state))
}

/// Checks a read state: its format and file names, and that it belongs to `expected`'s
/// settings (iterations aside), actor and performance.
fn check(state: &FitState, expected: &FitState) -> Result<(), InvalidState> {
    if state.format != CHECKPOINT_FORMAT {
        return Err(InvalidState::Format {
            found: state.format.clone(),
            expected: CHECKPOINT_FORMAT,
        });
    }
    state.files.validate()?;
    let same = FitConfig {
        iterations: expected.config.iterations,
        ..state.config.clone()
    };
    let mut differences = Vec::new();
    if same != expected.config {
        // Named field by field ("settings.lambda: 0.1 in the checkpoint, 0.2 now").
        if let (Ok(a), Ok(b)) = (
            serde_json::to_value(&same),
            serde_json::to_value(&expected.config),
        ) {
            checkpoint::differences("settings", &a, &b, &mut differences);
        }
        if differences.is_empty() {
            differences.push("settings: others in the checkpoint than now".into());
        }
    }
    if state.actor != expected.actor {
        differences.push(format!(
            "actor: {} in the checkpoint, {} now",
            state.actor, expected.actor
        ));
    }
    if state.target_crc != expected.target_crc {
        differences.push(format!(
            "performance CRC: {} in the checkpoint, {} now",
            state.target_crc, expected.target_crc
        ));
    }
    if !differences.is_empty() {
        return Err(InvalidState::OtherRun { differences });
    }
    if state.steps_done > expected.config.iterations {
        return Err(InvalidState::StepsDone {
            done: state.steps_done,
            asked: expected.config.iterations,
        });
    }
    Ok(())
}
