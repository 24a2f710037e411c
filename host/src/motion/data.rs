//! Labelled landmark motions from ICT-FaceKit, standing in for CoMA's 4D sequences (no licensed
//! 4D data set is reachable): `sinew data motions`.
//!
//! Identities are drawn as `data s2d-pairs` draws them (the generic neutral plus Σ_m w_m ·
//! identity_m, w_m ~ N(0, 1) over all identity modes) and every expression delta a class uses is
//! deformation-transferred onto each identity ([`crate::geometry::deformation`]), so each identity
//! performs the expressions in its own way. A sequence plays one variant of one class's pattern
//! ([`super::classes`]) from neutral to apex: every part j of the pattern gets an apex weight
//! `a_j = pattern weight · intensity · jitter` (intensity uniform in [`INTENSITY`], jitter uniform
//! in ±15 %, at most 1), its own onset and peak time, and an easing curve; frame f of F at time
//! t = f / (F − 1) has weights `w_j = a_j · ease_j(clamp((t − onset_j) / (peak_j − onset_j)))`
//! plus small Gaussian noise (σ = [`NOISE`] · intensity), clamped to [0, 1]; frame 0 is the
//! neutral, exactly. F is uniform in [`FRAMES_RANGE`], like CoMA's sub-sequences of varying
//! length. The dense frame is `neutral + Σ_j w_j · delta_j` summed in pattern order, and its 68
//! landmark vertices are the frame's landmarks.
//!
//! Sequences run identity-major, then label, then repetition; repetition 0 of every (identity,
//! label) is the test set, the rest trains (the paper's split, section 4.3: "the first
//! sub-sequence for each subject and expression is used as test set").

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::classes::{LABELS, PATTERNS, used_expressions};
use crate::geometry::identities::{FaceRegion, RegionError};
use crate::io::dataset::DataSetError;
use crate::io::ict::{FACE_REGION, IctError, IctFaceKit};
use crate::io::mesh::Mesh;
use crate::training::random::Stream;

/// Range of a sequence's apex intensity.
pub const INTENSITY: (f32, f32) = (0.6, 1.0);
/// Per-frame weight noise, as a fraction of the intensity.
pub const NOISE: f32 = 0.01;
/// Range of a sequence's number of frames (inclusive).
pub const FRAMES_RANGE: (usize, usize) = (30, 60);
/// The numbers of a motion set, inside its folder.
pub const DATA_FILE: &str = "motions.sinew";
/// The manifest of a motion set, inside its folder.
pub const MANIFEST_FILE: &str = "manifest.json";
/// `format` field of the manifest.
pub const MANIFEST_FORMAT: &str = "sinew-motions";
/// Version of the manifest and of the `motions.` sections.
pub const MANIFEST_VERSION: u32 = 1;

/// What to generate.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionsConfig {
    /// Seed of every random choice.
    pub seed: u64,
    /// Number of identities (random neutrals).
    pub identities: usize,
    /// Sequences per identity and label (the first of each is a test sequence).
    pub per_class: usize,
}

impl Default for MotionsConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            // CoMA's 12 subjects; 12 × 12 test sequences, the paper's 144.
            identities: 12,
            per_class: 8,
        }
    }
}

/// The rule of [`MotionsConfig`] a configuration breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidMotionsConfig {
    /// No identities.
    #[error("at least 1 identity is needed")]
    Identities,
    /// Fewer than 2 sequences per class: none would be left to train on.
    #[error("at least 2 sequences per identity and class are needed (the first is a test one)")]
    PerClass,
}

impl MotionsConfig {
    /// Checks the counts.
    pub fn validate(&self) -> Result<(), InvalidMotionsConfig> {
        if self.identities < 1 {
            return Err(InvalidMotionsConfig::Identities);
        }
        if self.per_class < 2 {
            return Err(InvalidMotionsConfig::PerClass);
        }
        Ok(())
    }
}

