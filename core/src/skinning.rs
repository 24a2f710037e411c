//! AIM skinning: the anatomical neutral point, jaw linear blend skinning with a pivot, corrective
//! expression displacements and the global head transform (AIM eqs. 6, 10 and 17), plus
//! area-weighted vertex normals.
//!
//! Positions are `f32` triples interleaved `x, y, z` per vertex.

use crate::error::{Argument, BufferError, FormatError, InputError};
use crate::input::check_value;
use crate::linalg::{Mat3, Rigid, Vec3};
use crate::rotation;
use crate::tensor::{F32s, U32s};

/// A bone transform `T_b` rotating about a pivot: `T_b(x) = R (x − p) + p + t`.
///
/// For AIM's jaw, `p` is the jaw's hinge point, so a pure rotation opens the mouth about the hinge
/// and `t` slides the jaw.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct BoneTransform {
    /// Rotation `R` and translation `t`.
    pub rigid: Rigid,
    /// Pivot `p` the rotation turns about.
    pub pivot: Vec3,
}

impl BoneTransform {
    /// The identity bone transform (pivot at the origin).
    pub const IDENTITY: Self = Self {
        rigid: Rigid::IDENTITY,
        pivot: Vec3::ZERO,
    };

    /// A bone transform from rotation, translation and pivot.
    pub const fn new(rot: Mat3, trans: Vec3, pivot: Vec3) -> Self {
        Self {
            rigid: Rigid::new(rot, trans),
            pivot,
        }
    }

    /// A bone transform from AIM's 9 parameters `[6D rotation, tx, ty, tz]` (see
    /// [`rotation::rigid_from_9d`]) and a pivot.
    pub fn from_9d(params: &[f32; 9], pivot: Vec3) -> Self {
        Self {
            rigid: rotation::rigid_from_9d(params),
            pivot,
        }
    }

    /// [`Self::from_9d`] refusing what it would have to guess ([`rotation::try_rigid_from_9d`]);
    /// `argument` names the caller's 9 values in errors.
    ///
    /// # Errors
    /// [`InputError`] naming the value or the rotation's degenerate column.
    pub fn try_from_9d(
        params: &[f32; 9],
        pivot: Vec3,
        argument: Argument,
    ) -> Result<Self, InputError> {
        Ok(Self {
            rigid: rotation::try_rigid_from_9d(params, argument)?,
            pivot,
        })
    }

    /// `T_b(x) = R (x − p) + p + t`, evaluated as `((R (x − p)) + p) + t`.
    #[inline]
    pub fn apply(&self, x: Vec3) -> Vec3 {
        self.rigid.rot.mul_vec(x - self.pivot) + self.pivot + self.rigid.trans
    }
}

/// The per-frame pose of an AIM face: jaw bone transform and global head transform.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Pose {
    /// Jaw transform `T_b`, blended per vertex by the skinning weight `k`.
    pub jaw: BoneTransform,
    /// Global head transform `T_g`, applied last to every vertex.
    pub head: Rigid,
}

impl Pose {
    /// The rest pose: both transforms the identity.
    pub const IDENTITY: Self = Self {
        jaw: BoneTransform::IDENTITY,
        head: Rigid::IDENTITY,
    };

    /// Checks a pose built by hand (a pose from `AimActor::pose_from_9d` always passes): every
    /// rotation entry finite and within ±[`crate::layout::MAX_FACTOR`], every translation and
    /// the pivot within ±[`crate::layout::MAX_COORDINATE`]. The matrices need not be rotations;
    /// these bounds alone keep a valid actor's pose finite.
    ///
    /// # Errors
    /// [`InputError`] naming [`Argument::PoseHead`] (rotation by columns 0..9, translation
    /// 9..12) or [`Argument::PoseJaw`] (the same, then the pivot 12..15) and the value.
    pub fn check(&self) -> Result<(), InputError> {
        let [h0, h1, h2] = self.head.rot.cols;
        check_vectors(Argument::PoseHead, &[h0, h1, h2, self.head.trans])?;
        let [j0, j1, j2] = self.jaw.rigid.rot.cols;
        let jaw = [j0, j1, j2, self.jaw.rigid.trans, self.jaw.pivot];
        check_vectors(Argument::PoseJaw, &jaw)
    }
}

/// [`check_value`] of every component of `vectors`, indexed x y z per vector.
fn check_vectors(argument: Argument, vectors: &[Vec3]) -> Result<(), InputError> {
    for (i, v) in vectors.iter().enumerate() {
        for (j, x) in v.to_array().into_iter().enumerate() {
            check_value(argument, 3 * i + j, x)?;
        }
    }
    Ok(())
}

