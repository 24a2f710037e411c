//! The built-in demo actor: a face-like surface, its expressions and its bones, generated in code
//! so that every command has something to work on without any data files.
//!
//! The face is the front of a deformed ellipsoid (cm; y up, z towards the viewer, x to the
//! actor's left, symmetric about x = 0) with a nose, brow ridge, eye sockets, lips, cheekbones and
//! a chin added as smooth bumps. The jaw is a hinge: a smooth skinning weight field k (1 on the
//! chin and lower lip, 0 above the mouth) blends a rigid rotation about a pivot near the ears,
//! which is exactly the linear blend skinning model AIM learns (AIM eq. 10:
//! s = LBS(s₀, T, k)). Everything is deterministic: no random numbers are drawn.

use std::f64::consts::PI;

use crate::io::ict::Actor;
use crate::io::mesh::Mesh;

/// The resolution [`actor`] is meant to be called with: 48 rows of 65 vertices (3,120).
pub const DEFAULT_RESOLUTION: usize = 48;

/// The smallest resolution [`actor`] accepts; smaller values are raised to it.
pub const MIN_RESOLUTION: usize = 8;

/// Names of the procedural actor's shapes, neutral first.
pub const SHAPE_NAMES: [&str; 7] = [
    "neutral",
    "jawOpen",
    "jawLeft",
    "smile_L",
    "smile_R",
    "browRaise",
    "puff_L",
];

/// Semi-axes of the head ellipsoid (cm): half width, half height, depth of the face.
const AXES: [f64; 3] = [9.0, 12.5, 10.0];
/// The hinge pivot of the jaw (cm), between the ears and slightly behind the face's centre.
const JAW_PIVOT: [f64; 3] = [0.0, 0.5, -0.5];
/// Jaw opening angle of `jawOpen` (degrees, about +x: the chin moves down and back).
const JAW_OPEN_DEG: f64 = 15.0;
/// Jaw yaw of `jawLeft` (degrees, about +y: the chin moves to the actor's left) and its shift.
const JAW_LEFT_DEG: f64 = 6.0;
const JAW_LEFT_SHIFT: [f64; 3] = [0.35, 0.0, 0.0];

/// The demo actor's bones, as meshes whose vertices each sit a tissue thickness behind one skin
/// vertex of the neutral face: bone = skin − thickness · tissue normal.
#[derive(Clone, Debug)]
pub struct Bones {
    /// The upper skull (under the skin where the jaw weight k < 0.5).
    pub skull: Mesh,
    /// The mandible (under the skin where k ≥ 0.5).
    pub jaw: Mesh,
    /// The point the jaw rotates about (cm).
    pub jaw_pivot: [f32; 3],
    /// For each skull vertex, the skin (template) vertex it lies under.
    pub skull_to_skin: Vec<u32>,
    /// For each jaw vertex, the skin (template) vertex it lies under.
    pub jaw_to_skin: Vec<u32>,
    /// The jaw skinning weight k of each skin vertex (ground truth for skinning fits).
    pub jaw_weights: Vec<f32>,
    /// The soft-tissue thickness (cm) at each skin vertex.
    pub thickness: Vec<f32>,
    /// At each skin vertex, the unit outward direction from its bone vertex to it: the normal of
    /// the smooth head shape under the facial relief, within 45° of the skin normal.
    pub tissue_normals: Vec<[f32; 3]>,
}

/// Cubic smoothstep from 0 at `e0` to 1 at `e1`.
fn smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// An axis-aligned Gaussian bump of height 1 centred on (cx, cy) with widths (sx, sy).
fn bump(x: f64, y: f64, cx: f64, cy: f64, sx: f64, sy: f64) -> f64 {
    let (u, v) = ((x - cx) / sx, (y - cy) / sy);
    (-0.5 * (u * u + v * v)).exp()
}

/// The nose tip and nostril wings: cartilage and fat, so the thickness field absorbs them and
/// the skull carries no nose tip.
fn nose_soft(x: f64, y: f64) -> f64 {
    2.4 * bump(x, y, 0.0, 0.0, 1.0, 1.6) + 0.6 * bump(x.abs(), y, 1.3, -0.6, 0.7, 0.6)
}

