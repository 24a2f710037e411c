//! Sparse anatomical constraints between a skin surface and bone surfaces (Wu et al. 2016, as AIM
//! section 3 and eq. 12 use them): for each skin vertex with bone underneath, the bone point `b`,
//! the soft-tissue thickness `d` and the bone normal `n`.
//!
//! How a constraint is found: a ray starts at the skin vertex and goes inward, along the negated
//! outward vertex normal. The first bone triangle it crosses within `max_depth` gives the bone
//! point (the crossing), the thickness (the ray length, since the direction is a unit vector) and
//! the bone normal (that triangle's plane normal, turned to face the skin). A vertex whose ray
//! meets no bone, meets it too deep, or meets it at a grazing angle gets no constraint: these are
//! the "regions where the constraints can be accurately computed" of AIM section 4.1.1.
//!
//! Why grazing hits are rejected (`min_cos`): when the ray meets the bone nearly tangentially,
//! (1) the hit point is ill-conditioned: a small change of the skin normal slides it far along
//! the bone; (2) the ray length overstates the tissue depth, roughly by `1 / cos`; (3) such hits
//! come from silhouettes of thin bone (zygomatic arch, nasal bones, the mandible's lower border)
//! whose triangle normals are unreliable; and (4) AIM eq. 1 rebuilds the skin as
//! `s = b + d n`, which holds exactly only when the bone normal is anti-parallel to the ray;
//! the mismatch is `d * |n - m|` (m the skin normal), i.e. `d * sqrt(2 - 2 cos)`. Bounding
//! `cos` from below bounds that inconsistency between the three supervised quantities.
//!
//! Speed: the bone triangles go into a bounding-volume hierarchy (median split on the longest
//! centroid axis, at most [`LEAF_SIZE`] triangles per leaf); each ray walks it front to back and
//! tests triangles with the Möller–Trumbore algorithm in `f64`. The result is deterministic: the
//! build sorts with index tie-breaks, ties between equally near hits go to the lower triangle
//! number, and the optional threads each own a fixed slice of the vertices.

use crate::geometry::vec3::{V3, cross, dot, norm, sub, to64};
use crate::io::mesh::Mesh;
use serde::{Deserialize, Serialize};

/// Which bone a constraint lies on. AIM moves the jaw rigidly (eq. 10's `T_b`) and keeps the
/// skull fixed, so the learner needs to know which one each bone point belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Bone {
    /// The skull (cranium, maxilla, nasal bones, zygomas): does not move.
    Skull,
    /// The mandible: moves with the jaw transform.
    Jaw,
}

impl std::fmt::Display for Bone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Skull => "skull",
            Self::Jaw => "jaw",
        })
    }
}

/// One bone as a triangle soup: which bone, its positions, its triangles.
pub type BoneMesh<'a> = (Bone, &'a [[f32; 3]], &'a [[u32; 3]]);

/// The default lower bound on `|cos|` between the ray and the bone normal (hits flatter than
/// about 72.5° from the normal are rejected; see the module docs for why).
pub const DEFAULT_MIN_COS: f32 = 0.3;

/// The most triangles in one hierarchy leaf.
pub const LEAF_SIZE: usize = 4;

/// Settings for [`compute`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstraintParams {
    /// The deepest bone hit accepted, in the skin's unit (for example 2.5 for 25 mm on ICT's cm).
    pub max_depth: f32,
    /// The smallest accepted `|cos|` between the ray and the hit triangle's normal.
    pub min_cos: f32,
}

impl ConstraintParams {
    /// Parameters with the given `max_depth` and [`DEFAULT_MIN_COS`].
    pub fn new(max_depth: f32) -> Self {
        Self {
            max_depth,
            min_cos: DEFAULT_MIN_COS,
        }
    }
}

