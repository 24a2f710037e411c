//! `sinew eval motion`: Table 3 of the S2D paper (section 4.3) on a motion set. A sequence
//! classifier ([`super::classifier`]) and the LSTM baseline ([`super::lstm_baseline`]) train on
//! the training sequences; then three rows of test motions, one per test sequence (its label, on
//! its identity's neutral landmarks), are classified and compared:
//! - ground truth: the test sequences themselves;
//! - Motion3DGAN: the baked generator through `sinew-core`, as `sinew generate` runs it (default
//!   intensity), seed `seed · 1,000,000 + k` for the k-th test sequence;
//! - LSTM: the baseline's motion of the label on the same neutral.
//!
//! Each row is read twice: as generated landmarks (Gen-LM) and as landmarks re-extracted from
//! S2D-Dec meshes (Det-LM): every frame's landmarks go through the baked decoder
//! (`input(frame 0, frame t)`, decoded onto the decoder's own template neutral, `s2d.h0.pos`) and
//! the decoder's landmark vertices (`s2d.lmk`) are read back out. The decoder's neutral is the one
//! face certain to be in its topology (the motion set's identities live on the full face region,
//! a decoder may be trained on a decimated one), and one face for every row keeps the rows
//! comparable: the ground truth takes the same path.
//!
//! Accuracy: the fraction classified as their label. Fréchet distance: between the classifier
//! features (its last hidden state) of a row and of the ground truth read the same way.
//! Diversity: per label, the mean pairwise geodesic distance between the SRVFs (re-encoded from
//! the landmarks) of the motions from `diversity_seeds` seeds on the decoder's neutral; the LSTM
//! takes no seed, so its motions repeat and its diversity comes out 0.

use std::path::{Path, PathBuf};

use burn::tensor::Device;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sinew_core::motion::MotionGenerator;

mod redetect;

pub use redetect::RedetectError;
use redetect::{Reading, Redetector};

use super::classes::LABELS;
use super::classifier::{self, Classifier, SequenceTraining, TrainingSetError, sequence_features};
use super::data::{MotionSet, Split};
use super::diversity::DiversityError;
use super::frechet::FrechetError;
use super::generate::{MotionGenerateError, open_decoder, open_generator};
use super::lstm_baseline::{self, UnknownLabel};
use super::srvf::SrvfError;
use super::{diversity, frechet, srvf};
use crate::io::atomic::AtomicWriteError;
use crate::io::container::ContainerError;
use crate::io::dataset::DataSetError;
use crate::training::backend::{Backend, BackendError};

