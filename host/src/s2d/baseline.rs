//! The S2D paper's 3DMM baselines (§4.2, Table 1 "PCA-k"): a PCA model of the training pairs'
//! dense displacements, fitted to a test pair's landmark displacements by ridge least squares,
//! then expanded to a dense displacement.
//!
//! The model is built from the N × 3V matrix of centred training displacements through its N × N
//! Gram matrix (N is a few hundred, 3V about 28,000): `G = X Xᵀ = U Λ Uᵀ`, and the principal
//! directions are `Xᵀ u_i / √λ_i`, unit vectors of displacement space. Component i explains
//! `λ_i / (N − 1)` of the variance.
//!
//! The fit runs in the raw landmark space (template units, no normalisation): a 3DMM deforms the
//! neutral so that its landmarks meet the target ones (the paper: "minimize the Euclidean error
//! between the target landmarks Z^e and the neutral ones Z^n"), and the displacement at the
//! landmark vertices is then exactly `Z^e − Z^n`, the rows of the model's components at those
//! vertices times the coefficients. S2D's normalised input (each set centred and scaled to unit
//! norm) is not linear in the displacement, so a linear model fitted there would mix a global
//! rescaling into every coefficient.

use anyhow::{Result, ensure};
use nalgebra::{DMatrix, DVector};

/// Relative size below which a Gram eigenvalue counts as zero: the Gram matrix sums f32 products
/// in f32 lanes, so its rounding noise reaches about 1e-8 of the largest eigenvalue (measured on
/// the synthetic test), while the smallest genuine direction of ICT pairs (a small shape at a
/// small weight) is far above 1e-6.
const RANK_TOLERANCE: f64 = 1e-6;

/// Default ridge weight, relative to the mean squared norm of the components' landmark rows.
pub const DEFAULT_RIDGE: f64 = 1e-3;

/// A PCA model of dense displacements.
#[derive(Clone, Debug)]
pub struct Pca {
    /// Mean displacement, `[3V]`.
    pub mean: Vec<f32>,
    /// Principal directions, unit length, by decreasing variance, `rank × [3V]`.
    pub components: Vec<Vec<f32>>,
    /// Variance along each component (`λ_i / (N − 1)`).
    pub variances: Vec<f64>,
}

/// `Σ a_i b_i` in f64, over f32 inputs, in blocks (f32 products summed in f64).
fn dot(a: &[f32], b: &[f32]) -> f64 {
    let mut total = 0.0f64;
    for (ca, cb) in a.chunks(256).zip(b.chunks(256)) {
        let mut lanes = [0.0f32; 8];
        let (ha, ta) = ca.split_at(ca.len() / 8 * 8);
        let (hb, tb) = cb.split_at(ha.len());
        for (x, y) in ha.chunks_exact(8).zip(hb.chunks_exact(8)) {
            for k in 0..8 {
                lanes[k] += x[k] * y[k];
            }
        }
        total += lanes.iter().map(|&v| f64::from(v)).sum::<f64>();
        total += ta
            .iter()
            .zip(tb)
            .map(|(&x, &y)| f64::from(x) * f64::from(y))
            .sum::<f64>();
    }
    total
}

impl Pca {
    /// Builds the model from `samples` (each `[3V]`): all components with a non-zero variance.
    pub fn fit(samples: &[&[f32]]) -> Result<Self> {
        let n = samples.len();
        ensure!(n >= 2, "PCA needs at least 2 samples, got {n}");
        let dim = samples[0].len();
        ensure!(
            dim > 0 && samples.iter().all(|s| s.len() == dim),
            "PCA samples must all have the same positive length"
        );
        let mut mean = vec![0.0f64; dim];
        for s in samples {
            for (m, &v) in mean.iter_mut().zip(*s) {
                *m += f64::from(v);
            }
        }
        let mean: Vec<f32> = mean.iter().map(|m| (m / n as f64) as f32).collect();
        let centred: Vec<Vec<f32>> = samples
            .iter()
            .map(|s| s.iter().zip(&mean).map(|(v, m)| v - m).collect())
            .collect();
        let gram = gram(&centred);
        let eig = nalgebra::SymmetricEigen::new(gram);
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let top = eig.eigenvalues[order[0]].max(0.0);
        let mut components = Vec::new();
        let mut variances = Vec::new();
        for &i in &order {
            let lambda = eig.eigenvalues[i];
            if top == 0.0 || lambda <= RANK_TOLERANCE * top {
                break;
            }
            let u = eig.eigenvectors.column(i);
            let mut c = vec![0.0f64; dim];
            for (row, &w) in centred.iter().zip(u.iter()) {
                for (c, &x) in c.iter_mut().zip(row) {
                    *c += w * f64::from(x);
                }
            }
            let scale = 1.0 / lambda.sqrt();
            components.push(c.iter().map(|v| (v * scale) as f32).collect());
            variances.push(lambda / (n - 1) as f64);
        }
        Ok(Self {
            mean,
            components,
            variances,
        })
    }

