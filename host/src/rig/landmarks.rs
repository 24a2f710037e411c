//! A rig's 68 iBUG landmarks, found without a hand: the built-in face template placed on the
//! rig's neutral from its conventions (the nose tip forward, the head's width), aligned by a
//! similarity ICP, then deformed onto it by optimal-step non-rigid ICP (Amberg et al. 2007);
//! each template landmark, carried by the deformation, is the rig's landmark, bound to the rig's
//! vertex nearest to it. The registered template is kept: it is the dense correspondence between
//! the rig and the kit. A landmarks file (68 vertex indices, or 68 positions in the rig's own
//! frame) can be given instead.

use std::path::Path;

use serde::Serialize;

use super::conventions::{Axis, Conventions};
use super::error::RigError;
use super::template::FaceTemplate;
use crate::geometry::align::{Affine, fit_similarity};
use crate::geometry::nicp::{Settings, normals, register};
use crate::geometry::surface::{Surface, agree};
use crate::geometry::vec3::{V3, norm, sub};
use crate::geometry::weld::Weld;

/// The similarity ICP's alternations from the best start.
const SIMILARITY_STEPS: usize = 30;

/// Distances above this count as this much when the rigid starts are compared (cm, at the
/// template's size).
const CAP_CM: f64 = 1.0;

/// Correspondences farther than this many times the median are dropped while aligning.
const TRIM: f64 = 2.5;

/// One landmark on the rig.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Landmark {
    /// Its position in the rig's own frame and units (the skin mesh's coordinates).
    pub position: [f64; 3],
    /// Its position in Sinew's face frame (cm).
    #[serde(skip)]
    pub face: [f64; 3],
    /// The rig's vertex nearest to it (as the rig numbers them, seams split).
    pub vertex: u32,
    /// The welded vertex nearest to it.
    #[serde(skip)]
    pub welded_vertex: u32,
    /// Its distance from that vertex, in millimetres.
    pub vertex_distance_mm: f64,
}

/// How the landmarks were found.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "method", rename_all = "snake_case")]
pub enum Method {
    /// Registered from the built-in template.
    Registration {
        /// The template vertices whose correspondence held at the end, as a fraction.
        matched: f64,
        /// The mean distance of the matched template vertices from the rig's surface, mm.
        residual_mm: f64,
    },
    /// Read from a file.
    File {
        /// The file.
        path: String,
    },
}

/// The landmarks, and the template registered onto the rig when they were found that way.
#[derive(Clone, Debug)]
pub struct Found {
    /// The 68 landmarks in iBUG order.
    pub landmarks: Vec<Landmark>,
    /// How they were found.
    pub method: Method,
    /// The template's vertices on the rig, in the face frame (cm), when registered.
    pub registered: Option<Vec<[f64; 3]>>,
    /// The jaw hinge carried over from the template, in the face frame (cm).
    pub jaw_pivot: [f64; 3],
    /// The similarity that carries the template's landmarks onto these.
    carry: Affine,
}

impl Found {
    /// The face frame from the scene's: the inverse of the rotation and translation of the
    /// similarity that carries the template onto the rig (its scale stays: the rig keeps its
    /// size), column-major.
    pub(crate) fn placement(&self) -> [[f64; 4]; 4] {
        let s = self.carry.scale().max(f64::MIN_POSITIVE);
        let r = self.carry.a.map(|row| row.map(|v| v / s));
        let t = self.carry.t;
        // face = Rᵀ (scene − t): column c of Rᵀ is row c of R.
        let mut m = [[0.0; 4]; 4];
        for c in 0..3 {
            for k in 0..3 {
                m[c][k] = r[c][k];
            }
        }
        for k in 0..3 {
            m[3][k] = -(0..3).map(|i| r[i][k] * t[i]).sum::<f64>();
        }
        m[3][3] = 1.0;
        m
    }

    /// The same landmarks with every face-frame position moved by `place`.
    pub(crate) fn placed(mut self, place: &impl Fn([f64; 3]) -> [f64; 3]) -> Self {
        for l in &mut self.landmarks {
            l.face = place(l.face);
        }
        if let Some(r) = &mut self.registered {
            for p in r.iter_mut() {
                *p = place(*p);
            }
        }
        self.jaw_pivot = place(self.jaw_pivot);
        self
    }

    /// Per landmark, the welded vertex nearest to it (what the bone fit and the training set
    /// take).
    pub fn welded_vertices(&self) -> Vec<u32> {
        self.landmarks.iter().map(|l| l.welded_vertex).collect()
    }
}

