//! The golden live run: the golden driver (`tests/data/driver-ict.sinew`) drives the ICT actor
//! through `sinew_core::live` from a 60-frame OpenFace 2.0 track that rests, carries a tracker's
//! convention and four tracker failures (`tests/data/driver-ict-live.csv`, as the frames a tracker
//! hands a device, [`Frames`]; a row whose `success` is 0 is a frame without landmarks), at the
//! settings of its hash list's `live`
//! line, each row at its time stamp. Three checks a row, each against
//! `tests/data/driver-ict-live.hashes`, the list `tests/tests/suite/golden_driver.rs` pins: what became
//! of the frame (calibrating, driven, missing, lost to the residual or to a jump), the hash of
//! the pose played, and the posed frame's (positions then normals). Every step is the core's
//! ([`Live::step`], [`driver::pose_hash`]), as on the host.

use core::fmt;

use sinew_core::aim::AimActor;
use sinew_core::driver::{self, Driver, Intrinsics, LANDMARKS};
use sinew_core::hash::frame_hash;
use sinew_core::live::{Live, Lost, Outcome, Settings};
use sinew_core::replay::{FrameCheck, ReplayError};

use crate::list;
use crate::track::Frames;
use crate::{Error, Golden, ICT, MAX_VERTICES, Scratch, Summary, summarise};

/// The live run: `model` is the actor the golden driver ([`crate::driver::DRIVER`]) drives, `replay` the pinned
/// list.
pub const LIVE_GOLDENS: [Golden; 1] = [Golden {
    name: "driver-ict-live.f32",
    model: ICT,
    replay: include_bytes!("../../../tests/data/driver-ict-live.hashes"),
}];

/// The live track, the OpenFace CSV the list's `track` line names, as the frames a tracker hands
/// a device (made by the build, `build.rs`; [`Frames`]).
pub const LIVE_TRACK: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/driver-ict-live.frames"));

/// The checks of one track row, in the list's names and order.
pub const CHECKS: [&str; 3] = ["outcome", "pose", "frame"];

/// Every outcome, as the list names them.
const OUTCOMES: [Outcome; 5] = [
    Outcome::Driven,
    Outcome::Calibrating,
    Outcome::Missing,
    Outcome::Lost(Lost::Residual),
    Outcome::Lost(Lost::Jump),
];

/// What a live list says: the camera, the settings and each check's value.
#[derive(Clone, Copy, Debug)]
pub struct LiveList {
    text: &'static str,
    /// The camera's intrinsics (`track FILE FX FY CX CY`).
    pub camera: Intrinsics,
    /// The settings (`live FRAMES RESIDUAL SPEED TURN REACQUIRE`).
    pub settings: Settings,
}

impl LiveList {
    /// Reads the `track` and `live` lines of `bytes`; `None` if the text is not UTF-8 or a line
    /// is missing or malformed.
    pub fn parse(bytes: &'static [u8]) -> Option<Self> {
        let text = core::str::from_utf8(bytes).ok()?;
        let mut l = list::words(text, "live")?;
        let frames: u32 = l.next()?.parse().ok()?;
        let [max_residual, max_speed, max_turn, reacquire] = list::numbers(&mut l)?;
        Some(Self {
            text,
            camera: list::camera(text)?,
            settings: Settings {
                calibrate_frames: frames,
                max_residual,
                max_speed,
                max_turn,
                reacquire,
            },
        })
    }

    /// The pinned value of check `kind` (one of [`CHECKS`]) of row `row`: a hash, or for
    /// `outcome` the outcome's code ([`Outcome::code`]).
    pub fn expected(&self, kind: &str, row: usize) -> Option<u64> {
        if kind == "outcome" {
            let value = list::pinned(self.text, kind, row)?;
            let o = OUTCOMES.iter().find(|o| o.name() == value)?;
            Some(u64::from(o.code()))
        } else {
            list::pinned_hash(self.text, kind, row)
        }
    }
}

