//! Golden AIM, S2D, fitted-performance and generated-sequence replays on a 32-bit RISC-V core
//! without FPU (riscv32imac-unknown-none-elf: every `f32` operation in software), run
//! under `qemu-system-riscv32 -machine virt` with semihosting.
//!
//! Plays the 16-frame golden sequence with `sinew-core`, prints each frame's hash and the
//! instructions it retired, and exits 0 only when every hash equals the one pinned on the x86_64
//! host. A panic or a trap exits non-zero too, so the runner never waits on a spinning hart.
#![no_std]
#![no_main]

use riscv::register::{mcause, mepc, minstret, mtval};
use semihosting::{eprintln, println, process};
use sinew_firmware_common::driver::{DRIVER_GOLDENS, driver_costs};
use sinew_firmware_common::kernels::{KernelScratch, check_kernels};
use sinew_firmware_common::motion::{MOTION_GOLDENS, motion_costs};
use sinew_firmware_common::suite::{Run, Suite};
use sinew_firmware_common::{
    Error, FrameCheck, GOLDENS, S2D_GOLDENS, Scratch, Summary, phase_costs, s2d_costs,
};

/// Plays `frames` to the end, printing each frame's check and cost in instructions retired (exact
/// and repeatable under QEMU's -icount) and adding it to `summary`; false (after saying why) if a
/// frame could not be played.
fn timed_frames(
    name: &str,
    frames: &mut impl Iterator<Item = Result<FrameCheck, Error>>,
    summary: &mut Summary,
) -> bool {
    loop {
        let start = minstret::read64();
        let Some(result) = frames.next() else {
            return true;
        };
        let instructions = minstret::read64().wrapping_sub(start);
        match result {
            Ok(check) => {
                println!("{check}  {instructions} instructions");
                summary.add(&check);
            }
            Err(e) => {
                eprintln!("sinew-firmware-sim-riscv: {name}: {e}");
                return false;
            }
        }
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
    // The core kernels on seeded weights, against the hashes pinned on the host.
    let Some(kernel_scratch) = riscv::singleton!(: KernelScratch = KernelScratch::new()) else {
        eprintln!("sinew-firmware-sim-riscv: kernel scratch already taken");
        return false;
    };
    match check_kernels(kernel_scratch, |name, hash, ok| {
        println!(
            "kernel {} {:016x} {}",
            name,
            hash,
            if ok { "ok" } else { "DIFFERS" }
        );
    }) {
        Ok((cases, 0)) => println!(
            "sinew-firmware-sim-riscv: {}/{} kernels bit-identical to the host",
            cases, cases
        ),
        Ok((cases, bad)) => {
            eprintln!(
                "sinew-firmware-sim-riscv: {} of {} kernels differ from the host",
                bad, cases
            );
            return false;
        }
        Err(e) => {
            eprintln!("sinew-firmware-sim-riscv: kernel suite failed: {:?}", e);
            return false;
        }
    }
    // The AIM replays, the S2D replay, the fitted performance and the generated sequence, in the
    // same frame buffers.
    let mut passed = true;
    for suite in Suite::ALL {
        let mut summary = Summary::default();
        for golden in suite.goldens() {
            let mut run = match Run::new(suite, golden, scratch) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("sinew-firmware-sim-riscv: {}: {e}", golden.name);
                    return false;
                }
            };
            println!(
                "sinew-firmware-sim-riscv: rv32imac, {}: {}",
                golden.name, run
            );
            if !timed_frames(golden.name, &mut run, &mut summary) {
                return false;
            }
        }
        println!(
            "sinew-firmware-sim-riscv: {}/{} {} bit-identical to the host",
            summary.frames - summary.mismatches,
            summary.frames,
            suite.frames_label()
        );
        passed &= summary.passed();
    }
    // Cost of each phase of one frame, per golden actor (the f32 replay stands for its model).
    for golden in GOLDENS.iter().filter(|g| g.name.ends_with(".f32")) {
        match phase_costs(golden, 8, scratch, minstret::read64) {
            Ok(c) => println!("cost {} frame 8 (instructions): {c}", golden.name),
            Err(e) => {
                eprintln!("sinew-firmware-sim-riscv: {}: {e}", golden.name);
                return false;
            }
        }
    }
    for golden in &S2D_GOLDENS {
        match s2d_costs(golden, 8, scratch, minstret::read64) {
            Ok(c) => println!("s2d cost {} frame 8 (instructions): {c}", golden.name),
            Err(e) => {
                eprintln!("sinew-firmware-sim-riscv: {}: {e}", golden.name);
                return false;
            }
        }
    }
    for golden in &MOTION_GOLDENS {
        match motion_costs(golden, 8, scratch, minstret::read64) {
            Ok(c) => println!("motion cost {} frame 8 (instructions): {c}", golden.name),
            Err(e) => {
                eprintln!("sinew-firmware-sim-riscv: {}: {e}", golden.name);
                return false;
            }
        }
    }
    for golden in &DRIVER_GOLDENS {
        match driver_costs(golden, 8, scratch, minstret::read64) {
            Ok(c) => println!("driver cost {} frame 8 (instructions): {c}", golden.name),
            Err(e) => {
                eprintln!("sinew-firmware-sim-riscv: {}: {e}", golden.name);
                return false;
            }
        }
    }
    passed
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
