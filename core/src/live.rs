//! Driving an actor live from a real tracker (docs/FIT.md, "Live driving"): the calibration
//! every live tool asks for ("look at the camera with a neutral face") and the rules that tell a
//! frame the tracker lost or misread, over a state the caller keeps, as the One Euro filter's
//! ([`crate::filter`]).
//!
//! **Calibration.** A tracker follows its annotators' convention (the lips' visible contour, the
//! brows' upper edge, the jaw's silhouette), not the actor's landmark vertices the driver was
//! trained on. The first [`Settings::calibrate_frames`] found frames are taken as the face at
//! rest: for each, the head pose is found that best places the actor's steady rest landmarks
//! (nose and eyes, where trackers agree) on the tracker's (`head`: Gauss–Newton from the
//! driver's answer to the raw landmarks, through the driver's canonical camera in 2D,
//! [`crate::driver::Driver::camera`]; its depth then taken part of the way toward the driver's
//! answer where the driver records a share, [`crate::driver::Driver::calibration_depth`]), the
//! actor's rest landmarks are placed under it, and the
//! difference to the tracker's landmarks is carried into the face's frame (2D: each image
//! difference lifted to the landmark's depth). Their mean is the tracker's convention, one offset
//! per landmark in the actor's unit. From then on each frame's head is found the same way, the
//! offsets are placed under it (2D: and seen by the camera) and taken off the landmarks, and the
//! driver reads what is left. Frames before the calibration completes are written at rest.
//!
//! **Lost frames.** A frame is lost when no pose of the actor explains its landmarks: the
//! driven pose's landmarks (the actor's landmark vertices posed by it, seen by the camera) lie
//! further from the (calibrated) track than [`Settings::max_residual`], in units of the face's
//! size in the image; or when the face's centre moves, or the head turns, faster since the last
//! found frame than a head does ([`Settings::max_speed`], [`Settings::max_turn`]). A lost frame
//! holds the last accepted pose. A run of jumps is ended by a frame back within reach of the
//! held pose, or, after [`Settings::reacquire`] seconds, by the next frame the residual accepts
//! (the head really moved while the tracker was unsure). Lengths are in units of the actor's
//! face size: the root mean square distance of the steady rest landmarks (nose and eyes,
//! [`crate::driver::STEADY`]) from their centre, 3.5 cm on the ICT actor.
//!
//! Deterministic as the rest of the core: the caller's time stamps, never a clock; the state in
//! the caller's buffer (zeros: a session that has seen nothing); libm only, in index order.

use crate::aim::AimActor;
use crate::driver::{Driver, LANDMARKS, STEADY, Space, project};
use crate::error::{Argument, BufferError, EvalError, InputError, InputErrorKind};
use crate::input::check_value;
use crate::layout::{MAX_COORDINATE, MAX_FACTOR};
use crate::linalg::{Rigid, Vec3};
use crate::replay::AIM_POSE_LEN;
use crate::rotation::from_6d;
use crate::skinning::skin_vertex;
use crate::tensor::F32s;

mod settings;
pub use settings::{
    DEFAULT_MAX_RESIDUAL, DEFAULT_MAX_SPEED, DEFAULT_MAX_TURN, DEFAULT_REACQUIRE, Lost,
    MAX_CALIBRATION_FRAMES, Outcome, Settings,
};

// The state's layout: a few scalars, the offsets, then the held pose.
/// Found frames taken into the calibration so far.
const TAKEN: usize = 0;
/// 1 once a frame was stepped.
const STARTED: usize = 1;
/// The last frame's time stamp.
const LAST_TIME: usize = 2;
/// 1 once a frame was found.
const FOUND: usize = 3;
/// The last found frame's time stamp.
const FOUND_TIME: usize = 4;
/// 1 once a pose was accepted (then [`HELD`] holds it).
const ACCEPTED: usize = 5;
/// 1 during a run of lost frames.
const LOST: usize = 6;
/// The first lost frame's time stamp of the run.
const LOST_SINCE: usize = 7;
/// During the calibration the sum of the offsets' squares; then their root mean square
/// deviation from the mean, in face sizes.
const DEVIATION: usize = 8;
/// The last found frame's residual ([`Live::residual`]) once calibrated; 0 before.
const RESIDUAL: usize = 9;
/// 1 once [`REFERENCE`] holds a head.
const HAS_REFERENCE: usize = 10;
/// `[9]`: the head the next found frame's is compared with for jumps: the last accepted pose's,
/// or, before any, the calibration's last frame driven with the completed calibration.
const REFERENCE: usize = 11;
/// `[68, 3]`: the offsets' sum during the calibration, then their mean (the actor's unit, the
/// face's frame).
const OFFSETS: usize = 20;
/// `[18 + M]`: the last accepted pose.
const HELD: usize = OFFSETS + 3 * LANDMARKS;

