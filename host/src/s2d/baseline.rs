//! The S2D paper's 3DMM baselines (§4.2, Table 1 "PCA-k" and "DL-3DMM"): a PCA model of the
//! training pairs' dense displacements, or a dictionary of sparse-coded atoms learned in its
//! coordinates ([`Dictionary`]), fitted to a test pair's landmark displacements by ridge least
//! squares, then expanded to a dense displacement.
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

use nalgebra::{DMatrix, DVector};

mod error;
pub use error::BaselineModelError;

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
    /// Each training sample's centred displacement in the components' coordinates,
    /// `N × rank` (`√λ_i · u_i[n]`: exact, the components span every centred sample).
    pub scores: Vec<Vec<f64>>,
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
    pub fn fit(samples: &[&[f32]]) -> Result<Self, BaselineModelError> {
        let n = samples.len();
        if n < 2 {
            return Err(BaselineModelError::TooFewSamples { got: n });
        }
        let dim = samples[0].len();
        if dim == 0 || samples.iter().any(|s| s.len() != dim) {
            return Err(BaselineModelError::SampleLengths);
        }
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
        let mut scores = vec![Vec::new(); n];
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
            for (s, &w) in scores.iter_mut().zip(u.iter()) {
                s.push(lambda.sqrt() * w);
            }
        }
        Ok(Self {
            mean,
            components,
            variances,
            scores,
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
    pub fn fitter(
        &self,
        k: usize,
        landmarks: &[u32],
        ridge: f64,
    ) -> Result<Fitter<'_>, BaselineModelError> {
        if !(1..=self.rank()).contains(&k) {
            return Err(BaselineModelError::Components {
                k,
                rank: self.rank(),
            });
        }
        let b = self.landmark_rows(landmarks)?.columns(0, k).into_owned();
        Fitter::new(self, landmarks, b, &vec![1.0; k], None, ridge)
    }

    /// The rows of every component at the vertices `landmarks`, `[3 · landmarks, rank]`.
    fn landmark_rows(&self, landmarks: &[u32]) -> Result<DMatrix<f64>, BaselineModelError> {
        let v = self.mean.len() / 3;
        if landmarks.iter().any(|&l| l as usize >= v) {
            return Err(BaselineModelError::LandmarkOutside { vertices: v });
        }
        Ok(DMatrix::from_fn(
            3 * landmarks.len(),
            self.rank(),
            |r, c| f64::from(self.components[c][3 * landmarks[r / 3] as usize + r % 3]),
        ))
    }

    /// The orthogonal projection of the displacement `sample` (`[3V]`) onto the model's affine
    /// span, `μ + Σ ((x − μ)·e_i) e_i`: the closest displacement any combination of the
    /// components can give.
    pub fn project(&self, sample: &[f32]) -> Result<Vec<f32>, BaselineModelError> {
        if sample.len() != self.mean.len() {
            return Err(BaselineModelError::SampleLength {
                found: sample.len(),
                expected: self.mean.len(),
            });
        }
        let centred: Vec<f32> = sample.iter().zip(&self.mean).map(|(x, m)| x - m).collect();
        let w: Vec<f64> = self.components.iter().map(|e| dot(&centred, e)).collect();
        Ok(self.expand(&w))
    }

    /// The dense displacement `μ + Σ w_i e_i`, `[3V]`, of the coordinates `w` (at most `rank`).
    fn expand(&self, w: &[f64]) -> Vec<f32> {
        let mut out: Vec<f64> = self.mean.iter().map(|&m| f64::from(m)).collect();
        for (wi, e) in w.iter().zip(&self.components) {
            for (o, &x) in out.iter_mut().zip(e) {
                *o += wi * f64::from(x);
            }
        }
        out.iter().map(|&v| v as f32).collect()
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

/// A linear model of dense displacements (a PCA's leading components, or a dictionary's atoms)
/// fitted to landmark displacements by ridge least squares.
#[derive(Debug)]
pub struct Fitter<'a> {
    pca: &'a Pca,
    landmarks: Vec<u32>,
    /// The model's landmark rows, `[3 · landmarks, k]`.
    b: DMatrix<f64>,
    solve: nalgebra::Cholesky<f64, nalgebra::Dyn>,
    /// From the fit's coefficients to the PCA's coordinates (`[rank, k]`); none when the
    /// coefficients are the first `k` PCA coordinates themselves.
    to_pca: Option<DMatrix<f64>>,
}

impl<'a> Fitter<'a> {
    /// Solves `min |B c − y|² + λ Σ_i p_i c_i²` with `λ = ridge · trace(BᵀB) / k` and the
    /// relative penalties `p` (`1` for a plain ridge).
    fn new(
        pca: &'a Pca,
        landmarks: &[u32],
        b: DMatrix<f64>,
        penalty: &[f64],
        to_pca: Option<DMatrix<f64>>,
        ridge: f64,
    ) -> Result<Self, BaselineModelError> {
        if ridge.is_nan() || ridge < 0.0 {
            return Err(BaselineModelError::NegativeRidge(ridge));
        }
        let k = b.ncols();
        let mut normal = b.transpose() * &b;
        let lambda = ridge * normal.trace() / k as f64;
        for (i, p) in penalty.iter().enumerate() {
            normal[(i, i)] += lambda * p;
        }
        let solve = normal
            .cholesky()
            .ok_or(BaselineModelError::RankDeficient { k })?;
        Ok(Self {
            pca,
            landmarks: landmarks.to_vec(),
            b,
            solve,
            to_pca,
        })
    }

    /// Components (or atoms) used.
    pub fn k(&self) -> usize {
        self.b.ncols()
    }

    /// The coefficients `c = argmin |B c − (y − μ_L)|² + λ Σ p_i c_i²` for the landmark
    /// displacements `y` (one per landmark, template units).
    pub fn coefficients(
        &self,
        landmark_displacement: &[[f32; 3]],
    ) -> Result<Vec<f64>, BaselineModelError> {
        if landmark_displacement.len() != self.landmarks.len() {
            return Err(BaselineModelError::LandmarkCount {
                found: landmark_displacement.len(),
                expected: self.landmarks.len(),
            });
        }
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

    /// The dense displacement, `[3V]`, fitted to `landmark_displacement`.
    pub fn predict(
        &self,
        landmark_displacement: &[[f32; 3]],
    ) -> Result<Vec<f32>, BaselineModelError> {
        let c = self.coefficients(landmark_displacement)?;
        Ok(match &self.to_pca {
            Some(a) => self.pca.expand((a * DVector::from_vec(c)).as_slice()),
            None => self.pca.expand(&c),
        })
    }
}

/// Settings of the DL-3DMM dictionary ([`Dictionary::learn`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DictionaryConfig {
    /// Atoms (the paper's DL-3DMM: 220); at most one per training sample is used.
    pub atoms: usize,
    /// Weight of the codes' L1 norm, relative to the root-mean-square norm of the centred
    /// training displacements.
    pub sparsity: f64,
    /// Alternations of sparse coding and dictionary update.
    pub iterations: usize,
}

impl Default for DictionaryConfig {
    fn default() -> Self {
        Self {
            atoms: 220,
            sparsity: 0.1,
            iterations: 30,
        }
    }
}

/// Coordinate-descent sweeps of one sparse code at most.
const LASSO_SWEEPS: usize = 500;

/// A sparse code has converged when no coefficient moved by more than this share of the
/// largest correlation in a sweep.
const LASSO_TOLERANCE: f64 = 1e-10;

/// The DL-3DMM of Ferrari et al. (S2D's reference \[20\]): a dictionary of displacement atoms
/// learned with sparse codes, fitted to landmarks by ridge regression weighted by how much each
/// atom is used.
///
/// Learning alternates, as in Mairal et al.'s dictionary learning, the sparse codes
/// `α_n = argmin ½|z_n − D α|² + λ|α|₁` (coordinate descent over the atoms' Gram matrix) with a
/// block-coordinate update of the atoms under `|d_j| ≤ 1`; an atom no code uses is re-seeded with
/// the worst-represented sample's residual. It runs in the PCA's coordinates (`Pca::scores`):
/// the components are orthonormal and span every centred training displacement, so norms and
/// products there are those of displacement space, and an atom costs `rank` numbers instead of
/// `3V`. Everything is in f64 in a fixed order: the same samples give the same dictionary.
#[derive(Clone, Debug)]
pub struct Dictionary {
    /// The atoms in the PCA's coordinates, `[rank, atoms]`, each of norm at most 1.
    pub atoms: DMatrix<f64>,
    /// Each atom's mean squared code over the training samples (0 for an unused atom).
    pub code_power: Vec<f64>,
    /// Mean number of non-zero codes per training sample.
    pub mean_nonzeros: f64,
    /// `Σ_n ½|z_n − D α_n|² + λ|α_n|₁` after each sparse coding.
    pub objective: Vec<f64>,
}

/// `sign(x) · max(|x| − t, 0)`.
fn soft_threshold(x: f64, t: f64) -> f64 {
    if x > t {
        x - t
    } else if x < -t {
        x + t
    } else {
        0.0
    }
}

/// `α = argmin ½ αᵀ G α − cᵀ α + λ|α|₁` by cyclic coordinate descent, from the start `alpha`.
fn lasso(gram: &DMatrix<f64>, c: &[f64], lambda: f64, alpha: &mut [f64]) {
    let k = c.len();
    let mut q = vec![0.0f64; k];
    for (j, &a) in alpha.iter().enumerate() {
        if a != 0.0 {
            for (q, &g) in q.iter_mut().zip(gram.column(j).iter()) {
                *q += a * g;
            }
        }
    }
    let scale = c.iter().fold(0.0f64, |m, &x| m.max(x.abs()));
    for _ in 0..LASSO_SWEEPS {
        let mut moved = 0.0f64;
        for j in 0..k {
            let g = gram[(j, j)];
            let new = if g > 0.0 {
                soft_threshold(c[j] - q[j] + g * alpha[j], lambda) / g
            } else {
                0.0
            };
            let delta = new - alpha[j];
            if delta != 0.0 {
                for (q, &g) in q.iter_mut().zip(gram.column(j).iter()) {
                    *q += delta * g;
                }
                alpha[j] = new;
                moved = moved.max(delta.abs());
            }
        }
        if moved <= LASSO_TOLERANCE * scale {
            break;
        }
    }
}

/// Sparse codes of the samples `z` (columns) over the atoms `d`, warm-started from `codes`;
/// returns the learning objective.
fn sparse_codes(d: &DMatrix<f64>, z: &DMatrix<f64>, lambda: f64, codes: &mut DMatrix<f64>) -> f64 {
    let gram = d.transpose() * d;
    let c = d.transpose() * z;
    for i in 0..z.ncols() {
        let mut alpha: Vec<f64> = codes.column(i).iter().copied().collect();
        lasso(&gram, c.column(i).as_slice(), lambda, &mut alpha);
        codes.set_column(i, &DVector::from_vec(alpha));
    }
    0.5 * (z - d * &*codes).norm_squared() + lambda * codes.iter().map(|a| a.abs()).sum::<f64>()
}

impl Dictionary {
    /// Learns the dictionary of the training samples behind `pca`.
    pub fn learn(pca: &Pca, config: &DictionaryConfig) -> Result<Self, BaselineModelError> {
        let n = pca.scores.len();
        let r = pca.rank();
        if config.atoms == 0 {
            return Err(BaselineModelError::NoAtoms);
        }
        if !(config.sparsity.is_finite() && config.sparsity >= 0.0) {
            return Err(BaselineModelError::Sparsity(config.sparsity));
        }
        if r == 0 {
            return Err(BaselineModelError::EmptyPca);
        }
        let z = DMatrix::from_fn(r, n, |c, i| pca.scores[i][c]);
        let k = config.atoms.min(n);
        let lambda = config.sparsity * (z.norm_squared() / n as f64).sqrt();
        // Start from evenly spaced samples.
        let mut d = DMatrix::zeros(r, k);
        for j in 0..k {
            let s = z.column(j * n / k);
            let norm = s.norm();
            if norm > 0.0 {
                d.set_column(j, &(s / norm));
            }
        }
        let mut codes = DMatrix::zeros(k, n);
        let mut objective = Vec::with_capacity(config.iterations + 1);
        for _ in 0..config.iterations {
            objective.push(sparse_codes(&d, &z, lambda, &mut codes));
            let a = &codes * codes.transpose();
            let b = &z * codes.transpose();
            let mut unused = Vec::new();
            for j in 0..k {
                let ajj = a[(j, j)];
                if ajj <= 0.0 {
                    unused.push(j);
                    continue;
                }
                let u = d.column(j) + (b.column(j) - &d * a.column(j)) / ajj;
                let norm = u.norm();
                d.set_column(j, &(u / norm.max(1.0)));
            }
            if !unused.is_empty() {
                let residual = &z - &d * &codes;
                let norms: Vec<f64> = residual.column_iter().map(|c| c.norm()).collect();
                let mut worst: Vec<usize> = (0..n).collect();
                worst.sort_by(|&a, &b| norms[b].total_cmp(&norms[a]).then(a.cmp(&b)));
                for (&j, &i) in unused.iter().zip(&worst) {
                    if norms[i] > 0.0 {
                        d.set_column(j, &(residual.column(i) / norms[i]));
                        codes.row_mut(j).fill(0.0);
                    }
                }
            }
        }
        objective.push(sparse_codes(&d, &z, lambda, &mut codes));
        let code_power = codes
            .row_iter()
            .map(|row| row.norm_squared() / n as f64)
            .collect();
        let mean_nonzeros = codes.iter().filter(|&&a| a != 0.0).count() as f64 / n as f64;
        Ok(Self {
            atoms: d,
            code_power,
            mean_nonzeros,
            objective,
        })
    }

    /// Atoms the training codes use (the others are left out of the fit).
    pub fn used(&self) -> usize {
        self.code_power.iter().filter(|&&p| p > 0.0).count()
    }

    /// A fitter over the used atoms, reading the displacement at the vertices `landmarks`: the
    /// coefficients minimise `|B α − (y − μ_L)|² + λ Σ_j (p̄ / p_j) α_j²`, a ridge whose weight
    /// on atom j is the inverse of its mean squared training code `p_j` (relative to their mean
    /// `p̄`), so an atom the training samples use little is held near zero.
    pub fn fitter<'a>(
        &self,
        pca: &'a Pca,
        landmarks: &[u32],
        ridge: f64,
    ) -> Result<Fitter<'a>, BaselineModelError> {
        if self.atoms.nrows() != pca.rank() {
            return Err(BaselineModelError::Coordinates {
                dictionary: self.atoms.nrows(),
                pca: pca.rank(),
            });
        }
        let used: Vec<usize> = (0..self.code_power.len())
            .filter(|&j| self.code_power[j] > 0.0)
            .collect();
        if used.is_empty() {
            return Err(BaselineModelError::NoAtomUsed);
        }
        let a = DMatrix::from_fn(pca.rank(), used.len(), |row, c| self.atoms[(row, used[c])]);
        let b = pca.landmark_rows(landmarks)? * &a;
        let mean = used.iter().map(|&j| self.code_power[j]).sum::<f64>() / used.len() as f64;
        let penalty: Vec<f64> = used.iter().map(|&j| mean / self.code_power[j]).collect();
        Fitter::new(pca, landmarks, b, &penalty, Some(a), ridge)
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

    /// Every third of the 40 test vertices as landmarks, and `sample`'s displacement there.
    fn every_third_vertex(sample: &[f32]) -> (Vec<u32>, Vec<[f32; 3]>) {
        let landmarks: Vec<u32> = (0..40).step_by(3).map(|v| v as u32).collect();
        let y = landmarks
            .iter()
            .map(|&l| {
                let l = 3 * l as usize;
                [sample[l], sample[l + 1], sample[l + 2]]
            })
            .collect();
        (landmarks, y)
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
        let (landmarks, y) = every_third_vertex(target);
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
        // A sample in the span projects onto itself; one off it loses exactly its off-span part.
        let back = pca.project(target).unwrap();
        assert!(back.iter().zip(target).all(|(a, b)| (a - b).abs() < 1e-4));
        let off: Vec<f32> = (0..120).map(|j| if j == 7 { 1.0 } else { 0.0 }).collect();
        let off_in_span: Vec<f32> = {
            let p = pca.project(
                &off.iter()
                    .zip(&pca.mean)
                    .map(|(o, m)| o + m)
                    .collect::<Vec<_>>(),
            );
            p.unwrap()
                .iter()
                .zip(&pca.mean)
                .map(|(p, m)| p - m)
                .collect()
        };
        let in_span: f64 = pca.components.iter().map(|c| dot(&off, c).powi(2)).sum();
        assert!(
            (dot(&off_in_span, &off_in_span) - in_span).abs() < 1e-5,
            "{in_span}"
        );
        for c in &pca.components {
            assert!((dot(&off_in_span, c) - dot(&off, c)).abs() < 1e-5);
        }
        let (n, short) = (target.len(), pca.project(&target[1..]));
        let expected = BaselineModelError::SampleLength {
            found: n - 1,
            expected: n,
        };
        assert_eq!(short, Err(expected));
        assert!(pca.components_for(0.5) <= pca.components_for(0.99));
        assert_eq!(pca.components_for(1.0), 3);
        assert!(matches!(
            pca.fitter(4, &landmarks, 1e-3),
            Err(BaselineModelError::Components { k: 4, rank: 3 })
        ));
        assert!(matches!(
            pca.fitter(2, &[40], 1e-3),
            Err(BaselineModelError::LandmarkOutside { .. })
        ));
        let e = fit.predict(&y[1..]).unwrap_err();
        assert!(matches!(e, BaselineModelError::LandmarkCount { .. }));
        assert!(matches!(
            Pca::fit(&refs[..1]),
            Err(BaselineModelError::TooFewSamples { got: 1 })
        ));
    }

    /// Samples that each combine one or two of 6 known unit atoms (signed weights of size 0.5
    /// to 2) over 40 vertices (120 values).
    fn sparse_samples(n: usize, rng: &mut Rng) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
        let atoms: Vec<Vec<f32>> = (0..6)
            .map(|_| {
                let a: Vec<f32> = (0..120).map(|_| rng.uniform(-1.0, 1.0)).collect();
                let norm = dot(&a, &a).sqrt() as f32;
                a.iter().map(|x| x / norm).collect()
            })
            .collect();
        let weight = |rng: &mut Rng| {
            let w = rng.uniform(0.5, 2.0);
            if rng.uniform(0.0, 1.0) < 0.5 { -w } else { w }
        };
        let samples = (0..n)
            .map(|_| {
                let mut s = vec![0.0f32; 120];
                let first = (rng.uniform(0.0, 6.0) as usize).min(5);
                let mut used = vec![(first, weight(rng))];
                if rng.uniform(0.0, 1.0) < 0.3 {
                    used.push((
                        (first + 1 + (rng.uniform(0.0, 5.0) as usize).min(4)) % 6,
                        weight(rng),
                    ));
                }
                for (a, w) in used {
                    for (s, x) in s.iter_mut().zip(&atoms[a]) {
                        *s += w * x;
                    }
                }
                s
            })
            .collect();
        (samples, atoms)
    }

    #[test]
    fn dictionary_recovers_sparse_atoms_and_fits_landmarks() {
        let mut rng = Rng::new(5);
        let (samples, truth) = sparse_samples(301, &mut rng);
        let refs: Vec<&[f32]> = samples[..300].iter().map(Vec::as_slice).collect();
        let pca = Pca::fit(&refs).unwrap();
        assert_eq!(pca.rank(), 6);
        // The scores are the centred samples' coordinates.
        for (s, z) in refs.iter().zip(&pca.scores).take(5) {
            let centred: Vec<f32> = s.iter().zip(&pca.mean).map(|(a, m)| a - m).collect();
            for (c, &zc) in pca.components.iter().zip(z) {
                assert!((dot(&centred, c) - zc).abs() < 1e-4, "{zc}");
            }
        }
        let config = DictionaryConfig {
            atoms: 12,
            ..DictionaryConfig::default()
        };
        let dict = Dictionary::learn(&pca, &config).unwrap();
        assert_eq!(dict.atoms.shape(), (6, 12));
        assert_eq!(dict.objective.len(), config.iterations + 1);
        let (first, last) = (dict.objective[0], *dict.objective.last().unwrap());
        eprintln!(
            "objective {first:.3} → {last:.3}, {:.2} codes a sample, {} atoms used",
            dict.mean_nonzeros,
            dict.used()
        );
        assert!(last < 0.7 * first, "objective {first} → {last}");
        assert!(
            dict.mean_nonzeros < 3.0,
            "{} codes a sample",
            dict.mean_nonzeros
        );
        for a in dict.atoms.column_iter() {
            assert!(a.norm() <= 1.0 + 1e-12);
        }
        // Each true atom, in the PCA's coordinates, is one of the learned atoms up to sign.
        for t in &truth {
            let coords = DVector::from_iterator(6, pca.components.iter().map(|c| dot(t, c)));
            let best = dict
                .atoms
                .column_iter()
                .map(|a| a.dot(&coords).abs() / a.norm().max(1e-12))
                .fold(0.0f64, f64::max);
            eprintln!("best cosine {best:.4}");
            assert!(best > 0.95, "best cosine {best}");
        }
        // A new sample is recovered from its landmark rows alone, better than by the mean.
        let target = &samples[300];
        let (landmarks, y) = every_third_vertex(target);
        let fit = dict.fitter(&pca, &landmarks, 1e-6).unwrap();
        assert_eq!(fit.k(), dict.used());
        let dense = fit.predict(&y).unwrap();
        let err = |p: &[f32]| {
            p.iter()
                .zip(target)
                .map(|(a, b)| f64::from(a - b).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let (e, e_mean) = (err(&dense), err(&pca.mean));
        eprintln!("fit error {e:.4}, the mean's {e_mean:.4}");
        assert!(e < 0.05 * e_mean, "fit {e}, mean {e_mean}");
        // Same samples, same dictionary.
        let again = Dictionary::learn(&pca, &config).unwrap();
        assert_eq!(again.atoms, dict.atoms);
        assert!(matches!(
            Dictionary::learn(&pca, &DictionaryConfig { atoms: 0, ..config }),
            Err(BaselineModelError::NoAtoms)
        ));
        assert!(matches!(
            Dictionary::learn(
                &pca,
                &DictionaryConfig {
                    sparsity: -1.0,
                    ..config
                }
            ),
            Err(BaselineModelError::Sparsity(s)) if s == -1.0
        ));
        let other = Pca::fit(&refs[..4]).unwrap();
        assert!(matches!(
            dict.fitter(&other, &landmarks, 1e-3),
            Err(BaselineModelError::Coordinates { .. })
        ));
    }
}
