//! The continuous 6D rotation representation (Zhou et al., "On the Continuity of Rotation
//! Representations in Neural Networks", CVPR 2019), used by AIM for the jaw and head transforms
//! (AIM Sec. 4.1: `T_b ∈ R⁹` is a 6D rotation plus a translation).
//!
//! # Layout
//! A 6D rotation is `[a1x, a1y, a1z, a2x, a2y, a2z]`: the first two **columns** of the rotation
//! matrix (as in the paper). pytorch3d's `rotation_6d_to_matrix` stacks the same vectors as
//! **rows** instead, i.e. it returns the transpose of [`from_6d`]; an exporter from such code must
//! transpose (or swap the meaning of `[a1, a2]`) to match.

use crate::error::{Argument, InputError, InputErrorKind};
use crate::input::check_value;
use crate::layout::MIN_ROTATION_COLUMN;
use crate::linalg::{Mat3, Rigid, Vec3};

/// The 6D encoding of the identity rotation: columns `(1, 0, 0)` and `(0, 1, 0)`.
pub const IDENTITY_6D: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

/// Relative size below which the second column counts as parallel to the first: the part of `a2`
/// orthogonal to `b1` must be longer than `PARALLEL_TOLERANCE · |a2|`.
///
/// Exactly parallel columns leave a rounding residual of a few 1e-7 · |a2|, pointing anywhere
/// (often along `b1` itself), and normalising it would give a matrix that is not a rotation.
/// 1e-4 (an angle of about 0.006°) keeps well clear of that.
pub const PARALLEL_TOLERANCE: f32 = 1e-4;

/// The 6D encoding of the identity rotation (same as [`IDENTITY_6D`]).
pub const fn identity_6d() -> [f32; 6] {
    IDENTITY_6D
}

/// Rotation matrix from the 6D representation by Gram–Schmidt.
///
/// For well-formed input, with `a1 = r[0..3]` and `a2 = r[3..6]`:
/// `b1 = a1 / |a1|`, `b2 = normalize(a2 − (b1·a2) b1)`, `b3 = b1 × b2`, and the result has
/// columns `[b1 b2 b3]`. Every step is the ordered arithmetic of [`Vec3`].
///
/// # Degenerate input
/// The result is always a rotation (orthonormal, determinant +1), never NaN:
/// - if `a1` cannot be normalised (zero, NaN, infinite, or squared length under/overflowing
///   `f32`; see [`Vec3::normalize`]), `b1 = (1, 0, 0)`;
/// - if `a2` is zero, non-finite, or parallel to `b1` within [`PARALLEL_TOLERANCE`], `b2` is the
///   coordinate axis least aligned with `b1` (smallest `|b1ᵢ|`, lowest index on ties),
///   orthogonalised against `b1` and normalised.
///
/// So an all-zero input gives the identity, and `a1 = 0` with a usable `a2` gives a rotation whose
/// first column is `x` and whose second column follows `a2`.
pub fn from_6d(r: &[f32; 6]) -> Mat3 {
    // Zhou et al. 2019, Sec. 4 (6D → SO(3)): b1 = N(a1), b2 = N(a2 − (b1·a2) b1), b3 = b1 × b2
    let (a1, a2) = columns(r);
    let b1 = first_column(a1).unwrap_or(Vec3::X);
    let b2 = second_column(b1, a2).unwrap_or_else(|| fallback_second(b1));
    let b3 = b1.cross(b2);
    Mat3::from_cols(b1, b2, b3)
}

/// Rotation matrix from the 6D representation, refusing what [`from_6d`] would have to guess:
/// the caller's rotation `argument` (its values 0..6 are `r`) must have six finite values within
/// ±[`crate::layout::MAX_ROTATION_ENTRY`], each column at least [`MIN_ROTATION_COLUMN`] long, and a second
/// column whose part orthogonal to the first is longer than [`PARALLEL_TOLERANCE`] times its
/// length. Such a rotation gives exactly [`from_6d`]'s matrix, bit for bit: both run the same
/// arithmetic, and these inputs never reach its fallbacks.
///
/// # Errors
/// [`InputError`] naming the value (non-finite, out of range) or the column (degenerate: index 0
/// for the first, 3 for the second).
pub fn try_from_6d(r: &[f32; 6], argument: Argument) -> Result<Mat3, InputError> {
    for (index, &v) in r.iter().enumerate() {
        check_value(argument, index, v)?;
    }
    let degenerate = |index| InputError::new(argument, index, InputErrorKind::Degenerate);
    let (a1, a2) = columns(r);
    // Each value is within ±1e6, so the squared lengths (at most 3e12) cannot overflow, and a
    // length of at least 1e-6 has a square far above f32's smallest normal number.
    if a1.norm() < MIN_ROTATION_COLUMN {
        return Err(degenerate(0));
    }
    if a2.norm() < MIN_ROTATION_COLUMN {
        return Err(degenerate(3));
    }
    let b1 = first_column(a1).ok_or(degenerate(0))?;
    let b2 = second_column(b1, a2).ok_or(degenerate(3))?;
    let b3 = b1.cross(b2);
    Ok(Mat3::from_cols(b1, b2, b3))
}

