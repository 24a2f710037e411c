//! The fast numeric mode: micromath's approximations where AIM playback spends its transcendental
//! work, through micromath's `F32` type (never its `F32Ext` trait).
//!
//! Posing (eq. 17) is multiply-adds only, so its positions are the `f32` mode's, bit for bit. The
//! one square root per vertex is in the vertex normals: there this mode replaces `libm::sqrtf`
//! and the division by micromath's bit-trick inverse square root refined by one Newton–Raphson
//! step (relative error below 0.2 %, see the tests). Every step is a plain IEEE `f32` operation,
//! so the mode is as deterministic as the reference; it has its own golden hashes.

use micromath::F32;

use crate::error::BufferError;
use crate::linalg::Vec3;
use crate::skinning::{Triangles, vertex_normals_with};

/// `v / |v|` with micromath's inverse square root and one Newton–Raphson step,
/// `y ← y · (1.5 − 0.5 · x · y²)`; zero, never NaN, when the squared length is not a positive
/// finite number (a zero vector, one whose squared length overflows, one with a NaN component),
/// as [`Vec3::normalize`].
#[inline]
pub fn normalize(v: Vec3) -> Vec3 {
    let x = F32(v.dot(v));
    if !(x.0 > 0.0 && x.0.is_finite()) {
        return Vec3::ZERO;
    }
    let y = x.invsqrt();
    let y = y * (F32(1.5) - F32(0.5) * x * y * y);
    v.scale(y.0)
}

/// Area-weighted vertex normals as `crate::skinning::vertex_normals`, normalised with
/// [`normalize`].
///
/// # Errors
/// [`BufferError`] if a length is wrong.
pub fn vertex_normals(
    triangles: &Triangles<'_>,
    positions: &[f32],
    out: &mut [f32],
) -> Result<(), BufferError> {
    vertex_normals_with(triangles, positions, out, normalize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalize_is_within_two_per_mille_of_exact() {
        let mut worst = 0.0f32;
        // Lengths over twelve orders of magnitude and directions around the sphere.
        for i in 0..2000 {
            let t = i as f32 * 0.37;
            let scale = libm::powf(10.0, (i % 13) as f32 - 6.0);
            let v = Vec3::new(libm::cosf(t), libm::sinf(1.3 * t), libm::sinf(t) + 0.1).scale(scale);
            let n = normalize(v);
            let exact = v.normalize();
            let err = (n - exact).norm();
            worst = if err > worst { err } else { worst };
        }
        assert!(worst < 2e-3, "worst {worst}");
        assert!(worst > 0.0, "fast mode should differ from libm somewhere");
    }

    #[test]
    fn zero_vector_stays_zero() {
        assert_eq!(normalize(Vec3::ZERO), Vec3::ZERO);
    }

    #[test]
    fn overflowing_and_nan_vectors_give_zero() {
        // (1e20)² overflows: the inverse square root of infinity would give NaN.
        assert_eq!(normalize(Vec3::new(1e20, 0.0, 0.0)), Vec3::ZERO);
        assert_eq!(normalize(Vec3::new(f32::NAN, 1.0, 0.0)), Vec3::ZERO);
        assert_eq!(normalize(Vec3::new(f32::INFINITY, 0.0, 0.0)), Vec3::ZERO);
    }
}