/// The rig as the landmarks see it: its welded surface in the scene's frame (cm, axes
/// resolved, not yet placed).
pub(crate) struct Target<'a> {
    /// The rig, for errors.
    pub(crate) path: &'a Path,
    /// The welded neutral's surface.
    pub(crate) surface: Surface,
    /// The welding.
    pub(crate) weld: &'a Weld,
    /// The conventions, placement still the identity.
    pub(crate) conventions: &'a Conventions,
    /// The rig's vertex count, seams split.
    pub(crate) vertices: usize,
}

impl Target<'_> {
    /// The landmark at `scene` (a template landmark carried by the registration, or a point a
    /// landmarks file gives) and the welded vertex nearest to it. The point is kept where it is,
    /// not snapped onto the surface: a landmark at an eye's or the mouth's corner lies in the
    /// gap between the lids or lips (up to ~1.5 mm off the skin on the kit's identities), where
    /// the closest point of the surface jumps between the two sides as the point moves by a
    /// hundredth of a millimetre (so a rig re-ordered or re-quantised by an optimiser moved such
    /// a landmark by 0.77 mm; kept, 0.02 mm).
    fn landmark_at(&self, scene: V3) -> Result<Landmark, RigError> {
        let (welded, d) =
            self.surface
                .nearest_vertex(scene)
                .ok_or_else(|| RigError::Registration {
                    path: self.path.to_owned(),
                    what: "the neutral has no vertices".into(),
                })?;
        let position =
            self.conventions
                .from_face(scene)
                .ok_or_else(|| RigError::NodeTransform {
                    path: self.path.to_owned(),
                })?;
        Ok(Landmark {
            position,
            face: scene,
            vertex: self.weld.first[welded],
            welded_vertex: welded as u32,
            vertex_distance_mm: d * 10.0,
        })
    }
}

/// The template's landmarks in its own frame (cm).
fn template_landmarks(template: &FaceTemplate) -> Vec<V3> {
    let tpl = template.points();
    let surface = Surface::new(tpl.clone(), template.triangles.clone());
    template
        .landmarks
        .iter()
        .map(|&(t, w)| surface.at(&tpl, t, w))
        .collect()
}

/// The yaw turns (degrees, about the up axis) the rigid start tries: a head may face any way
/// in its scene.
const START_YAWS: [f64; 8] = [0.0, 45.0, -45.0, 90.0, -90.0, 135.0, -135.0, 180.0];

/// One similarity ICP from `placed`: trimmed closest points that face the same way. Returns
/// the placed template and its score (the mean over every template point of its distance from
/// the rig, capped at `cap` and counted as `cap` where the surfaces face apart), or `None` when
/// too few points face it.
fn align(
    target: &Surface,
    target_normals: &[V3],
    triangles: &[[u32; 3]],
    mut placed: Vec<V3>,
    steps: usize,
    cap: f64,
) -> Option<(Vec<V3>, f64)> {
    let pairs_of = |placed: &[V3]| {
        let here = normals(placed, triangles);
        let mut pairs = Vec::new();
        for (i, p) in placed.iter().enumerate() {
            if let Some((sp, v)) = target.closest(*p)
                && agree(here[i], target_normals[v], 60.0)
            {
                pairs.push((i, sp.position, norm(sub(sp.position, *p))));
            }
        }
        pairs
    };
    for _ in 0..steps {
        let pairs = pairs_of(&placed);
        if pairs.len() < 10 {
            return None;
        }
        let mut d: Vec<f64> = pairs.iter().map(|p| p.2).collect();
        d.sort_by(f64::total_cmp);
        let cut = d[d.len() / 2] * TRIM + 1e-9;
        let (x, y): (Vec<V3>, Vec<V3>) = pairs
            .iter()
            .filter(|p| p.2 <= cut)
            .map(|&(i, q, _)| (placed[i], q))
            .unzip();
        let fit = fit_similarity(&x, &y, &vec![1.0; x.len()]);
        placed = placed.iter().map(|&p| fit.apply(p)).collect();
    }
    let pairs = pairs_of(&placed);
    let n = placed.len() as f64;
    let score =
        (pairs.iter().map(|p| p.2.min(cap)).sum::<f64>() + (n - pairs.len() as f64) * cap) / n;
    Some((placed, score))
}

