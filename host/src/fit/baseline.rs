//! The blendshape baselines of AIM's Table 1, fitted to a performance's meshes: global
//! blendshapes (GBS, Lewis et al.) and patch-based local blendshapes (PBS, after Chaudhuri et
//! al.), both built from the actor's own training shapes (the kit's neutral and the shapes the
//! baked actor records in its `shapes` metadata, at the performance's vertices).
//!
//! - GBS: `x = R (n + Σ_i w_i d_i) + t`; alternates a rigid alignment (Horn) of the current
//!   shape to the target with the least-squares weights in the aligned frame.
//! - PBS: the same rigid alignment, then one weight vector per patch: patches are the cells of a
//!   grid over the neutral's front view (x, y), overlapping through smooth partition-of-unity
//!   weights `φ_p(v) = g_p(v) / Σ_q g_q(v)`, `g_p = exp(−|c_v − c_p|² / 2σ²)` (σ = 0.6 of a
//!   cell); each patch's weights minimise `Σ_v φ_p(v) |D_v w_p − r_v|²`, and the shape is the
//!   blend `n_v + Σ_p φ_p(v) D_v w_p`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::geometry::align::{RigidFit, fit_rigid};
use crate::io::ict::{DEFAULT_SHAPES, FACE_REGION, IctError, IctFaceKit};
use crate::io::performance::Performance;
use crate::io::units::Unit;

/// Most alternations of rigid alignment and least squares per frame for GBS, which stops
/// earlier once no weight changes by more than [`CONVERGED`].
pub const ALTERNATIONS: usize = 100;
/// GBS's stopping threshold on the weights' largest change between alternations.
pub const CONVERGED: f64 = 1e-7;
/// Alternations of rigid alignment and per-patch least squares for PBS, after GBS's fit.
pub const PATCH_ALTERNATIONS: usize = 5;
/// Patch grid of PBS over the neutral's front view (columns, rows).
pub const PATCH_GRID: [usize; 2] = [4, 4];

/// A baseline fit that could not be set up or run; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BaselineError {
    /// An actor file that is not a `.sinew` artefact.
    #[error("{}: invalid .sinew file", path.display())]
    NotASinewFile {
        /// The actor file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: sinew_core::error::FormatError,
    },
    /// An actor whose `shapes` metadata does not start with the neutral.
    #[error("{}: the shapes metadata must start with the neutral, not {first:?}", path.display())]
    ShapesMetadata {
        /// The actor file.
        path: PathBuf,
        /// The first name it lists.
        first: Option<String>,
    },
    /// The ICT-FaceKit folder a performance was made from cannot give the actor's shapes.
    #[error("{}: the performance's ICT-FaceKit folder", path.display())]
    Kit {
        /// The performance's manifest, which names the folder.
        path: PathBuf,
        /// What the kit reader said.
        #[source]
        source: IctError,
    },
    /// A frame the fit cannot align to.
    #[error("{}", path.display())]
    Frame {
        /// The frame's mesh.
        path: PathBuf,
        /// Why.
        #[source]
        source: NoRigidAlignment,
    },
}

/// A target frame that no rigid motion aligns the model to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("no rigid alignment (degenerate or non-finite target)")]
pub struct NoRigidAlignment;

/// The actor's training shapes at a performance's vertices.
#[derive(Clone, Debug)]
pub struct Basis {
    /// The shape names, neutral first.
    pub names: Vec<String>,
    /// The neutral, `[V]`.
    pub neutral: Vec<[f64; 3]>,
    /// The deltas (shape − neutral), `[M][V]`.
    pub deltas: Vec<Vec<[f64; 3]>>,
}

/// The shape names a baked actor was trained on (its `shapes` metadata, neutral first), or the
/// default ICT actor's when it records none.
pub fn actor_shape_names(model: &Path, bytes: &[u8]) -> Result<Vec<String>, BaselineError> {
    let file = sinew_core::SinewFile::from_bytes(bytes).map_err(|source| {
        BaselineError::NotASinewFile {
            path: model.to_owned(),
            source,
        }
    })?;
    let names: Vec<String> = match file.metadata().get("shapes") {
        Some(list) => list.split(',').map(str::to_owned).collect(),
        None => std::iter::once("neutral")
            .chain(DEFAULT_SHAPES)
            .map(str::to_owned)
            .collect(),
    };
    if names.first().map(String::as_str) != Some("neutral") {
        return Err(BaselineError::ShapesMetadata {
            path: model.to_owned(),
            first: names.first().cloned(),
        });
    }
    Ok(names)
}

