//! The S2D mesh hierarchy (S2D section 3.2 and appendix; CoMA-style sampling): quadric-error
//! decimation by half-edge collapse, the 0/1 down-sampling D, the barycentric up-sampling U and
//! the dummy-vertex padding of `shared/notes/s2d-reference.md`.
//!
//! Decimation (Garland and Heckbert 1997) collapses a vertex `u` onto a neighbour `v` that stays
//! where it is, so every coarse vertex *is* a fine vertex and D is an exact selection. Each level
//! is decimated from the previous level's mesh with fresh quadrics, as the reference does.
//!
//! Determinism: the priority queue orders candidates by `(cost, from, to)` with `f64::total_cmp`,
//! every adjacency list is a sorted `Vec`, and no hash map is iterated, so the same mesh and
//! factors give the same hierarchy byte for byte.

use std::cmp::{Ordering, Reverse};
use std::collections::BinaryHeap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail, ensure};
use sinew_core::SinewFile;
use sinew_core::format::ArtifactKind;

use super::{Hierarchy, Level, Sampling, spirals};
use crate::container::SinewWriter;
use crate::mesh::Mesh;
use crate::vec3::{add, cross, dot, norm2, scale, sub, to64};

/// The reference's decimation factors: four levels, each a quarter of the one before.
pub const DEFAULT_FACTORS: [usize; 4] = [4, 4, 4, 4];

/// Weight of the boundary-plane quadrics relative to the area-weighted face quadrics (qslim's
/// default): high enough that open borders (neck, eye and mouth holes) keep their shape.
const BOUNDARY_WEIGHT: f64 = 1000.0;

/// A collapse whose new triangle's doubled area is below this fraction of its longest edge
/// squared is refused as degenerate.
const MIN_AREA_RATIO: f64 = 1e-6;

/// Version of the algorithm, part of the cache key: bump it whenever the output may change.
const ALGORITHM_VERSION: u32 = 1;

/// One level's vertex positions and triangles.
type Geometry = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// What a hierarchy is built with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Config {
    /// Decimation factor of each level: level `i + 1` has `ceil(n_i / factors[i])` vertices.
    pub factors: Vec<usize>,
    /// Spiral length of each level, overriding `int(mean + 2·std)` (e.g.
    /// [`spirals::REFERENCE_FLAME_LENGTHS`], to build the reference network's exact shapes).
    pub spiral_lengths: Option<Vec<usize>>,
}

impl Default for Config {
    /// The reference configuration: [`DEFAULT_FACTORS`], spiral lengths from the statistics.
    fn default() -> Self {
        Self {
            factors: DEFAULT_FACTORS.to_vec(),
            spiral_lengths: None,
        }
    }
}

impl Config {
    /// The reference network's exact shapes on FLAME: [`DEFAULT_FACTORS`] and the spiral
    /// lengths pinned to [`spirals::REFERENCE_FLAME_LENGTHS`].
    pub fn reference_flame() -> Self {
        Self {
            factors: DEFAULT_FACTORS.to_vec(),
            spiral_lengths: Some(spirals::REFERENCE_FLAME_LENGTHS.to_vec()),
        }
    }
}

/// [`build_with`] with `factors` and spiral lengths from the statistics.
pub fn build(mesh: &Mesh, factors: &[usize]) -> Result<Hierarchy> {
    build_with(
        mesh,
        &Config {
            factors: factors.to_vec(),
            spiral_lengths: None,
        },
    )
}

/// Builds the hierarchy of `mesh`: level 0 is the mesh itself (polygons triangulated by fans),
/// level `i + 1` has `ceil(n_i / factors[i])` vertices. Spirals follow
/// [`spirals::reference_schedule`], their lengths the statistics or `config.spiral_lengths`.
///
/// # Errors
/// An empty mesh, an index out of range, a polygon with a repeated vertex or zero area, a
/// non-manifold edge or vertex, inconsistently oriented neighbours, duplicate faces, a vertex in
/// no face, a factor below 2, spiral lengths that are zero or not one per level, or a level that
/// cannot be decimated that far without breaking the surface. Errors name the face or vertex;
/// callers add the file name.
pub fn build_with(mesh: &Mesh, config: &Config) -> Result<Hierarchy> {
    let factors = config.factors.as_slice();
    if let Some(lens) = &config.spiral_lengths {
        ensure!(
            lens.len() == factors.len() + 1 && lens.iter().all(|&l| l > 0),
            "spiral lengths {lens:?}: need {} positive lengths, one per level",
            factors.len() + 1
        );
    }
    let triangles = checked_triangles(mesh)?;
    if let Some(i) = factors.iter().position(|&f| f < 2) {
        bail!(
            "decimation factor {i} is {} (at least 2 needed)",
            factors[i]
        );
    }
    let mut levels_geo: Vec<Geometry> = vec![(mesh.positions.clone(), triangles)];
    let mut kept_per_level: Vec<Vec<u32>> = Vec::with_capacity(factors.len());
    for (i, &factor) in factors.iter().enumerate() {
        let (positions, triangles) = &levels_geo[i];
        let target = positions.len().div_ceil(factor);
        let (kept, coarse_tris) = decimate(positions, triangles, target)
            .with_context(|| format!("level {i} → {}", i + 1))?;
        let coarse_pos = kept.iter().map(|&v| positions[v as usize]).collect();
        kept_per_level.push(kept);
        levels_geo.push((coarse_pos, coarse_tris));
    }

    let mut down = Vec::with_capacity(factors.len());
    let mut up = Vec::with_capacity(factors.len());
    for (i, kept) in kept_per_level.iter().enumerate() {
        let (fine_pos, _) = &levels_geo[i];
        let (coarse_pos, coarse_tris) = &levels_geo[i + 1];
        down.push(selection(kept, fine_pos.len()));
        up.push(barycentric_upsampling(
            fine_pos,
            coarse_pos,
            coarse_tris,
            kept,
        ));
    }

    let schedule = spirals::reference_schedule(levels_geo.len());
    let levels = levels_geo
        .into_iter()
        .zip(schedule)
        .enumerate()
        .map(|(i, ((positions, triangles), (steps, dilation)))| {
            let len = config.spiral_lengths.as_ref().map(|l| l[i]);
            let (spiral_len, spirals) =
                spirals::build(&positions, &triangles, steps, dilation, len)
                    .with_context(|| format!("spirals of level {i}"))?;
            Ok(Level {
                positions,
                triangles,
                spiral_len,
                spirals,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Hierarchy { levels, down, up })
}

/// Fan-triangulates `mesh` and checks that it is a manifold surface the hierarchy can be built
/// on (see [`build`] for the conditions).
pub fn checked_triangles(mesh: &Mesh) -> Result<Vec<[u32; 3]>> {
    let n = mesh.positions.len();
    ensure!(n > 0, "the mesh has no vertices");
    ensure!(!mesh.polygons.is_empty(), "the mesh has no faces");
    let mut triangles = Vec::new();
    let mut owner = Vec::new();
    for (pi, poly) in mesh.polygons.iter().enumerate() {
        ensure!(
            poly.len() >= 3,
            "face {pi} has {} corners (at least 3 needed)",
            poly.len()
        );
        for (k, &v) in poly.iter().enumerate() {
            ensure!(
                (v as usize) < n,
                "face {pi} refers to vertex {v} but the mesh has {n} vertices"
            );
            if poly[..k].contains(&v) {
                bail!("face {pi} uses vertex {v} twice (degenerate face)");
            }
        }
        for k in 1..poly.len() - 1 {
            let t = [poly[0], poly[k], poly[k + 1]];
            let p = t.map(|v| to64(mesh.positions[v as usize]));
            if norm2(cross(sub(p[1], p[0]), sub(p[2], p[0]))) == 0.0 {
                bail!(
                    "face {pi} has zero area (vertices {:?}; degenerate face)",
                    poly
                );
            }
            triangles.push(t);
            owner.push(pi);
        }
    }

    // Every undirected edge with its faces; sorted, so the first error found is always the same.
    let mut edges: Vec<(u32, u32, bool, usize)> = Vec::with_capacity(triangles.len() * 3);
    for (ti, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), a < b, ti));
        }
    }
    edges.sort_unstable();
    for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (a, b) = (group[0].0, group[0].1);
        if group.len() > 2 {
            let faces: Vec<usize> = group.iter().map(|e| owner[e.3]).collect();
            bail!(
                "edge ({a}, {b}) is shared by {} faces {faces:?} (non-manifold edge)",
                group.len()
            );
        }
        if group.len() == 2 && group[0].2 == group[1].2 {
            bail!(
                "faces {} and {} use edge ({a}, {b}) in the same direction (inconsistent \
                 orientation or a non-manifold fold)",
                owner[group[0].3],
                owner[group[1].3]
            );
        }
    }
    let mut keys: Vec<([u32; 3], usize)> = triangles
        .iter()
        .enumerate()
        .map(|(ti, t)| {
            let mut k = *t;
            k.sort_unstable();
            (k, ti)
        })
        .collect();
    keys.sort_unstable();
    for w in keys.windows(2) {
        if w[0].0 == w[1].0 {
            bail!(
                "faces {} and {} use the same vertices {:?} (duplicate face)",
                owner[w[0].1],
                owner[w[1].1],
                w[0].0
            );
        }
    }
    let incident = incident_triangles(n, &triangles);
    for (v, faces) in incident.iter().enumerate() {
        if faces.is_empty() {
            bail!("vertex {v} belongs to no face");
        }
        if fan(v as u32, faces, &triangles).is_none() {
            bail!(
                "vertex {v} joins faces that do not form one fan (non-manifold vertex, faces {:?})",
                faces.iter().map(|&t| owner[t as usize]).collect::<Vec<_>>()
            );
        }
    }
    Ok(triangles)
}

