//! Live driving's settings ([`Settings`], their defaults) and what becomes of a frame
//! ([`Outcome`]).

use crate::error::{Argument, InputError, InputErrorKind};
use crate::input::check_value;

/// The most frames a calibration may take ([`Settings::calibrate_frames`]).
pub const MAX_CALIBRATION_FRAMES: u32 = 1000;

/// Live driving's settings; a limit of 0 turns its rule off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Found frames taken as the face at rest looking at the camera (0: no calibration).
    pub calibrate_frames: u32,
    /// The largest residual of a found frame: the root mean square distance between the
    /// track's landmarks and the driven pose's, in units of the face's size in the image (2D:
    /// the steady landmarks' spread in the frame; 3D: the actor's face size).
    pub max_residual: f32,
    /// The fastest the face's centre moves, in face sizes per second.
    pub max_speed: f32,
    /// The fastest the head turns, in radians per second.
    pub max_turn: f32,
    /// Seconds after which a run of frames lost to a jump is taken as the head's real motion.
    pub reacquire: f32,
}

impl Settings {
    /// No calibration, no lost-frame rule: every found frame is driven as it is.
    pub const OFF: Self = Self {
        calibrate_frames: 0,
        max_residual: 0.0,
        max_speed: 0.0,
        max_turn: 0.0,
        reacquire: 0.0,
    };

    /// The lost-frame rules' defaults (docs/FIT.md, "Live driving", where they were measured),
    /// calibrating on `calibrate_frames` frames.
    pub const fn defaults(calibrate_frames: u32) -> Self {
        Self {
            calibrate_frames,
            max_residual: DEFAULT_MAX_RESIDUAL,
            max_speed: DEFAULT_MAX_SPEED,
            max_turn: DEFAULT_MAX_TURN,
            reacquire: DEFAULT_REACQUIRE,
        }
    }

    /// The settings as the values [`Argument::Live`] indexes: frames, residual, speed, turn,
    /// reacquire.
    pub fn values(&self) -> [f32; 5] {
        [
            self.calibrate_frames as f32,
            self.max_residual,
            self.max_speed,
            self.max_turn,
            self.reacquire,
        ]
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`InputError`] naming [`Argument::Live`] and the value ([`Self::values`]' index) for a
    /// value that is not finite or outside `[0, MAX_FACTOR]`, or a frame count above
    /// [`MAX_CALIBRATION_FRAMES`].
    pub fn check(&self) -> Result<(), InputError> {
        for (i, v) in self.values().into_iter().enumerate() {
            check_value(Argument::Live, i, v)?;
        }
        if self.calibrate_frames > MAX_CALIBRATION_FRAMES {
            return Err(InputError::new(
                Argument::Live,
                0,
                InputErrorKind::OutOfRange,
            ));
        }
        Ok(())
    }
}

/// The default [`Settings::max_residual`]: above the largest residual measured on clean tracks
/// with up to 4 px of landmark noise (0.17, docs/FIT.md "Live driving").
pub const DEFAULT_MAX_RESIDUAL: f32 = 0.2;
/// The default [`Settings::max_speed`]: 40 face sizes a second, 1.4 m/s on the ICT actor (a
/// head's quick turn is well below 1 m/s; a face misread as 12 % smaller jumps 8 cm in a frame).
pub const DEFAULT_MAX_SPEED: f32 = 40.0;
/// The default [`Settings::max_turn`], radians a second (a quick shake of the head stays below
/// 5).
pub const DEFAULT_MAX_TURN: f32 = 8.0;
/// The default [`Settings::reacquire`], seconds.
pub const DEFAULT_REACQUIRE: f32 = 0.5;

/// What became of one frame ([`super::Live::step`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Outcome {
    /// Taken into the calibration; the pose written is the rest pose.
    Calibrating,
    /// Driven and accepted; the pose written is the frame's.
    Driven,
    /// Found but lost; the pose written is the last accepted one (the rest pose before any).
    Lost(Lost),
    /// No landmarks (the tracker found no face); the pose written is the last accepted one.
    Missing,
}

/// Why a found frame is lost.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Lost {
    /// The driven pose's landmarks lie further from the track than
    /// [`Settings::max_residual`].
    Residual,
    /// The face moved or turned faster than a head does.
    Jump,
}

impl Outcome {
    /// The outcome as a number (the C ABI's and the wasm package's): 0 driven, 1 calibrating,
    /// 2 missing, 3 lost to the residual, 4 lost to a jump.
    pub const fn code(self) -> u32 {
        match self {
            Self::Driven => 0,
            Self::Calibrating => 1,
            Self::Missing => 2,
            Self::Lost(Lost::Residual) => 3,
            Self::Lost(Lost::Jump) => 4,
        }
    }

    /// The outcome in a word: `driven`, `calibrating`, `missing`, `lost-residual`,
    /// `lost-jump`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Driven => "driven",
            Self::Calibrating => "calibrating",
            Self::Missing => "missing",
            Self::Lost(Lost::Residual) => "lost-residual",
            Self::Lost(Lost::Jump) => "lost-jump",
        }
    }
}
