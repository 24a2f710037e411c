//! Builds the WebAssembly module that `sinew view` serves (core/wasm, docs/VIEW.md) and leaves it
//! in `OUT_DIR`, where `host/src/view/files.rs` embeds it with `include_bytes!`.
//!
//! The module is built from the sources of this checkout, every time they change, so the viewer
//! can never serve a stale module beside a newer core: a frame hash in the page is the core's. It
//! is built by a second cargo with its own target folder (`target/view-wasm`), so it never waits
//! on the lock of the build that runs this script, with the `wasm` profile and `simd128` exactly
//! as `core/wasm/build.sh` builds `core/wasm/pkg/`.

use std::env;
use std::path::{Path, PathBuf};
use std::process::Command;

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let root = manifest
        .parent()
        .expect("host/ lies in the workspace")
        .to_path_buf();
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    for input in [
        "core/src",
        "core/Cargo.toml",
        "core/wasm/src",
        "core/wasm/Cargo.toml",
        "Cargo.toml",
        "Cargo.lock",
    ] {
        println!("cargo::rerun-if-changed={}", root.join(input).display());
    }
    println!("cargo::rerun-if-env-changed=SINEW_VIEW_WASM_TARGET_DIR");

    let target_dir = env::var_os("SINEW_VIEW_WASM_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| target_root(&out, &root).join("view-wasm"));
    ensure_wasm_target();
    let cargo = env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut build = Command::new(cargo);
    build
        .current_dir(&root)
        .args(["build", "--locked", "-p", "sinew-wasm", "--profile", "wasm"])
        .args(["--target", "wasm32-unknown-unknown", "--target-dir"])
        .arg(&target_dir)
        .env(
            "CARGO_TARGET_WASM32_UNKNOWN_UNKNOWN_RUSTFLAGS",
            "-C target-feature=+simd128",
        );
    // What this build's cargo told its build script is not meant for the inner build: the
    // encoded flags would replace the wasm target's, and a clippy or coverage wrapper has
    // nothing to say about the module.
    for name in [
        "CARGO_ENCODED_RUSTFLAGS",
        "RUSTFLAGS",
        "RUSTC_WRAPPER",
        "RUSTC_WORKSPACE_WRAPPER",
        "CARGO_TARGET_DIR",
        "CARGO_BUILD_TARGET",
    ] {
        build.env_remove(name);
    }
    let status = build.status().unwrap_or_else(|e| {
        fail(&format!(
            "cannot run cargo to build the viewer's WebAssembly module: {e}"
        ))
    });
    if !status.success() {
        fail(
            "building the viewer's WebAssembly module (sinew-wasm for wasm32-unknown-unknown) \
             failed; its errors are above.",
        );
    }
    let module = target_dir.join("wasm32-unknown-unknown/wasm/sinew_wasm.wasm");
    std::fs::copy(&module, out.join("sinew_wasm.wasm")).unwrap_or_else(|e| {
        fail(&format!("cannot copy {}: {e}", module.display()));
    });
}

/// Adds rustup's `wasm32-unknown-unknown` target when the compiler's sysroot lacks it, as
/// `core/wasm/build.sh` does, so that a fresh checkout builds with plain `cargo build`.
fn ensure_wasm_target() {
    let rustc = env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    let sysroot = Command::new(rustc)
        .args(["--print", "sysroot"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()));
    let installed =
        sysroot.is_some_and(|s| s.join("lib/rustlib/wasm32-unknown-unknown/lib").is_dir());
    if installed {
        return;
    }
    println!(
        "cargo::warning=adding rustup's wasm32-unknown-unknown target for the viewer's module"
    );
    let added = Command::new("rustup")
        .args(["target", "add", "wasm32-unknown-unknown"])
        .status()
        .is_ok_and(|s| s.success());
    if !added {
        fail(
            "the viewer's WebAssembly module needs the wasm32-unknown-unknown target, and \
             `rustup target add wasm32-unknown-unknown` failed: add it, then build again",
        );
    }
}

/// The workspace's target folder: `OUT_DIR` is `<target>/<profile>/build/<package>-<hash>/out`
/// (or `<target>/<triple>/<profile>/…` when cross-compiling), so the folder holding the profile's.
fn target_root(out: &Path, root: &Path) -> PathBuf {
    out.ancestors()
        .find(|p| p.file_name().is_some_and(|n| n == "build"))
        .and_then(Path::parent)
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| root.join("target"))
}

fn fail(message: &str) -> ! {
    eprintln!("error: {message}");
    std::process::exit(1);
}