/// The triangles incident to each vertex, in increasing triangle order.
pub(crate) fn incident_triangles(n: usize, triangles: &[[u32; 3]]) -> Vec<Vec<u32>> {
    let mut out = vec![Vec::new(); n];
    for (ti, t) in triangles.iter().enumerate() {
        for &v in t {
            out[v as usize].push(ti as u32);
        }
    }
    out
}

/// The neighbours of `v` in counter-clockwise order (seen with the triangles' orientation),
/// given its incident triangles. For a boundary vertex the order runs from the neighbour after
/// the boundary gap to the one before it. `None` if the triangles around `v` do not form a
/// single fan (a non-manifold vertex).
pub(crate) fn fan(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Vec<u32>> {
    // In a counter-clockwise triangle (v, a, b), `a` comes right before `b` around `v`.
    let mut next: Vec<(u32, u32)> = faces
        .iter()
        .map(|&t| {
            let tri = triangles[t as usize];
            let k = tri.iter().position(|&x| x == v).unwrap_or(0);
            (tri[(k + 1) % 3], tri[(k + 2) % 3])
        })
        .collect();
    next.sort_unstable();
    if next.windows(2).any(|w| w[0].0 == w[1].0) {
        return None;
    }
    let succ = |a: u32| {
        next.binary_search_by_key(&a, |e| e.0)
            .ok()
            .map(|i| next[i].1)
    };
    // A boundary fan starts at the one neighbour that no triangle leads to.
    let mut targets: Vec<u32> = next.iter().map(|e| e.1).collect();
    targets.sort_unstable();
    let starts: Vec<u32> = next
        .iter()
        .map(|e| e.0)
        .filter(|a| targets.binary_search(a).is_err())
        .collect();
    let start = match starts.as_slice() {
        [] => next.first()?.0,
        [s] => *s,
        _ => return None,
    };
    let mut order = vec![start];
    let mut cur = start;
    while let Some(b) = succ(cur) {
        if b == start {
            break;
        }
        order.push(b);
        cur = b;
        if order.len() > next.len() + 1 {
            return None;
        }
    }
    // Every triangle must have been walked: a closed fan has as many neighbours as triangles,
    // an open one one more.
    let expected = if starts.is_empty() {
        next.len()
    } else {
        next.len() + 1
    };
    (order.len() == expected).then_some(order)
}

/// The down-sampling of one level: coarse vertex `j` (and the dummy) selects one fine vertex.
///
/// # Shapes
/// `(m + 1) × (n + 1)` with `m = kept.len()`, `n = n_fine`.
fn selection(kept: &[u32], n_fine: usize) -> Sampling {
    let m = kept.len();
    let mut col_idx: Vec<u32> = kept.to_vec();
    col_idx.push(n_fine as u32);
    Sampling {
        rows: m + 1,
        cols: n_fine + 1,
        row_ptr: (0..=m as u32 + 1).collect(),
        col_idx,
        values: vec![1.0; m + 1],
    }
}

/// The up-sampling of one level: a kept fine vertex copies its coarse vertex; any other fine
/// vertex takes the barycentric weights of its closest point on the coarse surface (the
/// nearest coarse triangle, first in triangle order on ties). Zero weights are not stored; each
/// row's columns are increasing.
///
/// # Shapes
/// `(n + 1) × (m + 1)`, `n = fine.len()`, `m = coarse.len()`.
fn barycentric_upsampling(
    fine: &[[f32; 3]],
    coarse: &[[f32; 3]],
    coarse_tris: &[[u32; 3]],
    kept: &[u32],
) -> Sampling {
    let n = fine.len();
    let m = coarse.len();
    let mut coarse_of = vec![u32::MAX; n];
    for (j, &v) in kept.iter().enumerate() {
        coarse_of[v as usize] = j as u32;
    }
    let tris: Vec<[[f64; 3]; 3]> = coarse_tris
        .iter()
        .map(|t| t.map(|v| to64(coarse[v as usize])))
        .collect();
    let boxes: Vec<([f64; 3], [f64; 3])> = tris
        .iter()
        .map(|t| {
            let mut lo = t[0];
            let mut hi = t[0];
            for p in &t[1..] {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            (lo, hi)
        })
        .collect();
    let mut row_ptr = Vec::with_capacity(n + 2);
    let mut col_idx = Vec::with_capacity(3 * n + 1);
    let mut values = Vec::with_capacity(3 * n + 1);
    row_ptr.push(0u32);
    for (i, &p) in fine.iter().enumerate() {
        if coarse_of[i] != u32::MAX {
            col_idx.push(coarse_of[i]);
            values.push(1.0f32);
        } else {
            let p = to64(p);
            let mut best = (f64::INFINITY, 0usize, [1.0, 0.0, 0.0]);
            for (ti, (t, (lo, hi))) in tris.iter().zip(&boxes).enumerate() {
                let mut d2 = 0.0;
                for k in 0..3 {
                    let gap = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
                    d2 += gap * gap;
                }
                if d2 >= best.0 {
                    continue;
                }
                let (q, w) = closest_point_on_triangle(p, t);
                let d2 = norm2(sub(p, q));
                if d2 < best.0 {
                    best = (d2, ti, w);
                }
            }
            let t = coarse_tris[best.1];
            let mut entries: Vec<(u32, f64)> = (0..3)
                .filter(|&k| best.2[k] > 0.0)
                .map(|k| (t[k], best.2[k]))
                .collect();
            entries.sort_unstable_by_key(|e| e.0);
            // Rounded to f32 the weights may miss 1 by an ulp; the last one takes the remainder
            // so that each row reproduces constants as closely as f32 allows.
            let total: f64 = entries.iter().map(|e| e.1).sum();
            let last = entries.len() - 1;
            let mut acc = 0.0f32;
            for (k, &(c, w)) in entries.iter().enumerate() {
                let w = if k == last {
                    1.0 - acc
                } else {
                    (w / total) as f32
                };
                acc += w;
                col_idx.push(c);
                values.push(w);
            }
        }
        row_ptr.push(col_idx.len() as u32);
    }
    col_idx.push(m as u32);
    values.push(1.0);
    row_ptr.push(col_idx.len() as u32);
    Sampling {
        rows: n + 1,
        cols: m + 1,
        row_ptr,
        col_idx,
        values,
    }
}

/// The closest point of triangle `t` to `p` and its barycentric weights, clamped to the
/// triangle (Ericson, "Real-Time Collision Detection", 5.1.5: Voronoi regions of the corners,
/// edges and face).
fn closest_point_on_triangle(p: [f64; 3], t: &[[f64; 3]; 3]) -> ([f64; 3], [f64; 3]) {
    let [a, b, c] = *t;
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let s = d1 / (d1 - d3);
        return (add(a, scale(ab, s)), [1.0 - s, s, 0.0]);
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let s = d2 / (d2 - d6);
        return (add(a, scale(ac, s)), [1.0 - s, 0.0, s]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let s = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (add(b, scale(sub(c, b), s)), [0.0, 1.0 - s, s]);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (add(a, add(scale(ab, v), scale(ac, w))), [1.0 - v - w, v, w])
}

/// A symmetric 4×4 error quadric `Q` (Garland–Heckbert eq. 2: `Δ(v) = vᵀ Q v`), upper triangle.
#[derive(Clone, Copy, Debug, Default)]
struct Quadric([f64; 10]);

impl Quadric {
    /// `w · p pᵀ` for the plane `n·x + d = 0`, `p = (n, d)`.
    fn plane(n: [f64; 3], d: f64, w: f64) -> Self {
        let [a, b, c] = n;
        Self([
            w * a * a,
            w * a * b,
            w * a * c,
            w * a * d,
            w * b * b,
            w * b * c,
            w * b * d,
            w * c * c,
            w * c * d,
            w * d * d,
        ])
    }

    fn add(&mut self, o: &Self) {
        for (x, y) in self.0.iter_mut().zip(&o.0) {
            *x += y;
        }
    }

    fn sum(&self, o: &Self) -> Self {
        let mut s = *self;
        s.add(o);
        s
    }

    /// `vᵀ Q v` with `v = (x, y, z, 1)`.
    fn eval(&self, p: [f64; 3]) -> f64 {
        let [q00, q01, q02, q03, q11, q12, q13, q22, q23, q33] = self.0;
        let [x, y, z] = p;
        x * (q00 * x + 2.0 * (q01 * y + q02 * z + q03))
            + y * (q11 * y + 2.0 * (q12 * z + q13))
            + z * (q22 * z + 2.0 * q23)
            + q33
    }
}

/// A half-edge collapse `from → to` waiting in the queue, with the vertex versions it was
/// computed for (stale once either vertex changed).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    cost: f64,
    from: u32,
    to: u32,
    from_version: u32,
    to_version: u32,
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Candidate {
    // A total order: cost first, then the vertex indices, so ties never depend on heap history.
    fn cmp(&self, other: &Self) -> Ordering {
        self.cost
            .total_cmp(&other.cost)
            .then(self.from.cmp(&other.from))
            .then(self.to.cmp(&other.to))
            .then(self.from_version.cmp(&other.from_version))
            .then(self.to_version.cmp(&other.to_version))
    }
}

/// The decimation state of one level.
struct Decimator {
    pos: Vec<[f64; 3]>,
    tris: Vec<[u32; 3]>,
    tri_alive: Vec<bool>,
    /// Alive incident triangles of each vertex, increasing.
    incident: Vec<Vec<u32>>,
    vertex_alive: Vec<bool>,
    quadric: Vec<Quadric>,
    version: Vec<u32>,
    heap: BinaryHeap<Reverse<Candidate>>,
}

/// Decimates one level to `target` vertices. Returns the kept vertices (increasing) and the
/// coarse triangles in the kept vertices' numbering (in the order of the fine triangles they
/// came from).
fn decimate(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    target: usize,
) -> Result<(Vec<u32>, Vec<[u32; 3]>)> {
    let n = positions.len();
    let mut d = Decimator {
        pos: positions.iter().map(|&p| to64(p)).collect(),
        tris: triangles.to_vec(),
        tri_alive: vec![true; triangles.len()],
        incident: incident_triangles(n, triangles),
        vertex_alive: vec![true; n],
        quadric: vec![Quadric::default(); n],
        version: vec![0; n],
        heap: BinaryHeap::new(),
    };
    d.init_quadrics();
    for v in 0..n as u32 {
        for w in d.neighbours(v) {
            d.push(v, w);
        }
    }
    let mut alive = n;
    while alive > target {
        let Some(Reverse(c)) = d.heap.pop() else {
            bail!(
                "cannot decimate {n} vertices to {target}: every remaining collapse would flip, \
                 degenerate or disconnect the surface (stopped at {alive})"
            );
        };
        if !d.vertex_alive[c.from as usize]
            || !d.vertex_alive[c.to as usize]
            || d.version[c.from as usize] != c.from_version
            || d.version[c.to as usize] != c.to_version
        {
            continue;
        }
        if !d.can_collapse(c.from, c.to) {
            continue;
        }
        d.collapse(c.from, c.to);
        alive -= 1;
    }
    let kept: Vec<u32> = (0..n as u32)
        .filter(|&v| d.vertex_alive[v as usize])
        .collect();
    let mut new_index = vec![u32::MAX; n];
    for (j, &v) in kept.iter().enumerate() {
        new_index[v as usize] = j as u32;
    }
    let coarse = d
        .tris
        .iter()
        .zip(&d.tri_alive)
        .filter(|(_, alive)| **alive)
        .map(|(t, _)| t.map(|v| new_index[v as usize]))
        .collect();
    Ok((kept, coarse))
}

impl Decimator {
    fn init_quadrics(&mut self) {
        for t in &self.tris {
            let p = t.map(|v| self.pos[v as usize]);
            let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
            let len = norm2(n).sqrt();
            if len == 0.0 {
                continue;
            }
            let unit = scale(n, 1.0 / len);
            // Area weighting keeps the error independent of how finely a region is meshed.
            let q = Quadric::plane(unit, -dot(unit, p[0]), 0.5 * len);
            for &v in t {
                self.quadric[v as usize].add(&q);
            }
        }
        // Boundary edges: a plane through the edge, perpendicular to its face, weighted by the
        // edge length squared (Garland and Heckbert, section 6.1).
        for ti in 0..self.tris.len() {
            let t = self.tris[ti];
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                if self.edge_faces(a, b).len() != 1 {
                    continue;
                }
                let p = t.map(|v| self.pos[v as usize]);
                let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
                let e = sub(self.pos[b as usize], self.pos[a as usize]);
                let m = cross(e, n);
                let len = norm2(m).sqrt();
                if len == 0.0 {
                    continue;
                }
                let unit = scale(m, 1.0 / len);
                let q = Quadric::plane(
                    unit,
                    -dot(unit, self.pos[a as usize]),
                    BOUNDARY_WEIGHT * norm2(e),
                );
                self.quadric[a as usize].add(&q);
                self.quadric[b as usize].add(&q);
            }
        }
    }

    /// Alive triangles holding both `a` and `b`.
    fn edge_faces(&self, a: u32, b: u32) -> Vec<u32> {
        self.incident[a as usize]
            .iter()
            .copied()
            .filter(|&t| self.tris[t as usize].contains(&b))
            .collect()
    }

    /// Neighbours of `v`, increasing.
    fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> = self.incident[v as usize]
            .iter()
            .flat_map(|&t| self.tris[t as usize])
            .filter(|&w| w != v)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    fn is_boundary_vertex(&self, v: u32) -> bool {
        self.neighbours(v)
            .into_iter()
            .any(|w| self.edge_faces(v, w).len() == 1)
    }

    fn push(&mut self, from: u32, to: u32) {
        // Garland–Heckbert eq. 2 at the kept position: Δ = p_vᵀ (Q_u + Q_v) p_v
        let q = self.quadric[from as usize].sum(&self.quadric[to as usize]);
        self.heap.push(Reverse(Candidate {
            cost: q.eval(self.pos[to as usize]),
            from,
            to,
            from_version: self.version[from as usize],
            to_version: self.version[to as usize],
        }));
    }

    /// Whether collapsing `u` onto `v` keeps the surface a manifold without flipped,
    /// degenerate or duplicate triangles and without stranding a vertex.
    fn can_collapse(&self, u: u32, v: u32) -> bool {
        let shared = self.edge_faces(u, v);
        if shared.is_empty() || shared.len() > 2 {
            return false;
        }
        let opposite: Vec<u32> = shared
            .iter()
            .map(|&t| {
                self.tris[t as usize]
                    .into_iter()
                    .find(|&x| x != u && x != v)
                    .unwrap_or(u)
            })
            .collect();
        // Link condition (Dey et al.): the common neighbours are exactly the opposite vertices.
        let nu = self.neighbours(u);
        let nv = self.neighbours(v);
        let mut common: Vec<u32> = nu
            .iter()
            .copied()
            .filter(|w| nv.binary_search(w).is_ok())
            .collect();
        common.sort_unstable();
        let mut opp = opposite.clone();
        opp.sort_unstable();
        if common != opp {
            return false;
        }
        // An interior edge between two boundary vertices would pinch the surface at `v`.
        if shared.len() == 2 && self.is_boundary_vertex(u) && self.is_boundary_vertex(v) {
            return false;
        }
        // Every opposite vertex must keep a triangle, and so must `v`.
        for &w in &opposite {
            let lost = shared
                .iter()
                .filter(|t| self.tris[**t as usize].contains(&w))
                .count();
            if self.incident[w as usize].len() <= lost {
                return false;
            }
        }
        let survivors: Vec<u32> = self.incident[u as usize]
            .iter()
            .copied()
            .filter(|t| !shared.contains(t))
            .collect();
        if self.incident[v as usize].len() - shared.len() + survivors.len() == 0 {
            return false;
        }
        let pv = self.pos[v as usize];
        for &t in &survivors {
            let tri = self.tris[t as usize];
            let old = tri.map(|x| self.pos[x as usize]);
            let new = tri.map(|x| if x == u { pv } else { self.pos[x as usize] });
            let n_old = cross(sub(old[1], old[0]), sub(old[2], old[0]));
            let n_new = cross(sub(new[1], new[0]), sub(new[2], new[0]));
            if dot(n_old, n_new) <= 0.0 {
                return false;
            }
            let longest = (0..3)
                .map(|k| norm2(sub(new[k], new[(k + 1) % 3])))
                .fold(0.0, f64::max);
            if norm2(n_new).sqrt() <= MIN_AREA_RATIO * longest {
                return false;
            }
            // The moved triangle must not coincide with one already at `v`.
            let mut key = tri.map(|x| if x == u { v } else { x });
            key.sort_unstable();
            let duplicate = self.incident[v as usize].iter().any(|&s| {
                let mut k = self.tris[s as usize];
                k.sort_unstable();
                !shared.contains(&s) && k == key
            });
            if duplicate {
                return false;
            }
        }
        true
    }

    fn collapse(&mut self, u: u32, v: u32) {
        let shared = self.edge_faces(u, v);
        for &t in &shared {
            self.tri_alive[t as usize] = false;
            for x in self.tris[t as usize] {
                self.incident[x as usize].retain(|&s| s != t);
            }
        }
        let moved = std::mem::take(&mut self.incident[u as usize]);
        for &t in &moved {
            for x in &mut self.tris[t as usize] {
                if *x == u {
                    *x = v;
                }
            }
            let list = &mut self.incident[v as usize];
            if let Err(i) = list.binary_search(&t) {
                list.insert(i, t);
            }
        }
        self.vertex_alive[u as usize] = false;
        let qu = self.quadric[u as usize];
        self.quadric[v as usize].add(&qu);

        // Costs change on edges at `v`; feasibility may change on edges at `v` and its
        // neighbours. Renew every candidate touching them.
        let mut ring = self.neighbours(v);
        ring.push(v);
        ring.sort_unstable();
        for &r in &ring {
            self.version[r as usize] += 1;
        }
        for &a in &ring {
            for b in self.neighbours(a) {
                if ring.binary_search(&b).is_ok() && b < a {
                    continue;
                }
                self.push(a, b);
                self.push(b, a);
            }
        }
    }
}

/// Which of a hierarchy's sections to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sections {
    /// Everything [`read_sections`] reads back (hierarchy files and the cache).
    All,
    /// What `sinew_core::s2d::S2dDecoder` reads (a baked decoder): `p.levels`, `p.h0.pos`,
    /// every `p.h<i>.spiral` and `p.u<i>.*`, not the triangles, the coarser levels' positions
    /// or the down-samplings.
    Playback,
}

/// Writes `h` as sections under `prefix` (see docs/FORMAT.md, "S2D mesh hierarchy"):
/// `p.levels`, per level `p.h<i>.pos`, `p.h<i>.tri`, `p.h<i>.spiral`, and per sampling
/// `p.d<i>.{ptr,col,val}` and `p.u<i>.{ptr,col,val}`; with [`Sections::Playback`] only those the
/// core's decoder reads.
pub fn write_sections(
    h: &Hierarchy,
    w: &mut SinewWriter,
    prefix: &str,
    which: Sections,
) -> Result<()> {
    let all = which == Sections::All;
    let table: Vec<u32> = h
        .levels
        .iter()
        .flat_map(|l| [l.positions.len() as u32, l.spiral_len as u32])
        .collect();
    w.u32s(&format!("{prefix}.levels"), &[h.levels.len(), 2], &table)?;
    for (i, l) in h.levels.iter().enumerate() {
        let n = l.positions.len();
        if all || i == 0 {
            let pos: Vec<f32> = l.positions.iter().flatten().copied().collect();
            w.f32s(&format!("{prefix}.h{i}.pos"), &[n, 3], &pos)?;
        }
        if all {
            let tri: Vec<u32> = l.triangles.iter().flatten().copied().collect();
            w.u32s(&format!("{prefix}.h{i}.tri"), &[l.triangles.len(), 3], &tri)?;
        }
        w.u32s(
            &format!("{prefix}.h{i}.spiral"),
            &[n + 1, l.spiral_len],
            &l.spirals,
        )?;
    }
    let samplings: &[(&str, &Vec<Sampling>)] = if all {
        &[("d", &h.down), ("u", &h.up)]
    } else {
        &[("u", &h.up)]
    };
    for (tag, list) in samplings {
        for (i, s) in list.iter().enumerate() {
            let p = format!("{prefix}.{tag}{i}");
            w.u32s(&format!("{p}.ptr"), &[s.row_ptr.len()], &s.row_ptr)?;
            w.u32s(&format!("{p}.col"), &[s.col_idx.len()], &s.col_idx)?;
            w.f32s(&format!("{p}.val"), &[s.values.len()], &s.values)?;
        }
    }
    Ok(())
}

/// Reads the sections [`write_sections`] wrote under `prefix`, checking every shape and index
/// with the core's own validation (`Csr::new`, `Spirals::new`).
pub fn read_sections(f: &SinewFile<'_>, prefix: &str) -> Result<Hierarchy> {
    let fmt = |e: sinew_core::FormatError, name: &str| anyhow::anyhow!("section {name}: {e}");
    let name = format!("{prefix}.levels");
    let (dims, rank) = f.dims_of(&name).map_err(|e| fmt(e, &name))?;
    ensure!(
        rank == 2 && dims[1] == 2 && dims[0] >= 1,
        "section {name}: shape must be [levels, 2]"
    );
    let table: Vec<u32> = f
        .u32_tensor(&name, &dims[..2])
        .map_err(|e| fmt(e, &name))?
        .iter()
        .collect();
    let mut levels = Vec::new();
    for (i, row) in table.chunks_exact(2).enumerate() {
        let (n, len) = (row[0], row[1]);
        let rows = n
            .checked_add(1)
            .with_context(|| format!("section {prefix}.levels: level {i} is too large"))?;
        let name = format!("{prefix}.h{i}.pos");
        let pos = f.f32_tensor(&name, &[n, 3]).map_err(|e| fmt(e, &name))?;
        let positions = pos
            .iter()
            .collect::<Vec<_>>()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let name = format!("{prefix}.h{i}.tri");
        let (dims, rank) = f.dims_of(&name).map_err(|e| fmt(e, &name))?;
        ensure!(
            rank == 2 && dims[1] == 3,
            "section {name}: shape must be [T, 3]"
        );
        let tri = f.u32_tensor(&name, &dims[..2]).map_err(|e| fmt(e, &name))?;
        ensure!(
            tri.iter().all(|v| v < n),
            "section {name}: vertex index out of range"
        );
        let triangles = tri
            .iter()
            .collect::<Vec<_>>()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let name = format!("{prefix}.h{i}.spiral");
        let sp = f
            .u32_tensor(&name, &[rows, len])
            .map_err(|e| fmt(e, &name))?;
        sinew_core::spiral::Spirals::new(sp, rows as usize, len as usize, rows as usize)
            .map_err(|e| fmt(e, &name))?;
        levels.push(Level {
            positions,
            triangles,
            spiral_len: len as usize,
            spirals: sp.iter().collect(),
        });
    }
    let sizes: Vec<usize> = levels.iter().map(|l| l.positions.len() + 1).collect();
    let mut down = Vec::new();
    let mut up = Vec::new();
    for i in 0..sizes.len() - 1 {
        down.push(read_sampling(
            f,
            &format!("{prefix}.d{i}"),
            sizes[i + 1],
            sizes[i],
        )?);
        up.push(read_sampling(
            f,
            &format!("{prefix}.u{i}"),
            sizes[i],
            sizes[i + 1],
        )?);
    }
    Ok(Hierarchy { levels, down, up })
}

fn read_sampling(f: &SinewFile<'_>, p: &str, rows: usize, cols: usize) -> Result<Sampling> {
    let fmt = |e: sinew_core::FormatError, name: &str| anyhow::anyhow!("section {name}: {e}");
    let vec_u32 = |name: &str| -> Result<sinew_core::tensor::U32s<'_>> {
        let (dims, rank) = f.dims_of(name).map_err(|e| fmt(e, name))?;
        ensure!(rank == 1, "section {name}: must be a vector");
        f.u32_tensor(name, &dims[..1]).map_err(|e| fmt(e, name))
    };
    let (ptr_name, col_name, val_name) =
        (format!("{p}.ptr"), format!("{p}.col"), format!("{p}.val"));
    let ptr = vec_u32(&ptr_name)?;
    let col = vec_u32(&col_name)?;
    let (dims, rank) = f.dims_of(&val_name).map_err(|e| fmt(e, &val_name))?;
    ensure!(rank == 1, "section {val_name}: must be a vector");
    let val = f
        .f32_tensor(&val_name, &dims[..1])
        .map_err(|e| fmt(e, &val_name))?;
    sinew_core::sparse::Csr::new(rows, cols, ptr, col, val).map_err(|e| fmt(e, p))?;
    Ok(Sampling {
        rows,
        cols,
        row_ptr: ptr.iter().collect(),
        col_idx: col.iter().collect(),
        values: val.iter().collect(),
    })
}

