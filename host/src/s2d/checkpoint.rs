//! Checkpoints of S2D-Dec training ([`super::train::train`]): a folder with the decoder's burn
//! record, the Adam state and a `state.json` that says where training stands and what run it
//! belongs to. Every file is written atomically and `state.json` last, naming the weight files
//! it goes with, so an interruption at any moment leaves the previous checkpoint whole.
//!
//! A resumed run must be the same run: [`check_same_run`] compares the training configuration,
//! the decoder's shape, a fingerprint of the training data and the caller's context (protocol,
//! fold, …) and names every difference.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use anyhow::{Context, Result, bail, ensure};
use burn::module::Module;
use burn::optim::ModuleOptimizer;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use super::decoder::{DecoderConfig, S2dDecoder};
use super::train::{Sample, TrainConfig};

/// The name of the state file inside a checkpoint folder.
pub const STATE_FILE: &str = "state.json";

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
    /// The decoder's burn record in this folder.
    pub model_file: String,
    /// CRC-64/XZ of `model_file`, 16 hexadecimal digits.
    pub model_crc: String,
    /// The Adam state in this folder.
    pub optim_file: String,
    /// CRC-64/XZ of `optim_file`, 16 hexadecimal digits.
    pub optim_crc: String,
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
            model_file: String::new(),
            model_crc: String::new(),
            optim_file: String::new(),
            optim_crc: String::new(),
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
    fn validate(&self) -> Result<()> {
        ensure!(
            self.format == CHECKPOINT_FORMAT,
            "format {:?}, expected {CHECKPOINT_FORMAT:?} (not an S2D training checkpoint)",
            self.format
        );
        ensure!(
            self.version == CHECKPOINT_VERSION,
            "version {}, this build reads {CHECKPOINT_VERSION}",
            self.version
        );
        ensure!(
            self.epochs_done <= self.config.epochs,
            "{} epochs done of {}",
            self.epochs_done,
            self.config.epochs
        );
        ensure!(
            self.losses.len() == self.epochs_done,
            "{} epoch losses for {} epochs done",
            self.losses.len(),
            self.epochs_done
        );
        ensure!(
            !self.complete() || self.steps_in_epoch == 0,
            "every epoch is done but {} steps of another are recorded",
            self.steps_in_epoch
        );
        ensure!(
            self.epoch_loss_total.is_finite() && self.losses.iter().all(|l| l.is_finite()),
            "a loss is not finite"
        );
        for (what, name) in [("model", &self.model_file), ("optimiser", &self.optim_file)] {
            ensure!(
                is_weight_file_name(name),
                "{what} file {name:?} is not a checkpoint file name"
            );
        }
        Ok(())
    }
}

/// `model-<n>.bpk` / `optim-<n>.bpk`: the only names a checkpoint reads or deletes.
fn is_weight_file_name(name: &str) -> bool {
    ["model-", "optim-"].iter().any(|prefix| {
        name.strip_prefix(prefix)
            .and_then(|rest| rest.strip_suffix(".bpk"))
            .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
    })
}

fn crc_hex(bytes: &[u8]) -> String {
    format!(
        "{:016x}",
        crc::Crc::<u64>::new(&crc::CRC_64_XZ).checksum(bytes)
    )
}

