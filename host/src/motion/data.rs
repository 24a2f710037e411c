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
//! Version 2 (2026-11-27) adds what makes real sequences of one label differ
//! ([`super::variation`]): each identity's style of each label, and per sequence an envelope, co-
//! activations and tracking noise on the landmarks, all set by [`Variation`]'s knobs. A version-1
//! set (no variation) is still read, as a version-2 set whose variation is none.
//!
//! Sequences run identity-major, then label, then repetition; repetition 0 of every (identity,
//! label) is the test set, the rest trains (the paper's split, section 4.3: "the first
//! sub-sequence for each subject and expression is used as test set").

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::classes::{LABELS, PATTERNS, used_expressions};
use super::variation::{self, COACTIVATIONS, Envelope, Event, Style, Variation};
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
/// Version of the manifest and of the `motions.` sections: 2 since 2026-11-27 (styles,
/// envelopes, co-activations, tracking noise); version-1 sets are read as version 2 without
/// variation.
pub const MANIFEST_VERSION: u32 = 2;
/// The first version, still read.
pub const FIRST_VERSION: u32 = 1;

/// What to generate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionsConfig {
    /// Seed of every random choice.
    pub seed: u64,
    /// Number of identities (random neutrals).
    pub identities: usize,
    /// Sequences per identity and label (the first of each is a test sequence).
    pub per_class: usize,
    /// What makes sequences of one label differ (version 2; absent in a version-1 manifest,
    /// whose sets have none).
    #[serde(default = "Variation::none")]
    pub variation: Variation,
}

impl Default for MotionsConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            // CoMA's 12 subjects; 12 × 12 test sequences, the paper's 144.
            identities: 12,
            per_class: 8,
            variation: Variation::default(),
        }
    }
}

/// The rule of [`MotionsConfig`] a configuration breaks.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidMotionsConfig {
    /// No identities.
    #[error("at least 1 identity is needed")]
    Identities,
    /// Fewer than 2 sequences per class: none would be left to train on.
    #[error("at least 2 sequences per identity and class are needed (the first is a test one)")]
    PerClass,
    /// A variation knob out of its range.
    #[error("{option} {value}: must be {rule}")]
    Knob {
        /// The command-line option.
        option: &'static str,
        /// Its value.
        value: f32,
        /// Its range.
        rule: &'static str,
    },
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
        for (option, value, probability) in self.variation.knobs() {
            let ok = value.is_finite() && value >= 0.0 && (!probability || value <= 1.0);
            if !ok {
                return Err(InvalidMotionsConfig::Knob {
                    option,
                    value,
                    rule: if probability {
                        "a number from 0 to 1"
                    } else {
                        "a finite number of at least 0"
                    },
                });
            }
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
    /// More identities than the kit has identity modes.
    #[error(
        "--identities {asked}: more than the {modes} identity modes of the kit {}",
        path.display()
    )]
    TooManyIdentities {
        /// The kit's folder.
        path: PathBuf,
        /// The identities asked for.
        asked: usize,
        /// The kit's identity modes.
        modes: usize,
    },
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
    /// The parts: the identity's style of the label (the pattern's order, then borrowed and
    /// leaned-in deltas).
    pub parts: Vec<PartSpec>,
    /// The neighbouring class this sequence mixes in and how much, μ (version 2).
    #[serde(default)]
    pub mix: Option<(String, f32)>,
    /// How the parts move together (version 2; flat in version 1).
    #[serde(default = "Envelope::flat")]
    pub envelope: Envelope,
    /// Co-activations of deltas outside the class (version 2).
    #[serde(default)]
    pub events: Vec<Event>,
    /// σ of the landmarks' tracking noise (version 2; 0 in version 1).
    #[serde(default)]
    pub tracking_noise: f32,
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
    /// Each identity's style of each label (version 2; empty in version 1).
    #[serde(default)]
    pub styles: Vec<Vec<Style>>,
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

/// Every delta a motion set stores: those the patterns use and the co-activations', sorted.
pub fn stored_expressions() -> Vec<&'static str> {
    let mut names = used_expressions();
    names.extend(COACTIVATIONS.iter().flat_map(|g| g.iter().copied()));
    names.sort_unstable();
    names.dedup();
    names
}

/// What [`draw`] draws: identities, their styles, the sequences and their per-frame weights.
type Drawn = (
    Vec<Vec<f32>>,
    Vec<Vec<Style>>,
    Vec<SequenceSpec>,
    Vec<Vec<f32>>,
);