/// The lips; half of their relief is soft tissue, the rest stands for the teeth and alveolar
/// bone behind them.
fn lips(x: f64, y: f64) -> f64 {
    0.7 * bump(x, y, 0.0, -2.6, 2.2, 0.7) + 0.6 * bump(x, y, 0.0, -4.3, 2.0, 0.6)
}

/// The forward relief of the face at (x, y), in cm; symmetric in x by construction (paired
/// features use |x|).
fn relief(x: f64, y: f64) -> f64 {
    let ax = x.abs();
    nose_soft(x, y) + lips(x, y) + 0.9 * bump(x, y, 0.0, 2.2, 0.8, 1.5) // nose bridge
        - 0.9 * bump(ax, y, 3.3, 3.2, 1.4, 0.9) // eye sockets
        + 0.4 * bump(ax, y, 3.3, 4.8, 2.2, 0.6) // brow ridge
        + 0.5 * bump(ax, y, 4.8, 1.0, 1.6, 1.4) // cheekbones
        + 1.6 * bump(x, y, 0.0, -8.2, 2.4, 1.6) // chin
}

/// The jaw skinning weight k: 1 below the mouth, 0 above, with a smooth band whose centre rises
/// towards the ears the way the mandible's ramus does.
fn jaw_weight(x: f64, y: f64) -> f64 {
    let boundary = -3.5 + 3.0 * (x / AXES[0]).powi(2);
    1.0 - smoothstep(boundary - 0.9, boundary + 0.9, y)
}

/// Soft-tissue thickness (cm): about 0.5 on the forehead and 1.2 on the cheeks and chin, plus
/// the soft part of the nose and lip relief (so about 1.5 cm at the lips). `front` fades the
/// relief terms exactly as the skin's relief fades.
fn thickness(x: f64, y: f64, front: f64) -> f64 {
    0.5 + 0.7 * (1.0 - smoothstep(-1.0, 3.5, y)) + front * (nose_soft(x, y) + 0.5 * lips(x, y))
}

/// Rotation by `deg` degrees about coordinate axis `axis` (0 = x, 1 = y), applied to `p` around
/// `c`, then shifted by `t`.
fn rigid(p: [f64; 3], c: [f64; 3], axis: usize, deg: f64, t: [f64; 3]) -> [f64; 3] {
    let (s, co) = (deg * PI / 180.0).sin_cos();
    let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
    let q = if axis == 0 {
        [r[0], co * r[1] - s * r[2], s * r[1] + co * r[2]]
    } else {
        [co * r[0] + s * r[2], r[1], -s * r[0] + co * r[2]]
    };
    [q[0] + c[0] + t[0], q[1] + c[1] + t[1], q[2] + c[2] + t[2]]
}

/// Linear blend of `p` towards `target` by `k` (two-bone LBS, AIM eq. 10).
fn blend(p: [f64; 3], target: [f64; 3], k: f64) -> [f64; 3] {
    [
        p[0] + k * (target[0] - p[0]),
        p[1] + k * (target[1] - p[1]),
        p[2] + k * (target[2] - p[2]),
    ]
}

fn to_f32(p: [f64; 3]) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, p[2] as f32]
}

