//! Where a rig's coordinates sit ([`Conventions`]: units, up and forward [`Axis`], the node's
//! place in its scene) and the map between them and Sinew's face frame.

use serde::Serialize;

use crate::io::units::Unit;

/// Centimetres per millimetre: Sinew's face frame is in centimetres.
pub(crate) const CM_PER_MM: f64 = 0.1;

/// A coordinate axis with its direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// +x
    PosX,
    /// −x
    NegX,
    /// +y
    PosY,
    /// −y
    NegY,
    /// +z
    PosZ,
    /// −z
    NegZ,
}

impl Axis {
    /// `+x` … `-z`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::PosX => "+x",
            Self::NegX => "-x",
            Self::PosY => "+y",
            Self::NegY => "-y",
            Self::PosZ => "+z",
            Self::NegZ => "-z",
        }
    }

    /// The axis closest to the direction `v`.
    pub fn nearest(v: [f64; 3]) -> Self {
        let all = [
            Self::PosX,
            Self::NegX,
            Self::PosY,
            Self::NegY,
            Self::PosZ,
            Self::NegZ,
        ];
        all.into_iter()
            .max_by(|a, b| {
                crate::geometry::vec3::dot(a.vector(), v)
                    .total_cmp(&crate::geometry::vec3::dot(b.vector(), v))
            })
            .unwrap_or(Self::PosY)
    }

    /// The unit vector.
    pub const fn vector(self) -> [f64; 3] {
        match self {
            Self::PosX => [1.0, 0.0, 0.0],
            Self::NegX => [-1.0, 0.0, 0.0],
            Self::PosY => [0.0, 1.0, 0.0],
            Self::NegY => [0.0, -1.0, 0.0],
            Self::PosZ => [0.0, 0.0, 1.0],
            Self::NegZ => [0.0, 0.0, -1.0],
        }
    }
}

impl std::str::FromStr for Axis {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim().to_ascii_lowercase();
        let t = t.strip_prefix('+').unwrap_or(&t);
        Ok(match t {
            "x" => Self::PosX,
            "-x" => Self::NegX,
            "y" => Self::PosY,
            "-y" => Self::NegY,
            "z" => Self::PosZ,
            "-z" => Self::NegZ,
            _ => return Err(format!("{s:?} is not an axis (+x, -x, +y, -y, +z or -z)")),
        })
    }
}

impl Serialize for Axis {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Where a rig's coordinates sit, and the map between them and Sinew's face frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Conventions {
    /// The rig's length unit.
    pub units: Unit,
    /// Whether the unit was guessed from the head's size (an OBJ rig without `--units`).
    pub units_guessed: bool,
    /// The rig's up axis.
    pub up: Axis,
    /// The axis the face looks along.
    pub forward: Axis,
    /// The skin mesh's coordinates to its scene's, column-major (glTF's node transforms).
    pub node_transform: [[f64; 4]; 4],
    /// The head's place in its scene: Sinew's face frame from the scene's (in centimetres, up
    /// and forward resolved), a rotation and a translation, column-major. Found by registering
    /// the face template, so that the face frame is the kit's whichever way the head turns.
    pub placement: [[f64; 4]; 4],
}

impl Conventions {
    /// The face frame's x axis in the scene: up × forward.
    pub(crate) fn right(&self) -> [f64; 3] {
        crate::geometry::vec3::cross(self.up.vector(), self.forward.vector())
    }

    fn scale(&self) -> f64 {
        self.units.mm() * CM_PER_MM
    }

    /// A point of the skin mesh in the face frame (cm).
    pub fn to_face(&self, p: [f32; 3]) -> [f64; 3] {
        let m = &self.node_transform;
        let q: [f64; 3] = std::array::from_fn(|r| {
            (0..3).map(|c| m[c][r] * f64::from(p[c])).sum::<f64>() + m[3][r]
        });
        transform(&self.placement, self.axes(q), true)
    }

    /// An offset of the skin mesh in the face frame (cm).
    pub fn offset_to_face(&self, d: [f32; 3]) -> [f64; 3] {
        let m = &self.node_transform;
        let q: [f64; 3] =
            std::array::from_fn(|r| (0..3).map(|c| m[c][r] * f64::from(d[c])).sum::<f64>());
        transform(&self.placement, self.axes(q), false)
    }

    fn axes(&self, q: [f64; 3]) -> [f64; 3] {
        use crate::geometry::vec3::dot;
        let s = self.scale();
        [
            dot(q, self.right()) * s,
            dot(q, self.up.vector()) * s,
            dot(q, self.forward.vector()) * s,
        ]
    }

    /// A point of the face frame back in the skin mesh's own coordinates; `None` when the node
    /// transform cannot be inverted.
    pub fn from_face(&self, f: [f64; 3]) -> Option<[f64; 3]> {
        // The placement is rigid: its inverse is its transpose.
        let p = &self.placement;
        let g = [f[0] - p[3][0], f[1] - p[3][1], f[2] - p[3][2]];
        let f: [f64; 3] = std::array::from_fn(|k| (0..3).map(|r| p[k][r] * g[r]).sum());
        let s = self.scale();
        let (r, u, w) = (self.right(), self.up.vector(), self.forward.vector());
        let q: [f64; 3] = std::array::from_fn(|k| (f[0] * r[k] + f[1] * u[k] + f[2] * w[k]) / s);
        let m = &self.node_transform;
        let a: crate::geometry::align::M3 =
            std::array::from_fn(|r| std::array::from_fn(|c| m[c][r]));
        let inv = crate::geometry::align::inv3(a)?;
        let t = [q[0] - m[3][0], q[1] - m[3][1], q[2] - m[3][2]];
        Some(crate::geometry::align::mat_vec(inv, t))
    }
}

/// `m` (column-major 4 × 4) applied to a point (`point`) or a direction.
pub(crate) fn transform(m: &[[f64; 4]; 4], v: [f64; 3], point: bool) -> [f64; 3] {
    let w = if point { 1.0 } else { 0.0 };
    std::array::from_fn(|r| (0..3).map(|c| m[c][r] * v[c]).sum::<f64>() + w * m[3][r])
}
