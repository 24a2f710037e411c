//! Small fixed-size linear algebra: 3-vectors, 3×3 matrices and rigid transforms.
//!
//! Every operation is written out with separate multiplies and adds in a documented order (no
//! fused multiply-add, no reassociation), so results are bit-identical on every target. nalgebra
//! is used only for conversions at the API boundary: its generic kernels make no promise about the
//! order of their sums.

use core::ops::{Add, Mul, Neg, Sub};
use nalgebra::{ArrayStorage, Matrix3, Vector3};

/// A 3-vector of `f32`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Vec3 {
    /// First component.
    pub x: f32,
    /// Second component.
    pub y: f32,
    /// Third component.
    pub z: f32,
}

impl Vec3 {
    /// The zero vector.
    pub const ZERO: Self = Self::new(0.0, 0.0, 0.0);
    /// The unit vector along x.
    pub const X: Self = Self::new(1.0, 0.0, 0.0);
    /// The unit vector along y.
    pub const Y: Self = Self::new(0.0, 1.0, 0.0);
    /// The unit vector along z.
    pub const Z: Self = Self::new(0.0, 0.0, 1.0);

    /// A vector from its components.
    pub const fn new(x: f32, y: f32, z: f32) -> Self {
        Self { x, y, z }
    }

    /// The components as an array `[x, y, z]`.
    pub const fn to_array(self) -> [f32; 3] {
        [self.x, self.y, self.z]
    }

    /// A vector from an array `[x, y, z]`.
    pub const fn from_array(a: [f32; 3]) -> Self {
        let [x, y, z] = a;
        Self { x, y, z }
    }

    /// Scalar multiple `s · self`, one multiply per component.
    #[inline]
    pub fn scale(self, s: f32) -> Self {
        Self::new(self.x * s, self.y * s, self.z * s)
    }

    /// Dot product, summed as `(x·x' + y·y') + z·z'`.
    #[inline]
    pub fn dot(self, o: Self) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Cross product `self × o`; each component is `a·b − c·d` with two rounded products.
    #[inline]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Euclidean length, `libm::sqrtf(self · self)`.
    #[inline]
    pub fn norm(self) -> f32 {
        libm::sqrtf(self.dot(self))
    }

    /// The unit vector in the direction of `self`, each component divided by [`Self::norm`].
    ///
    /// Returns [`Vec3::ZERO`] when the length is not a positive finite number: the zero vector,
    /// vectors whose squared length underflows to zero (|v| below about 1e-23) or overflows to
    /// infinity (|v| above about 1.8e19), and vectors with a NaN component. The result is
    /// therefore never NaN, and callers detect the degenerate case by comparing with zero.
    #[inline]
    pub fn normalize(self) -> Self {
        let n = self.norm();
        if n > 0.0 && n.is_finite() {
            Self::new(self.x / n, self.y / n, self.z / n)
        } else {
            Self::ZERO
        }
    }
}

impl Add for Vec3 {
    type Output = Self;

    /// Component-wise sum.
    #[inline]
    fn add(self, o: Self) -> Self {
        Self::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl Sub for Vec3 {
    type Output = Self;

    /// Component-wise difference.
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl Neg for Vec3 {
    type Output = Self;

    /// Component-wise negation (exact).
    #[inline]
    fn neg(self) -> Self {
        Self::new(-self.x, -self.y, -self.z)
    }
}

impl Mul<f32> for Vec3 {
    type Output = Self;

    /// Same as [`Vec3::scale`].
    #[inline]
    fn mul(self, s: f32) -> Self {
        self.scale(s)
    }
}

/// A 3×3 `f32` matrix stored by columns.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Mat3 {
    /// The three columns, left to right.
    pub cols: [Vec3; 3],
}

impl Mat3 {
    /// The identity matrix.
    pub const IDENTITY: Self = Self::from_cols(Vec3::X, Vec3::Y, Vec3::Z);

    /// The identity matrix (same as [`Mat3::IDENTITY`]).
    pub const fn identity() -> Self {
        Self::IDENTITY
    }

    /// A matrix from its three columns.
    pub const fn from_cols(c0: Vec3, c1: Vec3, c2: Vec3) -> Self {
        Self { cols: [c0, c1, c2] }
    }

    /// A matrix from its three rows.
    pub const fn from_rows(r0: Vec3, r1: Vec3, r2: Vec3) -> Self {
        Self::from_cols(
            Vec3::new(r0.x, r1.x, r2.x),
            Vec3::new(r0.y, r1.y, r2.y),
            Vec3::new(r0.z, r1.z, r2.z),
        )
    }

    /// Matrix–vector product `M v = c0·v.x + c1·v.y + c2·v.z`, summed left to right per
    /// component: `(c0ᵢ·v.x + c1ᵢ·v.y) + c2ᵢ·v.z`.
    #[inline]
    pub fn mul_vec(&self, v: Vec3) -> Vec3 {
        let [c0, c1, c2] = self.cols;
        c0.scale(v.x) + c1.scale(v.y) + c2.scale(v.z)
    }

    /// Matrix product `self · b`: column `j` is `self.mul_vec(b.cols[j])`.
    #[inline]
    pub fn mul_mat(&self, b: &Self) -> Self {
        let [b0, b1, b2] = b.cols;
        Self::from_cols(self.mul_vec(b0), self.mul_vec(b1), self.mul_vec(b2))
    }

    /// The transpose (exact: it only moves values).
    #[inline]
    pub fn transpose(&self) -> Self {
        let [c0, c1, c2] = self.cols;
        Self::from_rows(c0, c1, c2)
    }
}

/// A rigid transform `x ↦ R x + t`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Rigid {
    /// The rotation `R` (assumed orthonormal by [`Rigid::inverse`]).
    pub rot: Mat3,
    /// The translation `t`, added after rotating.
    pub trans: Vec3,
}

impl Rigid {
    /// The identity transform.
    pub const IDENTITY: Self = Self {
        rot: Mat3::IDENTITY,
        trans: Vec3::ZERO,
    };