impl Basis {
    /// The kit's shapes `names` (neutral first) at the performance's vertices, read from the
    /// kit folder the performance was made from.
    pub fn of_performance(perf: &Performance, names: &[String]) -> Result<Self, BaselineError> {
        let kit_error = |source| BaselineError::Kit {
            path: perf.dir.join(crate::io::performance::MANIFEST),
            source,
        };
        let kit = IctFaceKit::open(&perf.manifest.data).map_err(kit_error)?;
        let expressions: Vec<&str> = names.iter().skip(1).map(String::as_str).collect();
        let actor = kit
            .actor(&[], &expressions, FACE_REGION)
            .map_err(kit_error)?;
        let pick = |s: &[[f32; 3]]| -> Vec<[f64; 3]> {
            perf.manifest
                .kit_vertices
                .iter()
                .map(|&v| s[v as usize].map(f64::from))
                .collect()
        };
        let neutral = pick(&actor.shapes[0]);
        let deltas = actor.shapes[1..]
            .iter()
            .map(|s| {
                pick(s)
                    .iter()
                    .zip(&neutral)
                    .map(|(p, n)| [p[0] - n[0], p[1] - n[1], p[2] - n[2]])
                    .collect()
            })
            .collect();
        Ok(Self {
            names: names.to_vec(),
            neutral,
            deltas,
        })
    }

    fn shapes(&self) -> usize {
        self.deltas.len()
    }

    /// `Σ_v φ(v) D_vᵀ D_v` (M × M), with a small ridge for conditioning.
    fn gram(&self, phi: &[f64]) -> DMatrix<f64> {
        let m = self.shapes();
        let mut g = DMatrix::from_fn(m, m, |i, j| {
            (0..phi.len())
                .map(|v| phi[v] * dot(self.deltas[i][v], self.deltas[j][v]))
                .sum::<f64>()
        });
        let ridge = 1e-9 * g.trace().max(1e-30) / m.max(1) as f64;
        for i in 0..m {
            g[(i, i)] += ridge;
        }
        g
    }

    /// The weights minimising `Σ_v φ(v) |D_v w − r_v|²`.
    fn solve(&self, gram: &DMatrix<f64>, phi: &[f64], residual: &[[f64; 3]]) -> DVector<f64> {
        let rhs = DVector::from_fn(self.shapes(), |i, _| {
            (0..phi.len())
                .map(|v| phi[v] * dot(self.deltas[i][v], residual[v]))
                .sum()
        });
        gram.clone()
            .cholesky()
            .map_or_else(|| DVector::zeros(self.shapes()), |c| c.solve(&rhs))
    }

