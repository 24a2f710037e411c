//! The jaw of a pose given by corrective coefficients alone: an ARKit capture, an engine driving
//! shapes by name, a viewer's sliders.
//!
//! AIM learns a jaw transform T_b for every training expression (Sec. 4.1), not only for the
//! shapes named after the jaw: on a studio's rig `mouthClose` or `mouthFunnel` turn the jaw by
//! several degrees, and their correctives were learned on top of that jaw. A pose that names only
//! coefficients takes its jaw from every shape's learned transform (`train.jaw`, `[M, 9]`: a 6D
//! rotation, then a translation), blended by the coefficients:
//!
//! 1. **Blend.** `J(w) = I + Σ_j w_j (J_j − I)` on the nine values, the sum over j from zero in
//!    order, where `I` is the identity `[1, 0, 0, 0, 1, 0, 0, 0, 0]`. One shape at weight 1 gets
//!    its learned transform, to the bit for any rotation under 60° (every jaw's), so it poses as
//!    it was trained; at weight ½ a rotation about one axis turns exactly half way
//!    (`atan2(w sin θ, 1 − w + w cos θ)` is θ/2 there), and in general within a few per cent of
//!    w θ.
//! 2. **Stay anatomical.** The blend's translation, value by value, and its rotation, as a
//!    rotation vector (axis × angle, in the actor's face frame: x opens the jaw, y slides it
//!    sideways, z tilts it), are held within the range that the identity and the shapes' learned
//!    transforms span ([`LearnedJaws::low`], [`LearnedJaws::high`]). However many shapes play and
//!    however far their weights go, the jaw opens, slides, tilts and moves no further than some
//!    training shape took it. A rotation within the range is the blend's own; one beyond it is
//!    the rotation of the held rotation vector (Rodrigues' formula).
//! 3. **A rotation the core accepts.** A blend whose 6D rotation the core would refuse (a column
//!    vanishing between shapes that turn the jaw opposite ways, only reachable with weights far
//!    outside [0, 1]) is taken as the rotation [`crate::rotation::from_6d`] makes of it, then
//!    held as in 2, and written with orthonormal 6D columns.
//!
//! An actor without `train.jaw` (built by other tools) keeps the jaw at rest.

use crate::error::{Argument, Bound, FormatError};
use crate::format::{SinewFile, out_of_range};
use crate::linalg::{Mat3, Vec3};
use crate::rotation::{from_6d, to_6d, try_from_6d, try_rigid_from_9d};
use crate::tensor::F32s;

/// The section holding every training shape's learned jaw transform, `[M, 9]`.
pub const SECTION: &str = "train.jaw";

/// The nine values of the identity jaw transform: the 6D identity rotation, no translation.
pub const IDENTITY: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];

/// Every training shape's learned jaw transform, validated, with the range they span.
#[derive(Clone, Copy, Debug)]
pub struct LearnedJaws<'a> {
    jaws: F32s<'a>,
    shapes: usize,
    /// The least rotation vector (per axis), then translation.
    low: [f32; 6],
    /// The greatest.
    high: [f32; 6],
}

impl<'a> LearnedJaws<'a> {
    /// Reads [`SECTION`] of an actor with `shapes` correctives: `None` when the file has no such
    /// section.
    ///
    /// # Errors
    /// [`FormatError`] if the section is not `[shapes, 9]` f32, or a transform is not one a
    /// caller could pose with (as [`Self::new`]).
    pub fn from_file(file: &SinewFile<'a>, shapes: usize) -> Result<Option<Self>, FormatError> {
        if file.section(SECTION).is_none() {
            return Ok(None);
        }
        let rows = u32::try_from(shapes).unwrap_or(u32::MAX);
        let jaws = file.f32_tensor(SECTION, &[rows, 9])?;
        Self::new(jaws).map(Some)
    }

