//! A landmark driver (`sinew train driver`) that owns its bytes, bound to the AIM actor it was
//! trained for: a tracker's pixels through the camera's intrinsics, one frame's landmarks to the
//! actor's pose ([`CoreDriver::drive`]), the One Euro filter stepped at the caller's time stamps
//! with the caller's state ([`sinew_core::driver::filter_pose`]), and the pose played and hashed
//! as every target does it ([`sinew_core::driver::pose_hash`]).

use self_cell::self_cell;
use sinew_core::aim::AimActor;
use sinew_core::driver::{self, Driver as CoreDriver, Intrinsics, LANDMARKS};
use sinew_core::error::Argument;
use sinew_core::filter::OneEuro;
use sinew_core::live::{Live, Settings};

use crate::error::{Error, Refused};
use crate::model::{Kind, Model, ModelInner, check_len};

self_cell!(
    struct DriverCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: CoreDriver,
    }
    impl {Debug}
);

/// A validated landmark driver that owns its bytes.
#[derive(Debug)]
pub struct Driver {
    cell: DriverCell,
    vertices: usize,
}

/// The names the JavaScript API gives the core's arguments in the driver's calls.
const NAMES: &[(Argument, &str)] = &[
    (Argument::Weights, "coefficients"),
    (Argument::Live, "settings"),
];

/// One frame of live driving ([`Driver::live_step`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LiveFrame {
    /// What became of the frame ([`sinew_core::live::Outcome::code`]).
    pub outcome: u32,
    /// The pose to play.
    pub pose: Vec<f32>,
    /// Found frames the calibration has taken.
    pub calibrated: u32,
    /// The calibration's deviation once complete (face sizes), else -1.
    pub deviation: f32,
    /// The last found frame's residual (face sizes).
    pub residual: f32,
}

impl Driver {
    /// Validates `bytes` as a landmark driver and checks it against `model`, the actor it was
    /// trained for ([`CoreDriver::check_actor`]: content hash, coefficients, landmark vertices).
    ///
    /// # Errors
    /// The core's [`sinew_core::FormatError`] message (`WrongKind` with the kind found for
    /// another artefact), an S2D decoder, or another actor.
    pub fn load(bytes: Vec<u8>, model: &Model) -> Result<Self, Error> {
        let file = sinew_core::format::SinewFile::from_bytes(&bytes)?;
        if file.kind != sinew_core::format::ArtifactKind::Driver {
            return Err(Error::new(format!(
                "{} ({}, not a landmark driver)",
                sinew_core::FormatError::WrongKind,
                file.kind
            )));
        }
        let cell = DriverCell::try_new(bytes.into_boxed_slice(), |b| {
            CoreDriver::from_bytes(b).map_err(Error::from)
        })?;
        let ModelInner::Aim(actor_cell) = &model.inner else {
            return Err(aim(model)
                .err()
                .unwrap_or_else(|| Error::new("not an AIM actor")));
        };
        let actor = actor_cell.borrow_dependent();
        cell.borrow_dependent()
            .check_actor(actor_cell.borrow_owner(), actor)
            .map_err(|e| Error::new(format!("driver does not fit this actor: {e}")))?;
        let vertices = actor.vertex_count();
        Ok(Self { cell, vertices })
    }

