//! The golden kernels, replays, fitted performance, generated sequence and driven track on a
//! Cortex-M4F (thumbv7em-none-eabihf, hardware single-precision FPU), run under
//! `qemu-system-arm -machine mps2-an386` with semihosting.
//!
//! The run is the common crate's ([`check_all`]); this firmware gives it semihosting's output and
//! a SysTick clock, and adds the checks of its own core (flush-to-zero off, the stack's
//! high-water mark). It prints each frame's hash and its cost, and exits 0 only when every hash
//! equals the one pinned on the x86_64 host. A panic or a HardFault exits non-zero too, so the
//! runner never waits on a spinning core.
#![no_std]
#![no_main]

use core::fmt;

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, heprintln, hprintln};
use panic_semihosting as _;
use sinew_firmware_common::Scratch;
use sinew_firmware_common::kernels::KernelScratch;
use sinew_firmware_common::target::{Target, check_all};

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

/// The Cortex-M4F as the shared run's target: semihosting's output, SysTick's clock.
struct M4f {
    clock: Clock,
}

impl Target for M4f {
    const PREFIX: &'static str = "sinew-firmware-sim";
    const CORE: &'static str = "cortex-m4f";
    // SysTick counts core clock ticks; instructions are ticks × INSTRUCTIONS_PER_TICK.
    const ESTIMATE: &'static str = "~";

    fn out(&mut self, line: fmt::Arguments<'_>) {
        hprintln!("{}", line);
    }

    fn err(&mut self, line: fmt::Arguments<'_>) {
        heprintln!("{}", line);
    }

    /// A frame is far shorter than a SysTick period (671 M instructions), but some span the
    /// counter's reload: the accumulating clock counts across it.
    fn restart(&mut self) {
        self.clock = Clock {
            last: SYST::get_current(),
            total: 0,
        };
    }

    fn now(&mut self) -> u64 {
        self.clock.now()
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

    let Some(kernels) = cortex_m::singleton!(: KernelScratch = KernelScratch::new()) else {
        heprintln!("sinew-firmware-sim: kernel scratch already taken");
        return false;
    };
    let mut target = M4f {
        clock: Clock {
            last: SYST::get_current(),
            total: 0,
        },
    };
    let passed = check_all(&mut target, kernels, scratch);
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