    /// `n_v + Σ_i w_i D_v,i` at every vertex.
    fn shape(&self, w: &DVector<f64>) -> Vec<[f64; 3]> {
        self.neutral
            .iter()
            .enumerate()
            .map(|(v, n)| {
                let mut x = *n;
                for (d, wi) in self.deltas.iter().zip(w.iter()) {
                    x = [
                        x[0] + wi * d[v][0],
                        x[1] + wi * d[v][1],
                        x[2] + wi * d[v][2],
                    ];
                }
                x
            })
            .collect()
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `Rᵀ (y − t)`: a target point in the model's frame.
fn unrigid(r: &RigidFit, y: [f64; 3]) -> [f64; 3] {
    let d = [
        y[0] - r.translation[0],
        y[1] - r.translation[1],
        y[2] - r.translation[2],
    ];
    let m = r.rotation;
    [0, 1, 2].map(|j| m[0][j] * d[0] + m[1][j] * d[1] + m[2][j] * d[2])
}

fn to32(p: &[[f64; 3]]) -> Vec<[f32; 3]> {
    p.iter().map(|x| x.map(|c| c as f32)).collect()
}

/// A blendshape model fitted frame by frame.
pub trait Blendshapes {
    /// Fits one target frame; returns the fitted positions `[V]`.
    fn fit_frame(&self, target: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NoRigidAlignment>;
}

/// Global blendshapes.
#[derive(Debug)]
pub struct Gbs {
    basis: Basis,
    gram: DMatrix<f64>,
}

impl Gbs {
    /// GBS over `basis`.
    pub fn new(basis: Basis) -> Self {
        let gram = basis.gram(&vec![1.0; basis.neutral.len()]);
        Self { basis, gram }
    }

    /// The weights and the rigid alignment for `target`.
    fn fit(&self, target: &[[f32; 3]]) -> Result<(DVector<f64>, RigidFit), NoRigidAlignment> {
        let b = &self.basis;
        let ones = vec![1.0; b.neutral.len()];
        let mut w = DVector::zeros(b.shapes());
        let mut shape = b.neutral.clone();
        let mut rigid = None;
        for _ in 0..ALTERNATIONS {
            let r = fit_rigid(&to32(&shape), target).ok_or(NoRigidAlignment)?;
            let residual: Vec<[f64; 3]> = target
                .iter()
                .zip(&b.neutral)
                .map(|(y, n)| {
                    let x = unrigid(&r, y.map(f64::from));
                    [x[0] - n[0], x[1] - n[1], x[2] - n[2]]
                })
                .collect();
            let next = b.solve(&self.gram, &ones, &residual);
            let change = (&next - &w).amax();
            w = next;
            shape = b.shape(&w);
            rigid = Some(r);
            if change < CONVERGED {
                break;
            }
        }
        let r = fit_rigid(&to32(&shape), target)
            .or(rigid)
            .ok_or(NoRigidAlignment)?;
        Ok((w, r))
    }
}

impl Blendshapes for Gbs {
    fn fit_frame(&self, target: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NoRigidAlignment> {
        let (w, r) = self.fit(target)?;
        Ok(self
            .basis
            .shape(&w)
            .iter()
            .map(|&x| r.apply(x).map(|c| c as f32))
            .collect())
    }
}

/// Patch-based local blendshapes.
#[derive(Debug)]
pub struct Pbs {
    global: Gbs,
    /// `φ_p(v)`, `[P][V]`.
    phi: Vec<Vec<f64>>,
    grams: Vec<DMatrix<f64>>,
}

impl Pbs {
    /// PBS over `basis` with a `grid[0] × grid[1]` patch grid.
    pub fn new(basis: Basis, grid: [usize; 2]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &basis.neutral {
            for c in 0..2 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let cell = [0, 1].map(|c| (hi[c] - lo[c]) / grid[c].max(1) as f64);
        let sigma = 0.6 * cell[0].max(cell[1]);
        let centres: Vec<[f64; 2]> = (0..grid[1])
            .flat_map(|j| {
                (0..grid[0]).map(move |i| {
                    [
                        lo[0] + (i as f64 + 0.5) * cell[0],
                        lo[1] + (j as f64 + 0.5) * cell[1],
                    ]
                })
            })
            .collect();
        let mut phi = vec![vec![0.0; basis.neutral.len()]; centres.len()];
        for (v, p) in basis.neutral.iter().enumerate() {
            let g: Vec<f64> = centres
                .iter()
                .map(|c| {
                    let d2 = (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2);
                    (-d2 / (2.0 * sigma * sigma)).exp()
                })
                .collect();
            let sum: f64 = g.iter().sum();
            for (patch, gp) in phi.iter_mut().zip(&g) {
                patch[v] = gp / sum;
            }
        }
        let grams = phi.iter().map(|f| basis.gram(f)).collect();
        Self {
            global: Gbs::new(basis),
            phi,
            grams,
        }
    }
}

impl Blendshapes for Pbs {
    fn fit_frame(&self, target: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, NoRigidAlignment> {
        let b = &self.global.basis;
        let (_, mut r) = self.global.fit(target)?;
        let mut shape = Vec::new();
        for _ in 0..PATCH_ALTERNATIONS {
            let residual: Vec<[f64; 3]> = target
                .iter()
                .zip(&b.neutral)
                .map(|(y, n)| {
                    let x = unrigid(&r, y.map(f64::from));
                    [x[0] - n[0], x[1] - n[1], x[2] - n[2]]
                })
                .collect();
            shape = b.neutral.clone();
            for (phi, gram) in self.phi.iter().zip(&self.grams) {
                let w = b.solve(gram, phi, &residual);
                for (v, x) in shape.iter_mut().enumerate() {
                    for (d, wi) in b.deltas.iter().zip(w.iter()) {
                        let s = phi[v] * wi;
                        x[0] += s * d[v][0];
                        x[1] += s * d[v][1];
                        x[2] += s * d[v][2];
                    }
                }
            }
            r = fit_rigid(&to32(&shape), target).ok_or(NoRigidAlignment)?;
        }
        Ok(shape
            .iter()
            .map(|&x| r.apply(x).map(|c| c as f32))
            .collect())
    }
}

/// One method's fit of a performance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodResult {
    /// Mean per-vertex distance to the performance's meshes over all frames, in mm.
    pub mean_error_mm: f64,
    /// The same per frame.
    pub frame_error_mm: Vec<f64>,
    /// Wall-clock seconds per frame of the fit.
    pub seconds_per_frame: f64,
}

/// Mean per-vertex distance of `fit` to `target`, in mm.
pub fn mean_error_mm(fit: &[[f32; 3]], target: &[[f32; 3]], unit: Unit) -> f64 {
    let sum: f64 = fit
        .iter()
        .zip(target)
        .map(|(a, b)| {
            (0..3)
                .map(|c| (f64::from(a[c]) - f64::from(b[c])).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .sum();
    sum / fit.len().max(1) as f64 * unit.mm()
}

/// The unit of a performance's meshes.
/// Fitted positions per frame, `[J][V]`.
pub type FittedMeshes = Vec<Vec<[f32; 3]>>;

/// Fits every frame of `perf` with `model`; the fitted meshes and the errors.
pub fn fit_performance(
    model: &dyn Blendshapes,
    perf: &Performance,
) -> Result<(FittedMeshes, MethodResult), BaselineError> {
    let unit = perf.unit;
    let start = Instant::now();
    let fits = perf
        .frames
        .iter()
        .enumerate()
        .map(|(f, target)| {
            model
                .fit_frame(target)
                .map_err(|source| BaselineError::Frame {
                    path: perf.frame_path(f),
                    source,
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let seconds = start.elapsed().as_secs_f64();
    let frame_error_mm: Vec<f64> = fits
        .iter()
        .zip(&perf.frames)
        .map(|(a, b)| mean_error_mm(a, b, unit))
        .collect();
    let n = frame_error_mm.len().max(1) as f64;
    Ok((
        fits,
        MethodResult {
            mean_error_mm: frame_error_mm.iter().sum::<f64>() / n,
            frame_error_mm,
            seconds_per_frame: seconds / n,
        },
    ))
}

#[cfg(test)]
mod tests;