/// Finds the landmarks by registering `template` onto the rig: a rigid start for each of
/// [`START_YAWS`] (the template's nose tip on the rig's point farthest along that way, scaled to
/// the rig's width), a short similarity ICP from each, the best continued, then non-rigid ICP.
pub(crate) fn register_template(
    target: &Target<'_>,
    template: &FaceTemplate,
) -> Result<Found, RigError> {
    let fail = |what: String| RigError::Registration {
        path: target.path.to_owned(),
        what,
    };
    let surface = &target.surface;
    if surface.triangles.is_empty() {
        return Err(fail("the neutral has no faces to register onto".into()));
    }
    let (lo, hi) = crate::geometry::spatial::bbox(&surface.points);
    if norm(sub(hi, lo)).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(fail(
            "the neutral has no extent (every vertex at one point)".into(),
        ));
    }
    let target_normals = normals(&surface.points, &surface.triangles);
    let tpl = template.points();
    let tpl_tris = template.triangles.clone();
    let nose = template_landmarks(template)[30];
    let (tlo, thi) = crate::geometry::spatial::bbox(&tpl);
    let s0 = ((0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max)
        / (0..3).map(|k| thi[k] - tlo[k]).fold(0.0, f64::max))
    .clamp(0.25, 4.0);
    let cap = CAP_CM * s0;

    // The template's nose tip on the rig's point farthest along `ahead` among those above the
    // lowest quarter along `up`, the template turned so that its +y is `up` and its +z `ahead`,
    // then a short similarity ICP.
    let start = |up: V3, ahead: V3, steps: usize| {
        let right = crate::geometry::vec3::cross(up, ahead);
        let dot = crate::geometry::vec3::dot;
        let heights: Vec<f64> = surface.points.iter().map(|p| dot(*p, up)).collect();
        let (h_lo, h_hi) = heights
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &h| {
                (a.min(h), b.max(h))
            });
        let floor = h_lo + 0.25 * (h_hi - h_lo);
        let tip = surface
            .points
            .iter()
            .zip(&heights)
            .filter(|(_, h)| **h >= floor)
            .map(|(p, _)| *p)
            .max_by(|a, b| dot(*a, ahead).total_cmp(&dot(*b, ahead)))?;
        let placed: Vec<V3> = tpl
            .iter()
            .map(|p| {
                let q = sub(*p, nose);
                std::array::from_fn(|k| {
                    (right[k] * q[0] + up[k] * q[1] + ahead[k] * q[2]) * s0 + tip[k]
                })
            })
            .collect();
        align(surface, &target_normals, &tpl_tris, placed, steps, cap)
    };
    let mut best: Option<(Vec<V3>, f64)> = None;
    for yaw in START_YAWS {
        let (sn, cs) = yaw.to_radians().sin_cos();
        if let Some((placed, score)) = start([0.0, 1.0, 0.0], [sn, 0.0, cs], 12)
            && best.as_ref().is_none_or(|b| score < b.1)
        {
            best = Some((placed, score));
        }
    }
    let (placed, score) = best.ok_or_else(|| {
        fail(
            "the face template found too few points facing it on the neutral; is it a face, \
              and are --up and --forward right?"
                .into(),
        )
    })?;
    // A face that fits far better standing on another axis: the rig's axes are not the ones
    // given.
    let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let signed = axes.iter().flat_map(|a| [*a, a.map(|v: f64| -v)]);
    for up in signed.clone().filter(|u| u[1] < 0.5) {
        for ahead in signed
            .clone()
            .filter(|a| crate::geometry::vec3::dot(*a, up).abs() < 0.5)
        {
            if let Some((_, other)) = start(up, ahead, 8)
                && other < 0.6 * score
            {
                let c = target.conventions;
                let (r, u, f) = (c.right(), c.up.vector(), c.forward.vector());
                let name = |v: V3| {
                    let w: V3 = std::array::from_fn(|k| v[0] * r[k] + v[1] * u[k] + v[2] * f[k]);
                    Axis::nearest(w).name()
                };
                return Err(fail(format!(
                    "the face stands along {} and looks along {} in the rig's own axes, not \
                     along --up {} and --forward {}; pass --up {} --forward {}",
                    name(up),
                    name(ahead),
                    c.up.name(),
                    c.forward.name(),
                    name(up),
                    name(ahead)
                )));
            }
        }
    }
    let (placed, _) = align(
        surface,
        &target_normals,
        &tpl_tris,
        placed,
        SIMILARITY_STEPS,
        cap,
    )
    .ok_or_else(|| fail("the face template lost the neutral while aligning".into()))?;

    // Non-rigid ICP in coordinates scaled to the template's radius.
    let n = placed.len() as f64;
    let centre: V3 = std::array::from_fn(|k| placed.iter().map(|p| p[k]).sum::<f64>() / n);
    let radius = (placed
        .iter()
        .map(|p| crate::geometry::vec3::norm2(sub(*p, centre)))
        .sum::<f64>()
        / n)
        .sqrt()
        .max(f64::MIN_POSITIVE);
    let to_unit = |p: &V3| -> V3 { std::array::from_fn(|k| (p[k] - centre[k]) / radius) };
    let unit_target = Surface::new(
        surface.points.iter().map(to_unit).collect(),
        surface.triangles.clone(),
    );
    let unit_template: Vec<V3> = placed.iter().map(to_unit).collect();
    let settings = Settings {
        // 1 cm, in the unit radius.
        max_distance: 1.0 / radius,
        ..Settings::default()
    };
    let got = register(&unit_template, &tpl_tris, &unit_target, &settings);
    let registered: Vec<V3> = got
        .points
        .iter()
        .map(|p| std::array::from_fn(|k| p[k] * radius + centre[k]))
        .collect();
    let matched = got.matched.iter().filter(|&&m| m).count() as f64 / n;
    if matched < 0.5 {
        return Err(fail(format!(
            "the face template held on only {:.0} % of its points; the neutral may not be a face \
             (or is degenerate, or not manifold); give --landmarks",
            matched * 100.0
        )));
    }
    let mut residual = 0.0;
    let mut count = 0u32;
    for (p, &m) in registered.iter().zip(&got.matched) {
        if m && let Some((sp, _)) = surface.closest(*p) {
            residual += norm(sub(sp.position, *p));
            count += 1;
        }
    }
    let tpl_surface = Surface::new(tpl.clone(), tpl_tris.clone());
    let landmarks = template
        .landmarks
        .iter()
        .map(|&(t, w)| target.landmark_at(tpl_surface.at(&registered, t, w)))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(found(
        template,
        landmarks,
        Method::Registration {
            matched,
            residual_mm: residual / f64::from(count.max(1)) * 10.0,
        },
        Some(registered),
    ))
}