/// One anatomical constraint (AIM eq. 1: `s_0 = b_0 + d_0 n_0`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Constraint {
    /// The bone point `b`: where the inward ray first meets bone.
    pub bone_point: [f32; 3],
    /// The soft-tissue thickness `d`: the distance from the skin vertex to `bone_point` along the
    /// ray, in the skin's unit.
    pub thickness: f32,
    /// The bone normal `n`: the unit normal of the hit triangle, oriented towards the skin vertex
    /// (outward from the bone, whatever the mesh's winding).
    pub normal: [f32; 3],
    /// The bone that was hit.
    pub bone: Bone,
}

impl Constraint {
    /// The skin point AIM eq. 1 rebuilds from this constraint: `b + d n`. It equals the skin
    /// vertex only when the bone normal is anti-parallel to the ray (see the module docs).
    pub fn reconstruct(&self) -> [f32; 3] {
        let (b, n, d) = (self.bone_point, self.normal, self.thickness);
        [b[0] + d * n[0], b[1] + d * n[1], b[2] + d * n[2]]
    }
}

/// The constraints of a whole skin mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Constraints {
    /// One entry per skin vertex, `None` where no bone was accepted under it.
    pub per_vertex: Vec<Option<Constraint>>,
    /// Bone triangles that were left out because an index was out of range, a coordinate was
    /// not finite, or the triangle had no area. Non-zero means the bone input deserves a look.
    pub skipped_triangles: usize,
}

impl Constraints {
    /// How many vertices carry a constraint.
    pub fn count(&self) -> usize {
        self.per_vertex.iter().filter(|c| c.is_some()).count()
    }

    /// The constrained share of all vertices (0 for an empty skin).
    pub fn fraction(&self) -> f32 {
        if self.per_vertex.is_empty() {
            return 0.0;
        }
        self.count() as f32 / self.per_vertex.len() as f32
    }

    /// The constrained share of the listed vertices (indices out of range count as
    /// unconstrained; 0 for an empty list).
    pub fn fraction_of(&self, vertices: impl IntoIterator<Item = u32>) -> f32 {
        let (mut n, mut hit) = (0usize, 0usize);
        for v in vertices {
            n += 1;
            if matches!(self.per_vertex.get(v as usize), Some(Some(_))) {
                hit += 1;
            }
        }
        if n == 0 { 0.0 } else { hit as f32 / n as f32 }
    }
}

/// Computes the constraints of every skin vertex against the bones (see the module docs).
///
/// `skin_normals` are the outward unit (or any non-zero) vertex normals, one per position; a
/// vertex with a missing, zero or non-finite normal or position gets `None`. Each bone is a
/// triangle soup: positions and triangles indexing them; triangles with an out-of-range index,
/// a non-finite corner or zero area are skipped and counted in
/// [`Constraints::skipped_triangles`].
pub fn compute(
    skin_positions: &[[f32; 3]],
    skin_normals: &[[f32; 3]],
    bones: &[BoneMesh<'_>],
    params: &ConstraintParams,
) -> Constraints {
    BoneScene::new(bones).constraints(skin_positions, skin_normals, params)
}

/// A ray hit on a bone, from [`BoneScene::first_hit`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// The distance along the (normalised) ray direction.
    pub distance: f32,
    /// The hit point.
    pub point: [f32; 3],
    /// The hit triangle's unit normal as the mesh winds it (not re-oriented).
    pub normal: [f32; 3],
    /// The bone that was hit.
    pub bone: Bone,
}

/// Bone triangles in a ray-query hierarchy; build once, query many times.
#[derive(Debug)]
pub struct BoneScene {
    scene: Scene,
    skipped: usize,
}

