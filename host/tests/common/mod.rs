//! What the command-line tests share: running the `sinew` binary of this build, and paths in the
//! repository.

#![allow(dead_code)] // each test binary uses its own part of it

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `sinew` with `args`, without the environment's `SINEW_SEED`.
pub fn sinew(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sinew"))
        .args(args)
        .env_remove("SINEW_SEED")
        .output()
        .expect("run sinew")
}

/// Runs `sinew`, requires success and returns its standard output.
pub fn ok(args: &[&str]) -> String {
    let out = sinew(args);
    assert!(
        out.status.success(),
        "sinew {args:?} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `sinew`, requires failure and returns its standard error.
pub fn err(args: &[&str]) -> String {
    let out = sinew(args);
    assert!(!out.status.success(), "sinew {args:?} should have failed");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A file of the repository by its path from the root, as an argument.
pub fn repo(path: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path);
    p.to_str().unwrap().to_owned()
}
pub mod gltf;
