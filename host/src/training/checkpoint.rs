//! The files of a training checkpoint folder, shared by every training (AIM, S2D, the driver,
//! Motion3DGAN): the model's burn record and the optimiser's state, named by the step they were
//! taken at, and a `state.json` written after them that names them with their CRCs. Every file
//! is written atomically and `state.json` last, so an interruption at any moment leaves the
//! previous checkpoint whole; earlier weight files are removed only once the new `state.json` is
//! in place.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;

/// The name of the state file inside a checkpoint folder.
pub const STATE_FILE: &str = "state.json";

/// A checkpoint that could not be written, read or resumed, always with the file or folder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckpointError {
    /// `state.json` could not be read.
    #[error(
        "{}: cannot read the checkpoint state (is {} a checkpoint folder?)",
        path.display(),
        path.parent().unwrap_or(Path::new("")).display()
    )]
    StateRead {
        /// The state file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// `state.json` is not JSON.
    #[error("{}: not valid JSON (truncated?)", path.display())]
    StateJson {
        /// The state file.
        path: PathBuf,
        /// What the parser said.
        #[source]
        source: serde_json::Error,
    },
    /// `state.json` is JSON of another shape than the trainer's state.
    #[error("{}: not {what}", path.display())]
    NotState {
        /// The state file.
        path: PathBuf,
        /// What it should be, e.g. "an S2D checkpoint state".
        what: &'static str,
        /// What the parser said.
        #[source]
        source: serde_json::Error,
    },
    /// `state.json` reads, but breaks a rule or belongs to another run.
    #[error("{}: invalid checkpoint state", path.display())]
    Invalid {
        /// The state file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: InvalidState,
    },
    /// A weight file named by `state.json` could not be read.
    #[error("{}: cannot read this file named by {STATE_FILE}", path.display())]
    WeightRead {
        /// The weight file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A weight file whose bytes do not match the CRC that `state.json` records.
    #[error(
        "{}: its CRC differs from the one {STATE_FILE} records (the file is damaged)",
        path.display()
    )]
    Crc {
        /// The weight file.
        path: PathBuf,
    },
    /// A weight file that burn cannot read as a record.
    #[error("{}: invalid: {detail}", path.display())]
    Record {
        /// The weight file.
        path: PathBuf,
        /// What burn said.
        detail: String,
    },
    /// A record that does not fit the model or optimiser it is loaded into.
    #[error("{}: does not fit {what}: {detail}", path.display())]
    Mismatch {
        /// The weight file.
        path: PathBuf,
        /// What it was loaded into, e.g. "the decoder".
        what: &'static str,
        /// What burn said.
        detail: String,
    },
    /// The model or optimiser could not be serialised.
    #[error("{}: cannot serialise the {what}: {detail}", path.display())]
    Serialise {
        /// The checkpoint folder.
        path: PathBuf,
        /// What, e.g. "decoder" or "optimiser".
        what: &'static str,
        /// What burn said.
        detail: String,
    },
    /// The state could not be written as JSON.
    #[error("{}: cannot encode the checkpoint state", path.display())]
    EncodeState {
        /// The state file.
        path: PathBuf,
        /// What the encoder said.
        #[source]
        source: serde_json::Error,
    },
    /// The checkpoint folder could not be created.
    #[error("{}: cannot create", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A weight file that ends before what it holds does.
    #[error("{}: truncated", path.display())]
    Truncated {
        /// The weight file.
        path: PathBuf,
    },
    /// A weight file with bytes after what it holds.
    #[error("{}: trailing bytes after the last record", path.display())]
    TrailingBytes {
        /// The weight file.
        path: PathBuf,
    },
    /// A file could not be written (the message names it).
    #[error(transparent)]
    Write(crate::io::atomic::AtomicWriteError),
}