mod head;

/// The rest pose's head and jaw: the identity, no translation.
const REST_9: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];

/// A driver and its actor under live settings: everything [`Live::step`] needs that does not
/// change from frame to frame. Cheap to make (it reads the 68 rest landmarks); it borrows both.
#[derive(Clone, Copy, Debug)]
pub struct Live<'d, 'a> {
    driver: &'d Driver<'a>,
    actor: &'d AimActor<'a>,
    settings: Settings,
    /// The canonical camera (a 3D driver's is unused).
    camera: Vec3,
    /// The nearest a point is seen from the camera (points nearer are seen at this depth).
    min_depth: f32,
    /// The rest landmarks' centre.
    centre: Vec3,
    /// The actor's face size ([module documentation](self)).
    size: f32,
}

impl<'d, 'a> Live<'d, 'a> {
    /// `driver` driving `actor` (for which [`Driver::check_actor`] passed) under `settings`.
    ///
    /// # Errors
    /// [`EvalError::Input`] for settings [`Settings::check`] refuses; [`BufferError::Input`]
    /// when the actor has another coefficient count than the driver or lacks a landmark vertex.
    pub fn new(
        driver: &'d Driver<'a>,
        actor: &'d AimActor<'a>,
        settings: Settings,
    ) -> Result<Self, EvalError> {
        settings.check()?;
        let fits = (0..LANDMARKS).all(|l| {
            driver
                .landmark_vertex(l)
                .is_some_and(|v| v < actor.vertex_count())
        });
        if !fits || actor.shape_count() != driver.shape_count() {
            return Err(BufferError::Input.into());
        }
        let rest = |l: usize| rest_landmark(driver, actor, l);
        let mean = |range: core::ops::Range<usize>| {
            let n = range.len() as f32;
            let sum = range.fold(Vec3::ZERO, |s, l| s + rest(l));
            sum.scale(1.0 / n)
        };
        let centre = mean(0..LANDMARKS);
        let steady = mean(STEADY);
        let sq = STEADY.fold(0.0f32, |s, l| {
            let d = rest(l) - steady;
            s + d.dot(d)
        });
        let size = libm::sqrtf(sq / STEADY.len() as f32);
        let camera = driver.camera().unwrap_or(Vec3::ZERO);
        let distance = libm::fabsf(camera.z - centre.z);
        Ok(Self {
            driver,
            actor,
            settings,
            camera,
            min_depth: if distance > 0.0 {
                1e-2 * distance
            } else {
                1e-6
            },
            centre,
            size: if size > 1e-6 { size } else { 1e-6 },
        })
    }

    /// The settings.
    pub const fn settings(&self) -> Settings {
        self.settings
    }

    /// The actor's face size, in its unit ([module documentation](self)).
    pub const fn face_size(&self) -> f32 {
        self.size
    }

    /// The state's length: 20 values, the 68 offsets (3 each), the held pose (`18 + M`). A state
    /// of zeros has seen nothing.
    pub const fn state_len(&self) -> usize {
        Self::state_len_of(self.driver)
    }

    /// [`Self::state_len`] of any live driving of `driver` (it depends on the driver alone).
    pub const fn state_len_of(driver: &Driver<'_>) -> usize {
        HELD + driver.output_len()
    }

    /// Scratch values [`Self::step`] needs: the driver's, the corrected landmarks, two poses.
    pub fn scratch_len(&self) -> usize {
        self.driver.scratch_len() + 3 * LANDMARKS + 2 * self.driver.output_len()
    }

    /// The residual of the last found frame driven ([`Self::residual`]), lost or not; 0 before
    /// one was.
    pub fn last_residual(&self, state: &[f32]) -> f32 {
        value(state, RESIDUAL)
    }

    /// Found frames taken into the calibration so far (at most [`Settings::calibrate_frames`]).
    pub fn calibrated_frames(&self, state: &[f32]) -> u32 {
        state.get(TAKEN).copied().unwrap_or(0.0) as u32
    }