/// The landmarks with the similarity that carries the template's onto them, and the jaw hinge
/// it carries.
fn found(
    template: &FaceTemplate,
    landmarks: Vec<Landmark>,
    method: Method,
    registered: Option<Vec<V3>>,
) -> Found {
    let from = template_landmarks(template);
    let to: Vec<V3> = landmarks.iter().map(|l| l.face).collect();
    let carry = fit_similarity(&from, &to, &vec![1.0; from.len()]);
    Found {
        landmarks,
        method,
        registered,
        jaw_pivot: carry.apply(template.jaw_pivot_cm()),
        carry,
    }
}

/// Most a landmark given by position may lie off the rig's surface, in centimetres.
const OFF_SURFACE_CM: f64 = 0.5;

/// Reads 68 landmarks from `path`: a JSON list of 68 vertex indices (the rig's own numbering)
/// or of 68 `[x, y, z]` positions in the rig's own frame and units, each of which must lie on
/// the rig's surface (within 5 mm). The jaw hinge comes from the template, carried by the
/// landmarks.
pub(crate) fn from_file(
    target: &Target<'_>,
    path: &Path,
    template: &FaceTemplate,
) -> Result<Found, RigError> {
    let bad = |what: String| RigError::Landmarks {
        path: path.to_owned(),
        what,
    };
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let list = value
        .as_array()
        .ok_or_else(|| bad("not a JSON list of 68 vertex indices or positions".into()))?;
    if list.len() != 68 {
        return Err(bad(format!(
            "{} landmarks, 68 needed (iBUG order)",
            list.len()
        )));
    }
    let mut landmarks = Vec::with_capacity(68);
    for (k, item) in list.iter().enumerate() {
        let scene = if let Some(v) = item.as_u64() {
            let v = usize::try_from(v).unwrap_or(usize::MAX);
            if v >= target.vertices {
                return Err(bad(format!(
                    "landmark {k} is vertex {v}, past the rig's {} vertices",
                    target.vertices
                )));
            }
            target.surface.points[target.weld.welded[v] as usize]
        } else if let Some(p) = item.as_array().filter(|a| a.len() == 3) {
            let xyz: Vec<f64> = p.iter().filter_map(serde_json::Value::as_f64).collect();
            if xyz.len() != 3 || xyz.iter().any(|v| !v.is_finite()) {
                return Err(bad(format!("landmark {k} is not three finite numbers")));
            }
            let q = target
                .conventions
                .to_face([xyz[0] as f32, xyz[1] as f32, xyz[2] as f32]);
            let (on, _) = target
                .surface
                .closest(q)
                .ok_or_else(|| bad("the rig has no vertices".into()))?;
            let off = norm(sub(on.position, q));
            if off.is_nan() || off > OFF_SURFACE_CM {
                return Err(bad(format!(
                    "landmark {k} lies {:.1} mm off the rig's surface (at most {:.0} mm)",
                    off * 10.0,
                    OFF_SURFACE_CM * 10.0
                )));
            }
            q
        } else {
            return Err(bad(format!(
                "landmark {k} is neither a vertex index nor [x, y, z]"
            )));
        };
        landmarks.push(target.landmark_at(scene)?);
    }
    Ok(found(
        template,
        landmarks,
        Method::File {
            path: path.display().to_string(),
        },
        None,
    ))
}
