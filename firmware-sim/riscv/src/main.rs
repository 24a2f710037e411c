//! The golden kernels, replays, fitted performance, generated sequence and driven track on a
//! 32-bit RISC-V core without FPU (riscv32imac-unknown-none-elf: every `f32` operation in
//! software), run under `qemu-system-riscv32 -machine virt` with semihosting.
//!
//! The run is the common crate's ([`check_all`]); this firmware gives it semihosting's output and
//! `minstret`. It prints each frame's hash and the instructions it retired, and exits 0 only when
//! every hash equals the one pinned on the x86_64 host. A panic or a trap exits non-zero too, so
//! the runner never waits on a spinning hart.
#![no_std]
#![no_main]

use core::fmt;

use riscv::register::{mcause, mepc, minstret, mtval};
use semihosting::{eprintln, println, process};
use sinew_firmware_common::Scratch;
use sinew_firmware_common::kernels::KernelScratch;
use sinew_firmware_common::target::{Target, check_all};

/// The RV32IMAC hart as the shared run's target: semihosting's output, `minstret`'s count of
/// instructions retired (exact and repeatable under QEMU's -icount).
struct Rv32;

impl Target for Rv32 {
    const PREFIX: &'static str = "sinew-firmware-sim-riscv";
    const CORE: &'static str = "rv32imac";
    const ESTIMATE: &'static str = "";

    fn out(&mut self, line: fmt::Arguments<'_>) {
        println!("{line}");
    }

    fn err(&mut self, line: fmt::Arguments<'_>) {
        eprintln!("{line}");
    }

    /// `minstret` only counts up: the costs are differences of it.
    fn restart(&mut self) {}

    fn now(&mut self) -> u64 {
        minstret::read64()
    }
}

#[riscv_rt::entry]
fn main() -> ! {
    process::exit(if run() { 0 } else { 1 })
}

/// Replays every frame; true when all matched.
fn run() -> bool {
    // The frame buffers (180 KiB) live in a static, not on the stack.
    let Some(scratch) = riscv::singleton!(: Scratch = Scratch::new()) else {
        eprintln!("sinew-firmware-sim-riscv: scratch already taken");
        return false;
    };
    let Some(kernels) = riscv::singleton!(: KernelScratch = KernelScratch::new()) else {
        eprintln!("sinew-firmware-sim-riscv: kernel scratch already taken");
        return false;
    };
    check_all(&mut Rv32, kernels, scratch)
}

/// Any trap (bad memory access, illegal instruction, …) ends the run with a failure instead of
/// falling into riscv-rt's default `abort`, which spins until the runner's timeout.
// Safety: riscv-rt's trap entry calls the symbol `ExceptionHandler` with this signature for every
// exception that has no handler of its own; no other item exports that name.
#[unsafe(export_name = "ExceptionHandler")]
fn exception_handler(_trap_frame: &riscv_rt::TrapFrame) -> ! {
    eprintln!(
        "sinew-firmware-sim-riscv: trap, mcause {:#x} at mepc {:#010x} (mtval {:#x})",
        mcause::read().bits(),
        mepc::read(),
        mtval::read()
    );
    process::exit(1)
}
