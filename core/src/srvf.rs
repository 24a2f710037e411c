//! Landmark motions as square-root velocity functions (SRVF) on the unit hypersphere, the
//! representation Motion3DGAN generates in (S2D paper, section 3.1 and appendix 7.2): the
//! exponential map that turns a generated tangent vector into a motion, and the decoding of a
//! motion back into a landmark curve on any neutral face.
//!
//! A motion is [`FRAMES`] samples `q_t` of `dims` coordinates each (`dims = 3 K` for `K`
//! landmarks), frame-major: `q[t · dims + d]`. It encodes a landmark curve of `FRAMES + 1`
//! frames, frame 0 the neutral, sampled at equal steps `h = 1 / FRAMES`: sample `t` is the
//! velocity on the step from frame `t` to frame `t + 1`, so decoding is an exact inverse of the
//! host's encoding (`sinew-host`, `motion::srvf`) up to rounding. The inner product is
//! `⟨a, b⟩ = Σ a_i b_i / FRAMES` (the integral over [0, 1]), and motions have `⟨q, q⟩ = 1`.
//!
//! Every sum runs in index order and every transcendental is a `libm` free function, so the
//! same motion decodes to the same bits on every target.

use crate::error::BufferError;

/// Samples of a motion (the paper's sequences of 30 frames from neutral to apex); the decoded
/// curve has one more frame, the neutral.
pub const FRAMES: usize = 30;

/// `⟨a, b⟩ = Σ_i a_i b_i / FRAMES`, summed in index order: the hypersphere's inner product.
///
/// # Errors
/// [`BufferError::Input`] if the lengths differ or are not a whole number of frames.
pub fn inner(a: &[f32], b: &[f32]) -> Result<f32, BufferError> {
    if a.len() != b.len() || !a.len().is_multiple_of(FRAMES) {
        return Err(BufferError::Input);
    }
    Ok(dot(a, b) / FRAMES as f32)
}

/// `Σ a_i b_i` in index order (lengths already checked).
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut s = 0.0f32;
    for (x, y) in a.iter().zip(b) {
        s += *x * *y;
    }
    s
}

/// `‖a‖ = √⟨a, a⟩`.
///
/// # Errors
/// [`BufferError::Input`] if the length is not a whole number of frames.
pub fn norm(a: &[f32]) -> Result<f32, BufferError> {
    Ok(libm::sqrtf(inner(a, a)?))
}

/// The exponential map at `p` (S2D eq. 8): `exp_p(s) = cos(‖s‖) p + sin(‖s‖) s / ‖s‖` into `out`
/// (`p` itself when `‖s‖ = 0`). `p` is a point of the sphere and `s` a tangent vector at `p`
/// (`⟨s, p⟩ = 0`); for such inputs `‖out‖ = 1` up to rounding. A vector with a component along
/// `p` is mapped as the formula says, off the sphere: project it first ([`project_tangent`]).
///
/// # Errors
/// [`BufferError::Input`] if `p` and `s` differ in length or are not whole frames;
/// [`BufferError::Output`] if `out` has another length.
pub fn exp_map(p: &[f32], s: &[f32], out: &mut [f32]) -> Result<(), BufferError> {
    let n = norm_pair(p, s)?;
    if out.len() != p.len() {
        return Err(BufferError::Output);
    }
    let (c, k) = if n > 0.0 {
        (libm::cosf(n), libm::sinf(n) / n)
    } else {
        (1.0, 0.0)
    };
    for ((o, pi), si) in out.iter_mut().zip(p).zip(s) {
        *o = c * *pi + k * *si;
    }
    Ok(())
}

/// `‖s‖` after checking that `p` and `s` are motions of one shape.
fn norm_pair(p: &[f32], s: &[f32]) -> Result<f32, BufferError> {
    inner(p, s)?;
    norm(s)
}

/// Removes from `s` its component along the unit motion `p`: `s ← s − ⟨s, p⟩ p`, the tangent
/// space at `p` (what the exponential map expects).
///
/// # Errors
/// [`BufferError::Input`] if `p` and `s` differ in length or are not whole frames.
pub fn project_tangent(p: &[f32], s: &mut [f32]) -> Result<(), BufferError> {
    let a = inner(p, s)?;
    for (si, pi) in s.iter_mut().zip(p) {
        *si -= a * *pi;
    }
    Ok(())
}

/// Centred Frobenius norm of a `[K, 3]` landmark set (the size the encoding divides each frame
/// by); 0 for an empty or degenerate set.
pub fn landmark_size(points: &[f32]) -> f32 {
    crate::s2d::centre_size(points).1
}

/// A decoded motion whose ends are closer than this fraction of its length is decoded as if they
/// were this far apart ([`length_for_reach`]): no training motion comes near it (the least
/// straight class averages 0.68), and it keeps the length of a motion that returns to where it
/// started finite.
pub const MIN_STRAIGHTNESS: f32 = 0.25;