    /// Once the calibration is complete, the root mean square deviation of its frames' offsets
    /// from their mean, in face sizes: the tracker's noise and the driver's error at rest on a
    /// calibration made at rest, more when the face moved ([`Self::deviation`] names the
    /// frames). `None` before, or without a calibration.
    pub fn calibration_deviation(&self, state: &[f32]) -> Option<f32> {
        let n = self.settings.calibrate_frames;
        (n > 0 && self.calibrated_frames(state) >= n)
            .then(|| state.get(DEVIATION).copied())
            .flatten()
    }

    /// The calibration's offset of landmark `l` (`[3]`, the actor's unit, the face's frame):
    /// the tracker's convention there. `None` before the calibration completes or past the 68.
    pub fn offset(&self, state: &[f32], l: usize) -> Option<[f32; 3]> {
        let n = self.settings.calibrate_frames;
        if n == 0 || self.calibrated_frames(state) < n {
            return None;
        }
        let at = state.get(OFFSETS + 3 * l..OFFSETS + 3 * l + 3)?;
        Some(core::array::from_fn(|c| at.get(c).copied().unwrap_or(0.0)))
    }

    /// How far one frame's offsets lie from the completed calibration's mean, in face sizes
    /// (root mean square over the landmarks): what tells a calibration frame where the face was
    /// not at rest. `Ok(None)` before the calibration completes.
    ///
    /// # Errors
    /// As [`Driver::drive`]; [`BufferError`] for a state or scratch of the wrong length.
    pub fn deviation(
        &self,
        state: &[f32],
        landmarks: &[f32],
        scratch: &mut [f32],
    ) -> Result<Option<f32>, EvalError> {
        if state.len() != self.state_len() {
            return Err(BufferError::Scratch.into());
        }
        if self.calibration_deviation(state).is_none() {
            return Ok(None);
        }
        let buffers = self.split(scratch)?;
        self.driver.drive(landmarks, buffers.driver, buffers.raw)?;
        let head = self.head(landmarks, head_of(buffers.raw));
        let mut sq = 0.0f32;
        for l in 0..LANDMARKS {
            let d = self.frame_offset(landmarks, &head, l) - stored(state, l);
            sq += d.dot(d);
        }
        Ok(Some(libm::sqrtf(sq / LANDMARKS as f32) / self.size))
    }

    /// One frame's landmarks less the completed calibration's offsets, as [`Self::step`] gives
    /// them to the driver (the landmarks as they are before the calibration completes, or
    /// without one), into `out` ([`Driver::input_len`]).
    ///
    /// # Errors
    /// As [`Driver::drive`]; [`BufferError`] for a buffer of the wrong length.
    pub fn calibrated(
        &self,
        state: &[f32],
        landmarks: &[f32],
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        if state.len() != self.state_len() {
            return Err(BufferError::Scratch.into());
        }
        if out.len() != landmarks.len() {
            return Err(BufferError::Output.into());
        }
        let buffers = self.split(scratch)?;
        self.driver.drive(landmarks, buffers.driver, buffers.raw)?;
        if self.calibration_deviation(state).is_none() {
            out.copy_from_slice(landmarks);
            return Ok(());
        }
        let head = self.head(landmarks, head_of(buffers.raw));
        self.correct(state, landmarks, &head, out);
        Ok(())
    }

