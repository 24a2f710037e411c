//! The on-disk form of a pair set (`pairs.sinew` and `manifest.json` in a folder; docs/S2D.md):
//! [`PairSet::write`], [`PairSet::read`] and the bytes between.

use std::path::Path;

use sinew_core::ArtifactKind;

use super::data::{
    DATA_FILE, Expressions, MANIFEST_FILE, MANIFEST_FORMAT, MANIFEST_VERSION, Manifest, PairSet,
    combinations_of,
};
use crate::io::container::{SinewWriter, WriterError};
use crate::io::dataset::{
    self, ContentError, DataSetError, Entry, Layout, Sections, Versioned, count, flat, points,
};

/// `content` metadata of a pair set's `.sinew` file.
pub const CONTENT: &str = "s2d-pairs";

const LAYOUT: Layout = Layout {
    manifest: MANIFEST_FILE,
    data: DATA_FILE,
    what: "an S2D pairs manifest",
    format: MANIFEST_FORMAT,
    version: MANIFEST_VERSION,
};

impl Versioned for Manifest {
    fn format_version(&self) -> (&str, u32) {
        (&self.format, self.version)
    }
}

impl PairSet {
    /// The `pairs.` sections and metadata, as a `.sinew` file.
    pub fn to_bytes(&self) -> Result<Vec<u8>, WriterError> {
        let m = &self.manifest;
        let (v, i, e, p) = (
            self.vertices(),
            self.neutrals.len(),
            m.expressions.len(),
            self.len(),
        );
        let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
        w.meta("content", CONTENT)
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
        w.to_bytes()
    }

    /// Writes `pairs.sinew` and `manifest.json` into `dir` (created if missing), each
    /// atomically.
    pub fn write(&self, dir: &Path) -> Result<(), DataSetError> {
        dataset::write(dir, &LAYOUT, self.to_bytes(), &self.manifest)
    }

    /// Reads a data set written by [`PairSet::write`], checking that the manifest and the
    /// numbers agree; errors name the offending file.
    pub fn read(dir: &Path) -> Result<Self, DataSetError> {
        dataset::read(dir, &LAYOUT, combinations_of, Self::from_parts)
    }

    fn from_parts(
        manifest: Manifest,
        combinations: Vec<Vec<(usize, f32)>>,
        bytes: &[u8],
    ) -> Result<Self, ContentError> {
        let f = Sections::open(bytes, ArtifactKind::S2dDecoder, CONTENT)?;
        let (v, i, e, p) = (
            count(manifest.vertices)?,
            count(manifest.identities.len())?,
            count(manifest.expressions.len())?,
            count(manifest.pairs.len())?,
        );
        let template = f.template("pairs", v)?;
        let lmk = f.u32s("pairs.lmk", &[count(manifest.landmarks.len())?])?;
        if lmk != manifest.landmarks {
            return Err(ContentError::Landmarks {
                name: "pairs.lmk".into(),
            });
        }
        if lmk.len() != 68 || lmk.iter().any(|&x| x >= v) {
            return Err(ContentError::LandmarkCount {
                name: "pairs.lmk".into(),
                vertices: v,
            });
        }
        let split = |s: Vec<f32>, n: u32| -> Vec<Vec<[f32; 3]>> {
            s.chunks_exact(3 * v as usize)
                .take(n as usize)
                .map(points)
                .collect()
        };
        let neutrals = split(f.f32s("pairs.ident", &[i, v, 3])?, i);
        let deltas = match manifest.config.expressions {
            Expressions::Shared => split(f.f32s("pairs.delta", &[e, v, 3])?, e),
            Expressions::Transferred => split(f.f32s("pairs.delta", &[i, e, v, 3])?, i * e),
        };
        let ids = f.u32s("pairs.identity", &[p])?;
        let weights = f.f32s("pairs.weights", &[p, e])?;
        for (k, spec) in manifest.pairs.iter().enumerate() {
            if ids[k] as usize != spec.identity {
                return Err(ContentError::Entry {
                    name: "pairs.identity".into(),
                    entry: Entry::Pair(k),
                });
            }
            let mut row = vec![0.0f32; e as usize];
            for &(x, wt) in &combinations[k] {
                row[x] = wt;
            }
            if row[..] != weights[k * e as usize..(k + 1) * e as usize] {
                return Err(ContentError::Entry {
                    name: "pairs.weights".into(),
                    entry: Entry::Pair(k),
                });
            }
        }
        Ok(Self {
            manifest,
            template,
            neutrals,
            deltas,
            combinations,
        })
    }
}
