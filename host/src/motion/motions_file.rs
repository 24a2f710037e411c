//! The on-disk form of a motion set (`motions.sinew` and `manifest.json` in a folder;
//! docs/MOTION.md and docs/FORMAT.md, "Motion sets"): [`MotionSet::write`], [`MotionSet::read`].
//!
//! The dense frames are not stored: frame f of a sequence is its identity's neutral plus
//! Σ_j w_j · delta_j, recomputed on demand ([`MotionSet::frame`]). The landmarks are stored, and
//! reading recomputes them from the weights and checks every bit, so a file whose numbers
//! disagree is refused.

use std::path::Path;

use sinew_core::ArtifactKind;

use super::data::{
    DATA_FILE, FIRST_VERSION, MANIFEST_FILE, MANIFEST_FORMAT, MANIFEST_VERSION, Manifest,
    MotionSet, Split, tracked,
};
use crate::io::container::{SinewWriter, WriterError};
use crate::io::dataset::{
    self, ContentError, DataSetError, Entry, Layout, ManifestProblem, Sections, Versioned, count,
    flat, points,
};

/// `content` metadata of a motion set's `.sinew` file.
pub const CONTENT: &str = "motions";

const LAYOUT: Layout = Layout {
    manifest: MANIFEST_FILE,
    data: DATA_FILE,
    what: "a motion-set manifest",
    format: MANIFEST_FORMAT,
    version: MANIFEST_VERSION,
};

impl Versioned for Manifest {
    fn format_version(&self) -> (&str, u32) {
        // A version-1 set is a version-2 set without variation: its manifest has no styles,
        // envelopes, events or noise, which read as none.
        let version = if self.version == FIRST_VERSION {
            MANIFEST_VERSION
        } else {
            self.version
        };
        (&self.format, version)
    }
}

impl MotionSet {
    /// The `motions.` sections and metadata, as a `.sinew` file (kind `Performance`: recorded
    /// per-frame inputs).
    pub fn to_bytes(&self) -> Result<Vec<u8>, WriterError> {
        let m = &self.manifest;
        let (v, i, e) = (self.vertices(), self.neutrals.len(), m.expressions.len());
        let frames: usize = m.sequences.iter().map(|s| s.frames).sum();
        let mut w = SinewWriter::new(ArtifactKind::Performance);
        w.meta("content", CONTENT)
            .meta("version", MANIFEST_VERSION)
            .meta("units", m.units.name())
            .meta("seed", m.config.seed)
            .meta("source", &m.source);
        let tpl: Vec<f32> = self.template.positions.iter().flatten().copied().collect();
        w.f32s("motions.template", &[v, 3], &tpl)?;
        let tri: Vec<u32> = self.template.polygons.iter().flatten().copied().collect();
        w.u32s("motions.tri", &[self.template.polygons.len(), 3], &tri)?;
        w.u32s("motions.lmk", &[m.landmarks.len()], &m.landmarks)?;
        w.f32s("motions.ident", &[i, v, 3], &flat(&self.neutrals))?;
        w.f32s("motions.delta", &[i, e, v, 3], &flat(&self.deltas))?;
        let weights: Vec<f32> = self.weights.iter().flatten().copied().collect();
        w.f32s("motions.weights", &[frames, e], &weights)?;
        let lmk: Vec<f32> = self.landmarks.iter().flatten().copied().collect();
        w.f32s("motions.landmarks", &[frames, m.landmarks.len(), 3], &lmk)?;
        w.to_bytes()
    }

    /// Writes `motions.sinew` and `manifest.json` into `dir` (created if missing), each
    /// atomically.
    pub fn write(&self, dir: &Path) -> Result<(), DataSetError> {
        dataset::write(dir, &LAYOUT, self.to_bytes(), &self.manifest)
    }

    /// Reads a motion set written by [`MotionSet::write`], checking that the manifest and the
    /// numbers agree; errors name the offending file.
    pub fn read(dir: &Path) -> Result<Self, DataSetError> {
        dataset::read(dir, &LAYOUT, check_manifest, |m, (), bytes| {
            Self::from_parts(m, bytes)
        })
    }

