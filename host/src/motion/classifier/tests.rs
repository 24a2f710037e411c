use super::*;
use crate::training::backend::Backend;

/// A toy motion of 3 landmarks over `frames` frames: landmark 0 moves up (class 0) or to the
/// side (class 1) by `amount`, with a small wobble of the others set by `k`.
pub(crate) fn toy_motion(class: usize, amount: f32, k: usize, frames: usize) -> Vec<Vec<f32>> {
    (0..frames)
        .map(|f| {
            let t = f as f32 / (frames - 1) as f32;
            let wobble = 0.02 * ((k as f32 + 1.0) * t * 3.0).sin();
            let (dx, dy) = if class == 0 {
                (0.0, amount * t)
            } else {
                (amount * t, 0.0)
            };
            vec![dx, 1.0 + dy, 0.0, -1.0 + wobble, 0.0, 0.0, 1.0, wobble, 0.1]
        })
        .collect()
}

pub(crate) fn toy_set(n: usize, offset: usize) -> (Vec<Vec<f32>>, Vec<usize>) {
    let mut seqs = Vec::new();
    let mut labels = Vec::new();
    for k in 0..n {
        let class = k % 2;
        let frames = toy_motion(
            class,
            0.3 + 0.05 * ((k + offset) % 5) as f32,
            k + offset,
            12 + k % 7,
        );
        let refs: Vec<&[f32]> = frames.iter().map(Vec::as_slice).collect();
        seqs.push(sequence_features(&refs).unwrap());
        labels.push(class);
    }
    (seqs, labels)
}

#[test]
fn features_ignore_position_scale_and_frame_count_shape() {
    let frames = toy_motion(0, 0.4, 1, 17);
    let refs: Vec<&[f32]> = frames.iter().map(Vec::as_slice).collect();
    let f = sequence_features(&refs).unwrap();
    assert_eq!(f.len(), FRAMES * 9);
    // Moved and scaled: the same features (per-frame normalisation).
    let moved: Vec<Vec<f32>> = frames
        .iter()
        .map(|fr| {
            fr.chunks(3)
                .flat_map(|p| [3.0 * p[0] + 5.0, 3.0 * p[1] - 2.0, 3.0 * p[2] + 1.0])
                .collect()
        })
        .collect();
    let refs: Vec<&[f32]> = moved.iter().map(Vec::as_slice).collect();
    let g = sequence_features(&refs).unwrap();
    let worst = f
        .iter()
        .zip(&g)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-5, "{worst}");
    // Frame 0 less frame 0 is not stored; the last row is the whole displacement, not zero.
    assert!(f[(FRAMES - 1) * 9..].iter().any(|x| x.abs() > 0.01));
    // A still sequence cannot be read.
    let still = vec![frames[0].as_slice(); 5];
    assert!(sequence_features(&still).is_err());
}

#[test]
fn batches_cover_every_sequence_once_and_repeat_for_a_seed() {
    let b = batches(10, 4, 7, 2);
    assert_eq!(b.iter().map(Vec::len).collect::<Vec<_>>(), [4, 4, 2]);
    let mut all: Vec<usize> = b.iter().flatten().copied().collect();
    all.sort_unstable();
    assert_eq!(all, (0..10).collect::<Vec<_>>());
    assert_eq!(b, batches(10, 4, 7, 2));
    assert_ne!(b, batches(10, 4, 7, 3));
}

#[test]
fn the_classifier_learns_two_toy_classes() {
    let (seqs, labels) = toy_set(24, 0);
    let (test, test_labels) = toy_set(10, 100);
    let config = SequenceTraining {
        seed: 5,
        epochs: 25,
        batch: 8,
        lr: 1e-2,
        hidden: 8,
    };
    let device = Backend::Flex.autodiff_device(config.seed).unwrap();
    let mut seen = 0;
    let (model, losses) =
        train(&seqs, &labels, 2, &config, &device, &mut |_, _| seen += 1).unwrap();
    assert_eq!(seen, 25);
    assert!(losses[24] < 0.5 * losses[0], "{losses:?}");
    let (predicted, features) = model.predict(&test, &device);
    assert_eq!(accuracy(&predicted, &test_labels), 1.0);
    assert_eq!(features.len(), 10);
    assert!(features.iter().all(|f| f.len() == 8));
    // Bad input is refused.
    let refused = |labels: &[usize]| {
        train(&seqs, labels, 2, &config, &device, &mut |_, _| {})
            .map(|_| ())
            .unwrap_err()
    };
    assert_eq!(refused(&labels[..3]), TrainingSetError::NoSequences);
    assert_eq!(refused(&[2; 24]), TrainingSetError::LabelOutOfRange);
}
