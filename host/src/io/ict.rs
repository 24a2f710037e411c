//! The ICT-FaceKit "Light" face model (USC ICT, MIT licence) as a source of actors.
//!
//! The kit is a folder holding `generic_neutral_mesh.obj`, `vertex_indices.json`,
//! `expressions/NAME.obj[.gz]` (53 ARKit-named shapes, each a full mesh) and
//! `identities/identityNNN.obj[.gz]` (100 PCA modes, each neutral + 1σ of the mode). All share one
//! topology (26,719 vertices, 26,384 polygons, cm). An actor is built as the kit's README says:
//! actor neutral = neutral + Σ wᵢ (identityᵢ − neutral), and each of its blendshapes is the actor
//! neutral plus the generic expression delta (expression − neutral).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::io::mesh::{Mesh, MeshError};

/// Why a kit could not be opened or an actor built, always naming the file or folder.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum IctError {
    /// A mesh of the kit could not be read, or has another topology than the neutral (the
    /// mesh error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A folder of the kit could not be listed.
    #[error("{}: cannot list folder", path.display())]
    List {
        /// The folder.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// `vertex_indices.json` could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// `vertex_indices.json` is not JSON.
    #[error("{}: not valid JSON", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        #[source]
        source: serde_json::Error,
    },
    /// The `expressions` folder holds no mesh.
    #[error("{}: no expression meshes (NAME.obj or NAME.obj.gz)", path.display())]
    NoExpressions {
        /// The folder.
        path: PathBuf,
    },
    /// An `identityNNN` file whose `NNN` is not a number.
    #[error("{}: identity file name without a number", path.display())]
    IdentityName {
        /// The file.
        path: PathBuf,
    },
    /// The identity files skip a number.
    #[error(
        "{}: identity modes must be numbered from 000 without gaps; mode {missing} is missing \
         (next found: {next})",
        path.display()
    )]
    IdentityGap {
        /// The `identities` folder.
        path: PathBuf,
        /// The first missing mode.
        missing: usize,
        /// The mode found in its place.
        next: usize,
    },
    /// An expression name the kit does not have.
    #[error("{}: no expression {name:?}; valid names: {}", path.display(), valid.join(", "))]
    UnknownExpression {
        /// The `expressions` folder.
        path: PathBuf,
        /// The name asked for.
        name: String,
        /// The kit's names.
        valid: Vec<String>,
    },
    /// An expression asked for twice.
    #[error("{}: expression {name:?} is listed twice", path.display())]
    RepeatedExpression {
        /// The `expressions` folder.
        path: PathBuf,
        /// The name.
        name: String,
    },
    /// An identity mode beyond the kit's.
    #[error(
        "{}: no identity mode {mode}; the kit has {count} (0 to {})",
        path.display(),
        count.saturating_sub(1)
    )]
    UnknownIdentity {
        /// The `identities` folder.
        path: PathBuf,
        /// The mode asked for.
        mode: usize,
        /// How many the kit has.
        count: usize,
    },
    /// More identity weights than the kit has modes.
    #[error(
        "{given} identity weights given but the kit in {} has {count} identity modes",
        path.display()
    )]
    TooManyWeights {
        /// The kit's folder.
        path: PathBuf,
        /// How many weights were given.
        given: usize,
        /// How many modes the kit has.
        count: usize,
    },
    /// An identity weight that is NaN or infinite.
    #[error("{}: identity weight {weight} is not finite", path.display())]
    WeightNotFinite {
        /// The kit's folder.
        path: PathBuf,
        /// The weight.
        weight: f32,
    },
    /// A vertex region that is empty or reaches past the neutral's vertices.
    #[error(
        "vertex region {region:?} is empty or beyond the kit's {vertices} vertices ({})",
        path.display()
    )]
    Region {
        /// The kit's folder.
        path: PathBuf,
        /// The region asked for.
        region: Range<u32>,
        /// The neutral's vertex count.
        vertices: usize,
    },
    /// `vertex_indices.json` has no `idx_to_landmark_verts` list.
    #[error("{}: no idx_to_landmark_verts list", path.display())]
    NoLandmarks {
        /// The file.
        path: PathBuf,
    },
    /// The landmark list is not 68 long.
    #[error("{}: idx_to_landmark_verts has {count} entries, 68 expected", path.display())]
    LandmarkCount {
        /// The file.
        path: PathBuf,
        /// Its length.
        count: usize,
    },
    /// A landmark entry that is not a vertex index of the neutral.
    #[error(
        "{}: landmark {landmark} is {value}, not a vertex index below {vertices}",
        path.display()
    )]
    LandmarkIndex {
        /// The file.
        path: PathBuf,
        /// The landmark's position in the list.
        landmark: usize,
        /// The entry, as JSON text.
        value: String,
        /// The neutral's vertex count.
        vertices: usize,
    },
    /// A thread reading meshes stopped without an answer.
    #[error("{}: a reader thread did not finish", path.display())]
    ReaderThread {
        /// The kit's folder.
        path: PathBuf,
    },
}