    /// Number of components with non-zero variance.
    pub fn rank(&self) -> usize {
        self.components.len()
    }

    /// The fewest leading components that explain at least `fraction` of the variance.
    pub fn components_for(&self, fraction: f64) -> usize {
        let total: f64 = self.variances.iter().sum();
        let mut acc = 0.0;
        for (k, v) in self.variances.iter().enumerate() {
            acc += v;
            if acc >= fraction * total {
                return k + 1;
            }
        }
        self.rank()
    }

    /// A fitter that uses the first `k` components and reads the displacement at the vertices
    /// `landmarks` (each `< V`).
    pub fn fitter(&self, k: usize, landmarks: &[u32], ridge: f64) -> Result<Fitter<'_>> {
        ensure!(
            (1..=self.rank()).contains(&k),
            "{k} components asked of a PCA of rank {}",
            self.rank()
        );
        let v = self.mean.len() / 3;
        ensure!(
            landmarks.iter().all(|&l| (l as usize) < v),
            "a landmark vertex is outside the {v} modelled vertices"
        );
        ensure!(ridge >= 0.0, "ridge weight {ridge} is negative");
        let rows = 3 * landmarks.len();
        let b = DMatrix::from_fn(rows, k, |r, c| {
            f64::from(self.components[c][3 * landmarks[r / 3] as usize + r % 3])
        });
        let mut normal = b.transpose() * &b;
        let lambda = ridge * normal.trace() / k as f64;
        for i in 0..k {
            normal[(i, i)] += lambda;
        }
        let solve = normal.cholesky().ok_or_else(|| {
            anyhow::anyhow!(
                "the landmark rows of the first {k} components are rank-deficient; use a \
                 positive ridge"
            )
        })?;
        Ok(Fitter {
            pca: self,
            k,
            landmarks: landmarks.to_vec(),
            b,
            solve,
        })
    }
}

/// `X Xᵀ` of the rows `x`, on all available threads.
fn gram(x: &[Vec<f32>]) -> DMatrix<f64> {
    let n = x.len();
    let threads = std::thread::available_parallelism().map_or(1, usize::from);
    let mut g = DMatrix::zeros(n, n);
    let rows: Vec<Vec<f64>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    // Row i fills columns j ≤ i; rows are dealt round-robin to balance the
                    // triangle.
                    (t..n)
                        .step_by(threads)
                        .map(|i| (0..=i).map(|j| dot(&x[i], &x[j])).collect::<Vec<f64>>())
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        let mut out = vec![Vec::new(); n];
        for (t, h) in handles.into_iter().enumerate() {
            let part = h.join().unwrap_or_default();
            for (k, row) in part.into_iter().enumerate() {
                out[t + k * threads] = row;
            }
        }
        out
    });
    for (i, row) in rows.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            g[(i, j)] = v;
            g[(j, i)] = v;
        }
    }
    g
}

/// A PCA model's first `k` components fitted to landmark displacements.
#[derive(Debug)]
pub struct Fitter<'a> {
    pca: &'a Pca,
    k: usize,
    landmarks: Vec<u32>,
    /// The components' landmark rows, `[3 · landmarks, k]`.
    b: DMatrix<f64>,
    solve: nalgebra::Cholesky<f64, nalgebra::Dyn>,
}