/// The two columns `a1 = r[0..3]`, `a2 = r[3..6]`.
fn columns(r: &[f32; 6]) -> (Vec3, Vec3) {
    let [a1x, a1y, a1z, a2x, a2y, a2z] = *r;
    (Vec3::new(a1x, a1y, a1z), Vec3::new(a2x, a2y, a2z))
}

/// `b1 = a1 / |a1|`, or `None` when `a1` cannot be normalised (see [`Vec3::normalize`]).
fn first_column(a1: Vec3) -> Option<Vec3> {
    let b1 = a1.normalize();
    (b1 != Vec3::ZERO).then_some(b1)
}

/// `b2 = normalize(a2 − (b1·a2) b1)`, or `None` when `a2` is zero, non-finite or parallel to
/// `b1` within [`PARALLEL_TOLERANCE`].
fn second_column(b1: Vec3, a2: Vec3) -> Option<Vec3> {
    let resid = a2 - b1.scale(b1.dot(a2));
    let rn = resid.norm();
    if !(rn.is_finite() && rn > PARALLEL_TOLERANCE * a2.norm()) {
        return None;
    }
    // `normalize` can still return zero if `rn` was positive but the division underflowed; the
    // tolerance test above excludes that for every finite `a2` whose norm is representable.
    let b2 = resid.normalize();
    (b2 != Vec3::ZERO).then_some(b2)
}

/// A unit vector orthogonal to the unit vector `b1`: the coordinate axis least aligned with it
/// (lowest index on ties), with its `b1` component removed, normalised.
fn fallback_second(b1: Vec3) -> Vec3 {
    let (ax, ay, az) = (abs(b1.x), abs(b1.y), abs(b1.z));
    let axis = if ax <= ay && ax <= az {
        Vec3::X
    } else if ay <= az {
        Vec3::Y
    } else {
        Vec3::Z
    };
    // |b1ᵢ| ≤ 1/√3 for the chosen axis, so the residual has length ≥ √(2/3): never degenerate.
    (axis - b1.scale(b1.dot(axis))).normalize()
}

fn abs(x: f32) -> f32 {
    libm::fabsf(x)
}

/// The 6D representation of a rotation matrix: its first two columns, `[c0, c1]`.
pub fn to_6d(m: &Mat3) -> [f32; 6] {
    let [c0, c1, _] = m.cols;
    [c0.x, c0.y, c0.z, c1.x, c1.y, c1.z]
}

/// A rigid transform from 9 parameters `[r0, r1, r2, r3, r4, r5, tx, ty, tz]`: a 6D rotation
/// (see [`from_6d`]) then the translation. This is the layout of AIM's `T ∈ R⁹` in this crate.
pub fn rigid_from_9d(p: &[f32; 9]) -> Rigid {
    let [r0, r1, r2, r3, r4, r5, tx, ty, tz] = *p;
    Rigid::new(from_6d(&[r0, r1, r2, r3, r4, r5]), Vec3::new(tx, ty, tz))
}

/// [`rigid_from_9d`] refusing what it would have to guess: the rotation as [`try_from_6d`], the
/// translation's values finite and within ±[`crate::layout::MAX_COORDINATE`]. The caller's
/// transform `argument` has its 9 values in `p`.
///
/// # Errors
/// [`InputError`] naming the value, or the rotation's degenerate column.
pub fn try_rigid_from_9d(p: &[f32; 9], argument: Argument) -> Result<Rigid, InputError> {
    let [r0, r1, r2, r3, r4, r5, tx, ty, tz] = *p;
    let rot = try_from_6d(&[r0, r1, r2, r3, r4, r5], argument)?;
    for (index, v) in [(6, tx), (7, ty), (8, tz)] {
        check_value(argument, index, v)?;
    }
    Ok(Rigid::new(rot, Vec3::new(tx, ty, tz)))
}