/// The neutral skin point from the anatomy: `s0 = b0 + d0 · n0`.
///
/// Evaluated per component as `b0ᵢ + d0 · n0ᵢ`. `n0` is used as given (AIM's normal MLP is
/// expected to produce unit vectors; this function does not renormalise).
#[inline]
pub fn neutral_point(b0: Vec3, d0: f32, n0: Vec3) -> Vec3 {
    // AIM eq. 6: s_0 = b_0 + d_0 n_0
    b0 + n0.scale(d0)
}

/// Linear blend skinning with one bone: `LBS(x, T_b, k) = k · T_b(x) + (1 − k) · x`.
///
/// Evaluated per component as `k · T_b(x)ᵢ + (1 − k) · xᵢ` (two rounded products, then the sum),
/// so `k = 0` returns `x` and `k = 1` returns `T_b(x)` exactly.
#[inline]
pub fn lbs(x: Vec3, bone: &BoneTransform, k: f32) -> Vec3 {
    // AIM eq. 10 (without e_i): LBS(s_0, T_b, k) = k T_b(s_0) + (1 − k) s_0
    let t = bone.apply(x);
    let j = 1.0 - k;
    Vec3::new(k * t.x + j * x.x, k * t.y + j * x.y, k * t.z + j * x.z)
}

/// One skinned vertex, AIM eq. 17: `s* = T_g( LBS(s0, T_b, k) + Σ_j w_j e_j )`.
///
/// `correctives` holds this vertex's `n_shapes` corrective displacements `e_j` as `[n_shapes, 3]`
/// (row-major), `weights` the `n_shapes` blend coefficients `w_j`. The pair is zipped: extra
/// entries of the longer one are ignored.
///
/// Order of operations: the corrective sum `e = Σ_j w_j e_j` is accumulated per component from
/// `0.0` in `j` order (`e ← e + w_j · e_j`), then `p = LBS(s0, T_b, k) + e`, then
/// `s* = R_g p + t_g` ([`Rigid::apply`]).
#[inline]
pub fn skin_vertex(s0: Vec3, k: f32, correctives: F32s<'_>, weights: &[f32], pose: &Pose) -> Vec3 {
    // AIM eq. 17: s* = T_g( LBS(s_0, T_b, k) + Σ_{N−1} w B_e )
    let skinned = lbs(s0, &pose.jaw, k);
    let e = corrective_sum(correctives, weights);
    pose.head.apply(skinned + e)
}

/// `Σ_j w_j e_j` accumulated per component from zero in `j` order.
#[inline]
fn corrective_sum(correctives: F32s<'_>, weights: &[f32]) -> Vec3 {
    let mut it = correctives.iter();
    let mut e = Vec3::ZERO;
    for w in weights {
        let (Some(x), Some(y), Some(z)) = (it.next(), it.next(), it.next()) else {
            break;
        };
        e = Vec3::new(e.x + *w * x, e.y + *w * y, e.z + *w * z);
    }
    e
}

/// Skins every vertex of a mesh with [`skin_vertex`] (AIM eq. 17 with global coefficients `w`).
///
/// # Shapes
/// With `n` vertices and `m = weights.len()` corrective shapes:
/// - `rest`: `[n, 3]` neutral positions `s0` (xyz interleaved);
/// - `k`: `[n]` jaw skinning weights;
/// - `correctives`: `[n, m, 3]` displacement basis `B_e`, vertex-major, so that each vertex's
///   `m × 3` block is contiguous (the layout of AIM's per-point MLP output, eq. 8);
/// - `weights`: `[m]` blend coefficients `w`, shared by all vertices;
/// - `out`: `[n, 3]` skinned positions.
///
/// # Errors
/// [`BufferError::Input`] if `rest.len()` is not a multiple of 3, or `k` or `correctives` do not
/// match `n` and `m`; [`BufferError::Output`] if `out.len() != rest.len()`. Nothing is written on
/// error.
pub fn skin(
    rest: &[f32],
    k: &[f32],
    correctives: F32s<'_>,
    weights: &[f32],
    pose: &Pose,
    out: &mut [f32],
) -> Result<(), BufferError> {
    let n = rest.len() / 3;
    let m = weights.len();
    let block = m.checked_mul(3).ok_or(BufferError::Input)?;
    if !rest.len().is_multiple_of(3)
        || k.len() != n
        || Some(correctives.len()) != n.checked_mul(block)
    {
        return Err(BufferError::Input);
    }
    if out.len() != rest.len() {
        return Err(BufferError::Output);
    }
    let verts = rest.chunks_exact(3).zip(k).zip(out.chunks_exact_mut(3));
    for (i, ((s, kv), o)) in verts.enumerate() {
        let s0 = read3(s);
        let e = correctives.slice(i * block, block);
        write3(o, skin_vertex(s0, *kv, e, weights, pose));
    }
    Ok(())
}

