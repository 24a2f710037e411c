// S2D eq. 1 (SRVF q = α̇ / √‖α̇‖), eq. 8 (log map) and §4.4 (geodesic path between two motions).
//! Landmark motions as square-root velocity functions on the unit hypersphere (S2D paper,
//! section 3.1, appendix 7.2, and the interpolation of section 4.4): encoding a landmark sequence,
//! the log map, the geodesic distance and the geodesic path between two motions.
//!
//! The layout, the inner product and the decoding are `sinew_core::srvf`'s, which this module
//! shares (the exponential map, the inner product and the decoding run the core's code), so a
//! motion encoded here plays back through the core exactly.
//!
//! Encoding follows the reference: each frame's landmarks are centred and scaled to unit
//! Frobenius norm; the curve through them is resampled to `FRAMES + 1` frames equally spaced in
//! arc length; sample `t` of the SRVF is the velocity of step `t`, `v_t = FRAMES · (c_{t+1} −
//! c_t)`, divided by `√‖v_t‖`, and the whole is scaled to `⟨q, q⟩ = 1`. The curve's arc length
//! `L` is returned beside it: decoding with that length gives the resampled curve back exactly
//! (up to rounding), since `‖q_t‖ q_t = v_t / L`.

use sinew_core::srvf::{FRAMES, exp_map, inner, norm};

/// Why a landmark sequence cannot be encoded, or two motions cannot be compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SrvfError {
    /// Fewer than two frames: a motion needs a start and an end.
    #[error("a landmark sequence needs at least 2 frames, it has {0}")]
    TooFewFrames(usize),
    /// A frame is empty or not whole 3D points, or frames differ in length.
    #[error("frame {0} is not a landmark set of the first frame's length (whole 3D points)")]
    FrameShape(usize),
    /// A frame's landmarks all coincide (or are not finite), so it cannot be normalised.
    #[error("frame {0} has zero size or non-finite coordinates")]
    DegenerateFrame(usize),
    /// The normalised landmarks do not move: a still sequence has no velocity to encode.
    #[error("the landmarks do not move (zero arc length)")]
    Still,
    /// Two motions of different shapes.
    #[error("the motions have different lengths or are not whole frames")]
    Shape,
}

/// An encoded sequence: the unit SRVF and the arc length of the normalised curve.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoded {
    /// `[FRAMES × dims]`, frame-major, `⟨q, q⟩ = 1`.
    pub q: Vec<f32>,
    /// Arc length of the per-frame-normalised landmark curve (the decoding's `length`).
    pub length: f32,
    /// Distance between its first and last frame (the apex's from the neutral): the reach
    /// `sinew_core::srvf::length_for_reach` decodes to.
    pub reach: f32,
}

/// A landmark frame centred on its mean and scaled to unit Frobenius norm, in f64.
///
/// # Errors
/// [`SrvfError::DegenerateFrame`] (with `index`) for a zero-size or non-finite frame.
pub fn normalise_frame(points: &[f32], index: usize) -> Result<Vec<f64>, SrvfError> {
    let k = (points.len() / 3) as f64;
    let mut c = [0.0f64; 3];
    for p in points.chunks_exact(3) {
        for (ci, pi) in c.iter_mut().zip(p) {
            *ci += f64::from(*pi);
        }
    }
    c.iter_mut().for_each(|ci| *ci /= k);
    let centred: Vec<f64> = points
        .chunks_exact(3)
        .flat_map(|p| (0..3).map(move |j| f64::from(p[j]) - c[j]))
        .collect();
    let n = centred.iter().map(|x| x * x).sum::<f64>().sqrt();
    if !(n.is_finite() && n > 0.0) {
        return Err(SrvfError::DegenerateFrame(index));
    }
    Ok(centred.into_iter().map(|x| x / n).collect())
}

/// The polyline through `curve` resampled at `points` positions equally spaced in arc length
/// (first and last points kept). `curve` must have a positive length.
fn resample(curve: &[Vec<f64>], points: usize) -> Vec<Vec<f64>> {
    let dist = |a: &[f64], b: &[f64]| -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (y - x) * (y - x))
            .sum::<f64>()
            .sqrt()
    };
    let mut cumulative = vec![0.0f64; curve.len()];
    for i in 1..curve.len() {
        cumulative[i] = cumulative[i - 1] + dist(&curve[i - 1], &curve[i]);
    }
    let total = cumulative[curve.len() - 1];
    let mut segment = 0;
    (0..points)
        .map(|j| {
            if j + 1 == points {
                return curve[curve.len() - 1].clone();
            }
            let s = total * j as f64 / (points - 1) as f64;
            while segment + 2 < curve.len() && cumulative[segment + 1] < s {
                segment += 1;
            }
            let span = cumulative[segment + 1] - cumulative[segment];
            let w = if span > 0.0 {
                ((s - cumulative[segment]) / span).clamp(0.0, 1.0)
            } else {
                0.0
            };
            curve[segment]
                .iter()
                .zip(&curve[segment + 1])
                .map(|(a, b)| a + w * (b - a))
                .collect()
        })
        .collect()
}

