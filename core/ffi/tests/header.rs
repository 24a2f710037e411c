//! The committed C header is what cbindgen generates from this crate now: a change to the C API
//! that is not regenerated into `include/sinew.h` fails here. `UPDATE_EXPECT=1` rewrites it.

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
