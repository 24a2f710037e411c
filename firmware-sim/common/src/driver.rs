//! The golden live driver: a 2D landmark driver of the ICT actor (`tests/data/driver-ict.sinew`)
//! drives it from a 20-frame OpenFace 2.0 track (`tests/data/driver-ict.csv`, parsed here without
//! allocation), each row's pixels through the camera of the hash list's `track` line, without and
//! then with the One Euro filter of its `filter` line at the row's time stamp. Four checks a row,
//! each against `tests/data/driver-ict.hashes`, the list `tests/tests/suite/golden_driver.rs` pins:
//! the driven pose's hash, the posed frame's (positions then normals), and the same after the
//! filter. Every step is the core's ([`Driver::drive`], [`driver::filter_pose`],
//! [`driver::pose_hash`]), as on the host.

use core::fmt;

use sinew_core::aim::AimActor;
use sinew_core::driver::{self, Driver, Intrinsics, LANDMARKS};
use sinew_core::filter::OneEuro;
use sinew_core::hash::frame_hash;
use sinew_core::replay::{FrameCheck, ReplayError};

use crate::list;
use crate::track::Track;
use crate::{Error, Golden, ICT, MAX_VERTICES, Scratch, Summary, summarise};

/// The golden driver's run: `model` is the actor it drives, `replay` the pinned hash list; the
/// driver is [`DRIVER`].
///
/// The actor is named in a `const` as in the other goldens' lists: the image then holds its 2.6
/// MB once, where a `static` of it, or the `const` used in a function, placed a second copy.
pub const DRIVER_GOLDENS: [Golden; 1] = [Golden {
    name: "driver-ict.f32",
    model: ICT,
    replay: include_bytes!("../../../tests/data/driver-ict.hashes"),
}];

/// The golden landmark driver of the ICT actor. Read only through [`load`]: a `const` places a
/// copy of its bytes in the image for each function that names it.
pub const DRIVER: &[u8] = include_bytes!("../../../tests/data/driver-ict.sinew");

/// Validates `model` and the golden driver ([`DRIVER`]) and checks that the driver was trained
/// for the actor (content hash): the start of the driven and the live runs.
pub fn load(model: &'static [u8]) -> Result<(AimActor<'static>, Driver<'static>), Error> {
    let actor = AimActor::from_bytes(model).map_err(Error::Model)?;
    let driver = Driver::from_bytes(DRIVER).map_err(Error::Model)?;
    driver.check_actor(model, &actor).map_err(Error::Playback)?;
    if actor.vertex_count() > MAX_VERTICES {
        return Err(Error::TooManyVertices {
            vertices: actor.vertex_count(),
        });
    }
    Ok((actor, driver))
}

/// The golden track, the OpenFace CSV the hash list's `track` line names.
pub const DRIVER_TRACK: &[u8] = include_bytes!("../../../tests/data/driver-ict.csv");

/// The checks of one track row, in the hash list's names and order.
pub const CHECKS: [&str; 4] = ["pose", "frame", "filtered-pose", "filtered-frame"];

/// Values of a driver's buffers carved from [`Scratch`]'s small buffer: landmarks, the pose, the
/// filtered pose, the filter's state, then the driver's scratch (which holds a row's pixels
/// before the network runs).
fn needed(d: &Driver<'_>) -> usize {
    d.input_len()
        + 2 * d.output_len()
        + OneEuro::timed_state_len(d.output_len())
        + d.scratch_len().max(2 * LANDMARKS)
}

/// What a hash list says: the camera, the filter and each check's hash.
#[derive(Clone, Copy, Debug)]
pub struct DriverList {
    text: &'static str,
    /// The camera's intrinsics (`track FILE FX FY CX CY`).
    pub camera: Intrinsics,
    /// The filter's minimum cutoff, beta and derivative cutoff (`filter A B C`).
    pub filter: [f32; 3],
}

impl DriverList {
    /// Reads the `track` and `filter` lines of `bytes`; `None` if the text is not UTF-8 or a
    /// line is missing or malformed.
    pub fn parse(bytes: &'static [u8]) -> Option<Self> {
        let text = core::str::from_utf8(bytes).ok()?;
        Some(Self {
            text,
            camera: list::camera(text)?,
            filter: list::numbers(&mut list::words(text, "filter")?)?,
        })
    }

    /// The pinned hash of check `kind` (one of [`CHECKS`]) of row `row`.
    pub fn expected(&self, kind: &str, row: usize) -> Option<u64> {
        list::pinned_hash(self.text, kind, row)
    }
}

/// The golden driver in progress: an iterator over every row's four checks, so that a firmware
/// can time each on its own.
#[derive(Debug)]
pub struct DriverRun<'s> {
    actor: AimActor<'static>,
    driver: Driver<'static>,
    list: DriverList,
    filter: OneEuro,
    track: Track<'static>,
    /// The next check: row `next / 4`, check `next % 4`.
    next: usize,
    time: f32,
    scratch: &'s mut Scratch,
}