/// A rule of a checkpoint state that it breaks, or the run it does not belong to.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidState {
    /// Another trainer's checkpoint.
    #[error("format {found:?}, expected {expected:?}")]
    Format {
        /// The state's format name.
        found: String,
        /// This trainer's.
        expected: &'static str,
    },
    /// A state of another version.
    #[error("version {found}, this build reads {expected}")]
    Version {
        /// The state's version.
        found: u32,
        /// This build's.
        expected: u32,
    },
    /// A weight file name that is not `model-<n>.bpk` / `optim-<n>.bpk`.
    #[error("{what} file {name:?} is not a checkpoint file name")]
    FileName {
        /// "model" or "optimiser".
        what: &'static str,
        /// The name.
        name: String,
    },
    /// More epochs done than the run has.
    #[error("{done} epochs done of {epochs}")]
    EpochsDone {
        /// Epochs done.
        done: usize,
        /// Epochs of the run.
        epochs: usize,
    },
    /// A loss history of another length than the epochs done.
    #[error("{losses} epoch losses for {done} epochs done")]
    Losses {
        /// Losses recorded.
        losses: usize,
        /// Epochs done.
        done: usize,
    },
    /// Steps of an epoch beyond the last.
    #[error("every epoch is done but {steps} steps of another are recorded")]
    StepsAfterLast {
        /// The steps.
        steps: usize,
    },
    /// A recorded loss that is NaN or infinite.
    #[error("a loss is not finite")]
    LossNotFinite,
    /// More steps done than the run asks for.
    #[error("{done} steps done, more than the {asked} asked for")]
    StepsDone {
        /// Steps done.
        done: usize,
        /// Steps asked for.
        asked: usize,
    },
    /// A step history of another length than the steps done.
    #[error("{recorded} steps recorded for {done} steps done")]
    History {
        /// Steps recorded.
        recorded: usize,
        /// Steps done.
        done: usize,
    },
    /// The checkpoint belongs to another run; each entry is `field: A in the checkpoint, B now`.
    #[error(
        "the checkpoint belongs to another run ({}); resume with the same arguments and data, or \
         train without --resume to start over",
        differences.join("; ")
    )]
    OtherRun {
        /// The fields that differ.
        differences: Vec<String>,
    },
}

/// The weight files a `state.json` goes with. Missing fields read as empty (AIM checkpoints
/// written before these fields existed: see [`WeightFiles::is_legacy`]).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default)]
pub struct WeightFiles {
    /// The model's burn record in this folder.
    pub model_file: String,
    /// CRC-64/XZ of `model_file`, 16 hexadecimal digits.
    pub model_crc: String,
    /// The optimiser's state in this folder.
    pub optim_file: String,
    /// CRC-64/XZ of `optim_file`, 16 hexadecimal digits.
    pub optim_crc: String,
}

impl WeightFiles {
    /// Whether the state names no files: an AIM checkpoint from before this scheme, whose
    /// weights are `model.bpk` and `optim.bpk` without CRCs.
    pub fn is_legacy(&self) -> bool {
        self.model_file.is_empty() && self.optim_file.is_empty()
    }

    /// Checks that both names are checkpoint weight-file names (nothing else is ever read or
    /// deleted through them).
    pub fn validate(&self) -> Result<(), InvalidState> {
        for (what, name) in [("model", &self.model_file), ("optimiser", &self.optim_file)] {
            if !is_weight_file_name(name) {
                return Err(InvalidState::FileName {
                    what,
                    name: name.clone(),
                });
            }
        }
        Ok(())
    }

    /// Reads the model's bytes and checks them against their CRC.
    pub fn read_model(&self, dir: &Path) -> Result<Vec<u8>, CheckpointError> {
        read_checked(dir, &self.model_file, &self.model_crc)
    }

    /// Reads the optimiser's bytes and checks them against their CRC.
    pub fn read_optim(&self, dir: &Path) -> Result<Vec<u8>, CheckpointError> {
        read_checked(dir, &self.optim_file, &self.optim_crc)
    }
}

/// `model-<n>.bpk` / `optim-<n>.bpk`: the only names a checkpoint reads or deletes.
pub fn is_weight_file_name(name: &str) -> bool {
    ["model-", "optim-"].iter().any(|prefix| {
        name.strip_prefix(prefix)
            .and_then(|rest| rest.strip_suffix(".bpk"))
            .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
    })
}

/// CRC-64/XZ of `bytes`, 16 hexadecimal digits.
pub fn crc_hex(bytes: &[u8]) -> String {
    format!(
        "{:016x}",
        crc::Crc::<u64>::new(&crc::CRC_64_XZ).checksum(bytes)
    )
}

