//! Which bone vertices lie behind the skin (a depth map seen from the front), for pictures and
//! the constraint search.

use super::landmarks::FaceFrame;
use crate::geometry::vec3::{V3, dot, scale, to64};
use crate::io::mesh::Mesh;
use serde::Serialize;

/// How many bone vertices near the face lie behind the skin (see [`behind_skin`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct BehindSkin {
    /// Vertices near the face.
    pub near: usize,
    /// Of those, the ones behind the skin in every view.
    pub behind: usize,
}

impl BehindSkin {
    /// `behind / near` (1 when nothing is near).
    pub fn fraction(&self) -> f32 {
        if self.near == 0 {
            1.0
        } else {
            self.behind as f32 / self.near as f32
        }
    }
}

/// Checks that bone points lie inside the skin, seen from four sides. The whole skin mesh is
/// rendered into depth maps (pixel size `pixel`, in the skin's unit) looking from the front,
/// the left, the right and the top of the face frame. A point is *near the face* if in some view
/// a skin pixel covers it and it lies in front of that skin or less than `near_depth` behind it;
/// it is *behind the skin* if in no covering view it lies in front of the skin.
///
/// Why views and not the nearest skin vertex: near the mouth and eyes the nearest skin vertex is
/// often on an inner lip or eyelid rim whose normal faces the teeth or the orbit, which would
/// call a tooth "in front of the skin". A depth map asks the right question: is there skin
/// between this bone point and the outside?
pub fn behind_skin(
    skin: &Mesh,
    frame: &FaceFrame,
    points: &[[f32; 3]],
    near_depth: f32,
    pixel: f32,
) -> BehindSkin {
    let (l, u, f) = (to64(frame.left), to64(frame.up), to64(frame.forward));
    let views = [
        (l, u, f),
        (f, u, scale(l, -1.0)),
        (scale(f, -1.0), u, l),
        (l, scale(f, -1.0), u),
    ];
    let tris = skin.triangles();
    let maps: Vec<DepthMap> = views
        .iter()
        .map(|&(a, b, c)| DepthMap::render(&skin.positions, &tris, a, b, c, pixel as f64))
        .collect();
    let mut out = BehindSkin::default();
    for p in points {
        let p = to64(*p);
        let (mut near, mut front) = (false, false);
        for (m, &(a, b, c)) in maps.iter().zip(&views) {
            let Some(depth) = m.depth(dot(p, a), dot(p, b)) else {
                continue;
            };
            let z = dot(p, c);
            if z > depth {
                front = true;
                near = true;
            } else if z > depth - near_depth as f64 {
                near = true;
            }
        }
        if near {
            out.near += 1;
            if !front {
                out.behind += 1;
            }
        }
    }
    out
}

/// The largest `c` coordinate of the skin over a pixel grid in the `(a, b)` plane.
pub(crate) struct DepthMap {
    pub(crate) lo: [f64; 2],
    pub(crate) pixel: f64,
    pub(crate) w: usize,
    pub(crate) h: usize,
    pub(crate) depth: Vec<f64>,
}

impl DepthMap {
    pub(crate) fn render(
        pos: &[[f32; 3]],
        tris: &[[u32; 3]],
        a: V3,
        b: V3,
        c: V3,
        pixel: f64,
    ) -> Self {
        let proj: Vec<[f64; 3]> = pos
            .iter()
            .map(|p| {
                let p = to64(*p);
                [dot(p, a), dot(p, b), dot(p, c)]
            })
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in &proj {
            for k in 0..2 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        // Keep the map to at most 2048 pixels a side whatever the unit.
        let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(0.0);
        let pixel = if pixel > 0.0 {
            pixel.max(span / 2048.0)
        } else {
            span / 2048.0
        };
        let (w, h) = if proj.is_empty() || pixel.is_nan() || pixel <= 0.0 {
            (0, 0)
        } else {
            (
                ((hi[0] - lo[0]) / pixel) as usize + 2,
                ((hi[1] - lo[1]) / pixel) as usize + 2,
            )
        };
        let mut m = Self {
            lo,
            pixel,
            w,
            h,
            depth: vec![f64::NEG_INFINITY; w * h],
        };
        if w == 0 {
            return m;
        }
        for t in tris {
            let [p0, p1, p2] = t.map(|i| proj[i as usize]);
            let d = (p1[1] - p2[1]) * (p0[0] - p2[0]) + (p2[0] - p1[0]) * (p0[1] - p2[1]);
            if d.abs() < 1e-30 {
                continue;
            }
            let px = |x: f64, k: usize| (x - m.lo[k]) / m.pixel;
            let x0 = px(p0[0].min(p1[0]).min(p2[0]), 0).floor().max(0.0) as usize;
            let x1 = (px(p0[0].max(p1[0]).max(p2[0]), 0).ceil() as usize).min(w - 1);
            let y0 = px(p0[1].min(p1[1]).min(p2[1]), 1).floor().max(0.0) as usize;
            let y1 = (px(p0[1].max(p1[1]).max(p2[1]), 1).ceil() as usize).min(h - 1);
            for iy in y0..=y1 {
                for ix in x0..=x1 {
                    let (x, y) = (m.lo[0] + ix as f64 * m.pixel, m.lo[1] + iy as f64 * m.pixel);
                    let l0 = ((p1[1] - p2[1]) * (x - p2[0]) + (p2[0] - p1[0]) * (y - p2[1])) / d;
                    let l1 = ((p2[1] - p0[1]) * (x - p2[0]) + (p0[0] - p2[0]) * (y - p2[1])) / d;
                    let l2 = 1.0 - l0 - l1;
                    if l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9 {
                        continue;
                    }
                    let z = l0 * p0[2] + l1 * p1[2] + l2 * p2[2];
                    let cell = &mut m.depth[iy * w + ix];
                    if z > *cell {
                        *cell = z;
                    }
                }
            }
        }
        m
    }

    /// The skin depth at the pixel nearest `(x, y)`, if skin covers it.
    pub(crate) fn depth(&self, x: f64, y: f64) -> Option<f64> {
        let ix = ((x - self.lo[0]) / self.pixel).round();
        let iy = ((y - self.lo[1]) / self.pixel).round();
        if !(ix >= 0.0 && iy >= 0.0 && (ix as usize) < self.w && (iy as usize) < self.h) {
            return None;
        }
        let d = self.depth[iy as usize * self.w + ix as usize];
        d.is_finite().then_some(d)
    }
}