/// What the kit's functions return.
pub type Result<T, E = IctError> = std::result::Result<T, E>;

/// The full face area: vertices 0–9408 and polygons 0–9229 of the ICT topology (the upstream
/// README's "Face" geometry; eyes, mouth socket, teeth and back of the head are excluded).
pub const FACE_REGION: Range<u32> = 0..9409;

/// The expressions of the default ICT actor: the jaw's degrees of freedom, the main mouth
/// shapes and one or two shapes from each other part of the face, mixing left and right sides so
/// that asymmetric behaviour is exercised.
pub const DEFAULT_SHAPES: [&str; 19] = [
    "jawOpen",
    "jawLeft",
    "jawRight",
    "jawForward",
    "mouthSmile_L",
    "mouthSmile_R",
    "mouthFunnel",
    "mouthPucker",
    "mouthStretch_L",
    "mouthStretch_R",
    "mouthUpperUp_L",
    "mouthLowerDown_R",
    "mouthRollLower",
    "browInnerUp_L",
    "browOuterUp_R",
    "browDown_L",
    "eyeBlink_R",
    "cheekPuff_L",
    "noseSneer_R",
];

/// Attribution carried into every ICT actor's provenance text.
pub const ICT_ATTRIBUTION: &str = "ICT-FaceKit Light face model (github ICT-VGL/ICT-FaceKit), \
     Copyright (c) 2020 USC Institute for Creative Technologies, MIT licence";

/// An actor: a template mesh and its blendshapes, one set of vertices shared by all.
#[derive(Clone, Debug)]
pub struct Actor {
    /// The actor's neutral face with its polygons and texture coordinates; its positions equal
    /// `shapes[0]`.
    pub template: Mesh,
    /// Vertex positions of each shape, neutral first, each with `template.positions.len()`
    /// entries.
    pub shapes: Vec<Vec<[f32; 3]>>,
    /// The name of each shape: `"neutral"`, then the expression names.
    pub names: Vec<String>,
    /// The 68 iBUG (Multi-PIE) landmarks as template vertex indices, in iBUG order; `None`
    /// where a landmark's vertex is not part of the template.
    pub landmarks: Vec<Option<u32>>,
    /// Length unit of every coordinate.
    pub units: crate::io::units::Unit,
    /// Where the actor comes from, with licence and attribution, for artefact metadata.
    pub source: String,
}

/// An opened ICT-FaceKit folder: the neutral mesh and landmark data in memory, the expression and
/// identity files listed (read on demand, as all of them together are ~250 MB of text).
#[derive(Debug)]
pub struct IctFaceKit {
    dir: PathBuf,
    neutral: Mesh,
    vertex_indices: serde_json::Value,
    expressions: BTreeMap<String, PathBuf>,
    identities: Vec<PathBuf>,
}