/// Writes a checkpoint into `dir` (which must exist): `model-<steps>.bpk`, `optim-<steps>.bpk`,
/// then `state.json` from `state`, which receives the files' names and CRCs through
/// `set_files` before it is serialised; then removes the weight files of earlier checkpoints.
pub fn save<S: Serialize>(
    dir: &Path,
    steps: usize,
    model: &[u8],
    optim: &[u8],
    state: &mut S,
    set_files: impl FnOnce(&mut S, WeightFiles),
) -> Result<(), CheckpointError> {
    let files = WeightFiles {
        model_file: format!("model-{steps}.bpk"),
        model_crc: crc_hex(model),
        optim_file: format!("optim-{steps}.bpk"),
        optim_crc: crc_hex(optim),
    };
    crate::io::atomic::write(&dir.join(&files.model_file), model)
        .map_err(CheckpointError::Write)?;
    crate::io::atomic::write(&dir.join(&files.optim_file), optim)
        .map_err(CheckpointError::Write)?;
    let keep = files.clone();
    set_files(state, files);
    // state.json last: until it is in place, the previous one still names whole files.
    let path = dir.join(STATE_FILE);
    let json =
        serde_json::to_string_pretty(state).map_err(|source| CheckpointError::EncodeState {
            path: path.clone(),
            source,
        })?;
    crate::io::atomic::write(&path, json.as_bytes()).map_err(CheckpointError::Write)?;
    // The earlier checkpoints' weights; a file that cannot be removed only costs disk space.
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if is_weight_file_name(&name) && name != keep.model_file && name != keep.optim_file {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    Ok(())
}

/// Reads `dir/state.json` as JSON; the error names the file.
pub fn read_state_value(dir: &Path) -> Result<serde_json::Value, CheckpointError> {
    let path = dir.join(STATE_FILE);
    let bytes = match std::fs::read(&path) {
        Ok(bytes) => bytes,
        Err(source) => return Err(CheckpointError::StateRead { path, source }),
    };
    serde_json::from_slice(&bytes).map_err(|source| CheckpointError::StateJson { path, source })
}

/// Reads `dir/state.json` as the trainer's state `S`; `what` names it in errors (e.g. "an S2D
/// checkpoint state").
pub fn read_state<S: serde::de::DeserializeOwned>(
    dir: &Path,
    what: &'static str,
) -> Result<(S, serde_json::Value), CheckpointError> {
    let value = read_state_value(dir)?;
    match serde_json::from_value(value.clone()) {
        Ok(state) => Ok((state, value)),
        Err(source) => Err(CheckpointError::NotState {
            path: dir.join(STATE_FILE),
            what,
            source,
        }),
    }
}

/// `reason` as the error of `dir/state.json`.
pub fn invalid(dir: &Path, reason: InvalidState) -> CheckpointError {
    CheckpointError::Invalid {
        path: dir.join(STATE_FILE),
        source: reason,
    }
}

/// What a run counted in steps (the driver's, Motion3DGAN's) wrote about itself in its
/// `state.json`, for [`check_step_run`].
#[derive(Debug)]
pub struct StepRunState<'a, C> {
    /// The state's format string.
    pub format: &'a str,
    /// The weight files it names.
    pub files: &'a WeightFiles,
    /// The settings it was made with.
    pub config: &'a C,
    /// Steps done.
    pub steps_done: usize,
    /// Entries in its loss history.
    pub history: usize,
}

