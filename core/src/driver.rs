//! A landmark driver: a small network per actor that maps one frame of a tracker's 68 landmarks
//! to the actor's pose in one forward pass (an amortised fit), as `sinew train driver` bakes it
//! (docs/FORMAT.md, "Driver"; docs/FIT.md, "Live driver").
//!
//! The input is the 68 iBUG landmarks of one frame, either in the image (`[68, 2]`, pixels
//! normalised by the camera's intrinsics, [`normalise_pixels`]) or in space (`[68, 3]`, in the
//! actor's unit). The output is a pose the actor plays: head 6D rotation + translation, jaw 6D
//! rotation + translation, then the `M` corrective coefficients (`[18 + M]`, the layout of a
//! replay frame). Per frame:
//!
//! `f = features(x)`, `x̂ = clamp((f − μ_in) ⊙ s_in, ±MAX_INPUT)`, `y = μ_out + s_out ⊙ F(x̂)`,
//!
//! where a 2D driver's features ([`features`]) separate where the face is and how large it looks
//! (what the head's translation and depth follow) from its shape: the landmarks centred on the
//! mean `c` of the steady landmarks (nose and eyes, [`STEADY`]) and divided by their spread `r`
//! (root mean square distance to `c`), then `c` and `ln r` (`[68 · 2 + 3]`); a 3D driver's are the
//! landmarks themselves. A camera sees a face of width w at depth z with a spread of about w / z,
//! so `ln r` is the depth's logarithm up to a constant the network learns.
//!
//! then each 6D rotation of `y` is made orthonormal ([`crate::rotation::from_6d`], whose
//! fallbacks make every value a rotation), each translation is clamped to ±`MAX_COORDINATE` and
//! each coefficient to ±`MAX_FACTOR`: every finite input gives a pose the actor accepts.
//!
//! Sections (names are the `pub const`s below):
//! - `drv.model`: `u32 [2]`, the actor's content hash ([`crate::replay::model_hash`]), low word
//!   first;
//! - `drv.lmk`: `u32 [68]`, the actor's vertex of each landmark;
//! - `drv.in`: `f32 [2, D]`, the features' mean `μ_in` and scale `s_in` (D = 139 or 204);
//! - `drv.out`: `f32 [2, 18 + M]`, the output's offset `μ_out` and scale `s_out`;
//! - the MLP `drv.net` ([`crate::network`]), D inputs and `18 + M` outputs.
//!
//! A 2D driver's metadata names its canonical camera (`camera=x,y,z`, the actor's unit and
//! frame): the centre of the pinhole camera the head's pose is relative to, looking along −z,
//! v down, so that a point `p` of the actor's frame is seen at `((p.x − x) / (z − p.z),
//! −(p.y − y) / (z − p.z))`, the normalised image coordinates the driver reads
//! ([`Driver::camera`], [`project`]). The calibration and the lost-frame rules of
//! [`crate::live`] see the driven face through it.

use crate::aim::{AimActor, MAX_SHAPES};
use crate::error::{
    Argument, Bound, BufferError, EvalError, FormatError, InputError, InputErrorKind,
};
use crate::filter::OneEuro;
use crate::format::{ArtifactKind, SinewFile, out_of_range};
use crate::hash::posed_frame_hash;
use crate::input::check_values;
use crate::layout::{MAX_COORDINATE, MAX_FACTOR};
use crate::linalg::Vec3;
use crate::network::{check_bound, load_mlp};
use crate::nn::Mlp;
use crate::replay::{AIM_POSE_LEN, ReplayError, model_hash};
use crate::rotation::{from_6d, to_6d};
use crate::tensor::{F32s, U32s};

