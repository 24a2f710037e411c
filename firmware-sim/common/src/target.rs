//! The run every firmware makes, written once: the core kernels against their pinned hashes,
//! every suite's goldens frame by frame ([`crate::suite`]), then the cost of each phase of one
//! frame per golden. A firmware supplies only what differs between cores ([`Target`]): where its
//! log lines go and how it counts instructions.
//!
//! `scripts/firmware_costs.py` reads the log; its lines are the same on every target but for the
//! prefix, the core's name and the `~` of an estimated count.

use core::fmt;

use crate::driver::{DRIVER_GOLDENS, driver_costs};
use crate::kernels::{KernelScratch, check_kernels};
use crate::live::{LIVE_GOLDENS, live_costs};
use crate::motion::{MOTION_GOLDENS, motion_costs};
use crate::s2d::s2d_costs;
use crate::suite::{Run, Suite};
use crate::{Error, GOLDENS, Golden, S2D_GOLDENS, Scratch, Summary, phase_costs};

/// What a firmware gives the shared run.
pub trait Target {
    /// The log's prefix, the firmware's name (`sinew-firmware-sim`).
    const PREFIX: &'static str;
    /// The core's name in the log (`cortex-m4f`).
    const CORE: &'static str;
    /// `"~"` where [`Target::now`] estimates the count, `""` where it is exact.
    const ESTIMATE: &'static str;