/// The checks a step-counted run's checkpoint in `dir` passes before it is loaded: the format
/// `expected`, valid file names, the settings `config` but for their `steps` entry, which a
/// resumed run may raise to train on (a difference that writes the same JSON is named whole),
/// no `other` difference (the run's own comparisons of what it trains on, e.g. a data CRC), one
/// history entry per step done, and no more steps done than `steps`, the steps this run asks
/// for. Every difference is named at once. Only for runs whose steps depend on the seed and the
/// step alone, not on the number of steps, so that a run raised from a checkpoint is the longer
/// run.
pub fn check_step_run<C: Serialize + PartialEq + std::fmt::Debug>(
    dir: &Path,
    state: &StepRunState<'_, C>,
    expected: &'static str,
    config: &C,
    steps: usize,
    other: Vec<String>,
) -> Result<(), CheckpointError> {
    let invalid = |reason| invalid(dir, reason);
    if state.format != expected {
        return Err(invalid(InvalidState::Format {
            found: state.format.to_owned(),
            expected,
        }));
    }
    state.files.validate().map_err(invalid)?;
    let encode = |c: &C| {
        serde_json::to_value(c).map_err(|source| CheckpointError::EncodeState {
            path: dir.join(STATE_FILE),
            source,
        })
    };
    let (mut stored, mut current) = (encode(state.config)?, encode(config)?);
    let take_steps = |v: &mut Value| v.as_object_mut().and_then(|o| o.remove("steps"));
    let same_steps = take_steps(&mut stored) == take_steps(&mut current);
    let mut differences = Vec::new();
    self::differences("settings", &stored, &current, &mut differences);
    if differences.is_empty() && same_steps && state.config != config {
        // Settings that differ yet write the same JSON: named whole.
        differences.push(format!(
            "settings: {:?} in the checkpoint, {config:?} now",
            state.config
        ));
    }
    differences.extend(other);
    if !differences.is_empty() {
        return Err(invalid(InvalidState::OtherRun { differences }));
    }
    if state.history != state.steps_done {
        return Err(invalid(InvalidState::History {
            recorded: state.history,
            done: state.steps_done,
        }));
    }
    if state.steps_done > steps {
        return Err(invalid(InvalidState::StepsDone {
            done: state.steps_done,
            asked: steps,
        }));
    }
    Ok(())
}

/// Reads a checkpoint file named by `state.json` and checks it against its CRC.
fn read_checked(dir: &Path, name: &str, crc: &str) -> Result<Vec<u8>, CheckpointError> {
    let path = dir.join(name);
    let bytes = match std::fs::read(&path) {
        Ok(bytes) => bytes,
        Err(source) => return Err(CheckpointError::WeightRead { path, source }),
    };
    if crc_hex(&bytes) != crc {
        return Err(CheckpointError::Crc { path });
    }
    Ok(bytes)
}

/// Appends `path: A in the checkpoint, B now` for every leaf where `a` (the checkpoint's) and
/// `b` (this run's) differ: the entries of [`InvalidState::OtherRun`].
pub fn differences(path: &str, a: &Value, b: &Value, out: &mut Vec<String>) {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            for k in keys {
                differences(
                    &format!("{path}.{k}"),
                    x.get(k).unwrap_or(&Value::Null),
                    y.get(k).unwrap_or(&Value::Null),
                    out,
                );
            }
        }
        _ if a != b => out.push(format!(
            "{path}: {} in the checkpoint, {} now",
            shorten(a),
            shorten(b)
        )),
        _ => {}
    }
}

/// A value's JSON, cut to 60 characters.
fn shorten(v: &Value) -> String {
    let s = if v.is_null() {
        "nothing".to_owned()
    } else {
        v.to_string()
    };
    if s.chars().count() > 60 {
        format!("{}…", s.chars().take(59).collect::<String>())
    } else {
        s
    }
}

/// [`differences`] of two values as serde_json writes them, under `path`. A value read back from
/// `state.json` writes as the value it was written from, so only real differences are named.
pub fn serialised_differences<T: Serialize>(
    path: &str,
    stored: &T,
    current: &T,
    out: &mut Vec<String>,
) -> Result<(), serde_json::Error> {
    differences(
        path,
        &serde_json::to_value(stored)?,
        &serde_json::to_value(current)?,
        out,
    );
    Ok(())
}

/// The error of a `what` (e.g. "decoder") that burn could not serialise for the checkpoint in
/// `dir`.
pub fn serialise_error(
    dir: &Path,
    what: &'static str,
    e: impl std::fmt::Display,
) -> CheckpointError {
    CheckpointError::Serialise {
        path: dir.to_owned(),
        what,
        detail: e.to_string(),
    }
}

/// Reads the burn record in the weight file `path` from its `bytes` (checked against their CRC).
pub fn record_from_bytes(
    path: &Path,
    bytes: Vec<u8>,
) -> Result<burn::store::ModuleRecord, CheckpointError> {
    burn::store::ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(bytes)).map_err(|e| {
        CheckpointError::Record {
            path: path.to_owned(),
            detail: e.to_string(),
        }
    })
}

