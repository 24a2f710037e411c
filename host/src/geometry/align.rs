//! Rigid, similarity and affine alignment of point sets (Horn's closed form, weighted least
//! squares) and the `f64` 3×3 algebra they need, for the bone fit and the actor's training set.

use crate::geometry::vec3::{V3, add, cross, dot, scale, sub, to64};
pub(crate) type M3 = [[f64; 3]; 3];

/// `x ↦ a x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Affine {
    pub(crate) a: M3,
    pub(crate) t: V3,
}

impl Affine {
    pub(crate) fn apply(&self, p: V3) -> V3 {
        add(mat_vec(self.a, p), self.t)
    }

    /// Uniform scale (cube root of the determinant's magnitude).
    pub(crate) fn scale(&self) -> f64 {
        det3(self.a).abs().cbrt()
    }

    pub(crate) fn inverse(&self) -> Option<Affine> {
        let inv = inv3(self.a)?;
        Some(Affine {
            a: inv,
            t: scale(mat_vec(inv, self.t), -1.0),
        })
    }

    pub(crate) fn matrix(&self) -> [[f32; 4]; 3] {
        let r = |i: usize| {
            [
                self.a[i][0] as f32,
                self.a[i][1] as f32,
                self.a[i][2] as f32,
                self.t[i] as f32,
            ]
        };
        [r(0), r(1), r(2)]
    }
}

/// Weighted means and centred cross-covariance `Σ w (y - ȳ)(x - x̄)ᵀ` and `Σ w (x - x̄)(x - x̄)ᵀ`.
pub(crate) fn moments(x: &[V3], y: &[V3], w: &[f64]) -> (V3, V3, M3, M3, f64) {
    let ws: f64 = w.iter().sum();
    let ws = if ws > 0.0 { ws } else { 1.0 };
    let mut mx = [0.0; 3];
    let mut my = [0.0; 3];
    for ((p, q), &wi) in x.iter().zip(y).zip(w) {
        mx = add(mx, scale(*p, wi / ws));
        my = add(my, scale(*q, wi / ws));
    }
    let mut cyx = [[0.0; 3]; 3];
    let mut cxx = [[0.0; 3]; 3];
    for ((p, q), &wi) in x.iter().zip(y).zip(w) {
        let (xc, yc) = (sub(*p, mx), sub(*q, my));
        for i in 0..3 {
            for j in 0..3 {
                cyx[i][j] += wi * yc[i] * xc[j];
                cxx[i][j] += wi * xc[i] * xc[j];
            }
        }
    }
    (mx, my, cyx, cxx, ws)
}

/// The rotation `R` maximising `tr(Rᵀ C_yx)`, i.e. the rotation of the weighted least-squares
/// fit `y ≈ R x + t` (or `s R x + t`) given the centred cross-covariance `C_yx` of
/// [`moments`]: Horn 1987's quaternion solution (the minimiser Umeyama 1991 gives in closed
/// form), always a proper rotation.
pub(crate) fn horn_rotation(cyx: &M3) -> M3 {
    // Horn's S_ab = Σ x_a y_b = cyx[b][a].
    let s = |a: usize, b: usize| cyx[b][a];
    let n = [
        [
            s(0, 0) + s(1, 1) + s(2, 2),
            s(1, 2) - s(2, 1),
            s(2, 0) - s(0, 2),
            s(0, 1) - s(1, 0),
        ],
        [
            s(1, 2) - s(2, 1),
            s(0, 0) - s(1, 1) - s(2, 2),
            s(0, 1) + s(1, 0),
            s(2, 0) + s(0, 2),
        ],
        [
            s(2, 0) - s(0, 2),
            s(0, 1) + s(1, 0),
            -s(0, 0) + s(1, 1) - s(2, 2),
            s(1, 2) + s(2, 1),
        ],
        [
            s(0, 1) - s(1, 0),
            s(2, 0) + s(0, 2),
            s(1, 2) + s(2, 1),
            -s(0, 0) - s(1, 1) + s(2, 2),
        ],
    ];
    let (vals, vecs) = jacobi_eigen(n);
    let best = (0..4).fold(0, |b, i| if vals[i] > vals[b] { i } else { b });
    quat_to_mat([vecs[0][best], vecs[1][best], vecs[2][best], vecs[3][best]])
}

/// The weighted least-squares similarity `y ≈ s R x + t` (Horn 1987's quaternion solution; it
/// is the minimiser Umeyama 1991 gives in closed form and always a proper rotation).
pub(crate) fn fit_similarity(x: &[V3], y: &[V3], w: &[f64]) -> Affine {
    let (mx, my, cyx, cxx, _) = moments(x, y, w);
    let r = horn_rotation(&cyx);
    let var = cxx[0][0] + cxx[1][1] + cxx[2][2];
    // s = Σ w (y - ȳ)·R(x - x̄) / Σ w |x - x̄|² = tr(Rᵀ C_yx) / tr(C_xx).
    let mut num = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            num += r[i][j] * cyx[i][j];
        }
    }
    let sc = if var > 0.0 { num / var } else { 1.0 };
    let a = r.map(|row| row.map(|v| v * sc));
    Affine {
        a,
        t: sub(my, mat_vec(a, mx)),
    }
}

/// A rigid transform `x ↦ R x + t` from [`fit_rigid`], in `f64`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidFit {
    /// The rotation `R`, row-major (`rotation[i][j]` is row `i`, column `j`); proper.
    pub rotation: [[f64; 3]; 3],
    /// The translation `t`, added after rotating.
    pub translation: [f64; 3],
}

