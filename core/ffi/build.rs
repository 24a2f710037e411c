//! Names the shared library after its ABI version: `libsinew.so`'s SONAME is
//! `libsinew.so.N` (`N` = `SINEW_ABI_VERSION`, src/abi.rs), so that a program linked against one
//! ABI never loads a library of another. ELF targets only; elsewhere the linker has no SONAME.

include!("src/abi.rs");

fn main() {
    println!("cargo:rerun-if-changed=src/abi.rs");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let elf = matches!(
        os.as_str(),
        "linux" | "android" | "freebsd" | "netbsd" | "openbsd" | "dragonfly" | "illumos"
    );
    if elf {
        println!("cargo:rustc-cdylib-link-arg=-Wl,-soname,libsinew.so.{SINEW_ABI_VERSION}");
    }
}