/// An evaluation that was refused or failed; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// Fewer than 2 diversity seeds.
    #[error("--diversity-seeds must be at least 2")]
    DiversitySeeds,
    /// A model or decoder file that cannot be read as a `.sinew` file (the error names it).
    #[error(transparent)]
    Read(#[from] ContainerError),
    /// A generator or decoder that cannot be used (the error names the file).
    #[error(transparent)]
    Open(#[from] MotionGenerateError),
    /// A generator whose labels are not CoMA's twelve in order.
    #[error("{}: the generator's labels {labels:?} are not CoMA's twelve in order", path.display())]
    Labels {
        /// The model file.
        path: PathBuf,
        /// Its labels.
        labels: Vec<String>,
    },
    /// A motion set that cannot be read (the error names the file).
    #[error(transparent)]
    Motions(#[from] DataSetError),
    /// Motions of other landmarks than the generator moves.
    #[error(
        "{}: the motions have {landmarks} landmarks, the generator {} moves {moved}",
        motions.display(),
        model.display()
    )]
    Landmarks {
        /// The motion set's folder.
        motions: PathBuf,
        /// Its landmarks.
        landmarks: usize,
        /// The model file.
        model: PathBuf,
        /// The generator's landmarks.
        moved: usize,
    },
    /// A motion set without training sequences or with fewer than 2 test sequences.
    #[error(
        "{}: {train} training and {test} test sequences; the evaluation needs some of each \
         (2 tests)",
        path.display()
    )]
    Split {
        /// The motion set's folder.
        path: PathBuf,
        /// Its training sequences.
        train: usize,
        /// Its test sequences.
        test: usize,
    },
    /// A motion whose features cannot be computed (it does not move).
    #[error("{what} motion {motion}")]
    Features {
        /// Which motions: the set and row.
        what: String,
        /// The motion's index among them.
        motion: usize,
        /// Why.
        #[source]
        source: SrvfError,
    },
    /// A motion with no SRVF.
    #[error(transparent)]
    Srvf(#[from] SrvfError),
    /// The core refused to generate a motion.
    #[error("generating label {label}, seed {seed}")]
    Generate {
        /// The label.
        label: usize,
        /// The seed.
        seed: u64,
        /// What the core said.
        #[source]
        source: sinew_core::EvalError,
    },
    /// The decoder refused a motion whose landmarks are re-extracted.
    #[error("{}: re-extracting landmarks", path.display())]
    Redetect {
        /// The decoder file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: RedetectError,
    },
    /// The backend cannot run.
    #[error(transparent)]
    Backend(#[from] BackendError),
    /// The training features or settings that the classifier or the LSTM cannot train on.
    #[error(transparent)]
    TrainingSet(#[from] TrainingSetError),
    /// A label the LSTM baseline does not know.
    #[error(transparent)]
    Label(#[from] UnknownLabel),
    /// A diversity that cannot be measured.
    #[error(transparent)]
    Diversity(#[from] DiversityError),
    /// A Fréchet distance that cannot be measured.
    #[error(transparent)]
    Frechet(#[from] FrechetError),
    /// The report cannot be encoded as JSON.
    #[error("{}: cannot encode the report", path.display())]
    Encode {
        /// The report file.
        path: PathBuf,
        /// What serde said.
        #[source]
        source: serde_json::Error,
    },
    /// The report cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}

/// Seeds of the k-th generated test motion: `seed · SEED_STRIDE + k`; diversity seed j:
/// `seed · SEED_STRIDE + DIVERSITY_OFFSET + j`.
pub const SEED_STRIDE: u64 = 1_000_000;
/// See [`SEED_STRIDE`].
pub const DIVERSITY_OFFSET: u64 = 500_000;

/// What the evaluation trains and draws.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalSettings {
    /// The seed every other seed derives from.
    pub seed: u64,
    /// The classifier's training.
    pub classifier: SequenceTraining,
    /// The LSTM baseline's training.
    pub lstm: SequenceTraining,
    /// Motions per label for the diversity (at least 2).
    pub diversity_seeds: usize,
}

impl EvalSettings {
    /// The defaults for `seed`, with `epochs` for both networks.
    pub fn new(seed: u64, epochs: usize) -> Self {
        Self {
            seed,
            classifier: SequenceTraining {
                seed,
                epochs,
                batch: 32,
                lr: 1e-3,
                hidden: 64,
            },
            lstm: SequenceTraining {
                seed: seed.wrapping_add(1),
                epochs,
                batch: 32,
                lr: 1e-3,
                hidden: 128,
            },
            diversity_seeds: 10,
        }
    }
}

/// `sinew eval motion`'s inputs.
#[derive(Clone, Debug)]
pub struct EvalMotion {
    /// The baked generator.
    pub model: PathBuf,
    /// The baked S2D decoder.
    pub decoder: PathBuf,
    /// The motion set folder.
    pub motions: PathBuf,
    /// The JSON report to write.
    pub report: PathBuf,
    /// The settings.
    pub settings: EvalSettings,
    /// The burn backend.
    pub backend: Backend,
    /// No progress bar.
    pub quiet: bool,
}

/// One reading of Table 3 (Gen-LM or Det-LM).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// Classifier accuracy on the ground-truth test sequences.
    pub accuracy_gt: f32,
    /// … on Motion3DGAN's motions.
    pub accuracy_motion3dgan: f32,
    /// … on the LSTM baseline's motions.
    pub accuracy_lstm: f32,
    /// Per label (in [`LABELS`] order): ground truth, Motion3DGAN, LSTM.
    pub per_label_accuracy: [Vec<f32>; 3],
    /// Fréchet distance of Motion3DGAN's features from the ground truth's.
    pub frechet_motion3dgan: f64,
    /// Fréchet distance of the LSTM's features from the ground truth's.
    pub frechet_lstm: f64,
    /// The mean term `‖μ − μ_gt‖²` of `frechet_motion3dgan` (the rest is the covariances').
    #[serde(default)]
    pub frechet_mean_motion3dgan: f64,
    /// The mean term of `frechet_lstm`.
    #[serde(default)]
    pub frechet_mean_lstm: f64,
    /// Per label (in [`LABELS`] order), `‖μ − μ_gt‖²` of that label's features, Motion3DGAN's
    /// (`frechet::label_mean_offsets`): which label's centre the whole distance misses.
    #[serde(default)]
    pub label_mean_offset_motion3dgan: Vec<Option<f64>>,
    /// … the LSTM's.
    #[serde(default)]
    pub label_mean_offset_lstm: Vec<Option<f64>>,
    /// Fréchet distance of the training sequences' features from the test ground truth's (a
    /// floor: two samples of the same distribution); Gen-LM only (Det-LM would decode every
    /// training sequence).
    pub frechet_train: Option<f64>,
    /// Motion3DGAN's diversity (rad).
    pub diversity: f32,
    /// The LSTM's diversity (rad; 0 by construction, computed).
    pub diversity_lstm: f32,
    /// The ground truth's: the mean pairwise distance of the test sequences of one label (one
    /// per identity); absent with a single identity.
    pub diversity_gt: Option<f32>,
}

/// One generated test motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Generated {
    /// Its label.
    pub label: String,
    /// The identity whose neutral it plays on.
    pub identity: usize,
    /// Motion3DGAN's seed.
    pub seed: u64,
}

/// The report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EvalReport {
    /// The generator file.
    pub model: String,
    /// The decoder file.
    pub decoder: String,
    /// The motion set folder.
    pub motions: String,
    /// The settings.
    pub settings: EvalSettings,
    /// Training sequences (the classifier's and the LSTM's).
    pub train_sequences: usize,
    /// Test sequences (each row's size).
    pub test_sequences: usize,
    /// The neutral Det-LM decodes onto.
    pub det_lm_neutral: String,
    /// The classifier's accuracy on its own training sequences.
    pub classifier_train_accuracy: f32,
    /// The classifier's mean cross-entropy per epoch.
    pub classifier_losses: Vec<f32>,
    /// The LSTM's mean squared error per epoch (scaled units).
    pub lstm_losses: Vec<f32>,
    /// Generated landmarks.
    pub gen_lm: Row,
    /// Landmarks re-extracted from S2D-Dec meshes.
    pub det_lm: Row,
    /// The generated test motions, in test order.
    pub generated: Vec<Generated>,
    /// The diversity's seeds (the same for every label).
    pub diversity_seeds: Vec<u64>,
    /// Seconds the evaluation took.
    pub seconds: f64,
}

/// Each sequence's classifier features ([`sequence_features`]); `what` names the set in errors.
pub(crate) fn features(seqs: &[Vec<Vec<f32>>], what: &str) -> Result<Vec<Vec<f32>>, EvalError> {
    seqs.par_iter()
        .enumerate()
        .map(|(i, s)| {
            let refs: Vec<&[f32]> = s.iter().map(Vec::as_slice).collect();
            sequence_features(&refs).map_err(|source| EvalError::Features {
                what: what.to_owned(),
                motion: i,
                source,
            })
        })
        .collect()
}

fn srvfs(seqs: &[Vec<Vec<f32>>]) -> Result<Vec<Vec<f32>>, SrvfError> {
    seqs.iter()
        .map(|s| {
            let refs: Vec<&[f32]> = s.iter().map(Vec::as_slice).collect();
            Ok(srvf::encode(&refs)?.q)
        })
        .collect()
}

/// Motion3DGAN's landmark curve (`FRAMES + 1` frames) of `label` from `seed` on `neutral`.
fn generated(
    generator: &MotionGenerator<'_>,
    label: usize,
    seed: u64,
    neutral: &[f32],
) -> Result<Vec<Vec<f32>>, EvalError> {
    let mut scratch = vec![0.0f32; generator.scratch_len()];
    let mut curve = vec![0.0f32; generator.curve_len()];
    generator
        .landmarks(label, seed, 1.0, neutral, &mut scratch, &mut curve)
        .map_err(|source| EvalError::Generate {
            label,
            seed,
            source,
        })?;
    Ok(curve
        .chunks_exact(generator.dims())
        .map(<[f32]>::to_vec)
        .collect())
}

/// Everything a row needs besides the reading.
struct Judge<'a> {
    classifier: &'a Classifier,
    device: &'a Device,
    test_labels: &'a [usize],
    train_features: &'a [Vec<f32>],
    /// Per label, the test sequences' indices (into the rows).
    by_label: Vec<Vec<usize>>,
}

impl Judge<'_> {
    /// The row of `reading`; `with_train`: also the training sequences' Fréchet distance (for
    /// the reading whose landmarks are the training sequences' own).
    fn row(&self, reading: &Reading, name: &str, with_train: bool) -> Result<Row, EvalError> {
        let mut accuracy = Vec::new();
        let mut per_label: [Vec<f32>; 3] = Default::default();
        let mut feats = Vec::new();
        for (k, who) in ["ground-truth", "Motion3DGAN", "LSTM"].iter().enumerate() {
            let f = features(&reading.rows[k], &format!("{name} {who}"))?;
            let (predicted, h) = self.classifier.predict(&f, self.device);
            accuracy.push(classifier::accuracy(&predicted, self.test_labels));
            per_label[k] = self
                .by_label
                .iter()
                .map(|rows| {
                    let p: Vec<usize> = rows.iter().map(|&r| predicted[r]).collect();
                    let l: Vec<usize> = rows.iter().map(|&r| self.test_labels[r]).collect();
                    classifier::accuracy(&p, &l)
                })
                .collect();
            feats.push(h);
        }
        let mut div = Vec::new();
        for groups in &reading.diversity {
            let qs: Vec<Vec<Vec<f32>>> =
                groups.iter().map(|g| srvfs(g)).collect::<Result<_, _>>()?;
            div.push(diversity::mean_pairwise(&qs)?.1);
        }
        let gt_groups: Vec<Vec<Vec<f32>>> = self
            .by_label
            .iter()
            .map(|rows| {
                let seqs: Vec<Vec<Vec<f32>>> =
                    rows.iter().map(|&r| reading.rows[0][r].clone()).collect();
                srvfs(&seqs)
            })
            .collect::<Result<_, _>>()?;
        let diversity_gt = if gt_groups.iter().all(|g| g.len() >= 2) {
            Some(diversity::mean_pairwise(&gt_groups)?.1)
        } else {
            None
        };
        let generated = frechet::terms_between(&feats[1], &feats[0])?;
        let lstm = frechet::terms_between(&feats[2], &feats[0])?;
        let offsets = |k: usize| {
            frechet::label_mean_offsets(&feats[k], &feats[0], self.test_labels, LABELS.len())
        };
        Ok(Row {
            accuracy_gt: accuracy[0],
            accuracy_motion3dgan: accuracy[1],
            accuracy_lstm: accuracy[2],
            per_label_accuracy: per_label,
            frechet_motion3dgan: generated.distance(),
            frechet_lstm: lstm.distance(),
            frechet_mean_motion3dgan: generated.mean,
            frechet_mean_lstm: lstm.mean,
            label_mean_offset_motion3dgan: offsets(1)?,
            label_mean_offset_lstm: offsets(2)?,
            frechet_train: if with_train {
                Some(frechet::between(self.train_features, &feats[0])?)
            } else {
                None
            },
            diversity: div[0],
            diversity_lstm: div[1],
            diversity_gt,
        })
    }
}