impl<'s> DriverRun<'s> {
    /// Validates the golden's actor, the driver and the hash list, checks that the driver was
    /// trained for the actor (content hash) and that everything fits in `scratch`; the filter
    /// starts reset.
    pub fn new(golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        let (actor, driver) = load(golden.model)?;
        let list = DriverList::parse(golden.replay).ok_or(Error::HashList)?;
        let track = Track::parse(DRIVER_TRACK, LANDMARKS).ok_or(Error::Track { row: 0 })?;
        let [min_cutoff, beta, d_cutoff] = list.filter;
        // The time-stamped step takes its rate from the stamps; 1 Hz only fills the setting.
        let filter = OneEuro::new(min_cutoff, beta, d_cutoff, 1.0)
            .map_err(|e| Error::Playback(ReplayError::Input(e)))?;
        if needed(&driver) > scratch.performance.len() {
            return Err(Error::ScratchTooSmall {
                values: needed(&driver),
            });
        }
        scratch.performance.fill(0.0);
        Ok(Self {
            actor,
            driver,
            list,
            filter,
            track,
            next: 0,
            time: 0.0,
            scratch,
        })
    }

    /// The actor.
    pub const fn actor(&self) -> &AimActor<'static> {
        &self.actor
    }

    /// The driver.
    pub const fn driver(&self) -> &Driver<'static> {
        &self.driver
    }

    /// Rows of the track.
    pub const fn rows(&self) -> usize {
        self.track.rows
    }

    /// Check `check` (an index of [`CHECKS`]) of row `row`.
    fn play(&mut self, row: usize, check: usize) -> Result<FrameCheck, Error> {
        let refused = |e: sinew_core::EvalError| Error::Playback(ReplayError::from(e));
        let d = &self.driver;
        let (lmk, rest) = self.scratch.performance.split_at_mut(d.input_len());
        let (pose, rest) = rest.split_at_mut(d.output_len());
        let (filtered, rest) = rest.split_at_mut(d.output_len());
        let (state, net) = rest.split_at_mut(OneEuro::timed_state_len(d.output_len()));
        let n = 3 * self.actor.vertex_count();
        let (positions, normals) = self.scratch.frame.split_at_mut(3 * MAX_VERTICES);
        let (Some(positions), Some(normals)) = (positions.get_mut(..n), normals.get_mut(..n))
        else {
            return Err(Error::TooManyVertices {
                vertices: self.actor.vertex_count(),
            });
        };
        let hash = match check {
            0 => {
                // The row's pixels, read into the network's room (free until it runs).
                let pixels = net.get_mut(..2 * LANDMARKS).ok_or(Error::ScratchTooSmall {
                    values: 2 * LANDMARKS,
                })?;
                self.time = self
                    .track
                    .row(row, pixels)
                    .ok_or(Error::Track { row: row + 1 })?;
                driver::normalise_pixels(pixels, &self.list.camera, lmk).map_err(refused)?;
                d.drive(lmk, net, pose).map_err(refused)?;
                frame_hash(pose)
            }
            1 => driver::pose_hash(&self.actor, pose, positions, normals).map_err(refused)?,
            2 => {
                filtered.copy_from_slice(pose);
                driver::filter_pose(&self.filter, state, self.time, filtered).map_err(refused)?;
                frame_hash(filtered)
            }
            _ => driver::pose_hash(&self.actor, filtered, positions, normals).map_err(refused)?,
        };
        let kind = CHECKS.get(check).copied().unwrap_or("");
        Ok(FrameCheck {
            frame: row,
            hash,
            // A check missing from the list is a mismatch.
            expected: self.list.expected(kind, row).unwrap_or(!hash),
        })
    }
}

impl Iterator for DriverRun<'_> {
    type Item = Result<FrameCheck, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        let (row, check) = list::next_check(&mut self.next, self.track.rows, CHECKS.len())?;
        Some(self.play(row, check))
    }
}

/// Plays every check of the golden driver `golden`, calling `report` after each one, and returns
/// the totals.
pub fn replay_driver(
    golden: &Golden,
    scratch: &mut Scratch,
    report: impl FnMut(&FrameCheck),
) -> Result<Summary, Error> {
    summarise(DriverRun::new(golden, scratch)?, report)
}

/// What one driven frame costs, in the units of the counter given to [`driver_costs`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct DriverCosts {
    /// One driver evaluation: the pixels through the camera, the features, the network and the
    /// pose made whole ([`driver::normalise_pixels`], [`Driver::drive`]).
    pub drive: u64,
    /// One One Euro filter step on the pose ([`driver::filter_pose`]).
    pub filter: u64,
    /// Posing the actor with the pose (AIM eq. 17, [`driver::play`]).
    pub pose: u64,
    /// The vertex normals.
    pub normals: u64,
    /// Hashing positions and normals (the golden check, not playback).
    pub hash: u64,
}

impl fmt::Display for DriverCosts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "drive={} filter={} pose={} normals={} hash={}",
            self.drive, self.filter, self.pose, self.normals, self.hash
        )
    }
}

