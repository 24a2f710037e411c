//! Keeps freed memory in the process on glibc, so that training does not pay a page fault for
//! every byte of every tensor.
//!
//! burn's CPU kernels allocate a fresh output buffer per operation, several MiB each at AIM's
//! batch of 4096 × 256. glibc's malloc serves such blocks with `mmap` and, when they are freed,
//! unmaps them or trims the heap top back to the kernel; the next step then faults every page
//! in again. perf put about 20 % of an AIM step in that page-fault path. Raising the mmap and
//! trim thresholds (glibc's documented tunables) keeps the memory mapped and reused: the step
//! ran about 25 % faster with an unchanged peak resident size (docs/BENCHMARKS.md, "Allocator").
//!
//! The tunables are read once, when the process starts, and the workspace forbids `unsafe` (so
//! no `mallopt` call), so [`keep_freed_memory`] re-executes the program once with
//! `GLIBC_TUNABLES` set. A `GLIBC_TUNABLES` the user already set is respected as is, and on
//! other platforms or C libraries this does nothing.

/// The tunables: blocks up to 32 MiB come from the heap (the largest mmap threshold glibc
/// accepts from `mallopt` on 64-bit targets, far above one 4096 × 256 `f32` tensor's 4 MiB), and
/// the heap is trimmed only past 1 GiB of free memory at its top.
pub const TUNABLES: &str =
    "glibc.malloc.mmap_threshold=33554432:glibc.malloc.trim_threshold=1073741824";

/// Whether [`keep_freed_memory`] would re-execute a process started with `existing` as its
/// `GLIBC_TUNABLES`: only when there is none (the user's own choice wins, and a re-executed
/// process has ours).
pub fn needs_reexec(existing: Option<&std::ffi::OsStr>) -> bool {
    cfg!(all(target_os = "linux", target_env = "gnu")) && existing.is_none()
}

/// Re-executes the running program with [`TUNABLES`] in `GLIBC_TUNABLES` (same arguments, same
/// process id) unless [`needs_reexec`] says no. Call it first thing in `main`, before any thread
/// starts. Returns only when nothing was to be done or the re-execution failed, in which case the
/// program carries on with glibc's defaults (slower, otherwise the same).
pub fn keep_freed_memory() {
    if !needs_reexec(std::env::var_os("GLIBC_TUNABLES").as_deref()) {
        return;
    }
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        use std::os::unix::process::CommandExt;
        let Ok(exe) = std::env::current_exe() else {
            return;
        };
        let mut args = std::env::args_os();
        let arg0 = args.next().unwrap_or_else(|| exe.clone().into_os_string());
        // `exec` replaces this process and returns only on failure.
        let error = std::process::Command::new(&exe)
            .arg0(arg0)
            .args(args)
            .env("GLIBC_TUNABLES", TUNABLES)
            .exec();
        eprintln!(
            "note: could not re-execute {} with glibc's malloc tunables ({error}); training runs slower",
            exe.display()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_users_tunables_are_left_alone() {
        assert!(!needs_reexec(Some(std::ffi::OsStr::new(
            "glibc.malloc.arena_max=2"
        ))));
        assert!(!needs_reexec(Some(std::ffi::OsStr::new(TUNABLES))));
        assert_eq!(
            needs_reexec(None),
            cfg!(all(target_os = "linux", target_env = "gnu"))
        );
    }

    #[test]
    fn tunables_are_well_formed() {
        for setting in TUNABLES.split(':') {
            let (name, value) = setting.split_once('=').expect("name=value");
            assert!(name.starts_with("glibc.malloc."), "{name}");
            assert!(value.parse::<u64>().is_ok(), "{value}");
        }
    }
}
