//! Checkpoints of S2D-Dec training ([`super::train::train`]): a folder with the decoder's burn
//! record, the Adam state and a `state.json` that says where training stands and what run it
//! belongs to. Every file is written atomically and `state.json` last, naming the weight files
//! it goes with, so an interruption at any moment leaves the previous checkpoint whole.
//!
//! A resumed run must be the same run: `check_same_run` compares the training configuration,
//! the decoder's shape, a fingerprint of the training data and the caller's context (protocol,
//! fold, …) and names every difference.

use std::collections::BTreeMap;
use std::path::Path;

use burn::module::Module;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::decoder::{DecoderConfig, S2dDecoder};
use super::objective::{Sample, TrainConfig};
use crate::training::adam::Adam;
pub use crate::training::checkpoint::STATE_FILE;
use crate::training::checkpoint::{self, CheckpointError, InvalidState, WeightFiles};

/// [`CheckpointState::format`] of an S2D checkpoint.
pub const CHECKPOINT_FORMAT: &str = "sinew-s2d-checkpoint";

/// [`CheckpointState::version`] this build writes and reads.
pub const CHECKPOINT_VERSION: u32 = 1;

/// The fields of `state.json` that identify the run; a resumed run must match them all.
const IDENTITY: [&str; 5] = ["config", "decoder", "vertices", "data", "context"];

/// What identifies the training data: the sample count and a CRC-64/XZ over every sample's
/// input and displacement bits, in training order, then the vertex weights' bits.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DataFingerprint {
    /// Training samples.
    pub samples: usize,
    /// The CRC, 16 hexadecimal digits.
    pub crc: String,
}

impl DataFingerprint {
    /// The fingerprint of `set` trained with `vertex_weights`.
    pub fn of(set: &[Sample], vertex_weights: &[f32]) -> Self {
        let crc = crc::Crc::<u64>::new(&crc::CRC_64_XZ);
        let mut d = crc.digest();
        let mut floats = |v: &[f32]| {
            d.update(&(v.len() as u64).to_le_bytes());
            for x in v {
                d.update(&x.to_bits().to_le_bytes());
            }
        };
        for s in set {
            floats(&s.input);
            floats(&s.displacement);
        }
        floats(vertex_weights);
        Self {
            samples: set.len(),
            crc: format!("{:016x}", d.finalize()),
        }
    }
}

/// A checkpoint folder's `state.json`.
///
/// The two values that feed the results bit for bit (`epoch_loss_total` and `losses`) are written
/// as decimal strings: Rust prints the shortest decimal that reads back to the same bits and
/// reads decimals correctly rounded, whereas serde_json's default number reader may land one
/// unit in the last place off.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointState {
    /// [`CHECKPOINT_FORMAT`].
    pub format: String,
    /// [`CHECKPOINT_VERSION`].
    pub version: u32,
    /// Epochs completed.
    pub epochs_done: usize,
    /// Steps (batches) completed of epoch `epochs_done` when training stopped inside it; 0 at an
    /// epoch boundary.
    pub steps_in_epoch: usize,
    /// Steps completed in all (`epochs_done` × batches per epoch + `steps_in_epoch`).
    pub steps_done: usize,
    /// Σ batch loss × batch size over the steps done of the unfinished epoch (0 at a boundary).
    #[serde(with = "exact")]
    pub epoch_loss_total: f64,
    /// Mean loss of each completed epoch.
    #[serde(with = "exact::list")]
    pub losses: Vec<f32>,
    /// Training seconds so far, over every invocation.
    pub seconds: f64,
    /// The decoder's burn record and the Adam state in this folder, with their CRCs.
    #[serde(flatten)]
    pub files: WeightFiles,
    /// The training configuration.
    pub config: TrainConfig,
    /// The decoder's shape.
    pub decoder: DecoderConfig,
    /// Vertices of each level of the decoder's hierarchy, finest first.
    pub vertices: Vec<usize>,
    /// The training data.
    pub data: DataFingerprint,
    /// What else the caller requires to match (protocol, fold, held-out set, …).
    pub context: BTreeMap<String, String>,
}

