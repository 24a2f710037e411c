//! A baked AIM actor ("Anatomically Constrained Implicit Face Models", Chandran & Zoss 2024):
//! real-time playback from a per-vertex cache, anatomy editing on that cache, and evaluation of
//! the five networks at any template point when the artefact carries them.
//!
//! # Sections (artefact kind [`ArtifactKind::AimActor`])
//! | name | dtype | shape | meaning |
//! |---|---|---|---|
//! | `tpl.pos` | f32 | `[V, 3]` | template points c |
//! | `tpl.tri` | u32 | `[T, 3]` | template triangles (for normals and rendering) |
//! | `cache.s0` | f32 | `[V, 3]` | neutral skin s0 = b0 + d0·n0 at the template points (eq. 6) |
//! | `cache.k` | f32 | `[V]` | jaw skinning weight k (eq. 7) |
//! | `cache.e` | f32 | `[V, M, 3]` | corrective basis B_e, vertex-major (eq. 8), M = N − 1 |
//! | `cache.b0` | f32 | `[V, 3]` | bone point b0 (eq. 3) |
//! | `cache.d0` | f32 | `[V]` | soft-tissue thickness d0 (eq. 4) |
//! | `cache.n0` | f32 | `[V, 3]` | unit bone normal n0 (eq. 5) |
//! | `jaw.pivot` | f32 | `[3]` | the jaw's pivot p: T_b(x) = R (x − p) + p + t |
//! | `train.jaw` | f32 | `[M, 9]` | optional: each training shape's learned jaw transform ([`crate::jaw`]) |
//! | `aim.norm` | f32 | `[4]` | network input normalisation: ĉ = (c − centre) / scale; centre xyz, scale |
//! | `net.b`, `net.d`, `net.n`, `net.k`, `net.e` | MLP | | the five networks (absent when playback-only) |
//!
//! The networks see ĉ and predict: b0 = c + B(ĉ) (a residual, so the network's outputs stay of
//! order one), d0 = D(ĉ), n0 = normalise(N(ĉ)), k = K(ĉ), B_e = E(ĉ).

use crate::error::{Argument, Bound, BufferError, EvalError, FormatError, InputError};
use crate::format::{ArtifactKind, FLAG_PLAYBACK_ONLY, SinewFile, out_of_range};
use crate::input::{check_finite, check_values};
use crate::jaw::LearnedJaws;
use crate::layout::MAX_COORDINATE;
use crate::linalg::Vec3;
use crate::network::{check_bound, load_mlp};
use crate::nn::Mlp;
use crate::q16::AimQ16;
use crate::skinning::{Pose, Triangles, skin_vertex, vertex_normals};
use crate::tensor::F32s;

/// Largest number of corrective shapes M a baked actor may hold.
pub const MAX_SHAPES: usize = 256;

/// The five AIM networks and their input normalisation.
#[derive(Clone, Debug)]
pub struct AimNetworks<'a> {
    /// B: bone point residual, 3 outputs.
    pub b: Mlp<'a>,
    /// D: soft-tissue thickness, 1 output.
    pub d: Mlp<'a>,
    /// N: bone normal (unnormalised), 3 outputs.
    pub n: Mlp<'a>,
    /// K: jaw skinning weight, 1 output.
    pub k: Mlp<'a>,
    /// E: corrective basis, 3·M outputs.
    pub e: Mlp<'a>,
    centre: Vec3,
    scale: f32,
    thickness_activation: u32,
}

/// Section `aim.dact` value: d0 = D(c) (also when the section is absent).
pub const THICKNESS_IDENTITY: u32 = 0;
/// Section `aim.dact` value: d0 = softplus(D(c)) ([`softplus`]).
pub const THICKNESS_SOFTPLUS: u32 = 1;

/// `ln(1 + e^x)` with `libm`, and `x` itself above 20 (where the two agree to f32 precision; the
/// threshold of burn's and PyTorch's softplus).
pub fn softplus(x: f32) -> f32 {
    if x > 20.0 {
        x
    } else {
        libm::log1pf(libm::expf(x))
    }
}

/// What the networks say about one template point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointAnatomy {
    /// Bone point b0.
    pub bone: Vec3,
    /// Soft-tissue thickness d0.
    pub thickness: f32,
    /// Unit bone normal n0.
    pub normal: Vec3,
    /// Neutral skin point s0 = b0 + d0·n0 (AIM eq. 6).
    pub skin: Vec3,
    /// Jaw skinning weight k.
    pub k: f32,
}