/// The actor's content hash.
pub const MODEL_HASH: &str = "drv.model";
/// The actor's vertex of each landmark, `[68]`.
pub const LANDMARK_VERTICES: &str = "drv.lmk";
/// The input's mean and scale, `[2, D]`.
pub const INPUT_NORM: &str = "drv.in";
/// The output's offset and scale, `[2, 18 + M]`.
pub const OUTPUT_NORM: &str = "drv.out";
/// The prefix of the network.
pub const NETWORK: &str = "drv.net";

/// Landmarks per frame: the 68 iBUG points (OpenFace, dlib, OpenSeeFace).
pub const LANDMARKS: usize = 68;
/// A normalised input value is clamped to ± this (in units of the training spread), so that a
/// tracker's wild point cannot push the network outside the range it was bounded for.
pub const MAX_INPUT: f32 = 16.0;
/// The steady landmarks a 2D driver's features are centred on and scaled by: the nose (27–35)
/// and the eyes (36–47), which expressions hardly move.
pub const STEADY: core::ops::Range<usize> = 27..48;
/// A 2D driver's features beyond the landmarks: the centre's x and y and the spread's logarithm.
pub const EXTRA_FEATURES: usize = 3;
/// The smallest spread of the steady landmarks a 2D driver accepts (normalised image units: a
/// face a thousandth of the focal length across is no face).
pub const MIN_SPREAD: f32 = 1e-3;
/// The largest input scale a driver may carry (a landmark coordinate's training spread is at
/// least 1e-6 of its unit).
pub const MAX_INPUT_SCALE: f32 = 1e6;
/// The metadata key of a 2D driver's canonical camera centre (`x,y,z`, the actor's unit).
pub const CAMERA: &str = "camera";

/// The metadata key of the share of a 2D driver's own answer in the head's depth that the live
/// calibration takes (`crate::live`; docs/FIT.md, "The head's depth"): a number from 0 to 1,
/// 0 without the entry. A driver trained on trackers' conventions reads a face's depth through
/// them and records a share; one trained without them is fooled by a convention's spread and
/// records none, so its calibration finds the depth on the steady landmarks alone.
pub const CALIBRATION_DEPTH: &str = "calibration_depth";

/// Where a driver's landmarks live.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Space {
    /// In the image: `[68, 2]`, `((u − cx) / fx, (v − cy) / fy)` (v points down).
    Image,
    /// In space: `[68, 3]`, in the actor's unit and frame.
    World,
}

impl Space {
    /// Coordinates per landmark.
    pub const fn dims(self) -> usize {
        match self {
            Self::Image => 2,
            Self::World => 3,
        }
    }

    /// Features per frame the network reads ([`features`]): `68 · 2 + 3` or `68 · 3`.
    pub const fn features(self) -> usize {
        match self {
            Self::Image => 2 * LANDMARKS + EXTRA_FEATURES,
            Self::World => 3 * LANDMARKS,
        }
    }

    /// `2d` or `3d`, as `sinew train driver --input` names it.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Image => "2d",
            Self::World => "3d",
        }
    }
}

/// A validated landmark driver over the artefact's bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Driver<'a> {
    model_hash: u64,
    space: Space,
    shapes: usize,
    vertices: U32s<'a>,
    input: F32s<'a>,
    output: F32s<'a>,
    net: Mlp<'a>,
    camera: Option<Vec3>,
    calibration_depth: f32,
}