impl CheckpointState {
    /// The state before the first step of a run.
    pub fn start(
        config: &TrainConfig,
        decoder: &S2dDecoder,
        data: DataFingerprint,
        context: BTreeMap<String, String>,
    ) -> Self {
        Self {
            format: CHECKPOINT_FORMAT.to_owned(),
            version: CHECKPOINT_VERSION,
            epochs_done: 0,
            steps_in_epoch: 0,
            steps_done: 0,
            epoch_loss_total: 0.0,
            losses: Vec::new(),
            seconds: 0.0,
            files: WeightFiles::default(),
            config: config.clone(),
            decoder: decoder.config.clone(),
            vertices: decoder.vertices.clone(),
            data,
            context,
        }
    }

    /// Whether every configured epoch is done.
    pub fn complete(&self) -> bool {
        self.epochs_done >= self.config.epochs
    }

    /// Checks the fields against each other (not against a run: see [`check_same_run`]).
    fn validate(&self) -> Result<(), InvalidState> {
        if self.format != CHECKPOINT_FORMAT {
            return Err(InvalidState::Format {
                found: self.format.clone(),
                expected: CHECKPOINT_FORMAT,
            });
        }
        if self.version != CHECKPOINT_VERSION {
            return Err(InvalidState::Version {
                found: self.version,
                expected: CHECKPOINT_VERSION,
            });
        }
        if self.epochs_done > self.config.epochs {
            return Err(InvalidState::EpochsDone {
                done: self.epochs_done,
                epochs: self.config.epochs,
            });
        }
        if self.losses.len() != self.epochs_done {
            return Err(InvalidState::Losses {
                losses: self.losses.len(),
                done: self.epochs_done,
            });
        }
        if self.complete() && self.steps_in_epoch != 0 {
            return Err(InvalidState::StepsAfterLast {
                steps: self.steps_in_epoch,
            });
        }
        if !(self.epoch_loss_total.is_finite() && self.losses.iter().all(|l| l.is_finite())) {
            return Err(InvalidState::LossNotFinite);
        }
        self.files.validate()
    }
}

/// Writes a checkpoint of `decoder` and `optim` at `state`'s position into `dir` (created):
/// `model-<steps>.bpk` and `optim-<steps>.bpk`, then `state.json` naming them (its file fields
/// are filled in here), each atomically; then removes the weight files of earlier checkpoints.
pub fn save_checkpoint(
    dir: &Path,
    decoder: &S2dDecoder,
    optim: &Adam,
    state: &mut CheckpointState,
) -> Result<(), CheckpointError> {
    let model = decoder
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "decoder", e))?;
    let opt = optim
        .into_bytes()
        .map_err(|e| checkpoint::serialise_error(dir, "optimiser", e))?;
    checkpoint::save(dir, state.steps_done, &model, &opt, state, |s, f| {
        s.files = f
    })
}

/// Reads and checks `dir/state.json`; also returns it as read, for [`check_same_run`].
///
/// # Errors
/// If the file cannot be read, is not JSON, not an S2D checkpoint state, or inconsistent; the
/// message names the file.
fn read_state_json(dir: &Path) -> Result<(CheckpointState, Value), CheckpointError> {
    let (state, value): (CheckpointState, _) =
        checkpoint::read_state(dir, "an S2D checkpoint state")?;
    state
        .validate()
        .map_err(|reason| checkpoint::invalid(dir, reason))?;
    Ok((state, value))
}

/// Reads and checks a checkpoint folder's `state.json`.
pub fn read_state(dir: &Path) -> Result<CheckpointState, CheckpointError> {
    Ok(read_state_json(dir)?.0)
}