/// A validated triangle list: vertex indices in triples, each below the vertex count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Triangles<'a> {
    indices: U32s<'a>,
    n_vertices: usize,
}

impl<'a> Triangles<'a> {
    /// Checks a triangle list of `[n_triangles, 3]` indices into `n_vertices` vertices.
    ///
    /// # Errors
    /// [`FormatError::IncompatibleShapes`] (argument `indices`) if the number of indices is not a
    /// multiple of 3;
    /// [`FormatError::IndexOutOfRange`] (argument `indices`, the index's position) if an index
    /// is `>= n_vertices`.
    pub fn new(indices: U32s<'a>, n_vertices: usize) -> Result<Self, FormatError> {
        if !indices.len().is_multiple_of(3) {
            return Err(FormatError::incompatible_shapes("indices"));
        }
        if let Some(at) = indices.iter().position(|i| i as usize >= n_vertices) {
            return Err(FormatError::index_out_of_range("indices", at));
        }
        Ok(Self {
            indices,
            n_vertices,
        })
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.indices.len() / 3
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Number of vertices the indices refer to.
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// The raw indices, `[n_triangles, 3]`.
    pub fn indices(&self) -> U32s<'a> {
        self.indices
    }
}

/// Area-weighted vertex normals.
///
/// For each triangle `(a, b, c)` in order, the unnormalised face normal `(p_b − p_a) × (p_c − p_a)`
/// (twice the area, oriented by the counter-clockwise winding) is added to the accumulators of
/// `a`, then `b`, then `c`; `out` starts from zero. Finally every vertex's sum is normalised with
/// [`Vec3::normalize`], so vertices in no triangle (or only in degenerate ones) get `(0, 0, 0)`.
///
/// # Shapes
/// `positions`: `[n_vertices, 3]`; `out`: `[n_vertices, 3]`.
///
/// # Errors
/// [`BufferError::Input`] if `positions.len() != 3 · n_vertices`; [`BufferError::Output`] if
/// `out.len() != 3 · n_vertices`.
pub fn vertex_normals(
    triangles: &Triangles<'_>,
    positions: &[f32],
    out: &mut [f32],
) -> Result<(), BufferError> {
    vertex_normals_with(triangles, positions, out, Vec3::normalize)
}

/// [`vertex_normals`] with another normalisation of the summed face normals (the fast mode's
/// approximate one, `crate::fast::normalize`).
///
/// # Errors
/// As [`vertex_normals`].
pub fn vertex_normals_with(
    triangles: &Triangles<'_>,
    positions: &[f32],
    out: &mut [f32],
    normalize: impl Fn(Vec3) -> Vec3,
) -> Result<(), BufferError> {
    let len = triangles
        .n_vertices
        .checked_mul(3)
        .ok_or(BufferError::Input)?;
    if positions.len() != len {
        return Err(BufferError::Input);
    }
    if out.len() != len {
        return Err(BufferError::Output);
    }
    out.fill(0.0);
    let mut idx = triangles.indices.iter();
    while let (Some(a), Some(b), Some(c)) = (idx.next(), idx.next(), idx.next()) {
        let (a, b, c) = (a as usize, b as usize, c as usize);
        let pa = vertex(positions, a);
        let n = (vertex(positions, b) - pa).cross(vertex(positions, c) - pa);
        for v in [a, b, c] {
            if let Some(o) = out.get_mut(v * 3..v * 3 + 3) {
                write3(o, read3(o) + n);
            }
        }
    }
    for o in out.chunks_exact_mut(3) {
        write3(o, normalize(read3(o)));
    }
    Ok(())
}

/// Vertex `i` of an interleaved position array (zero if out of range, which validation excludes).
#[inline]
fn vertex(positions: &[f32], i: usize) -> Vec3 {
    positions.get(i * 3..i * 3 + 3).map_or(Vec3::ZERO, read3)
}

#[inline]
fn read3(s: &[f32]) -> Vec3 {
    match *s {
        [x, y, z, ..] => Vec3::new(x, y, z),
        _ => Vec3::ZERO,
    }
}