/// The per-frame-normalised curve of `frames`, resampled to `FRAMES + 1` frames equally spaced
/// in arc length, and its arc length: what [`encode`] encodes, and what decoding it onto the
/// first normalised frame gives back.
///
/// # Errors
/// As [`encode`].
pub fn normalised_curve(frames: &[&[f32]]) -> Result<(Vec<Vec<f64>>, f64), SrvfError> {
    if frames.len() < 2 {
        return Err(SrvfError::TooFewFrames(frames.len()));
    }
    let dims = frames[0].len();
    let curve = frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            if f.len() != dims || dims == 0 || !dims.is_multiple_of(3) {
                return Err(SrvfError::FrameShape(i));
            }
            normalise_frame(f, i)
        })
        .collect::<Result<Vec<_>, _>>()?;
    let total: f64 = curve
        .windows(2)
        .map(|w| {
            w[0].iter()
                .zip(&w[1])
                .map(|(a, b)| (b - a) * (b - a))
                .sum::<f64>()
                .sqrt()
        })
        .sum();
    if !(total.is_finite() && total > 0.0) {
        return Err(SrvfError::Still);
    }
    Ok((resample(&curve, FRAMES + 1), total))
}

/// Encodes a landmark sequence (each frame `[K · 3]`, any number ≥ 2 of frames) as a unit SRVF
/// (S2D eq. 1) and its arc length.
///
/// # Errors
/// [`SrvfError`] for too few frames, frames of different or broken shapes, degenerate frames, or
/// landmarks that do not move.
pub fn encode(frames: &[&[f32]]) -> Result<Encoded, SrvfError> {
    let (curve, _) = normalised_curve(frames)?;
    let dims = curve[0].len();
    let reach = curve[0]
        .iter()
        .zip(&curve[FRAMES])
        .map(|(a, b)| (b - a) * (b - a))
        .sum::<f64>()
        .sqrt();
    let mut q = Vec::with_capacity(FRAMES * dims);
    for w in curve.windows(2) {
        let v: Vec<f64> = w[0]
            .iter()
            .zip(&w[1])
            .map(|(a, b)| FRAMES as f64 * (b - a))
            .collect();
        let speed = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        // q = 0 where the curve stops (the paper's convention); arc-length sampling of a moving
        // curve never stops, but a rounding-level step could.
        let k = if speed > 0.0 { 1.0 / speed.sqrt() } else { 0.0 };
        q.extend(v.iter().map(|x| x * k));
    }
    // ⟨q̃, q̃⟩ = Σ_t ‖v_t‖ / FRAMES = L, the arc length.
    let length = q.iter().map(|x| x * x).sum::<f64>() / FRAMES as f64;
    let scale = 1.0 / length.sqrt();
    Ok(Encoded {
        q: q.into_iter().map(|x| (x * scale) as f32).collect(),
        length: length as f32,
        reach: reach as f32,
    })
}

/// `(θ, w)`: the geodesic distance from `p` to `q` and `w = q − ⟨q, p⟩ p`, q's component
/// tangent at `p`. `θ = atan2(‖w‖, ⟨q, p⟩)`, which equals the paper's `acos⟨q, p⟩` on the sphere
/// but keeps its precision near 0 and π, where acos of a rounded cosine does not.
fn angle(p: &[f32], q: &[f32]) -> Result<(f32, Vec<f32>), SrvfError> {
    let c = inner(q, p).map_err(|_| SrvfError::Shape)?;
    let w: Vec<f32> = q.iter().zip(p).map(|(a, b)| a - c * b).collect();
    let s = norm(&w).map_err(|_| SrvfError::Shape)?;
    Ok((s.atan2(c), w))
}

/// Geodesic distance on the hypersphere, `d(q, p) = acos⟨q, p⟩` (S2D appendix 7.2).
///
/// # Errors
/// [`SrvfError::Shape`] if the motions differ in shape.
pub fn distance(q: &[f32], p: &[f32]) -> Result<f32, SrvfError> {
    Ok(angle(p, q)?.0)
}

/// The log map at `p` (S2D eq. 8): `log_p(q) = d / sin(d) · (q − cos(d) p)`, the tangent vector
/// at `p` whose exponential is `q` (0 for `q = p`). The reference clips `⟨q, p⟩` to ±0.98
/// before `acos`; here the angle comes from `atan2` ([`distance`]), exact near 0, so no clipping
/// is needed and `exp_p(log_p(q)) = q` holds for every `q` short of the antipode.
///
/// # Errors
/// [`SrvfError::Shape`] if the motions differ in shape.
pub fn log_map(p: &[f32], q: &[f32]) -> Result<Vec<f32>, SrvfError> {
    let (theta, mut w) = angle(p, q)?;
    let s = norm(&w).map_err(|_| SrvfError::Shape)?;
    // ‖w‖ = sin θ: the factor is θ / sin θ, and 1 in the limit θ → 0.
    let k = if s > 0.0 { theta / s } else { 1.0 };
    w.iter_mut().for_each(|x| *x *= k);
    Ok(w)
}

/// The exponential map at `p` (S2D eq. 8), the core's [`sinew_core::srvf::exp_map`].
///
/// # Errors
/// [`SrvfError::Shape`] if `p` and `s` differ in shape.
pub fn exp(p: &[f32], s: &[f32]) -> Result<Vec<f32>, SrvfError> {
    let mut out = vec![0.0f32; p.len()];
    exp_map(p, s, &mut out).map_err(|_| SrvfError::Shape)?;
    Ok(out)
}

/// The point at `τ ∈ [0, 1]` of the geodesic from `q1` to `q2` (S2D §4.4: `ψ(τ) = (sin((1 − τ)θ)
/// q1 + sin(τθ) q2) / sin θ`), computed as `exp_{q1}(τ log_{q1}(q2))`, the same path, which
/// stays well defined as θ → 0.
///
/// # Errors
/// [`SrvfError::Shape`] if the motions differ in shape.
pub fn interpolate(q1: &[f32], q2: &[f32], tau: f32) -> Result<Vec<f32>, SrvfError> {
    let mut s = log_map(q1, q2)?;
    s.iter_mut().for_each(|x| *x *= tau);
    exp(q1, &s)
}

#[cfg(test)]
mod tests;
