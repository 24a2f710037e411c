//! The on-disk form of a motion set (`motions.sinew` and `manifest.json` in a folder;
//! docs/MOTION.md and docs/FORMAT.md, "Motion sets"): [`MotionSet::write`], [`MotionSet::read`].
//!
//! The dense frames are not stored: frame f of a sequence is its identity's neutral plus
//! Σ_j w_j · delta_j, recomputed on demand ([`MotionSet::frame`]). The landmarks are stored, and
//! reading recomputes them from the weights and checks every bit, so a file whose numbers
//! disagree is refused.

use std::path::Path;

use anyhow::{Context, Result, anyhow, ensure};
use sinew_core::{ArtifactKind, SinewFile};

use super::data::{
    DATA_FILE, MANIFEST_FILE, MANIFEST_FORMAT, MANIFEST_VERSION, Manifest, MotionSet, Split,
    frame_of,
};
use crate::io::container::SinewWriter;
use crate::io::mesh::Mesh;

/// `content` metadata of a motion set's `.sinew` file.
pub const CONTENT: &str = "motions";

fn flat(v: &[Vec<[f32; 3]>]) -> Vec<f32> {
    v.iter().flatten().flatten().copied().collect()
}

impl MotionSet {
    /// The `motions.` sections and metadata, as a `.sinew` file (kind `Performance`: recorded
    /// per-frame inputs).
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
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
        Ok(w.to_bytes()?)
    }

    /// Writes `motions.sinew` and `manifest.json` into `dir` (created if missing), each
    /// atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        crate::io::atomic::write(&dir.join(DATA_FILE), &self.to_bytes()?)?;
        let json = serde_json::to_string_pretty(&self.manifest)?;
        crate::io::atomic::write(&dir.join(MANIFEST_FILE), json.as_bytes())
    }

    /// Reads a motion set written by [`MotionSet::write`], checking that the manifest and the
    /// numbers agree; errors name the offending file.
    pub fn read(dir: &Path) -> Result<Self> {
        let mpath = dir.join(MANIFEST_FILE);
        let text = std::fs::read_to_string(&mpath)
            .with_context(|| format!("{}: cannot read", mpath.display()))?;
        let manifest: Manifest = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a motion-set manifest", mpath.display()))?;
        ensure!(
            manifest.format == MANIFEST_FORMAT && manifest.version == MANIFEST_VERSION,
            "{}: format {:?} version {}, expected {MANIFEST_FORMAT:?} version {MANIFEST_VERSION}",
            mpath.display(),
            manifest.format,
            manifest.version
        );
        check_manifest(&manifest).with_context(|| format!("{}", mpath.display()))?;
        let dpath = dir.join(DATA_FILE);
        let bytes = crate::io::container::read(&dpath)?;
        Self::from_parts(manifest, &bytes).with_context(|| format!("{}", dpath.display()))
    }

    fn from_parts(manifest: Manifest, bytes: &[u8]) -> Result<Self> {
        let f = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::Performance)
            .map_err(|e| anyhow!("{e}"))?;
        ensure!(
            f.metadata().get("content") == Some(CONTENT),
            "not a motion set (metadata content={:?})",
            f.metadata().get("content")
        );
        let u = |x: usize| u32::try_from(x).context("count too large");
        let frames: usize = manifest.sequences.iter().map(|s| s.frames).sum();
        let (v, i, e, k, n) = (
            u(manifest.vertices)?,
            u(manifest.identities.len())?,
            u(manifest.expressions.len())?,
            u(manifest.landmarks.len())?,
            u(frames)?,
        );
        let f32s = |name: &str, dims: &[u32]| -> Result<Vec<f32>> {
            Ok(f.f32_tensor(name, dims)
                .map_err(|e| anyhow!("{name}: {e}"))?
                .iter()
                .collect())
        };
        let u32s = |name: &str, dims: &[u32]| -> Result<Vec<u32>> {
            Ok(f.u32_tensor(name, dims)
                .map_err(|e| anyhow!("{name}: {e}"))?
                .iter()
                .collect())
        };
        let points = |s: &[f32]| -> Vec<[f32; 3]> {
            s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        };
        let positions = points(&f32s("motions.template", &[v, 3])?);
        let (tdims, rank) = f
            .dims_of("motions.tri")
            .map_err(|e| anyhow!("motions.tri: {e}"))?;
        ensure!(
            rank == 2 && tdims[1] == 3,
            "motions.tri: shape must be [T, 3]"
        );
        let tri = u32s("motions.tri", &tdims[..2])?;
        ensure!(
            tri.iter().all(|&x| x < v),
            "motions.tri: vertex index out of range"
        );
        let lmk = u32s("motions.lmk", &[k])?;
        ensure!(
            lmk == manifest.landmarks,
            "motions.lmk differs from the manifest's landmarks"
        );
        let split = |s: Vec<f32>| -> Vec<Vec<[f32; 3]>> {
            s.chunks_exact(3 * v as usize).map(points).collect()
        };
        let neutrals = split(f32s("motions.ident", &[i, v, 3])?);
        let deltas = split(f32s("motions.delta", &[i, e, v, 3])?);
        let all_weights = f32s("motions.weights", &[n, e])?;
        ensure!(
            all_weights.iter().all(|w| (0.0..=1.0).contains(w)),
            "motions.weights: a weight outside [0, 1]"
        );
        let all_landmarks = f32s("motions.landmarks", &[n, k, 3])?;
        let (mut weights, mut landmarks) = (Vec::new(), Vec::new());
        let (mut at_w, mut at_l) = (0, 0);
        let (e, d) = (e as usize, 3 * k as usize);
        for (s, spec) in manifest.sequences.iter().enumerate() {
            let w = all_weights[at_w..at_w + spec.frames * e].to_vec();
            let l = all_landmarks[at_l..at_l + spec.frames * d].to_vec();
            (at_w, at_l) = (at_w + spec.frames * e, at_l + spec.frames * d);
            for fr in 0..spec.frames {
                let expected = frame_of(
                    &neutrals[spec.identity],
                    &deltas,
                    spec.identity,
                    &w,
                    e,
                    fr,
                    Some(&lmk),
                );
                let stored = &l[fr * d..(fr + 1) * d];
                ensure!(
                    expected
                        .iter()
                        .flatten()
                        .zip(stored)
                        .all(|(a, b)| a.to_bits() == b.to_bits()),
                    "motions.landmarks: sequence {s} frame {fr} differs from its weights' frame"
                );
            }
            weights.push(w);
            landmarks.push(l);
        }
        let template = Mesh::new(
            positions,
            tri.chunks_exact(3).map(<[u32]>::to_vec).collect(),
        );
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

/// The manifest's own rules: labels, landmarks, identities, the split and frame counts.
fn check_manifest(m: &Manifest) -> Result<()> {
    ensure!(
        m.labels
            .iter()
            .map(String::as_str)
            .eq(super::classes::LABELS),
        "labels {:?} are not CoMA's twelve",
        m.labels
    );
    ensure!(
        m.landmarks.len() == 68 && m.landmarks.iter().all(|&l| (l as usize) < m.vertices),
        "68 landmark vertices below {} expected",
        m.vertices
    );
    for (s, spec) in m.sequences.iter().enumerate() {
        ensure!(
            spec.identity < m.identities.len(),
            "sequence {s}: identity {} of {}",
            spec.identity,
            m.identities.len()
        );
        ensure!(
            m.labels.contains(&spec.label),
            "sequence {s}: unknown label {:?}",
            spec.label
        );
        ensure!(spec.frames >= 2, "sequence {s}: fewer than 2 frames");
        ensure!(
            (spec.split == Split::Test) == (spec.repetition == 0),
            "sequence {s}: repetition {} is on the {:?} side; repetition 0 and only it is a test \
             sequence",
            spec.repetition,
            spec.split
        );
    }
    Ok(())
}
