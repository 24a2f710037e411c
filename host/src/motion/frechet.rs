// Fréchet distance of two Gaussians (Table 3's FD, the FID formula of Heusel et al. 2017):
// d² = ‖μ1 − μ2‖² + tr(S1 + S2 − 2 (S1^½ S2 S1^½)^½).
//! The Fréchet distance between two sets of feature vectors (S2D section 4.3, Table 3): each set
//! is summarised by its mean and covariance, and the distance is that of the two Gaussians.
//!
//! The matrix square root of the cross term is taken on the symmetric matrix `S1^½ S2 S1^½`
//! (whose trace of square root equals that of `(S1 S2)^½`): both roots come from nalgebra's
//! symmetric eigen-decomposition in f64, with eigenvalues that rounding makes slightly negative
//! set to 0 (covariances are positive semi-definite; with fewer samples than dimensions they are
//! singular).

use nalgebra::{DMatrix, DVector};

/// Feature sets that have no Fréchet distance.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FrechetError {
    /// Fewer than 2 feature vectors.
    #[error("a covariance needs at least 2 feature vectors, got {got}")]
    TooFew {
        /// The vectors given.
        got: usize,
    },
    /// Empty vectors or vectors of different lengths.
    #[error("feature vectors of different lengths")]
    Lengths,
    /// A value that is NaN or infinite.
    #[error("a feature is not finite")]
    NonFinite,
    /// Two Gaussians of different dimensions.
    #[error("features of {a} and {b} dimensions")]
    Dimensions {
        /// The first's.
        a: usize,
        /// The second's.
        b: usize,
    },
}

/// A set of feature vectors as a Gaussian: mean and covariance (unbiased, `1 / (n − 1)`).
#[derive(Clone, Debug, PartialEq)]
pub struct Gaussian {
    /// `[d]`.
    pub mean: DVector<f64>,
    /// `[d, d]`, symmetric.
    pub cov: DMatrix<f64>,
}

impl Gaussian {
    /// The mean and covariance of `features` (each `[d]`).
    ///
    /// # Errors
    /// Fewer than 2 vectors, vectors of different lengths or of none, or non-finite values.
    pub fn of(features: &[Vec<f32>]) -> Result<Self, FrechetError> {
        if features.len() < 2 {
            return Err(FrechetError::TooFew {
                got: features.len(),
            });
        }
        let d = features[0].len();
        if d == 0 || features.iter().any(|f| f.len() != d) {
            return Err(FrechetError::Lengths);
        }
        if !features.iter().flatten().all(|x| x.is_finite()) {
            return Err(FrechetError::NonFinite);
        }
        let n = features.len();
        let x = DMatrix::from_fn(n, d, |i, j| f64::from(features[i][j]));
        let mean = DVector::from_fn(d, |j, _| x.column(j).sum() / n as f64);
        let centred = DMatrix::from_fn(n, d, |i, j| x[(i, j)] - mean[j]);
        let cov = centred.transpose() * &centred / (n - 1) as f64;
        Ok(Self { mean, cov })
    }
}

/// The square root of a symmetric positive semi-definite matrix, through its eigen-decomposition
/// (negative eigenvalues from rounding taken as 0).
fn sqrt_psd(m: &DMatrix<f64>) -> DMatrix<f64> {
    let sym = (m + m.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let roots = eig.eigenvalues.map(|l| l.max(0.0).sqrt());
    &eig.eigenvectors * DMatrix::from_diagonal(&roots) * eig.eigenvectors.transpose()
}

/// The squared Fréchet distance between two Gaussians (the quantity Table 3 and FID report).
/// Rounding can leave a tiny negative value for equal Gaussians; it is returned as 0.
///
/// # Errors
/// If the dimensions differ.
pub fn distance(a: &Gaussian, b: &Gaussian) -> Result<f64, FrechetError> {
    Ok(terms(a, b)?.distance())
}

/// The two terms of the squared Fréchet distance: where the means lie and how the spreads
/// differ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Terms {
    /// `‖μ1 − μ2‖²`.
    pub mean: f64,
    /// `tr(S1 + S2 − 2 (S1^½ S2 S1^½)^½)`, the Bures distance of the covariances (≥ 0 up to
    /// rounding).
    pub covariance: f64,
}

impl Terms {
    /// Their sum, the squared Fréchet distance ([`distance`]); a tiny negative value that
    /// rounding leaves for equal Gaussians is returned as 0.
    pub fn distance(&self) -> f64 {
        (self.mean + self.covariance).max(0.0)
    }
}