/// A motion set that could not be generated or written; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MotionDataError {
    /// Settings that cannot make a motion set.
    #[error(transparent)]
    Config(#[from] InvalidMotionsConfig),
    /// The ICT-FaceKit folder cannot be read (the error names the file).
    #[error(transparent)]
    Kit(#[from] IctError),
    /// A kit without an expression a motion class uses.
    #[error("{}: the kit has no expression {name:?}, which a motion class uses", path.display())]
    MissingExpression {
        /// The kit's folder.
        path: PathBuf,
        /// The expression.
        name: String,
    },
    /// The kit's face region cannot carry identities, or an identity its expressions (the
    /// error names the kit or the identity).
    #[error(transparent)]
    Region(#[from] RegionError),
    /// The motion set cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] DataSetError),
}

/// Which side of the split a sequence is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    /// Trains the generator, the LSTM baseline and the classifier.
    Train,
    /// Repetition 0 of its identity and label.
    Test,
}

/// How a part's weight rises from 0 to its apex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Easing {
    /// `x`.
    Linear,
    /// `x² (3 − 2x)`.
    Smooth,
    /// `x²`.
    EaseIn,
    /// `1 − (1 − x)²`.
    EaseOut,
}

impl Easing {
    const ALL: [Self; 4] = [Self::Linear, Self::Smooth, Self::EaseIn, Self::EaseOut];

    fn at(self, x: f32) -> f32 {
        match self {
            Self::Linear => x,
            Self::Smooth => x * x * (3.0 - 2.0 * x),
            Self::EaseIn => x * x,
            Self::EaseOut => 1.0 - (1.0 - x) * (1.0 - x),
        }
    }
}

/// One part of a sequence: a delta of the pattern and its timing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartSpec {
    /// The expression delta (an ICT-FaceKit blendshape).
    pub shape: String,
    /// Weight at the apex.
    pub apex: f32,
    /// Time (in [0, 1]) the part starts to move.
    pub onset: f32,
    /// Time it reaches its apex.
    pub peak: f32,
    /// Its easing.
    pub easing: Easing,
}

/// One sequence.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequenceSpec {
    /// Index into [`Manifest::identities`].
    pub identity: usize,
    /// One of [`LABELS`].
    pub label: String,
    /// Repetition of its (identity, label); 0 is the test one.
    pub repetition: usize,
    /// Train or test.
    pub split: Split,
    /// The pattern's variant (mouth_side: 0 left, 1 right).
    pub variant: usize,
    /// The apex intensity.
    pub intensity: f32,
    /// Number of frames, neutral first.
    pub frames: usize,
    /// The parts, in the pattern's order.
    pub parts: Vec<PartSpec>,
}

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`MANIFEST_FORMAT`].
    pub format: String,
    /// [`MANIFEST_VERSION`].
    pub version: u32,
    /// The generation settings.
    pub config: MotionsConfig,
    /// Length unit of every coordinate (`cm` for ICT).
    pub units: crate::io::units::Unit,
    /// Provenance with licence and attribution, and that the motions are synthetic.
    pub source: String,
    /// Vertices of the face region.
    pub vertices: usize,
    /// The 68 landmark vertices (iBUG order), indices into the face region.
    pub landmarks: Vec<u32>,
    /// The class labels, [`LABELS`].
    pub labels: Vec<String>,
    /// The expression deltas stored, in the order of the `motions.delta` section.
    pub expressions: Vec<String>,
    /// Each identity's weights, one per identity mode (in standard deviations).
    pub identities: Vec<Vec<f32>>,
    /// The sequences.
    pub sequences: Vec<SequenceSpec>,
}

/// A motion set in memory.
#[derive(Clone, Debug)]
pub struct MotionSet {
    /// The manifest.
    pub manifest: Manifest,
    /// The generic neutral's face region, triangulated.
    pub template: Mesh,
    /// Each identity's neutral face region, `[identities][vertices]`.
    pub neutrals: Vec<Vec<[f32; 3]>>,
    /// Each expression's delta transferred onto each identity, `[identities × expressions]
    /// [vertices]`, identity-major.
    pub deltas: Vec<Vec<[f32; 3]>>,
    /// Each sequence's per-frame weights, `[frames × expressions]` (0 for deltas its pattern does
    /// not use).
    pub weights: Vec<Vec<f32>>,
    /// Each sequence's per-frame landmarks, `[frames × 68 × 3]`.
    pub landmarks: Vec<Vec<f32>>,
}

