//! Eyeballs behind a face mesh's eye openings, for photographs that a face tracker reads as
//! eyes: a face model's eye openings are holes, and a tracker shown a hole places the eye's
//! corners and lids elsewhere than on the eyelids (MediaPipe Face Mesh put the outer corners
//! 5 px outside the openings and the lids 6 px closer together on a rendered performance,
//! docs/FIT.md). Each eye is a spherical cap, white with a brown iris and a black pupil, placed
//! from the frame's own eyelid landmarks (iBUG 36–41 and 42–47): centred behind the middle of
//! the eye's corners, facing the way the face faces, its silhouette wider than the opening so
//! that the eyelids cover its edge.

use sinew_core::linalg::Vec3;

/// The sclera's albedo.
pub const SCLERA: [u8; 3] = [222, 216, 206];
/// The iris's albedo.
pub const IRIS: [u8; 3] = [85, 60, 42];
/// The pupil's albedo.
pub const PUPIL: [u8; 3] = [15, 12, 12];

/// The eyeball's radius, in eye widths (the distance between the eye's corners).
const RADIUS: f32 = 0.6;
/// How far behind the eye's centre the front of the eyeball lies, in eye widths (the eyelids
/// lie in front of it).
const SETBACK: f32 = 0.02;
/// Rings of the cap, as distances from its axis in eye widths, with their albedo: the pupil,
/// the iris, the sclera out to the silhouette.
const RINGS: [(f32, [u8; 3]); 7] = [
    (0.0, PUPIL),
    (0.08, PUPIL),
    (0.09, IRIS),
    (0.2, IRIS),
    (0.21, SCLERA),
    (0.4, SCLERA),
    (RADIUS, SCLERA),
];
/// Points on each ring.
const SEGMENTS: u32 = 24;

/// The eyeballs of a face whose 68 iBUG landmarks are at `landmarks` (positions), appended to
/// `positions`, `triangles` and `albedo` (which is first padded with skin to the mesh's vertex
/// count). The face's frame is taken from the landmarks themselves (x from the right eye's outer
/// corner to the left's, y from the chin to the nose's bridge), so no pose is needed. Nothing is
/// added for fewer than 68 landmarks or a degenerate face.
pub fn add_eyes(
    positions: &mut Vec<[f32; 3]>,
    triangles: &mut Vec<[u32; 3]>,
    albedo: &mut Vec<[u8; 3]>,
    landmarks: &[[f32; 3]],
) {
    if landmarks.len() != 68 {
        return;
    }
    let at = |l: usize| Vec3::from_array(landmarks[l]);
    let across = at(45) - at(36);
    let up = at(27) - at(8);
    let forward = across.cross(up);
    if !(forward.dot(forward) > 0.0 && forward.dot(forward).is_finite()) {
        return;
    }
    let forward = forward.normalize();
    let right = across.normalize();
    let up = forward.cross(right).normalize();
    let skin = albedo.len().max(positions.len());
    albedo.resize(skin, super::SKIN);
    for (a, b) in [(36, 39), (42, 45)] {
        let width = (at(b) - at(a)).norm();
        if !(width > 0.0 && width.is_finite()) {
            continue;
        }
        let mid = (at(a) + at(b)).scale(0.5);
        let eyelids = (a..a + 6).fold(0.0f32, |s, l| s + (at(l) - mid).dot(forward)) / 6.0;
        let radius = RADIUS * width;
        let front = mid + forward.scale(eyelids - SETBACK * width);
        let centre = front - forward.scale(radius);
        let first = positions.len() as u32;
        for (k, &(r, colour)) in RINGS.iter().enumerate() {
            let lateral = (r * width).min(radius);
            let depth = (radius * radius - lateral * lateral).max(0.0).sqrt();
            let count = if k == 0 { 1 } else { SEGMENTS };
            for s in 0..count {
                let a = std::f32::consts::TAU * s as f32 / SEGMENTS as f32;
                let p = centre
                    + forward.scale(depth)
                    + right.scale(lateral * a.cos())
                    + up.scale(lateral * a.sin());
                positions.push(p.to_array());
                albedo.push(colour);
            }
        }
        // The pupil's fan, then a band between each pair of rings.
        let ring = |k: u32, s: u32| first + 1 + (k - 1) * SEGMENTS + s % SEGMENTS;
        for s in 0..SEGMENTS {
            triangles.push([first, ring(1, s), ring(1, s + 1)]);
        }
        for k in 1..RINGS.len() as u32 - 1 {
            for s in 0..SEGMENTS {
                let (a, b) = (ring(k, s), ring(k, s + 1));
                let (c, d) = (ring(k + 1, s), ring(k + 1, s + 1));
                triangles.push([a, c, d]);
                triangles.push([a, d, b]);
            }
        }
    }
}