impl BoneScene {
    /// Builds the hierarchy. Triangles with an out-of-range index, a non-finite corner or zero
    /// area are left out and counted ([`BoneScene::skipped_triangles`]).
    pub fn new(bones: &[BoneMesh<'_>]) -> Self {
        let (scene, skipped) = Scene::build(bones);
        Self { scene, skipped }
    }

    /// How many input triangles were left out.
    pub fn skipped_triangles(&self) -> usize {
        self.skipped
    }

    /// How many triangles the scene holds.
    pub fn triangle_count(&self) -> usize {
        self.scene.tris.len()
    }

    /// The nearest bone crossing of the ray from `origin` along `direction` (any non-zero
    /// length; it is normalised) no farther than `max_distance`.
    pub fn first_hit(
        &self,
        origin: [f32; 3],
        direction: [f32; 3],
        max_distance: f32,
    ) -> Option<RayHit> {
        if !finite(origin) || !finite(direction) || max_distance.is_nan() || max_distance < 0.0 {
            return None;
        }
        let m = to64(direction);
        let len = norm(m);
        if len <= 0.0 || !len.is_finite() {
            return None;
        }
        let d = [m[0] / len, m[1] / len, m[2] / len];
        let o = to64(origin);
        let hit = self.scene.first_hit(o, d, max_distance as f64)?;
        let tri = &self.scene.tris[hit.tri as usize];
        let p = [
            o[0] + hit.t * d[0],
            o[1] + hit.t * d[1],
            o[2] + hit.t * d[2],
        ];
        Some(RayHit {
            distance: hit.t as f32,
            point: [p[0] as f32, p[1] as f32, p[2] as f32],
            normal: [
                tri.normal[0] as f32,
                tri.normal[1] as f32,
                tri.normal[2] as f32,
            ],
            bone: tri.bone,
        })
    }

    /// The constraint of one skin vertex with outward normal `outward` (see the module docs).
    pub fn constraint(
        &self,
        origin: [f32; 3],
        outward: [f32; 3],
        params: &ConstraintParams,
    ) -> Option<Constraint> {
        self.scene.constraint(origin, outward, params)
    }

    /// The constraints of every skin vertex (as [`compute`]).
    pub fn constraints(
        &self,
        skin_positions: &[[f32; 3]],
        skin_normals: &[[f32; 3]],
        params: &ConstraintParams,
    ) -> Constraints {
        let per_vertex = map_vertices(skin_positions.len(), |i| {
            let m = *skin_normals.get(i)?;
            self.scene.constraint(skin_positions[i], m, params)
        });
        Constraints {
            per_vertex,
            skipped_triangles: self.skipped,
        }
    }
}

/// Runs `f` for every index in `0..n`, on up to 8 threads, each over one contiguous slice, so the
/// output order (and every value) is the same as a sequential loop.
fn map_vertices<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism()
        .map(|t| t.get())
        .unwrap_or(1)
        .clamp(1, 8);
    // Small inputs are not worth a thread.
    if threads == 1 || n < 512 {
        return (0..n).map(f).collect();
    }
    let chunk = n.div_ceil(threads);
    let f = &f;
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let lo = (t * chunk).min(n);
                let hi = ((t + 1) * chunk).min(n);
                s.spawn(move || (lo..hi).map(f).collect::<Vec<T>>())
            })
            .collect();
        let mut out = Vec::with_capacity(n);
        for h in handles {
            // A worker only panics if `f` does; pass that panic on unchanged.
            match h.join() {
                Ok(part) => out.extend(part),
                Err(e) => std::panic::resume_unwind(e),
            }
        }
        out
    })
}

fn finite(a: [f32; 3]) -> bool {
    a.iter().all(|x| x.is_finite())
}

/// One bone triangle, ready for intersection.
#[derive(Clone, Copy, Debug)]
struct Tri {
    p0: V3,
    e1: V3,
    e2: V3,
    /// Unit normal by the mesh's winding (re-oriented per hit).
    normal: V3,
    bone: Bone,
}

#[derive(Clone, Copy, Debug)]
struct Aabb {
    min: V3,
    max: V3,
}

