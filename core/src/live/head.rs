//! The head pose that best places the actor's steady rest landmarks (nose and eyes) on a
//! tracker's: Gauss–Newton over a rotation and a translation, from a start (the driver's own
//! answer), a fixed number of steps. In 2D the landmarks are seen by the driver's canonical
//! camera (perspective-n-point); in 3D they are compared where they are.
//!
//! The steady landmarks are where trackers agree with each other and with the actor's vertices
//! (eye corners, the nose), and expressions hardly move them, so the head found there leaves a
//! tracker's convention on the contour, the lips and the brows to the calibration's offsets
//! instead of folding it into the head.

use crate::linalg::{Mat3, Rigid, Vec3};
use crate::rotation::{from_6d, to_6d};

/// Gauss–Newton steps (the start is the driver's answer, within a few degrees and
/// millimetres).
pub const STEPS: usize = 5;

/// Where the head's landmarks are compared with the tracker's.
#[derive(Clone, Copy, Debug)]
pub enum View {
    /// Seen by a pinhole camera at this centre, looking along −z, v down (normalised image
    /// coordinates), points nearer than `min_depth` seen at that depth.
    Camera {
        /// The camera's centre.
        centre: Vec3,
        /// The smallest depth.
        min_depth: f32,
    },
    /// In space.
    Space,
}

/// The rigid motion `start` improved by [`STEPS`] Gauss–Newton steps so that `rest[i]`, moved
/// by it (and seen by `view`), lies on `seen(i)` (2 or 3 values) in the least-squares sense.
/// A step that would not be finite, or that the normal equations cannot give, ends the fit.
pub fn fit(view: View, rest: &[Vec3], seen: impl Fn(usize) -> [f32; 3], start: Rigid) -> Rigid {
    let mut head = start;
    for _ in 0..STEPS {
        let mut a = [[0.0f32; 6]; 6];
        let mut b = [0.0f32; 6];
        for (i, &p) in rest.iter().enumerate() {
            let turned = head.rot.mul_vec(p);
            let x = turned + head.trans;
            let target = seen(i);
            // Each row: a residual and its derivative by (ω, τ), where the step moves x by
            // ω × turned + τ.
            let rows = match view {
                View::Camera { centre, min_depth } => {
                    let d = centre.z - x.z;
                    let d = if d >= min_depth { d } else { min_depth };
                    let (u, v) = ((x.x - centre.x) / d, -(x.y - centre.y) / d);
                    // ∂u/∂x = (1/d, 0, u/d), ∂v/∂x = (0, −1/d, v/d).
                    let du = Vec3::new(1.0 / d, 0.0, u / d);
                    let dv = Vec3::new(0.0, -1.0 / d, v / d);
                    [(u - target[0], du), (v - target[1], dv), (0.0, Vec3::ZERO)]
                }
                View::Space => [
                    (x.x - target[0], Vec3::X),
                    (x.y - target[1], Vec3::Y),
                    (x.z - target[2], Vec3::Z),
                ],
            };
            for (r, g) in rows {
                // ∂(g · (ω × q + τ)) = (q × g, g).
                let w = turned.cross(g);
                let j = [w.x, w.y, w.z, g.x, g.y, g.z];
                for (row, &jr) in a.iter_mut().zip(&j) {
                    for (cell, &jc) in row.iter_mut().zip(&j) {
                        *cell += jr * jc;
                    }
                }
                for (bi, &ji) in b.iter_mut().zip(&j) {
                    *bi -= ji * r;
                }
            }
        }
        let Some(step) = solve(a, b) else { break };
        if step.iter().any(|v| !v.is_finite()) {
            break;
        }
        let turn = rodrigues(Vec3::new(step[0], step[1], step[2]));
        let rot = from_6d(&to_6d(&turn.mul_mat(&head.rot)));
        // x = R p + t becomes turn · R p + t + τ.
        head = Rigid::new(rot, head.trans + Vec3::new(step[3], step[4], step[5]));
    }
    head
}

/// The rotation by the vector `w` (axis times angle, radians).
fn rodrigues(w: Vec3) -> Mat3 {
    let angle = w.norm();
    if angle.is_nan() || angle <= 1e-12 {
        return Mat3::IDENTITY;
    }
    let k = w.scale(1.0 / angle);
    let (s, c) = (libm::sinf(angle), libm::cosf(angle));
    let col = |e: Vec3| e.scale(c) + k.cross(e).scale(s) + k.scale(k.dot(e) * (1.0 - c));
    Mat3::from_cols(col(Vec3::X), col(Vec3::Y), col(Vec3::Z))
}