/// The mesh files in `dir` as (name without `.obj`/`.obj.gz`, path), sorted by name.
fn list_obj(dir: &Path) -> Result<BTreeMap<String, PathBuf>> {
    let mut out = BTreeMap::new();
    let list = |source| IctError::List {
        path: dir.to_owned(),
        source,
    };
    for entry in std::fs::read_dir(dir).map_err(list)? {
        let entry = entry.map_err(list)?;
        let file_name = entry.file_name();
        let name = file_name.to_string_lossy();
        let stem = name
            .strip_suffix(".obj.gz")
            .or_else(|| name.strip_suffix(".obj"));
        if let Some(stem) = stem {
            // If both a plain and a compressed copy exist, either will do; keep the first seen.
            out.entry(stem.to_owned()).or_insert_with(|| entry.path());
        }
    }
    Ok(out)
}

impl IctFaceKit {
    /// Opens the kit in `dir`: reads the neutral mesh and `vertex_indices.json`, and lists the
    /// expressions and identity modes (which must be numbered `identity000` upwards without
    /// gaps).
    pub fn open(dir: &Path) -> Result<Self> {
        let neutral = Mesh::read(&dir.join("generic_neutral_mesh.obj"))?;
        let json_path = dir.join("vertex_indices.json");
        let text = std::fs::read_to_string(&json_path).map_err(|source| IctError::Read {
            path: json_path.clone(),
            source,
        })?;
        let vertex_indices: serde_json::Value =
            serde_json::from_str(&text).map_err(|source| IctError::Json {
                path: json_path.clone(),
                source,
            })?;
        let expressions = list_obj(&dir.join("expressions"))?;
        if expressions.is_empty() {
            return Err(IctError::NoExpressions {
                path: dir.join("expressions"),
            });
        }
        let id_dir = dir.join("identities");
        let mut numbered = BTreeMap::new();
        for (stem, path) in list_obj(&id_dir)? {
            let Some(num) = stem.strip_prefix("identity") else {
                continue;
            };
            let i: usize = num
                .parse()
                .map_err(|_| IctError::IdentityName { path: path.clone() })?;
            numbered.insert(i, path);
        }
        let identities: Vec<PathBuf> = numbered.values().cloned().collect();
        if let Some((pos, (&i, _))) = numbered.iter().enumerate().find(|(k, (i, _))| k != *i) {
            return Err(IctError::IdentityGap {
                path: id_dir,
                missing: pos,
                next: i,
            });
        }
        Ok(Self {
            dir: dir.to_owned(),
            neutral,
            vertex_indices,
            expressions,
            identities,
        })
    }

    /// The folder the kit was opened from.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The generic neutral mesh (all 26,719 vertices).
    pub fn neutral(&self) -> &Mesh {
        &self.neutral
    }

    /// The expression names, sorted (53 in the published kit).
    pub fn expression_names(&self) -> Vec<String> {
        self.expressions.keys().cloned().collect()
    }

    /// The number of identity modes (100 in the published kit).
    pub fn identity_count(&self) -> usize {
        self.identities.len()
    }

    /// Reads a mesh of the kit and returns its offsets from the neutral, after checking that it
    /// has the neutral's topology.
    fn delta_of(&self, path: &Path) -> Result<Vec<[f32; 3]>> {
        let mesh = Mesh::read(path)?;
        self.neutral.check_same_topology(&mesh, path)?;
        Ok(mesh
            .positions
            .iter()
            .zip(&self.neutral.positions)
            .map(|(p, n)| [p[0] - n[0], p[1] - n[1], p[2] - n[2]])
            .collect())
    }

    fn expression_path(&self, name: &str) -> Result<&Path> {
        self.expressions
            .get(name)
            .map(PathBuf::as_path)
            .ok_or_else(|| IctError::UnknownExpression {
                path: self.dir.join("expressions"),
                name: name.to_owned(),
                valid: self.expression_names(),
            })
    }