impl<'a> Driver<'a> {
    /// Validates `bytes` as a landmark driver.
    ///
    /// # Errors
    /// A [`FormatError`] for a bad container, another kind, a missing or misshapen section, a
    /// network whose width is neither 139 nor 204 inputs or whose outputs are not `18 + M`
    /// (`M` up to [`MAX_SHAPES`]), an input mean outside ±`MAX_COORDINATE`, an input scale not
    /// in (0, [`MAX_INPUT_SCALE`]], an output offset outside ±`MAX_COORDINATE`, an output scale
    /// outside ±`MAX_FACTOR`, a network that can exceed ±`MAX_NETWORK_VALUE` for inputs
    /// within ±[`MAX_INPUT`], or ([`FormatError::BadMetadata`]) a 2D driver without a
    /// `camera` entry, a `camera` entry that is not three numbers within ±`MAX_COORDINATE`, or
    /// a [`CALIBRATION_DEPTH`] entry that is not a number from 0 to 1.
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let file = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::Driver)?;
        let model = file.u32_tensor(MODEL_HASH, &[2])?;
        let vertices = file.u32_tensor(LANDMARK_VERTICES, &[LANDMARKS as u32])?;
        let net = load_mlp(&file, NETWORK)?;
        let space = match net.inputs() {
            n if n == Space::Image.features() => Space::Image,
            n if n == Space::World.features() => Space::World,
            _ => return Err(FormatError::incompatible_shapes(NETWORK)),
        };
        let outputs = net.outputs();
        if outputs <= AIM_POSE_LEN {
            return Err(FormatError::incompatible_shapes(NETWORK));
        }
        let shapes = outputs - AIM_POSE_LEN;
        if shapes > MAX_SHAPES {
            return Err(FormatError::limit_exceeded(NETWORK, shapes, MAX_SHAPES));
        }
        let d = net.inputs();
        let input = file.f32_tensor(INPUT_NORM, &[2, d as u32])?;
        for (i, v) in input.iter().enumerate() {
            let ok = if i < d {
                Bound::Coordinate.contains(v)
            } else {
                v > 0.0 && v <= MAX_INPUT_SCALE
            };
            if !ok {
                let bound = if i < d {
                    Bound::Coordinate
                } else {
                    Bound::PositiveFactor
                };
                return Err(out_of_range(INPUT_NORM, i, bound));
            }
        }
        let output = file.f32_tensor(OUTPUT_NORM, &[2, outputs as u32])?;
        for (i, v) in output.iter().enumerate() {
            let bound = if i < outputs {
                Bound::Coordinate
            } else {
                Bound::Factor
            };
            if !bound.contains(v) {
                return Err(out_of_range(OUTPUT_NORM, i, bound));
            }
        }
        check_bound(&net, NETWORK, f64::from(MAX_INPUT))?;
        let metadata = file.metadata();
        let camera = match metadata.get(CAMERA) {
            Some(text) => Some(parse_point(text).ok_or_else(|| metadata.bad_entry(CAMERA))?),
            None if space == Space::Image => return Err(metadata.bad_entry(CAMERA)),
            None => None,
        };
        let calibration_depth = match metadata.get(CALIBRATION_DEPTH) {
            Some(text) => text
                .trim()
                .parse::<f32>()
                .ok()
                .filter(|v| (0.0..=1.0).contains(v))
                .ok_or_else(|| metadata.bad_entry(CALIBRATION_DEPTH))?,
            None => 0.0,
        };
        Ok(Self {
            model_hash: u64::from(model.at(0)) | (u64::from(model.at(1)) << 32),
            space,
            shapes,
            vertices,
            input,
            output,
            net,
            camera,
            calibration_depth,
        })
    }

    /// The share of this driver's own answer in the head's depth that the live calibration
    /// takes ([`CALIBRATION_DEPTH`]; 0 without the entry).
    pub const fn calibration_depth(&self) -> f32 {
        self.calibration_depth
    }

    /// The canonical camera's centre (module documentation): always there for a 2D driver;
    /// a 3D driver may record one.
    pub const fn camera(&self) -> Option<Vec3> {
        self.camera
    }

    /// The content hash of the actor this driver was trained for.
    pub const fn model_hash(&self) -> u64 {
        self.model_hash
    }

    /// Where its landmarks live.
    pub const fn space(&self) -> Space {
        self.space
    }

    /// The actor's coefficient count M.
    pub const fn shape_count(&self) -> usize {
        self.shapes
    }

    /// Values per frame of input: `68 × 2` or `68 × 3`.
    pub fn input_len(&self) -> usize {
        LANDMARKS * self.space.dims()
    }

    /// Values of the pose [`Self::drive`] writes: `18 + M`.
    pub const fn output_len(&self) -> usize {
        AIM_POSE_LEN + self.shapes
    }

    /// The actor's vertex of landmark `l`, `None` past the 68.
    pub fn landmark_vertex(&self, l: usize) -> Option<usize> {
        (l < LANDMARKS).then(|| self.vertices.at(l) as usize)
    }

    /// The network.
    pub const fn network(&self) -> &Mlp<'a> {
        &self.net
    }

    /// Scratch values [`Self::drive`] needs: the normalised features and the network's own.
    pub fn scratch_len(&self) -> usize {
        self.space.features() + self.net.scratch_len()
    }

    /// Checks that this driver was trained for the actor whose bytes are `model_bytes`.
    ///
    /// # Errors
    /// [`ReplayError::WrongModel`]; [`ReplayError::ShapeCount`]; [`ReplayError::PointCount`]
    /// when a landmark vertex is not a vertex of the actor (`performance` is then one past the
    /// largest landmark vertex).
    pub fn check_actor(&self, model_bytes: &[u8], actor: &AimActor<'_>) -> Result<(), ReplayError> {
        let found = model_hash(model_bytes);
        if found != self.model_hash {
            return Err(ReplayError::WrongModel {
                expected: self.model_hash,
                found,
            });
        }
        if actor.shape_count() != self.shapes {
            return Err(ReplayError::ShapeCount {
                replay: self.shapes,
                actor: actor.shape_count(),
            });
        }
        let largest = self.vertices.iter().max().unwrap_or(0) as usize;
        if largest >= actor.vertex_count() {
            return Err(ReplayError::PointCount {
                performance: largest + 1,
                actor: actor.vertex_count(),
            });
        }
        Ok(())
    }

    /// One frame's landmarks to the actor's pose: head `[0..9]`, jaw `[9..18]` (6D rotation +
    /// translation each), coefficients `[18..18 + M]` (module documentation).
    ///
    /// # Shapes
    /// - `landmarks`: `[68, 2]` or `[68, 3]` ([`Self::input_len`])
    /// - `scratch`: at least [`Self::scratch_len`]
    /// - `pose`: `[18 + M]` ([`Self::output_len`])
    ///
    /// # Errors
    /// [`BufferError`] for a wrong length; [`EvalError::Input`] naming
    /// [`Argument::Landmarks`] and the value for a landmark that is NaN, infinite or outside
    /// ±`MAX_COORDINATE`, or (index 0, `Degenerate`) 2D landmarks whose steady ones spread less
    /// than [`MIN_SPREAD`] (nothing is written then).
    pub fn drive(
        &self,
        landmarks: &[f32],
        scratch: &mut [f32],
        pose: &mut [f32],
    ) -> Result<(), EvalError> {
        let d = self.input_len();
        if landmarks.len() != d {
            return Err(BufferError::Input.into());
        }
        if pose.len() != self.output_len() {
            return Err(BufferError::Output.into());
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch.into());
        }
        let f = self.space.features();
        let (x, rest) = scratch.split_at_mut(f);
        features(self.space, landmarks, x)?;
        for (i, x) in x.iter_mut().enumerate() {
            let v = (*x - self.input.at(i)) * self.input.at(f + i);
            *x = v.clamp(-MAX_INPUT, MAX_INPUT);
        }
        self.net.eval(x, pose, rest)?;
        let p = self.output_len();
        for (i, y) in pose.iter_mut().enumerate() {
            *y = self.output.at(i) + self.output.at(p + i) * *y;
        }
        finish_pose(pose);
        Ok(())
    }

    /// The 68 landmarks of the actor's posed `positions` (`[V, 3]`) into `out` (`[68, 3]`).
    ///
    /// # Errors
    /// [`BufferError::Output`] if `out` is not `[68, 3]`, [`BufferError::Input`] if a landmark
    /// vertex is not one of `positions`'.
    pub fn landmarks_of(&self, positions: &[f32], out: &mut [f32]) -> Result<(), BufferError> {
        if out.len() != 3 * LANDMARKS {
            return Err(BufferError::Output);
        }
        for (o, v) in out.chunks_exact_mut(3).zip(self.vertices.iter()) {
            let at = 3 * v as usize;
            let p = positions.get(at..at + 3).ok_or(BufferError::Input)?;
            o.copy_from_slice(p);
        }
        Ok(())
    }
}