/// `a x = b` for the symmetric 6 × 6 `a` by Cholesky, with a ridge of 1e-6 of the diagonal's
/// largest value (so that a direction the landmarks do not see stays put); `None` when `a` is
/// not positive.
fn solve(mut a: [[f32; 6]; 6], b: [f32; 6]) -> Option<[f32; 6]> {
    let largest = (0..6).fold(0.0f32, |m, i| {
        let v = a.get(i).and_then(|r| r.get(i)).copied().unwrap_or(0.0);
        if v > m { v } else { m }
    });
    if largest.is_nan() || largest <= 0.0 {
        return None;
    }
    for (i, row) in a.iter_mut().enumerate() {
        if let Some(d) = row.get_mut(i) {
            *d += 1e-6 * largest;
        }
    }
    // a = L Lᵀ, L stored in the lower triangle of `l`.
    let mut l = [[0.0f32; 6]; 6];
    for i in 0..6 {
        for j in 0..=i {
            let mut sum = a.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0);
            for k in 0..j {
                sum -= at(&l, i, k) * at(&l, j, k);
            }
            let v = if i == j {
                if sum.is_nan() || sum <= 0.0 {
                    return None;
                }
                libm::sqrtf(sum)
            } else {
                sum / at(&l, j, j)
            };
            if let Some(cell) = l.get_mut(i).and_then(|r| r.get_mut(j)) {
                *cell = v;
            }
        }
    }
    let mut y = [0.0f32; 6];
    for i in 0..6 {
        let mut sum = b.get(i).copied().unwrap_or(0.0);
        for k in 0..i {
            sum -= at(&l, i, k) * y.get(k).copied().unwrap_or(0.0);
        }
        if let Some(v) = y.get_mut(i) {
            *v = sum / at(&l, i, i);
        }
    }
    let mut x = [0.0f32; 6];
    for i in (0..6).rev() {
        let mut sum = y.get(i).copied().unwrap_or(0.0);
        for k in i + 1..6 {
            sum -= at(&l, k, i) * x.get(k).copied().unwrap_or(0.0);
        }
        if let Some(v) = x.get_mut(i) {
            *v = sum / at(&l, i, i);
        }
    }
    Some(x)
}

fn at(m: &[[f32; 6]; 6], i: usize, j: usize) -> f32 {
    m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> [Vec3; 21] {
        core::array::from_fn(|i| {
            let f = i as f32;
            Vec3::new(
                libm::sinf(1.3 * f) * 3.0,
                libm::cosf(0.7 * f) * 2.0 + 1.0,
                libm::sinf(0.4 * f) * 1.5 + 8.0,
            )
        })
    }

    #[test]
    fn the_head_that_placed_the_points_is_found_again() {
        let points = cloud();
        let truth = Rigid::new(
            rodrigues(Vec3::new(0.08, -0.25, 0.05)),
            Vec3::new(1.5, -0.8, 4.0),
        );
        let camera = Vec3::new(0.5, 1.0, 70.0);
        let view = View::Camera {
            centre: camera,
            min_depth: 0.1,
        };
        let seen = |i: usize| {
            let x = truth.apply(points[i]);
            let d = camera.z - x.z;
            [(x.x - camera.x) / d, -(x.y - camera.y) / d, 0.0]
        };
        let start = Rigid::new(Mat3::IDENTITY, Vec3::new(0.0, 0.0, 0.0));
        let found = fit(view, &points, seen, start);
        let moved = |r: &Rigid| points.map(|p| r.apply(p));
        let worst = moved(&found)
            .iter()
            .zip(moved(&truth))
            .map(|(a, b)| (*a - b).norm())
            .fold(0.0f32, f32::max);
        assert!(worst < 0.02, "{worst} {found:?}");
        let in_space = fit(
            View::Space,
            &points,
            |i| truth.apply(points[i]).to_array(),
            start,
        );
        let worst = moved(&in_space)
            .iter()
            .zip(moved(&truth))
            .map(|(a, b)| (*a - b).norm())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-3, "{worst}");
    }

    #[test]
    fn no_landmarks_leave_the_start_where_it_was() {
        let start = Rigid::new(
            rodrigues(Vec3::new(0.1, 0.0, 0.0)),
            Vec3::new(1.0, 2.0, 3.0),
        );
        assert_eq!(fit(View::Space, &[], |_| [0.0; 3], start), start);
        assert_eq!(solve([[0.0; 6]; 6], [1.0; 6]), None);
    }
}