    /// The blendshape offsets of expression `name` (expression mesh − neutral), per vertex.
    pub fn expression_delta(&self, name: &str) -> Result<Vec<[f32; 3]>> {
        self.delta_of(self.expression_path(name)?)
    }

    /// The offsets of identity mode `i` at one standard deviation (identity file − neutral).
    pub fn identity_delta(&self, i: usize) -> Result<Vec<[f32; 3]>> {
        let path = self
            .identities
            .get(i)
            .ok_or_else(|| IctError::UnknownIdentity {
                path: self.dir.join("identities"),
                mode: i,
                count: self.identities.len(),
            })?;
        self.delta_of(path)
    }

    /// The offsets of the expressions `names`, in that order, read on several threads (as
    /// [`Self::expression_delta`] for each).
    pub fn expression_deltas(&self, names: &[impl AsRef<str>]) -> Result<Vec<Vec<[f32; 3]>>> {
        let paths = names
            .iter()
            .map(|name| self.expression_path(name.as_ref()).map(Path::to_owned))
            .collect::<Result<Vec<_>>>()?;
        self.read_deltas(&paths)
    }

    /// The offsets of identity modes `0..count`, in mode order, read on several threads (as
    /// [`Self::identity_delta`] for each).
    pub fn identity_deltas(&self, count: usize) -> Result<Vec<Vec<[f32; 3]>>> {
        if count > self.identities.len() {
            return Err(IctError::UnknownIdentity {
                path: self.dir.join("identities"),
                mode: count - 1,
                count: self.identities.len(),
            });
        }
        self.read_deltas(&self.identities[..count])
    }

    /// The 68 iBUG landmark vertices (`idx_to_landmark_verts` of `vertex_indices.json`), in iBUG
    /// order.
    pub fn landmarks68(&self) -> Result<Vec<u32>> {
        let path = self.dir.join("vertex_indices.json");
        let list = self
            .vertex_indices
            .get("idx_to_landmark_verts")
            .and_then(serde_json::Value::as_array)
            .ok_or_else(|| IctError::NoLandmarks { path: path.clone() })?;
        if list.len() != 68 {
            return Err(IctError::LandmarkCount {
                path,
                count: list.len(),
            });
        }
        let nv = self.neutral.positions.len();
        list.iter()
            .enumerate()
            .map(|(k, v)| {
                v.as_u64()
                    .filter(|&i| (i as usize) < nv)
                    .map(|i| i as u32)
                    .ok_or_else(|| IctError::LandmarkIndex {
                        path: path.clone(),
                        landmark: k,
                        value: v.to_string(),
                        vertices: nv,
                    })
            })
            .collect()
    }

    /// The whole neutral head of an identity (`identity_weights` as for [`Self::actor`]; empty:
    /// the generic neutral).
    pub fn neutral_of(&self, identity_weights: &[f32]) -> Result<Mesh> {
        if identity_weights.iter().all(|&w| w == 0.0) {
            return Ok(self.neutral.clone());
        }
        let all = 0..self.neutral.positions.len() as u32;
        Ok(self.actor(identity_weights, &[], all)?.template)
    }