/// Three comma-separated numbers within ±`MAX_COORDINATE` (the `camera` entry), parsed with
/// `core`'s correctly rounded `f32` parser, which reads back the bits the host wrote.
fn parse_point(text: &str) -> Option<Vec3> {
    let mut values = text.split(',').map(|v| v.trim().parse::<f32>().ok());
    let mut next = || {
        values
            .next()
            .flatten()
            .filter(|v| Bound::Coordinate.contains(*v))
    };
    let point = Vec3::new(next()?, next()?, next()?);
    values.next().is_none().then_some(point)
}

/// Where the canonical camera at `camera` sees the point `p` of the actor's frame, in
/// normalised image coordinates `((p.x − c.x) / d, −(p.y − c.y) / d)`, `d = c.z − p.z` held at
/// least `min_depth` (a point at or behind the camera is seen as if at that depth, so that
/// every finite point projects to finite coordinates).
pub fn project(camera: Vec3, p: Vec3, min_depth: f32) -> [f32; 2] {
    let depth = camera.z - p.z;
    let depth = if depth >= min_depth { depth } else { min_depth };
    [(p.x - camera.x) / depth, -(p.y - camera.y) / depth]
}

/// A frame's landmarks (`[68 × dims]`) as a driver of `space` reads them, into `out`
/// (`[space.features()]`; module documentation): for 2D, `(x − c) / r` per landmark, then `c`
/// and `ln r`, with `c` the mean and `r` the root mean square distance to it of the [`STEADY`]
/// landmarks; for 3D, the landmarks. The host trains on exactly these values.
///
/// # Errors
/// [`BufferError`] for a wrong length; [`EvalError::Input`] naming [`Argument::Landmarks`] for
/// a value that is NaN, infinite or outside ±`MAX_COORDINATE`, or (index 0, `Degenerate`) a
/// spread below [`MIN_SPREAD`].
pub fn features(space: Space, landmarks: &[f32], out: &mut [f32]) -> Result<(), EvalError> {
    if landmarks.len() != LANDMARKS * space.dims() {
        return Err(BufferError::Input.into());
    }
    if out.len() != space.features() {
        return Err(BufferError::Output.into());
    }
    check_values(Argument::Landmarks, landmarks)?;
    if space == Space::World {
        out.copy_from_slice(landmarks);
        return Ok(());
    }
    let steady = landmarks
        .get(2 * STEADY.start..2 * STEADY.end)
        .unwrap_or(&[]);
    let n = STEADY.len() as f32;
    let (mut cx, mut cy) = (0.0f32, 0.0f32);
    for p in steady.chunks_exact(2) {
        if let [x, y] = p {
            cx += *x;
            cy += *y;
        }
    }
    (cx, cy) = (cx / n, cy / n);
    let mut sq = 0.0f32;
    for p in steady.chunks_exact(2) {
        if let [x, y] = p {
            sq += (*x - cx) * (*x - cx) + (*y - cy) * (*y - cy);
        }
    }
    let r = libm::sqrtf(sq / n);
    // Also refuses a NaN spread, which finite landmarks within ±MAX_COORDINATE cannot give.
    if r.is_nan() || r < MIN_SPREAD {
        return Err(InputError::new(Argument::Landmarks, 0, InputErrorKind::Degenerate).into());
    }
    let (shape, extra) = out.split_at_mut(2 * LANDMARKS);
    for (o, p) in shape.chunks_exact_mut(2).zip(landmarks.chunks_exact(2)) {
        if let ([ox, oy], [x, y]) = (o, p) {
            *ox = (*x - cx) / r;
            *oy = (*y - cy) / r;
        }
    }
    for (o, v) in extra.iter_mut().zip([cx, cy, libm::logf(r)]) {
        *o = v;
    }
    Ok(())
}

