//! S2D training pairs from ICT-FaceKit (the paper's §4 set-up, with ICT's linear identity and
//! expression models standing in for CoMA's captured subjects).
//!
//! A pair is (neutral, expressive) on the face region ([`FACE_REGION`]): the neutral is the generic
//! neutral plus Σ_m w_m · identity_m with w_m ~ N(0, 1) over all identity modes; the expressive
//! face is the neutral plus a sparse combination Σ_j c_j · expression_j of 1 to
//! [`PairsConfig::max_shapes`] expression deltas with c_j uniform in (0, 1]. The landmarks are the
//! 68 iBUG vertices of the kit.
//!
//! The expression shapes are partitioned (seeded) into [`SHAPE_GROUPS`] groups, and every pair
//! combines shapes of one group only, so that the expression-independent protocol can hold out a
//! group and still test on every pair of it (a pair mixing held-out and seen shapes would belong
//! to neither side). Pairs cycle through identities and groups, so every (identity, group) cell
//! holds the same number of pairs, ±1.
//!
//! With [`Expressions::Transferred`] every expression delta is first deformation-transferred onto
//! every identity's neutral ([`crate::geometry::deformation`]), so each identity performs the expressions
//! in its own way; the kit's deltas are otherwise shared by all identities.
//!
//! On disk a data set is a folder with `pairs.sinew` (the numbers: identities' neutrals,
//! expression deltas and each pair's weights, as f32 sections; FORMAT.md, "S2D training pairs")
//! and `manifest.json` (the same combinations by name, for people and for the protocols). A
//! pair's dense displacement is not stored: it is Σ_j c_j · expression_j, recomputed in a fixed
//! order on load, which keeps a thousand pairs in a few megabytes (tens with transferred deltas,
//! which are stored per identity).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::decoder::InputNormalisation;
use super::hierarchy::BuildError;
use super::objective::LandmarkError;
use super::symmetry::Mirror;
use super::train::{Sample, landmark_input};
use crate::geometry::identities::{FaceRegion, RegionError};
use crate::io::dataset::{DataSetError, Entry, ManifestProblem};
use crate::io::ict::{FACE_REGION, IctError, IctFaceKit};
use crate::io::mesh::Mesh;
use crate::training::random::Stream;

/// Number of expression-shape groups (the expression protocol's folds).
pub const SHAPE_GROUPS: usize = 4;
/// The numbers of a data set, inside its folder.
pub const DATA_FILE: &str = "pairs.sinew";
/// The manifest of a data set, inside its folder.
pub const MANIFEST_FILE: &str = "manifest.json";
/// `format` field of the manifest.
pub const MANIFEST_FORMAT: &str = "sinew-s2d-pairs";
/// Version of the manifest and of the `pairs.` sections.
pub const MANIFEST_VERSION: u32 = 1;

/// How a pair's expression deltas relate to its identity.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Expressions {
    /// ICT-FaceKit's deltas as they are: the same vectors for every identity (the kit's linear
    /// model).
    Shared,
    /// Each delta transferred onto each identity's neutral by deformation transfer
    /// ([`crate::geometry::deformation`]): the expression deforms the identity's own triangles as it
    /// deforms the generic neutral's, so displacements differ between identities.
    Transferred,
}

impl Expressions {
    /// What a manifest written before the `expressions` field existed holds.
    fn before_the_field() -> Self {
        Self::Shared
    }
}

/// What to generate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairsConfig {
    /// Seed of every random choice.
    pub seed: u64,
    /// Number of identities (random neutrals).
    pub identities: usize,
    /// Number of pairs.
    pub pairs: usize,
    /// Most expression shapes combined in one pair (each pair takes 1 to this many).
    pub max_shapes: usize,
    /// Shared or identity-specific expression deltas (manifests written before this field
    /// existed are `shared`).
    #[serde(default = "Expressions::before_the_field")]
    pub expressions: Expressions,
}

impl Default for PairsConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            // CoMA has 12 subjects; the paper's identity protocol holds out 3 per fold.
            identities: 12,
            pairs: 1200,
            max_shapes: 3,
            // Identity-specific, so that both protocols measure something: with the kit's shared
            // deltas the identity split's test displacements lie in the training span, and the
            // expression split's `pca_max` is a well-posed low-rank fit (docs/S2D.md).
            expressions: Expressions::Transferred,
        }
    }
}

