//! Labels as the networks read and write them: one-hot rows in, the best-scoring label of each
//! row of scores out. Below every network of the motion module (the generator and critic, the
//! label guide, the evaluation's classifier), so that each uses the same two conversions.

use burn::tensor::{Device, Tensor};

use crate::training::nn::tensor;

/// One-hot rows of `labels` over `classes`.
///
/// # Shapes
/// - → `[labels.len(), classes]`
pub fn one_hot(labels: &[usize], classes: usize, device: &Device) -> Tensor<2> {
    let mut v = vec![0.0f32; labels.len() * classes];
    for (row, &l) in labels.iter().enumerate() {
        v[row * classes + l] = 1.0;
    }
    tensor(v, [labels.len(), classes], device)
}

/// The label of the highest score in each row of `classes` scores (`scores` row-major; the first
/// of equal scores; a row of NaNs gives label 0).
pub fn best_labels(scores: &[f32], classes: usize) -> Vec<usize> {
    scores
        .chunks_exact(classes.max(1))
        .map(|row| {
            row.iter()
                .enumerate()
                .fold((0, f32::NEG_INFINITY), |(bi, bv), (i, &v)| {
                    if v > bv { (i, v) } else { (bi, bv) }
                })
                .0
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::training::backend::Backend;
    use crate::training::nn::to_vec;

    #[test]
    fn one_hot_rows_set_each_label_and_best_labels_reads_them_back() {
        let device = Backend::Flex.autodiff_device(3).unwrap();
        let labels = [2, 0, 1, 2];
        let rows = to_vec(one_hot(&labels, 3, &device));
        assert_eq!(rows, [0., 0., 1., 1., 0., 0., 0., 1., 0., 0., 0., 1.]);
        assert_eq!(best_labels(&rows, 3), labels);
    }

    #[test]
    fn best_labels_takes_the_first_of_equal_scores_and_skips_nans() {
        let scores = [
            0.5,
            0.5,
            -1.0,
            f32::NAN,
            -2.0,
            -3.0,
            f32::NAN,
            f32::NAN,
            f32::NAN,
        ];
        assert_eq!(best_labels(&scores, 3), [0, 1, 0]);
    }
}
