//! The plane of left-right symmetry of a face: AIM's eq. 14 mirrors across it, and a rig's
//! report states it.

use serde::Serialize;

/// A plane of symmetry: points x with (x − origin)·normal = 0.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Plane {
    /// Unit normal.
    pub normal: [f32; 3],
    /// A point on the plane.
    pub origin: [f32; 3],
}

impl Plane {
    /// Reflects `x` across the plane.
    pub fn reflect(&self, x: [f32; 3]) -> [f32; 3] {
        let d = (0..3)
            .map(|i| (x[i] - self.origin[i]) * self.normal[i])
            .sum::<f32>();
        [0, 1, 2].map(|i| x[i] - 2.0 * d * self.normal[i])
    }

    /// The reflection as `x ↦ M x + t` (M = I − 2 n nᵀ, t = 2 (o·n) n).
    pub fn affine(&self) -> ([[f32; 3]; 3], [f32; 3]) {
        let n = self.normal;
        let on = (0..3).map(|i| self.origin[i] * n[i]).sum::<f32>();
        let m =
            [0, 1, 2].map(|r| [0, 1, 2].map(|c| f32::from(u8::from(r == c)) - 2.0 * n[r] * n[c]));
        (m, n.map(|v| 2.0 * on * v))
    }
}

/// Symmetric iBUG-68 landmark pairs (left, right) used to estimate the plane of symmetry.
pub const IBUG_PAIRS: [(usize, usize); 17] = [
    (0, 16),
    (1, 15),
    (2, 14),
    (3, 13),
    (4, 12),
    (5, 11),
    (6, 10),
    (7, 9),
    (17, 26),
    (18, 25),
    (19, 24),
    (20, 23),
    (21, 22),
    (36, 45),
    (39, 42),
    (31, 35),
    (48, 54),
];

/// The plane of symmetry: from mirrored landmark pairs when the actor has them (normal along the
/// mean left − right direction, through the mean midpoint), else the bounding box's mid-plane
/// across x.
pub fn symmetry_plane(positions: &[[f32; 3]], landmarks: &[Option<u32>]) -> Plane {
    let mut dir = [0.0f32; 3];
    let mut mid = [0.0f32; 3];
    let mut n = 0;
    for &(l, r) in &IBUG_PAIRS {
        if let (Some(Some(a)), Some(Some(b))) = (landmarks.get(l), landmarks.get(r)) {
            let (a, b) = (positions[*a as usize], positions[*b as usize]);
            for i in 0..3 {
                dir[i] += a[i] - b[i];
                mid[i] += 0.5 * (a[i] + b[i]);
            }
            n += 1;
        }
    }
    let len = dir.iter().map(|v| v * v).sum::<f32>().sqrt();
    if n >= 3 && len > 0.0 {
        return Plane {
            normal: dir.map(|v| v / len),
            origin: mid.map(|v| v / n as f32),
        };
    }
    let (lo, hi) = crate::io::mesh::Mesh::new(positions.to_vec(), Vec::new()).bounds();
    Plane {
        normal: [1.0, 0.0, 0.0],
        origin: [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ],
    }
}