/// Writes a checkpoint of `decoder` and `optim` at `state`'s position into `dir` (created):
/// `model-<steps>.bpk` and `optim-<steps>.bpk`, then `state.json` naming them (its file fields
/// are filled in here), each atomically; then removes the weight files of earlier checkpoints.
pub fn save_checkpoint(
    dir: &Path,
    decoder: &S2dDecoder,
    optim: &ModuleOptimizer,
    state: &mut CheckpointState,
) -> Result<()> {
    let model =
        decoder.clone().into_record().into_bytes().map_err(|e| {
            anyhow::anyhow!("{}: cannot serialise the decoder: {e:?}", dir.display())
        })?;
    let opt = optim
        .into_bytes()
        .map_err(|e| anyhow::anyhow!("{}: cannot serialise the optimiser: {e:?}", dir.display()))?;
    state.model_file = format!("model-{}.bpk", state.steps_done);
    state.optim_file = format!("optim-{}.bpk", state.steps_done);
    state.model_crc = crc_hex(&model);
    state.optim_crc = crc_hex(&opt);
    crate::atomic::write(&dir.join(&state.model_file), &model)?;
    crate::atomic::write(&dir.join(&state.optim_file), &opt)?;
    // state.json last: until it is in place, the previous one still names whole files.
    crate::atomic::write(
        &dir.join(STATE_FILE),
        serde_json::to_string_pretty(state)?.as_bytes(),
    )?;
    // The earlier checkpoints' weights; a file that cannot be removed only costs disk space.
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if is_weight_file_name(&name) && name != state.model_file && name != state.optim_file {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
    Ok(())
}

/// Reads and checks `dir/state.json`; also returns it as read, for [`check_same_run`].
///
/// # Errors
/// If the file cannot be read, is not JSON, not an S2D checkpoint state, or inconsistent; the
/// message names the file.
fn read_state_json(dir: &Path) -> Result<(CheckpointState, Value)> {
    let path = dir.join(STATE_FILE);
    let bytes = std::fs::read(&path).with_context(|| {
        format!(
            "{}: cannot read the checkpoint state (is {} a checkpoint folder?)",
            path.display(),
            dir.display()
        )
    })?;
    let value: Value = serde_json::from_slice(&bytes)
        .with_context(|| format!("{}: not valid JSON (truncated?)", path.display()))?;
    let state: CheckpointState = serde_json::from_value(value.clone())
        .with_context(|| format!("{}: not an S2D checkpoint state", path.display()))?;
    state
        .validate()
        .with_context(|| format!("{}: invalid checkpoint state", path.display()))?;
    Ok((state, value))
}

/// Reads and checks a checkpoint folder's `state.json`.
pub fn read_state(dir: &Path) -> Result<CheckpointState> {
    Ok(read_state_json(dir)?.0)
}

/// Reads a checkpoint file named by `state.json` and checks it against its CRC.
fn read_weights(dir: &Path, name: &str, crc: &str) -> Result<Vec<u8>> {
    let path = dir.join(name);
    let bytes = std::fs::read(&path).with_context(|| {
        format!(
            "{}: cannot read this file named by {STATE_FILE}",
            path.display()
        )
    })?;
    ensure!(
        crc_hex(&bytes) == crc,
        "{}: its CRC differs from the one {STATE_FILE} records (the file is damaged)",
        path.display()
    );
    Ok(bytes)
}

/// Loads the checkpoint in `dir` into `decoder` and `optim` (built as for a fresh run), after
/// checking that it belongs to the run `current` describes ([`check_same_run`]). Returns them
/// with the checkpoint's state.
pub fn load_checkpoint(
    dir: &Path,
    decoder: S2dDecoder,
    optim: ModuleOptimizer,
    current: &CheckpointState,
) -> Result<(S2dDecoder, ModuleOptimizer, CheckpointState)> {
    let (state, stored) = read_state_json(dir)?;
    check_same_run(dir, &stored, current)?;
    let model_path = dir.join(&state.model_file);
    let model = read_weights(dir, &state.model_file, &state.model_crc)?;
    let record = burn::store::ModuleRecord::from_bytes(burn::tensor::Bytes::from_bytes_vec(model))
        .map_err(|e| anyhow::anyhow!("{}: invalid: {e:?}", model_path.display()))?;
    let decoder = decoder.try_load_record(record).map_err(|e| {
        anyhow::anyhow!("{}: does not fit the decoder: {e:?}", model_path.display())
    })?;
    let optim_path = dir.join(&state.optim_file);
    let opt = read_weights(dir, &state.optim_file, &state.optim_crc)?;
    let optim = optim
        .from_bytes(burn::tensor::Bytes::from_bytes_vec(opt))
        .map_err(|e| anyhow::anyhow!("{}: invalid: {e:?}", optim_path.display()))?;
    Ok((decoder, optim, state))
}

/// Checks that the checkpoint in `dir`, whose `state.json` read as `stored`, belongs to the run
/// described by `current`: the same training configuration, decoder shape, level sizes, data
/// and context. The error names the folder and every field that differs.
///
/// Both sides are compared as serde_json writes and reads them back, so a value that went
/// through the file compares equal to the value it was written from.
fn check_same_run(dir: &Path, stored: &Value, current: &CheckpointState) -> Result<()> {
    let current: Value = serde_json::from_str(&serde_json::to_string(current)?)?;
    let mut diffs = Vec::new();
    for key in IDENTITY {
        differences(key, &stored[key], &current[key], &mut diffs);
    }
    if !diffs.is_empty() {
        bail!(
            "{}: the checkpoint belongs to another run ({}); resume with the same arguments and \
             data, or train without --resume to start over",
            dir.display(),
            diffs.join("; ")
        );
    }
    Ok(())
}

/// Appends `path: A in the checkpoint, B now` for every leaf where `a` and `b` differ.
fn differences(path: &str, a: &Value, b: &Value, out: &mut Vec<String>) {
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