impl PairsConfig {
    /// Checks the counts.
    pub fn validate(&self) -> Result<(), InvalidPairsConfig> {
        if self.identities < 2 {
            return Err(InvalidPairsConfig::Identities);
        }
        if self.pairs < 1 {
            return Err(InvalidPairsConfig::Pairs);
        }
        if self.max_shapes < 1 {
            return Err(InvalidPairsConfig::MaxShapes);
        }
        Ok(())
    }
}

/// The rule of [`PairsConfig`] a configuration breaks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidPairsConfig {
    /// Fewer than 2 identities.
    #[error("at least 2 identities are needed (one to train, one to test)")]
    Identities,
    /// No pairs.
    #[error("at least one pair is needed")]
    Pairs,
    /// `max_shapes` is 0.
    #[error("max_shapes must be at least 1")]
    MaxShapes,
}

/// One shape of a pair's expression.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Component {
    /// The expression's name (an ICT-FaceKit blendshape).
    pub shape: String,
    /// Its weight, in (0, 1].
    pub weight: f32,
}

/// One pair: which identity, and which expression combination.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PairSpec {
    /// Index into [`Manifest::identities`].
    pub identity: usize,
    /// The shape group all of its shapes belong to.
    pub group: usize,
    /// The combination, in the order the shapes were drawn.
    pub shapes: Vec<Component>,
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
    pub config: PairsConfig,
    /// Length unit of every coordinate (`cm` for ICT).
    pub units: crate::io::units::Unit,
    /// Provenance with licence and attribution.
    pub source: String,
    /// Vertices of the face region.
    pub vertices: usize,
    /// The 68 landmark vertices (iBUG order), indices into the face region.
    pub landmarks: Vec<u32>,
    /// Every expression shape, in the order of the `pairs.delta` section.
    pub expressions: Vec<String>,
    /// The shape groups, by name; together they hold every expression exactly once.
    pub shape_groups: Vec<Vec<String>>,
    /// Each identity's weights, one per identity mode (in standard deviations).
    pub identities: Vec<Vec<f32>>,
    /// The pairs.
    pub pairs: Vec<PairSpec>,
}

/// A data set in memory.
#[derive(Clone, Debug)]
pub struct PairSet {
    /// The manifest.
    pub manifest: Manifest,
    /// The generic neutral's face region, triangulated (the template of the hierarchy).
    pub template: Mesh,
    /// Each identity's neutral face region, `[identities][vertices]`.
    pub neutrals: Vec<Vec<[f32; 3]>>,
    /// Each expression's delta on the face region, `[expressions][vertices]` when shared, or
    /// `[identities × expressions][vertices]` (identity-major) when transferred; see
    /// [`PairSet::delta`].
    pub deltas: Vec<Vec<[f32; 3]>>,
    /// Each pair's combination as (expression index, weight), in the manifest's order.
    pub combinations: Vec<Vec<(usize, f32)>>,
}

/// Draws the identities, shape groups and pair combinations of `config` over `expressions`
/// (names, sorted) and `modes` identity modes. Pure: the same inputs give the same manifest.
fn draw(
    config: &PairsConfig,
    expressions: &[String],
    modes: usize,
) -> (Vec<Vec<f32>>, Vec<Vec<usize>>, Vec<PairSpec>) {
    let mut rng = Stream::new(
        config.seed,
        0x5d2d_da7a,
        0x00a0_2bdb_0000_0000_0000_0000_0000_0001,
    );
    let identities: Vec<Vec<f32>> = (0..config.identities)
        .map(|_| (0..modes).map(|_| rng.normal() as f32).collect())
        .collect();
    let mut order: Vec<usize> = (0..expressions.len()).collect();
    rng.shuffle(&mut order);
    let groups: Vec<Vec<usize>> = (0..SHAPE_GROUPS)
        .map(|g| {
            // Contiguous near-equal chunks of the shuffled order; larger chunks first.
            let n = expressions.len();
            let (lo, hi) = (g * n / SHAPE_GROUPS, (g + 1) * n / SHAPE_GROUPS);
            let mut group = order[lo..hi].to_vec();
            group.sort_unstable();
            group
        })
        .collect();
    let pairs = (0..config.pairs)
        .map(|p| {
            let identity = p % config.identities;
            let group = (p / config.identities) % SHAPE_GROUPS;
            let members = &groups[group];
            let k = 1 + rng.below(config.max_shapes.min(members.len()));
            let mut pool = members.clone();
            let mut shapes = Vec::with_capacity(k);
            for _ in 0..k {
                let e = pool.remove(rng.below(pool.len()));
                // (0, 1]: a zero weight would make the shape's presence a fiction.
                let weight = (1.0 - rng.unit()) as f32;
                shapes.push(Component {
                    shape: expressions[e].clone(),
                    weight,
                });
            }
            PairSpec {
                identity,
                group,
                shapes,
            }
        })
        .collect();
    (identities, groups, pairs)
}

