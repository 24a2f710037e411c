//! Checkpoints of Motion3DGAN training (`sinew train motion`): both networks as one burn
//! record, both Adam states, and a `state.json` naming them with their CRCs (the shared layout of
//! `training::checkpoint`). A resumed run must be the same run: the same settings and training
//! motions; the refusal names every difference.

use std::path::Path;

use burn::module::Module;
use serde::{Deserialize, Serialize};

use super::gan::{Critic, GanConfig, Generator, StepLosses};
use super::train::{Run, TangentData};
use crate::training::adam::AdamRecordError;
use crate::training::checkpoint::{self, CheckpointError, WeightFiles};

/// `format` of a checkpoint's `state.json`.
pub const CHECKPOINT_FORMAT: &str = "sinew-motion-checkpoint";

/// Both networks, as one burn record in a checkpoint.
#[derive(Module, Debug)]
pub struct Networks {
    /// The generator.
    pub generator: Generator,
    /// The critic.
    pub critic: Critic,
}

/// A checkpoint's `state.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointState {
    /// [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// The run's settings (a resumed run must have the same).
    pub config: GanConfig,
    /// CRC of the training tangent vectors (a resumed run must train on the same data).
    pub data_crc: String,
    /// Generator steps done.
    pub steps_done: usize,
    /// Per generator step.
    pub history: Vec<StepLosses>,
    /// The weight files.
    pub files: WeightFiles,
}

/// CRC of the reference point and every tangent vector with its label.
pub fn data_crc(data: &TangentData) -> String {
    let mut bytes = Vec::new();
    for x in &data.p {
        bytes.extend(x.to_bits().to_le_bytes());
    }
    for (t, l) in data.tangents.iter().zip(&data.labels) {
        bytes.extend((*l as u32).to_le_bytes());
        for x in t {
            bytes.extend(x.to_bits().to_le_bytes());
        }
    }
    checkpoint::crc_hex(&bytes)
}

/// Writes the run into the checkpoint folder `dir` (created if missing).
pub fn save_checkpoint(
    dir: &Path,
    run: &Run,
    config: &GanConfig,
    data: &TangentData,
) -> Result<(), CheckpointError> {
    std::fs::create_dir_all(dir).map_err(|source| CheckpointError::CreateDir {
        path: dir.to_owned(),
        source,
    })?;
    let nets = Networks {
        generator: run.generator.clone(),
        critic: run.critic.clone(),
    };
    let model = nets
        .into_record()
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "networks", e))?;
    let mut opt = Vec::new();
    for o in [&run.g_optim, &run.c_optim] {
        let bytes = o
            .into_bytes()
            .map_err(|e| checkpoint::serialise_error(dir, "optimiser", e))?;
        // The generator's Adam state, then the critic's, each after its length.
        opt.extend((bytes.len() as u64).to_le_bytes());
        opt.extend_from_slice(&bytes);
    }
    let mut state = CheckpointState {
        format: CHECKPOINT_FORMAT.to_owned(),
        config: config.clone(),
        data_crc: data_crc(data),
        steps_done: run.step,
        history: run.history.clone(),
        files: WeightFiles::default(),
    };
    checkpoint::save(dir, run.step, &model, &opt, &mut state, |s, f| s.files = f)
}

/// Loads the checkpoint in `dir` into `run` (built as for a fresh run), after checking that it
/// belongs to the same settings and data; errors name the file and every difference.
pub fn load_checkpoint(
    dir: &Path,
    run: Run,
    config: &GanConfig,
    data: &TangentData,
) -> Result<Run, CheckpointError> {
    let (state, _): (CheckpointState, _) =
        checkpoint::read_state(dir, "a Motion3DGAN checkpoint state")?;
    check(dir, &state, config, &data_crc(data))?;
    let model_path = dir.join(&state.files.model_file);
    let networks = Networks {
        generator: run.generator,
        critic: run.critic,
    };
    let nets = checkpoint::load_module(
        networks,
        model_path,
        state.files.read_model(dir)?,
        "the networks",
    )?;
    let optim_path = dir.join(&state.files.optim_file);
    let opt = state.files.read_optim(dir)?;
    let split = |at: usize| -> Result<(Vec<u8>, usize), CheckpointError> {
        let truncated = || CheckpointError::Truncated {
            path: optim_path.clone(),
        };
        let len = opt
            .get(at..at + 8)
            .and_then(|b| b.try_into().ok())
            .map(u64::from_le_bytes)
            .and_then(|len| usize::try_from(len).ok())
            .ok_or_else(truncated)?;
        let end = at
            .checked_add(8)
            .and_then(|start| start.checked_add(len))
            .ok_or_else(truncated)?;
        let bytes = opt.get(at + 8..end).ok_or_else(truncated)?;
        Ok((bytes.to_vec(), end))
    };
    let (g, next) = split(0)?;
    let (c, end) = split(next)?;
    if end != opt.len() {
        return Err(CheckpointError::TrailingBytes { path: optim_path });
    }
    let record = |e: AdamRecordError| CheckpointError::Record {
        path: optim_path.clone(),
        detail: e.to_string(),
    };
    let g_optim = run.g_optim.load(g, &nets.generator).map_err(record)?;
    let c_optim = run.c_optim.load(c, &nets.critic).map_err(record)?;
    Ok(Run {
        generator: nets.generator,
        critic: nets.critic,
        g_optim,
        c_optim,
        step: state.steps_done,
        history: state.history,
        guide: run.guide,
    })
}

/// Checks a read state: its format and file names, that it belongs to this run's settings and
/// training motions (`data_crc`), and that its history fits its steps.
fn check(
    dir: &Path,
    state: &CheckpointState,
    config: &GanConfig,
    data_crc: &str,
) -> Result<(), CheckpointError> {
    let mut other = Vec::new();
    if state.data_crc != data_crc {
        other.push(format!(
            "training motions (data CRC): {} in the checkpoint, {data_crc} now",
            state.data_crc
        ));
    }
    let run = checkpoint::StepRunState {
        format: &state.format,
        files: &state.files,
        config: &state.config,
        steps_done: state.steps_done,
        history: state.history.len(),
    };
    checkpoint::check_step_run(dir, &run, CHECKPOINT_FORMAT, config, config.steps, other)
}