/// The 9 parameters `[6D rotation, tx, ty, tz]` of a rigid transform; inverse of
/// [`rigid_from_9d`] for rotations that came from it.
pub fn rigid_to_9d(t: &Rigid) -> [f32; 9] {
    let [r0, r1, r2, r3, r4, r5] = to_6d(&t.rot);
    [r0, r1, r2, r3, r4, r5, t.trans.x, t.trans.y, t.trans.z]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn assert_rotation(m: &Mat3) {
        let [c0, c1, c2] = m.cols;
        for c in [c0, c1, c2] {
            assert!(
                c.x.is_finite() && c.y.is_finite() && c.z.is_finite(),
                "{m:?}"
            );
            assert!((c.dot(c) - 1.0).abs() < 1e-6, "{m:?}");
        }
        assert!(
            c0.dot(c1).abs() < 1e-6 && c0.dot(c2).abs() < 1e-6 && c1.dot(c2).abs() < 1e-6,
            "{m:?}"
        );
        // det = c0 · (c1 × c2) = +1
        assert!((c0.dot(c1.cross(c2)) - 1.0).abs() < 1e-6, "{m:?}");
    }

    #[test]
    fn identity_round_trip() {
        assert_eq!(from_6d(&identity_6d()), Mat3::IDENTITY);
        assert_eq!(to_6d(&Mat3::IDENTITY), IDENTITY_6D);
    }

    #[test]
    fn gram_schmidt_hand_computed() {
        // a1 = (2, 0, 0) → b1 = (1, 0, 0).
        // a2 = (3, 0, 4): b1·a2 = 3, residual = (0, 0, 4) → b2 = (0, 0, 1).
        // b3 = b1 × b2 = (0·1 − 0·0, 0·0 − 1·1, 1·0 − 0·0) = (0, −1, 0).
        let m = from_6d(&[2.0, 0.0, 0.0, 3.0, 0.0, 4.0]);
        assert_eq!(m.cols, [Vec3::X, Vec3::Z, Vec3::new(0.0, -1.0, 0.0)]);

        // a1 = (0, 3, 4) → |a1| = 5, b1 = (0, 0.6, 0.8).
        // a2 = (1, 0, 0): b1·a2 = 0 → b2 = (1, 0, 0).
        // b3 = b1 × b2 = (0.6·0 − 0.8·0, 0.8·1 − 0·0, 0·0 − 0.6·1) = (0, 0.8, −0.6).
        let m = from_6d(&[0.0, 3.0, 4.0, 1.0, 0.0, 0.0]);
        assert_eq!(
            m.cols,
            [Vec3::new(0.0, 0.6, 0.8), Vec3::X, Vec3::new(0.0, 0.8, -0.6)]
        );
        assert_rotation(&m);
        assert_eq!(to_6d(&m), [0.0, 0.6, 0.8, 1.0, 0.0, 0.0]);
    }

    #[test]
    fn round_trip_of_a_generic_rotation() {
        let m = from_6d(&[0.3, -1.2, 0.5, 2.0, 0.7, -0.4]);
        assert_rotation(&m);
        // The columns of a rotation are already orthonormal: converting back gives them again up
        // to rounding.
        let back = from_6d(&to_6d(&m));
        for (a, b) in back.cols.iter().zip(m.cols.iter()) {
            assert!((*a - *b).norm() < 1e-6);
        }
    }

    #[test]
    fn degenerate_inputs_give_rotations() {
        // All zero → identity.
        assert_eq!(from_6d(&[0.0; 6]), Mat3::IDENTITY);
        // a1 zero: b1 = x, then a2 = (5, 0, 2) → residual (0, 0, 2) → b2 = z, b3 = x × z = −y.
        let m = from_6d(&[0.0, 0.0, 0.0, 5.0, 0.0, 2.0]);
        assert_eq!(m.cols, [Vec3::X, Vec3::Z, Vec3::new(0.0, -1.0, 0.0)]);
        // a2 zero with b1 = z: least aligned axis is x (tie x/y → x) → b2 = x, b3 = z × x = y.
        let m = from_6d(&[0.0, 0.0, 3.0, 0.0, 0.0, 0.0]);
        assert_eq!(m.cols, [Vec3::Z, Vec3::X, Vec3::Y]);
        // Exactly parallel columns that leave a rounding residual.
        let m = from_6d(&[1.0, 1.0, 0.0, 1.0, 1.0, 0.0]);
        assert_rotation(&m);
        // b1 = (1/√2, 1/√2, 0); least aligned axis z → b2 = z.
        assert_eq!(m.cols[1], Vec3::Z);
        // Anti-parallel and nearly parallel.
        assert_rotation(&from_6d(&[0.3, -0.2, 0.9, -0.6, 0.4, -1.8]));
        assert_rotation(&from_6d(&[1.0, 2.0, 3.0, 1.0, 2.0, 3.000_01]));
        // Non-finite values never produce NaN.
        let nan = f32::NAN;
        let inf = f32::INFINITY;
        for r in [
            [nan; 6],
            [inf, 0.0, 0.0, 0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0, nan, 1.0, 0.0],
            [1.0, 0.0, 0.0, 0.0, inf, 0.0],
            [1e-30, 0.0, 0.0, 0.0, 1e-30, 0.0],
            [1e30, 0.0, 0.0, 0.0, 1e30, 0.0],
        ] {
            assert_rotation(&from_6d(&r));
        }
    }

    #[test]
    fn rigid_nine_parameters() {
        let t = rigid_from_9d(&[0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0, 2.0, 3.0]);
        // Columns y, −x → 90° about z; b3 = y × (−x) = z.
        assert_eq!(t.rot.cols, [Vec3::Y, Vec3::new(-1.0, 0.0, 0.0), Vec3::Z]);
        assert_eq!(t.trans, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            rigid_to_9d(&t),
            [0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0, 2.0, 3.0]
        );
    }
}