/// The hierarchy as a stand-alone `.sinew` file (kind S2D decoder, hierarchy sections only,
/// under prefix `s2d`), with the cache key and factors as metadata.
pub fn to_bytes(h: &Hierarchy, key: u64, config: &Config) -> Result<Vec<u8>> {
    let list = |v: &[usize]| v.iter().map(usize::to_string).collect::<Vec<_>>().join(",");
    let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
    w.meta("tool", concat!("sinew ", env!("CARGO_PKG_VERSION")))
        .meta("content", "s2d-hierarchy")
        .meta("key", format!("{key:016x}"))
        .meta("factors", list(&config.factors));
    if let Some(lens) = &config.spiral_lengths {
        w.meta("spiral_lengths", list(lens));
    }
    write_sections(h, &mut w, "s2d", Sections::All)?;
    w.to_bytes()
}

/// Reads a hierarchy file written by [`to_bytes`].
pub fn from_bytes(bytes: &[u8]) -> Result<Hierarchy> {
    let f = SinewFile::from_bytes(bytes).map_err(|e| anyhow::anyhow!("{e}"))?;
    read_sections(&f, "s2d")
}

/// A stable 64-bit key of the mesh's positions and faces, the configuration and the algorithm
/// version (CRC-64/XZ over their little-endian bytes; a cache key, not a security hash).
pub fn cache_key(mesh: &Mesh, config: &Config) -> u64 {
    let crc = crc::Crc::<u64>::new(&crc::CRC_64_XZ);
    let mut d = crc.digest();
    d.update(b"sinew-s2d-hierarchy");
    d.update(&ALGORITHM_VERSION.to_le_bytes());
    d.update(&(mesh.positions.len() as u64).to_le_bytes());
    for p in &mesh.positions {
        for c in p {
            d.update(&c.to_bits().to_le_bytes());
        }
    }
    d.update(&(mesh.polygons.len() as u64).to_le_bytes());
    for poly in &mesh.polygons {
        d.update(&(poly.len() as u32).to_le_bytes());
        for v in poly {
            d.update(&v.to_le_bytes());
        }
    }
    d.update(&(config.factors.len() as u64).to_le_bytes());
    for f in &config.factors {
        d.update(&(*f as u64).to_le_bytes());
    }
    match &config.spiral_lengths {
        None => d.update(&[0]),
        Some(lens) => {
            d.update(&[1]);
            d.update(&(lens.len() as u64).to_le_bytes());
            for l in lens {
                d.update(&(*l as u64).to_le_bytes());
            }
        }
    }
    d.finalize()
}

