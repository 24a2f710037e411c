//! The committed C header is what cbindgen generates from this crate now: a change to the C API
//! that is not regenerated into `include/sinew.h` fails here (`UPDATE_EXPECT=1` rewrites it);
//! the header's ABI version, the library's versions and the shared library's SONAME agree.

#![allow(unsafe_code)] // Reading the version string the library returns is `unsafe` by nature.

use std::path::Path;

#[test]
fn committed_header_is_current() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).unwrap();
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_crate(dir)
        .with_config(config)
        .generate()
        .unwrap()
        .write(&mut generated);
    let generated = String::from_utf8(generated).unwrap();
    let path = dir.join("include/sinew.h");
    if std::env::var_os("UPDATE_EXPECT").is_some() {
        std::fs::write(&path, &generated).unwrap();
        return;
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run with UPDATE_EXPECT=1 to write it)",
            path.display()
        )
    });
    assert!(
        committed == generated,
        "{} is stale: regenerate with UPDATE_EXPECT=1 cargo test -p sinew-ffi --test header",
        path.display()
    );
}

/// The header's `SINEW_ABI_VERSION` is the library's `sinew_abi_version()`: a program built
/// with this header and linked with this library agrees with it.
#[test]
fn the_header_abi_version_is_the_library_s() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("include/sinew.h");
    let header = std::fs::read_to_string(&path).unwrap();
    let defined: Vec<u32> = header
        .lines()
        .filter_map(|l| l.strip_prefix("#define SINEW_ABI_VERSION "))
        .map(|v| v.trim().parse().unwrap())
        .collect();
    assert_eq!(defined, [sinew::sinew_abi_version()], "{}", path.display());
    assert_eq!(sinew::SINEW_ABI_VERSION, sinew::sinew_abi_version());
}

/// `sinew_version` is the crate's version; `sinew_format_versions` the core's range.
#[test]
fn versions_are_reported() {
    // Safety: a static NUL-terminated string.
    let version = unsafe { std::ffi::CStr::from_ptr(sinew::sinew_version()) };
    assert_eq!(version.to_str().unwrap(), env!("CARGO_PKG_VERSION"));
    let v = sinew::sinew_format_versions();
    use sinew_core::format::{MIN_VERSION_MAJOR, VERSION_MAJOR, VERSION_MINOR};
    assert_eq!(
        (v.min_major, v.max_major, v.minor),
        (MIN_VERSION_MAJOR, VERSION_MAJOR, VERSION_MINOR)
    );
    assert!(v.min_major <= v.max_major);
}

/// On ELF targets the shared library's SONAME is `libsinew.so.SINEW_ABI_VERSION` (build.rs), as
/// `readelf -d` (binutils) reads it; skipped, saying so, where readelf is missing.
#[cfg(target_os = "linux")]
#[test]
fn the_shared_library_is_named_after_the_abi() {
    // The test binary lives in target/<profile>/deps, where cargo also places the cdylib.
    let exe = std::env::current_exe().unwrap();
    let deps = exe.parent().unwrap();
    let lib = [deps.join("libsinew.so"), deps.join("../libsinew.so")]
        .into_iter()
        .find(|p| p.exists())
        .unwrap_or_else(|| panic!("no libsinew.so beside {}", deps.display()));
    let out = match std::process::Command::new("readelf")
        .arg("-d")
        .arg(&lib)
        .output()
    {
        Ok(out) => out,
        Err(e) => {
            eprintln!("skipped: readelf cannot run ({e}); install binutils to check the SONAME");
            return;
        }
    };
    assert!(out.status.success(), "readelf -d {}", lib.display());
    let text = String::from_utf8_lossy(&out.stdout);
    let want = format!("Library soname: [libsinew.so.{}]", sinew::SINEW_ABI_VERSION);
    assert!(
        text.lines()
            .any(|l| l.contains("(SONAME)") && l.contains(&want)),
        "{}: no {want} in\n{text}",
        lib.display()
    );
}