    /// One frame, taken at `time` seconds: its landmarks as the driver reads them (`None`
    /// when the tracker found no face) → the pose to play (`[18 + M]`), the calibration and the
    /// lost-frame rules applied ([module documentation](self)), and what became of the frame.
    ///
    /// # Shapes
    /// - `state`: [`Self::state_len`] (zeros to start)
    /// - `landmarks`: [`Driver::input_len`]
    /// - `scratch`: at least [`Self::scratch_len`]
    /// - `pose`: [`Driver::output_len`]
    ///
    /// # Errors
    /// [`BufferError`] for a wrong length; [`EvalError::Input`] naming [`Argument::Time`] for a
    /// time stamp that is not finite, outside ±`MAX_COORDINATE` or less than 1 ms after the last
    /// frame's, and as [`Driver::drive`] for landmarks it refuses (also once calibrated: the
    /// landmarks less the offsets). Nothing changes then.
    pub fn step(
        &self,
        state: &mut [f32],
        landmarks: Option<&[f32]>,
        time: f32,
        scratch: &mut [f32],
        pose: &mut [f32],
    ) -> Result<Outcome, EvalError> {
        if state.len() != self.state_len() {
            return Err(BufferError::Scratch.into());
        }
        if pose.len() != self.driver.output_len() {
            return Err(BufferError::Output.into());
        }
        check_value(Argument::Time, 0, time)?;
        if flag(state, STARTED) {
            let dt = time - value(state, LAST_TIME);
            if dt.is_nan() || dt < 1.0 / MAX_FACTOR {
                return Err(InputError::new(Argument::Time, 0, InputErrorKind::Degenerate).into());
            }
        }
        let buffers = self.split(scratch)?;
        let outcome = match landmarks {
            None => Outcome::Missing,
            Some(landmarks) => self.found(state, landmarks, time, buffers)?,
        };
        set(state, STARTED, 1.0);
        set(state, LAST_TIME, time);
        if landmarks.is_some() {
            set(state, FOUND, 1.0);
            set(state, FOUND_TIME, time);
        }
        match state.get(HELD..) {
            Some(held) if flag(state, ACCEPTED) => pose.copy_from_slice(held),
            _ => rest_pose(pose),
        }
        Ok(outcome)
    }

    /// A found frame: taken into the calibration, or driven and judged. Every fallible step
    /// comes before the state changes.
    fn found(
        &self,
        state: &mut [f32],
        landmarks: &[f32],
        time: f32,
        b: Buffers<'_>,
    ) -> Result<Outcome, EvalError> {
        self.driver.drive(landmarks, b.driver, b.raw)?;
        let head = self.head(landmarks, head_of(b.raw));
        let n = self.settings.calibrate_frames;
        let taken = self.calibrated_frames(state);
        if taken < n {
            self.calibrate(state, landmarks, &head, taken + 1);
            if taken + 1 == n {
                // The jumps' first reference: this frame driven as the calibration reads it
                // (a frame whose corrected landmarks the driver refuses leaves none).
                let corrected = b.landmarks.get_mut(..landmarks.len());
                if let Some(corrected) = corrected {
                    self.correct(state, landmarks, &head, corrected);
                    if self.driver.drive(corrected, b.driver, b.candidate).is_ok() {
                        set_reference(state, b.candidate);
                    }
                }
            }
            return Ok(Outcome::Calibrating);
        }
        let corrected = b
            .landmarks
            .get_mut(..landmarks.len())
            .ok_or(BufferError::Scratch)?;
        if n > 0 {
            self.correct(state, landmarks, &head, corrected);
        } else {
            corrected.copy_from_slice(landmarks);
        }
        self.driver.drive(corrected, b.driver, b.candidate)?;
        let s = &self.settings;
        let residual = self.residual(b.candidate, corrected)?;
        set(state, RESIDUAL, residual);
        let lost = if s.max_residual > 0.0 && residual > s.max_residual {
            Some(Lost::Residual)
        } else if self.jumped(state, b.candidate, time) {
            let waited = time - value(state, LOST_SINCE);
            let reacquired = flag(state, LOST) && s.reacquire > 0.0 && waited >= s.reacquire;
            (!reacquired).then_some(Lost::Jump)
        } else {
            None
        };
        Ok(match lost {
            Some(why) => {
                if !flag(state, LOST) {
                    set(state, LOST, 1.0);
                    set(state, LOST_SINCE, time);
                }
                Outcome::Lost(why)
            }
            None => {
                if let Some(held) = state.get_mut(HELD..) {
                    held.copy_from_slice(b.candidate);
                }
                set_reference(state, b.candidate);
                set(state, ACCEPTED, 1.0);
                set(state, LOST, 0.0);
                Outcome::Driven
            }
        })
    }

