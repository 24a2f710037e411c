//! `sinew eval motion` without a generator: how hard a motion set is. The classifier of Table 3
//! ([`super::classifier`], with the evaluation's settings) trains on the training sequences and
//! labels the test sequences' own landmarks (Gen-LM's ground-truth accuracy); the report adds
//! the per-label accuracies and the confusion matrix, to tune a set's knobs
//! ([`super::variation`]) against CoMA's 73 % (docs/MOTION.md, "How hard the motions are").

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::classes::LABELS;
use super::classifier;
use super::data::{MotionSet, Split};
use super::evaluate::{EvalError, EvalSettings, features};
use crate::training::backend::Backend;

/// What to measure.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    /// The motion set folder.
    pub motions: PathBuf,
    /// The JSON report to write.
    pub report: PathBuf,
    /// The classifier's settings (the evaluation's).
    pub settings: EvalSettings,
    /// The burn backend.
    pub backend: Backend,
    /// No progress bar.
    pub quiet: bool,
}

/// The report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GroundTruthReport {
    /// The motion set folder.
    pub motions: String,
    /// The set's generation settings (its knobs).
    pub set: super::data::MotionsConfig,
    /// The classifier's settings.
    pub settings: EvalSettings,
    /// Training sequences.
    pub train_sequences: usize,
    /// Test sequences.
    pub test_sequences: usize,
    /// The classifier's accuracy on the test sequences (Gen-LM's `accuracy_gt`).
    pub accuracy: f32,
    /// … per label, in [`LABELS`] order.
    pub per_label_accuracy: Vec<f32>,
    /// `confusion[true label][predicted label]`: test sequences.
    pub confusion: Vec<Vec<usize>>,
    /// The classifier's accuracy on its own training sequences.
    pub train_accuracy: f32,
    /// The classifier's mean cross-entropy per epoch.
    pub losses: Vec<f32>,
    /// Seconds it took.
    pub seconds: f64,
}

/// Trains the classifier on the set's training sequences and labels its test sequences; writes
/// the report (atomically) and returns it.
pub fn ground_truth(opts: &GroundTruth) -> Result<GroundTruthReport, EvalError> {
    let started = std::time::Instant::now();
    let set = MotionSet::read(&opts.motions)?;
    let (train, test) = (set.split(Split::Train), set.split(Split::Test));
    if train.is_empty() || test.len() < 2 {
        return Err(EvalError::Split {
            path: opts.motions.clone(),
            train: train.len(),
            test: test.len(),
        });
    }
    let own = |ids: &[usize]| -> Vec<Vec<Vec<f32>>> {
        ids.iter()
            .map(|&s| {
                set.landmark_frames(s)
                    .into_iter()
                    .map(<[f32]>::to_vec)
                    .collect()
            })
            .collect()
    };
    let what = |side: &str| format!("{}: {side}", opts.motions.display());
    let train_features = features(&own(&train), &what("training"))?;
    let test_features = features(&own(&test), &what("test"))?;
    let train_labels: Vec<usize> = train.iter().map(|&s| set.label(s)).collect();
    let test_labels: Vec<usize> = test.iter().map(|&s| set.label(s)).collect();
    let settings = &opts.settings;
    let device = opts.backend.autodiff_device(settings.seed)?;
    let bar = crate::training::progress::bar(settings.classifier.epochs as u64, opts.quiet);
    let (model, losses) = classifier::train(
        &train_features,
        &train_labels,
        LABELS.len(),
        &settings.classifier,
        &device,
        &mut |_, loss| {
            bar.inc(1);
            bar.set_message(format!("classifier: cross-entropy {loss:.4}"));
        },
    )?;
    bar.finish_and_clear();
    let (predicted, _) = model.predict(&test_features, &device);
    let (train_predicted, _) = model.predict(&train_features, &device);
    let mut confusion = vec![vec![0usize; LABELS.len()]; LABELS.len()];
    for (&t, &p) in test_labels.iter().zip(&predicted) {
        confusion[t][p] += 1;
    }
    let per_label_accuracy = confusion
        .iter()
        .enumerate()
        .map(|(l, row)| row[l] as f32 / row.iter().sum::<usize>().max(1) as f32)
        .collect();
    let report = GroundTruthReport {
        motions: opts.motions.display().to_string(),
        set: set.manifest.config.clone(),
        settings: settings.clone(),
        train_sequences: train.len(),
        test_sequences: test.len(),
        accuracy: classifier::accuracy(&predicted, &test_labels),
        per_label_accuracy,
        confusion,
        train_accuracy: classifier::accuracy(&train_predicted, &train_labels),
        losses,
        seconds: started.elapsed().as_secs_f64(),
    };
    write(&opts.report, &report)?;
    Ok(report)
}

fn write(path: &Path, report: &GroundTruthReport) -> Result<(), EvalError> {
    let json = serde_json::to_string_pretty(report).map_err(|source| EvalError::Encode {
        path: path.to_owned(),
        source,
    })?;
    Ok(crate::io::atomic::write(path, json.as_bytes())?)
}
