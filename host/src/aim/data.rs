//! From an actor (ICT-FaceKit or procedural) and bones aligned to its neutral to AIM's training
//! set: sparse bone constraints (Wu et al.), the forehead region of eq. 15, the symmetry plane of
//! eq. 14 and the jaw pivot.

use super::TrainingSet;
use crate::anatomy::constraints::anchors;
use crate::geometry::align::RigidFit;
use crate::io::ict::Actor;
use crate::io::mesh::Mesh;

pub use crate::geometry::symmetry::symmetry_plane;

fn bounds(p: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for q in p {
        for i in 0..3 {
            lo[i] = lo[i].min(q[i]);
            hi[i] = hi[i].max(q[i]);
        }
    }
    (lo, hi)
}

/// The forehead region c* of eq. 15 (y is up): with landmarks, the vertices above the highest
/// eyebrow landmark (17–26) by 15% of the brow-to-chin height; without, the top 15% of the face.
pub fn forehead(positions: &[[f32; 3]], landmarks: &[Option<u32>]) -> Vec<u32> {
    let y = |i: u32| positions[i as usize][1];
    let brow = (17..=26)
        .filter_map(|l| landmarks.get(l).copied().flatten())
        .map(y)
        .fold(f32::NEG_INFINITY, f32::max);
    let chin = landmarks.get(8).copied().flatten().map(y);
    let threshold = match chin {
        Some(chin) if brow.is_finite() => brow + 0.15 * (brow - chin),
        _ => {
            let (lo, hi) = bounds(positions);
            hi[1] - 0.15 * (hi[1] - lo[1])
        }
    };
    (0..positions.len() as u32)
        .filter(|&i| y(i) > threshold)
        .collect()
}

/// The jaw's hinge: the mean of the jaw-bone vertices in the top tenth of its height and the back
/// half of its depth (z is forward), near the condyles.
pub fn jaw_pivot(jaw: &Mesh) -> [f32; 3] {
    let (lo, hi) = bounds(&jaw.positions);
    let mid_z = 0.5 * (lo[2] + hi[2]);
    let top = hi[1] - 0.1 * (hi[1] - lo[1]);
    let sel: Vec<&[f32; 3]> = jaw
        .positions
        .iter()
        .filter(|p| p[1] >= top && p[2] <= mid_z)
        .collect();
    let sel: Vec<&[f32; 3]> = if sel.is_empty() {
        jaw.positions.iter().collect()
    } else {
        sel
    };
    let n = sel.len().max(1) as f32;
    [0, 1, 2].map(|i| sel.iter().map(|p| p[i]).sum::<f32>() / n)
}

/// A rigid transform `x ↦ R x + t0` in AIM's 9 jaw parameters about `pivot` (eq. 10's
/// `R (x − p) + p + t`, so `t = t0 + R p − p`): `[first column of R, second column of R, t]`, the
/// layout `model::rotate_6d` and `sinew_core::rotation::rigid_from_9d` read.
pub fn rigid_to_pivot_9d(fit: &RigidFit, pivot: [f32; 3]) -> [f32; 9] {
    let r = fit.rotation;
    let p = pivot.map(f64::from);
    let t: [f64; 3] = std::array::from_fn(|i| {
        fit.translation[i] + (0..3).map(|j| r[i][j] * p[j]).sum::<f64>() - p[i]
    });
    [
        r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], t[0], t[1], t[2],
    ]
    .map(|v| v as f32)
}

/// The jaw transform of each expression (shapes 1..N) estimated from the data: the
/// least-squares rigid transform (Horn, [`crate::geometry::align::fit_rigid`]) taking the neutral's
/// jaw-constrained skin vertices ([`TrainingSet::jaw_constrained`]) to their positions in that
/// shape, in AIM's 9 parameters about the set's jaw pivot. `None` for every shape when fewer
/// than three vertices are jaw-constrained or they are (nearly) collinear, or for a shape whose
/// positions there are not finite.
pub fn jaw_transforms(set: &TrainingSet) -> Vec<Option<[f32; 9]>> {
    let jaw = set.jaw_constrained();
    let Some(neutral) = set.shapes.first() else {
        return Vec::new();
    };
    let at = |shape: &[[f32; 3]]| -> Option<Vec<[f32; 3]>> {
        jaw.iter()
            .map(|&v| shape.get(v as usize).copied())
            .collect()
    };
    let from = at(neutral);
    set.shapes[1..]
        .iter()
        .map(|shape| {
            let fit = crate::geometry::align::fit_rigid(from.as_deref()?, &at(shape)?)?;
            Some(rigid_to_pivot_9d(&fit, set.jaw_pivot))
        })
        .collect()
}

