//! Golden AIM and S2D replays in WebAssembly (wasm32-unknown-unknown, no_std): the module
//! exports [`sinew_replay`], which plays every golden AIM replay, and [`sinew_replay_s2d`], the
//! golden S2D replay (`tests/data/*.replay.sinew`), and [`sinew_replay_performance`], the golden
//! fitted performance (`tests/data/fit-ict.sinew`), and [`sinew_replay_motion`], the golden
//! generated sequence (`tests/data/motion-ict.sinew` through the S2D decoder), and
//! [`sinew_replay_driver`] and [`sinew_replay_live`], the golden driver's track and live track,
//! with
//! `sinew-core` and returns how many frames' hashes differ from those recorded on the x86_64
//! host. Each frame is also handed to the host through the import `sinew.report`, so `run.mjs`
//! can print it.
#![no_std]
#![deny(unsafe_code)]

use sinew_firmware_common::kernels::{KernelScratch, check_kernels};
use sinew_firmware_common::suite::{Run, Suite};
use sinew_firmware_common::{Scratch, Summary};

/// What [`sinew_replay`] returns when the replay could not run (bad model, malformed or empty
/// hash list).
pub const LOAD_ERROR: u32 = 0xFFFF_FFFF;

// Safety: the host must supply `sinew.report` with the signature (i32, i64, i64) -> (); the wasm
// engine checks the import's type when it instantiates the module, so a wrong signature fails
// there rather than at the call. The function only reads its arguments, which makes it safe to
// call (hence `safe fn`).
#[allow(unsafe_code)]
#[link(wasm_import_module = "sinew")]
unsafe extern "C" {
    /// Called after each frame with this module's hash and the pinned one.
    safe fn report(frame: u32, hash: u64, expected: u64);
}

/// Plays every golden replay; returns the number of mismatching frames (0 when every frame is
/// bit-identical to the host), or [`LOAD_ERROR`]. Frames are reported with the index of their
/// replay in `GOLDENS` times 1000 added to the frame number.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_replay`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay() -> u32 {
    play(Suite::Aim, |i| i * 1000)
}

/// Plays every golden of `suite`, reporting each frame with `base(golden index)` added to its
/// number; returns the mismatching frames ([`outcome`]), or [`LOAD_ERROR`].
fn play(suite: Suite, base: impl Fn(usize) -> usize) -> u32 {
    // On the stack (180 KiB of the 1 MiB wasm stack): a `static` would need `static mut` or a
    // lock, and the module runs one replay at a time anyway.
    let mut scratch = Scratch::new();
    let mut total = Summary::default();
    for (i, golden) in suite.goldens().iter().enumerate() {
        let Ok(run) = Run::new(suite, golden, &mut scratch) else {
            return LOAD_ERROR;
        };
        for check in run {
            let Ok(check) = check else {
                return LOAD_ERROR;
            };
            report(
                u32::try_from(base(i) + check.frame).unwrap_or(u32::MAX),
                check.hash,
                check.expected,
            );
            total.add(&check);
        }
    }
    outcome(&total)
}

/// What an export returns for `total`: its mismatching frames (at most the number of frames, far
/// below [`LOAD_ERROR`]), or [`LOAD_ERROR`] if no frame was played.
fn outcome(total: &Summary) -> u32 {
    if total.frames == 0 {
        return LOAD_ERROR;
    }
    u32::try_from(total.mismatches).unwrap_or(LOAD_ERROR - 1)
}

/// Plays the golden S2D replay; returns the number of mismatching frames, or [`LOAD_ERROR`].
/// Frames are reported with 8000 added to the frame number.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_replay_s2d`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_s2d() -> u32 {
    play(Suite::S2d, |_| 8000)
}

/// Plays the golden fitted performance; returns the number of mismatching frames, or
/// [`LOAD_ERROR`]. Frames are reported with 7000 added to the frame number.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_replay_performance`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_performance() -> u32 {
    play(Suite::Performance, |_| 7000)
}

/// Plays the golden generated sequence; returns the number of mismatching frames, or
/// [`LOAD_ERROR`]. Frames are reported with 6000 added to the frame number.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_replay_motion`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_motion() -> u32 {
    play(Suite::Motion, |_| 6000)
}

/// Plays the golden driver's track (four checks a row); returns the number of mismatching checks,
/// or [`LOAD_ERROR`]. Checks are reported with 5000 added to the row number.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_replay_driver`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_driver() -> u32 {
    play(Suite::Driver, |_| 5000)
}

/// Plays the golden live track through the calibration and the lost-frame rules (three checks a
/// row: the outcome, the pose, the frame); returns the number of mismatching checks, or
/// [`LOAD_ERROR`]. Checks are reported with 4000 added to the row number.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_replay_live`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_replay_live() -> u32 {
    play(Suite::Live, |_| 4000)
}

/// Runs the core kernel suite on seeded weights; returns the number of cases whose hash differs
/// from the one pinned on the host, or [`LOAD_ERROR`]. Each case is reported through
/// `sinew.report` with frame number 9000 + its index.
// Safety: `no_mangle` exports the function under its own name; no other symbol in the module
// is called `sinew_kernels`.
#[allow(unsafe_code)]
#[unsafe(no_mangle)]
pub extern "C" fn sinew_kernels() -> u32 {
    let mut scratch = KernelScratch::new();
    let mut index = 0u32;
    let result = check_kernels(&mut scratch, |name, hash, ok| {
        let pinned = sinew_firmware_common::kernels::pinned(name).map_or(!hash, |(h, _)| h);
        report(9000 + index, hash, if ok { hash } else { pinned });
        index += 1;
    });
    match result {
        Ok((cases, bad)) if cases > 0 => u32::try_from(bad).unwrap_or(LOAD_ERROR - 1),
        _ => LOAD_ERROR,
    }
}

/// A panic traps: the host sees a `RuntimeError` from the call, never a wrong count.
#[panic_handler]
fn panic(_info: &core::panic::PanicInfo<'_>) -> ! {
    core::arch::wasm32::unreachable()
}
