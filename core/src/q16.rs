//! Q16.16 fixed-point AIM playback, for parts without a floating-point unit.
//!
//! Integer arithmetic only per vertex: the actor's per-vertex cache is baked in Q16.16 (sections
//! `q16.s0`, `q16.k`, `q16.e`, see `docs/FORMAT.md`), the pose is converted once per frame
//! ([`PoseQ16::from_pose`]), and eq. 17 is evaluated on the `fixed` crate's `I16F16` with
//! saturating additions and [`mul`]. Integer arithmetic is exact and the same everywhere, so this mode is deterministic
//! by construction; it differs from the `f32` reference by the quantisation of the cache
//! (2⁻¹⁶ of the model's unit, 0.15 µm for a model in centimetres) and of every product.
//!
//! Range: values must stay within ±32768 of the model's unit; results saturate there instead of
//! wrapping (a face in centimetres or millimetres is far inside).

use core::ops::{Add, Sub};

use fixed::types::I16F16;

use crate::error::{BufferError, FormatError};
use crate::linalg::{Mat3, Vec3};
use crate::skinning::Pose;
use crate::tensor::I32s;

/// A Q16.16 number.
pub type Q16 = I16F16;

/// A 3-vector of [`Q16`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Vec3Q {
    /// First component.
    pub x: Q16,
    /// Second component.
    pub y: Q16,
    /// Third component.
    pub z: Q16,
}

impl Vec3Q {
    /// The zero vector.
    pub const ZERO: Self = Self::new(Q16::ZERO, Q16::ZERO, Q16::ZERO);

    /// A vector from its components.
    pub const fn new(x: Q16, y: Q16, z: Q16) -> Self {
        Self { x, y, z }
    }

    /// The nearest Q16.16 vector to `v` (saturating at the range's ends, NaN to zero).
    pub fn from_f32(v: Vec3) -> Self {
        Self::new(q16(v.x), q16(v.y), q16(v.z))
    }

    /// The components converted to `f32` (exact inside ±128, rounded to nearest beyond).
    pub fn to_f32(self) -> Vec3 {
        Vec3::new(self.x.to_num(), self.y.to_num(), self.z.to_num())
    }

    /// `s · self`, one [`mul`] per component.
    #[inline]
    pub fn scale(self, s: Q16) -> Self {
        Self::new(mul(self.x, s), mul(self.y, s), mul(self.z, s))
    }
}

impl Add for Vec3Q {
    type Output = Self;

    /// The component-wise saturating sum.
    #[inline]
    fn add(self, o: Self) -> Self {
        Self::new(
            self.x.saturating_add(o.x),
            self.y.saturating_add(o.y),
            self.z.saturating_add(o.z),
        )
    }
}

impl Sub for Vec3Q {
    type Output = Self;

    /// The component-wise saturating difference.
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self::new(
            self.x.saturating_sub(o.x),
            self.y.saturating_sub(o.y),
            self.z.saturating_sub(o.z),
        )
    }
}

/// A 3×3 matrix of [`Q16`], by columns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Mat3Q {
    /// The three columns, left to right.
    pub cols: [Vec3Q; 3],
}

impl Mat3Q {
    /// The nearest Q16.16 matrix to `m`.
    pub fn from_f32(m: &Mat3) -> Self {
        let [a, b, c] = m.cols;
        Self {
            cols: [Vec3Q::from_f32(a), Vec3Q::from_f32(b), Vec3Q::from_f32(c)],
        }
    }

    /// `M v = (c0·v.x + c1·v.y) + c2·v.z`, saturating.
    #[inline]
    pub fn mul_vec(&self, v: Vec3Q) -> Vec3Q {
        let [c0, c1, c2] = self.cols;
        c0.scale(v.x) + c1.scale(v.y) + c2.scale(v.z)
    }
}

/// The Q16.16 product `a · b`: the exact 64-bit product shifted right by 16 (rounding toward
/// negative infinity), saturated to the Q16.16 range. One widening multiply, a shift and a clamp
/// (a few instructions on a Cortex-M4, against the generic `saturating_mul`'s dozens).
#[inline]
pub fn mul(a: Q16, b: Q16) -> Q16 {
    let p = (i64::from(a.to_bits()) * i64::from(b.to_bits())) >> 16;
    let clamped = p.clamp(i64::from(i32::MIN), i64::from(i32::MAX));
    Q16::from_bits(i32::try_from(clamped).unwrap_or(0))
}

