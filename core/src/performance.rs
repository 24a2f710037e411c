//! A fitted performance (AIM Sec. 4.2): the per-frame inputs that play a baked actor through a
//! captured sequence, as `sinew fit` bakes them (docs/FORMAT.md, "Performance").
//!
//! Per frame j the file holds the head and jaw transforms (`T_g`, `T_b`, 6D rotation +
//! translation each) and the corrective coefficients, in one of two forms:
//! - **global** (the paper's "(G)"): one vector `w_j ∈ R^M` per frame, played with
//!   [`AimActor::pose`] exactly as a replay frame is;
//! - **local**: a frame code `z_j ∈ R^f` and the network `F_W`, evaluated here at every template
//!   point c: `w_j(c) = F_W(z_j, ĉ)` (AIM eq. 19), with `ĉ = (c − centre) / half` the template
//!   point in the fit's normalised box. Then `s*(c) = T_g(LBS(s0, T_b, k) + Σ w_j(c) B_e)`
//!   (AIM eq. 17) per vertex.
//!
//! Sections (names are the `pub const`s below):
//! - `perf.model`: `u32 [2]`, the actor's content hash ([`crate::replay::model_hash`]), low word first;
//! - `perf.pose`: `f32 [J, 18]`, head 6D + translation, then jaw 6D + translation;
//! - global: `perf.w`: `f32 [J, M]`;
//! - local: `perf.z`: `f32 [J, f]`; `perf.box`: `f32 [4]` (centre x, y, z, half extent); the MLP
//!   `perf.fw` ([`crate::network`]) with `f + 3` inputs and `M` outputs;
//! - optional `perf.hash`: `u32 [J, 2]`, each frame's f32 hash ([`play_frame_hash`]) as baked;
//! - optional, local only: `perf.points`: `f32 [V, 3]`, the template points `F_W` is evaluated
//!   at when they are not the actor's own: a performance retargeted from another actor in
//!   correspondence (AIM Sec. 5.4) evaluates `w_j(c)` at the source actor's points, where the fit
//!   learned it, and plays it on the target's vertices of the same index.

use crate::aim::{AimActor, MAX_SHAPES};
use crate::error::{Argument, Bound, BufferError, EvalError, FormatError};
use crate::format::{ArtifactKind, SinewFile, out_of_range};
use crate::hash::posed_frame_hash;
use crate::layout::MAX_COORDINATE;
use crate::linalg::Vec3;
use crate::network::{check_bound, load_mlp};
use crate::nn::Mlp;
use crate::replay::{AIM_POSE_LEN, FrameCheck, ReplayError, model_hash};
use crate::rotation::try_rigid_from_9d;
use crate::skinning::skin_vertex;
use crate::tensor::{F32s, U32s};

/// The actor's content hash.
pub const MODEL_HASH: &str = "perf.model";
/// Per-frame head and jaw, `[J, 18]`.
pub const POSES: &str = "perf.pose";
/// Per-frame global coefficients, `[J, M]`.
pub const WEIGHTS: &str = "perf.w";
/// Per-frame codes of a local fit, `[J, f]`.
pub const CODES: &str = "perf.z";
/// The normalisation of template points of a local fit: centre x, y, z and half extent.
pub const BOX: &str = "perf.box";
/// The prefix of F_W, the local coefficient network.
pub const F_W: &str = "perf.fw";
/// Per-frame f32 hashes, `[J, 2]` (optional).
pub const HASHES: &str = "perf.hash";
/// The points `F_W` is evaluated at, `[V, 3]` (optional, local only; default: the actor's
/// template).
pub const POINTS: &str = "perf.points";

/// Longest frame code this build accepts.
pub const MAX_CODE: usize = 1024;

/// How a performance's coefficients vary.
// The local variant holds F_W's layers inline (no allocation in the core); a performance has one.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Coefficients<'a> {
    /// One vector per frame, `[J, M]`.
    Global(F32s<'a>),
    /// `w_j(c) = F_W(z_j, ĉ)`.
    Local {
        /// The codes, `[J, f]`.
        codes: F32s<'a>,
        /// f.
        code_len: usize,
        /// The template box's centre.
        centre: [f32; 3],
        /// Its half extent (positive).
        half: f32,
        /// F_W: `f + 3` inputs, `M` outputs.
        fw: Mlp<'a>,
        /// The points F_W is evaluated at (`[V, 3]`), when not the actor's template.
        points: Option<F32s<'a>>,
    },
}

/// A validated fitted performance over the artefact's bytes.
#[derive(Clone, Debug, PartialEq)]
pub struct Performance<'a> {
    model_hash: u64,
    frames: usize,
    shapes: usize,
    poses: F32s<'a>,
    coefficients: Coefficients<'a>,
    hashes: Option<U32s<'a>>,
}