/// A validated AIM actor over the artefact's bytes.
#[derive(Clone, Debug)]
pub struct AimActor<'a> {
    file: SinewFile<'a>,
    vertices: usize,
    shapes: usize,
    template: F32s<'a>,
    triangles: Triangles<'a>,
    rest: F32s<'a>,
    k: F32s<'a>,
    correctives: F32s<'a>,
    bone: F32s<'a>,
    thickness: F32s<'a>,
    normal: F32s<'a>,
    pivot: Vec3,
    jaws: Option<LearnedJaws<'a>>,
    networks: Option<AimNetworks<'a>>,
    q16: Option<AimQ16<'a>>,
}

fn vec3(v: F32s<'_>, i: usize) -> Vec3 {
    Vec3::new(v.at(3 * i), v.at(3 * i + 1), v.at(3 * i + 2))
}

impl<'a> AimActor<'a> {
    /// Validates `bytes` as an AIM actor (container checks, then every role and shape, and every
    /// value the evaluation reads within its bound: lengths within ±[`MAX_COORDINATE`], the jaw
    /// weights and bone normals within ±[`crate::layout::MAX_FACTOR`], and the networks bounded
    /// for every template point within ±[`MAX_COORDINATE`]; docs/FORMAT.md, "Value bounds").
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let file = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::AimActor)?;
        let (shape, rank) = file.dims_of("cache.e")?;
        let [v, m, three, _] = shape;
        if rank != 3 || three != 3 {
            return Err(FormatError::incompatible_shapes("cache.e"));
        }
        if m as usize > MAX_SHAPES {
            return Err(FormatError::limit_exceeded(
                "cache.e", m as usize, MAX_SHAPES,
            ));
        }
        let template = file.f32_tensor_within("tpl.pos", &[v, 3], Bound::Coordinate)?;
        let (tri_shape, tri_rank) = file.dims_of("tpl.tri")?;
        if tri_rank != 2 {
            return Err(FormatError::incompatible_shapes("tpl.tri"));
        }
        let tri = file.u32_tensor("tpl.tri", &[tri_shape[0], 3])?;
        let triangles = Triangles::new(tri, v as usize).map_err(|e| e.in_section("tpl.tri"))?;
        let pivot = file.f32_tensor_within("jaw.pivot", &[3], Bound::Coordinate)?;
        let networks = if file.flags & FLAG_PLAYBACK_ONLY != 0 {
            None
        } else {
            let norm = file.f32_tensor("aim.norm", &[4])?;
            for (i, x) in norm.iter().enumerate() {
                let bound = if i < 3 {
                    Bound::Coordinate
                } else {
                    Bound::PositiveCoordinate
                };
                if !bound.contains(x) {
                    return Err(out_of_range("aim.norm", i, bound));
                }
            }
            let scale = norm.at(3);
            let nets = AimNetworks {
                b: load_mlp(&file, "net.b")?,
                d: load_mlp(&file, "net.d")?,
                n: load_mlp(&file, "net.n")?,
                k: load_mlp(&file, "net.k")?,
                e: load_mlp(&file, "net.e")?,
                centre: vec3(norm, 0),
                scale,
                thickness_activation: match file.section("aim.dact") {
                    None => THICKNESS_IDENTITY,
                    Some(_) => match file.u32_tensor("aim.dact", &[1])?.at(0) {
                        code @ (THICKNESS_IDENTITY | THICKNESS_SOFTPLUS) => code,
                        code => return Err(FormatError::unknown_code("aim.dact", 0, code)),
                    },
                },
            };
            let outputs = [
                (&nets.b, 3, "net.b"),
                (&nets.d, 1, "net.d"),
                (&nets.n, 3, "net.n"),
                (&nets.k, 1, "net.k"),
                (&nets.e, 3 * m as usize, "net.e"),
            ];
            if let Some((.., prefix)) = outputs
                .iter()
                .find(|(mlp, out, _)| mlp.inputs() != 3 || mlp.outputs() != *out)
            {
                return Err(FormatError::incompatible_shapes(prefix));
            }
            // The networks see ĉ = (c − centre) / scale for template points c within ±MAX_COORDINATE.
            let centre = nets.centre.to_array().map(libm::fabsf);
            let reach = centre.into_iter().fold(0.0f32, f32::max) + MAX_COORDINATE;
            let input = f64::from(reach) / f64::from(scale);
            let named = [
                (&nets.b, "net.b"),
                (&nets.d, "net.d"),
                (&nets.n, "net.n"),
                (&nets.k, "net.k"),
                (&nets.e, "net.e"),
            ];
            for (mlp, prefix) in named {
                check_bound(mlp, prefix, input)?;
            }
            Some(nets)
        };
        Ok(Self {
            vertices: v as usize,
            shapes: m as usize,
            template,
            triangles,
            rest: file.f32_tensor_within("cache.s0", &[v, 3], Bound::Coordinate)?,
            k: file.f32_tensor_within("cache.k", &[v], Bound::Factor)?,
            correctives: file.f32_tensor_within("cache.e", &[v, m, 3], Bound::Coordinate)?,
            bone: file.f32_tensor_within("cache.b0", &[v, 3], Bound::Coordinate)?,
            thickness: file.f32_tensor_within("cache.d0", &[v], Bound::Coordinate)?,
            normal: file.f32_tensor_within("cache.n0", &[v, 3], Bound::Factor)?,
            pivot: vec3(pivot, 0),
            jaws: LearnedJaws::from_file(&file, m as usize)?,
            networks,
            q16: AimQ16::from_file(&file, v, m)?,
            file,
        })
    }

    /// The container (metadata, sections).
    pub const fn file(&self) -> &SinewFile<'a> {
        &self.file
    }

    /// Number of template vertices V.
    pub const fn vertex_count(&self) -> usize {
        self.vertices
    }

    /// Number of corrective shapes M = N − 1 (the length of a pose's coefficient vector).
    pub const fn shape_count(&self) -> usize {
        self.shapes
    }

    /// The recorded name of corrective shape `i` (coefficient `i`, below [`Self::shape_count`]):
    /// entry `i + 1` of the metadata `shapes`, the training shapes' names with the neutral first.
    /// `None` past the end, or when the file records no names or not exactly M + 1 of them.
    pub fn shape_name(&self, i: usize) -> Option<&'a str> {
        let names = self.file.metadata().get("shapes")?;
        if names.split(',').count() != self.shapes + 1 || i >= self.shapes {
            return None;
        }
        names.split(',').nth(i + 1).map(str::trim)
    }

    /// The template triangles.
    pub const fn triangles(&self) -> &Triangles<'a> {
        &self.triangles
    }

    /// The template points, `[V, 3]`.
    pub const fn template(&self) -> F32s<'a> {
        self.template
    }

    /// The cached neutral skin s0, `[V, 3]`.
    pub const fn rest(&self) -> F32s<'a> {
        self.rest
    }

    /// The cached soft-tissue thickness d0, `[V]`.
    pub const fn thickness(&self) -> F32s<'a> {
        self.thickness
    }

    /// The cached jaw skinning weight k, `[V]`.
    pub const fn skinning_weights(&self) -> F32s<'a> {
        self.k
    }

    /// The cached corrective basis B_e, `[V, M, 3]` vertex-major (eq. 8).
    pub const fn correctives(&self) -> F32s<'a> {
        self.correctives
    }

    /// The jaw pivot.
    pub const fn jaw_pivot(&self) -> Vec3 {
        self.pivot
    }

    /// Every training shape's learned jaw transform (`train.jaw`), when the artefact records them
    /// (every actor Sinew trains does).
    pub const fn learned_jaws(&self) -> Option<&LearnedJaws<'a>> {
        self.jaws.as_ref()
    }

    /// The jaw transform of a pose given by corrective coefficients alone (an ARKit capture, an
    /// engine driving shapes by name, a viewer's sliders): every shape's learned jaw blended by
    /// its coefficient and held within the range the shapes span ([`crate::jaw`] gives the rule);
    /// the identity for an actor without learned jaws. The result is a transform
    /// [`Self::pose_from_9d`] accepts.
    ///
    /// # Shapes
    /// - `weights`: `[M]`
    ///
    /// # Errors
    /// [`EvalError::Buffer`] for a wrong length; [`EvalError::Input`] for a coefficient that is
    /// not finite or outside ±[`crate::layout::MAX_FACTOR`].
    pub fn jaw_from_weights(&self, weights: &[f32]) -> Result<[f32; 9], EvalError> {
        if weights.len() != self.shapes {
            return Err(BufferError::Input.into());
        }
        check_values(Argument::Weights, weights)?;
        Ok(self
            .jaws
            .as_ref()
            .map_or(crate::jaw::IDENTITY, |j| j.blend(weights)))
    }

    /// The Q16.16 playback cache, when the artefact has one (`sinew bake --q16`).
    pub const fn q16(&self) -> Option<&AimQ16<'a>> {
        self.q16.as_ref()
    }

    /// The networks, unless the artefact is playback-only.
    pub const fn networks(&self) -> Option<&AimNetworks<'a>> {
        self.networks.as_ref()
    }

    /// Poses the actor: AIM eq. 17 with global coefficients, per vertex
    /// `T_g(LBS(s0, T_b, k) + Σ_j w_j e_j)`. The pose's jaw pivot is the actor's
    /// ([`Self::jaw_pivot`]) when built with [`Self::pose_from_9d`].
    ///
    /// # Shapes
    /// - `weights`: `[M]`
    /// - `out`: `[V, 3]`
    ///
    /// # Errors
    /// [`EvalError::Buffer`] for a wrong length; [`EvalError::Input`] for a coefficient that is
    /// not finite or outside ±[`crate::layout::MAX_FACTOR`], or a pose that [`Pose::check`]
    /// refuses. Nothing is written then; accepted inputs always give finite positions.
    pub fn pose(&self, pose: &Pose, weights: &[f32], out: &mut [f32]) -> Result<(), EvalError> {
        self.pose_rest(None, pose, weights, out)
    }

    /// Like [`Self::pose`], but from another neutral skin `rest` (`[V, 3]`), e.g. the result of
    /// [`Self::edit_thickness`], whose values must be finite and within ±[`MAX_COORDINATE`].
    ///
    /// # Errors
    /// As [`Self::pose`], and [`EvalError::Input`] naming `rest`'s value.
    pub fn pose_rest(
        &self,
        rest: Option<&[f32]>,
        pose: &Pose,
        weights: &[f32],
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        if weights.len() != self.shapes || rest.is_some_and(|r| r.len() != 3 * self.vertices) {
            return Err(BufferError::Input.into());
        }
        if out.len() != 3 * self.vertices {
            return Err(BufferError::Output.into());
        }
        check_values(Argument::Weights, weights)?;
        if let Some(r) = rest {
            check_values(Argument::Rest, r)?;
        }
        pose.check()?;
        let per_vertex = 3 * self.shapes;
        for (i, o) in out.chunks_exact_mut(3).enumerate() {
            let s0 = match rest {
                Some(r) => Vec3::new(
                    r.get(3 * i).copied().unwrap_or(0.0),
                    r.get(3 * i + 1).copied().unwrap_or(0.0),
                    r.get(3 * i + 2).copied().unwrap_or(0.0),
                ),
                None => vec3(self.rest, i),
            };
            let e = self.correctives.slice(i * per_vertex, per_vertex);
            let p = skin_vertex(s0, self.k.at(i), e, weights, pose);
            o.copy_from_slice(&p.to_array());
        }
        Ok(())
    }

    /// A pose from AIM's parameters: jaw `[6D rotation, translation]` about the actor's pivot,
    /// head `[6D rotation, translation]`.
    ///
    /// # Errors
    /// [`InputError`] naming [`Argument::Head`] or [`Argument::Jaw`] and the value: every value
    /// must be finite, the rotation's within ±[`crate::layout::MAX_ROTATION_ENTRY`] with columns
    /// at least [`crate::layout::MIN_ROTATION_COLUMN`] long and not parallel
    /// ([`crate::rotation::try_from_6d`]), the translation's within ±[`MAX_COORDINATE`]. The
    /// core refuses such a rotation instead of guessing one.
    pub fn pose_from_9d(&self, jaw: &[f32; 9], head: &[f32; 9]) -> Result<Pose, InputError> {
        Ok(Pose {
            head: crate::rotation::try_rigid_from_9d(head, Argument::Head)?,
            jaw: crate::skinning::BoneTransform::try_from_9d(jaw, self.pivot, Argument::Jaw)?,
        })
    }

    /// Area-weighted vertex normals of posed positions (`[V, 3]` in and out).
    ///
    /// # Errors
    /// [`EvalError::Buffer`] for a wrong length; [`EvalError::Input`] for a position that is NaN
    /// or infinite (finite positions always give finite normals).
    pub fn normals(&self, positions: &[f32], out: &mut [f32]) -> Result<(), EvalError> {
        if positions.len() == 3 * self.vertices {
            check_finite(Argument::Positions, positions)?;
        }
        Ok(vertex_normals(&self.triangles, positions, out)?)
    }

    /// Anatomy editing (AIM Fig. 5): scales the soft-tissue thickness by `1 + (scale − 1)·m_v`
    /// per vertex, `m_v ∈ [0, 1]` from `mask`, and re-derives the neutral skin
    /// s0' = b0 + d0'·n0 (eq. 6). Pose the result with [`Self::pose_rest`].
    ///
    /// # Shapes
    /// - `mask`: `[V]`
    /// - `out`: `[V, 3]`
    ///
    /// # Errors
    /// [`EvalError::Buffer`] for a wrong length; [`EvalError::Input`] for a mask value outside
    /// `[0, 1]` or a scale outside ±[`crate::layout::MAX_FACTOR`] (or either not finite).
    pub fn edit_thickness(
        &self,
        mask: &[f32],
        scale: f32,
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        if mask.len() != self.vertices {
            return Err(BufferError::Input.into());
        }
        if out.len() != 3 * self.vertices {
            return Err(BufferError::Output.into());
        }
        check_values(Argument::Mask, mask)?;
        check_values(Argument::Scale, &[scale])?;
        for (i, (o, m)) in out.chunks_exact_mut(3).zip(mask).enumerate() {
            // AIM eq. 6 with an edited thickness.
            let d = self.thickness.at(i) * (1.0 + (scale - 1.0) * *m);
            let s = vec3(self.bone, i) + vec3(self.normal, i) * d;
            o.copy_from_slice(&s.to_array());
        }
        Ok(())
    }
}