/// Draws the identities and sequences of `config` over `modes` identity modes, and each
/// sequence's per-frame weights over `expressions` (the stored deltas, by name). Pure: the same
/// inputs give the same draw.
fn draw(
    config: &MotionsConfig,
    expressions: &[&str],
    modes: usize,
) -> (Vec<Vec<f32>>, Vec<SequenceSpec>, Vec<Vec<f32>>) {
    // PCG-64, as `data s2d-pairs` draws, on a stream of its own.
    let mut rng = Stream::new(
        config.seed,
        0x4d07_1035,
        0x00a0_2bdb_0000_0000_0000_0000_0000_0003,
    );
    let identities: Vec<Vec<f32>> = (0..config.identities)
        .map(|_| (0..modes).map(|_| rng.normal() as f32).collect())
        .collect();
    let mut sequences = Vec::new();
    let mut weights = Vec::new();
    for identity in 0..config.identities {
        for (label, variants) in LABELS.iter().zip(PATTERNS) {
            for repetition in 0..config.per_class {
                let variant = rng.below(variants.len());
                let intensity = rng.uniform_f32(INTENSITY.0, INTENSITY.1);
                let frames = FRAMES_RANGE.0 + rng.below(FRAMES_RANGE.1 - FRAMES_RANGE.0 + 1);
                let parts: Vec<PartSpec> = variants[variant]
                    .iter()
                    .map(|&(shape, weight)| {
                        let apex = (weight * intensity * rng.uniform_f32(0.85, 1.15)).min(1.0);
                        let onset = rng.uniform_f32(0.0, 0.35);
                        let peak = rng.uniform_f32(0.65, 1.0);
                        let easing = Easing::ALL[rng.below(Easing::ALL.len())];
                        PartSpec {
                            shape: shape.to_owned(),
                            apex,
                            onset,
                            peak,
                            easing,
                        }
                    })
                    .collect();
                let e = expressions.len();
                let mut w = vec![0.0f32; frames * e];
                for f in 1..frames {
                    let t = f as f32 / (frames - 1) as f32;
                    for p in &parts {
                        let x = ((t - p.onset) / (p.peak - p.onset)).clamp(0.0, 1.0);
                        let noise = NOISE * intensity * rng.normal() as f32;
                        let k = expressions.iter().position(|n| *n == p.shape).unwrap_or(e);
                        if let Some(slot) = w.get_mut(f * e + k) {
                            *slot = (p.apex * p.easing.at(x) + noise).clamp(0.0, 1.0);
                        }
                    }
                }
                sequences.push(SequenceSpec {
                    identity,
                    label: (*label).to_owned(),
                    repetition,
                    split: if repetition == 0 {
                        Split::Test
                    } else {
                        Split::Train
                    },
                    variant,
                    intensity,
                    frames,
                    parts,
                });
                weights.push(w);
            }
        }
    }
    (identities, sequences, weights)
}

impl MotionSet {
    /// Number of sequences.
    pub fn len(&self) -> usize {
        self.manifest.sequences.len()
    }

    /// Whether there are no sequences.
    pub fn is_empty(&self) -> bool {
        self.manifest.sequences.is_empty()
    }

    /// Vertices of the face region.
    pub fn vertices(&self) -> usize {
        self.template.positions.len()
    }

    /// The indices of the sequences on one side of the split, in order.
    pub fn split(&self, split: Split) -> Vec<usize> {
        (0..self.len())
            .filter(|&s| self.manifest.sequences[s].split == split)
            .collect()
    }

    /// The label index of sequence `s`.
    pub fn label(&self, s: usize) -> usize {
        super::classes::label_index(&self.manifest.sequences[s].label).unwrap_or(0)
    }

    /// The neutral of sequence `s`'s identity.
    pub fn neutral(&self, s: usize) -> &[[f32; 3]] {
        &self.neutrals[self.manifest.sequences[s].identity]
    }

    /// Frame `f` of sequence `s` as a dense face region: the neutral plus Σ_j w_j · delta_j,
    /// summed in expression order.
    pub fn frame(&self, s: usize, f: usize) -> Vec<[f32; 3]> {
        let identity = self.manifest.sequences[s].identity;
        frame_of(
            &self.neutrals[identity],
            &self.deltas,
            identity,
            &self.weights[s],
            self.manifest.expressions.len(),
            f,
            None,
        )
    }

    /// Frame `f` of sequence `s`'s landmarks, `[68 × 3]`.
    pub fn landmark_frame(&self, s: usize, f: usize) -> &[f32] {
        let d = 3 * self.manifest.landmarks.len();
        &self.landmarks[s][f * d..(f + 1) * d]
    }