/// The path [`cached_with`] uses in `cache_dir` for `mesh` and `config`.
pub fn cache_path(mesh: &Mesh, config: &Config, cache_dir: &Path) -> PathBuf {
    cache_dir.join(format!(
        "s2d-hierarchy-{:016x}.sinew",
        cache_key(mesh, config)
    ))
}

/// [`cached_with`] with `factors` and spiral lengths from the statistics.
pub fn cached(mesh: &Mesh, factors: &[usize], cache_dir: &Path) -> Result<Hierarchy> {
    let config = Config {
        factors: factors.to_vec(),
        spiral_lengths: None,
    };
    cached_with(mesh, &config, cache_dir)
}

/// The hierarchy of `mesh`, read from `cache_dir` if an entry for this mesh and configuration
/// exists and matches, else built and written there atomically (so training and playback build
/// it once). An entry that cannot be read, or whose key or level-0 positions differ, is rebuilt
/// and replaced.
pub fn cached_with(mesh: &Mesh, config: &Config, cache_dir: &Path) -> Result<Hierarchy> {
    let key = cache_key(mesh, config);
    let path = cache_path(mesh, config, cache_dir);
    if let Ok(bytes) = std::fs::read(&path)
        && let Ok(f) = SinewFile::from_bytes(&bytes)
        && f.metadata().get("key") == Some(format!("{key:016x}").as_str())
        && let Ok(h) = read_sections(&f, "s2d")
        && h.levels
            .first()
            .is_some_and(|l| l.positions == mesh.positions)
    {
        return Ok(h);
    }
    let h = build_with(mesh, config)?;
    crate::atomic::write(&path, &to_bytes(&h, key, config)?)?;
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::data_dir;
    use std::time::Instant;

    fn tri_mesh(positions: Vec<[f32; 3]>, faces: &[&[u32]]) -> Mesh {
        Mesh::new(positions, faces.iter().map(|f| f.to_vec()).collect())
    }

    /// Checks every structural promise of a hierarchy and returns the mean distance of each
    /// level's vertices to their up-sampled coarse positions.
    fn check(h: &Hierarchy) -> Vec<f64> {
        let mut mean_dist = Vec::new();
        for (i, l) in h.levels.iter().enumerate() {
            let n = l.positions.len();
            assert_eq!(l.spirals.len(), (n + 1) * l.spiral_len, "level {i}");
            for (v, row) in l.spirals.chunks_exact(l.spiral_len).enumerate() {
                assert_eq!(row[0] as usize, v, "level {i}: spiral {v} starts elsewhere");
                assert!(row.iter().all(|&s| s as usize <= n));
                // A real spiral never repeats a vertex; only the padding repeats the dummy.
                let mut real: Vec<u32> = row.iter().copied().filter(|&s| s as usize != n).collect();
                if v < n {
                    let len = real.len();
                    real.sort_unstable();
                    real.dedup();
                    assert_eq!(real.len(), len, "level {i}: spiral {v} repeats a vertex");
                }
            }
            assert!(l.triangles.iter().flatten().all(|&v| (v as usize) < n));
            // Every level stays a valid manifold mesh.
            let m = Mesh::new(
                l.positions.clone(),
                l.triangles.iter().map(|t| t.to_vec()).collect(),
            );
            checked_triangles(&m).unwrap_or_else(|e| panic!("level {i}: {e:#}"));
        }
        for (i, (d, u)) in h.down.iter().zip(&h.up).enumerate() {
            let (n, m) = (h.levels[i].positions.len(), h.levels[i + 1].positions.len());
            assert_eq!((d.rows, d.cols), (m + 1, n + 1));
            assert_eq!((u.rows, u.cols), (n + 1, m + 1));
            for r in 0..d.rows {
                let (a, b) = (d.row_ptr[r] as usize, d.row_ptr[r + 1] as usize);
                assert_eq!(b - a, 1, "D{i} row {r}");
                assert_eq!(d.values[a], 1.0);
            }
            assert_eq!(*d.col_idx.last().unwrap() as usize, n);
            let mut selected = vec![u32::MAX; n + 1];
            for (r, &c) in d.col_idx.iter().enumerate() {
                selected[c as usize] = r as u32;
                // Coarse vertex r is fine vertex c.
                if r < m {
                    assert_eq!(
                        h.levels[i + 1].positions[r],
                        h.levels[i].positions[c as usize]
                    );
                }
            }
            let mut total = 0.0;
            assert_eq!(selected.len(), u.rows);
            for (r, &sel) in selected.iter().enumerate() {
                let (a, b) = (u.row_ptr[r] as usize, u.row_ptr[r + 1] as usize);
                assert!(
                    (1..=3).contains(&(b - a)),
                    "U{i} row {r} has {} entries",
                    b - a
                );
                let sum: f32 = u.values[a..b].iter().sum();
                assert!((sum - 1.0).abs() < 1e-6, "U{i} row {r} sums to {sum}");
                assert!(u.values[a..b].iter().all(|&w| w > 0.0 && w <= 1.0));
                if sel != u32::MAX {
                    assert_eq!(&u.col_idx[a..b], &[sel], "U{i} row {r}");
                    assert_eq!(u.values[a], 1.0);
                }
                if r < n {
                    let mut q = [0.0f64; 3];
                    for k in a..b {
                        let p = h.levels[i + 1].positions[u.col_idx[k] as usize];
                        for c in 0..3 {
                            q[c] += f64::from(u.values[k]) * f64::from(p[c]);
                        }
                    }
                    total += norm2(sub(q, to64(h.levels[i].positions[r]))).sqrt();
                }
            }
            mean_dist.push(total / n as f64);
        }
        mean_dist
    }

    fn summary(name: &str, unit: &str, h: &Hierarchy, dist: &[f64], seconds: f64) {
        let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
        let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
        let d: Vec<String> = dist.iter().map(|d| format!("{d:.3e}")).collect();
        eprintln!(
            "{name}: vertices {sizes:?}, spiral lengths {lens:?}, mean |U·x_coarse − x| per \
             level [{}] {unit}, built in {seconds:.2} s",
            d.join(", ")
        );
    }

    /// FLAME: the reference's level sizes exactly; spiral lengths compared with the reference's
    /// `[15, 14, 9, 9, 7]` (see docs/S2D.md for why they differ).
    #[test]
    fn flame_hierarchy() {
        let Some(dir) = data_dir() else { return };
        let mesh = Mesh::read(&dir.join("flame/FLAME_template.ply")).unwrap();
        let t = Instant::now();
        let h = build(&mesh, &DEFAULT_FACTORS).unwrap();
        let seconds = t.elapsed().as_secs_f64();
        let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
        assert_eq!(sizes, [5023, 1256, 314, 79, 20]);
        let dist = check(&h);
        summary("FLAME", "m", &h, &dist, seconds);
        // FLAME is in metres: the 5023 → 1256 up-sampling stays well under a millimetre on
        // average, the coarsest levels within a few centimetres.
        assert!(dist[0] < 1e-3, "{dist:?}");
        assert!(dist.iter().all(|&d| d < 0.02), "{dist:?}");
        let lens: Vec<usize> = h.levels.iter().map(|l| l.spiral_len).collect();
        assert_eq!(lens, FLAME_SPIRAL_LENGTHS);

        // Byte-identical when built again, and read back unchanged.
        let config = Config::default();
        let key = cache_key(&mesh, &config);
        let bytes = to_bytes(&h, key, &config).unwrap();
        let again = to_bytes(&build(&mesh, &DEFAULT_FACTORS).unwrap(), key, &config).unwrap();
        assert!(bytes == again, "two builds differ");
        assert_eq!(from_bytes(&bytes).unwrap(), h);

        // Pinned to the reference's lengths, the spirals give the reference network's shapes.
        let pinned = Config::reference_flame();
        let hp = build_with(&mesh, &pinned).unwrap();
        check(&hp);
        let lens: Vec<usize> = hp.levels.iter().map(|l| l.spiral_len).collect();
        assert_eq!(lens, spirals::REFERENCE_FLAME_LENGTHS);
        assert_eq!(hp.up, h.up);
        assert!(
            build_with(
                &mesh,
                &Config {
                    spiral_lengths: Some(vec![9; 4]),
                    ..pinned
                }
            )
            .is_err()
        );
    }

    /// Spiral lengths Sinew's construction gives on FLAME (reference: `[15, 14, 9, 9, 7]`).
    const FLAME_SPIRAL_LENGTHS: [usize; 5] = [15, 13, 9, 9, 7];

    #[test]
    fn ict_face_region_hierarchy() {
        let Some(dir) = data_dir() else { return };
        let full = Mesh::read(&dir.join("ict-facekit/generic_neutral_mesh.obj")).unwrap();
        let region = crate::ict::FACE_REGION;
        let (mesh, _) = full.submesh(|v| region.contains(&v));
        let t = Instant::now();
        let h = build(&mesh, &DEFAULT_FACTORS).unwrap();
        let seconds = t.elapsed().as_secs_f64();
        let n = mesh.positions.len();
        let mut expect = vec![n];
        for _ in 0..4 {
            expect.push(expect.last().unwrap().div_ceil(4));
        }
        let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
        assert_eq!(sizes, expect);
        let dist = check(&h);
        summary("ICT face region", "cm", &h, &dist, seconds);
        // ICT-FaceKit is in centimetres.
        assert!(dist[0] < 0.1, "{dist:?}");
    }

    #[test]
    fn cache_builds_once_and_reads_back() {
        let Some(dir) = data_dir() else { return };
        let mesh = Mesh::read(&dir.join("flame/FLAME_template.ply")).unwrap();
        let tmp = tempfile::tempdir().unwrap();
        let factors = [4, 4];
        let config = Config {
            factors: factors.to_vec(),
            spiral_lengths: None,
        };
        let h = cached(&mesh, &factors, tmp.path()).unwrap();
        let path = cache_path(&mesh, &config, tmp.path());
        let written = std::fs::read(&path).unwrap();
        let again = cached(&mesh, &factors, tmp.path()).unwrap();
        assert_eq!(h, again);
        assert_eq!(std::fs::read(&path).unwrap(), written);
        // A different factor list is a different entry; a corrupt entry is rebuilt.
        let other = Config {
            factors: vec![4, 3],
            spiral_lengths: None,
        };
        assert_ne!(cache_path(&mesh, &other, tmp.path()), path);
        let other = Config {
            spiral_lengths: Some(vec![9, 9, 9]),
            ..config
        };
        assert_ne!(cache_path(&mesh, &other, tmp.path()), path);
        std::fs::write(&path, b"garbage").unwrap();
        assert_eq!(cached(&mesh, &factors, tmp.path()).unwrap(), h);
        assert_eq!(std::fs::read(&path).unwrap(), written);
    }

    /// A `k × k` grid of unit squares split into triangles, counter-clockwise seen from +z.
    fn grid(k: u32) -> Mesh {
        let mut positions = Vec::new();
        for y in 0..=k {
            for x in 0..=k {
                // A small bump so that the quadrics are not all zero.
                let z = ((x * 7 + y * 3) % 5) as f32 * 0.01;
                positions.push([x as f32, y as f32, z]);
            }
        }
        let id = |x: u32, y: u32| y * (k + 1) + x;
        let mut polygons = Vec::new();
        for y in 0..k {
            for x in 0..k {
                polygons.push(vec![id(x, y), id(x + 1, y), id(x + 1, y + 1), id(x, y + 1)]);
            }
        }
        Mesh::new(positions, polygons)
    }

    #[test]
    fn quad_grid_decimates_and_keeps_its_border() {
        let mesh = grid(12);
        let h = build(&mesh, &[4, 4]).unwrap();
        let sizes: Vec<usize> = h.levels.iter().map(|l| l.positions.len()).collect();
        assert_eq!(sizes, [169, 43, 11]);
        check(&h);
        // The four corners survive every level: moving one would cost a boundary plane.
        let corners = [[0.0, 0.0], [12.0, 0.0], [0.0, 12.0], [12.0, 12.0]];
        for l in &h.levels {
            for c in corners {
                assert!(l.positions.iter().any(|p| p[0] == c[0] && p[1] == c[1]));
            }
        }
    }

    #[test]
    fn sections_round_trip_and_bad_ones_are_named() {
        let h = build(&grid(8), &[4, 4]).unwrap();
        let config = Config {
            factors: vec![4, 4],
            spiral_lengths: Some(vec![7, 6, 5]),
        };
        let bytes = to_bytes(&h, 7, &config).unwrap();
        assert_eq!(from_bytes(&bytes).unwrap(), h);
        let f = SinewFile::from_bytes(&bytes).unwrap();
        assert_eq!(f.metadata().get("key"), Some("0000000000000007"));
        assert_eq!(f.metadata().get("factors"), Some("4,4"));
        assert_eq!(f.metadata().get("spiral_lengths"), Some("7,6,5"));

        let rewrite = |h: &Hierarchy| {
            let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
            write_sections(h, &mut w, "s2d", Sections::All).unwrap();
            format!("{:#}", from_bytes(&w.to_bytes().unwrap()).unwrap_err())
        };
        let mut bad = h.clone();
        bad.levels[1].spirals[0] = 1000;
        let e = rewrite(&bad);
        assert!(e.contains("s2d.h1.spiral"), "{e}");
        let mut bad = h.clone();
        bad.up[0].col_idx[0] = 1000;
        let e = rewrite(&bad);
        assert!(e.contains("s2d.u0"), "{e}");
        let mut bad = h.clone();
        bad.levels[0].triangles[0][0] = 1000;
        let e = rewrite(&bad);
        assert!(e.contains("s2d.h0.tri"), "{e}");
    }

    #[test]
    fn rejects_bad_meshes_naming_the_culprit() {
        let err = |m: &Mesh| format!("{:#}", build(m, &DEFAULT_FACTORS).unwrap_err());
        let p = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, 1.0],
        ];
        assert!(err(&Mesh::default()).contains("no vertices"));
        assert!(err(&tri_mesh(p.clone(), &[])).contains("no faces"));
        // Three triangles on edge (0, 1).
        let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[1, 0, 3], &[0, 1, 4]]));
        assert!(
            e.contains("edge (0, 1)") && e.contains("non-manifold"),
            "{e}"
        );
        let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[0, 1, 3]]));
        assert!(e.contains("same direction"), "{e}");
        let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[0, 1, 1]]));
        assert!(e.contains("face 1") && e.contains("twice"), "{e}");
        let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[0, 2, 7]]));
        assert!(e.contains("face 1") && e.contains("vertex 7"), "{e}");
        // Vertex 3 lies on the line through 0 and 1.
        let mut q = p.clone();
        q[3] = [2.0, 0.0, 0.0];
        let e = err(&tri_mesh(q, &[&[0, 2, 1], &[0, 1, 3]]));
        assert!(e.contains("face 1") && e.contains("zero area"), "{e}");
        let e = err(&tri_mesh(p.clone(), &[&[0, 1, 2], &[1, 0, 3]]));
        assert!(e.contains("vertex 4") && e.contains("no face"), "{e}");
        // Two fans meeting only at vertex 0 (a bow tie).
        let bow = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [-1.0, -1.0, 0.0],
        ];
        let e = err(&tri_mesh(bow, &[&[0, 1, 2], &[0, 3, 4]]));
        assert!(
            e.contains("vertex 0") && e.contains("non-manifold vertex"),
            "{e}"
        );
        // A single triangle cannot lose a vertex.
        let e = err(&tri_mesh(p[..3].to_vec(), &[&[0, 1, 2]]));
        assert!(e.contains("cannot decimate"), "{e}");
        assert!(build(&grid(3), &[1]).is_err());
    }
}