/// The straightness of the motion `q` (`[FRAMES × dims]`, `⟨q, q⟩ = 1`): the distance between the
/// first and the last frame of its curve decoded at length 1 on a neutral of size 1,
/// `‖Σ_t ‖q_t‖ q_t‖ / FRAMES` (1 for a motion along a straight line, less for one that turns or
/// wavers). Summed per coordinate over the frames in order.
///
/// # Errors
/// [`BufferError::Input`] if `q` is not [`FRAMES`] frames of `dims` coordinates.
pub fn straightness(q: &[f32], dims: usize) -> Result<f32, BufferError> {
    if dims == 0 || q.len() != FRAMES * dims {
        return Err(BufferError::Input);
    }
    let mut speed = [0.0f32; FRAMES];
    for (s, qt) in speed.iter_mut().zip(q.chunks_exact(dims)) {
        *s = libm::sqrtf(dot(qt, qt));
    }
    let mut total = 0.0f32;
    for d in 0..dims {
        let mut sum = 0.0f32;
        for (s, x) in speed.iter().zip(q.iter().skip(d).step_by(dims)) {
            sum += *s * *x;
        }
        total += sum * sum;
    }
    Ok(libm::sqrtf(total) / FRAMES as f32)
}

/// The length [`decode`] takes for the motion `q` to end `reach` away from where it starts (in
/// units of the per-frame normalised landmarks, as a length): `reach / straightness(q)`, the
/// straightness at least [`MIN_STRAIGHTNESS`]. How far an expression goes is its apex's distance
/// from the neutral; a motion's arc length also counts how much it wavers on the way.
///
/// # Errors
/// As [`straightness`].
pub fn length_for_reach(q: &[f32], dims: usize, reach: f32) -> Result<f32, BufferError> {
    Ok(reach / straightness(q, dims)?.max(MIN_STRAIGHTNESS))
}