/// Measures each phase of track row `row` separately with `now`; the track's text is read
/// before the first reading. The steps are the core's; they are called one by one here only so
/// that the counter can be read between them.
pub fn driver_costs(
    golden: &Golden,
    row: usize,
    scratch: &mut Scratch,
    mut now: impl FnMut() -> u64,
) -> Result<DriverCosts, Error> {
    let mut run = DriverRun::new(golden, scratch)?;
    let refused = |e: sinew_core::EvalError| Error::Playback(ReplayError::from(e));
    // The filter's state after the row before, so that the step measured is not a first one.
    if row > 0 {
        run.play(row - 1, 0)?;
        run.play(row - 1, 2)?;
    }
    let d = &run.driver;
    let (lmk, rest) = run.scratch.performance.split_at_mut(d.input_len());
    let (pose, rest) = rest.split_at_mut(d.output_len());
    let (_, rest) = rest.split_at_mut(d.output_len());
    let (state, net) = rest.split_at_mut(OneEuro::timed_state_len(d.output_len()));
    let mut px = [0.0f32; 2 * LANDMARKS];
    let time = run
        .track
        .row(row, &mut px)
        .ok_or(Error::Track { row: row + 1 })?;
    let n = 3 * run.actor.vertex_count();
    let (positions, normals) = run.scratch.frame.split_at_mut(3 * MAX_VERTICES);
    let (Some(positions), Some(normals)) = (positions.get_mut(..n), normals.get_mut(..n)) else {
        return Err(Error::TooManyVertices {
            vertices: run.actor.vertex_count(),
        });
    };
    let mut costs = DriverCosts::default();
    let start = now();
    driver::normalise_pixels(&px, &run.list.camera, lmk).map_err(refused)?;
    d.drive(lmk, net, pose).map_err(refused)?;
    costs.drive = now() - start;
    let start = now();
    driver::filter_pose(&run.filter, state, time, pose).map_err(refused)?;
    costs.filter = now() - start;
    let start = now();
    driver::play(&run.actor, pose, positions).map_err(refused)?;
    costs.pose = now() - start;
    let start = now();
    run.actor.normals(positions, normals).map_err(refused)?;
    costs.normals = now() - start;
    let start = now();
    let mut h = sinew_core::hash::FrameHasher::new();
    h.write_f32s(positions);
    h.write_f32s(normals);
    core::hint::black_box(h.finish());
    costs.hash = now() - start;
    Ok(costs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::{edited_list, wrong_last_digit};
    use std::boxed::Box;
    use std::vec::Vec;

    #[test]
    fn the_driven_track_matches_the_host() {
        let g = &DRIVER_GOLDENS[0];
        let mut seen = Vec::new();
        let s = replay_driver(g, &mut Box::default(), |r| seen.push(*r)).unwrap();
        assert!(s.passed(), "{seen:?}");
        assert_eq!(s.frames, 4 * 20);
        // The face moves, and the filter changes every frame after the first.
        assert_ne!(seen[1].hash, seen[5].hash);
        assert_ne!(seen[5].hash, seen[7].hash);
    }

    #[test]
    fn a_wrong_pinned_hash_is_a_mismatch_and_a_bad_list_an_error() {
        let g = DRIVER_GOLDENS[0];
        let text = core::str::from_utf8(g.replay).unwrap();
        let leaked = edited_list(text, |l| {
            Some(if l.starts_with("filtered-frame 12 ") {
                wrong_last_digit(l)
            } else {
                l.into()
            })
        });
        let mut wrong = Vec::new();
        let s = replay_driver(
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
        assert_eq!(s.mismatches, 1);
        assert_eq!(wrong, [12]);
        let leaked = edited_list(text, |l| (!l.starts_with("filter ")).then(|| l.into()));
        let got = DriverRun::new(
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
    fn another_actor_or_kind_of_model_is_refused() {
        let g = Golden {
            model: crate::S2D_GOLDENS[0].model,
            ..DRIVER_GOLDENS[0]
        };
        let got = DriverRun::new(&g, &mut Box::default()).map(|_| ());
        assert!(matches!(got, Err(Error::Model(_))), "{got:?}");
        // The procedural actor is not the one the driver was trained for.
        let g = Golden {
            model: crate::GOLDENS[0].model,
            ..DRIVER_GOLDENS[0]
        };
        let got = DriverRun::new(&g, &mut Box::default()).map(|_| ());
        assert!(matches!(got, Err(Error::Playback(_))), "{got:?}");
    }

    #[test]
    fn driver_costs_measure_every_phase() {
        let mut clock = 0u64;
        let c = driver_costs(&DRIVER_GOLDENS[0], 8, &mut Box::default(), || {
            clock += 1;
            clock
        })
        .unwrap();
        assert_eq!(
            c,
            DriverCosts {
                drive: 1,
                filter: 1,
                pose: 1,
                normals: 1,
                hash: 1
            }
        );
    }
}