    /// Sequence `s`'s landmark frames, each `[68 × 3]`.
    pub fn landmark_frames(&self, s: usize) -> Vec<&[f32]> {
        (0..self.manifest.sequences[s].frames)
            .map(|f| self.landmark_frame(s, f))
            .collect()
    }
}

/// Frame `f` of a sequence with `weights` (`[frames × e]`) on `neutral`, with `deltas`
/// identity-major; only the vertices in `only` (all when `None`), in that order.
pub(crate) fn frame_of(
    neutral: &[[f32; 3]],
    deltas: &[Vec<[f32; 3]>],
    identity: usize,
    weights: &[f32],
    e: usize,
    f: usize,
    only: Option<&[u32]>,
) -> Vec<[f32; 3]> {
    let pick: Vec<usize> = match only {
        Some(v) => v.iter().map(|&i| i as usize).collect(),
        None => (0..neutral.len()).collect(),
    };
    let mut out: Vec<[f32; 3]> = pick.iter().map(|&i| neutral[i]).collect();
    for (k, &w) in weights[f * e..(f + 1) * e].iter().enumerate() {
        if w == 0.0 {
            continue;
        }
        let d = &deltas[identity * e + k];
        for (o, &i) in out.iter_mut().zip(&pick) {
            for c in 0..3 {
                o[c] += w * d[i][c];
            }
        }
    }
    out
}

/// Generates a motion set from the ICT-FaceKit in `kit`.
pub fn generate(kit: &IctFaceKit, config: &MotionsConfig) -> Result<MotionSet, MotionDataError> {
    config.validate()?;
    let expressions = used_expressions();
    let available = kit.expression_names();
    if let Some(missing) = expressions
        .iter()
        .find(|n| !available.iter().any(|a| a == *n))
    {
        return Err(MotionDataError::MissingExpression {
            path: kit.dir().to_owned(),
            name: (*missing).to_owned(),
        });
    }
    let modes = kit.identity_count();
    let (identities, sequences, weights) = draw(config, &expressions, modes);
    let face = FaceRegion::of(kit, &expressions, modes)?;
    let neutrals: Vec<Vec<[f32; 3]>> = identities.iter().map(|w| face.neutral(w)).collect();
    let deltas = face.transferred(&neutrals)?;
    let e = expressions.len();
    let landmark_seqs: Vec<Vec<f32>> = sequences
        .iter()
        .zip(&weights)
        .map(|(spec, w)| {
            (0..spec.frames)
                .flat_map(|f| {
                    frame_of(
                        &neutrals[spec.identity],
                        &deltas,
                        spec.identity,
                        w,
                        e,
                        f,
                        Some(&face.landmarks),
                    )
                })
                .flatten()
                .collect()
        })
        .collect();
    let manifest = Manifest {
        format: MANIFEST_FORMAT.to_owned(),
        version: MANIFEST_VERSION,
        config: config.clone(),
        units: crate::io::units::Unit::Centimetre,
        source: format!(
            "synthetic motions (CoMA's 12 classes as patterns over ICT-FaceKit deltas, not \
             captured 4D data); ICT-FaceKit Light face model (github ICT-VGL/ICT-FaceKit), \
             Copyright (c) 2020 USC Institute for Creative Technologies, MIT licence; face region \
             {}..{}",
            FACE_REGION.start, FACE_REGION.end
        ),
        vertices: face.vertices(),
        landmarks: face.landmarks,
        labels: LABELS.iter().map(|l| (*l).to_owned()).collect(),
        expressions: expressions.iter().map(|n| (*n).to_owned()).collect(),
        identities,
        sequences,
    };
    Ok(MotionSet {
        manifest,
        template: face.template,
        neutrals,
        deltas,
        weights,
        landmarks: landmark_seqs,
    })
}

/// `sinew data motions`: generates from the kit in `data` and writes to `out`.
pub fn generate_to(
    data: &Path,
    out: &Path,
    config: &MotionsConfig,
) -> Result<MotionSet, MotionDataError> {
    let kit = IctFaceKit::open(data)?;
    let set = generate(&kit, config)?;
    set.write(out)?;
    Ok(set)
}

#[cfg(test)]
mod tests;