/// Decodes the motion `q` onto the landmarks `neutral` (S2D eq. 5, `α(t) = ∫₀ᵗ ‖q(s)‖ q(s) ds +
/// α(0)`, as a left Riemann sum over the [`FRAMES`] steps): `out` receives `FRAMES + 1` landmark
/// frames, frame-major, frame 0 the neutral and
/// `α_{t+1} = α_t + (length · size(neutral) / FRAMES) · ‖q_t‖ · q_t`,
/// with `‖q_t‖` the Euclidean norm of sample `t` and `size` the neutral's centred Frobenius norm
/// ([`landmark_size`]). A unit motion loses its curve's length; `length` puts it back (the arc
/// length of the encoded curve in units of the per-frame normalised landmarks: the intensity,
/// which eq. 5 allows to scale), and `size` carries the normalised motion onto the neutral's
/// scale, so one motion plays on any face.
///
/// # Errors
/// [`BufferError::Input`] if `q` is not a whole number of frames of `neutral.len()` coordinates
/// (or `neutral` is not whole points); [`BufferError::Output`] if `out` is not
/// `(FRAMES + 1) · neutral.len()` long.
pub fn decode(q: &[f32], neutral: &[f32], length: f32, out: &mut [f32]) -> Result<(), BufferError> {
    let dims = neutral.len();
    if dims == 0 || !dims.is_multiple_of(3) || q.len() != FRAMES * dims {
        return Err(BufferError::Input);
    }
    if out.len() != (FRAMES + 1) * dims {
        return Err(BufferError::Output);
    }
    let step = length * landmark_size(neutral) / FRAMES as f32;
    let (first, rest) = out.split_at_mut(dims);
    first.copy_from_slice(neutral);
    let mut previous: &[f32] = first;
    for (qt, next) in q.chunks_exact(dims).zip(rest.chunks_exact_mut(dims)) {
        let k = step * libm::sqrtf(dot(qt, qt));
        for ((n, a), v) in next.iter_mut().zip(previous).zip(qt) {
            *n = *a + k * *v;
        }
        previous = next;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// A deterministic unit motion of `dims` coordinates per frame.
    fn motion(dims: usize, seed: u32) -> Vec<f32> {
        let mut q: Vec<f32> = (0..FRAMES * dims)
            .map(|i| libm::sinf((i as f32 + 1.0) * 0.37 + seed as f32))
            .collect();
        let n = norm(&q).unwrap();
        q.iter_mut().for_each(|x| *x /= n);
        q
    }

    #[test]
    fn exp_map_stays_on_the_sphere_and_is_p_at_zero() {
        let p = motion(6, 1);
        let mut s = motion(6, 2);
        project_tangent(&p, &mut s).unwrap();
        assert!(inner(&p, &s).unwrap().abs() < 1e-6);
        for scale in [0.0f32, 1e-4, 0.3, 1.0, 2.5] {
            let v: Vec<f32> = s.iter().map(|x| x * scale).collect();
            let mut out = vec![0.0; p.len()];
            exp_map(&p, &v, &mut out).unwrap();
            assert!((norm(&out).unwrap() - 1.0).abs() < 1e-5, "scale {scale}");
            if scale == 0.0 {
                assert_eq!(out, p);
            }
        }
    }

    #[test]
    fn decode_starts_at_the_neutral_and_scales_with_length_and_size() {
        let dims = 6;
        let q = motion(dims, 3);
        let neutral = [0.0f32, 0.0, 0.0, 2.0, 0.0, 0.0];
        let mut a = vec![0.0; (FRAMES + 1) * dims];
        let mut b = a.clone();
        decode(&q, &neutral, 0.5, &mut a).unwrap();
        decode(&q, &neutral, 1.0, &mut b).unwrap();
        assert_eq!(&a[..dims], &neutral);
        // The path length of the decoded curve is length · size · ⟨q, q⟩ = length · √2.
        let path = |c: &[f32]| -> f32 {
            c.chunks_exact(dims)
                .zip(c.chunks_exact(dims).skip(1))
                .map(|(x, y)| libm::sqrtf(x.iter().zip(y).map(|(u, v)| (v - u) * (v - u)).sum()))
                .sum()
        };
        assert!((path(&a) - 0.5 * libm::sqrtf(2.0)).abs() < 1e-4);
        assert!((path(&b) - libm::sqrtf(2.0)).abs() < 1e-4);
    }

    #[test]
    fn wrong_lengths_are_refused() {
        let q = motion(6, 4);
        let mut out = vec![0.0; (FRAMES + 1) * 6];
        assert_eq!(inner(&q, &q[1..]), Err(BufferError::Input));
        assert_eq!(
            decode(&q, &[0.0; 9], 1.0, &mut out),
            Err(BufferError::Input)
        );
        assert_eq!(
            decode(&q, &[0.0; 6], 1.0, &mut out[1..]),
            Err(BufferError::Output)
        );
        assert_eq!(exp_map(&q, &q, &mut out), Err(BufferError::Output));
        assert_eq!(straightness(&q, 9), Err(BufferError::Input));
        assert_eq!(straightness(&q, 0), Err(BufferError::Input));
    }

    #[test]
    fn a_motion_decoded_for_a_reach_ends_that_far_from_the_neutral() {
        // Straight: every sample the same direction, so the ends are the whole length apart.
        let dims = 6;
        let mut line = vec![0.0f32; FRAMES * dims];
        for qt in line.chunks_exact_mut(dims) {
            qt[0] = 1.0;
        }
        assert!((straightness(&line, dims).unwrap() - 1.0).abs() < 1e-6);
        // Out along one axis for half the frames and along another for the rest: the ends are
        // √2 / 2 of the length apart.
        let mut corner = vec![0.0f32; FRAMES * dims];
        for (t, qt) in corner.chunks_exact_mut(dims).enumerate() {
            qt[usize::from(t >= FRAMES / 2)] = 1.0;
        }
        let s = straightness(&corner, dims).unwrap();
        assert!((s - 0.5 * libm::sqrtf(2.0)).abs() < 1e-6, "{s}");
        // Decoded at the length for a reach, the last frame is that reach (times the neutral's
        // size) from the first.
        let neutral = [0.0f32, 0.0, 0.0, 2.0, 0.0, 0.0];
        let size = landmark_size(&neutral);
        // A quarter circle, sampled per step at the step's middle angle.
        let mut arc = vec![0.0f32; FRAMES * dims];
        for (t, qt) in arc.chunks_exact_mut(dims).enumerate() {
            let a = core::f32::consts::FRAC_PI_2 * (t as f32 + 0.5) / FRAMES as f32;
            qt[0] = libm::cosf(a);
            qt[1] = libm::sinf(a);
        }
        for q in [&line, &corner, &arc] {
            let length = length_for_reach(q, dims, 0.3).unwrap();
            let mut out = vec![0.0f32; (FRAMES + 1) * dims];
            decode(q, &neutral, length, &mut out).unwrap();
            let last = &out[FRAMES * dims..];
            let d = libm::sqrtf(
                last.iter()
                    .zip(&neutral)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum(),
            );
            assert!((d - 0.3 * size).abs() < 1e-4 * size, "{d}");
        }
        // A motion that comes back to its start is decoded at most 1 / MIN_STRAIGHTNESS times
        // its reach.
        let mut back = line.clone();
        for qt in back.chunks_exact_mut(dims).skip(FRAMES / 2) {
            qt[0] = -1.0;
        }
        assert_eq!(straightness(&back, dims).unwrap(), 0.0);
        assert_eq!(
            length_for_reach(&back, dims, 0.3).unwrap(),
            0.3 / MIN_STRAIGHTNESS
        );
    }
}