/// A pair set that could not be generated, decimated or written; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PairsError {
    /// Settings that cannot make a pair set.
    #[error(transparent)]
    Config(#[from] InvalidPairsConfig),
    /// The ICT-FaceKit folder cannot be read (the error names the file).
    #[error(transparent)]
    Kit(#[from] IctError),
    /// A kit with fewer expressions than shape groups.
    #[error("{}: {found} expressions, at least {SHAPE_GROUPS} needed", path.display())]
    Expressions {
        /// The kit's folder.
        path: PathBuf,
        /// Its expressions.
        found: usize,
    },
    /// The kit's face region cannot carry identities, or an identity its expressions (the
    /// error names the kit or the identity).
    #[error(transparent)]
    Region(#[from] RegionError),
    /// Pairs that break a rule of the manifest.
    #[error(transparent)]
    Manifest(#[from] ManifestProblem),
    /// The face region cannot be decimated.
    #[error("decimating the face region")]
    Decimate(#[source] BuildError),
    /// A decimation that left no coarser level.
    #[error("decimation by {factor} gave no coarser level")]
    NoCoarserLevel {
        /// The factor.
        factor: usize,
    },
    /// The pair set cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] DataSetError),
}

/// Generates a data set from the ICT-FaceKit in `kit`.
pub fn generate(kit: &IctFaceKit, config: &PairsConfig) -> Result<PairSet, PairsError> {
    config.validate()?;
    let expressions = kit.expression_names();
    if expressions.len() < SHAPE_GROUPS {
        return Err(PairsError::Expressions {
            path: kit.dir().to_owned(),
            found: expressions.len(),
        });
    }
    let modes = kit.identity_count();
    let (identities, groups, pairs) = draw(config, &expressions, modes);
    let mut face = FaceRegion::of(kit, &expressions, modes)?;
    let neutrals: Vec<Vec<[f32; 3]>> = identities.iter().map(|w| face.neutral(w)).collect();
    let deltas = match config.expressions {
        // The region's deltas are not needed again: moved, not copied.
        Expressions::Shared => std::mem::take(&mut face.deltas),
        Expressions::Transferred => face.transferred(&neutrals)?,
    };
    let manifest = Manifest {
        format: MANIFEST_FORMAT.to_owned(),
        version: MANIFEST_VERSION,
        config: config.clone(),
        units: crate::io::units::Unit::Centimetre,
        source: format!(
            "ICT-FaceKit Light face model (github ICT-VGL/ICT-FaceKit), Copyright (c) 2020 USC \
             Institute for Creative Technologies, MIT licence; face region {}..{}",
            FACE_REGION.start, FACE_REGION.end
        ),
        vertices: face.vertices(),
        landmarks: face.landmarks,
        shape_groups: groups
            .iter()
            .map(|g| g.iter().map(|&e| expressions[e].clone()).collect())
            .collect(),
        expressions,
        identities,
        pairs,
    };
    let combinations = combinations_of(&manifest)?;
    Ok(PairSet {
        manifest,
        template: face.template,
        neutrals,
        deltas,
        combinations,
    })
}

/// Each pair's shapes as (expression index, weight), checking names, weights and groups.
pub(crate) fn combinations_of(m: &Manifest) -> Result<Vec<Vec<(usize, f32)>>, ManifestProblem> {
    let index = |name: &str, entry: Option<Entry>| {
        m.expressions.iter().position(|e| e == name).ok_or_else(|| {
            ManifestProblem::UnknownExpression {
                entry,
                name: name.to_owned(),
            }
        })
    };
    let mut group_of = vec![usize::MAX; m.expressions.len()];
    for (g, group) in m.shape_groups.iter().enumerate() {
        for name in group {
            let e = index(name, None)?;
            if group_of[e] != usize::MAX {
                return Err(ManifestProblem::TwoGroups { name: name.clone() });
            }
            group_of[e] = g;
        }
    }
    if let Some(e) = group_of.iter().position(|&g| g == usize::MAX) {
        return Err(ManifestProblem::NoGroup {
            name: m.expressions[e].clone(),
        });
    }
    m.pairs
        .iter()
        .enumerate()
        .map(|(p, spec)| {
            let entry = Entry::Pair(p);
            if spec.identity >= m.identities.len() {
                return Err(ManifestProblem::Identity {
                    entry,
                    identity: spec.identity,
                    count: m.identities.len(),
                });
            }
            if spec.shapes.is_empty() {
                return Err(ManifestProblem::NoShapes { entry });
            }
            let mut out: Vec<(usize, f32)> = Vec::with_capacity(spec.shapes.len());
            for c in &spec.shapes {
                let e = index(&c.shape, Some(entry))?;
                if !(c.weight.is_finite() && c.weight > 0.0 && c.weight <= 1.0) {
                    return Err(ManifestProblem::Weight {
                        entry,
                        shape: c.shape.clone(),
                        weight: c.weight,
                    });
                }
                if group_of[e] != spec.group {
                    return Err(ManifestProblem::Group {
                        entry,
                        shape: c.shape.clone(),
                        group: spec.group,
                    });
                }
                if out.iter().any(|&(o, _)| o == e) {
                    return Err(ManifestProblem::Repeated {
                        entry,
                        shape: c.shape.clone(),
                    });
                }
                out.push((e, c.weight));
            }
            Ok(out)
        })
        .collect()
}

impl PairSet {
    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.manifest.pairs.len()
    }

    /// Whether there are no pairs.
    pub fn is_empty(&self) -> bool {
        self.manifest.pairs.is_empty()
    }

    /// Vertices of the face region.
    pub fn vertices(&self) -> usize {
        self.template.positions.len()
    }

    /// The neutral of pair `p`.
    pub fn neutral(&self, p: usize) -> &[[f32; 3]] {
        &self.neutrals[self.manifest.pairs[p].identity]
    }

    /// Expression `e`'s delta for `identity` (the same for every identity when shared).
    pub fn delta(&self, identity: usize, e: usize) -> &[[f32; 3]] {
        match self.manifest.config.expressions {
            Expressions::Shared => &self.deltas[e],
            Expressions::Transferred => {
                &self.deltas[identity * self.manifest.expressions.len() + e]
            }
        }
    }

    /// The dense displacement of pair `p`: Σ_j c_j · expression_j, summed in the pair's order.
    pub fn displacement(&self, p: usize) -> Vec<[f32; 3]> {
        let mut out = vec![[0.0f32; 3]; self.vertices()];
        let identity = self.manifest.pairs[p].identity;
        for &(e, w) in &self.combinations[p] {
            for (o, d) in out.iter_mut().zip(self.delta(identity, e)) {
                for c in 0..3 {
                    o[c] += w * d[c];
                }
            }
        }
        out
    }

    /// The landmark positions of `points` (a face-region vertex array).
    pub fn landmarks_of(&self, points: &[[f32; 3]]) -> Vec<[f32; 3]> {
        self.manifest
            .landmarks
            .iter()
            .map(|&l| points[l as usize])
            .collect()
    }

    /// Neutral and expressive landmarks of pair `p`.
    pub fn landmark_pair(&self, p: usize) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        let n = self.neutral(p);
        let d = self.displacement(p);
        let e: Vec<[f32; 3]> = n
            .iter()
            .zip(&d)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect();
        (self.landmarks_of(n), self.landmarks_of(&e))
    }

    /// Pair `p` as a training sample: the decoder's landmark input, normalised by
    /// `normalisation`, and the dense displacement, flattened.
    pub fn sample(
        &self,
        p: usize,
        normalisation: InputNormalisation,
    ) -> Result<Sample, LandmarkError> {
        self.sample_of(self.neutral(p), &self.displacement(p), normalisation)
    }

    /// Pair `p` mirrored left to right as a training sample: the mirrored neutral (a new
    /// identity) with the mirrored displacement (the mirrored expression).
    ///
    /// # Errors
    /// As [`PairSet::sample`].
    ///
    /// # Panics
    /// If `mirror` is not the symmetry of this set's template (another vertex count).
    pub fn mirrored_sample(
        &self,
        p: usize,
        mirror: &Mirror,
        normalisation: InputNormalisation,
    ) -> Result<Sample, LandmarkError> {
        self.sample_of(
            &mirror.positions(self.neutral(p)),
            &mirror.vectors(&self.displacement(p)),
            normalisation,
        )
    }

    /// The sample of a neutral face region and its displacement.
    fn sample_of(
        &self,
        neutral: &[[f32; 3]],
        displacement: &[[f32; 3]],
        normalisation: InputNormalisation,
    ) -> Result<Sample, LandmarkError> {
        let e: Vec<[f32; 3]> = neutral
            .iter()
            .zip(displacement)
            .map(|(a, b)| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
            .collect();
        Ok(Sample {
            input: landmark_input(
                normalisation,
                &self.landmarks_of(neutral),
                &self.landmarks_of(&e),
            )?,
            displacement: displacement.iter().flatten().copied().collect(),
        })
    }

    /// The same pairs on the template decimated by `factor` (Sinew's quadric decimation, the
    /// hierarchy's first step: every kept vertex is a vertex of the face region, so neutrals and
    /// expression deltas are exact selections). A landmark whose vertex is not kept moves to the
    /// nearest kept vertex of the generic neutral; the source string records the decimation.
    /// Used to train decoders small enough for microcontrollers (the golden S2D model).
    ///
    /// # Errors
    /// If the template cannot be decimated by `factor` (see `hierarchy::build`).
    pub fn decimated(&self, factor: usize) -> Result<Self, PairsError> {
        let h = super::hierarchy::build(&self.template, &[factor]).map_err(PairsError::Decimate)?;
        let (level, down) = match (h.levels.get(1), h.down.first()) {
            (Some(l), Some(d)) => (l, d),
            _ => return Err(PairsError::NoCoarserLevel { factor }),
        };
        let n = level.positions.len();
        // Row j of D selects the fine vertex that coarse vertex j is (the last row is the dummy's).
        let kept: Vec<usize> = (0..n)
            .map(|j| down.col_idx[down.row_ptr[j] as usize] as usize)
            .collect();
        let pick =
            |points: &[[f32; 3]]| -> Vec<[f32; 3]> { kept.iter().map(|&i| points[i]).collect() };
        let base = &self.template.positions;
        let dist2 =
            |a: [f32; 3], b: [f32; 3]| -> f32 { (0..3).map(|c| (a[c] - b[c]).powi(2)).sum() };
        let landmarks = self
            .manifest
            .landmarks
            .iter()
            .map(|&l| {
                let p = base[l as usize];
                // Nearest kept vertex; ties go to the lower index, so the choice is reproducible.
                let (j, _) = kept
                    .iter()
                    .enumerate()
                    .fold((0, f32::INFINITY), |best, (j, &i)| {
                        let d = dist2(base[i], p);
                        if d < best.1 { (j, d) } else { best }
                    });
                j as u32
            })
            .collect();
        let mut manifest = self.manifest.clone();
        manifest.vertices = n;
        manifest.landmarks = landmarks;
        manifest.source = format!(
            "{}; decimated by {factor} to {n} vertices (Sinew quadric decimation, landmarks at the \
             nearest kept vertex)",
            manifest.source
        );
        Ok(Self {
            manifest,
            template: Mesh::new(
                level.positions.clone(),
                level.triangles.iter().map(|t| t.to_vec()).collect(),
            ),
            neutrals: self.neutrals.iter().map(|v| pick(v)).collect(),
            deltas: self.deltas.iter().map(|v| pick(v)).collect(),
            combinations: self.combinations.clone(),
        })
    }
}

/// `sinew data s2d-pairs`: generates from the kit in `data` and writes to `out`.
/// With `decimate`, the pairs are written on the template decimated by that factor
/// ([`PairSet::decimated`]).
pub fn generate_to(
    data: &Path,
    out: &Path,
    config: &PairsConfig,
    decimate: Option<usize>,
) -> Result<PairSet, PairsError> {
    let kit = IctFaceKit::open(data)?;
    let mut set = generate(&kit, config)?;
    if let Some(factor) = decimate {
        set = set.decimated(factor)?;
    }
    set.write(out)?;
    Ok(set)
}

#[cfg(test)]
mod tests;