    /// Learned transforms from `jaws`, `[M, 9]` (any length that is a multiple of 9).
    ///
    /// # Errors
    /// [`FormatError::ValueOutOfRange`] naming [`SECTION`] and the first refused value of a
    /// transform the core would refuse from a caller ([`try_rigid_from_9d`]): [`Bound::Rotation`]
    /// for a rotation's, [`Bound::Coordinate`] for a translation's;
    /// [`FormatError::IncompatibleShapes`] if the length is not a multiple of 9.
    pub fn new(jaws: F32s<'a>) -> Result<Self, FormatError> {
        if !jaws.len().is_multiple_of(9) {
            return Err(FormatError::incompatible_shapes(SECTION));
        }
        let shapes = jaws.len() / 9;
        let (mut low, mut high) = ([0.0f32; 6], [0.0f32; 6]);
        for s in 0..shapes {
            let jaw = row(jaws, s);
            if let Err(e) = try_rigid_from_9d(&jaw, Argument::Jaw) {
                let bound = if e.index < 6 {
                    Bound::Rotation
                } else {
                    Bound::Coordinate
                };
                return Err(out_of_range(SECTION, 9 * s + e.index, bound));
            }
            for (i, v) in range_values(&jaw).into_iter().enumerate() {
                if let (Some(lo), Some(hi)) = (low.get_mut(i), high.get_mut(i)) {
                    *lo = lo.min(v);
                    *hi = hi.max(v);
                }
            }
        }
        Ok(Self {
            jaws,
            shapes,
            low,
            high,
        })
    }

    /// The number of shapes M.
    pub const fn shape_count(&self) -> usize {
        self.shapes
    }

    /// Shape `s`'s learned transform (the identity past the end).
    pub fn shape(&self, s: usize) -> [f32; 9] {
        if s < self.shapes {
            row(self.jaws, s)
        } else {
            IDENTITY
        }
    }

    /// The least of each of the six values that the rule holds (the rotation vector's x, y, z in
    /// radians, then the translation's x, y, z) over the identity and the shapes' learned
    /// transforms.
    pub const fn low(&self) -> [f32; 6] {
        self.low
    }

    /// The greatest of each of the six values, as [`Self::low`].
    pub const fn high(&self) -> [f32; 6] {
        self.high
    }

    /// The jaw transform of coefficients `weights` (`[M]`; a missing coefficient counts as 0 and
    /// extra ones are ignored): the module's rule. The caller checks the weights (finite, within
    /// ±[`crate::layout::MAX_FACTOR`]); whatever they are, the result is a transform
    /// [`crate::aim::AimActor::pose_from_9d`] accepts.
    pub fn blend(&self, weights: &[f32]) -> [f32; 9] {
        let mut jaw = IDENTITY;
        for (s, &w) in weights.iter().enumerate().take(self.shapes) {
            let learned = row(self.jaws, s);
            for ((v, l), i) in jaw.iter_mut().zip(learned).zip(IDENTITY) {
                *v += w * (l - i);
            }
        }
        let [r0, r1, r2, r3, r4, r5, ..] = jaw;
        let rotation = [r0, r1, r2, r3, r4, r5];
        let accepted = try_from_6d(&rotation, Argument::Jaw).is_ok();
        let values = range_values(&jaw);
        let mut held = values;
        for ((v, lo), hi) in held.iter_mut().zip(self.low).zip(self.high) {
            // NaN (only from non-finite weights, which callers refuse) becomes the low end.
            *v = if *v >= lo { v.min(hi) } else { lo };
        }
        let [x, y, z, tx, ty, tz] = held;
        let rotation = if accepted && held[..3] == values[..3] {
            rotation
        } else {
            to_6d(&exp(Vec3::new(x, y, z)))
        };
        let [r0, r1, r2, r3, r4, r5] = rotation;
        [r0, r1, r2, r3, r4, r5, tx, ty, tz]
    }
}

/// The six values the rule holds within range: the rotation vector of `jaw`'s rotation (as the
/// core poses it, [`from_6d`]), then its translation.
fn range_values(jaw: &[f32; 9]) -> [f32; 6] {
    let [r0, r1, r2, r3, r4, r5, tx, ty, tz] = *jaw;
    let r = log(&from_6d(&[r0, r1, r2, r3, r4, r5]));
    [r.x, r.y, r.z, tx, ty, tz]
}