impl Aabb {
    fn empty() -> Self {
        Self {
            min: [f64::INFINITY; 3],
            max: [f64::NEG_INFINITY; 3],
        }
    }
    fn grow(&mut self, p: V3) {
        for ((lo, hi), x) in self.min.iter_mut().zip(&mut self.max).zip(p) {
            *lo = lo.min(x);
            *hi = hi.max(x);
        }
    }
    /// The entry distance of the ray into the box, if it enters within `[0, t_max]`.
    fn enter(&self, o: V3, inv_dir: V3, t_max: f64) -> Option<f64> {
        let (mut lo, mut hi) = (0.0f64, t_max);
        for k in 0..3 {
            if inv_dir[k].is_infinite() {
                // The ray runs parallel to this slab: it is inside for all t or for none. (The
                // product below would be 0 * inf = NaN for an origin on the slab's plane.)
                if o[k] < self.min[k] || o[k] > self.max[k] {
                    return None;
                }
                continue;
            }
            let t1 = (self.min[k] - o[k]) * inv_dir[k];
            let t2 = (self.max[k] - o[k]) * inv_dir[k];
            lo = lo.max(t1.min(t2));
            hi = hi.min(t1.max(t2));
        }
        (lo <= hi).then_some(lo)
    }
}

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    first: u32,
    /// Leaf: number of triangles (> 0); inner: 0.
    count: u32,
}

/// The bone triangles and their hierarchy.
#[derive(Debug)]
struct Scene {
    tris: Vec<Tri>,
    order: Vec<u32>,
    nodes: Vec<Node>,
}

/// A ray hit: distance, triangle number.
#[derive(Clone, Copy, Debug)]
struct Hit {
    t: f64,
    tri: u32,
}

impl Scene {
    fn build(bones: &[BoneMesh<'_>]) -> (Self, usize) {
        let mut tris = Vec::new();
        let mut skipped = 0usize;
        for &(bone, pos, faces) in bones {
            for f in faces {
                let corner = |k: usize| pos.get(f[k] as usize).copied().filter(|p| finite(*p));
                let (Some(a), Some(b), Some(c)) = (corner(0), corner(1), corner(2)) else {
                    skipped += 1;
                    continue;
                };
                let (a, b, c) = (to64(a), to64(b), to64(c));
                let (e1, e2) = (sub(b, a), sub(c, a));
                let n = cross(e1, e2);
                let len = norm(n);
                if len <= 0.0 || !len.is_finite() {
                    skipped += 1;
                    continue;
                }
                tris.push(Tri {
                    p0: a,
                    e1,
                    e2,
                    normal: [n[0] / len, n[1] / len, n[2] / len],
                    bone,
                });
            }
        }
        let centroids: Vec<V3> = tris
            .iter()
            .map(|t| [0, 1, 2].map(|k| t.p0[k] + (t.e1[k] + t.e2[k]) / 3.0))
            .collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let mut nodes = Vec::new();
        if !tris.is_empty() {
            nodes.push(Node {
                bounds: Aabb::empty(),
                first: 0,
                count: 0,
            });
            Self::split(&tris, &centroids, &mut order, &mut nodes, 0, 0, tris.len());
        }
        (Self { tris, order, nodes }, skipped)
    }

    /// Fills node `at` with `order[lo..hi]`, splitting at the median of the longest centroid axis.
    fn split(
        tris: &[Tri],
        centroids: &[V3],
        order: &mut [u32],
        nodes: &mut Vec<Node>,
        at: usize,
        lo: usize,
        hi: usize,
    ) {
        let mut bounds = Aabb::empty();
        let mut cb = Aabb::empty();
        for &i in &order[lo..hi] {
            let t = &tris[i as usize];
            bounds.grow(t.p0);
            bounds.grow([t.p0[0] + t.e1[0], t.p0[1] + t.e1[1], t.p0[2] + t.e1[2]]);
            bounds.grow([t.p0[0] + t.e2[0], t.p0[1] + t.e2[1], t.p0[2] + t.e2[2]]);
            cb.grow(centroids[i as usize]);
        }
        if hi - lo <= LEAF_SIZE {
            nodes[at] = Node {
                bounds,
                first: lo as u32,
                count: (hi - lo) as u32,
            };
            return;
        }
        let ext = sub(cb.max, cb.min);
        let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
            0
        } else if ext[1] >= ext[2] {
            1
        } else {
            2
        };
        // A full sort with the triangle number as tie-break makes the tree independent of the
        // sort algorithm's internals.
        order[lo..hi].sort_by(|&a, &b| {
            centroids[a as usize][axis]
                .total_cmp(&centroids[b as usize][axis])
                .then(a.cmp(&b))
        });
        let mid = lo + (hi - lo) / 2;
        let left = nodes.len();
        let blank = Node {
            bounds: Aabb::empty(),
            first: 0,
            count: 0,
        };
        nodes.push(blank);
        nodes.push(blank);
        nodes[at] = Node {
            bounds,
            first: left as u32,
            count: 0,
        };
        Self::split(tris, centroids, order, nodes, left, lo, mid);
        Self::split(tris, centroids, order, nodes, left + 1, mid, hi);
    }