/// Loads the checkpoint in `dir` into `decoder` and `optim` (built as for a fresh run), after
/// checking that it belongs to the run `current` describes (`check_same_run`). Returns them
/// with the checkpoint's state.
pub fn load_checkpoint(
    dir: &Path,
    decoder: S2dDecoder,
    optim: Adam,
    current: &CheckpointState,
) -> Result<(S2dDecoder, Adam, CheckpointState), CheckpointError> {
    let (state, stored) = read_state_json(dir)?;
    check_same_run(dir, &stored, current)?;
    let model_path = dir.join(&state.files.model_file);
    let decoder = checkpoint::load_module(
        decoder,
        model_path,
        state.files.read_model(dir)?,
        "the decoder",
    )?;
    let optim_path = dir.join(&state.files.optim_file);
    let opt = state.files.read_optim(dir)?;
    let optim = optim
        .load(opt, &decoder)
        .map_err(|e| CheckpointError::Record {
            path: optim_path,
            detail: e.to_string(),
        })?;
    Ok((decoder, optim, state))
}

/// Checks that the checkpoint in `dir`, whose `state.json` read as `stored`, belongs to the run
/// described by `current`: the same training configuration, decoder shape, level sizes, data
/// and context. The error names the folder and every field that differs.
///
/// Both sides are compared as serde_json writes and reads them back, so a value that went
/// through the file compares equal to the value it was written from.
fn check_same_run(
    dir: &Path,
    stored: &Value,
    current: &CheckpointState,
) -> Result<(), CheckpointError> {
    let encode = |source| CheckpointError::EncodeState {
        path: dir.join(STATE_FILE),
        source,
    };
    let current: Value = serde_json::to_string(current)
        .and_then(|text| serde_json::from_str(&text))
        .map_err(encode)?;
    let mut diffs = Vec::new();
    for key in IDENTITY {
        checkpoint::differences(key, &stored[key], &current[key], &mut diffs);
    }
    if !diffs.is_empty() {
        return Err(checkpoint::invalid(
            dir,
            InvalidState::OtherRun { differences: diffs },
        ));
    }
    Ok(())
}

/// Serde for numbers that must read back bit for bit: as decimal strings, through `Display` and
/// `FromStr` (see [`CheckpointState`]).
mod exact {
    use std::fmt::Display;
    use std::str::FromStr;

    use serde::de::Error;
    use serde::{Deserialize, Deserializer, Serializer};

    fn parse<T: FromStr<Err: Display>, E: Error>(s: &str) -> Result<T, E> {
        s.parse()
            .map_err(|e| E::custom(format!("{s:?} is not a number: {e}")))
    }

    pub(super) fn serialize<T: Display, S: Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(v)
    }

    pub(super) fn deserialize<'de, T: FromStr<Err: Display>, D: Deserializer<'de>>(
        d: D,
    ) -> Result<T, D::Error> {
        parse(&String::deserialize(d)?)
    }

    /// The same for a list.
    pub(super) mod list {
        use super::*;

        pub(in super::super) fn serialize<T: Display, S: Serializer>(
            v: &[T],
            s: S,
        ) -> Result<S::Ok, S::Error> {
            s.collect_seq(v.iter().map(ToString::to_string))
        }

        pub(in super::super) fn deserialize<'de, T: FromStr<Err: Display>, D: Deserializer<'de>>(
            d: D,
        ) -> Result<Vec<T>, D::Error> {
            Vec::<String>::deserialize(d)?
                .iter()
                .map(|s| parse(s))
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decimal strings give back every bit, including values serde_json's default number reader
    /// may round differently.
    #[test]
    fn exact_numbers_round_trip() {
        #[derive(Serialize, Deserialize)]
        struct T {
            #[serde(with = "exact")]
            a: f64,
            #[serde(with = "exact::list")]
            b: Vec<f32>,
        }
        let a = [
            0.1 + 0.2,
            1.0 / 3.0,
            123_456.789_012_345_67,
            1e-300,
            2.5e300,
        ];
        let b = vec![f32::MIN_POSITIVE, 1.0 / 3.0, 321.654_3, 7e-45];
        for x in a {
            let json = serde_json::to_string(&T { a: x, b: b.clone() }).unwrap();
            let back: T = serde_json::from_str(&json).unwrap();
            assert_eq!(back.a.to_bits(), x.to_bits(), "{json}");
            assert!(
                back.b
                    .iter()
                    .zip(&b)
                    .all(|(p, q)| p.to_bits() == q.to_bits())
            );
        }
        assert!(serde_json::from_str::<T>(r#"{"a": "x", "b": []}"#).is_err());
    }
}