/// A driven pose made one the actor accepts: both 6D rotations orthonormal, translations within
/// ±`MAX_COORDINATE`, coefficients within ±`MAX_FACTOR`. Finite values only change where they
/// were out of reach; the rotations always pass through Gram–Schmidt.
pub fn finish_pose(pose: &mut [f32]) {
    for half in [0usize, 9] {
        if let Some(nine) = pose.get_mut(half..half + 9) {
            let r: [f32; 6] = core::array::from_fn(|i| nine.get(i).copied().unwrap_or(0.0));
            let r = to_6d(&from_6d(&r));
            for (o, v) in nine.iter_mut().zip(r) {
                *o = v;
            }
            for t in nine.iter_mut().skip(6) {
                *t = finite_clamp(*t, MAX_COORDINATE);
            }
        }
    }
    for w in pose.iter_mut().skip(AIM_POSE_LEN) {
        *w = finite_clamp(*w, MAX_FACTOR);
    }
}

/// `v` within ±`limit`; NaN becomes 0.
fn finite_clamp(v: f32, limit: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-limit, limit)
    }
}

/// A pinhole camera's intrinsics in pixels: focal lengths and principal point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal length along u.
    pub fx: f32,
    /// Focal length along v.
    pub fy: f32,
    /// Principal point u.
    pub cx: f32,
    /// Principal point v.
    pub cy: f32,
}