impl<'a> Performance<'a> {
    /// Validates `bytes` as a fitted performance.
    ///
    /// # Errors
    /// A [`FormatError`] for a bad container, another kind, a missing or misshapen section,
    /// neither or both coefficient forms, no frames, a code or coefficient count over this
    /// build's limits, or a value outside its bound (docs/FORMAT.md, "Value bounds"): a head or
    /// jaw the actor would refuse ([`AimActor::pose_from_9d`]), a global coefficient or a frame
    /// code outside ±[`crate::layout::MAX_FACTOR`], a box or point outside ±[`MAX_COORDINATE`]
    /// (the half extent positive), or an F_W that can exceed
    /// ±[`crate::layout::MAX_NETWORK_VALUE`].
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let file = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::Performance)?;
        let model = file.u32_tensor(MODEL_HASH, &[2])?;
        let (shape, rank) = file.dims_of(POSES)?;
        let frames = shape[0];
        if rank != 2 || frames == 0 || shape[1] as usize != AIM_POSE_LEN {
            return Err(FormatError::incompatible_shapes(POSES));
        }
        let poses = file.f32_tensor(POSES, &[frames, AIM_POSE_LEN as u32])?;
        check_poses(poses)?;
        let (coefficients, shapes) = match (file.section(WEIGHTS), file.section(CODES)) {
            (Some(_), None) => {
                let (shape, rank) = file.dims_of(WEIGHTS)?;
                if rank != 2 || shape[0] != frames {
                    return Err(FormatError::incompatible_shapes(WEIGHTS));
                }
                let shapes = shape[1] as usize;
                if shapes > MAX_SHAPES {
                    return Err(FormatError::limit_exceeded(WEIGHTS, shapes, MAX_SHAPES));
                }
                let weights =
                    file.f32_tensor_within(WEIGHTS, &[frames, shape[1]], Bound::Factor)?;
                (Coefficients::Global(weights), shapes)
            }
            (None, Some(_)) => local(&file, frames)?,
            // Exactly one form: neither is a missing section, both do not fit together.
            (None, None) => return Err(crate::format::missing(WEIGHTS)),
            (Some(_), Some(_)) => return Err(FormatError::incompatible_shapes(CODES)),
        };
        if file.section(POINTS).is_some() && !matches!(coefficients, Coefficients::Local { .. }) {
            // A global fit has no per-point coefficients to evaluate anywhere.
            return Err(FormatError::incompatible_shapes(POINTS));
        }
        let hashes = match file.section(HASHES) {
            Some(_) => Some(file.u32_tensor(HASHES, &[frames, 2])?),
            None => None,
        };
        let model_hash = u64::from(model.at(0)) | (u64::from(model.at(1)) << 32);
        Ok(Self {
            model_hash,
            frames: frames as usize,
            shapes,
            poses,
            coefficients,
            hashes,
        })
    }

    /// The content hash of the actor this performance was fitted to.
    pub const fn model_hash(&self) -> u64 {
        self.model_hash
    }

    /// Number of frames (at least one).
    pub const fn frames(&self) -> usize {
        self.frames
    }

    /// Coefficients M per frame (per point for a local fit).
    pub const fn shape_count(&self) -> usize {
        self.shapes
    }

    /// The coefficients' form.
    pub const fn coefficients(&self) -> &Coefficients<'a> {
        &self.coefficients
    }

    /// Whether the coefficients vary per template point.
    pub const fn is_local(&self) -> bool {
        matches!(self.coefficients, Coefficients::Local { .. })
    }

    /// Checks that this performance was fitted (or retargeted) to the actor whose bytes are
    /// `model_bytes`.
    ///
    /// # Errors
    /// [`ReplayError::WrongModel`], [`ReplayError::ShapeCount`], or
    /// [`ReplayError::PointCount`] when the file's own points do not number the actor's vertices.
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
        if let Some(n) = self.point_count()
            && n != actor.vertex_count()
        {
            return Err(ReplayError::PointCount {
                performance: n,
                actor: actor.vertex_count(),
            });
        }
        Ok(())
    }

    /// How many points the file carries for F_W (`perf.points`), if it carries its own.
    pub fn point_count(&self) -> Option<usize> {
        match &self.coefficients {
            Coefficients::Local {
                points: Some(p), ..
            } => Some(p.len() / 3),
            _ => None,
        }
    }

    /// Frame `f`'s head and jaw (6D rotation + translation each), `None` past the end.
    pub fn head_jaw(&self, f: usize) -> Option<([f32; 9], [f32; 9])> {
        if f >= self.frames {
            return None;
        }
        let row = self.poses.slice(f * AIM_POSE_LEN, AIM_POSE_LEN);
        Some((
            core::array::from_fn(|i| row.at(i)),
            core::array::from_fn(|i| row.at(9 + i)),
        ))
    }

    /// Frame `f`'s global coefficients copied into `weights` (`[M]`); `None` for a local fit,
    /// past the end or for a wrong length.
    pub fn global_weights(&self, f: usize, weights: &mut [f32]) -> Option<()> {
        let Coefficients::Global(w) = &self.coefficients else {
            return None;
        };
        if f >= self.frames || weights.len() != self.shapes {
            return None;
        }
        for (i, o) in weights.iter_mut().enumerate() {
            *o = w.at(f * self.shapes + i);
        }
        Some(())
    }

    /// Scratch values [`Self::pose`] needs: the coefficients, and for a local fit F_W's input
    /// and its own scratch.
    pub fn scratch_len(&self) -> usize {
        match &self.coefficients {
            Coefficients::Global(_) => self.shapes,
            Coefficients::Local { code_len, fw, .. } => {
                self.shapes + code_len + 3 + fw.scratch_len()
            }
        }
    }

    /// Poses `actor` for frame `f` into `out` (`[V, 3]`): AIM eq. 17 with this frame's head, jaw
    /// and coefficients, the local ones evaluated per template point by F_W (eq. 19).
    ///
    /// The actor must be the one this performance was fitted to ([`Self::check_actor`]); with
    /// another of the same coefficient count the result is defined but meaningless. F_W sees the
    /// file's own points (`perf.points`) where it carries them, else the actor's template.
    ///
    /// # Errors
    /// [`BufferError::Input`] if `f` is past the end, the actor's coefficient count differs or
    /// the file's points number other than the actor's vertices;
    /// [`BufferError::Scratch`] if `scratch` is shorter than [`Self::scratch_len`];
    /// [`BufferError::Output`] if `out` is not `[V, 3]`. Never [`EvalError::Input`]: the file's
    /// frames were checked at load as the actor checks a caller's.
    pub fn pose(
        &self,
        actor: &AimActor<'_>,
        f: usize,
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        let (head, jaw) = self.head_jaw(f).ok_or(BufferError::Input)?;
        if actor.shape_count() != self.shapes {
            return Err(BufferError::Input.into());
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch.into());
        }
        let pose = actor.pose_from_9d(&jaw, &head)?;
        let (weights, rest) = scratch.split_at_mut(self.shapes);
        match &self.coefficients {
            Coefficients::Global(_) => {
                self.global_weights(f, weights).ok_or(BufferError::Input)?;
                actor.pose(&pose, weights, out)
            }
            Coefficients::Local {
                codes,
                code_len,
                centre,
                half,
                fw,
                points,
            } => {
                let v = actor.vertex_count();
                if out.len() != 3 * v {
                    return Err(BufferError::Output.into());
                }
                let tpl = match points {
                    Some(p) if p.len() != 3 * v => return Err(BufferError::Input.into()),
                    Some(p) => *p,
                    None => actor.template(),
                };
                let (input, mlp) = rest.split_at_mut(code_len + 3);
                for (i, x) in input.iter_mut().take(*code_len).enumerate() {
                    *x = codes.at(f * code_len + i);
                }
                let (s0, k, e) = (actor.rest(), actor.skinning_weights(), actor.correctives());
                let per_vertex = 3 * self.shapes;
                for (i, o) in out.chunks_exact_mut(3).enumerate() {
                    let point = input.iter_mut().skip(*code_len).zip(centre).enumerate();
                    for (c, (x, centre)) in point {
                        // ĉ = (c − centre) / half, as the fit normalised it.
                        *x = (tpl.at(3 * i + c) - centre) / *half;
                    }
                    // AIM eq. 19: w_j(c) = F_W(z_j, c)
                    fw.eval(input, weights, mlp)?;
                    let p = skin_vertex(
                        Vec3::new(s0.at(3 * i), s0.at(3 * i + 1), s0.at(3 * i + 2)),
                        k.at(i),
                        e.slice(i * per_vertex, per_vertex),
                        weights,
                        &pose,
                    );
                    o.copy_from_slice(&p.to_array());
                }
                Ok(())
            }
        }
    }

    /// The baked hash of frame `f` ([`play_frame_hash`]), if the file carries them.
    pub fn expected(&self, f: usize) -> Option<u64> {
        let h = self.hashes.as_ref()?;
        if f >= self.frames {
            return None;
        }
        Some(u64::from(h.at(2 * f)) | (u64::from(h.at(2 * f + 1)) << 32))
    }
}