/// Designed (x, y) positions (cm) of the 68 iBUG landmarks on the demo face, in iBUG order
/// (subject's right first, at negative x); each is snapped to the nearest front vertex.
fn landmark_targets() -> Vec<[f64; 2]> {
    let mut t = Vec::with_capacity(68);
    // 0-16: jawline from the right ear over the chin to the left ear.
    for i in 0..17 {
        let a = PI * i as f64 / 16.0;
        t.push([-7.6 * a.cos(), 3.7 - 11.5 * a.sin()]);
    }
    // 17-21 right brow (outer to inner), 22-26 left brow (inner to outer).
    let brow = [
        [-7.0, 4.9],
        [-5.8, 5.4],
        [-4.4, 5.6],
        [-3.0, 5.5],
        [-1.3, 5.2],
    ];
    t.extend(brow);
    t.extend(brow.iter().rev().map(|p| [-p[0], p[1]]));
    // 27-30 nose bridge down to the tip, 31-35 nostrils right to left.
    t.extend([[0.0, 3.4], [0.0, 2.4], [0.0, 1.4], [0.0, 0.0]]);
    t.extend([
        [-1.5, -1.0],
        [-0.8, -1.1],
        [0.0, -1.2],
        [0.8, -1.1],
        [1.5, -1.0],
    ]);
    // 36-41 right eye from the outer corner, clockwise in the image; 42-47 the left eye.
    t.extend([
        [-4.5, 3.3],
        [-3.7, 3.75],
        [-2.8, 3.75],
        [-2.0, 3.3],
        [-2.8, 2.95],
        [-3.7, 2.95],
    ]);
    t.extend([
        [2.0, 3.3],
        [2.8, 3.75],
        [3.7, 3.75],
        [4.5, 3.3],
        [3.7, 2.95],
        [2.8, 2.95],
    ]);
    // 48-59 outer lips from the right corner over the upper lip; 60-67 inner lips.
    t.extend([
        [-2.5, -3.5],
        [-1.7, -2.9],
        [-0.6, -2.6],
        [0.0, -2.7],
        [0.6, -2.6],
        [1.7, -2.9],
        [2.5, -3.5],
        [1.7, -4.2],
        [0.6, -4.5],
        [0.0, -4.5],
        [-0.6, -4.5],
        [-1.7, -4.2],
    ]);
    t.extend([
        [-2.2, -3.5],
        [-0.8, -3.3],
        [0.0, -3.3],
        [0.8, -3.3],
        [2.2, -3.5],
        [0.8, -3.7],
        [0.0, -3.7],
        [-0.8, -3.7],
    ]);
    t
}