/// A tracker's pixels `[68, 2]` (`[u, v]`, v down) as a 2D driver reads them:
/// `((u − cx) / fx, (v − cy) / fy)`.
///
/// # Errors
/// [`BufferError`] for a wrong length; [`EvalError::Input`] naming [`Argument::Landmarks`] for
/// a pixel that is not finite or outside ±`MAX_COORDINATE`, or naming the intrinsics' value
/// (as `landmarks[136 + i]`, i: fx, fy, cx, cy) for a focal length that is not positive or a
/// value that is not finite.
pub fn normalise_pixels(
    pixels: &[f32],
    camera: &Intrinsics,
    out: &mut [f32],
) -> Result<(), EvalError> {
    if pixels.len() != 2 * LANDMARKS {
        return Err(BufferError::Input.into());
    }
    if out.len() != 2 * LANDMARKS {
        return Err(BufferError::Output.into());
    }
    check_values(Argument::Landmarks, pixels)?;
    let k = [camera.fx, camera.fy, camera.cx, camera.cy];
    for (i, &v) in k.iter().enumerate() {
        crate::input::check_value(Argument::Landmarks, 2 * LANDMARKS + i, v)?;
        if i < 2 && v <= 0.0 {
            return Err(crate::error::InputError::new(
                Argument::Landmarks,
                2 * LANDMARKS + i,
                crate::error::InputErrorKind::OutOfRange,
            )
            .into());
        }
    }
    for (o, p) in out.chunks_exact_mut(2).zip(pixels.chunks_exact(2)) {
        if let ([ox, oy], [u, v]) = (o, p) {
            *ox = (*u - camera.cx) / camera.fx;
            *oy = (*v - camera.cy) / camera.fy;
        }
    }
    Ok(())
}

/// The caller's buffers for one driven frame.
#[derive(Debug)]
pub struct DriveBuffers<'b> {
    /// At least [`Driver::scratch_len`].
    pub scratch: &'b mut [f32],
    /// `[18 + M]`: the driven pose.
    pub pose: &'b mut [f32],
    /// `[V, 3]`: the posed positions.
    pub positions: &'b mut [f32],
    /// `[V, 3]`: their normals.
    pub normals: &'b mut [f32],
}