    fn from_parts(manifest: Manifest, bytes: &[u8]) -> Result<Self, ContentError> {
        let f = Sections::open(bytes, ArtifactKind::Performance, CONTENT)?;
        let frames: usize = manifest.sequences.iter().map(|s| s.frames).sum();
        let (v, i, e, k, n) = (
            count(manifest.vertices)?,
            count(manifest.identities.len())?,
            count(manifest.expressions.len())?,
            count(manifest.landmarks.len())?,
            count(frames)?,
        );
        let template = f.template("motions", v)?;
        let lmk = f.u32s("motions.lmk", &[k])?;
        if lmk != manifest.landmarks {
            return Err(ContentError::Landmarks {
                name: "motions.lmk".into(),
            });
        }
        let split = |s: Vec<f32>| -> Vec<Vec<[f32; 3]>> {
            s.chunks_exact(3 * v as usize).map(points).collect()
        };
        let neutrals = split(f.f32s("motions.ident", &[i, v, 3])?);
        let deltas = split(f.f32s("motions.delta", &[i, e, v, 3])?);
        let all_weights = f.f32s("motions.weights", &[n, e])?;
        if !all_weights.iter().all(|w| (0.0..=1.0).contains(w)) {
            return Err(ContentError::WeightRange {
                name: "motions.weights".into(),
            });
        }
        let all_landmarks = f.f32s("motions.landmarks", &[n, k, 3])?;
        let (mut weights, mut landmarks) = (Vec::new(), Vec::new());
        let (mut at_w, mut at_l) = (0, 0);
        let (e, d) = (e as usize, 3 * k as usize);
        for (s, spec) in manifest.sequences.iter().enumerate() {
            let w = all_weights[at_w..at_w + spec.frames * e].to_vec();
            let l = all_landmarks[at_l..at_l + spec.frames * d].to_vec();
            (at_w, at_l) = (at_w + spec.frames * e, at_l + spec.frames * d);
            let expected = tracked(
                manifest.config.seed,
                s,
                spec,
                &neutrals[spec.identity],
                &deltas,
                &w,
                e,
                &lmk,
            );
            if let Some(fr) = (0..spec.frames).find(|&fr| {
                expected[fr * d..(fr + 1) * d]
                    .iter()
                    .zip(&l[fr * d..(fr + 1) * d])
                    .any(|(a, b)| a.to_bits() != b.to_bits())
            }) {
                return Err(ContentError::Frame {
                    name: "motions.landmarks".into(),
                    entry: Entry::Sequence(s),
                    frame: fr,
                });
            }
            weights.push(w);
            landmarks.push(l);
        }
        Ok(Self {
            manifest,
            template,
            neutrals,
            deltas,
            weights,
            landmarks,
        })
    }
}

/// The manifest's own rules: settings, labels, landmarks, identities, the split and frame counts.
fn check_manifest(m: &Manifest) -> Result<(), ManifestProblem> {
    m.config.validate().map_err(|e| ManifestProblem::Setting {
        problem: e.to_string(),
    })?;
    if !m
        .labels
        .iter()
        .map(String::as_str)
        .eq(super::classes::LABELS)
    {
        return Err(ManifestProblem::Labels {
            labels: m.labels.clone(),
        });
    }
    if m.landmarks.len() != 68 || m.landmarks.iter().any(|&l| l as usize >= m.vertices) {
        return Err(ManifestProblem::Landmarks {
            vertices: m.vertices,
        });
    }
    for (s, spec) in m.sequences.iter().enumerate() {
        let entry = Entry::Sequence(s);
        if spec.identity >= m.identities.len() {
            return Err(ManifestProblem::Identity {
                entry,
                identity: spec.identity,
                count: m.identities.len(),
            });
        }
        if !m.labels.contains(&spec.label) {
            return Err(ManifestProblem::UnknownLabel {
                entry,
                label: spec.label.clone(),
            });
        }
        if spec.frames < 2 {
            return Err(ManifestProblem::TooFewFrames { entry });
        }
        if (spec.split == Split::Test) != (spec.repetition == 0) {
            return Err(ManifestProblem::Split {
                entry,
                repetition: spec.repetition,
                side: format!("{:?}", spec.split),
            });
        }
    }
    Ok(())
}