    /// The nearest hit of the ray `o + t d` with `0 <= t <= t_max` (`d` a unit vector).
    fn first_hit(&self, o: V3, d: V3, t_max: f64) -> Option<Hit> {
        let root = self.nodes.first()?;
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        let mut best: Option<Hit> = None;
        let mut limit = t_max;
        root.bounds.enter(o, inv, limit)?;
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        stack.push(0);
        while let Some(ni) = stack.pop() {
            let node = self.nodes[ni as usize];
            // The limit may have shrunk since the node was pushed.
            if node.bounds.enter(o, inv, limit).is_none() {
                continue;
            }
            if node.count > 0 {
                let range = node.first as usize..(node.first + node.count) as usize;
                for &ti in &self.order[range] {
                    if let Some(t) = intersect(&self.tris[ti as usize], o, d)
                        && t <= limit
                    {
                        let better = match best {
                            None => true,
                            Some(b) => t < b.t || (t == b.t && ti < b.tri),
                        };
                        if better {
                            best = Some(Hit { t, tri: ti });
                            limit = t;
                        }
                    }
                }
            } else {
                let (l, r) = (node.first, node.first + 1);
                let tl = self.nodes[l as usize].bounds.enter(o, inv, limit);
                let tr = self.nodes[r as usize].bounds.enter(o, inv, limit);
                // Push the farther child first so the nearer one is searched first.
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        if a <= b {
                            stack.push(r);
                            stack.push(l);
                        } else {
                            stack.push(l);
                            stack.push(r);
                        }
                    }
                    (Some(_), None) => stack.push(l),
                    (None, Some(_)) => stack.push(r),
                    (None, None) => {}
                }
            }
        }
        best
    }

    fn constraint(
        &self,
        origin: [f32; 3],
        outward: [f32; 3],
        params: &ConstraintParams,
    ) -> Option<Constraint> {
        if !finite(origin) || !finite(outward) {
            return None;
        }
        let m = to64(outward);
        let len = norm(m);
        if len <= 0.0 || !len.is_finite() || params.max_depth.is_nan() || params.max_depth < 0.0 {
            return None;
        }
        let d = [-m[0] / len, -m[1] / len, -m[2] / len];
        let o = to64(origin);
        let hit = self.first_hit(o, d, params.max_depth as f64)?;
        let tri = &self.tris[hit.tri as usize];
        let cos = dot(tri.normal, d);
        if cos.abs() < params.min_cos as f64 {
            return None;
        }
        // Turn the normal towards the ray's origin: the ray travels along `d`, so a normal facing
        // the skin has a negative dot product with it.
        let n = if cos > 0.0 {
            [-tri.normal[0], -tri.normal[1], -tri.normal[2]]
        } else {
            tri.normal
        };
        let b = [
            o[0] + hit.t * d[0],
            o[1] + hit.t * d[1],
            o[2] + hit.t * d[2],
        ];
        Some(Constraint {
            bone_point: [b[0] as f32, b[1] as f32, b[2] as f32],
            thickness: hit.t as f32,
            normal: [n[0] as f32, n[1] as f32, n[2] as f32],
            bone: tri.bone,
        })
    }
}

/// Tolerance on barycentric coordinates in [`intersect`].
const BARY_EPS: f64 = 1e-9;

