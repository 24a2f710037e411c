//! From an actor (ICT-FaceKit or procedural) and bones aligned to its neutral to AIM's training
//! set: sparse bone constraints (Wu et al.), the forehead region of eq. 15, the symmetry plane of
//! eq. 14 and the jaw pivot.

use anyhow::{Result, ensure};

use super::{Anchor, Plane, TrainingSet};
use crate::constraints::{self, Bone, ConstraintParams};
use crate::ict::Actor;
use crate::mesh::Mesh;

/// Symmetric iBUG-68 landmark pairs (left, right) used to estimate the plane of symmetry.
const IBUG_PAIRS: [(usize, usize); 17] = [
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
    let (lo, hi) = bounds(positions);
    Plane {
        normal: [1.0, 0.0, 0.0],
        origin: [
            0.5 * (lo[0] + hi[0]),
            0.5 * (lo[1] + hi[1]),
            0.5 * (lo[2] + hi[2]),
        ],
    }
}

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

/// Wu et al.'s sparse constraints of every vertex of `neutral` against the bones.
pub fn anchors(neutral: &Mesh, skull: &Mesh, jaw: &Mesh, max_depth: f32) -> Vec<Option<Anchor>> {
    let normals = neutral.vertex_normals();
    let (skull_tri, jaw_tri) = (skull.triangles(), jaw.triangles());
    let found = constraints::compute(
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
                })
            })
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
) -> Result<TrainingSet> {
    ensure!(!actor.shapes.is_empty(), "the actor has no shapes");
    let neutral = &actor.template;
    let anchors = anchors(neutral, skull, jaw, max_depth);
    let mm_per_unit = match actor.units {
        "m" => 1000.0,
        "cm" => 10.0,
        "mm" => 1.0,
        other => anyhow::bail!("unknown length unit {other:?}"),
    };
    let set = TrainingSet {
        template: neutral.clone(),
        shapes: actor.shapes.clone(),
        names: actor.names.clone(),
        anchors,
        forehead: forehead(&neutral.positions, &actor.landmarks),
        symmetry: symmetry_plane(&neutral.positions, &actor.landmarks),
        jaw_pivot: pivot.unwrap_or_else(|| jaw_pivot(jaw)),
        units: actor.units.to_owned(),
        mm_per_unit,
        source: actor.source.clone(),
    };
    set.validate()?;
    Ok(set)
}