    /// Writes a line to the log.
    fn out(&mut self, line: fmt::Arguments<'_>);
    /// Writes a line saying what failed.
    fn err(&mut self, line: fmt::Arguments<'_>);
    /// Restarts the instruction count (before each timed golden).
    fn restart(&mut self);
    /// Instructions since the last [`Target::restart`].
    fn now(&mut self) -> u64;
}

/// Plays every golden and prints its costs; true when every kernel and frame matched the host.
/// Stops at the first golden that cannot be played, after saying why; a frame that differs
/// from the host's is reported and the run goes on.
pub fn check_all(
    target: &mut impl Target,
    kernels: &mut KernelScratch,
    scratch: &mut Scratch,
) -> bool {
    if !check_kernel_hashes(target, kernels) {
        return false;
    }
    let Some(matched) = check_goldens(target, scratch) else {
        return false;
    };
    costs(target, scratch) && matched
}

/// The core kernels on seeded weights, against the hashes pinned on the host.
fn check_kernel_hashes<T: Target>(target: &mut T, kernels: &mut KernelScratch) -> bool {
    let checked = check_kernels(kernels, |name, hash, ok| {
        let verdict = if ok { "ok" } else { "DIFFERS" };
        target.out(format_args!("kernel {name} {hash:016x} {verdict}"));
    });
    match checked {
        Ok((cases, 0)) => {
            target.out(format_args!(
                "{}: {cases}/{cases} kernels bit-identical to the host",
                T::PREFIX
            ));
            true
        }
        Ok((cases, bad)) => {
            target.err(format_args!(
                "{}: {bad} of {cases} kernels differ from the host",
                T::PREFIX
            ));
            false
        }
        Err(e) => {
            target.err(format_args!("{}: kernel suite failed: {e:?}", T::PREFIX));
            false
        }
    }
}

/// The AIM replays, the S2D replay, the fitted performance, the generated sequence, the
/// driven track and the live track, in the same frame buffers, each frame's check and instructions printed: whether
/// every frame matched, or `None` when a golden could not be played.
fn check_goldens<T: Target>(target: &mut T, scratch: &mut Scratch) -> Option<bool> {
    let mut passed = true;
    for suite in Suite::ALL {
        let mut summary = Summary::default();
        for golden in suite.goldens() {
            let mut run = match Run::new(suite, golden, scratch) {
                Ok(r) => r,
                Err(e) => {
                    failed(target, golden.name, e);
                    return None;
                }
            };
            target.out(format_args!(
                "{}: {}, {}: {run}",
                T::PREFIX,
                T::CORE,
                golden.name
            ));
            target.restart();
            loop {
                let start = target.now();
                let Some(result) = run.next() else { break };
                let instructions = target.now().wrapping_sub(start);
                match result {
                    Ok(check) => {
                        target.out(format_args!(
                            "{check}  {}{instructions} instructions",
                            T::ESTIMATE
                        ));
                        summary.add(&check);
                    }
                    Err(e) => {
                        failed(target, golden.name, e);
                        return None;
                    }
                }
            }
        }
        target.out(format_args!(
            "{}: {}/{} {} bit-identical to the host",
            T::PREFIX,
            summary.frames - summary.mismatches,
            summary.frames,
            suite.frames_label()
        ));
        passed &= summary.passed();
    }
    Some(passed)
}

/// The frame whose phases are measured.
const COST_FRAME: usize = 8;

/// The cost of each phase of one frame ([`COST_FRAME`]), per golden (an AIM actor's f32 replay
/// stands for its model).
fn costs<T: Target>(target: &mut T, scratch: &mut Scratch) -> bool {
    let f = COST_FRAME;
    GOLDENS
        .iter()
        .filter(|g| g.name.ends_with(".f32"))
        .all(|g| {
            cost(target, "cost", g, |t| {
                phase_costs(g, f, scratch, || t.now())
            })
        })
        && S2D_GOLDENS.iter().all(|g| {
            cost(target, "s2d cost", g, |t| {
                s2d_costs(g, f, scratch, || t.now())
            })
        })
        && MOTION_GOLDENS.iter().all(|g| {
            cost(target, "motion cost", g, |t| {
                motion_costs(g, f, scratch, || t.now())
            })
        })
        && DRIVER_GOLDENS.iter().all(|g| {
            cost(target, "driver cost", g, |t| {
                driver_costs(g, f, scratch, || t.now())
            })
        })
        && LIVE_GOLDENS.iter().all(|g| {
            cost(target, "live cost", g, |t| {
                live_costs(g, f, scratch, || t.now())
            })
        })
}

/// Measures `golden`'s phases with `measure` from a restarted count and prints them after `what`
/// (`cost`, `s2d cost`, …); false (after saying why) when the golden cannot be played.
fn cost<T: Target, C: fmt::Display>(
    target: &mut T,
    what: &str,
    golden: &Golden,
    measure: impl FnOnce(&mut T) -> Result<C, Error>,
) -> bool {
    target.restart();
    match measure(target) {
        Ok(c) => {
            target.out(format_args!(
                "{what} {} frame {COST_FRAME} (instructions): {c}",
                golden.name
            ));
            true
        }
        Err(e) => failed(target, golden.name, e),
    }
}

/// Says that `name` failed with `e`; false.
fn failed<T: Target>(target: &mut T, name: &str, e: impl fmt::Display) -> bool {
    target.err(format_args!("{}: {name}: {e}", T::PREFIX));
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::boxed::Box;
    use std::string::{String, ToString};
    use std::vec::Vec;

    /// The host as a target: lines kept, one "instruction" a call to `now`.
    #[derive(Default)]
    struct Host {
        out: Vec<String>,
        err: Vec<String>,
        count: u64,
    }

    impl Target for Host {
        const PREFIX: &'static str = "host";
        const CORE: &'static str = "x86_64";
        const ESTIMATE: &'static str = "";

        fn out(&mut self, line: fmt::Arguments<'_>) {
            self.out.push(line.to_string());
        }
        fn err(&mut self, line: fmt::Arguments<'_>) {
            self.err.push(line.to_string());
        }
        fn restart(&mut self) {
            self.count = 0;
        }
        fn now(&mut self) -> u64 {
            self.count += 1;
            self.count
        }
    }

    #[test]
    fn the_shared_run_checks_every_golden_and_prints_what_the_cost_script_reads() {
        let mut host = Host::default();
        let passed = check_all(
            &mut host,
            &mut Box::<KernelScratch>::default(),
            &mut Box::<Scratch>::default(),
        );
        assert!(passed, "{:?}", host.err);
        assert!(host.err.is_empty(), "{:?}", host.err);
        let has = |start: &str| host.out.iter().any(|l| l.starts_with(start));
        assert!(has("kernel ") && has("host: ") && has("host: x86_64, aim-ict.f32: "));
        for suite in Suite::ALL {
            let total = host
                .out
                .iter()
                .find(|l| {
                    l.ends_with(&std::format!(
                        "{} bit-identical to the host",
                        suite.frames_label()
                    ))
                })
                .unwrap();
            let (good, all) = total
                .trim_start_matches("host: ")
                .split_once(' ')
                .unwrap()
                .0
                .split_once('/')
                .unwrap();
            assert_eq!(good, all, "{total}");
        }
        // Each frame line carries its count: two calls of `now` apart.
        assert!(host.out.iter().any(|l| l.ends_with("  1 instructions")));
        for cost in [
            "cost aim-ict.f32",
            "s2d cost",
            "motion cost",
            "driver cost",
            "live cost",
        ] {
            assert!(has(cost), "no `{cost}` line");
        }
    }
}