/// Values of the run's buffers carved from [`Scratch`]'s small buffer: the state, the
/// landmarks, the pose, then the live step's scratch (which holds a row's pixels first).
fn needed(live: &Live<'_, '_>, d: &Driver<'_>) -> usize {
    live.state_len() + d.input_len() + d.output_len() + live.scratch_len().max(2 * LANDMARKS)
}

/// The live run in progress: an iterator over every row's three checks, so that a firmware can
/// time each on its own.
#[derive(Debug)]
pub struct LiveRun<'s> {
    actor: AimActor<'static>,
    driver: Driver<'static>,
    list: LiveList,
    track: Frames<'static>,
    /// The next check: row `next / 3`, check `next % 3`.
    next: usize,
    scratch: &'s mut Scratch,
}

impl<'s> LiveRun<'s> {
    /// Validates the golden's actor, the driver, the list and the settings, checks that the
    /// driver was trained for the actor and that everything fits in `scratch`; the state starts
    /// at zeros.
    pub fn new(golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let (actor, driver) = crate::driver::load(golden.model)?;
        let list = LiveList::parse(golden.replay).ok_or(Error::HashList)?;
        let track = Frames::parse(LIVE_TRACK, LANDMARKS).ok_or(Error::Track { row: 0 })?;
        let live = Live::new(&driver, &actor, list.settings)
            .map_err(|e| Error::Playback(ReplayError::from(e)))?;
        let values = needed(&live, &driver);
        if values > scratch.performance.len() {
            return Err(Error::ScratchTooSmall { values });
        }
        scratch.performance.fill(0.0);
        Ok(Self {
            actor,
            driver,
            list,
            track,
            next: 0,
            scratch,
        })
    }

    /// The actor.
    pub const fn actor(&self) -> &AimActor<'static> {
        &self.actor
    }

    /// Rows of the track.
    pub const fn rows(&self) -> usize {
        self.track.rows
    }

    /// The settings.
    pub const fn settings(&self) -> Settings {
        self.list.settings
    }

    /// Check `check` (an index of [`CHECKS`]) of row `row`: the step itself at the outcome's
    /// check, the pose it wrote at the others.
    fn play(&mut self, row: usize, check: usize) -> Result<FrameCheck, Error> {
        let refused = |e: sinew_core::EvalError| Error::Playback(ReplayError::from(e));
        let d = &self.driver;
        let live = Live::new(d, &self.actor, self.list.settings).map_err(refused)?;
        let (state, rest) = self.scratch.performance.split_at_mut(live.state_len());
        let (lmk, rest) = rest.split_at_mut(d.input_len());
        let (pose, step) = rest.split_at_mut(d.output_len());
        let n = 3 * self.actor.vertex_count();
        let (positions, normals) = self.scratch.frame.split_at_mut(3 * MAX_VERTICES);
        let (Some(positions), Some(normals)) = (positions.get_mut(..n), normals.get_mut(..n))
        else {
            return Err(Error::TooManyVertices {
                vertices: self.actor.vertex_count(),
            });
        };
        let value = match check {
            0 => {
                let bad_row = Error::Track { row: row + 1 };
                // The row's pixels, read into the step's room (free until it runs).
                let pixels = step
                    .get_mut(..2 * LANDMARKS)
                    .ok_or(Error::ScratchTooSmall {
                        values: 2 * LANDMARKS,
                    })?;
                let (time, found) = self.track.row(row, pixels).ok_or(bad_row)?;
                if found {
                    driver::normalise_pixels(pixels, &self.list.camera, lmk).map_err(refused)?;
                }
                let landmarks = if found { Some(&*lmk) } else { None };
                let outcome = live
                    .step(state, landmarks, time, step, pose)
                    .map_err(refused)?;
                u64::from(outcome.code())
            }
            1 => frame_hash(pose),
            _ => driver::pose_hash(&self.actor, pose, positions, normals).map_err(refused)?,
        };
        let kind = CHECKS.get(check).copied().unwrap_or("");
        Ok(FrameCheck {
            frame: row,
            hash: value,
            // A check missing from the list is a mismatch.
            expected: self.list.expected(kind, row).unwrap_or(!value),
        })
    }
}

