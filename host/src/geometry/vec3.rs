//! Small `f64` 3-vector helpers for the host's geometry (bone constraints, bone scenes, the S2D
//! mesh hierarchy, deformation transfer): one copy of each formula, so that every caller rounds
//! the same way.

/// A point or vector in `f64`.
pub(crate) type V3 = [f64; 3];

/// Widens an `f32` point.
pub(crate) fn to64(a: [f32; 3]) -> V3 {
    a.map(f64::from)
}
pub(crate) fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
pub(crate) fn scale(a: V3, s: f64) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub(crate) fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// Squared length.
pub(crate) fn norm2(a: V3) -> f64 {
    dot(a, a)
}
/// Length.
pub(crate) fn norm(a: V3) -> f64 {
    norm2(a).sqrt()
}
/// Narrows an `f64` point.
pub(crate) fn to32(p: V3) -> [f32; 3] {
    p.map(|c| c as f32)
}

/// The unit vector along `a` (zero for zero).
pub(crate) fn normalize(a: V3) -> V3 {
    let n = norm(a);
    if n > 0.0 { scale(a, 1.0 / n) } else { [0.0; 3] }
}

/// `a + t (b − a)`, as `(1 − t) a + t b`.
pub(crate) fn lerp(a: V3, b: V3, t: f64) -> V3 {
    add(scale(a, 1.0 - t), scale(b, t))
}