impl RigidFit {
    /// `R p + t`.
    pub fn apply(&self, p: [f64; 3]) -> [f64; 3] {
        add(mat_vec(self.rotation, p), self.translation)
    }
}

/// The least-squares rigid transform `y ≈ R x + t` taking the points `x` to the corresponding
/// points `y` (Horn 1987's quaternion rotation, as in the bone fit's similarity, without the
/// scale). `None` when the two lists differ in length, a coordinate is not finite, or the
/// points `x` do not determine a rotation: fewer than three, or (nearly) collinear (the second
/// principal variance under 1e-9 of the first).
pub fn fit_rigid(x: &[[f32; 3]], y: &[[f32; 3]]) -> Option<RigidFit> {
    if x.len() != y.len() || x.len() < 3 {
        return None;
    }
    let x: Vec<V3> = x.iter().copied().map(to64).collect();
    let y: Vec<V3> = y.iter().copied().map(to64).collect();
    if x.iter().chain(&y).flatten().any(|c| !c.is_finite()) {
        return None;
    }
    let (mx, my, cyx, cxx, _) = moments(&x, &y, &vec![1.0; x.len()]);
    let (mut spread, _) = jacobi_eigen(cxx);
    spread.sort_by(|a, b| b.total_cmp(a));
    if !(spread[0] > 0.0 && spread[1] > 1e-9 * spread[0]) {
        return None;
    }
    let rotation = horn_rotation(&cyx);
    Some(RigidFit {
        rotation,
        translation: sub(my, mat_vec(rotation, mx)),
    })
}

/// The weighted least-squares affine map `y ≈ A x + t`: `A = C_yx C_xx⁻¹`. `None` when the
/// points are (nearly) coplanar.
pub(crate) fn fit_affine(x: &[V3], y: &[V3], w: &[f64]) -> Option<Affine> {
    let (mx, my, cyx, cxx, _) = moments(x, y, w);
    let inv = inv3(cxx)?;
    let a = mat_mul(cyx, inv);
    Some(Affine {
        a,
        t: sub(my, mat_vec(a, mx)),
    })
}

/// Eigenvalues and eigenvectors (columns) of a symmetric matrix by cyclic Jacobi rotations.
pub(crate) fn jacobi_eigen<const N: usize>(mut a: [[f64; N]; N]) -> ([f64; N], [[f64; N]; N]) {
    let mut v = [[0.0; N]; N];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for _sweep in 0..64 {
        let off: f64 = (0..N)
            .flat_map(|i| (0..N).map(move |j| (i, j)))
            .filter(|(i, j)| i != j)
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let scale: f64 = (0..N).map(|i| a[i][i] * a[i][i]).sum::<f64>() + off;
        if off <= 1e-30 * scale.max(1e-300) {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if a[p][q] == 0.0 {
                    continue;
                }
                let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for row in a.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (rp, rq) = (a[p], a[q]);
                for k in 0..N {
                    a[p][k] = c * rp[k] - s * rq[k];
                    a[q][k] = s * rp[k] + c * rq[k];
                }
                for row in v.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    let mut vals = [0.0; N];
    for (i, val) in vals.iter_mut().enumerate() {
        *val = a[i][i];
    }
    (vals, v)
}

/// Singular values of a 3×3 matrix, largest first.
pub(crate) fn singular_values(a: M3) -> [f64; 3] {
    let ata = mat_mul(transpose(a), a);
    let (vals, _) = jacobi_eigen(ata);
    let mut s = vals.map(|v| v.max(0.0).sqrt());
    s.sort_by(|x, y| y.total_cmp(x));
    s
}

pub(crate) fn quat_to_mat(q: [f64; 4]) -> M3 {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let [w, x, y, z] = if n > 0.0 {
        q.map(|c| c / n)
    } else {
        [1.0, 0.0, 0.0, 0.0]
    };
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ]
}

pub(crate) fn mat_vec(m: M3, v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}
pub(crate) fn mat_mul(a: M3, b: M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}
pub(crate) fn transpose(a: M3) -> M3 {
    [
        [a[0][0], a[1][0], a[2][0]],
        [a[0][1], a[1][1], a[2][1]],
        [a[0][2], a[1][2], a[2][2]],
    ]
}
/// The cofactor matrix: `det(a) a⁻ᵀ`, which maps normals (up to length and sign).
pub(crate) fn cofactor(a: M3) -> M3 {
    [cross(a[1], a[2]), cross(a[2], a[0]), cross(a[0], a[1])]
}
pub(crate) fn det3(a: M3) -> f64 {
    dot(a[0], cross(a[1], a[2]))
}
/// The inverse of `a`, or `None` when it is near singular (determinant within 1e-12 of the cube
/// of its largest entry) or not finite.
pub(crate) fn inv3(a: M3) -> Option<M3> {
    let d = det3(a);
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if d.is_nan() || d.abs() <= 1e-12 * scale * scale * scale {
        return None;
    }
    cofactor_inverse(a, d)
}
/// The inverse of `a` whenever its determinant is non-zero and finite (the caller judges how
/// thin a matrix may be; deformation transfer rejects thin triangles itself).
pub(crate) fn inverse_unless_singular(a: M3) -> Option<M3> {
    let d = det3(a);
    if d == 0.0 || !d.is_finite() {
        return None;
    }
    cofactor_inverse(a, d)
}
/// `a⁻¹ = cofactor(a)ᵀ / det`, with `d = det3(a)`.
fn cofactor_inverse(a: M3, d: f64) -> Option<M3> {
    Some(transpose(cofactor(a)).map(|row| row.map(|v| v / d)))
}