/// The rotation vector (axis × angle in radians, the angle in [0, π]) of the rotation `m`.
fn log(m: &Mat3) -> Vec3 {
    let [c0, c1, c2] = m.cols;
    // sin θ · axis from the skew part, cos θ from the trace.
    let v = Vec3::new(c1.z - c2.y, c2.x - c0.z, c0.y - c1.x).scale(0.5);
    let s = v.norm();
    let c = (c0.x + c1.y + c2.z - 1.0) * 0.5;
    let angle = libm::atan2f(s, c);
    if s > 1e-4 {
        return v.scale(angle / s);
    }
    if c > 0.0 {
        // θ below 1e-4: sin θ · axis is θ · axis to f32's precision.
        return v;
    }
    // θ near π: the axis from the diagonal (R + I = 2 a aᵀ there), its largest component
    // positive and the others signed by the symmetric part.
    let d = [c0.x, c1.y, c2.z].map(|r| libm::sqrtf(((r + 1.0) * 0.5).max(0.0)));
    let sym = [c0.y + c1.x, c0.z + c2.x, c1.z + c2.y];
    let sign = |x: f32| if x < 0.0 { -1.0 } else { 1.0 };
    let [dx, dy, dz] = d;
    let [sxy, sxz, syz] = sym;
    let axis = if dx >= dy && dx >= dz {
        Vec3::new(dx, sign(sxy) * dy, sign(sxz) * dz)
    } else if dy >= dz {
        Vec3::new(sign(sxy) * dx, dy, sign(syz) * dz)
    } else {
        Vec3::new(sign(sxz) * dx, sign(syz) * dy, dz)
    };
    axis.normalize().scale(angle)
}

/// The rotation of rotation vector `r` (Rodrigues' formula).
fn exp(r: Vec3) -> Mat3 {
    let angle = r.norm();
    if angle == 0.0 {
        return Mat3::identity();
    }
    let k = r.scale(1.0 / angle);
    let (s, c) = (libm::sinf(angle), libm::cosf(angle));
    let t = 1.0 - c;
    // Column j of R = c I + s [k]× + t k kᵀ.
    let col = |e: Vec3| e.scale(c) + k.cross(e).scale(s) + k.scale(t * k.dot(e));
    Mat3::from_cols(
        col(Vec3::new(1.0, 0.0, 0.0)),
        col(Vec3::new(0.0, 1.0, 0.0)),
        col(Vec3::new(0.0, 0.0, 1.0)),
    )
}