/// The built-in demo actor and its bones.
///
/// `resolution` is the number of vertex rows (at least [`MIN_RESOLUTION`]); each row has
/// `4/3 · resolution` vertices, rounded to an odd number so a column lies on x = 0. The template
/// is a quad grid with per-vertex texture coordinates; the shapes are [`SHAPE_NAMES`].
pub fn actor(resolution: usize) -> (Actor, Bones) {
    let rows = resolution.max(MIN_RESOLUTION);
    let cols = (rows * 4 / 3) | 1;
    let (phi_lo, phi_hi) = (-60.0 * PI / 180.0, 75.0 * PI / 180.0);
    let theta_max = 100.0 * PI / 180.0;
    let half = (cols - 1) as i64;

    let mut neutral = Vec::with_capacity(rows * cols);
    // The smooth head under the relief: its normals carry the tissue thickness (see Bones).
    let mut base = Vec::with_capacity(rows * cols);
    let mut uvs = Vec::with_capacity(rows * cols);
    let mut front = Vec::with_capacity(rows * cols);
    for i in 0..rows {
        let phi = phi_lo + (phi_hi - phi_lo) * i as f64 / (rows - 1) as f64;
        for j in 0..cols {
            // An odd integer numerator makes column j and cols-1-j exact mirrors.
            let theta = theta_max * (2 * j as i64 - half) as f64 / half as f64;
            let y = AXES[1] * phi.sin();
            // The lower face narrows towards the chin.
            let taper = 1.0 - 0.18 * (1.0 - smoothstep(-9.0, 0.0, y));
            let x = AXES[0] * phi.cos() * theta.sin() * taper;
            // Features only on the front, fading out before the sides and the cut edge.
            let f = smoothstep(-0.2, 0.6, theta.cos());
            let z = AXES[2] * phi.cos() * theta.cos();
            base.push(to_f32([x, y, z]));
            neutral.push([x, y, z + f * relief(x, y)]);
            uvs.push([j as f32 / (cols - 1) as f32, i as f32 / (rows - 1) as f32]);
            front.push(f);
        }
    }
    let mut polygons = Vec::with_capacity((rows - 1) * (cols - 1));
    for i in 0..rows - 1 {
        for j in 0..cols - 1 {
            let v = |i: usize, j: usize| (i * cols + j) as u32;
            // Right, up, left: counter-clockwise seen from the front, so normals point out.
            polygons.push(vec![v(i, j), v(i, j + 1), v(i + 1, j + 1), v(i + 1, j)]);
        }
    }
    let template = Mesh {
        positions: neutral.iter().map(|&p| to_f32(p)).collect(),
        polygons,
        uvs,
        polygon_uvs: Vec::new(),
    };
    let normals = template.vertex_normals();
    let k: Vec<f64> = neutral.iter().map(|p| jaw_weight(p[0], p[1])).collect();

    let shape = |f: &dyn Fn(usize, [f64; 3]) -> [f64; 3]| -> Vec<[f32; 3]> {
        neutral
            .iter()
            .enumerate()
            .map(|(v, &p)| to_f32(f(v, p)))
            .collect()
    };
    let smile = |v: usize, p: [f64; 3], side: f64| {
        let g = front[v] * bump(p[0], p[1], side * 2.5, -3.5, 1.3, 1.1);
        [p[0] + side * 0.45 * g, p[1] + 0.7 * g, p[2] - 0.35 * g]
    };
    let shapes = vec![
        template.positions.clone(),
        shape(&|v, p| blend(p, rigid(p, JAW_PIVOT, 0, JAW_OPEN_DEG, [0.0; 3]), k[v])),
        shape(&|v, p| {
            blend(
                p,
                rigid(p, JAW_PIVOT, 1, JAW_LEFT_DEG, JAW_LEFT_SHIFT),
                k[v],
            )
        }),
        shape(&|v, p| smile(v, p, 1.0)),
        shape(&|v, p| smile(v, p, -1.0)),
        shape(&|v, p| {
            let g = front[v] * smoothstep(3.6, 5.5, p[1]) * (1.0 - smoothstep(8.5, 11.5, p[1]));
            [p[0], p[1] + 0.8 * g, p[2] + 0.1 * g]
        }),
        shape(&|v, p| {
            let g = 0.9 * front[v] * bump(p[0], p[1], 4.2, -3.0, 1.6, 1.6);
            let n = normals[v].map(f64::from);
            [p[0] + g * n[0], p[1] + g * n[1], p[2] + g * n[2]]
        }),
    ];

    // Landmarks: nearest front vertex in the image plane to each designed position.
    let landmarks = landmark_targets()
        .iter()
        .map(|t| {
            neutral
                .iter()
                .enumerate()
                .filter(|(v, p)| front[*v] > 0.5 && p[2] > 0.0)
                .min_by(|(_, a), (_, b)| {
                    let d = |p: &[f64; 3]| (p[0] - t[0]).powi(2) + (p[1] - t[1]).powi(2);
                    d(a).total_cmp(&d(b))
                })
                .map(|(v, _)| v as u32)
        })
        .collect();

    // Bones: the skin pushed inwards by the tissue thickness, split by k. The push follows the
    // normals of the smooth head under the relief rather than the skin's own normals: a nose tip
    // or lip is curved more tightly (radius ~0.5 cm) than the tissue is thick, so an offset along
    // the skin normals would fold over itself there, while the smooth head's radii (> 5 cm) keep
    // the offset surface clean and the bony relief (brows, cheekbones, chin) still shows on it.
    let tissue_normals = template.with_positions(base).vertex_normals();
    let thick: Vec<f64> = neutral
        .iter()
        .zip(&front)
        .map(|(p, &f)| thickness(p[0], p[1], f))
        .collect();
    let inner = template.with_positions(
        neutral
            .iter()
            .enumerate()
            .map(|(v, p)| {
                let n = tissue_normals[v].map(f64::from);
                to_f32([
                    p[0] - thick[v] * n[0],
                    p[1] - thick[v] * n[1],
                    p[2] - thick[v] * n[2],
                ])
            })
            .collect(),
    );
    let (skull, skull_to_skin) = inner.submesh(|v| k[v as usize] < 0.5);
    let (jaw, jaw_to_skin) = inner.submesh(|v| k[v as usize] >= 0.5);
    let bones = Bones {
        skull,
        jaw,
        jaw_pivot: to_f32(JAW_PIVOT),
        skull_to_skin,
        jaw_to_skin,
        jaw_weights: k.iter().map(|&k| k as f32).collect(),
        thickness: thick.iter().map(|&t| t as f32).collect(),
        tissue_normals,
    };
    let actor = Actor {
        template,
        shapes,
        names: SHAPE_NAMES.iter().map(|s| (*s).to_owned()).collect(),
        landmarks,
        units: crate::io::units::Unit::Centimetre,
        source: format!(
            "sinew built-in procedural demo actor (no external data), resolution {rows}x{cols}"
        ),
    };
    (actor, bones)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    /// The vertex nearest to `p`.
    fn nearest(m: &[[f32; 3]], p: [f32; 3]) -> usize {
        (0..m.len())
            .min_by(|&a, &b| dist(m[a], p).total_cmp(&dist(m[b], p)))
            .unwrap()
    }

    #[test]
    fn default_actor_shapes_and_size() {
        let (actor, bones) = actor(DEFAULT_RESOLUTION);
        let n = actor.template.positions.len();
        assert_eq!(n, 48 * 65);
        actor.template.validate().unwrap();
        assert_eq!(actor.names, SHAPE_NAMES);
        assert_eq!(actor.shapes.len(), 7);
        assert!(actor.shapes.iter().all(|s| s.len() == n));
        assert_eq!(actor.shapes[0], actor.template.positions);
        assert_eq!(actor.units, crate::io::units::Unit::Centimetre);
        // Every non-neutral shape actually moves something.
        for s in &actor.shapes[1..] {
            assert!(
                s.iter()
                    .zip(&actor.shapes[0])
                    .any(|(a, b)| dist(*a, *b) > 0.3)
            );
        }

        // About 18 cm wide, face towards +z, normals outwards at the nose tip.
        let (lo, hi) = actor.template.bounds();
        assert!((hi[0] - lo[0] - 18.0).abs() < 0.5, "{lo:?} {hi:?}");
        assert!(hi[1] > 11.0 && lo[1] < -10.0);
        let tip = actor.landmarks[30].unwrap() as usize;
        let np = actor.template.positions[tip];
        assert!(np[2] > 11.5 && np[0] == 0.0, "{np:?}");
        assert!(actor.template.vertex_normals()[tip][2] > 0.9);
        assert_eq!(actor.landmarks.len(), 68);
        assert!(actor.landmarks.iter().all(Option::is_some));
        // The chin landmark is the lowest of the 68.
        let y = |l: usize| actor.template.positions[actor.landmarks[l].unwrap() as usize][1];
        assert!((0..68).all(|l| y(8) <= y(l)));

        // jawOpen: the chin moves by centimetres, the forehead not at all.
        let chin = nearest(&actor.template.positions, [0.0, -9.0, 11.0]);
        let brow = nearest(&actor.template.positions, [0.0, 8.0, 8.0]);
        let jaw_move = |v: usize| dist(actor.shapes[1][v], actor.shapes[0][v]);
        assert!(jaw_move(chin) > 3.0, "{}", jaw_move(chin));
        assert!(jaw_move(brow) < 1e-3, "{}", jaw_move(brow));
        assert!(actor.shapes[1][chin][1] < actor.shapes[0][chin][1] - 2.0);
        // jawLeft takes the chin to the actor's left (+x).
        assert!(actor.shapes[2][chin][0] > 0.8);
        // smile_L acts on the actor's left corner (+x), smile_R on the right.
        let left = nearest(&actor.template.positions, [2.5, -3.5, 10.0]);
        let right = nearest(&actor.template.positions, [-2.5, -3.5, 10.0]);
        let moved = |s: usize, v: usize| dist(actor.shapes[s][v], actor.shapes[0][v]);
        assert!(moved(3, left) > 0.5 && moved(3, right) < 0.01);
        assert!(moved(4, right) > 0.5 && moved(4, left) < 0.01);
        // browRaise raises the forehead and leaves the chin.
        assert!(actor.shapes[5][brow][1] > actor.shapes[0][brow][1] + 0.5);
        assert_eq!(actor.shapes[5][chin], actor.shapes[0][chin]);

        // The bones split the skin in two by k and cover most of it.
        assert_eq!(bones.jaw_weights.len(), n);
        assert!(bones.jaw_weights[chin] > 0.99 && bones.jaw_weights[brow] < 0.01);
        assert!(bones.skull_to_skin.contains(&(brow as u32)));
        assert!(bones.jaw_to_skin.contains(&(chin as u32)));
        let covered = bones.skull.positions.len() + bones.jaw.positions.len();
        assert!(covered > n * 9 / 10 && covered <= n, "{covered} of {n}");
    }

    #[test]
    fn bones_lie_behind_the_skin_by_the_thickness() {
        let (actor, bones) = actor(24);
        let skin = &actor.template.positions;
        let normals = actor.template.vertex_normals();
        let tn = &bones.tissue_normals;
        let mut min_cos = 1.0f32;
        for (bone, map, upper) in [
            (&bones.skull, &bones.skull_to_skin, true),
            (&bones.jaw, &bones.jaw_to_skin, false),
        ] {
            assert_eq!(bone.positions.len(), map.len());
            bone.validate().unwrap();
            // The offset surface does not fold: every bone normal still faces outwards.
            for (n, &s) in bone.vertex_normals().iter().zip(map) {
                let cos = (0..3).map(|c| n[c] * tn[s as usize][c]).sum::<f32>();
                assert!(
                    cos > 0.3,
                    "bone normal at skin vertex {s} turned by acos({cos})"
                );
            }
            for (b, &s) in bone.positions.iter().zip(map) {
                let s = s as usize;
                assert_eq!(bones.jaw_weights[s] < 0.5, upper);
                let t = bones.thickness[s];
                assert!((0.45..4.0).contains(&t), "{t}");
                // skin − bone is the outward tissue normal times the thickness, and that
                // normal is outward on the skin too: the bone is behind the skin.
                let d = [skin[s][0] - b[0], skin[s][1] - b[1], skin[s][2] - b[2]];
                for c in 0..3 {
                    assert!((d[c] - t * tn[s][c]).abs() < 1e-5);
                }
                let cos = (0..3).map(|c| tn[s][c] * normals[s][c]).sum::<f32>();
                assert!(cos > 0.5, "{cos}");
                min_cos = min_cos.min(cos);
            }
        }
        eprintln!(
            "largest angle between tissue and skin normals: {}°",
            min_cos.acos().to_degrees()
        );
        // Forehead tissue is thin, cheek and lip tissue thicker.
        let th = |p: [f32; 3]| bones.thickness[nearest(skin, p)];
        assert!((th([0.0, 8.0, 8.0]) - 0.5).abs() < 0.05);
        assert!((th([-4.5, -2.0, 8.0]) - 1.2).abs() < 0.1);
        assert!(th([0.0, -4.3, 10.0]) > 1.2);
    }

    #[test]
    fn neutral_is_symmetric_and_generation_is_deterministic() {
        let (a, bones) = actor(24);
        let (b, _) = actor(24);
        assert_eq!(a.shapes, b.shapes);
        assert_eq!(bones.jaw_pivot, [0.0, 0.5, -0.5]);
        let p = &a.template.positions;
        for &q in p {
            let m = nearest(p, [-q[0], q[1], q[2]]);
            assert!(dist(p[m], [-q[0], q[1], q[2]]) < 1e-5, "{q:?}");
        }
        // The resolution floor keeps tiny requests valid.
        let (tiny, _) = actor(1);
        assert_eq!(tiny.template.positions.len(), MIN_RESOLUTION * 11);
        tiny.template.validate().unwrap();
    }
}