    /// Takes one frame into the calibration (`taken` frames with it), completing it at the last.
    fn calibrate(&self, state: &mut [f32], landmarks: &[f32], head: &Rigid, taken: u32) {
        let mut sq = value(state, DEVIATION);
        for l in 0..LANDMARKS {
            let d = self.frame_offset(landmarks, head, l);
            sq += d.dot(d);
            if let Some(sum) = state.get_mut(OFFSETS + 3 * l..OFFSETS + 3 * l + 3) {
                for (s, v) in sum.iter_mut().zip(d.to_array()) {
                    *s += v;
                }
            }
        }
        set(state, DEVIATION, sq);
        set(state, TAKEN, taken as f32);
        if taken < self.settings.calibrate_frames {
            return;
        }
        // Complete: the sums become means, the squares the deviation about them.
        let n = taken as f32;
        let mut mean_sq = 0.0f32;
        if let Some(offsets) = state.get_mut(OFFSETS..HELD) {
            for v in offsets.iter_mut() {
                *v /= n;
                mean_sq += *v * *v;
            }
        }
        let per = sq / (n * LANDMARKS as f32) - mean_sq / LANDMARKS as f32;
        let deviation = libm::sqrtf(if per > 0.0 { per } else { 0.0 }) / self.size;
        set(state, DEVIATION, deviation);
    }

    /// This frame's offset of landmark `l`, in the face's frame (the actor's unit): the
    /// tracker's landmark less the rest landmark under the driven `head`, turned back by it
    /// (2D: the image difference lifted to the rest landmark's depth). Within ±`MAX_COORDINATE`.
    fn frame_offset(&self, landmarks: &[f32], head: &Rigid, l: usize) -> Vec3 {
        let rest = rest_landmark(self.driver, self.actor, l);
        let at = head.rot.mul_vec(rest) + head.trans;
        let seen = match self.driver.space() {
            Space::Image => {
                let [u, v] = project(self.camera, at, self.min_depth);
                let depth = self.depth(at);
                let (x, y) = (
                    coordinate(landmarks, 2 * l),
                    coordinate(landmarks, 2 * l + 1),
                );
                Vec3::new((x - u) * depth, -(y - v) * depth, 0.0)
            }
            Space::World => {
                let p = Vec3::new(
                    coordinate(landmarks, 3 * l),
                    coordinate(landmarks, 3 * l + 1),
                    coordinate(landmarks, 3 * l + 2),
                );
                p - at
            }
        };
        let d = head.rot.transpose().mul_vec(seen);
        Vec3::new(clamp(d.x), clamp(d.y), clamp(d.z))
    }

    /// The landmarks less the calibrated offsets, placed under the raw frame's `head` (2D:
    /// seen by the camera), into `out`, each value within ±`MAX_COORDINATE`.
    fn correct(&self, state: &[f32], landmarks: &[f32], head: &Rigid, out: &mut [f32]) {
        let dims = self.driver.space().dims();
        for l in 0..LANDMARKS {
            let moved = head.rot.mul_vec(stored(state, l));
            let shift = match self.driver.space() {
                Space::Image => {
                    let at =
                        head.rot.mul_vec(rest_landmark(self.driver, self.actor, l)) + head.trans;
                    let [u0, v0] = project(self.camera, at, self.min_depth);
                    let [u1, v1] = project(self.camera, at + moved, self.min_depth);
                    [u1 - u0, v1 - v0, 0.0]
                }
                Space::World => moved.to_array(),
            };
            for c in 0..dims {
                if let Some(o) = out.get_mut(dims * l + c) {
                    let v =
                        coordinate(landmarks, dims * l + c) - shift.get(c).copied().unwrap_or(0.0);
                    *o = clamp(v);
                }
            }
        }
    }

    /// The root mean square distance between `pose`'s landmarks (the actor's landmark vertices
    /// posed, 2D: seen by the camera) and `landmarks` (as the driver read them: see
    /// [`Self::calibrated`]), in face sizes (2D: the landmarks' own steady spread in the image):
    /// what [`Settings::max_residual`] bounds.
    ///
    /// # Errors
    /// [`BufferError::Input`] for a pose shorter than 18 values; [`EvalError::Input`] for a pose
    /// the actor refuses (a driven pose never is).
    pub fn residual(&self, pose: &[f32], landmarks: &[f32]) -> Result<f32, EvalError> {
        let (head_jaw, weights) = pose
            .split_at_checked(AIM_POSE_LEN)
            .ok_or(BufferError::Input)?;
        let nine = |at: usize| -> [f32; 9] {
            core::array::from_fn(|i| head_jaw.get(at + i).copied().unwrap_or(0.0))
        };
        let built = self.actor.pose_from_9d(&nine(9), &nine(0))?;
        let m = self.actor.shape_count();
        let mut sq = 0.0f32;
        for l in 0..LANDMARKS {
            let v = self.driver.landmark_vertex(l).unwrap_or(0);
            let rest = rest_landmark(self.driver, self.actor, l);
            let k = self.actor.skinning_weights().at(v);
            let e = self.actor.correctives().slice(3 * m * v, 3 * m);
            let p = skin_vertex(rest, k, e, weights, &built);
            sq += match self.driver.space() {
                Space::Image => {
                    let [u, v] = project(self.camera, p, self.min_depth);
                    let du = u - coordinate(landmarks, 2 * l);
                    let dv = v - coordinate(landmarks, 2 * l + 1);
                    du * du + dv * dv
                }
                Space::World => {
                    let q = Vec3::new(
                        coordinate(landmarks, 3 * l),
                        coordinate(landmarks, 3 * l + 1),
                        coordinate(landmarks, 3 * l + 2),
                    );
                    let d = p - q;
                    d.dot(d)
                }
            };
        }
        let size = match self.driver.space() {
            Space::Image => image_spread(landmarks),
            Space::World => self.size,
        };
        Ok(libm::sqrtf(sq / LANDMARKS as f32) / size)
    }