/// `sinew eval motion`: trains the classifier and the LSTM baseline, generates and reads the
/// three rows twice, writes the report (atomically) and returns it.
pub fn eval_motion(opts: &EvalMotion) -> Result<EvalReport, EvalError> {
    let started = std::time::Instant::now();
    let settings = &opts.settings;
    if settings.diversity_seeds < 2 {
        return Err(EvalError::DiversitySeeds);
    }
    let gen_bytes = crate::io::container::read(&opts.model)?;
    let (generator, labels) = open_generator(&opts.model, &gen_bytes)?;
    if !labels.iter().map(String::as_str).eq(LABELS) {
        return Err(EvalError::Labels {
            path: opts.model.clone(),
            labels,
        });
    }
    let dec_bytes = crate::io::container::read(&opts.decoder)?;
    let decoder = open_decoder(&opts.decoder, &dec_bytes, &generator, &opts.model)?;
    let set = MotionSet::read(&opts.motions)?;
    if 3 * set.manifest.landmarks.len() != generator.dims() {
        return Err(EvalError::Landmarks {
            motions: opts.motions.clone(),
            landmarks: set.manifest.landmarks.len(),
            model: opts.model.clone(),
            moved: generator.dims() / 3,
        });
    }
    let (train, test) = (set.split(Split::Train), set.split(Split::Test));
    if train.is_empty() || test.len() < 2 {
        return Err(EvalError::Split {
            path: opts.motions.clone(),
            train: train.len(),
            test: test.len(),
        });
    }
    let own = |s: usize| -> Vec<Vec<f32>> {
        set.landmark_frames(s)
            .into_iter()
            .map(<[f32]>::to_vec)
            .collect()
    };
    let train_seqs: Vec<Vec<Vec<f32>>> = train.iter().map(|&s| own(s)).collect();
    let train_features = features(
        &train_seqs,
        &format!("{}: training", opts.motions.display()),
    )?;
    let train_labels: Vec<usize> = train.iter().map(|&s| set.label(s)).collect();
    let test_labels: Vec<usize> = test.iter().map(|&s| set.label(s)).collect();

    let device = opts.backend.autodiff_device(settings.seed)?;
    let epochs = settings.classifier.epochs + settings.lstm.epochs;
    let bar = crate::training::progress::bar(epochs as u64, opts.quiet);
    let (classifier, classifier_losses) = classifier::train(
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
    let (lstm, lstm_losses) = lstm_baseline::train(
        &train_features,
        &train_labels,
        LABELS.len(),
        &settings.lstm,
        &device,
        &mut |_, loss| {
            bar.inc(1);
            bar.set_message(format!("LSTM baseline: squared error {loss:.4}"));
        },
    )?;
    bar.finish_and_clear();
    let (train_predicted, train_h) = classifier.predict(&train_features, &device);
    let lstm_motions: Vec<Vec<f32>> = (0..LABELS.len())
        .map(|l| lstm.generate(l, &device))
        .collect::<Result<_, _>>()?;

    let base = settings.seed.wrapping_mul(SEED_STRIDE);
    let mut generated_info = Vec::with_capacity(test.len());
    let mut rows: [Vec<Vec<Vec<f32>>>; 3] = Default::default();
    for (k, &s) in test.iter().enumerate() {
        let neutral = set.landmark_frame(s, 0);
        let label = test_labels[k];
        let seed = base.wrapping_add(k as u64);
        rows[0].push(own(s));
        rows[1].push(generated(&generator, label, seed, neutral)?);
        rows[2].push(lstm_on(&lstm_motions[label], neutral)?);
        generated_info.push(Generated {
            label: LABELS[label].to_owned(),
            identity: set.manifest.sequences[s].identity,
            seed,
        });
    }
    let redetector = Redetector::new(&decoder);
    let decoder_neutral = redetector.neutral_landmarks();
    let diversity_seeds: Vec<u64> = (0..settings.diversity_seeds as u64)
        .map(|j| base.wrapping_add(DIVERSITY_OFFSET + j))
        .collect();
    let mut diversity: [Vec<Vec<Vec<Vec<f32>>>>; 2] = Default::default();
    for label in 0..LABELS.len() {
        diversity[0].push(
            diversity_seeds
                .iter()
                .map(|&seed| generated(&generator, label, seed, &decoder_neutral))
                .collect::<Result<_, _>>()?,
        );
        // The LSTM takes no seed: one generation per seed all the same.
        diversity[1].push(
            diversity_seeds
                .iter()
                .map(|_| -> Result<_, EvalError> {
                    let m = lstm.generate(label, &device)?;
                    Ok(lstm_on(&m, &decoder_neutral)?)
                })
                .collect::<Result<_, _>>()?,
        );
    }
    let gen_lm = Reading { rows, diversity };
    let det_lm = gen_lm
        .redetected(&redetector)
        .map_err(|source| EvalError::Redetect {
            path: opts.decoder.clone(),
            source,
        })?;

    let mut by_label = vec![Vec::new(); LABELS.len()];
    for (k, &l) in test_labels.iter().enumerate() {
        by_label[l].push(k);
    }
    let judge = Judge {
        classifier: &classifier,
        device: &device,
        test_labels: &test_labels,
        train_features: &train_h,
        by_label,
    };
    let report = EvalReport {
        model: opts.model.display().to_string(),
        decoder: opts.decoder.display().to_string(),
        motions: opts.motions.display().to_string(),
        settings: settings.clone(),
        train_sequences: train.len(),
        test_sequences: test.len(),
        det_lm_neutral: "the decoder's template neutral (s2d.h0.pos)".to_owned(),
        classifier_train_accuracy: classifier::accuracy(&train_predicted, &train_labels),
        classifier_losses,
        lstm_losses,
        gen_lm: judge.row(&gen_lm, "Gen-LM", true)?,
        det_lm: judge.row(&det_lm, "Det-LM", false)?,
        generated: generated_info,
        diversity_seeds,
        seconds: started.elapsed().as_secs_f64(),
    };
    write_report(&opts.report, &report)?;
    Ok(report)
}

fn lstm_on(motion: &[f32], neutral: &[f32]) -> Result<Vec<Vec<f32>>, SrvfError> {
    lstm_baseline::on_neutral(motion, neutral)
}

fn write_report(path: &Path, report: &EvalReport) -> Result<(), EvalError> {
    let json = serde_json::to_string_pretty(report).map_err(|source| EvalError::Encode {
        path: path.to_owned(),
        source,
    })?;
    Ok(crate::io::atomic::write(path, json.as_bytes())?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_model_and_too_few_diversity_seeds_are_refused_by_variant() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("missing.sinew");
        let mut opts = EvalMotion {
            model: missing.clone(),
            decoder: dir.path().join("decoder.sinew"),
            motions: dir.path().join("motions"),
            report: dir.path().join("report.json"),
            settings: EvalSettings::new(1, 1),
            backend: Backend::Flex,
            quiet: true,
        };
        let e = eval_motion(&opts).unwrap_err();
        assert!(
            matches!(&e, EvalError::Read(ContainerError::Read { path, .. }) if *path == missing),
            "{e:?}"
        );
        opts.settings.diversity_seeds = 1;
        let e = eval_motion(&opts).unwrap_err();
        assert!(matches!(e, EvalError::DiversitySeeds), "{e:?}");
        assert!(!opts.report.exists());
    }
}