    /// A transform from its rotation and translation.
    pub const fn new(rot: Mat3, trans: Vec3) -> Self {
        Self { rot, trans }
    }

    /// `R p + t`, with `R p` as in [`Mat3::mul_vec`] and `t` added last.
    #[inline]
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.rot.mul_vec(p) + self.trans
    }

    /// The transform `self ∘ inner`, i.e. `x ↦ self.apply(inner.apply(x))`:
    /// rotation `R_s R_i`, translation `R_s t_i + t_s`.
    ///
    /// Mathematically equal to applying the two transforms in turn, but rounded differently: use
    /// one or the other consistently where bits must match.
    #[inline]
    pub fn compose(&self, inner: &Self) -> Self {
        Self {
            rot: self.rot.mul_mat(&inner.rot),
            trans: self.apply(inner.trans),
        }
    }

    /// The inverse of a rigid transform, `x ↦ Rᵀ x − Rᵀ t`, using the transpose as the inverse
    /// rotation (so it is only an inverse when `R` is orthonormal).
    #[inline]
    pub fn inverse(&self) -> Self {
        let rt = self.rot.transpose();
        let t = rt.mul_vec(self.trans);
        Self {
            rot: rt,
            trans: Vec3::new(-t.x, -t.y, -t.z),
        }
    }
}

impl From<Vector3<f32>> for Vec3 {
    fn from(v: Vector3<f32>) -> Self {
        let ArrayStorage([[x, y, z]]) = v.data;
        Self::new(x, y, z)
    }
}

impl From<Vec3> for Vector3<f32> {
    fn from(v: Vec3) -> Self {
        Vector3::new(v.x, v.y, v.z)
    }
}

impl From<Matrix3<f32>> for Mat3 {
    fn from(m: Matrix3<f32>) -> Self {
        // nalgebra stores matrices by columns, like `Mat3`.
        let ArrayStorage([c0, c1, c2]) = m.data;
        Self::from_cols(
            Vec3::from_array(c0),
            Vec3::from_array(c1),
            Vec3::from_array(c2),
        )
    }
}