/// The nearest [`Q16`] to an `f32`: round to nearest, saturating, NaN to zero. Uses integer
/// operations on the float's bits only, so it is the same on every target.
pub fn q16(v: f32) -> Q16 {
    if v.is_nan() {
        Q16::ZERO
    } else {
        Q16::saturating_from_num(v)
    }
}

/// [`q16`] of every value of `values` into `out`.
///
/// # Errors
/// [`BufferError::Output`] if the lengths differ; nothing is written then.
pub fn q16_slice(values: &[f32], out: &mut [Q16]) -> Result<(), BufferError> {
    if values.len() != out.len() {
        return Err(BufferError::Output);
    }
    for (o, v) in out.iter_mut().zip(values) {
        *o = q16(*v);
    }
    Ok(())
}

/// A [`Pose`] in Q16.16, converted once per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PoseQ16 {
    jaw_rot: Mat3Q,
    jaw_trans: Vec3Q,
    pivot: Vec3Q,
    head_rot: Mat3Q,
    head_trans: Vec3Q,
}

impl PoseQ16 {
    /// The nearest Q16.16 pose to `pose` (each matrix entry and vector component rounded).
    pub fn from_pose(pose: &Pose) -> Self {
        Self {
            jaw_rot: Mat3Q::from_f32(&pose.jaw.rigid.rot),
            jaw_trans: Vec3Q::from_f32(pose.jaw.rigid.trans),
            pivot: Vec3Q::from_f32(pose.jaw.pivot),
            head_rot: Mat3Q::from_f32(&pose.head.rot),
            head_trans: Vec3Q::from_f32(pose.head.trans),
        }
    }

    /// AIM eq. 17 for one vertex, in the order of [`crate::skinning::skin_vertex`]:
    /// `T_b(s0) = (R_b (s0 − p) + p) + t_b`, `k·T_b(s0) + (1 − k)·s0`, plus `Σ_j w_j e_j`
    /// accumulated from zero in `j` order, then `R_g · + t_g`.
    #[inline]
    fn skin_vertex(&self, s0: Vec3Q, k: Q16, e: I32s<'_>, weights: &[Q16]) -> Vec3Q {
        let t = self.jaw_rot.mul_vec(s0 - self.pivot) + self.pivot + self.jaw_trans;
        let skinned = t.scale(k) + s0.scale(Q16::ONE.saturating_sub(k));
        let mut it = e.iter();
        let mut sum = Vec3Q::ZERO;
        for w in weights {
            let (Some(x), Some(y), Some(z)) = (it.next(), it.next(), it.next()) else {
                break;
            };
            sum =
                sum + Vec3Q::new(Q16::from_bits(x), Q16::from_bits(y), Q16::from_bits(z)).scale(*w);
        }
        self.head_rot.mul_vec(skinned + sum) + self.head_trans
    }
}

/// The Q16.16 playback cache of an AIM actor: neutral skin, jaw weights and correctives.
#[derive(Clone, Copy, Debug)]
pub struct AimQ16<'a> {
    vertices: usize,
    shapes: usize,
    rest: I32s<'a>,
    k: I32s<'a>,
    correctives: I32s<'a>,
}

impl<'a> AimQ16<'a> {
    /// The cache from sections `q16.s0` `[V, 3]`, `q16.k` `[V]` and `q16.e` `[V, M, 3]`;
    /// `None` when the artefact has no `q16.s0` section.
    ///
    /// # Errors
    /// A [`FormatError`] if the sections are there but incomplete or of the wrong type or shape.
    pub fn from_file(
        file: &crate::format::SinewFile<'a>,
        vertices: u32,
        shapes: u32,
    ) -> Result<Option<Self>, FormatError> {
        if file.section("q16.s0").is_none() {
            return Ok(None);
        }
        Ok(Some(Self {
            vertices: vertices as usize,
            shapes: shapes as usize,
            rest: file.q16_tensor("q16.s0", &[vertices, 3])?,
            k: file.q16_tensor("q16.k", &[vertices])?,
            correctives: file.q16_tensor("q16.e", &[vertices, shapes, 3])?,
        }))
    }

    /// Number of vertices.
    pub const fn vertex_count(&self) -> usize {
        self.vertices
    }

    /// Number of corrective shapes (coefficients per frame).
    pub const fn shape_count(&self) -> usize {
        self.shapes
    }