/// Drives `actor` with one frame's `landmarks` ([`Driver::drive`]), poses it, computes its
/// normals and returns the frame's f32 hash (the positions, then the normals, as an f32 replay
/// frame's): the step of every target's driver loop. Call [`Driver::check_actor`] once first.
///
/// # Errors
/// As [`Driver::drive`] and [`AimActor::pose`].
pub fn drive_frame_hash(
    driver: &Driver<'_>,
    actor: &AimActor<'_>,
    landmarks: &[f32],
    buf: &mut DriveBuffers<'_>,
) -> Result<u64, EvalError> {
    driver.drive(landmarks, buf.scratch, buf.pose)?;
    pose_hash(actor, buf.pose, buf.positions, buf.normals)
}

/// Poses `actor` with a driven `pose` ([`play`]) into `positions`, computes its `normals` and
/// returns their f32 hash (positions then normals, an f32 replay frame's hash).
///
/// # Errors
/// As [`play`] and [`AimActor::normals`].
pub fn pose_hash(
    actor: &AimActor<'_>,
    pose: &[f32],
    positions: &mut [f32],
    normals: &mut [f32],
) -> Result<u64, EvalError> {
    play(actor, pose, positions)?;
    actor.normals(positions, normals)?;
    Ok(posed_frame_hash(positions, normals))
}

/// Smooths a driven `pose` (`[18 + M]`, [`Driver::drive`]'s) taken at `time` seconds with the
/// One Euro `filter` ([`OneEuro::apply_at`], `state` of
/// [`OneEuro::timed_state_len`]`(18 + M)`, zeros to reset), then makes it a pose the actor
/// accepts again ([`finish_pose`]: the filtered 6D rotations made orthonormal).
///
/// # Errors
/// [`BufferError::Input`] for a pose shorter than 18 values; [`EvalError::Input`] naming
/// [`Argument::Head`], [`Argument::Jaw`] or [`Argument::Weights`] and the value for a pose value
/// that is NaN, infinite or out of the range posing accepts (a driven pose never is); as
/// [`OneEuro::apply_at`]: a state of another length, or a time stamp refused. Nothing changes
/// then.
pub fn filter_pose(
    filter: &OneEuro,
    state: &mut [f32],
    time: f32,
    pose: &mut [f32],
) -> Result<(), EvalError> {
    let (head_jaw, weights) = pose
        .split_at_checked(AIM_POSE_LEN)
        .ok_or(BufferError::Input)?;
    let (head, jaw) = head_jaw.split_at(9);
    check_values(Argument::Head, head)?;
    check_values(Argument::Jaw, jaw)?;
    check_values(Argument::Weights, weights)?;
    filter.apply_at(state, time, pose)?;
    finish_pose(pose);
    Ok(())
}

/// Poses `actor` with a driven pose (`[18 + M]`: head, jaw, coefficients) into `out` (`[V, 3]`).
///
/// # Errors
/// [`BufferError::Input`] if `pose` is not `18 + M` long; as [`AimActor::pose`].
pub fn play(actor: &AimActor<'_>, pose: &[f32], out: &mut [f32]) -> Result<(), EvalError> {
    if pose.len() != AIM_POSE_LEN + actor.shape_count() {
        return Err(BufferError::Input.into());
    }
    let (head_jaw, weights) = pose.split_at(AIM_POSE_LEN);
    let head: [f32; 9] = core::array::from_fn(|i| head_jaw.get(i).copied().unwrap_or(0.0));
    let jaw: [f32; 9] = core::array::from_fn(|i| head_jaw.get(9 + i).copied().unwrap_or(0.0));
    let built = actor.pose_from_9d(&jaw, &head)?;
    actor.pose(&built, weights, out)
}