/// Draws the identities, styles and sequences of `config` over `modes` identity modes, and each
/// sequence's per-frame weights over `expressions` (the stored deltas, by name). Pure: the same
/// inputs give the same draw.
fn draw(config: &MotionsConfig, expressions: &[&str], modes: usize) -> Drawn {
    // PCG-64, as `data s2d-pairs` draws, on a stream of its own.
    let mut rng = Stream::new(
        config.seed,
        0x4d07_1035,
        0x00a0_2bdb_0000_0000_0000_0000_0000_0003,
    );
    let v = &config.variation;
    let identities: Vec<Vec<f32>> = (0..config.identities)
        .map(|_| (0..modes).map(|_| rng.normal() as f32).collect())
        .collect();
    let styles: Vec<Vec<Style>> = (0..config.identities)
        .map(|_| {
            (0..LABELS.len())
                .map(|l| variation::style(v, l, &mut rng))
                .collect()
        })
        .collect();
    let e = expressions.len();
    let slot = |name: &str| expressions.iter().position(|n| *n == name).unwrap_or(e);
    let mut sequences = Vec::new();
    let mut weights = Vec::new();
    for (identity, identity_styles) in styles.iter().enumerate() {
        for (l, (label, variants)) in LABELS.iter().zip(PATTERNS).enumerate() {
            for repetition in 0..config.per_class {
                let variant = rng.below(variants.len());
                let intensity = rng.uniform_f32(INTENSITY.0, INTENSITY.1);
                let frames = FRAMES_RANGE.0 + rng.below(FRAMES_RANGE.1 - FRAMES_RANGE.0 + 1);
                let (envelope, peaks) = variation::envelope(v, &mut rng);
                let own = &identity_styles[l].parts[variant];
                let mix = variation::mix(v, l, &mut rng);
                let style = match mix {
                    Some((n, mu)) => variation::mixed(own, &identity_styles[n].parts[0], mu),
                    None => own.clone(),
                };
                let parts: Vec<PartSpec> = style
                    .iter()
                    .filter(|(_, weight)| *weight > 0.0)
                    .map(|(shape, weight)| {
                        let apex = (weight * intensity * rng.uniform_f32(0.85, 1.15)).min(1.0);
                        let onset = rng.uniform_f32(0.0, 0.35f32.min(peaks.0 - 0.1));
                        let peak = rng.uniform_f32(peaks.0, peaks.1);
                        let easing = Easing::ALL[rng.below(Easing::ALL.len())];
                        PartSpec {
                            shape: shape.clone(),
                            apex,
                            onset,
                            peak,
                            easing,
                        }
                    })
                    .collect();
                let events = variation::events(v, &mut rng);
                let mut w = vec![0.0f32; frames * e];
                for f in 1..frames {
                    let t = f as f32 / (frames - 1) as f32;
                    let g = envelope.at(t);
                    for p in &parts {
                        let x = ((t - p.onset) / (p.peak - p.onset)).clamp(0.0, 1.0);
                        let noise = NOISE * intensity * rng.normal() as f32;
                        if let Some(slot) = w.get_mut(f * e + slot(&p.shape)) {
                            let rise = p.apex * p.easing.at(x * envelope.reach);
                            *slot = (rise * g + noise).clamp(0.0, 1.0);
                        }
                    }
                    for ev in &events {
                        for shape in &ev.shapes {
                            if let Some(slot) = w.get_mut(f * e + slot(shape)) {
                                *slot = (*slot + ev.at(t)).clamp(0.0, 1.0);
                            }
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
                    mix: mix.map(|(n, mu)| (LABELS[n].to_owned(), mu)),
                    envelope,
                    events,
                    tracking_noise: v.noise(),
                });
                weights.push(w);
            }
        }
    }
    (identities, styles, sequences, weights)
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

/// Sequence `s`'s landmarks, `[frames × K × 3]`: each frame's landmark vertices plus the
/// sequence's tracking noise ([`variation::tracking_noise`], from `seed` and `s`), frame 0 exact.
#[allow(clippy::too_many_arguments)]
pub(crate) fn tracked(
    seed: u64,
    s: usize,
    spec: &SequenceSpec,
    neutral: &[[f32; 3]],
    deltas: &[Vec<[f32; 3]>],
    weights: &[f32],
    e: usize,
    landmarks: &[u32],
) -> Vec<f32> {
    let d = 3 * landmarks.len();
    let noise = variation::tracking_noise(seed, s, spec.frames, d, spec.tracking_noise);
    let mut out: Vec<f32> = (0..spec.frames)
        .flat_map(|f| {
            frame_of(
                neutral,
                deltas,
                spec.identity,
                weights,
                e,
                f,
                Some(landmarks),
            )
        })
        .flatten()
        .collect();
    // Frame 0 is left alone (the neutral, exactly), and so is every frame of a sequence without
    // noise (adding 0 would turn -0.0 into 0.0).
    if spec.tracking_noise != 0.0 {
        for (x, n) in out.iter_mut().zip(&noise).skip(d) {
            *x += n;
        }
    }
    out
}

/// Generates a motion set from the ICT-FaceKit in `kit`.
pub fn generate(kit: &IctFaceKit, config: &MotionsConfig) -> Result<MotionSet, MotionDataError> {
    config.validate()?;
    let expressions = stored_expressions();
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
    if config.identities > modes {
        return Err(MotionDataError::TooManyIdentities {
            path: kit.dir().to_owned(),
            asked: config.identities,
            modes,
        });
    }
    let (identities, styles, sequences, weights) = draw(config, &expressions, modes);
    let face = FaceRegion::of(kit, &expressions, modes)?;
    let neutrals: Vec<Vec<[f32; 3]>> = identities.iter().map(|w| face.neutral(w)).collect();
    let deltas = face.transferred(&neutrals)?;
    let e = expressions.len();
    let landmark_seqs: Vec<Vec<f32>> = sequences
        .iter()
        .zip(&weights)
        .enumerate()
        .map(|(s, (spec, w))| {
            tracked(
                config.seed,
                s,
                spec,
                &neutrals[spec.identity],
                &deltas,
                w,
                e,
                &face.landmarks,
            )
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
        styles,
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
