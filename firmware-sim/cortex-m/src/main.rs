//! Golden AIM, S2D, fitted-performance and generated-sequence replays on a Cortex-M4F
//! (thumbv7em-none-eabihf, hardware single-precision FPU), run under
//! `qemu-system-arm -machine mps2-an386` with semihosting.
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
use sinew_firmware_common::driver::{DRIVER_GOLDENS, driver_costs};
use sinew_firmware_common::kernels::{KernelScratch, check_kernels};
use sinew_firmware_common::motion::{MOTION_GOLDENS, motion_costs};
use sinew_firmware_common::suite::{Run, Suite};
use sinew_firmware_common::{
    Error, FrameCheck, GOLDENS, S2D_GOLDENS, Scratch, Summary, phase_costs, s2d_costs,
};

/// SysTick reload: the counter is 24 bits wide.
const SYST_MAX: u32 = 0x00FF_FFFF;

/// Instructions per SysTick tick under `-icount shift=0`: one instruction per virtual
/// nanosecond, SysTick on the mps2 core clock of 25 MHz.
const INSTRUCTIONS_PER_TICK: u32 = 40;

/// What unused stack holds after [`paint_stack`].
const STACK_PAINT: u32 = 0x5EED_5EED;

unsafe extern "C" {
    /// Lowest stack address (end of .bss/.uninit), from cortex-m-rt's linker script.
    static _stack_end: u32;
    /// Initial stack pointer (top of RAM), from cortex-m-rt's linker script.
    static _stack_start: u32;
}

/// Fills the free stack below the current frame (less a margin) with [`STACK_PAINT`], so that
/// [`stack_high_water`] can find the deepest address the run wrote.
fn paint_stack() {
    let bottom = core::ptr::addr_of!(_stack_end) as usize;
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = bottom;
    while p + 256 < sp {
        // Safety: [bottom, sp − 256) is RAM between the end of .bss and the live stack, used by
        // nothing else in this single-threaded program; word-aligned (cortex-m-rt aligns
        // _stack_end to 4).
        unsafe { (p as *mut u32).write_volatile(STACK_PAINT) };
        p += 4;
    }
}

/// Bytes of stack used so far: from the top of RAM down to the lowest word no longer holding
/// [`STACK_PAINT`].
fn stack_high_water() -> usize {
    let bottom = core::ptr::addr_of!(_stack_end) as usize;
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let mut p = bottom;
    // Safety: reads of RAM between the end of .bss and the top of the stack, word-aligned.
    while p < top && unsafe { (p as *const u32).read_volatile() } == STACK_PAINT {
        p += 4;
    }
    top - p
}

/// A monotonic instruction count from SysTick (24 bits, counting down): each call adds the ticks
/// since the previous one, so it never wraps as long as calls are less than a period apart.
struct Clock {
    last: u32,
    total: u64,
}

impl Clock {
    fn now(&mut self) -> u64 {
        let current = SYST::get_current();
        self.total += u64::from(self.last.wrapping_sub(current) & SYST_MAX);
        self.last = current;
        self.total * u64::from(INSTRUCTIONS_PER_TICK)
    }
}

/// Plays `frames` to the end, printing each frame's check and cost in instructions and adding it
/// to `summary`; false (after saying why) if a frame could not be played.
///
/// A frame is far shorter than a SysTick period (671 M instructions), but some span the counter's
/// reload: the accumulating clock counts across it.
fn timed_frames(
    name: &str,
    frames: &mut impl Iterator<Item = Result<FrameCheck, Error>>,
    summary: &mut Summary,
) -> bool {
    let mut clock = Clock {
        last: SYST::get_current(),
        total: 0,
    };
    loop {
        let start = clock.now();
        let Some(result) = frames.next() else {
            return true;
        };
        let instructions = clock.now() - start;
        match result {
            Ok(check) => {
                hprintln!("{}  ~{} instructions", check, instructions);
                summary.add(&check);
            }
            Err(e) => {
                heprintln!("sinew-firmware-sim: {}: {}", name, e);
                return false;
            }
        }
    }
}

#[entry]
fn main() -> ! {
    paint_stack();
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

    // The core kernels on seeded weights, against the hashes pinned on the host.
    let Some(kernel_scratch) = cortex_m::singleton!(: KernelScratch = KernelScratch::new()) else {
        heprintln!("sinew-firmware-sim: kernel scratch already taken");
        return false;
    };
    match check_kernels(kernel_scratch, |name, hash, ok| {
        hprintln!(
            "kernel {} {:016x} {}",
            name,
            hash,
            if ok { "ok" } else { "DIFFERS" }
        );
    }) {
        Ok((cases, 0)) => hprintln!(
            "sinew-firmware-sim: {}/{} kernels bit-identical to the host",
            cases,
            cases
        ),
        Ok((cases, bad)) => {
            heprintln!(
                "sinew-firmware-sim: {} of {} kernels differ from the host",
                bad,
                cases
            );
            return false;
        }
        Err(e) => {
            heprintln!("sinew-firmware-sim: kernel suite failed: {:?}", e);
            return false;
        }
    }
    // The AIM replays, the S2D replay, the fitted performance, the generated sequence and the
    // driven track, in the same frame buffers.
    let mut passed = true;
    for suite in Suite::ALL {
        let mut summary = Summary::default();
        for golden in suite.goldens() {
            let mut run = match Run::new(suite, golden, scratch) {
                Ok(r) => r,
                Err(e) => {
                    heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                    return false;
                }
            };
            hprintln!("sinew-firmware-sim: cortex-m4f, {}: {}", golden.name, run);
            if !timed_frames(golden.name, &mut run, &mut summary) {
                return false;
            }
        }
        hprintln!(
            "sinew-firmware-sim: {}/{} {} bit-identical to the host",
            summary.frames - summary.mismatches,
            summary.frames,
            suite.frames_label()
        );
        passed &= summary.passed();
    }
    // Cost of each phase of one frame, per golden actor (the f32 replay stands for its model).
    for golden in GOLDENS.iter().filter(|g| g.name.ends_with(".f32")) {
        let mut clock = Clock {
            last: SYST::get_current(),
            total: 0,
        };
        match phase_costs(golden, 8, scratch, || clock.now()) {
            Ok(c) => hprintln!("cost {} frame 8 (instructions): {}", golden.name, c),
            Err(e) => {
                heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                return false;
            }
        }
    }
    for golden in &S2D_GOLDENS {
        let mut clock = Clock {
            last: SYST::get_current(),
            total: 0,
        };
        match s2d_costs(golden, 8, scratch, || clock.now()) {
            Ok(c) => hprintln!("s2d cost {} frame 8 (instructions): {}", golden.name, c),
            Err(e) => {
                heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                return false;
            }
        }
    }
    for golden in &MOTION_GOLDENS {
        let mut clock = Clock {
            last: SYST::get_current(),
            total: 0,
        };
        match motion_costs(golden, 8, scratch, || clock.now()) {
            Ok(c) => hprintln!("motion cost {} frame 8 (instructions): {}", golden.name, c),
            Err(e) => {
                heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                return false;
            }
        }
    }
    for golden in &DRIVER_GOLDENS {
        let mut clock = Clock {
            last: SYST::get_current(),
            total: 0,
        };
        match driver_costs(golden, 8, scratch, || clock.now()) {
            Ok(c) => hprintln!("driver cost {} frame 8 (instructions): {}", golden.name, c),
            Err(e) => {
                heprintln!("sinew-firmware-sim: {}: {}", golden.name, e);
                return false;
            }
        }
    }
    hprintln!("stack high-water {} bytes", stack_high_water());
    passed
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