/// Möller–Trumbore ray/triangle intersection, two-sided: the distance `t >= 0` along the unit
/// direction `d`, if the ray crosses the triangle (edges included).
fn intersect(tri: &Tri, o: V3, d: V3) -> Option<f64> {
    let p = cross(d, tri.e2);
    let det = dot(tri.e1, p);
    // Relative test: a ray (nearly) in the triangle's plane has no single crossing point.
    let scale = norm(tri.e1) * norm(tri.e2);
    if det.abs() <= 1e-12 * scale {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, tri.p0);
    let u = dot(s, p) * inv;
    // The barycentric bounds are widened by `BARY_EPS`: a ray through a shared edge or vertex
    // would otherwise slip between the triangles by rounding and miss the bone entirely. It
    // may now hit both neighbours at the same distance; the lower triangle number wins.
    if !(-BARY_EPS..=1.0 + BARY_EPS).contains(&u) {
        return None;
    }
    let q = cross(s, tri.e1);
    let v = dot(d, q) * inv;
    if v < -BARY_EPS || u + v > 1.0 + BARY_EPS {
        return None;
    }
    let t = dot(tri.e2, q) * inv;
    (t >= 0.0).then_some(t)
}

/// The largest skin-to-bone depth for a constraint by default, in the data's unit (2.5 cm on
/// ICT-FaceKit): AIM's `max_constraint_depth` and the picture of `sinew bones fit`.
pub const DEFAULT_MAX_DEPTH: f32 = 2.5;

/// One sparse anatomical constraint at a skin vertex (Wu et al. 2016): bone point, soft-tissue
/// thickness, bone normal and which bone was hit.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Anchor {
    /// Bone point.
    pub bone: [f32; 3],
    /// Thickness, in the data's unit.
    pub thickness: f32,
    /// Unit bone normal (pointing out of the bone, towards the skin).
    pub normal: [f32; 3],
    /// The bone the constraint lies on: the skin over the jaw ([`Bone::Jaw`]) moves with the jaw
    /// transform, which is what the jaw initialisation and the jaw skinning term use.
    ///
    /// [`Bone::Jaw`]: crate::anatomy::constraints::Bone::Jaw
    pub on: crate::anatomy::constraints::Bone,
}

/// Wu et al.'s sparse constraints of every vertex of `neutral` against the bones.
pub fn anchors(neutral: &Mesh, skull: &Mesh, jaw: &Mesh, max_depth: f32) -> Vec<Option<Anchor>> {
    let normals = neutral.vertex_normals();
    let (skull_tri, jaw_tri) = (skull.triangles(), jaw.triangles());
    let found = compute(
        &neutral.positions,
        &normals,
        &[
            (Bone::Skull, &skull.positions, &skull_tri),
            (Bone::Jaw, &jaw.positions, &jaw_tri),
        ],
        &ConstraintParams::new(max_depth),
    );
    // The constraint's normal is the unit direction from the bone point to the skin vertex (the
    // reversed ray), not the bone triangle's normal: then b + d·n reproduces the skin vertex
    // exactly, as AIM eq. 1 states, and L_A (eq. 12) does not pull the neutral off the skin.
    // With the triangle normal, b + d·n missed the ICT skin by 3.9 mm (median) and the trained
    // neutral was 3.9 mm off on average while the expressions, helped by their correctives,
    // were 0.85 mm off (2000 steps; docs/AIM.md).
    found
        .per_vertex
        .iter()
        .zip(&neutral.positions)
        .map(|(c, s)| {
            c.and_then(|c| {
                let d = [
                    s[0] - c.bone_point[0],
                    s[1] - c.bone_point[1],
                    s[2] - c.bone_point[2],
                ];
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                (len > 0.0).then(|| Anchor {
                    bone: c.bone_point,
                    thickness: len,
                    normal: d.map(|v| v / len),
                    on: c.bone,
                })
            })
        })
        .collect()
}

#[cfg(test)]
mod tests;
