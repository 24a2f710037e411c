//! The face template that finds a rig's landmarks: the ICT-FaceKit generic neutral's face
//! region decimated by Sinew (every template vertex is a kit vertex, `kit_vertices`), its 68 iBUG
//! landmarks as points on the template's surface at the kit's landmark vertices, and the jaw
//! hinge of the bones fitted to the kit. Stored compactly in the repository
//! (`host/data/face-template.json.gz`, listed in NOTICE) and built into the binary, so that
//! `sinew rig inspect` needs no data files; `sinew data face-template` makes it.

use std::io::{Read, Write};

use serde::{Deserialize, Serialize};

/// The format name inside the file.
pub const FORMAT: &str = "sinew-face-template-1";

/// Where the file lives in the repository.
pub const PATH: &str = "host/data/face-template.json.gz";

const EMBEDDED: &[u8] = include_bytes!("../../data/face-template.json.gz");

/// Coordinates are stored as integers in units of this many centimetres (0.01 mm).
pub const QUANTUM_CM: f64 = 0.001;

/// The template: the kit's frame and unit (centimetres, +Y up, +Z forward).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FaceTemplate {
    /// The format name, [`FORMAT`].
    pub format: String,
    /// Where it comes from, with licence and attribution.
    pub source: String,
    /// Positions, in units of [`QUANTUM_CM`].
    pub positions: Vec<[i32; 3]>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Per template vertex, the kit vertex it is.
    pub kit_vertices: Vec<u32>,
    /// The 68 iBUG landmarks in order: a triangle and its barycentric weights.
    pub landmarks: Vec<(u32, [f64; 3])>,
    /// The jaw's hinge, in units of [`QUANTUM_CM`].
    pub jaw_pivot: [i32; 3],
}

/// Why the template cannot be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TemplateError {
    /// Not gzip.
    #[error("{name}: not a gzip file")]
    NotGzip {
        /// The file.
        name: String,
        /// What the decoder said.
        #[source]
        source: std::io::Error,
    },
    /// Not the template's JSON.
    #[error("{name}: not a face template ({FORMAT})")]
    NotTemplate {
        /// The file.
        name: String,
        /// What the parser said.
        #[source]
        source: serde_json::Error,
    },
    /// A count or index out of place.
    #[error("{name}: {what}")]
    Invalid {
        /// The file.
        name: String,
        /// What is wrong.
        what: String,
    },
    /// Encoding failed.
    #[error("encoding the face template")]
    Encode(#[source] std::io::Error),
}

impl FaceTemplate {
    /// The template built into the binary.
    pub fn builtin() -> Result<Self, TemplateError> {
        Self::decode(EMBEDDED, &format!("{PATH} (built in)"))
    }

    /// Reads gzipped JSON; `name` names the file in errors.
    pub fn decode(bytes: &[u8], name: &str) -> Result<Self, TemplateError> {
        let mut json = Vec::new();
        flate2::read::GzDecoder::new(bytes)
            .read_to_end(&mut json)
            .map_err(|source| TemplateError::NotGzip {
                name: name.to_owned(),
                source,
            })?;
        let t: Self =
            serde_json::from_slice(&json).map_err(|source| TemplateError::NotTemplate {
                name: name.to_owned(),
                source,
            })?;
        let invalid = |what: String| TemplateError::Invalid {
            name: name.to_owned(),
            what,
        };
        let n = t.positions.len();
        if t.format != FORMAT {
            return Err(invalid(format!("format {:?}, not {FORMAT}", t.format)));
        }
        if t.kit_vertices.len() != n {
            return Err(invalid(format!(
                "{} kit vertices for {n} positions",
                t.kit_vertices.len()
            )));
        }
        if let Some(k) = t
            .triangles
            .iter()
            .position(|tri| tri.iter().any(|&v| v as usize >= n))
        {
            return Err(invalid(format!(
                "triangle {k} names a vertex past the {n} positions"
            )));
        }
        if t.landmarks.len() != 68 {
            return Err(invalid(format!(
                "{} landmarks, 68 needed",
                t.landmarks.len()
            )));
        }
        if let Some(k) = t.landmarks.iter().position(|(tri, w)| {
            *tri as usize >= t.triangles.len() || w.iter().any(|v| !v.is_finite())
        }) {
            return Err(invalid(format!("landmark {k} is not on a triangle")));
        }
        Ok(t)
    }

    /// Gzipped JSON; the same template gives the same bytes.
    pub fn encode(&self) -> Result<Vec<u8>, TemplateError> {
        let json = serde_json::to_vec(self).map_err(|e| TemplateError::Encode(e.into()))?;
        let mut gz = flate2::GzBuilder::new()
            .mtime(0)
            .write(Vec::new(), flate2::Compression::best());
        gz.write_all(&json).map_err(TemplateError::Encode)?;
        gz.finish().map_err(TemplateError::Encode)
    }

    /// Positions in centimetres.
    pub fn points(&self) -> Vec<[f64; 3]> {
        self.positions
            .iter()
            .map(|q| q.map(|v| f64::from(v) * QUANTUM_CM))
            .collect()
    }

    /// A position in centimetres stored in units of [`QUANTUM_CM`].
    pub fn quantise(p: [f64; 3]) -> [i32; 3] {
        p.map(|v| (v / QUANTUM_CM).round() as i32)
    }

    /// The jaw pivot in centimetres.
    pub fn jaw_pivot_cm(&self) -> [f64; 3] {
        self.jaw_pivot.map(|v| f64::from(v) * QUANTUM_CM)
    }
}
