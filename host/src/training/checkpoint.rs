//! The files of a training checkpoint folder, shared by AIM and S2D training: the model's burn
//! record and the optimiser's state, named by the step they were taken at, and a `state.json`
//! written after them that names them with their CRCs. Every file is written atomically and
//! `state.json` last, so an interruption at any moment leaves the previous checkpoint whole;
//! earlier weight files are removed only once the new `state.json` is in place.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, ensure};
use serde::{Deserialize, Serialize};

/// The name of the state file inside a checkpoint folder.
pub const STATE_FILE: &str = "state.json";

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
    pub fn validate(&self) -> Result<()> {
        for (what, name) in [("model", &self.model_file), ("optimiser", &self.optim_file)] {
            ensure!(
                is_weight_file_name(name),
                "{what} file {name:?} is not a checkpoint file name"
            );
        }
        Ok(())
    }

    /// Reads the model's bytes and checks them against their CRC.
    pub fn read_model(&self, dir: &Path) -> Result<Vec<u8>> {
        read_checked(dir, &self.model_file, &self.model_crc)
    }

    /// Reads the optimiser's bytes and checks them against their CRC.
    pub fn read_optim(&self, dir: &Path) -> Result<Vec<u8>> {
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
) -> Result<()> {
    let files = WeightFiles {
        model_file: format!("model-{steps}.bpk"),
        model_crc: crc_hex(model),
        optim_file: format!("optim-{steps}.bpk"),
        optim_crc: crc_hex(optim),
    };
    crate::io::atomic::write(&dir.join(&files.model_file), model)?;
    crate::io::atomic::write(&dir.join(&files.optim_file), optim)?;
    let keep = files.clone();
    set_files(state, files);
    // state.json last: until it is in place, the previous one still names whole files.
    crate::io::atomic::write(
        &dir.join(STATE_FILE),
        serde_json::to_string_pretty(state)?.as_bytes(),
    )?;
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
pub fn read_state_value(dir: &Path) -> Result<serde_json::Value> {
    let path = dir.join(STATE_FILE);
    let bytes = std::fs::read(&path).with_context(|| {
        format!(
            "{}: cannot read the checkpoint state (is {} a checkpoint folder?)",
            path.display(),
            dir.display()
        )
    })?;
    serde_json::from_slice(&bytes)
        .with_context(|| format!("{}: not valid JSON (truncated?)", path.display()))
}

/// Reads a checkpoint file named by `state.json` and checks it against its CRC.
fn read_checked(dir: &Path, name: &str, crc: &str) -> Result<Vec<u8>> {
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
        let e = files.read_model(dir.path()).unwrap_err().to_string();
        assert!(e.contains("model-2.bpk") && e.contains("CRC"), "{e}");
        std::fs::write(dir.path().join(STATE_FILE), b"{\"step\": 2, \"mo").unwrap();
        let e = format!("{:#}", read_state_value(dir.path()).unwrap_err());
        assert!(
            e.contains("state.json") && e.contains("not valid JSON"),
            "{e}"
        );
    }
}
