//! What glTF's order of operations needs to pose as the core does.
//!
//! AIM eq. 17 adds the correctives after the jaw's skinning, `T_g(LBS(s0) + Σ w_j e_j)`, where
//! glTF morphs first and skins after: a displacement `d` added before skinning reaches the face
//! as `A d`, with `A = (1 − k) I + k R` for a vertex of jaw weight `k` and the jaw's rotation
//! `R`. With the jaw open by 20°, a chin corrective of 2 cm lands 7 mm astray. glTF's convex
//! skin weights also clamp a learned `k` outside [0, 1] ([`joint_weight`]). Two
//! things put it right:
//!
//! 1. **The named targets** ([`shape_deltas`]): every shape's target holds `A_j⁻¹ e_j`, its
//!    corrective undone by the rotation of its own learned jaw transform (`train.jaw`). A shape
//!    alone at weight 1 takes exactly that jaw under the core's rule for a pose given by
//!    coefficients alone (`sinew_core::jaw`: the learned jaws blended by the coefficients), so
//!    an engine that drives a target by name and turns the jaw joint by the same rule poses it
//!    exactly as the core does: `jawOpen`, and on a studio's rig `mouthClose` or `mouthFunnel`,
//!    whose learned jaws turn by several degrees. With several shapes at once, what is left is
//!    the remainder of the pose's other shapes and weights (docs/ENGINES.md gives it).
//! 2. **The animation** ([`compensate`]): for each frame, the displacement glTF needs before
//!    skinning, `X* = A_c⁻¹((k − k_c)(T_b(s0) − s0) + Σ w_j e_j)` (with `k_c` the clamped
//!    weight), less what the named targets give, `Σ w̄_j d_j`, is the frame's remainder. The
//!    named targets are keyed with `w̄_j`, the coefficient held to [0, 1] ([`keyed_weight`]),
//!    since a DCC's sliders clamp there (Blender's shape keys); what lies beyond is part of the
//!    remainder. The remainders span few directions (the jaw turns about one hinge), so the
//!    fewest directions, at most [`MAX_DIRECTIONS`], that leave every frame within
//!    [`TOLERANCE_M`] are kept, and each becomes one or two morph targets (`jawCompensation1`,
//!    …): its positive part and its negative part, each scaled to the largest coordinate the
//!    frames take along it, so that every frame keys it with a weight in [0, 1]. The worst
//!    remainder left is reported. Without frames there is nothing to compensate.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use sinew_core::InputError;
use sinew_core::aim::AimActor;
use sinew_core::tensor::F32s;

use crate::aim::play::Frame;

/// The remainder, in metres, below which a frame needs no compensation target of its own: half
/// of the 0.01 mm within which engines and DCCs must pose an export as the core does, leaving
/// the other half to f32 rounding.
pub const TOLERANCE_M: f64 = 5e-6;

/// The most compensation directions an animation gets; each is one target, or two where the
/// frames take it both ways.
pub const MAX_DIRECTIONS: usize = 32;

/// The morph weight a named target is keyed with for a coefficient `w`: held to [0, 1], the
/// range of a DCC's sliders; the compensation carries the rest (module docs).
pub fn keyed_weight(w: f32) -> f32 {
    w.clamp(0.0, 1.0)
}

/// The glTF skin weight of a learned k: clamped into [0, 1], since glTF's weights are convex.
pub fn joint_weight(k: f32) -> f32 {
    k.clamp(0.0, 1.0)
}

/// The name of compensation target `i` (from 0).
pub fn target_name(i: usize) -> String {
    format!("jawCompensation{}", i + 1)
}

/// The actor's skin as the compensation needs it, in f64.
pub(crate) struct Skin {
    rest: Vec<Vector3<f64>>,
    /// The learned jaw weights.
    k: Vec<f64>,
    /// The weights glTF carries.
    clamped: Vec<f64>,
    pivot: Vector3<f64>,
    /// The correctives `e`, `[V, M]`.
    correctives: Vec<Vector3<f64>>,
    shapes: usize,
}

impl Skin {
    pub(crate) fn of(actor: &AimActor<'_>, correctives: &F32s<'_>) -> Self {
        let v = actor.vertex_count();
        let rest = (0..v)
            .map(|i| Vector3::from_fn(|c, _| f64::from(actor.rest().at(3 * i + c))))
            .collect();
        let k: Vec<f64> = actor.skinning_weights().iter().map(f64::from).collect();
        let clamped = actor
            .skinning_weights()
            .iter()
            .map(|k| f64::from(joint_weight(k)))
            .collect();
        let p = actor.jaw_pivot();
        let correctives = (0..correctives.len() / 3)
            .map(|n| Vector3::from_fn(|c, _| f64::from(correctives.at(3 * n + c))))
            .collect();
        Self {
            rest,
            k,
            clamped,
            pivot: Vector3::new(p.x, p.y, p.z).cast::<f64>(),
            correctives,
            shapes: actor.shape_count(),
        }
    }