    /// Poses the actor in Q16.16 (AIM eq. 17 with global coefficients).
    ///
    /// # Shapes
    /// - `weights`: `[M]`
    /// - `out`: `[V, 3]`
    ///
    /// # Errors
    /// [`BufferError`] if a length is wrong; nothing is written then.
    pub fn pose(
        &self,
        pose: &PoseQ16,
        weights: &[Q16],
        out: &mut [Q16],
    ) -> Result<(), BufferError> {
        if weights.len() != self.shapes {
            return Err(BufferError::Input);
        }
        if out.len() != 3 * self.vertices {
            return Err(BufferError::Output);
        }
        let per_vertex = 3 * self.shapes;
        for (i, o) in out.chunks_exact_mut(3).enumerate() {
            let s0 = Vec3Q::new(
                Q16::from_bits(self.rest.at(3 * i)),
                Q16::from_bits(self.rest.at(3 * i + 1)),
                Q16::from_bits(self.rest.at(3 * i + 2)),
            );
            let k = Q16::from_bits(self.k.at(i));
            let e = self.correctives.slice(i * per_vertex, per_vertex);
            let p = pose.skin_vertex(s0, k, e, weights);
            if let [x, y, z] = o {
                *x = p.x;
                *y = p.y;
                *z = p.z;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::linalg::Rigid;
    use crate::skinning::BoneTransform;

    fn q(v: f32) -> Q16 {
        q16(v)
    }

    #[test]
    fn conversion_rounds_saturates_and_zeroes_nan() {
        assert_eq!(q(1.5).to_bits(), 0x0001_8000);
        assert_eq!(q(-0.25).to_bits(), -0x4000);
        // 2⁻¹⁷ is exactly half a step: rounds to even (zero); a little more rounds up.
        assert_eq!(q(1.0 / 131_072.0).to_bits(), 0);
        assert_eq!(q(1.5 / 131_072.0).to_bits(), 1);
        assert_eq!(q(1e9), Q16::MAX);
        assert_eq!(q(-1e9), Q16::MIN);
        assert_eq!(q(f32::NAN), Q16::ZERO);
        assert_eq!(q(f32::INFINITY), Q16::MAX);
    }

    #[test]
    fn skin_vertex_matches_hand_computation() {
        // Jaw: 90° about z through pivot (1, 0, 0), plus t = (0, 0, 1); head: translate by 2 in x.
        let rot = Mat3::from_cols(Vec3::Y, -Vec3::X, Vec3::Z);
        let pose = Pose {
            jaw: BoneTransform::new(rot, Vec3::Z, Vec3::X),
            head: Rigid::new(Mat3::IDENTITY, Vec3::new(2.0, 0.0, 0.0)),
        };
        let p = PoseQ16::from_pose(&pose);
        // s0 = (2, 0, 0): T_b(s0) = R (1, 0, 0) + (1, 0, 0) + (0, 0, 1) = (1, 1, 1).
        // k = 0.5: (1.5, 0.5, 0.5); e = 0.5·(0, 0, 2) = (0, 0, 1): (1.5, 0.5, 1.5); head: (3.5, 0.5, 1.5).
        let e_bits = [0i32, 0, 2 << 16];
        let e_bytes: std::vec::Vec<u8> = e_bits.iter().flat_map(|v| v.to_le_bytes()).collect();
        let e = I32s::new(&e_bytes).unwrap();
        let out = p.skin_vertex(
            Vec3Q::from_f32(Vec3::new(2.0, 0.0, 0.0)),
            q(0.5),
            e,
            &[q(0.5)],
        );
        assert_eq!(out.to_f32(), Vec3::new(3.5, 0.5, 1.5));
    }

    #[test]
    fn mul_floors_and_saturates() {
        assert_eq!(mul(q(1.5), q(2.0)), q(3.0));
        assert_eq!(mul(q(-1.5), q(2.0)), q(-3.0));
        // 2⁻¹⁶ · 0.5 = 2⁻¹⁷: rounds down to 0; its negative rounds down to −2⁻¹⁶.
        assert_eq!(mul(Q16::DELTA, q(0.5)), Q16::ZERO);
        assert_eq!(mul(-Q16::DELTA, q(0.5)), -Q16::DELTA);
        assert_eq!(mul(q(300.0), q(300.0)), Q16::MAX);
        assert_eq!(mul(q(-300.0), q(300.0)), Q16::MIN);
    }

    #[test]
    fn saturates_instead_of_wrapping() {
        let pose = PoseQ16::from_pose(&Pose {
            jaw: BoneTransform::IDENTITY,
            head: Rigid::new(Mat3::IDENTITY, Vec3::new(30_000.0, 0.0, 0.0)),
        });
        let e = I32s::empty();
        let out = pose.skin_vertex(
            Vec3Q::from_f32(Vec3::new(10_000.0, 0.0, 0.0)),
            q(0.0),
            e,
            &[],
        );
        assert_eq!(out.x, Q16::MAX);
    }
}