impl From<Mat3> for Matrix3<f32> {
    fn from(m: Mat3) -> Self {
        let [c0, c1, c2] = m.cols;
        Matrix3::from_data(ArrayStorage([c0.to_array(), c1.to_array(), c2.to_array()]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    #[test]
    fn vector_arithmetic() {
        let a = v(1.0, 2.0, 3.0);
        let b = v(4.0, -5.0, 6.0);
        assert_eq!(a + b, v(5.0, -3.0, 9.0));
        assert_eq!(a - b, v(-3.0, 7.0, -3.0));
        assert_eq!(-a, v(-1.0, -2.0, -3.0));
        assert_eq!(a * 0.5, v(0.5, 1.0, 1.5));
        assert_eq!(a.scale(2.0), v(2.0, 4.0, 6.0));
        // 1·4 + 2·(−5) + 3·6 = 4 − 10 + 18 = 12
        assert_eq!(a.dot(b), 12.0);
        // (2·6 − 3·(−5), 3·4 − 1·6, 1·(−5) − 2·4) = (27, 6, −13)
        assert_eq!(a.cross(b), v(27.0, 6.0, -13.0));
        assert_eq!(Vec3::X.cross(Vec3::Y), Vec3::Z);
        // √(9 + 16 + 0) = 5
        assert_eq!(v(3.0, 4.0, 0.0).norm(), 5.0);
        // (3/5, 4/5, 0) = (0.6, 0.8, 0) after rounding each quotient to f32
        assert_eq!(v(3.0, 4.0, 0.0).normalize(), v(0.6, 0.8, 0.0));
        assert_eq!(v(0.0, 0.0, -2.0).normalize(), v(0.0, 0.0, -1.0));
    }

    #[test]
    fn normalize_degenerate_is_zero_never_nan() {
        assert_eq!(Vec3::ZERO.normalize(), Vec3::ZERO);
        // (1e-30)² underflows to 0 in f32.
        assert_eq!(v(1e-30, 0.0, 0.0).normalize(), Vec3::ZERO);
        // (1e20)² overflows to infinity.
        assert_eq!(v(1e20, 0.0, 0.0).normalize(), Vec3::ZERO);
        assert_eq!(v(f32::NAN, 1.0, 0.0).normalize(), Vec3::ZERO);
        assert_eq!(v(f32::INFINITY, 1.0, 0.0).normalize(), Vec3::ZERO);
    }

    #[test]
    fn matrix_products_and_transpose() {
        // Rows (1 2 3), (4 5 6), (7 8 10).
        let m = Mat3::from_rows(v(1.0, 2.0, 3.0), v(4.0, 5.0, 6.0), v(7.0, 8.0, 10.0));
        assert_eq!(m.cols[0], v(1.0, 4.0, 7.0));
        // M (1, −1, 2) = (1 − 2 + 6, 4 − 5 + 12, 7 − 8 + 20) = (5, 11, 19)
        assert_eq!(m.mul_vec(v(1.0, -1.0, 2.0)), v(5.0, 11.0, 19.0));
        assert_eq!(m.mul_mat(&Mat3::IDENTITY), m);
        assert_eq!(Mat3::identity().mul_mat(&m), m);
        let mt = m.transpose();
        assert_eq!(mt.cols[0], v(1.0, 2.0, 3.0));
        assert_eq!(mt.transpose(), m);
        // (M Mᵀ)₀₀ = 1 + 4 + 9 = 14; (M Mᵀ)₁₀ = 4 + 10 + 18 = 32; (M Mᵀ)₂₂ = 49 + 64 + 100 = 213
        let mmt = m.mul_mat(&mt);
        assert_eq!(mmt.cols[0].x, 14.0);
        assert_eq!(mmt.cols[0].y, 32.0);
        assert_eq!(mmt.cols[2].z, 213.0);
    }

    #[test]
    fn rigid_apply_compose_inverse() {
        // 90° about z: x → y, y → −x.
        let rz = Mat3::from_cols(Vec3::Y, v(-1.0, 0.0, 0.0), Vec3::Z);
        let a = Rigid::new(rz, v(1.0, 2.0, 3.0));
        // R (1, 0, 0) + t = (0, 1, 0) + (1, 2, 3) = (1, 3, 3)
        assert_eq!(a.apply(Vec3::X), v(1.0, 3.0, 3.0));
        let b = Rigid::new(Mat3::IDENTITY, v(0.0, 0.0, -1.0));
        // a(b(x)) for x = (1, 0, 0): b → (1, 0, −1); a → (0, 1, −1) + (1, 2, 3) = (1, 3, 2)
        assert_eq!(a.compose(&b).apply(Vec3::X), v(1.0, 3.0, 2.0));
        assert_eq!(a.apply(b.apply(Vec3::X)), v(1.0, 3.0, 2.0));
        // inverse: Rᵀ = −90° about z; −Rᵀ t = −(2, −1, 3) = (−2, 1, −3)
        let inv = a.inverse();
        assert_eq!(inv.trans, v(-2.0, 1.0, -3.0));
        assert_eq!(inv.apply(v(1.0, 3.0, 3.0)), Vec3::X);
        assert_eq!(a.compose(&inv), Rigid::IDENTITY);
    }

    #[test]
    fn nalgebra_round_trip_keeps_layout() {
        let m = Mat3::from_rows(v(1.0, 2.0, 3.0), v(4.0, 5.0, 6.0), v(7.0, 8.0, 9.0));
        let n: Matrix3<f32> = m.into();
        assert_eq!(n[(0, 1)], 2.0);
        assert_eq!(n[(1, 0)], 4.0);
        assert_eq!(Mat3::from(n), m);
        let p: Vector3<f32> = v(1.0, 2.0, 3.0).into();
        assert_eq!(p[2], 3.0);
        assert_eq!(Vec3::from(p), v(1.0, 2.0, 3.0));
    }
}