    fn vertices(&self) -> usize {
        self.rest.len()
    }

    fn corrective(&self, i: usize, j: usize) -> Vector3<f64> {
        self.correctives[i * self.shapes + j]
    }

    /// `A⁻¹` for vertex `i` under the jaw rotation `r`: the inverse of `(1 − k_c) I + k_c R`,
    /// or the identity where that is singular (a half-turn with `k_c = ½`).
    fn undo(&self, i: usize, r: &Matrix3<f64>) -> Matrix3<f64> {
        let k = self.clamped[i];
        let a = Matrix3::identity() * (1.0 - k) + r * k;
        a.try_inverse().unwrap_or_else(Matrix3::identity)
    }
}

fn rotation(m: &sinew_core::linalg::Mat3) -> Matrix3<f64> {
    let c = m.cols.map(|v| Vector3::new(v.x, v.y, v.z).cast::<f64>());
    Matrix3::from_columns(&c)
}

/// The named targets' displacements `[V, M, 3]` (actor units): each shape's corrective, undone by
/// its own learned jaw rotation where `jaw` gives one (shape index and its learned 9D jaw
/// transform). A learned jaw the core refuses is returned with its shape.
pub(crate) fn shape_deltas(
    actor: &AimActor<'_>,
    skin: &Skin,
    jaw: &[(usize, [f32; 9])],
) -> Result<Vec<f32>, (usize, InputError)> {
    let (v, m) = (skin.vertices(), skin.shapes);
    let mut out: Vec<f32> = skin
        .correctives
        .iter()
        .flat_map(|e| [e.x as f32, e.y as f32, e.z as f32])
        .collect();
    for (j, learned) in jaw {
        let pose = actor
            .pose_from_9d(learned, &crate::aim::model::IDENTITY_9D)
            .map_err(|e| (*j, e))?;
        let r = rotation(&pose.jaw.rigid.rot);
        for i in 0..v {
            let d = skin.undo(i, &r) * skin.corrective(i, *j);
            let at = (i * m + j) * 3;
            for c in 0..3 {
                out[at + c] = d[c] as f32;
            }
        }
    }
    Ok(out)
}

/// The compensation targets of an animation and their weights.
#[derive(Debug, Default)]
pub(crate) struct Compensation {
    /// Each target's displacements `[V, 3]` (actor units): a direction's positive or negative
    /// part, scaled to the frames' largest coordinate along it that way.
    pub(crate) targets: Vec<Vec<f32>>,
    /// Each frame's weights of the targets, each in [0, 1].
    pub(crate) weights: Vec<Vec<f32>>,
    /// The directions the targets come from (fewer than the targets where some are taken both
    /// ways).
    pub(crate) directions: usize,
    /// The largest displacement left uncompensated in any frame and vertex, in metres.
    pub(crate) residual_m: f64,
}

