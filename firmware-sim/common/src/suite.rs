//! Every golden a target plays, as suites a firmware loops over in one way: the AIM replays
//! ([`Replay`]), the S2D replay ([`S2dRun`]), the fitted performance ([`PerformanceRun`]) and
//! the generated sequence ([`MotionRun`]), the driven track ([`DriverRun`]) and the live run
//! ([`LiveRun`]),
//! each started with [`Run::new`], described for the log by its `Display` and played frame by
//! frame as an iterator.

use core::fmt;

use crate::driver::{DRIVER_GOLDENS, DriverRun};
use crate::live::{LIVE_GOLDENS, LiveRun};
use crate::motion::{MOTION_GOLDENS, MotionRun};
use crate::performance::{PERFORMANCE_GOLDENS, PerformanceRun};
use crate::s2d::S2dRun;
use crate::{Error, FrameCheck, GOLDENS, Golden, Replay, S2D_GOLDENS, Scratch};

/// A kind of golden.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Suite {
    /// The AIM actors' replays ([`GOLDENS`]).
    Aim,
    /// The S2D decoder's replay ([`S2D_GOLDENS`]).
    S2d,
    /// The fitted performance ([`PERFORMANCE_GOLDENS`]).
    Performance,
    /// The generated sequence ([`MOTION_GOLDENS`]).
    Motion,
    /// The live driver's track ([`DRIVER_GOLDENS`]).
    Driver,
    /// The live track through the calibration and the lost-frame rules ([`LIVE_GOLDENS`]).
    Live,
}

impl Suite {
    /// Every suite, in the order the targets play them.
    pub const ALL: [Self; 6] = [
        Self::Aim,
        Self::S2d,
        Self::Performance,
        Self::Motion,
        Self::Driver,
        Self::Live,
    ];

    /// The suite's goldens.
    pub const fn goldens(self) -> &'static [Golden] {
        match self {
            Self::Aim => &GOLDENS,
            Self::S2d => &S2D_GOLDENS,
            Self::Performance => &PERFORMANCE_GOLDENS,
            Self::Motion => &MOTION_GOLDENS,
            Self::Driver => &DRIVER_GOLDENS,
            Self::Live => &LIVE_GOLDENS,
        }
    }

    /// What its frames are called in the log's totals.
    pub const fn frames_label(self) -> &'static str {
        match self {
            Self::Aim => "AIM replay frames",
            Self::S2d => "S2D frames",
            Self::Performance => "fitted-performance frames",
            Self::Motion => "generated-sequence frames",
            Self::Driver => "driven-track checks",
            Self::Live => "live-track checks",
        }
    }
}

/// A golden in progress, of any suite.
// One run lives at a time, on the stack; boxing the larger variants would need an allocator.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum Run<'s> {
    /// An AIM replay.
    Aim(Replay<'s>),
    /// An S2D replay.
    S2d(S2dRun<'s>),
    /// A fitted performance.
    Performance(PerformanceRun<'s>),
    /// A generated sequence.
    Motion(MotionRun<'s>),
    /// A driven track.
    Driver(DriverRun<'s>),
    /// A live track.
    Live(LiveRun<'s>),
}

impl<'s> Run<'s> {
    /// Validates and starts `golden` of `suite` in `scratch`.
    pub fn new(suite: Suite, golden: &Golden, scratch: &'s mut Scratch) -> Result<Self, Error> {
        Ok(match suite {
            Suite::Aim => Self::Aim(Replay::new(golden, scratch)?),
            Suite::S2d => Self::S2d(S2dRun::new(golden, scratch)?),
            Suite::Performance => Self::Performance(PerformanceRun::new(golden, scratch)?),
            Suite::Motion => Self::Motion(MotionRun::new(golden, scratch)?),
            Suite::Driver => Self::Driver(DriverRun::new(golden, scratch)?),
            Suite::Live => Self::Live(LiveRun::new(golden, scratch)?),
        })
    }
}

/// The log's description: sizes and frames (`scripts/firmware_costs.py` reads it).
impl fmt::Display for Run<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Aim(r) => write!(
                f,
                "{} vertices, {} shapes, {} frames",
                r.actor().vertex_count(),
                r.actor().shape_count(),
                r.replay().frames()
            ),
            Self::S2d(r) => write!(
                f,
                "{} vertices, {} inputs, {} frames, {} buffer values",
                r.decoder().vertex_count(),
                r.decoder().input_len(),
                r.replay().frames(),
                r.needed()
            ),
            Self::Performance(r) => write!(
                f,
                "{} vertices, {} shapes, {} frames",
                r.actor().vertex_count(),
                r.actor().shape_count(),
                r.performance().frames()
            ),
            Self::Motion(r) => write!(
                f,
                "{} vertices, {} landmarks, {} frames, {} buffer values, label {} seed {}",
                r.sequence().decoder().vertex_count(),
                r.sequence().input_len() / 3,
                sinew_core::srvf::FRAMES,
                r.sequence().buffer_len(),
                r.hashes().label,
                r.hashes().seed
            ),
            Self::Driver(r) => write!(
                f,
                "{} vertices, {} shapes, {} landmarks, {} frames, 4 checks a frame (pose, frame, \
                 filtered-pose, filtered-frame)",
                r.actor().vertex_count(),
                r.actor().shape_count(),
                sinew_core::driver::LANDMARKS,
                r.rows()
            ),
            Self::Live(r) => {
                let s = r.settings();
                write!(
                    f,
                    "{} vertices, {} shapes, {} frames, calibrating on {}, 3 checks a frame \
                     (outcome, pose, frame)",
                    r.actor().vertex_count(),
                    r.actor().shape_count(),
                    r.rows(),
                    s.calibrate_frames
                )
            }
        }
    }
}

impl Iterator for Run<'_> {
    type Item = Result<FrameCheck, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        match self {
            Self::Aim(r) => r.next(),
            Self::S2d(r) => r.next(),
            Self::Performance(r) => r.next(),
            Self::Motion(r) => r.next(),
            Self::Driver(r) => r.next(),
            Self::Live(r) => r.next(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::boxed::Box;
    use std::format;

    #[test]
    fn every_suite_plays_through_one_loop() {
        let mut scratch = Box::<Scratch>::default();
        for suite in Suite::ALL {
            assert!(!suite.goldens().is_empty(), "{suite:?}");
            for golden in suite.goldens() {
                let run = Run::new(suite, golden, &mut scratch).unwrap();
                let said = format!("{run}");
                assert!(
                    said.contains("vertices") && said.contains("frames"),
                    "{said}"
                );
                let mut frames = 0;
                for check in run {
                    assert!(check.unwrap().ok(), "{}", golden.name);
                    frames += 1;
                }
                assert!(frames >= 4, "{}", golden.name);
            }
        }
    }
}