    fn core(&self) -> &CoreDriver<'_> {
        self.cell.borrow_dependent()
    }

    /// `"2d"` or `"3d"`: where its landmarks live.
    pub fn space(&self) -> &'static str {
        self.core().space().name()
    }

    /// Values of one frame's landmarks: 68 × 2 or 68 × 3.
    pub fn input_len(&self) -> usize {
        self.core().input_len()
    }

    /// Values of a pose: 18 + M.
    pub fn pose_len(&self) -> usize {
        self.core().output_len()
    }

    /// The actor's coefficients M.
    pub fn shape_count(&self) -> usize {
        self.core().shape_count()
    }

    /// The content hash of the actor it was trained for.
    pub fn model_hash(&self) -> u64 {
        self.core().model_hash()
    }

    /// Values of the filter's state ([`OneEuro::timed_state_len`] of the pose).
    pub fn filter_state_len(&self) -> usize {
        OneEuro::timed_state_len(self.pose_len())
    }

    /// The actor of `model`, checked to be this driver's (content hash, vertices).
    fn actor<'m>(&self, model: &'m Model) -> Result<&'m AimActor<'m>, Error> {
        let actor = aim(model)?;
        if model.content_hash() != self.model_hash() || actor.vertex_count() != self.vertices {
            return Err(Error::new(format!(
                "driver was trained for the actor {:016x}, this model is {:016x}",
                self.model_hash(),
                model.content_hash()
            )));
        }
        Ok(actor)
    }

    /// A tracker's 68 `[u, v]` pixels through `camera` (fx, fy, cx, cy) as a 2D driver reads
    /// them ([`driver::normalise_pixels`]).
    ///
    /// # Errors
    /// Lengths; an `InputError` naming `pixels[i]`, or `camera[i]` for intrinsics that are not
    /// finite or a focal length that is not positive.
    pub fn pixels(pixels: &[f32], camera: &[f32]) -> Result<Vec<f32>, Error> {
        check_len("pixels", pixels.len(), 2 * LANDMARKS)?;
        check_len("camera", camera.len(), 4)?;
        let [fx, fy, cx, cy] = [0, 1, 2, 3].map(|i| camera.get(i).copied().unwrap_or(0.0));
        let mut out = vec![0.0; 2 * LANDMARKS];
        driver::normalise_pixels(pixels, &Intrinsics { fx, fy, cx, cy }, &mut out).map_err(
            |e| match e {
                sinew_core::EvalError::Input(mut i) => {
                    // The core names both as its one argument; JavaScript passes two.
                    let name = if i.index < 2 * LANDMARKS {
                        "pixels"
                    } else {
                        i.index -= 2 * LANDMARKS;
                        "camera"
                    };
                    let rest = i.to_string();
                    let rest = rest.split_once(']').map_or("", |(_, r)| r);
                    let mut err = Error::new(format!("{name}[{}]{rest}", i.index));
                    err.input = Some(Refused {
                        argument: name,
                        index: i.index,
                    });
                    err
                }
                e => e.into(),
            },
        )?;
        Ok(out)
    }

    /// One frame's landmarks to the actor's pose: head (9), jaw (9), coefficients (M).
    ///
    /// # Errors
    /// A wrong length; an `InputError` naming `landmarks[i]`.
    pub fn pose(&self, landmarks: &[f32]) -> Result<Vec<f32>, Error> {
        check_len("landmarks", landmarks.len(), self.input_len())?;
        let mut scratch = vec![0.0; self.core().scratch_len()];
        let mut pose = vec![0.0; self.pose_len()];
        self.core()
            .drive(landmarks, &mut scratch, &mut pose)
            .map_err(|e| Error::eval(e, NAMES))?;
        Ok(pose)
    }

    /// Filters `pose` taken at `time` seconds with the One Euro filter of `settings`
    /// (min cutoff, beta, d cutoff), updating `state` ([`Self::filter_state_len`], zeros to
    /// reset).
    ///
    /// # Errors
    /// Lengths; an `InputError` naming `filter[i]`, `time[0]` (not 1 ms after the last) or a
    /// pose value (`head`, `jaw`, `coefficients`). Nothing changes then.
    pub fn filter(
        &self,
        settings: &[f32],
        time: f32,
        state: &mut [f32],
        pose: &mut [f32],
    ) -> Result<(), Error> {
        check_len("filter", settings.len(), 3)?;
        check_len("state", state.len(), self.filter_state_len())?;
        check_len("pose", pose.len(), self.pose_len())?;
        let [min_cutoff, beta, d_cutoff] =
            [0, 1, 2].map(|i| settings.get(i).copied().unwrap_or(0.0));
        // The time-stamped step takes its rate from the stamps; 1 Hz only fills the setting.
        let filter = OneEuro::new(min_cutoff, beta, d_cutoff, 1.0)?;
        driver::filter_pose(&filter, state, time, pose).map_err(|e| Error::eval(e, NAMES))
    }

    /// Values of live driving's state ([`Live::state_len_of`]).
    pub fn live_state_len(&self) -> usize {
        Live::state_len_of(self.core())
    }

    /// One frame of live driving on `model` (this driver's actor) under `settings` (calibrate
    /// frames, max residual, max speed, max turn, reacquire: [`Settings`]): `landmarks` (or
    /// `None`: no face) at `time` seconds, updating `state` ([`Self::live_state_len`], zeros to
    /// start) ([`Live::step`]).
    ///
    /// # Errors
    /// Another model; lengths; an `InputError` naming `settings[i]` (a value not finite, outside
    /// `[0, 1e3]`, or a frame count above 1000 or not whole), `time[0]` or `landmarks[i]`.
    /// Nothing changes then.
    pub fn live_step(
        &self,
        model: &Model,
        settings: &[f32],
        landmarks: Option<&[f32]>,
        time: f32,
        state: &mut [f32],
    ) -> Result<LiveFrame, Error> {
        let actor = self.actor(model)?;
        check_len("settings", settings.len(), 5)?;
        let [frames, max_residual, max_speed, max_turn, reacquire] =
            [0, 1, 2, 3, 4].map(|i| settings.get(i).copied().unwrap_or(0.0));
        // A frame count is a whole number; the core checks its range.
        let whole = frames.is_finite() && frames >= 0.0 && frames == (frames as u32) as f32;
        if !whole {
            let kind = if frames.is_finite() {
                sinew_core::error::InputErrorKind::OutOfRange
            } else {
                sinew_core::error::InputErrorKind::NonFinite
            };
            let e = sinew_core::InputError::new(Argument::Live, 0, kind);
            return Err(Error::eval(e.into(), NAMES));
        }
        let settings = Settings {
            calibrate_frames: frames as u32,
            max_residual,
            max_speed,
            max_turn,
            reacquire,
        };
        let live = Live::new(self.core(), actor, settings).map_err(|e| Error::eval(e, NAMES))?;
        check_len("state", state.len(), live.state_len())?;
        if let Some(l) = landmarks {
            check_len("landmarks", l.len(), self.input_len())?;
        }
        let mut scratch = vec![0.0; live.scratch_len()];
        let mut pose = vec![0.0; self.pose_len()];
        let outcome = live
            .step(state, landmarks, time, &mut scratch, &mut pose)
            .map_err(|e| Error::eval(e, NAMES))?;
        Ok(LiveFrame {
            outcome: outcome.code(),
            pose,
            calibrated: live.calibrated_frames(state),
            deviation: live.calibration_deviation(state).unwrap_or(-1.0),
            residual: live.last_residual(state),
        })
    }

    /// `model` (this driver's actor) posed by `pose`: positions, x y z per vertex.
    ///
    /// # Errors
    /// Another model; a wrong length; a refused pose value.
    pub fn play(&self, model: &Model, pose: &[f32]) -> Result<Vec<f32>, Error> {
        let actor = self.actor(model)?;
        check_len("pose", pose.len(), self.pose_len())?;
        let mut out = vec![0.0; 3 * actor.vertex_count()];
        driver::play(actor, pose, &mut out).map_err(|e| Error::eval(e, NAMES))?;
        Ok(out)
    }

    /// The frame hash of `model` posed by `pose`: positions then normals
    /// ([`driver::pose_hash`]).
    ///
    /// # Errors
    /// As [`Self::play`].
    pub fn frame_hash(&self, model: &Model, pose: &[f32]) -> Result<u64, Error> {
        let actor = self.actor(model)?;
        check_len("pose", pose.len(), self.pose_len())?;
        let mut positions = vec![0.0; 3 * actor.vertex_count()];
        let mut normals = vec![0.0; positions.len()];
        driver::pose_hash(actor, pose, &mut positions, &mut normals)
            .map_err(|e| Error::eval(e, NAMES))
    }
}

/// The AIM actor of `model`, or why a driver cannot drive it.
fn aim(model: &Model) -> Result<&AimActor<'_>, Error> {
    match &model.inner {
        ModelInner::Aim(cell) => Ok(cell.borrow_dependent()),
        ModelInner::S2d { .. } => Err(Error::new(format!(
            "a driver drives {}, this model is {}",
            Kind::Aim.long_name(),
            model.kind().long_name()
        ))),
    }
}
