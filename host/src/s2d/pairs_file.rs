//! The on-disk form of a pair set (`pairs.sinew` and `manifest.json` in a folder; docs/S2D.md):
//! [`PairSet::write`], [`PairSet::read`] and the bytes between.

use std::path::Path;

use anyhow::{Context, Result, ensure};
use sinew_core::{ArtifactKind, SinewFile};

use super::data::{
    DATA_FILE, Expressions, MANIFEST_FILE, MANIFEST_FORMAT, MANIFEST_VERSION, Manifest, PairSet,
    combinations_of, flat,
};
use crate::io::container::SinewWriter;
use crate::io::mesh::Mesh;

impl PairSet {
    /// The `pairs.` sections and metadata, as a `.sinew` file.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let m = &self.manifest;
        let (v, i, e, p) = (
            self.vertices(),
            self.neutrals.len(),
            m.expressions.len(),
            self.len(),
        );
        let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
        w.meta("content", "s2d-pairs")
            .meta("version", MANIFEST_VERSION)
            .meta("units", m.units.name())
            .meta("seed", m.config.seed)
            .meta("source", &m.source);
        let tpl: Vec<f32> = self.template.positions.iter().flatten().copied().collect();
        w.f32s("pairs.template", &[v, 3], &tpl)?;
        let tri: Vec<u32> = self.template.polygons.iter().flatten().copied().collect();
        w.u32s("pairs.tri", &[self.template.polygons.len(), 3], &tri)?;
        w.u32s("pairs.lmk", &[m.landmarks.len()], &m.landmarks)?;
        w.f32s("pairs.ident", &[i, v, 3], &flat(&self.neutrals))?;
        match m.config.expressions {
            Expressions::Shared => w.f32s("pairs.delta", &[e, v, 3], &flat(&self.deltas))?,
            Expressions::Transferred => {
                w.f32s("pairs.delta", &[i, e, v, 3], &flat(&self.deltas))?
            }
        };
        let ids: Vec<u32> = m.pairs.iter().map(|s| s.identity as u32).collect();
        w.u32s("pairs.identity", &[p], &ids)?;
        let mut weights = vec![0.0f32; p * e];
        for (k, c) in self.combinations.iter().enumerate() {
            for &(x, wt) in c {
                weights[k * e + x] = wt;
            }
        }
        w.f32s("pairs.weights", &[p, e], &weights)?;
        Ok(w.to_bytes()?)
    }

    /// Writes `pairs.sinew` and `manifest.json` into `dir` (created if missing), each
    /// atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        crate::io::atomic::write(&dir.join(DATA_FILE), &self.to_bytes()?)?;
        let json = serde_json::to_string_pretty(&self.manifest)?;
        crate::io::atomic::write(&dir.join(MANIFEST_FILE), json.as_bytes())
    }

    /// Reads a data set written by [`PairSet::write`], checking that the manifest and the
    /// numbers agree; errors name the offending file.
    pub fn read(dir: &Path) -> Result<Self> {
        let mpath = dir.join(MANIFEST_FILE);
        let text = std::fs::read_to_string(&mpath)
            .with_context(|| format!("{}: cannot read", mpath.display()))?;
        let manifest: Manifest = serde_json::from_str(&text)
            .with_context(|| format!("{}: not an S2D pairs manifest", mpath.display()))?;
        ensure!(
            manifest.format == MANIFEST_FORMAT && manifest.version == MANIFEST_VERSION,
            "{}: format {:?} version {}, expected {MANIFEST_FORMAT:?} version {MANIFEST_VERSION}",
            mpath.display(),
            manifest.format,
            manifest.version
        );
        let combinations =
            combinations_of(&manifest).with_context(|| format!("{}", mpath.display()))?;
        let dpath = dir.join(DATA_FILE);
        let bytes = crate::io::container::read(&dpath)?;
        Self::from_parts(manifest, combinations, &bytes)
            .with_context(|| format!("{}", dpath.display()))
    }

    fn from_parts(
        manifest: Manifest,
        combinations: Vec<Vec<(usize, f32)>>,
        bytes: &[u8],
    ) -> Result<Self> {
        let f = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::S2dDecoder)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        ensure!(
            f.metadata().get("content") == Some("s2d-pairs"),
            "not an S2D pairs file (metadata content={:?})",
            f.metadata().get("content")
        );
        let u = |x: usize| u32::try_from(x).context("count too large");
        let (v, i, e, p) = (
            u(manifest.vertices)?,
            u(manifest.identities.len())?,
            u(manifest.expressions.len())?,
            u(manifest.pairs.len())?,
        );
        let points = |s: Vec<f32>| -> Vec<[f32; 3]> {
            s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        };
        let f32s = |name: &str, dims: &[u32]| -> Result<Vec<f32>> {
            Ok(f.f32_tensor(name, dims)
                .map_err(|e| anyhow::anyhow!("{name}: {e}"))?
                .iter()
                .collect())
        };
        let u32s = |name: &str, dims: &[u32]| -> Result<Vec<u32>> {
            Ok(f.u32_tensor(name, dims)
                .map_err(|e| anyhow::anyhow!("{name}: {e}"))?
                .iter()
                .collect())
        };
        let positions = points(f32s("pairs.template", &[v, 3])?);
        let (tdims, rank) = f
            .dims_of("pairs.tri")
            .map_err(|e| anyhow::anyhow!("pairs.tri: {e}"))?;
        ensure!(
            rank == 2 && tdims[1] == 3,
            "pairs.tri: shape must be [T, 3]"
        );
        let tri = u32s("pairs.tri", &tdims[..2])?;
        ensure!(
            tri.iter().all(|&x| x < v),
            "pairs.tri: vertex index out of range"
        );
        let lmk = u32s("pairs.lmk", &[u(manifest.landmarks.len())?])?;
        ensure!(
            lmk == manifest.landmarks,
            "pairs.lmk differs from the manifest's landmarks"
        );
        ensure!(
            lmk.len() == 68 && lmk.iter().all(|&x| x < v),
            "pairs.lmk: 68 landmark vertices below {v} expected"
        );
        let split = |s: Vec<f32>, n: u32| -> Vec<Vec<[f32; 3]>> {
            s.chunks_exact(3 * v as usize)
                .take(n as usize)
                .map(|c| points(c.to_vec()))
                .collect()
        };
        let neutrals = split(f32s("pairs.ident", &[i, v, 3])?, i);
        let deltas = match manifest.config.expressions {
            Expressions::Shared => split(f32s("pairs.delta", &[e, v, 3])?, e),
            Expressions::Transferred => split(f32s("pairs.delta", &[i, e, v, 3])?, i * e),
        };
        let ids = u32s("pairs.identity", &[p])?;
        let weights = f32s("pairs.weights", &[p, e])?;
        for (k, spec) in manifest.pairs.iter().enumerate() {
            ensure!(
                ids[k] as usize == spec.identity,
                "pairs.identity: pair {k} is identity {} here, {} in the manifest",
                ids[k],
                spec.identity
            );
            let mut row = vec![0.0f32; e as usize];
            for &(x, wt) in &combinations[k] {
                row[x] = wt;
            }
            ensure!(
                row[..] == weights[k * e as usize..(k + 1) * e as usize],
                "pairs.weights: pair {k} differs from the manifest's combination"
            );
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
            combinations,
        })
    }
}