impl Fitter<'_> {
    /// Components used.
    pub fn k(&self) -> usize {
        self.k
    }

    /// The coefficients `c = argmin |B c − (y − μ_L)|² + λ |c|²` for the landmark displacements
    /// `y` (one per landmark, template units).
    pub fn coefficients(&self, landmark_displacement: &[[f32; 3]]) -> Result<Vec<f64>> {
        ensure!(
            landmark_displacement.len() == self.landmarks.len(),
            "{} landmark displacements for {} landmarks",
            landmark_displacement.len(),
            self.landmarks.len()
        );
        let y = DVector::from_fn(self.b.nrows(), |r, _| {
            let l = self.landmarks[r / 3] as usize;
            f64::from(landmark_displacement[r / 3][r % 3]) - f64::from(self.pca.mean[3 * l + r % 3])
        });
        Ok(self
            .solve
            .solve(&(self.b.transpose() * y))
            .iter()
            .copied()
            .collect())
    }

    /// The dense displacement `μ + Σ c_i e_i`, `[3V]`, fitted to `landmark_displacement`.
    pub fn predict(&self, landmark_displacement: &[[f32; 3]]) -> Result<Vec<f32>> {
        let c = self.coefficients(landmark_displacement)?;
        let mut out: Vec<f64> = self.pca.mean.iter().map(|&m| f64::from(m)).collect();
        for (ci, e) in c.iter().zip(&self.pca.components) {
            for (o, &x) in out.iter_mut().zip(e) {
                *o += ci * f64::from(x);
            }
        }
        Ok(out.iter().map(|&v| v as f32).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s2d::synthetic::Rng;

    /// Samples `mean + Σ_i a_i b_i` over a known basis of 3 directions in a space of 40 vertices
    /// (120 values), with the landmarks at 12 of the vertices.
    fn low_rank(n: usize, rng: &mut Rng) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
        let basis: Vec<Vec<f32>> = (0..3)
            .map(|_| (0..120).map(|_| rng.uniform(-1.0, 1.0)).collect())
            .collect();
        let mean: Vec<f32> = (0..120).map(|_| rng.uniform(-0.2, 0.2)).collect();
        let samples = (0..n)
            .map(|_| {
                let a: Vec<f32> = (0..3).map(|_| rng.uniform(-2.0, 2.0)).collect();
                (0..120)
                    .map(|j| mean[j] + (0..3).map(|i| a[i] * basis[i][j]).sum::<f32>())
                    .collect()
            })
            .collect();
        (samples, basis)
    }

    #[test]
    fn known_low_rank_basis_is_recovered() {
        let mut rng = Rng::new(11);
        let (samples, basis) = low_rank(30, &mut rng);
        let refs: Vec<&[f32]> = samples.iter().map(Vec::as_slice).collect();
        let pca = Pca::fit(&refs).unwrap();
        assert_eq!(pca.rank(), 3, "variances {:?}", pca.variances);
        assert!(pca.variances.windows(2).all(|w| w[0] >= w[1]));
        // Every basis vector lies in the span of the components.
        for b in &basis {
            let norm2: f64 = dot(b, b);
            let proj2: f64 = pca.components.iter().map(|c| dot(b, c).powi(2)).sum();
            assert!((proj2 / norm2 - 1.0).abs() < 1e-5, "{}", proj2 / norm2);
        }
        // Orthonormal components.
        for (i, a) in pca.components.iter().enumerate() {
            for (j, c) in pca.components.iter().enumerate() {
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((dot(a, c) - want).abs() < 1e-4);
            }
        }
        // A new sample in the span is recovered from its landmark rows alone.
        let (test, _) = {
            let mut rng2 = Rng::new(11);
            low_rank(31, &mut rng2)
        };
        let target = &test[30];
        let landmarks: Vec<u32> = (0..40).step_by(3).map(|v| v as u32).collect();
        let y: Vec<[f32; 3]> = landmarks
            .iter()
            .map(|&l| {
                let l = 3 * l as usize;
                [target[l], target[l + 1], target[l + 2]]
            })
            .collect();
        let fit = pca.fitter(3, &landmarks, 1e-9).unwrap();
        let dense = fit.predict(&y).unwrap();
        let err = dense
            .iter()
            .zip(target)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(err < 1e-3, "max error {err}");
        // One component explains less, and fits worse.
        let one = pca
            .fitter(1, &landmarks, 1e-9)
            .unwrap()
            .predict(&y)
            .unwrap();
        let err1 = one
            .iter()
            .zip(target)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(err1 > 10.0 * err.max(1e-4), "{err1} vs {err}");
        assert!(pca.components_for(0.5) <= pca.components_for(0.99));
        assert_eq!(pca.components_for(1.0), 3);
        assert!(pca.fitter(4, &landmarks, 1e-3).is_err());
        assert!(pca.fitter(2, &[40], 1e-3).is_err());
        assert!(fit.predict(&y[1..]).is_err());
        assert!(Pca::fit(&refs[..1]).is_err());
    }
}