impl Iterator for LiveRun<'_> {
    type Item = Result<FrameCheck, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        let (row, check) = list::next_check(&mut self.next, self.track.rows, CHECKS.len())?;
        Some(self.play(row, check))
    }
}

/// Plays every check of the live golden `golden`, calling `report` after each one, and returns
/// the totals.
pub fn replay_live(
    golden: &Golden,
    scratch: &mut Scratch,
    report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    summarise(LiveRun::new(golden, scratch)?, report)
}

/// What one live frame costs beyond the driver's own evaluation, in the units of the counter
/// given to [`live_costs`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct LiveCosts {
    /// One calibration step: the driver on the raw landmarks, the head on the steady landmarks
    /// and the frame's offsets taken in.
    pub calibrate: u64,
    /// One step after the calibration: the driver on the raw landmarks, the head, the offsets
    /// taken off, the driver again, the residual and the jump check (the same work whether the
    /// frame is then driven or lost).
    pub step: u64,
}

impl fmt::Display for LiveCosts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "calibrate={} step={}", self.calibrate, self.step)
    }
}

/// Measures one calibration step (the track's first row) and the step of row `row` (after the
/// rows before it) with `now`.
pub fn live_costs(
    golden: &Golden,
    row: usize,
    scratch: &mut Scratch,
    mut now: impl FnMut() -> u64,
) -> Result<LiveCosts, Error> {
    let mut run = LiveRun::new(golden, scratch)?;
    let mut costs = LiveCosts::default();
    for r in 0..=row {
        let start = now();
        run.play(r, 0)?;
        let spent = now() - start;
        if r == 0 {
            costs.calibrate = spent;
        }
        if r == row {
            costs.step = spent;
        }
    }
    Ok(costs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::{edited_list, wrong_last_digit};
    use std::boxed::Box;
    use std::vec::Vec;

    #[test]
    fn the_live_track_matches_the_host_with_every_outcome() {
        let g = &LIVE_GOLDENS[0];
        let mut seen = Vec::new();
        let s = replay_live(g, &mut Box::default(), |r| seen.push(*r)).unwrap();
        assert!(s.passed(), "{seen:?}");
        assert_eq!(s.frames, 3 * 60);
        let outcomes: Vec<u64> = seen.iter().step_by(3).map(|c| c.hash).collect();
        for o in OUTCOMES {
            assert!(outcomes.contains(&u64::from(o.code())), "{o:?}");
        }
    }

    #[test]
    fn a_wrong_outcome_or_hash_is_a_mismatch_and_a_bad_list_an_error() {
        let g = LIVE_GOLDENS[0];
        let text = core::str::from_utf8(g.replay).unwrap();
        let leaked = edited_list(text, |l| {
            Some(if l == "outcome 32 lost-residual" {
                "outcome 32 driven".into()
            } else if l.starts_with("frame 40 ") {
                wrong_last_digit(l)
            } else {
                l.into()
            })
        });
        let mut wrong = Vec::new();
        let s = replay_live(
            &Golden {
                replay: leaked,
                ..g
            },
            &mut Box::default(),
            |r| {
                if !r.ok() {
                    wrong.push(r.frame);
                }
            },
        )
        .unwrap();
        assert_eq!(s.mismatches, 2);
        assert_eq!(wrong, [32, 40]);
        let leaked = edited_list(text, |l| (!l.starts_with("live ")).then(|| l.into()));
        let got = LiveRun::new(
            &Golden {
                replay: leaked,
                ..g
            },
            &mut Box::default(),
        )
        .map(|_| ());
        assert_eq!(got, Err(Error::HashList));
    }

    #[test]
    fn live_costs_measure_a_calibration_step_and_a_driven_one() {
        let mut clock = 0u64;
        let c = live_costs(&LIVE_GOLDENS[0], 8, &mut Box::default(), || {
            clock += 1;
            clock
        })
        .unwrap();
        assert_eq!(
            c,
            LiveCosts {
                calibrate: 1,
                step: 1
            }
        );
    }
}