/// The compensation targets that make `frames` pose in glTF as in the core (module docs), for
/// named targets `deltas` (`[V, M, 3]`, [`shape_deltas`]); `metres` per actor unit. A frame
/// whose jaw the core refuses is returned with its index.
///
/// The frames' remainders `R` (`[3V, F]`, one column a frame) are streamed, never held: a
/// randomised range finder (Halko, Martinsson and Tropp 2011, with one power iteration; the
/// random test matrix from a fixed seed, so an export is reproducible) finds the
/// [`MAX_DIRECTIONS`] + 8 directions that carry most of them, ordered by their singular values,
/// and the fewest leading directions that leave every frame within [`TOLERANCE_M`] are kept (all
/// [`MAX_DIRECTIONS`] where none do; the summary reports what is left). Each kept direction
/// becomes a target for its positive coordinates and one for its negative coordinates, each
/// scaled so that the frames' largest coordinate that way is weight 1; a part no frame takes is
/// left out.
pub(crate) fn compensate(
    actor: &AimActor<'_>,
    skin: &Skin,
    deltas: &[f32],
    frames: &[Frame],
    metres: f64,
) -> Result<Compensation, (usize, InputError)> {
    use rand_core::{RngCore, SeedableRng};
    let rows = 3 * skin.vertices();
    let width = (MAX_DIRECTIONS + 8).min(frames.len());
    let each = |visit: &mut dyn FnMut(usize, Vec<f64>)| -> Result<(), (usize, InputError)> {
        for (f, frame) in frames.iter().enumerate() {
            visit(
                f,
                remainder(actor, skin, deltas, frame).map_err(|e| (f, e))?,
            );
        }
        Ok(())
    };
    // Y = R Ω, then one power iteration Y = R (Rᵀ Q).
    let mut rng = rand_pcg::Pcg64::seed_from_u64(0x6a61_775f_636f_6d70);
    let mut y = DMatrix::<f64>::zeros(rows, width);
    each(&mut |_, r| {
        let omega = DVector::from_fn(width, |_, _| {
            (rng.next_u64() >> 11) as f64 * (2.0 / (1u64 << 53) as f64) - 1.0
        });
        y.ger(1.0, &DVector::from_vec(r), &omega, 1.0);
    })?;
    let q = y.qr().q();
    let mut y = DMatrix::<f64>::zeros(rows, width);
    each(&mut |_, r| {
        let r = DVector::from_vec(r);
        let z = q.tr_mul(&r);
        y.ger(1.0, &r, &z, 1.0);
    })?;
    let q = y.qr().q();
    // B = Qᵀ R; its left singular vectors U, from B Bᵀ, turn Q into the ordered directions Q U.
    let mut gram = DMatrix::<f64>::zeros(width, width);
    each(&mut |_, r| {
        let b = q.tr_mul(&DVector::from_vec(r));
        gram.ger(1.0, &b, &b, 1.0);
    })?;
    let eigen = gram.symmetric_eigen();
    let mut order: Vec<usize> = (0..width).collect();
    order.sort_by(|a, b| eigen.eigenvalues[*b].total_cmp(&eigen.eigenvalues[*a]));
    let u = DMatrix::from_fn(width, width, |i, j| eigen.eigenvectors[(i, order[j])]);
    let directions = q * u;
    // Each frame's worst remainder after its first n directions, for every n.
    let worst = |r: &[f64]| {
        r.chunks_exact(3)
            .map(|d| Vector3::new(d[0], d[1], d[2]).norm())
            .fold(0.0, f64::max)
    };
    let mut left = vec![0.0f64; width + 1];
    let mut coordinates = Vec::with_capacity(frames.len());
    each(&mut |_, mut r| {
        let c = directions.tr_mul(&DVector::from_column_slice(&r));
        left[0] = left[0].max(worst(&r));
        for (n, column) in directions.column_iter().enumerate() {
            for (x, d) in r.iter_mut().zip(column.iter()) {
                *x -= c[n] * d;
            }
            left[n + 1] = left[n + 1].max(worst(&r));
        }
        coordinates.push(c);
    })?;
    let tolerance = TOLERANCE_M / metres;
    let count = (0..=width.min(MAX_DIRECTIONS))
        .find(|n| left[*n] <= tolerance)
        .unwrap_or(width.min(MAX_DIRECTIONS));
    let mut out = Compensation {
        residual_m: left[count] * metres,
        directions: count,
        ..Compensation::default()
    };
    // Direction n's positive part is the target `top · q_n`, keyed `c / top` where the frame's
    // coordinate c is positive (0 elsewhere); its negative part `−bottom · q_n`, keyed
    // `−c / bottom` where c is negative. Their sum is `c q_n` in every frame, and between two
    // keys too: linear interpolation of the two weights interpolates c.
    let mut parts: Vec<(usize, f64)> = Vec::with_capacity(2 * count);
    for n in 0..count {
        let top = coordinates.iter().map(|c| c[n]).fold(0.0, f64::max);
        let bottom = coordinates.iter().map(|c| -c[n]).fold(0.0, f64::max);
        for (sign, reach) in [(1.0, top), (-1.0, bottom)] {
            if reach > 0.0 {
                let scale = sign * reach;
                out.targets.push(
                    directions
                        .column(n)
                        .iter()
                        .map(|x| (x * scale) as f32)
                        .collect(),
                );
                parts.push((n, scale));
            }
        }
    }
    out.weights = coordinates
        .iter()
        .map(|c| {
            parts
                .iter()
                .map(|&(n, scale)| ((c[n] / scale).max(0.0) as f32).min(1.0))
                .collect()
        })
        .collect();
    Ok(out)
}

/// `X* − Σ w̄_j d_j` for one frame (module docs), `[V, 3]`.
fn remainder(
    actor: &AimActor<'_>,
    skin: &Skin,
    deltas: &[f32],
    frame: &Frame,
) -> Result<Vec<f64>, InputError> {
    let pose = actor.pose_from_9d(&frame.jaw, &frame.head)?;
    let r = rotation(&pose.jaw.rigid.rot);
    let t = pose.jaw.rigid.trans;
    let t = Vector3::new(t.x, t.y, t.z).cast::<f64>();
    let m = skin.shapes;
    let mut out = Vec::with_capacity(3 * skin.vertices());
    for i in 0..skin.vertices() {
        let s0 = skin.rest[i];
        let moved = r * (s0 - skin.pivot) + skin.pivot + t;
        let mut e = (moved - s0) * (skin.k[i] - skin.clamped[i]);
        let mut given = Vector3::zeros();
        for (j, w) in frame.weights.iter().enumerate().take(m) {
            e += skin.corrective(i, j) * f64::from(*w);
            let at = (i * m + j) * 3;
            given +=
                Vector3::from_fn(|c, _| f64::from(deltas[at + c])) * f64::from(keyed_weight(*w));
        }
        let need = skin.undo(i, &r) * e - given;
        out.extend_from_slice(need.as_slice());
    }
    Ok(out)
}