/// [`Terms`] of the Fréchet distance between two Gaussians; [`distance`] is their sum.
///
/// # Errors
/// If the dimensions differ.
pub fn terms(a: &Gaussian, b: &Gaussian) -> Result<Terms, FrechetError> {
    if a.mean.len() != b.mean.len() {
        return Err(FrechetError::Dimensions {
            a: a.mean.len(),
            b: b.mean.len(),
        });
    }
    let s1h = sqrt_psd(&a.cov);
    let cross = &s1h * &b.cov * &s1h;
    let sym = (&cross + cross.transpose()) * 0.5;
    let tr_root: f64 = sym
        .symmetric_eigen()
        .eigenvalues
        .iter()
        .map(|l| l.max(0.0).sqrt())
        .sum();
    let diff = &a.mean - &b.mean;
    Ok(Terms {
        mean: diff.dot(&diff),
        covariance: a.cov.trace() + b.cov.trace() - 2.0 * tr_root,
    })
}

/// [`distance`] between the Gaussians of two feature sets.
///
/// # Errors
/// As [`Gaussian::of`] and [`distance`].
pub fn between(a: &[Vec<f32>], b: &[Vec<f32>]) -> Result<f64, FrechetError> {
    distance(&Gaussian::of(a)?, &Gaussian::of(b)?)
}

/// [`terms`] between the Gaussians of two feature sets.
///
/// # Errors
/// As [`Gaussian::of`] and [`terms`].
pub fn terms_between(a: &[Vec<f32>], b: &[Vec<f32>]) -> Result<Terms, FrechetError> {
    terms(&Gaussian::of(a)?, &Gaussian::of(b)?)
}

