//! Optimal-step non-rigid ICP (Amberg, Romdhani and Vetter, CVPR 2007): a template surface
//! deformed onto a target by one affine transform per template vertex, found for a decreasing
//! schedule of stiffness weights, each by alternating closest-point correspondences with the
//! linear least-squares step of the paper's eq. 4:
//!
//! `E(X) = α² ‖(M ⊗ G) X‖² + ‖W (D X − U)‖²`
//!
//! (`M`: the template's edge-node incidence, `G = diag(1, 1, 1, γ)`, `D`: each vertex as
//! `[x y z 1]`, `U`: its correspondence, `W`: per-vertex weights, zero for correspondences that
//! are too far, on the target's border, or facing away). The normal equations are solved by
//! conjugate gradients with a 4 × 4 block-Jacobi preconditioner, three right-hand sides (x, y, z)
//! over one matrix that is applied without being stored.

use nalgebra::{Matrix4, Vector4};

use crate::geometry::surface::{Surface, agree};
use crate::geometry::vec3::{V3, add, cross, norm, normalize, sub};

/// The stiffness schedule, for coordinates scaled to a unit radius.
pub(crate) const STIFFNESS: [f64; 9] = [50.0, 20.0, 10.0, 5.0, 2.0, 0.8, 0.5, 0.35, 0.2];

/// A registration's settings.
#[derive(Clone, Debug)]
pub(crate) struct Settings {
    /// The stiffness weights α, in order.
    pub(crate) stiffness: Vec<f64>,
    /// `γ`: the weight of the translation part against the linear part.
    pub(crate) gamma: f64,
    /// Correspondences farther than this are dropped.
    pub(crate) max_distance: f64,
    /// Correspondences whose normals differ by more than this are dropped (degrees).
    pub(crate) max_angle: f64,
    /// The most alternations per stiffness.
    pub(crate) iterations: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            stiffness: STIFFNESS.to_vec(),
            gamma: 1.0,
            max_distance: 0.1,
            max_angle: 60.0,
            iterations: 6,
        }
    }
}

/// Area-weighted vertex normals of a triangle mesh.
pub(crate) fn normals(points: &[V3], triangles: &[[u32; 3]]) -> Vec<V3> {
    let mut n = vec![[0.0; 3]; points.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let f = cross(sub(b, a), sub(c, a));
        for &i in t {
            n[i as usize] = add(n[i as usize], f);
        }
    }
    n.into_iter().map(normalize).collect()
}

/// The vertices on a border of a triangle mesh (an edge of one triangle only).
pub(crate) fn border(vertices: usize, triangles: &[[u32; 3]]) -> Vec<bool> {
    let mut edges = std::collections::HashMap::new();
    for t in triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0u32) += 1;
        }
    }
    let mut out = vec![false; vertices];
    for ((a, b), n) in edges {
        if n == 1 {
            out[a as usize] = true;
            out[b as usize] = true;
        }
    }
    out
}

/// The template's unique edges.
fn edges(triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut e: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| (0..3).map(move |k| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]))))
        .collect();
    e.sort_unstable();
    e.dedup();
    e
}

/// The system of one alternation: `A = α² (M ⊗ G)ᵀ(M ⊗ G) + Dᵀ W² D`, applied to a stack of
/// per-vertex 4-vectors.
struct System<'a> {
    points: &'a [V3],
    weights: &'a [f64],
    edges: &'a [(u32, u32)],
    g2: [f64; 4],
    alpha2: f64,
}

impl System<'_> {
    fn d(&self, i: usize) -> Vector4<f64> {
        let p = self.points[i];
        Vector4::new(p[0], p[1], p[2], 1.0)
    }

    fn apply(&self, x: &[Vector4<f64>], y: &mut [Vector4<f64>]) {
        for (i, yi) in y.iter_mut().enumerate() {
            let d = self.d(i);
            *yi = d * (self.weights[i] * self.weights[i] * d.dot(&x[i]));
        }
        let g = Vector4::from(self.g2) * self.alpha2;
        for &(a, b) in self.edges {
            let diff = (x[a as usize] - x[b as usize]).component_mul(&g);
            y[a as usize] += diff;
            y[b as usize] -= diff;
        }
    }

    /// The inverse of each vertex's 4 × 4 diagonal block.
    fn preconditioner(&self, degree: &[f64]) -> Vec<Matrix4<f64>> {
        (0..self.points.len())
            .map(|i| {
                let d = self.d(i);
                let w2 = self.weights[i] * self.weights[i];
                let block = d * d.transpose() * w2
                    + Matrix4::from_diagonal(&(Vector4::from(self.g2) * (self.alpha2 * degree[i])))
                    + Matrix4::identity() * 1e-12;
                block.try_inverse().unwrap_or_else(Matrix4::identity)
            })
            .collect()
    }
}

/// Preconditioned conjugate gradients from `x` (warm start) for `A x = b`.
fn solve(system: &System<'_>, pre: &[Matrix4<f64>], b: &[Vector4<f64>], x: &mut [Vector4<f64>]) {
    let n = x.len();
    let dot = |a: &[Vector4<f64>], b: &[Vector4<f64>]| {
        a.iter().zip(b).map(|(a, b)| a.dot(b)).sum::<f64>()
    };
    let mut ax = vec![Vector4::zeros(); n];
    system.apply(x, &mut ax);
    let mut r: Vec<Vector4<f64>> = b.iter().zip(&ax).map(|(b, a)| b - a).collect();
    let mut z: Vec<Vector4<f64>> = pre.iter().zip(&r).map(|(m, r)| m * r).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let stop = 1e-20 * dot(b, b).max(1e-30);
    let mut ap = vec![Vector4::zeros(); n];
    for _ in 0..2000 {
        if dot(&r, &r) <= stop {
            break;
        }
        system.apply(&p, &mut ap);
        let pap = dot(&p, &ap);
        if pap <= 0.0 || !pap.is_finite() {
            break;
        }
        let a = rz / pap;
        for i in 0..n {
            x[i] += p[i] * a;
            r[i] -= ap[i] * a;
            z[i] = pre[i] * r[i];
        }
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz;
        rz = rz_next;
        for i in 0..n {
            p[i] = z[i] + p[i] * beta;
        }
    }
}