impl AimNetworks<'_> {
    /// Scratch length for [`Self::eval`]: the largest of the five networks' scratch, plus room
    /// for E's outputs.
    pub fn scratch_len(&self) -> usize {
        let nets = [&self.b, &self.d, &self.n, &self.k, &self.e];
        nets.iter().map(|m| m.scratch_len()).max().unwrap_or(0) + self.e.outputs()
    }

    /// Number of corrective outputs 3·M of E.
    pub fn corrective_len(&self) -> usize {
        self.e.outputs()
    }

    /// Evaluates the networks at template point `c` (AIM eqs. 3–8): the anatomy, and the
    /// corrective basis into `correctives` (`[M, 3]`).
    ///
    /// # Errors
    /// [`EvalError::Buffer`] for a wrong length; [`EvalError::Input`] for a coordinate of `c`
    /// that is not finite or outside ±[`MAX_COORDINATE`] (the range the networks were bounded
    /// for at load).
    pub fn eval(
        &self,
        c: Vec3,
        correctives: &mut [f32],
        scratch: &mut [f32],
    ) -> Result<PointAnatomy, EvalError> {
        if correctives.len() != self.e.outputs() {
            return Err(BufferError::Output.into());
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch.into());
        }
        check_values(Argument::Point, &c.to_array())?;
        let x = ((c - self.centre) * (1.0 / self.scale)).to_array();
        let (mut b, mut d, mut n, mut k) = ([0.0f32; 3], [0.0f32; 1], [0.0f32; 3], [0.0f32; 1]);
        self.b.eval(&x, &mut b, scratch)?;
        self.d.eval(&x, &mut d, scratch)?;
        self.n.eval(&x, &mut n, scratch)?;
        self.k.eval(&x, &mut k, scratch)?;
        self.e.eval(&x, correctives, scratch)?;
        let bone = c + Vec3::from_array(b);
        let normal = Vec3::from_array(n).normalize();
        let [raw] = d;
        let thickness = if self.thickness_activation == THICKNESS_SOFTPLUS {
            softplus(raw)
        } else {
            raw
        };
        // AIM eq. 6: s0 = b0 + d0·n0
        let skin = bone + normal * thickness;
        let [k] = k;
        Ok(PointAnatomy {
            bone,
            thickness,
            normal,
            skin,
            k,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn softplus_values() {
        assert_eq!(softplus(0.0), libm::logf(2.0));
        assert_eq!(softplus(25.0), 25.0);
        assert!(softplus(-30.0) > 0.0 && softplus(-30.0) < 1e-12);
        // Continuous at the threshold to f32 precision.
        assert!((softplus(20.0) - 20.0).abs() < 1e-6);
        assert!(softplus(-200.0) >= 0.0);
    }
}
