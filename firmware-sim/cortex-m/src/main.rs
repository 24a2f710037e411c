//! Golden AIM replay on a Cortex-M4F (thumbv7em-none-eabihf, hardware single-precision FPU),
//! run under `qemu-system-arm -machine mps2-an386` with semihosting.
//!
//! Plays the 16-frame golden sequence with `sinew-core`, prints each frame's hash and its cost,
//! and exits 0 only when every hash equals the one pinned on the x86_64 host. A panic or a
//! HardFault exits non-zero too, so the runner never waits on a spinning core.
#![no_std]
#![no_main]

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, heprintln, hprintln};
use panic_semihosting as _;
use sinew_firmware_common::{GOLDENS, Replay, Scratch, Summary};

/// SysTick reload: the counter is 24 bits wide.
const SYST_MAX: u32 = 0x00FF_FFFF;

/// Instructions per SysTick tick under `-icount shift=0`: one instruction per virtual
/// nanosecond, SysTick on the mps2 core clock of 25 MHz.
const INSTRUCTIONS_PER_TICK: u32 = 40;

#[entry]
fn main() -> ! {
    let passed = run();
    debug::exit(if passed {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    // Only reached if the semihosting exit is ignored (no debugger or emulator attached).
    loop {
        cortex_m::asm::bkpt();
    }
}

/// Replays every frame; true when all matched.
fn run() -> bool {
    // The frame buffers (180 KiB) live in a static, not on the stack.
    let Some(scratch) = cortex_m::singleton!(: Scratch = Scratch::new()) else {
        heprintln!("sinew-firmware-sim: scratch already taken");
        return false;
    };
    // Flush-to-zero would change results on subnormals and break bit-identity with the host;
    // it is off after reset, and this guards against a startup that turns it on.
    if cortex_m::register::fpscr::read().fz() {
        heprintln!("sinew-firmware-sim: FPSCR.FZ (flush-to-zero) is set");
        return false;
    }
    let Some(mut peripherals) = cortex_m::Peripherals::take() else {
        heprintln!("sinew-firmware-sim: core peripherals already taken");
        return false;
    };
    let syst = &mut peripherals.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYST_MAX);
    syst.clear_current();
    syst.enable_counter();

    let mut total = Summary::default();
    for golden in &GOLDENS {
        let mut replay = match Replay::new(golden, scratch) {
            Ok(r) => r,
            Err(e) => {
                heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                return false;
            }
        };
        hprintln!(
            "sinew-firmware-sim: cortex-m4f, {}: {} vertices, {} shapes, {} frames",
            golden.name,
            replay.actor().vertex_count(),
            replay.actor().shape_count(),
            replay.replay().frames()
        );
        loop {
            // Clear COUNTFLAG, so that a frame longer than one SysTick period is noticed.
            let _ = syst.has_wrapped();
            let start = SYST::get_current();
            let Some(result) = replay.next() else { break };
            let end = SYST::get_current();
            // SysTick counts down.
            let ticks = start.wrapping_sub(end) & SYST_MAX;
            let check = match result {
                Ok(r) => r,
                Err(e) => {
                    heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                    return false;
                }
            };
            if syst.has_wrapped() {
                hprintln!("{}  (over one SysTick period: cost not measured)", check);
            } else {
                hprintln!("{}  ~{} instructions", check, ticks * INSTRUCTIONS_PER_TICK);
            }
            total.add(&check);
        }
    }
    hprintln!(
        "sinew-firmware-sim: {}/{} frames of {} replays bit-identical to the host",
        total.frames - total.mismatches,
        total.frames,
        GOLDENS.len()
    );
    total.passed()
}

/// A fault (bad memory access, undefined instruction, …) ends the run with a failure instead of
/// spinning until the runner's timeout.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    heprintln!("sinew-firmware-sim: HardFault at pc {:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}