fn local<'a>(file: &SinewFile<'a>, frames: u32) -> Result<(Coefficients<'a>, usize), FormatError> {
    let (shape, rank) = file.dims_of(CODES)?;
    if rank != 2 || shape[0] != frames || shape[1] == 0 {
        return Err(FormatError::incompatible_shapes(CODES));
    }
    let code_len = shape[1] as usize;
    if code_len > MAX_CODE {
        return Err(FormatError::limit_exceeded(CODES, code_len, MAX_CODE));
    }
    let codes = file.f32_tensor_within(CODES, &[frames, shape[1]], Bound::Factor)?;
    let bx = file.f32_tensor(BOX, &[4])?;
    let (centre, half) = ([bx.at(0), bx.at(1), bx.at(2)], bx.at(3));
    for (i, x) in bx.iter().enumerate() {
        let bound = if i < 3 {
            Bound::Coordinate
        } else {
            Bound::PositiveCoordinate
        };
        if !bound.contains(x) {
            return Err(out_of_range(BOX, i, bound));
        }
    }
    let fw = load_mlp(file, F_W)?;
    let shapes = fw.outputs();
    if fw.inputs() != code_len + 3 {
        return Err(FormatError::incompatible_shapes(F_W));
    }
    let points = match file.section(POINTS) {
        Some(_) => {
            let (shape, rank) = file.dims_of(POINTS)?;
            if rank != 2 || shape[0] == 0 || shape[1] != 3 {
                return Err(FormatError::incompatible_shapes(POINTS));
            }
            Some(file.f32_tensor_within(POINTS, &[shape[0], 3], Bound::Coordinate)?)
        }
        None => None,
    };
    // F_W sees the codes and ĉ = (c − centre) / half for points c within ±MAX_COORDINATE (the
    // file's own, or the actor's template).
    let reach = centre.map(libm::fabsf).into_iter().fold(0.0f32, f32::max) + MAX_COORDINATE;
    let code_max = codes.iter().map(libm::fabsf).fold(0.0f32, f32::max);
    let input = (f64::from(reach) / f64::from(half)).max(f64::from(code_max));
    check_bound(&fw, F_W, input)?;
    if shapes > MAX_SHAPES {
        return Err(FormatError::limit_exceeded(F_W, shapes, MAX_SHAPES));
    }
    Ok((
        Coefficients::Local {
            codes,
            code_len,
            centre,
            half,
            fw,
            points,
        },
        shapes,
    ))
}