/// Loads the burn record in the weight file `path` (its `bytes`, checked against their CRC)
/// into `module`, whose shape must match it ([`CheckpointError::Mismatch`] names `what` it was
/// loaded into otherwise).
pub fn load_module<M: burn::module::Module>(
    module: M,
    path: PathBuf,
    bytes: Vec<u8>,
    what: &'static str,
) -> Result<M, CheckpointError> {
    let record = record_from_bytes(&path, bytes)?;
    module
        .try_load_record(record)
        .map_err(|e| CheckpointError::Mismatch {
            path,
            what,
            detail: e.to_string(),
        })
}

/// The checkpoint folder that belongs to a model path: `MODEL.ckpt/` beside it.
pub fn checkpoint_dir_for(model: &Path) -> PathBuf {
    model.with_extension("ckpt")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weight_file_names() {
        assert!(is_weight_file_name("model-12.bpk"));
        assert!(is_weight_file_name("optim-0.bpk"));
        for bad in [
            "model-.bpk",
            "model-1.bpk.tmp",
            "../model-1.bpk",
            "model-1/../x.bpk",
            "state.json",
            "model-1a.bpk",
        ] {
            assert!(!is_weight_file_name(bad), "{bad}");
        }
    }

    #[derive(Serialize)]
    struct State {
        step: usize,
        #[serde(flatten)]
        files: WeightFiles,
    }

    #[test]
    fn a_new_checkpoint_replaces_the_old_files_and_damage_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let mut state = State {
            step: 1,
            files: WeightFiles::default(),
        };
        save(dir.path(), 1, b"m1", b"o1", &mut state, |s, f| s.files = f).unwrap();
        state.step = 2;
        save(dir.path(), 2, b"m2", b"o2", &mut state, |s, f| s.files = f).unwrap();
        let mut names: Vec<String> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["model-2.bpk", "optim-2.bpk", "state.json"]);
        let value = read_state_value(dir.path()).unwrap();
        let files: WeightFiles = serde_json::from_value(value.clone()).unwrap();
        files.validate().unwrap();
        assert_eq!(value["step"], 2);
        assert_eq!(files.read_model(dir.path()).unwrap(), b"m2");
        assert_eq!(files.read_optim(dir.path()).unwrap(), b"o2");
        std::fs::write(dir.path().join("model-2.bpk"), b"m3").unwrap();
        let e = files.read_model(dir.path()).unwrap_err();
        assert!(
            matches!(&e, CheckpointError::Crc { path } if path.ends_with("model-2.bpk")),
            "{e:?}"
        );
        assert!(e.to_string().contains("model-2.bpk"), "{e}");
        std::fs::remove_file(dir.path().join("optim-2.bpk")).unwrap();
        let e = files.read_optim(dir.path()).unwrap_err();
        assert!(
            matches!(&e, CheckpointError::WeightRead { path, .. } if path.ends_with("optim-2.bpk")),
            "{e:?}"
        );
        let bad = WeightFiles {
            model_file: "../model-2.bpk".into(),
            ..files
        };
        assert!(matches!(
            bad.validate(),
            Err(InvalidState::FileName { what: "model", .. })
        ));
        std::fs::write(dir.path().join(STATE_FILE), b"{\"step\": 2, \"mo").unwrap();
        let e = read_state_value(dir.path()).unwrap_err();
        assert!(
            matches!(&e, CheckpointError::StateJson { path, .. } if path.ends_with(STATE_FILE)),
            "{e:?}"
        );
        let e = read_state_value(&dir.path().join("nowhere")).unwrap_err();
        assert!(matches!(e, CheckpointError::StateRead { .. }), "{e:?}");
        assert!(e.to_string().contains("nowhere"), "{e}");
    }

    #[test]
    fn differences_name_each_field() {
        let a: Value = serde_json::json!({"epochs": 3, "lr": 0.001, "filters": [4, 2]});
        let b: Value = serde_json::json!({"epochs": 4, "lr": 0.001, "filters": [4, 3], "x": 1});
        let mut out = Vec::new();
        differences("config", &a, &b, &mut out);
        assert_eq!(
            out,
            [
                "config.epochs: 3 in the checkpoint, 4 now",
                "config.filters: [4,2] in the checkpoint, [4,3] now",
                "config.x: nothing in the checkpoint, 1 now",
            ]
        );
    }
}