    /// Whether `pose`'s head moved or turned faster than a head does since the last found
    /// frame, against the reference head (never before there is one).
    fn jumped(&self, state: &[f32], pose: &[f32], time: f32) -> bool {
        let s = &self.settings;
        if !flag(state, HAS_REFERENCE)
            || !flag(state, FOUND)
            || (s.max_speed <= 0.0 && s.max_turn <= 0.0)
        {
            return false;
        }
        let dt = time - value(state, FOUND_TIME);
        let held = head_of(state.get(REFERENCE..REFERENCE + 9).unwrap_or(&[]));
        let now = head_of(pose);
        let a = held.rot.mul_vec(self.centre) + held.trans;
        let b = now.rot.mul_vec(self.centre) + now.trans;
        let moved = (b - a).norm() / self.size;
        let r = held.rot.transpose().mul_mat(&now.rot);
        let trace = r.cols[0].x + r.cols[1].y + r.cols[2].z;
        let cos = ((trace - 1.0) * 0.5).clamp(-1.0, 1.0);
        let turned = libm::acosf(cos);
        (s.max_speed > 0.0 && moved > s.max_speed * dt)
            || (s.max_turn > 0.0 && turned > s.max_turn * dt)
    }

    /// The head that best places the steady rest landmarks on `landmarks`' ([`head::fit`]),
    /// from `start`.
    fn head(&self, landmarks: &[f32], start: Rigid) -> Rigid {
        let rest: [Vec3; STEADY.end - STEADY.start] =
            core::array::from_fn(|i| rest_landmark(self.driver, self.actor, STEADY.start + i));
        let dims = self.driver.space().dims();
        let seen = |i: usize| -> [f32; 3] {
            let at = dims * (STEADY.start + i);
            core::array::from_fn(|c| {
                if c < dims {
                    coordinate(landmarks, at + c)
                } else {
                    0.0
                }
            })
        };
        let view = match self.driver.space() {
            Space::Image => head::View::Camera {
                centre: self.camera,
                min_depth: self.min_depth,
            },
            Space::World => head::View::Space,
        };
        let fitted = head::fit(view, &rest, seen, start);
        let share = self.driver.calibration_depth();
        if share <= 0.0 || !matches!(self.driver.space(), Space::Image) {
            return fitted;
        }
        // In an image the steady landmarks' spread gives the head's depth, and a tracker whose
        // eyes sit off the actor's eyelids moves it (MediaPipe's by a centimetre); a driver
        // trained on conventions reads the depth from all 68 points through them. The depth of
        // the steady landmarks' centre is taken between the two, a weighted geometric mean with
        // the driver's share, the fitted head slid along its line of sight to it.
        let mut c = Vec3::ZERO;
        for &p in &rest {
            c = c + p;
        }
        c = c * (1.0 / rest.len() as f32);
        let at_fit = fitted.rot.mul_vec(c) + fitted.trans;
        let at_raw = start.rot.mul_vec(c) + start.trans;
        let scale = libm::powf(self.depth(at_raw) / self.depth(at_fit), share);
        if !scale.is_finite() {
            return fitted;
        }
        let moved = self.camera + (at_fit - self.camera) * scale;
        Rigid::new(fitted.rot, moved - fitted.rot.mul_vec(c))
    }