/// Per label `0..classes`, the squared distance `‖μ_a − μ_b‖²` between the means of that label's
/// rows of `a` and of `b` (two feature sets row for row, `labels` the rows' labels); `None` for a
/// label without rows. Where the Fréchet distance of two whole sets puts the difference between
/// their labels' centres into the covariance term, this says which label it is.
///
/// # Errors
/// [`FrechetError::Lengths`] if `a`, `b` and `labels` are not row for row or the vectors differ
/// in length; [`FrechetError::NonFinite`] for a non-finite value.
pub fn label_mean_offsets(
    a: &[Vec<f32>],
    b: &[Vec<f32>],
    labels: &[usize],
    classes: usize,
) -> Result<Vec<Option<f64>>, FrechetError> {
    let d = a.first().map_or(0, Vec::len);
    if a.len() != b.len() || a.len() != labels.len() || a.iter().chain(b).any(|v| v.len() != d) {
        return Err(FrechetError::Lengths);
    }
    if a.iter().chain(b).flatten().any(|x| !x.is_finite()) {
        return Err(FrechetError::NonFinite);
    }
    Ok((0..classes)
        .map(|c| {
            let rows: Vec<usize> = (0..labels.len()).filter(|&r| labels[r] == c).collect();
            if rows.is_empty() {
                return None;
            }
            let n = rows.len() as f64;
            Some(
                (0..d)
                    .map(|k| {
                        let diff: f64 = rows
                            .iter()
                            .map(|&r| f64::from(a[r][k]) - f64::from(b[r][k]))
                            .sum::<f64>()
                            / n;
                        diff * diff
                    })
                    .sum(),
            )
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diagonal(mean: &[f64], var: &[f64]) -> Gaussian {
        Gaussian {
            mean: DVector::from_row_slice(mean),
            cov: DMatrix::from_diagonal(&DVector::from_row_slice(var)),
        }
    }

    #[test]
    fn diagonal_gaussians_have_the_closed_form() {
        // For diagonal covariances d² = Σ (μ1 − μ2)² + Σ (σ1 − σ2)².
        let a = diagonal(&[0.0, 1.0, -2.0], &[1.0, 4.0, 0.25]);
        let b = diagonal(&[1.0, 1.0, 0.0], &[9.0, 1.0, 0.25]);
        let expected = (1.0 + 0.0 + 4.0) + (4.0 + 1.0 + 0.0);
        let d = distance(&a, &b).unwrap();
        assert!((d - expected).abs() < 1e-10, "{d} vs {expected}");
        assert!((distance(&b, &a).unwrap() - expected).abs() < 1e-10);
    }

    #[test]
    fn a_rotation_of_both_keeps_the_distance() {
        // A full (non-diagonal) case with a known answer: rotate both diagonal Gaussians by the
        // same orthogonal matrix; the distance is invariant.
        let a = diagonal(&[0.5, -1.0, 2.0], &[2.0, 0.5, 1.5]);
        let b = diagonal(&[0.0, 0.0, 1.0], &[0.1, 3.0, 1.5]);
        let expected = distance(&a, &b).unwrap();
        let r = nalgebra::Rotation3::from_euler_angles(0.3, -1.1, 0.7);
        let r = DMatrix::from_fn(3, 3, |i, j| r[(i, j)]);
        let rotate = |g: &Gaussian| Gaussian {
            mean: &r * &g.mean,
            cov: &r * &g.cov * r.transpose(),
        };
        let d = distance(&rotate(&a), &rotate(&b)).unwrap();
        assert!((d - expected).abs() < 1e-9, "{d} vs {expected}");
    }

    #[test]
    fn a_set_is_at_distance_zero_from_itself_and_not_from_a_shift() {
        let x: Vec<Vec<f32>> = (0..40)
            .map(|i| {
                let t = i as f32 * 0.37;
                vec![t.sin(), (2.0 * t).cos(), t.sin() * t.cos(), 0.1 * t]
            })
            .collect();
        let d = between(&x, &x).unwrap();
        assert!(d < 1e-9, "{d}");
        // A shift by c moves only the mean: d² = ‖c‖².
        let shifted: Vec<Vec<f32>> = x
            .iter()
            .map(|v| v.iter().map(|a| a + 0.5).collect())
            .collect();
        let d = between(&x, &shifted).unwrap();
        assert!((d - 4.0 * 0.25).abs() < 1e-5, "{d}");
        // … all of it in the mean term; a scaled copy differs in the covariance term alone.
        let t = terms_between(&x, &shifted).unwrap();
        assert!(
            (t.mean - 1.0).abs() < 1e-5 && t.covariance.abs() < 1e-5,
            "{t:?}"
        );
        let scaled: Vec<Vec<f32>> = x
            .iter()
            .map(|v| v.iter().map(|a| 2.0 * a).collect())
            .collect();
        let centred = |s: &[Vec<f32>]| Gaussian::of(s).unwrap();
        let (a, b) = (centred(&x), centred(&scaled));
        let t = terms(&a, &b).unwrap();
        let mean_gap = (&a.mean - &b.mean).norm_squared();
        assert!((t.mean - mean_gap).abs() < 1e-9, "{t:?}");
        // A covariance scaled by 4 (standard deviations by 2): tr(S + 4S − 2·2S) = tr S.
        assert!(
            (t.covariance - a.cov.trace()).abs() < 1e-6 * a.cov.trace(),
            "{t:?}"
        );
        assert!((distance(&a, &b).unwrap() - (t.mean + t.covariance)).abs() < 1e-12);
        // Fewer samples than dimensions: a singular covariance still gives a distance.
        let few = &x[..3];
        assert!(between(few, few).unwrap() < 1e-9);
    }

    #[test]
    fn bad_sets_are_refused() {
        assert_eq!(
            between(&[vec![1.0]], &[vec![1.0], vec![2.0]]),
            Err(FrechetError::TooFew { got: 1 })
        );
        assert_eq!(
            between(&[vec![1.0], vec![1.0, 2.0]], &[vec![1.0], vec![2.0]]),
            Err(FrechetError::Lengths)
        );
        assert_eq!(
            between(&[vec![1.0], vec![f32::NAN]], &[vec![1.0], vec![2.0]]),
            Err(FrechetError::NonFinite)
        );
        let a = [vec![1.0, 0.0], vec![0.0, 1.0]];
        assert_eq!(
            between(&a, &[vec![1.0], vec![2.0]]),
            Err(FrechetError::Dimensions { a: 2, b: 1 })
        );
    }

    #[test]
    fn label_mean_offsets_find_the_label_that_moved() {
        let labels = [0usize, 1, 0, 1, 2, 2];
        let a: Vec<Vec<f32>> = (0..6)
            .map(|i| vec![i as f32, (i * i) as f32 * 0.1])
            .collect();
        // Label 1's rows shifted by (3, 4): its offset is 25, the others' 0.
        let mut b = a.clone();
        for r in [1, 3] {
            b[r][0] += 3.0;
            b[r][1] += 4.0;
        }
        let offsets = label_mean_offsets(&a, &b, &labels, 4).unwrap();
        assert_eq!(offsets[0], Some(0.0));
        assert!((offsets[1].unwrap() - 25.0).abs() < 1e-5, "{offsets:?}");
        assert_eq!(offsets[2], Some(0.0));
        assert_eq!(offsets[3], None);
        // Rows within a label may be in any order: only the label's means count.
        let mut swapped = a.clone();
        swapped.swap(0, 2);
        assert_eq!(
            label_mean_offsets(&a, &swapped, &labels, 3).unwrap()[0],
            Some(0.0)
        );
        assert_eq!(
            label_mean_offsets(&a, &b[1..], &labels, 3),
            Err(FrechetError::Lengths)
        );
        b[4][0] = f32::NAN;
        assert_eq!(
            label_mean_offsets(&a, &b, &labels, 3),
            Err(FrechetError::NonFinite)
        );
    }
}