/// Checks every frame's head and jaw (`perf.pose`, `[J, 18]`) as the actor checks a caller's
/// ([`try_rigid_from_9d`]).
///
/// # Errors
/// [`FormatError::ValueOutOfRange`] naming the first refused value: [`Bound::Rotation`] for a
/// rotation's, [`Bound::Coordinate`] for a translation's.
fn check_poses(poses: F32s<'_>) -> Result<(), FormatError> {
    for (f, row) in poses.as_bytes().chunks_exact(4 * AIM_POSE_LEN).enumerate() {
        let row = F32s::new(row).unwrap_or(F32s::empty());
        for (half, argument) in [(0, Argument::Head), (9, Argument::Jaw)] {
            let nine: [f32; 9] = core::array::from_fn(|i| row.at(half + i));
            if let Err(e) = try_rigid_from_9d(&nine, argument) {
                let bound = if e.index < 6 {
                    Bound::Rotation
                } else {
                    Bound::Coordinate
                };
                return Err(out_of_range(
                    POSES,
                    f * AIM_POSE_LEN + half + e.index,
                    bound,
                ));
            }
        }
    }
    Ok(())
}

/// Poses frame `f` ([`Performance::pose`]), computes the actor's normals and returns the frame's
/// f32 hash: the positions, then the normals, as an f32 replay frame's.
///
/// # Errors
/// As [`Performance::pose`]; [`BufferError::Output`] if `normals` is not `[V, 3]`.
pub fn play_frame_hash(
    perf: &Performance<'_>,
    actor: &AimActor<'_>,
    f: usize,
    scratch: &mut [f32],
    positions: &mut [f32],
    normals: &mut [f32],
) -> Result<u64, EvalError> {
    perf.pose(actor, f, scratch, positions)?;
    actor.normals(positions, normals)?;
    Ok(posed_frame_hash(positions, normals))
}

/// Plays frame `f` ([`play_frame_hash`]) and compares its hash with the one baked into the file: the
/// step of every target's performance loop. A performance without baked hashes compares
/// against the complement of the computed hash, so the check fails rather than passing
/// vacuously. Call [`Performance::check_actor`] once before the first frame.
///
/// # Errors
/// As [`play_frame_hash`].
pub fn check_frame(
    perf: &Performance<'_>,
    actor: &AimActor<'_>,
    f: usize,
    scratch: &mut [f32],
    positions: &mut [f32],
    normals: &mut [f32],
) -> Result<FrameCheck, EvalError> {
    let hash = play_frame_hash(perf, actor, f, scratch, positions, normals)?;
    Ok(FrameCheck {
        frame: f,
        hash,
        expected: perf.expected(f).unwrap_or(!hash),
    })
}