/// Row `s` of `[M, 9]` values.
fn row(jaws: F32s<'_>, s: usize) -> [f32; 9] {
    core::array::from_fn(|i| jaws.at(9 * s + i))
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use super::*;

    fn bytes(values: &[f32]) -> Vec<u8> {
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// A rotation by `angle` about x (the jaw opening), as 6D + translation `t`.
    fn about_x(angle: f32, t: [f32; 3]) -> [f32; 9] {
        let (s, c) = (libm::sinf(angle), libm::cosf(angle));
        [1.0, 0.0, 0.0, 0.0, c, s, t[0], t[1], t[2]]
    }

    /// A rotation by `angle` about y (the jaw sliding sideways).
    fn about_y(angle: f32) -> [f32; 9] {
        let (s, c) = (libm::sinf(angle), libm::cosf(angle));
        [c, 0.0, -s, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]
    }

    fn opening(jaw: &[f32; 9]) -> f32 {
        let m = crate::rotation::rigid_from_9d(jaw).rot;
        libm::atan2f(m.cols[1].z, m.cols[1].y)
    }

    #[test]
    fn one_shape_at_weight_one_is_its_learned_jaw_bit_for_bit() {
        let rows = [
            about_x(0.3, [0.0, -0.1, 0.2]),
            about_x(0.08, [0.0; 3]),
            about_y(0.05),
        ];
        let data = bytes(&rows.concat());
        let jaws = LearnedJaws::new(F32s::new(&data).unwrap()).unwrap();
        for (s, want) in rows.iter().enumerate() {
            let mut w = [0.0; 3];
            w[s] = 1.0;
            assert_eq!(jaws.blend(&w).map(f32::to_bits), want.map(f32::to_bits));
        }
        assert_eq!(jaws.blend(&[0.0; 3]), IDENTITY);
        // Half a rotation about one axis turns half way.
        let half = opening(&jaws.blend(&[0.5, 0.0, 0.0]));
        assert!((half - 0.15).abs() < 1e-6, "{half}");
    }

    #[test]
    fn combinations_stay_within_the_range_the_shapes_span() {
        let rows = [
            about_x(0.35, [0.0, -0.2, 0.1]),
            about_x(0.1, [0.0, 0.0, 0.05]),
            about_x(-0.02, [0.0; 3]),
            about_y(0.06),
        ];
        let data = bytes(&rows.concat());
        let jaws = LearnedJaws::new(F32s::new(&data).unwrap()).unwrap();
        let (lo, hi) = (jaws.low(), jaws.high());
        // Every combination on a grid of weights from −1 to 3: the rotation vector and the
        // translation within the span, so the opening between the least and the greatest learned.
        let steps = [-1.0, 0.0, 0.5, 1.0, 2.0, 3.0];
        for a in steps {
            for b in steps {
                for c in steps {
                    for d in steps {
                        let jaw = jaws.blend(&[a, b, c, d]);
                        let held = range_values(&jaw);
                        for i in 0..6 {
                            let slack = 1e-6;
                            assert!(
                                lo[i] - slack <= held[i] && held[i] <= hi[i] + slack,
                                "{i}: {held:?} outside {lo:?} .. {hi:?}"
                            );
                        }
                        let open = opening(&jaw);
                        assert!((-0.02 - 1e-6..=0.35 + 1e-6).contains(&open), "{open}");
                        assert!(try_rigid_from_9d(&jaw, Argument::Jaw).is_ok());
                    }
                }
            }
        }
        // Both openings at full weight open no further than the wider one.
        let both = opening(&jaws.blend(&[1.0, 1.0, 0.0, 0.0]));
        assert!((both - 0.35).abs() < 1e-6, "{both}");
    }

    #[test]
    fn log_and_exp_are_inverse_from_small_angles_to_a_half_turn() {
        for (axis, angle) in [
            (Vec3::new(1.0, 0.0, 0.0), 1e-6),
            (Vec3::new(1.0, 0.0, 0.0), 0.37),
            (Vec3::new(0.6, -0.8, 0.0), 1.9),
            (Vec3::new(0.0, 0.6, 0.8), 3.1),
            (Vec3::new(-0.48, 0.6, 0.64), core::f32::consts::PI),
        ] {
            let r = axis.normalize().scale(angle);
            let back = log(&exp(r));
            // At a half-turn r and −r are the same rotation.
            let err = (back - r).norm().min((back + r).norm());
            assert!(err < 2e-3 * angle.max(1e-3), "{r:?} came back as {back:?}");
        }
    }

    #[test]
    fn a_blend_the_core_would_refuse_becomes_a_rotation() {
        // Opposite half-turns: their blend's second column passes through zero.
        let rows = [about_x(3.0, [0.0; 3]), about_x(-3.0, [0.0; 3])];
        let data = bytes(&rows.concat());
        let jaws = LearnedJaws::new(F32s::new(&data).unwrap()).unwrap();
        let jaw = jaws.blend(&[0.5, 0.5]);
        assert!(try_rigid_from_9d(&jaw, Argument::Jaw).is_ok(), "{jaw:?}");
    }

    #[test]
    fn a_transform_no_caller_could_pose_with_is_refused_by_value() {
        let mut rows = [about_x(0.3, [0.0; 3]), about_x(0.1, [0.0; 3])];
        rows[1][3..6].copy_from_slice(&[0.0; 3]);
        let data = bytes(&rows.concat());
        let e = LearnedJaws::new(F32s::new(&data).unwrap()).unwrap_err();
        assert_eq!(e, out_of_range(SECTION, 12, Bound::Rotation));
        rows[1] = about_x(0.1, [0.0, 2e5, 0.0]);
        let data = bytes(&rows.concat());
        let e = LearnedJaws::new(F32s::new(&data).unwrap()).unwrap_err();
        assert_eq!(e, out_of_range(SECTION, 16, Bound::Coordinate));
        let data = bytes(&[1.0; 10]);
        assert!(LearnedJaws::new(F32s::new(&data).unwrap()).is_err());
    }
}