/// What a registration found: the deformed template, and per template vertex whether its last
/// correspondence was used.
#[derive(Clone, Debug)]
pub(crate) struct Registered {
    pub(crate) points: Vec<V3>,
    pub(crate) matched: Vec<bool>,
}

/// Deforms `template` (points and triangles, already rigidly placed on the target) onto
/// `target`.
pub(crate) fn register(
    template: &[V3],
    triangles: &[[u32; 3]],
    target: &Surface,
    settings: &Settings,
) -> Registered {
    let n = template.len();
    let target_normals = normals(&target.points, &target.triangles);
    let target_border = border(target.points.len(), &target.triangles);
    let edges = edges(triangles);
    let mut degree = vec![0.0; n];
    for &(a, b) in &edges {
        degree[a as usize] += 1.0;
        degree[b as usize] += 1.0;
    }
    // X: per vertex a 4 × 3 affine map, stored as three columns of 4-vectors; the identity.
    let unit = |c: usize| {
        let mut v = Vector4::zeros();
        v[c] = 1.0;
        v
    };
    let mut x: [Vec<Vector4<f64>>; 3] = std::array::from_fn(|c| vec![unit(c); n]);
    let deform = |x: &[Vec<Vector4<f64>>; 3]| -> Vec<V3> {
        (0..n)
            .map(|i| {
                let p = template[i];
                let d = Vector4::new(p[0], p[1], p[2], 1.0);
                [d.dot(&x[0][i]), d.dot(&x[1][i]), d.dot(&x[2][i])]
            })
            .collect()
    };
    let mut current = template.to_vec();
    let mut weights = vec![0.0; n];
    let mut targets = vec![[0.0; 3]; n];
    for &alpha in &settings.stiffness {
        for _ in 0..settings.iterations {
            let normals_now = normals(&current, triangles);
            for i in 0..n {
                weights[i] = 0.0;
                if let Some((sp, v)) = target.closest(current[i]) {
                    let close = norm(sub(sp.position, current[i])) <= settings.max_distance;
                    let facing = agree(normals_now[i], target_normals[v], settings.max_angle);
                    if close && facing && !target_border[v] {
                        weights[i] = 1.0;
                        targets[i] = sp.position;
                    }
                }
            }
            let system = System {
                points: template,
                weights: &weights,
                edges: &edges,
                g2: [1.0, 1.0, 1.0, settings.gamma * settings.gamma],
                alpha2: alpha * alpha,
            };
            let pre = system.preconditioner(&degree);
            let before = current.clone();
            for (c, xc) in x.iter_mut().enumerate() {
                let b: Vec<Vector4<f64>> = (0..n)
                    .map(|i| system.d(i) * (weights[i] * weights[i] * targets[i][c]))
                    .collect();
                solve(&system, &pre, &b, xc);
            }
            current = deform(&x);
            let moved = current
                .iter()
                .zip(&before)
                .map(|(a, b)| norm(sub(*a, *b)))
                .fold(0.0, f64::max);
            if moved < 1e-4 {
                break;
            }
        }
    }
    Registered {
        points: current,
        matched: weights.iter().map(|&w| w > 0.0).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `k × k` points over `[-1, 1]²` at height `h(x, y)`, triangulated.
    fn sheet(k: usize, h: impl Fn(f64, f64) -> f64) -> (Vec<V3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..k {
            for i in 0..k {
                let (x, y) = (
                    2.0 * i as f64 / (k - 1) as f64 - 1.0,
                    2.0 * j as f64 / (k - 1) as f64 - 1.0,
                );
                p.push([x, y, h(x, y)]);
            }
        }
        let mut t = Vec::new();
        for j in 0..k - 1 {
            for i in 0..k - 1 {
                let a = (j * k + i) as u32;
                let k = k as u32;
                t.push([a, a + 1, a + k + 1]);
                t.push([a, a + k + 1, a + k]);
            }
        }
        (p, t)
    }

    #[test]
    fn a_flat_sheet_takes_the_shape_of_a_bump() {
        let bump = |x: f64, y: f64| 0.3 * (-(x * x + y * y) * 3.0).exp();
        let (target_points, target_tris) = sheet(41, bump);
        let target = Surface::new(target_points, target_tris);
        let (flat, tris) = sheet(15, |_, _| 0.0);
        let settings = Settings {
            max_distance: 0.5,
            ..Settings::default()
        };
        let got = register(&flat, &tris, &target, &settings);
        // Interior vertices lie on the bump (the border of the template has partners too).
        let worst = got
            .points
            .iter()
            .filter(|p| p[0].abs() < 0.8 && p[1].abs() < 0.8)
            .map(|p| (p[2] - bump(p[0], p[1])).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.01, "worst height error {worst}");
        let centre = got.points[7 * 15 + 7];
        assert!(
            centre[0].abs() < 0.05 && centre[1].abs() < 0.05,
            "{centre:?}"
        );
        assert!(got.matched.iter().filter(|&&m| m).count() > 150);
    }
}