#[inline]
fn write3(o: &mut [f32], v: Vec3) {
    if let [x, y, z, ..] = o {
        *x = v.x;
        *y = v.y;
        *z = v.z;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn f32_bytes(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn u32_bytes(v: &[u32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn v(x: f32, y: f32, z: f32) -> Vec3 {
        Vec3::new(x, y, z)
    }

    /// 90° about z: x → y, y → −x.
    fn rot_z90() -> Mat3 {
        Mat3::from_cols(Vec3::Y, v(-1.0, 0.0, 0.0), Vec3::Z)
    }

    #[test]
    fn neutral_point_from_anatomy() {
        // (1, 2, 3) + 0.5 · (0, 0, 2) = (1, 2, 4)
        assert_eq!(
            neutral_point(v(1.0, 2.0, 3.0), 0.5, v(0.0, 0.0, 2.0)),
            v(1.0, 2.0, 4.0)
        );
    }

    #[test]
    fn bone_rotates_about_pivot() {
        let bone = BoneTransform::new(rot_z90(), v(0.0, 0.0, 1.0), v(1.0, 0.0, 0.0));
        // x − p = (2, 0, 0) − (1, 0, 0) = (1, 0, 0); R → (0, 1, 0); + p → (1, 1, 0); + t → (1, 1, 1)
        assert_eq!(bone.apply(v(2.0, 0.0, 0.0)), v(1.0, 1.0, 1.0));
        // The pivot only moves by t.
        assert_eq!(bone.apply(v(1.0, 0.0, 0.0)), v(1.0, 0.0, 1.0));
        // From 9 parameters: 6D (y, −x) is the same rotation.
        let b9 = BoneTransform::from_9d(
            &[0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            v(1.0, 0.0, 0.0),
        );
        assert_eq!(b9.apply(v(2.0, 0.0, 0.0)), v(1.0, 1.0, 1.0));
    }

    #[test]
    fn lbs_blends_linearly() {
        let bone = BoneTransform::new(rot_z90(), v(0.0, 0.0, 1.0), v(1.0, 0.0, 0.0));
        let x = v(2.0, 0.0, 0.0);
        assert_eq!(lbs(x, &bone, 0.0), x);
        assert_eq!(lbs(x, &bone, 1.0), v(1.0, 1.0, 1.0));
        // k = 0.25: 0.25 · (1, 1, 1) + 0.75 · (2, 0, 0) = (0.25 + 1.5, 0.25, 0.25) = (1.75, 0.25, 0.25)
        assert_eq!(lbs(x, &bone, 0.25), v(1.75, 0.25, 0.25));
    }

    #[test]
    fn skin_vertex_follows_eq_17() {
        let pose = Pose {
            jaw: BoneTransform::new(rot_z90(), v(0.0, 0.0, 1.0), v(1.0, 0.0, 0.0)),
            head: Rigid::new(rot_z90(), v(10.0, 0.0, 0.0)),
        };
        // e = 2 · (1, 0, 0) + (−1) · (0, 0.5, 0) = (2, −0.5, 0)
        let b = f32_bytes(&[1.0, 0.0, 0.0, 0.0, 0.5, 0.0]);
        let e = F32s::new(&b).unwrap();
        // LBS at k = 0.25 is (1.75, 0.25, 0.25) (see above); + e = (3.75, −0.25, 0.25).
        // T_g: R (3.75, −0.25, 0.25) = (0.25, 3.75, 0.25); + (10, 0, 0) = (10.25, 3.75, 0.25).
        let s = skin_vertex(v(2.0, 0.0, 0.0), 0.25, e, &[2.0, -1.0], &pose);
        assert_eq!(s, v(10.25, 3.75, 0.25));
        // With the identity pose and no shapes the rest point comes back unchanged.
        assert_eq!(
            skin_vertex(v(2.0, 0.0, 0.0), 0.25, F32s::empty(), &[], &Pose::IDENTITY),
            v(2.0, 0.0, 0.0)
        );
    }

    #[test]
    fn skin_mesh_and_buffer_checks() {
        let pose = Pose {
            jaw: BoneTransform::new(rot_z90(), v(0.0, 0.0, 1.0), v(1.0, 0.0, 0.0)),
            head: Rigid::new(Mat3::IDENTITY, v(0.0, 1.0, 0.0)),
        };
        let rest = [2.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let k = [0.25, 0.0];
        // Vertex 0: e_0 = (1, 0, 0); vertex 1: e_0 = (0, 0, 3). One shape, w = [2].
        let b = f32_bytes(&[1.0, 0.0, 0.0, 0.0, 0.0, 3.0]);
        let corr = F32s::new(&b).unwrap();
        let mut out = [0.0; 6];
        skin(&rest, &k, corr, &[2.0], &pose, &mut out).unwrap();
        // Vertex 0: (1.75, 0.25, 0.25) + (2, 0, 0) + (0, 1, 0) = (3.75, 1.25, 0.25).
        // Vertex 1: k = 0 → (0, 0, 0) + (0, 0, 6) + (0, 1, 0) = (0, 1, 6).
        assert_eq!(out, [3.75, 1.25, 0.25, 0.0, 1.0, 6.0]);

        assert_eq!(
            skin(&rest[..5], &k, corr, &[2.0], &pose, &mut out),
            Err(BufferError::Input)
        );
        assert_eq!(
            skin(&rest, &k[..1], corr, &[2.0], &pose, &mut out),
            Err(BufferError::Input)
        );
        assert_eq!(
            skin(&rest, &k, corr, &[2.0, 1.0], &pose, &mut out),
            Err(BufferError::Input)
        );
        assert_eq!(
            skin(&rest, &k, corr, &[2.0], &pose, &mut out[..3]),
            Err(BufferError::Output)
        );
        // Empty mesh.
        assert_eq!(
            skin(&[], &[], F32s::empty(), &[1.0], &pose, &mut []),
            Ok(())
        );
    }

    #[test]
    fn triangles_validation() {
        let b = u32_bytes(&[0, 1, 2, 2, 1, 3]);
        let idx = U32s::new(&b).unwrap();
        assert!(Triangles::new(idx, 4).is_ok());
        assert_eq!(
            Triangles::new(idx, 3),
            Err(FormatError::index_out_of_range("indices", 5))
        );
        assert_eq!(
            Triangles::new(idx.slice(0, 4), 4),
            Err(FormatError::incompatible_shapes("indices"))
        );
        let t = Triangles::new(idx, 4).unwrap();
        assert_eq!((t.len(), t.n_vertices(), t.is_empty()), (2, 4, false));
    }

    #[test]
    fn area_weighted_normals() {
        // Two triangles sharing the edge 1–2:
        //   T0 = (0, 1, 2) in the z = 0 plane: p0 = (0,0,0), p1 = (1,0,0), p2 = (0,1,0)
        //        (p1 − p0) × (p2 − p0) = (1,0,0) × (0,1,0) = (0, 0, 1)       (area 1/2)
        //   T1 = (1, 3, 2) in the x = 1 … plane: p3 = (1, 0, 2)
        //        (p3 − p1) × (p2 − p1) = (0,0,2) × (−1,1,0) = (0·0 − 2·1, 2·(−1) − 0·0, 0) = (−2, −2, 0)
        // Vertex 0: (0,0,1) → (0, 0, 1).
        // Vertices 1, 2: (0,0,1) + (−2,−2,0) = (−2, −2, 1), |·| = 3 → (−2/3, −2/3, 1/3).
        // Vertex 3: (−2, −2, 0) → (−1/√2, −1/√2, 0). Vertex 4 is in no triangle → 0.
        let b = u32_bytes(&[0, 1, 2, 1, 3, 2]);
        let tris = Triangles::new(U32s::new(&b).unwrap(), 5).unwrap();
        let pos = [
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 2.0, 5.0, 5.0, 5.0,
        ];
        let mut out = [9.0; 15];
        vertex_normals(&tris, &pos, &mut out).unwrap();
        let (a, c) = (-2.0f32 / 3.0, 1.0f32 / 3.0);
        let h = -1.0 / libm::sqrtf(2.0);
        // −2 / √8 with √8 = 2.828427 rounds to the same f32 as −1 / √2.
        assert_eq!(
            out,
            [0.0, 0.0, 1.0, a, a, c, a, a, c, h, h, 0.0, 0.0, 0.0, 0.0]
        );

        assert_eq!(
            vertex_normals(&tris, &pos[..12], &mut out),
            Err(BufferError::Input)
        );
        assert_eq!(
            vertex_normals(&tris, &pos, &mut out[..12]),
            Err(BufferError::Output)
        );
    }

    #[test]
    fn degenerate_triangle_gives_zero_normal() {
        let b = u32_bytes(&[0, 1, 1]);
        let tris = Triangles::new(U32s::new(&b).unwrap(), 2).unwrap();
        let mut out = [1.0; 6];
        vertex_normals(&tris, &[0.0, 0.0, 0.0, 1.0, 2.0, 3.0], &mut out).unwrap();
        assert_eq!(out, [0.0; 6]);
    }
}