/// Builds the training set of `actor` with `skull` and `jaw` aligned to its neutral.
pub fn training_set(
    actor: &Actor,
    skull: &Mesh,
    jaw: &Mesh,
    pivot: Option<[f32; 3]>,
    max_depth: f32,
) -> Result<TrainingSet, super::InvalidTrainingSet> {
    if actor.shapes.is_empty() {
        return Err(super::InvalidTrainingSet::NoShapes);
    }
    let neutral = &actor.template;
    let anchors = anchors(neutral, skull, jaw, max_depth);
    let mm_per_unit = actor.units.mm() as f32;
    let set = TrainingSet {
        template: neutral.clone(),
        shapes: actor.shapes.clone(),
        names: actor.names.clone(),
        anchors,
        forehead: forehead(&neutral.positions, &actor.landmarks),
        symmetry: symmetry_plane(&neutral.positions, &actor.landmarks),
        jaw_pivot: pivot.unwrap_or_else(|| jaw_pivot(jaw)),
        units: actor.units,
        mm_per_unit,
        source: actor.source.clone(),
        provenance: Vec::new(),
    };
    set.validate()?;
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::training::nn::{tensor, to_vec};
    use sinew_core::linalg::Vec3;

    #[test]
    fn broken_sets_are_refused_by_rule() {
        let (actor, bones) = crate::aim::procedural::actor(8);
        let mut empty = actor.clone();
        empty.shapes.clear();
        let e = training_set(&empty, &bones.skull, &bones.jaw, None, 10.0).unwrap_err();
        assert_eq!(e, crate::aim::InvalidTrainingSet::NoShapes);
        let set = training_set(&actor, &bones.skull, &bones.jaw, None, 10.0).unwrap();
        let mut short = set.clone();
        short.names.pop();
        assert!(matches!(
            short.validate(),
            Err(crate::aim::InvalidTrainingSet::NameCount { .. })
        ));
        let mut far = set.clone();
        far.forehead.push(set.vertices() as u32);
        assert_eq!(
            far.validate(),
            Err(crate::aim::InvalidTrainingSet::ForeheadIndex)
        );
    }

    /// Rotation by `deg` degrees about the unit `axis` (Rodrigues), row-major.
    fn rotation(axis: [f64; 3], deg: f64) -> [[f64; 3]; 3] {
        let n = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
        let [x, y, z] = axis.map(|v| v / n);
        let (s, c) = deg.to_radians().sin_cos();
        let t = 1.0 - c;
        [
            [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
            [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
            [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
        ]
    }

    /// The angle (degrees) of the rotation taking the 6D rotation `r` to the matrix `m`.
    fn angle_between(r: &[f32; 9], m: [[f64; 3]; 3]) -> f64 {
        let got = sinew_core::rotation::from_6d(&[r[0], r[1], r[2], r[3], r[4], r[5]]);
        // tr(Gᵀ M) = 1 + 2 cos θ.
        let tr: f64 = (0..3)
            .map(|j| {
                let col = got.cols[j].to_array();
                (0..3).map(|i| f64::from(col[i]) * m[i][j]).sum::<f64>()
            })
            .sum();
        ((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
    }

    #[test]
    fn rigid_fit_about_a_pivot_round_trips_through_9d() {
        let r = rotation([0.3, -1.0, 0.4], 23.0);
        let pivot = [0.5f32, 2.0, -1.5];
        let t = [0.2, -0.7, 1.1];
        let moved = |p: [f32; 3]| -> [f32; 3] {
            let q = [0, 1, 2].map(|i| f64::from(p[i] - pivot[i]));
            std::array::from_fn(|i| {
                ((0..3).map(|j| r[i][j] * q[j]).sum::<f64>() + f64::from(pivot[i]) + t[i]) as f32
            })
        };
        // Pseudo-random points in a 6 cm box (a golden-ratio sequence: no RNG needed).
        let x: Vec<[f32; 3]> = (0..40)
            .map(|i| {
                let f = |k: f64| ((i as f64 * k).fract() - 0.5) as f32 * 6.0;
                [f(0.618_034), f(0.754_878), f(0.569_840)]
            })
            .collect();
        let y: Vec<[f32; 3]> = x.iter().map(|&p| moved(p)).collect();
        let fit = crate::geometry::align::fit_rigid(&x, &y).expect("well-posed");
        let p9 = rigid_to_pivot_9d(&fit, pivot);
        // The 9 parameters are [first column, second column, t] of the pivot form.
        for i in 0..3 {
            assert!((f64::from(p9[i]) - r[i][0]).abs() < 1e-5, "{p9:?}");
            assert!((f64::from(p9[3 + i]) - r[i][1]).abs() < 1e-5, "{p9:?}");
            assert!((f64::from(p9[6 + i]) - t[i]).abs() < 1e-5, "{p9:?}");
        }
        // The core's rigid_from_9d about the pivot reproduces the motion...
        let rigid = sinew_core::rotation::rigid_from_9d(&p9);
        let pv = Vec3::from_array(pivot);
        for (&p, &q) in x.iter().zip(&y) {
            let got = (rigid.rot.mul_vec(Vec3::from_array(p) - pv) + pv + rigid.trans).to_array();
            for c in 0..3 {
                assert!((got[c] - q[c]).abs() < 1e-4, "{got:?} vs {q:?}");
            }
        }
        // ... and so does the training model's rotate_6d (eq. 10 with k = 1).
        let device = crate::training::backend::Backend::Flex.device(1).unwrap();
        let n = x.len();
        let r6 = tensor(
            (0..n).flat_map(|_| p9[..6].to_vec()).collect(),
            [n, 6],
            &device,
        );
        let rel = tensor(
            x.iter()
                .flat_map(|p| [0, 1, 2].map(|c| p[c] - pivot[c]))
                .collect(),
            [n, 3],
            &device,
        );
        let rotated = to_vec(super::super::model::rotate_6d(r6, rel));
        for (got, q) in rotated.chunks_exact(3).zip(&y) {
            for c in 0..3 {
                let v = got[c] + pivot[c] + p9[6 + c];
                assert!((v - q[c]).abs() < 1e-4, "{got:?} vs {q:?}");
            }
        }
    }

    #[test]
    fn rigid_fit_refuses_too_few_or_collinear_points() {
        let line: Vec<[f32; 3]> = (0..10).map(|i| [i as f32, 2.0 * i as f32, 0.5]).collect();
        assert!(crate::geometry::align::fit_rigid(&line, &line).is_none());
        let three = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(crate::geometry::align::fit_rigid(&three[..2], &three[..2]).is_none());
        assert!(crate::geometry::align::fit_rigid(&three, &three[..2]).is_none());
        let mut bad = three;
        bad[1][0] = f32::NAN;
        assert!(crate::geometry::align::fit_rigid(&three, &bad).is_none());
        let fit =
            crate::geometry::align::fit_rigid(&three, &three).expect("three points in a plane");
        assert_eq!(
            rigid_to_pivot_9d(&fit, [1.0, 2.0, 3.0]),
            super::super::model::IDENTITY_9D
        );
    }

    #[test]
    fn jaw_init_recovers_the_procedural_jaw_open() {
        let (actor, bones) =
            crate::aim::procedural::actor(crate::aim::procedural::DEFAULT_RESOLUTION);
        let set =
            training_set(&actor, &bones.skull, &bones.jaw, Some(bones.jaw_pivot), 2.5).unwrap();
        let jaw = set.jaw_constrained();
        assert!(jaw.len() > 100, "{} jaw-constrained vertices", jaw.len());
        let init = jaw_transforms(&set);
        assert_eq!(init.len(), set.shapes.len() - 1);
        let open = set.names.iter().position(|n| n == "jawOpen").unwrap();
        let t = init[open - 1].expect("jawOpen has jaw-constrained vertices");
        // procedural.rs: jawOpen turns the jaw by 15° about +x through the pivot, no shift.
        let truth = rotation([1.0, 0.0, 0.0], 15.0);
        let err = angle_between(&t, truth);
        let tnorm = t[6..].iter().map(|v| v * v).sum::<f32>().sqrt();
        eprintln!(
            "jawOpen: rotation off by {err:.2}°, translation {:?} cm",
            &t[6..]
        );
        assert!(err < 1.5, "jawOpen rotation off by {err}°");
        assert!(tnorm < 0.3, "jawOpen translation {:?}", &t[6..]);
        // Shapes that do not move the jaw start near the identity.
        let brow = set.names.iter().position(|n| n == "browRaise").unwrap();
        let b = init[brow - 1].expect("browRaise has jaw-constrained vertices");
        assert!(
            angle_between(&b, rotation([1.0, 0.0, 0.0], 0.0)) < 0.5,
            "{b:?}"
        );

        // Without jaw constraints there is nothing to fit: every shape falls back.
        let mut bare = set.clone();
        for a in bare.anchors.iter_mut().flatten() {
            a.on = crate::anatomy::constraints::Bone::Skull;
        }
        assert!(jaw_transforms(&bare).iter().all(Option::is_none));
    }
}