    /// A point's depth in front of the camera, at least the smallest.
    fn depth(&self, p: Vec3) -> f32 {
        let d = self.camera.z - p.z;
        if d >= self.min_depth {
            d
        } else {
            self.min_depth
        }
    }

    /// The scratch cut into its parts.
    fn split<'s>(&self, scratch: &'s mut [f32]) -> Result<Buffers<'s>, BufferError> {
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch);
        }
        let p = self.driver.output_len();
        let (driver, rest) = scratch.split_at_mut(self.driver.scratch_len());
        let (landmarks, rest) = rest.split_at_mut(3 * LANDMARKS);
        let (raw, rest) = rest.split_at_mut(p);
        let candidate = rest.get_mut(..p).ok_or(BufferError::Scratch)?;
        Ok(Buffers {
            driver,
            landmarks,
            raw,
            candidate,
        })
    }
}

/// The parts of [`Live::step`]'s scratch.
struct Buffers<'s> {
    driver: &'s mut [f32],
    landmarks: &'s mut [f32],
    raw: &'s mut [f32],
    candidate: &'s mut [f32],
}

/// The head of a pose (`[0..9]`: 6D rotation, translation); missing values read as zero.
fn head_of(pose: &[f32]) -> Rigid {
    let at = |i: usize| pose.get(i).copied().unwrap_or(0.0);
    Rigid::new(
        from_6d(&core::array::from_fn(at)),
        Vec3::new(at(6), at(7), at(8)),
    )
}

/// The rest position of landmark `l`: the actor's cached neutral skin s0 at its vertex.
fn rest_landmark(driver: &Driver<'_>, actor: &AimActor<'_>, l: usize) -> Vec3 {
    let v = driver.landmark_vertex(l).unwrap_or(0);
    let s0: F32s<'_> = actor.rest();
    Vec3::new(s0.at(3 * v), s0.at(3 * v + 1), s0.at(3 * v + 2))
}

/// Makes `pose`'s head (`[0..9]`) the reference for jumps.
fn set_reference(state: &mut [f32], pose: &[f32]) {
    if let (Some(r), Some(head)) = (state.get_mut(REFERENCE..REFERENCE + 9), pose.get(..9)) {
        r.copy_from_slice(head);
        set(state, HAS_REFERENCE, 1.0);
    }
}

/// The calibrated offset of landmark `l` in `state` (zero past its end).
fn stored(state: &[f32], l: usize) -> Vec3 {
    let at = |c: usize| value(state, OFFSETS + 3 * l + c);
    Vec3::new(at(0), at(1), at(2))
}

/// The root mean square distance of 2D landmarks' steady ones from their centre.
fn image_spread(landmarks: &[f32]) -> f32 {
    let n = STEADY.len() as f32;
    let (mut cx, mut cy) = (0.0f32, 0.0f32);
    for l in STEADY {
        cx += coordinate(landmarks, 2 * l);
        cy += coordinate(landmarks, 2 * l + 1);
    }
    (cx, cy) = (cx / n, cy / n);
    let mut sq = 0.0f32;
    for l in STEADY {
        let (dx, dy) = (
            coordinate(landmarks, 2 * l) - cx,
            coordinate(landmarks, 2 * l + 1) - cy,
        );
        sq += dx * dx + dy * dy;
    }
    let r = libm::sqrtf(sq / n);
    if r > 1e-6 { r } else { 1e-6 }
}

/// Writes the rest pose: the identity head and jaw, no coefficient.
fn rest_pose(pose: &mut [f32]) {
    for (i, p) in pose.iter_mut().enumerate() {
        *p = if i < AIM_POSE_LEN {
            REST_9.get(i % 9).copied().unwrap_or(0.0)
        } else {
            0.0
        };
    }
}

fn coordinate(values: &[f32], i: usize) -> f32 {
    values.get(i).copied().unwrap_or(0.0)
}

fn value(state: &[f32], i: usize) -> f32 {
    state.get(i).copied().unwrap_or(0.0)
}

fn flag(state: &[f32], i: usize) -> bool {
    value(state, i) != 0.0
}

fn set(state: &mut [f32], i: usize, v: f32) {
    if let Some(s) = state.get_mut(i) {
        *s = v;
    }
}

/// `v` within ±`MAX_COORDINATE`; NaN becomes 0.
fn clamp(v: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-MAX_COORDINATE, MAX_COORDINATE)
    }
}

#[cfg(test)]
mod tests;