    /// Builds an actor: identity `identity_weights[i]` (in standard deviations) for the first
    /// modes, the given expressions, restricted to the vertex range `region` (e.g.
    /// [`FACE_REGION`]). Only modes with a non-zero weight are read. Files are read on several
    /// threads; results are summed in mode order, so the actor is the same on every run.
    pub fn actor(
        &self,
        identity_weights: &[f32],
        expressions: &[&str],
        region: Range<u32>,
    ) -> Result<Actor> {
        let nv = self.neutral.positions.len();
        if identity_weights.len() > self.identities.len() {
            return Err(IctError::TooManyWeights {
                path: self.dir.clone(),
                given: identity_weights.len(),
                count: self.identities.len(),
            });
        }
        if let Some(&weight) = identity_weights.iter().find(|w| !w.is_finite()) {
            return Err(IctError::WeightNotFinite {
                path: self.dir.clone(),
                weight,
            });
        }
        if region.is_empty() || region.end as usize > nv {
            return Err(IctError::Region {
                path: self.dir.clone(),
                region,
                vertices: nv,
            });
        }
        let mut paths = Vec::new();
        for (k, name) in expressions.iter().enumerate() {
            if expressions[..k].contains(name) {
                return Err(IctError::RepeatedExpression {
                    path: self.dir.join("expressions"),
                    name: (*name).to_owned(),
                });
            }
            paths.push(self.expression_path(name)?.to_owned());
        }
        let ids: Vec<(usize, f32)> = identity_weights
            .iter()
            .copied()
            .enumerate()
            .filter(|&(_, w)| w != 0.0)
            .collect();
        paths.extend(ids.iter().map(|&(i, _)| self.identities[i].clone()));

        let deltas = self.read_deltas(&paths)?;
        let (expr_deltas, id_deltas) = deltas.split_at(expressions.len());

        let mut actor_neutral = self.neutral.positions.clone();
        for (&(_, w), d) in ids.iter().zip(id_deltas) {
            for (p, d) in actor_neutral.iter_mut().zip(d) {
                for c in 0..3 {
                    p[c] += w * d[c];
                }
            }
        }
        let full = self.neutral.with_positions(actor_neutral);
        let (template, old_index) = full.submesh(|v| region.contains(&v));
        let mut shapes = Vec::with_capacity(1 + expressions.len());
        shapes.push(template.positions.clone());
        for d in expr_deltas {
            shapes.push(
                old_index
                    .iter()
                    .map(|&v| {
                        let (p, d) = (full.positions[v as usize], d[v as usize]);
                        [p[0] + d[0], p[1] + d[1], p[2] + d[2]]
                    })
                    .collect(),
            );
        }
        let mut new_index = vec![None; nv];
        for (new, &old) in old_index.iter().enumerate() {
            new_index[old as usize] = Some(new as u32);
        }
        let landmarks = self
            .landmarks68()?
            .iter()
            .map(|&v| new_index[v as usize])
            .collect();
        let mut names = vec!["neutral".to_owned()];
        names.extend(expressions.iter().map(|s| (*s).to_owned()));
        let weights: Vec<String> = ids.iter().map(|(i, w)| format!("{i}:{w}")).collect();
        let source = format!(
            "{ICT_ATTRIBUTION}; read from {}; identity weights (mode:sigma) [{}]; vertex region \
             {}..{}",
            self.dir.display(),
            weights.join(", "),
            region.start,
            region.end
        );
        Ok(Actor {
            template,
            shapes,
            names,
            landmarks,
            units: crate::io::units::Unit::Centimetre,
            source,
        })
    }

    /// Reads the deltas of `paths` on up to 8 threads, returning them in `paths` order.
    fn read_deltas(&self, paths: &[PathBuf]) -> Result<Vec<Vec<[f32; 3]>>> {
        let threads = std::thread::available_parallelism()
            .map_or(1, usize::from)
            .clamp(1, 8)
            .min(paths.len().max(1));
        let mut slots: Vec<Option<Result<Vec<[f32; 3]>>>> = Vec::new();
        slots.resize_with(paths.len(), || None);
        // Each thread fills one contiguous run of slots, so results keep the order of `paths`.
        let per_thread = paths.len().div_ceil(threads).max(1);
        std::thread::scope(|s| {
            for (slots, paths) in slots.chunks_mut(per_thread).zip(paths.chunks(per_thread)) {
                s.spawn(move || {
                    for (slot, path) in slots.iter_mut().zip(paths) {
                        *slot = Some(self.delta_of(path));
                    }
                });
            }
        });
        slots
            .into_iter()
            .map(|s| {
                s.unwrap_or_else(|| {
                    Err(IctError::ReaderThread {
                        path: self.dir.clone(),
                    })
                })
            })
            .collect()
    }
}

#[cfg(test)]
mod tests;
