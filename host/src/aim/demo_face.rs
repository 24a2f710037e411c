//! The demo's face: the ICT-FaceKit face region decimated by Sinew with its default 20 shapes and
//! the bone constraints AIM trains on, stored compactly in the repository
//! (`host/data/demo-face.json.gz`, listed in NOTICE) and built into the binary, so that
//! `sinew demo` trains on a human face with no data files.
//!
//! `sinew data demo-face` makes the file from ICT-FaceKit and the template bones: the actor of
//! the default protocol (generic neutral, [`DEFAULT_SHAPES`], [`FACE_REGION`]), quadric decimation
//! of its neutral to [`TARGET_VERTICES`] (every kept vertex is an original vertex, so each shape is
//! an exact selection), landmarks moved to the nearest kept vertex, and Wu et al.'s constraints
//! against the bones fitted to the full neutral (`sinew bones fit`'s fit). Coordinates are stored
//! as integers in units of [`QUANTUM_CM`] (0.01 mm), the neutral as positions and the expressions
//! as offsets from it, mostly zeros, which gzip shrinks well. Each constraint is stored as its
//! bone point and bone; its thickness and normal follow from the skin vertex, as
//! [`crate::anatomy::constraints::anchors`] defines them.

use std::io::{Read, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::data::{forehead, jaw_pivot, symmetry_plane};
use super::{Anchor, InvalidTrainingSet, TrainingSet};
use crate::anatomy::bones::BonesError;
use crate::anatomy::constraints::{Bone, anchors};
use crate::anatomy::fit::BonesFitError;
use crate::geometry::qem::DecimateError;
use crate::io::atomic::AtomicWriteError;
use crate::io::ict::{DEFAULT_SHAPES, FACE_REGION, ICT_ATTRIBUTION, IctError, IctFaceKit};
use crate::io::mesh::{InvalidMesh, Mesh};

/// Why the demo face could not be made or read. The reading variants carry the name the caller
/// gave the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemoFaceError {
    /// The ICT-FaceKit folder could not be read.
    #[error(transparent)]
    Kit(#[from] IctError),
    /// The template bones' folder holds no templates.
    #[error(transparent)]
    Templates(#[from] BonesFitError),
    /// The template bones could not be loaded or fitted.
    #[error(transparent)]
    Bones(#[from] BonesError),
    /// The face region could not be decimated.
    #[error("decimating the ICT-FaceKit face region")]
    Decimate(#[source] DecimateError),
    /// The decimated face region is not a valid mesh.
    #[error("the decimated ICT-FaceKit face region")]
    DecimatedMesh(#[source] InvalidMesh),
    /// The face could not be laid out as JSON.
    #[error(transparent)]
    Encode(serde_json::Error),
    /// The JSON could not be compressed.
    #[error(transparent)]
    Compress(std::io::Error),
    /// The file could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// A kit landmark outside the face region (the face template needs all 68).
    #[error("the kit's landmark {landmark} is not on the face region")]
    Landmark {
        /// The landmark (iBUG order).
        landmark: usize,
    },
    /// The face template could not be encoded.
    #[error(transparent)]
    Template(#[from] crate::rig::template::TemplateError),
    /// The bytes are not gzip.
    #[error("{name}: not a gzip file")]
    NotGzip {
        /// The file's name.
        name: String,
        /// What the decoder said.
        #[source]
        source: std::io::Error,
    },
    /// The JSON is not a demo face's.
    #[error("{name}: not a demo face file")]
    NotDemoFace {
        /// The file's name.
        name: String,
        /// What the JSON reader said.
        #[source]
        source: serde_json::Error,
    },
    /// A count or index of the file that does not add up.
    #[error("{name}: invalid demo face")]
    Invalid {
        /// The file's name.
        name: String,
        /// The broken rule.
        #[source]
        source: DemoFaceProblem,
    },
    /// The face's mesh is not valid.
    #[error("{name}: invalid face mesh")]
    FaceMesh {
        /// The file's name.
        name: String,
        /// The broken rule.
        #[source]
        source: InvalidMesh,
    },
    /// The training set built from the file is not valid.
    #[error("{name}")]
    Set {
        /// The file's name.
        name: String,
        /// The broken rule.
        #[source]
        source: InvalidTrainingSet,
    },
}

/// A rule of the demo face file that a file breaks.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DemoFaceProblem {
    /// Another `format` than this version's.
    #[error("format {found:?}, expected {:?}", FORMAT)]
    Format {
        /// The file's format.
        found: String,
    },
    /// Another coordinate step than [`QUANTUM_CM`].
    #[error("coordinate step {found} cm, expected {}", QUANTUM_CM)]
    Quantum {
        /// The file's step.
        found: f64,
    },
    /// No vertices.
    #[error("no vertices")]
    NoVertices,
    /// Names that do not match the expressions and the neutral.
    #[error("{names} shape names for {expressions} expressions and the neutral")]
    NameCount {
        /// The names.
        names: usize,
        /// The expressions.
        expressions: usize,
    },
    /// An expression with another offset count than the vertices.
    #[error("expression {name} has {offsets} offsets for {vertices} vertices")]
    Offsets {
        /// The expression.
        name: String,
        /// Its offsets.
        offsets: usize,
        /// The vertices.
        vertices: usize,
    },
    /// Bone entries of another count than the vertices.
    #[error("{entries} bone entries for {vertices} vertices")]
    BoneEntries {
        /// The entries.
        entries: usize,
        /// The vertices.
        vertices: usize,
    },
    /// A triangle that refers past the vertices.
    #[error("triangle {triangle:?} refers to a vertex beyond the {vertices} there are")]
    Triangle {
        /// The triangle.
        triangle: [u32; 3],
        /// The vertices.
        vertices: usize,
    },
    /// A landmark past the vertices.
    #[error("landmark vertex {vertex} is beyond the {vertices} vertices")]
    Landmark {
        /// The landmark's vertex.
        vertex: u32,
        /// The vertices.
        vertices: usize,
    },
    /// A stored coordinate so large that rebuilding the shapes could overflow.
    #[error("a coordinate beyond {limit_cm} cm")]
    Coordinate {
        /// The largest coordinate allowed (cm).
        limit_cm: f64,
    },
}

/// Where the file lives in the repository, for messages and the regeneration command.
pub const PATH: &str = "host/data/demo-face.json.gz";

/// The built-in file.
const EMBEDDED: &[u8] = include_bytes!("../../data/demo-face.json.gz");

/// Vertices of the decimated face region (9,409 in ICT-FaceKit's).
pub const TARGET_VERTICES: usize = 1500;

/// The coordinate step of the stored file, in cm: 0.01 mm, a tenth of the demo's accuracy goal.
pub const QUANTUM_CM: f64 = 1e-3;

/// The `format` field of the file.
const FORMAT: &str = "sinew-demo-face/1";

/// Deepest constraint kept (cm), [`super::AimConfig`]'s default `max_constraint_depth`.
const MAX_DEPTH_CM: f32 = 2.5;

/// The file's JSON (before gzip).
#[derive(Debug, Serialize, Deserialize)]
struct Stored {
    format: String,
    source: String,
    quantum_cm: f64,
    names: Vec<String>,
    triangles: Vec<[u32; 3]>,
    neutral: Vec<[i32; 3]>,
    /// Per expression (names[1..]), per vertex: the offset from the neutral.
    deltas: Vec<Vec<[i32; 3]>>,
    landmarks: Vec<Option<u32>>,
    /// Per vertex: the bone point of its constraint and the bone, if it has one.
    bones: Vec<Option<(Bone, [i32; 3])>>,
    jaw_pivot: [i32; 3],
}

fn quantise(p: [f32; 3]) -> [i32; 3] {
    p.map(|v| (f64::from(v) / QUANTUM_CM).round() as i32)
}

fn position(q: [i32; 3]) -> [f32; 3] {
    q.map(|v| (f64::from(v) * QUANTUM_CM) as f32)
}

/// Makes the demo face's file bytes from the ICT-FaceKit folder `data` and the template bones
/// in `templates` (`artisynth-jaw/`, `skull-odedstein/`). The same inputs give the same bytes.
pub fn make(data: &Path, templates: &Path) -> Result<Vec<u8>, DemoFaceError> {
    let kit = IctFaceKit::open(data)?;
    let actor = kit.actor(&[], &DEFAULT_SHAPES, FACE_REGION)?;
    let templates = crate::anatomy::fit::bone_templates(templates)?;
    let fitted = crate::anatomy::fit::fit_bones(kit.neutral(), &kit.landmarks68()?, &templates)?;

    let tris = actor.template.triangles();
    let (kept, triangles) =
        crate::geometry::qem::decimate(&actor.template.positions, &tris, TARGET_VERTICES)
            .map_err(DemoFaceError::Decimate)?;
    let pick =
        |shape: &[[f32; 3]]| -> Vec<[f32; 3]> { kept.iter().map(|&v| shape[v as usize]).collect() };
    let neutral = pick(&actor.template.positions);
    let template = Mesh::new(
        neutral.clone(),
        triangles.iter().map(|t| t.to_vec()).collect(),
    );
    template.validate().map_err(DemoFaceError::DecimatedMesh)?;
    let nearest = |p: [f32; 3]| -> u32 {
        let d = |q: &[f32; 3]| (0..3).map(|i| (p[i] - q[i]).powi(2)).sum::<f32>();
        (0..neutral.len())
            .min_by(|&a, &b| d(&neutral[a]).total_cmp(&d(&neutral[b])))
            .map_or(0, |v| v as u32)
    };
    let landmarks = actor
        .landmarks
        .iter()
        .map(|l| l.map(|l| nearest(actor.template.positions[l as usize])))
        .collect();

    let qn: Vec<[i32; 3]> = neutral.iter().map(|&p| quantise(p)).collect();
    let deltas = actor.shapes[1..]
        .iter()
        .map(|s| {
            pick(s)
                .iter()
                .zip(&qn)
                .map(|(&p, n)| {
                    let q = quantise(p);
                    [q[0] - n[0], q[1] - n[1], q[2] - n[2]]
                })
                .collect()
        })
        .collect();
    let bones = anchors(&template, &fitted.skull, &fitted.jaw, MAX_DEPTH_CM)
        .iter()
        .map(|a| a.map(|a| (a.on, quantise(a.bone))))
        .collect();
    let stored = Stored {
        format: FORMAT.into(),
        // No path in it: the file must not depend on where the kit was read from.
        source: format!(
            "{ICT_ATTRIBUTION}; generic neutral and its {} default expressions, vertex region \
             {FACE_REGION:?} decimated to {} vertices by Sinew; bone constraints against \
             ArtiSynth's jaw (BSD-style) and the odedstein skull (CC BY 3.0) fitted by Sinew",
            DEFAULT_SHAPES.len(),
            neutral.len()
        ),
        quantum_cm: QUANTUM_CM,
        names: actor.names.clone(),
        triangles,
        neutral: qn,
        deltas,
        landmarks,
        bones,
        jaw_pivot: quantise(jaw_pivot(&fitted.jaw)),
    };
    let json = serde_json::to_vec(&stored).map_err(DemoFaceError::Encode)?;
    // No file name and no time in the header, so the bytes depend on the content alone.
    let mut gz = flate2::GzBuilder::new()
        .mtime(0)
        .write(Vec::new(), flate2::Compression::best());
    gz.write_all(&json).map_err(DemoFaceError::Compress)?;
    gz.finish().map_err(DemoFaceError::Compress)
}

/// `sinew data demo-face`: [`make`], written atomically to `out`.
pub fn write(data: &Path, templates: &Path, out: &Path) -> Result<TrainingSet, DemoFaceError> {
    let bytes = make(data, templates)?;
    let set = load(&bytes, &out.display().to_string())?;
    crate::io::atomic::write(out, &bytes)?;
    Ok(set)
}

/// The built-in demo face's training set.
pub fn builtin() -> Result<TrainingSet, DemoFaceError> {
    load(EMBEDDED, &format!("{PATH} (built in)"))
}

/// Reads a demo face file (gzipped JSON) into a training set; `name` names it in errors.
pub fn load(bytes: &[u8], name: &str) -> Result<TrainingSet, DemoFaceError> {
    let mut json = Vec::new();
    flate2::read::GzDecoder::new(bytes)
        .read_to_end(&mut json)
        .map_err(|source| DemoFaceError::NotGzip {
            name: name.to_owned(),
            source,
        })?;
    let s: Stored = serde_json::from_slice(&json).map_err(|source| DemoFaceError::NotDemoFace {
        name: name.to_owned(),
        source,
    })?;
    check(&s).map_err(|source| DemoFaceError::Invalid {
        name: name.to_owned(),
        source,
    })?;
    let neutral: Vec<[f32; 3]> = s.neutral.iter().map(|&q| position(q)).collect();
    let template = Mesh::new(
        neutral.clone(),
        s.triangles.iter().map(|t| t.to_vec()).collect(),
    );
    template
        .validate()
        .map_err(|source| DemoFaceError::FaceMesh {
            name: name.to_owned(),
            source,
        })?;
    let mut shapes = vec![neutral.clone()];
    shapes.extend(s.deltas.iter().map(|d| {
        s.neutral
            .iter()
            .zip(d)
            .map(|(n, d)| position([n[0] + d[0], n[1] + d[1], n[2] + d[2]]))
            .collect()
    }));
    // As `constraints::anchors` defines them: the normal points from the bone point to the skin
    // vertex and the thickness is their distance.
    let anchors = s
        .bones
        .iter()
        .zip(&neutral)
        .map(|(b, skin)| {
            b.and_then(|(on, q)| {
                let bone = position(q);
                let d = [0, 1, 2].map(|i| skin[i] - bone[i]);
                let len = d.iter().map(|v| v * v).sum::<f32>().sqrt();
                (len > 0.0).then(|| Anchor {
                    bone,
                    thickness: len,
                    normal: d.map(|v| v / len),
                    on,
                })
            })
        })
        .collect();
    let set = TrainingSet {
        forehead: forehead(&neutral, &s.landmarks),
        symmetry: symmetry_plane(&neutral, &s.landmarks),
        template,
        shapes,
        names: s.names,
        anchors,
        jaw_pivot: position(s.jaw_pivot),
        units: crate::io::units::Unit::Centimetre,
        mm_per_unit: 10.0,
        source: s.source,
        provenance: Vec::new(),
    };
    set.validate().map_err(|source| DemoFaceError::Set {
        name: name.to_owned(),
        source,
    })?;
    Ok(set)
}

/// Every count and index of a stored face, before anything is built from it.
fn check(s: &Stored) -> Result<(), DemoFaceProblem> {
    if s.format != FORMAT {
        return Err(DemoFaceProblem::Format {
            found: s.format.clone(),
        });
    }
    if s.quantum_cm != QUANTUM_CM {
        return Err(DemoFaceProblem::Quantum {
            found: s.quantum_cm,
        });
    }
    let v = s.neutral.len();
    if v == 0 {
        return Err(DemoFaceProblem::NoVertices);
    }
    if s.names.len() != s.deltas.len() + 1 {
        return Err(DemoFaceProblem::NameCount {
            names: s.names.len(),
            expressions: s.deltas.len(),
        });
    }
    for (d, name) in s.deltas.iter().zip(&s.names[1..]) {
        if d.len() != v {
            return Err(DemoFaceProblem::Offsets {
                name: name.clone(),
                offsets: d.len(),
                vertices: v,
            });
        }
    }
    if s.bones.len() != v {
        return Err(DemoFaceProblem::BoneEntries {
            entries: s.bones.len(),
            vertices: v,
        });
    }
    if let Some(t) = s
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= v))
    {
        return Err(DemoFaceProblem::Triangle {
            triangle: *t,
            vertices: v,
        });
    }
    if let Some(&l) = s.landmarks.iter().flatten().find(|&&l| l as usize >= v) {
        return Err(DemoFaceProblem::Landmark {
            vertex: l,
            vertices: v,
        });
    }
    // Sums of stored integers must not overflow when the shapes are rebuilt.
    let limit = 1 << 28;
    let big = |q: &[i32; 3]| q.iter().any(|c| c.abs() > limit);
    if s.neutral.iter().chain(s.deltas.iter().flatten()).any(big) {
        return Err(DemoFaceProblem::Coordinate {
            limit_cm: f64::from(limit) * QUANTUM_CM,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_builtin_face_is_the_ict_face_region_with_its_bones() {
        let set = builtin().unwrap();
        let v = set.vertices();
        assert!((1000..=2000).contains(&v), "{v} vertices");
        assert_eq!(set.names.len(), 20);
        assert_eq!(set.names[0], "neutral");
        assert_eq!(set.names[1..], DEFAULT_SHAPES);
        // A human head in cm (face, ears and neck): about 18 cm wide and 29 tall, symmetric
        // about x = 0.
        let (lo, hi) = set.template.bounds();
        let size = [0, 1, 2].map(|i| hi[i] - lo[i]);
        assert!((15.0..22.0).contains(&size[0]), "{size:?}");
        assert!((24.0..34.0).contains(&size[1]), "{size:?}");
        assert!(set.symmetry.normal[0].abs() > 0.99, "{:?}", set.symmetry);
        // Most of the face is constrained, a good part of it to the jaw, at plausible depths.
        assert!(
            set.constrained_fraction() > 0.4,
            "{}",
            set.constrained_fraction()
        );
        assert!(set.jaw_constrained().len() > 100);
        let depth: Vec<f32> = set.anchors.iter().flatten().map(|a| a.thickness).collect();
        let mean = depth.iter().sum::<f32>() / depth.len() as f32;
        assert!((0.3..1.5).contains(&mean), "mean depth {mean} cm");
        assert!(!set.forehead.is_empty());
        // jawOpen moves the chin down by centimetres; the neutral is the template itself.
        let open = &set.shapes[1];
        let drop = set.shapes[0]
            .iter()
            .zip(open)
            .map(|(a, b)| a[1] - b[1])
            .fold(0.0f32, f32::max);
        assert!(drop > 2.0, "jawOpen lowers the chin by {drop} cm");
        assert_eq!(set.shapes[0], set.template.positions);
    }

    #[test]
    fn bad_files_are_refused_with_their_name() {
        let err = load(b"not gzip", "face.gz").unwrap_err();
        assert!(
            matches!(&err, DemoFaceError::NotGzip { name, .. } if name == "face.gz"),
            "{err}"
        );

        let mut json = Vec::new();
        flate2::read::GzDecoder::new(EMBEDDED)
            .read_to_end(&mut json)
            .unwrap();
        let gz = |s: &Stored| {
            let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
            e.write_all(&serde_json::to_vec(s).unwrap()).unwrap();
            e.finish().unwrap()
        };
        let good: Stored = serde_json::from_slice(&json).unwrap();
        assert!(load(&gz(&good), "ok").is_ok());

        let mut s: Stored = serde_json::from_slice(&json).unwrap();
        s.triangles[3][1] = 1_000_000;
        let err = load(&gz(&s), "face.gz").unwrap_err();
        assert!(
            matches!(&err, DemoFaceError::Invalid { name, source: DemoFaceProblem::Triangle { triangle, .. } }
                if name == "face.gz" && triangle[1] == 1_000_000),
            "{err}"
        );

        let mut s: Stored = serde_json::from_slice(&json).unwrap();
        s.deltas[4].pop();
        let err = load(&gz(&s), "face.gz").unwrap_err();
        assert!(
            matches!(&err, DemoFaceError::Invalid { source: DemoFaceProblem::Offsets { name, .. }, .. }
                if name == DEFAULT_SHAPES[4]),
            "{err}"
        );

        let mut s: Stored = serde_json::from_slice(&json).unwrap();
        s.format = "other/2".into();
        let err = load(&gz(&s), "face.gz").unwrap_err();
        assert!(
            matches!(&err, DemoFaceError::Invalid { source: DemoFaceProblem::Format { found }, .. }
                if found == "other/2"),
            "{err}"
        );

        let err = load(&gz(&good)[..200], "cut.gz").unwrap_err();
        assert!(
            matches!(&err, DemoFaceError::NotGzip { name, .. } if name == "cut.gz"),
            "{err}"
        );
    }

    /// The committed file is what `sinew data demo-face` makes from the shared data today.
    #[test]
    fn regenerating_from_ict_facekit_reproduces_the_committed_file() {
        let Some(root) = crate::io::data::data_dir() else {
            return;
        };
        let made = make(&root.join("ict-facekit"), &root).unwrap();
        assert!(
            made == EMBEDDED,
            "{PATH} differs from what `sinew data demo-face` makes now ({} bytes against {}); \
             regenerate it with the command in docs/AIM.md",
            made.len(),
            EMBEDDED.len()
        );
    }
}
