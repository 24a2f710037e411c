//! ArtiSynth's "Badin" face: a finite-element model of one real speaker's lower face
//! (`face.node`, `face.elem`) co-registered with his mandible (`badinjaw.obj`) and maxilla
//! (`badinmaxilla.obj`). It is the only real skin + bone pair in the data, so it is where the
//! ray-based anatomical constraints ([`crate::anatomy::constraints`]) are checked against measured
//! soft-tissue thickness (`fstt/soft_tissue_thickness.md`, section B).
//!
//! Frame: metres; x points posterior (anterior = smaller x), y is lateral with the midline at
//! y = 0, z points up.
//!
//! File format (ANSYS `NWRITE`/`EWRITE` fixed-width text, as ArtiSynth's `AnsysReader` reads it):
//! - `face.node`: one node per line, the node number in 8 columns, then x, y, z in 20 columns
//!   each (Fortran `E` notation; fields may touch, e.g. `0.57E-01-0.40E-02`, so they are cut by
//!   column, never split on spaces).
//! - `face.elem`: one element per line, 14 fields of 6 columns: the node numbers I, J, K, L
//!   (bottom face) and M, N, O, P (top face), then MAT, TYPE, REAL, SECNUM, ESYS and the element
//!   number. Degenerate shapes repeat nodes: a wedge has K = L and O = P (318 of them here); a
//!   pyramid M = N = O = P; a tetrahedron both.
//!
//! The skin: the FEM's boundary (faces used by exactly one element) is not all skin. It also
//! holds the inner surface that rests on the bones, the inner sides of the lips facing the teeth
//! and the cuts where the model ends. [`Fem::outer_skin`] keeps a boundary face when a ray from
//! its centre along its outward normal meets no bone: real skin looks out into the air, while
//! the bone-facing surfaces look straight at the jaw or maxilla. Where the FEM's inner surface
//! faces no bone in these meshes (behind the nose, whose bones are not modelled, and the cuts at
//! the back), a second test removes it: the outward normal must point away from a point inside
//! the head (the bones' centroid), as skin on a roughly convex head does.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::anatomy::constraints::{Bone, BoneScene, ConstraintParams, Constraints};
use crate::io::mesh::{Mesh, MeshError};

/// Why the Badin data set could not be read; every variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BadinError {
    /// One of the four files is absent.
    #[error("{}: missing (the Badin data set needs it)", path.display())]
    Missing {
        /// The file.
        path: PathBuf,
    },
    /// A node or element file could not be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A line of a node or element file that breaks the format.
    #[error("{}: line {line}: {problem}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The line, from 1.
        line: usize,
        /// What is wrong with it.
        problem: LineProblem,
    },
    /// A node file without nodes.
    #[error("{}: no nodes", path.display())]
    NoNodes {
        /// The node file.
        path: PathBuf,
    },
    /// An element file without elements.
    #[error("{}: no elements", path.display())]
    NoElements {
        /// The element file.
        path: PathBuf,
    },
    /// A bone mesh could not be read.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

/// What is wrong with one line of an ANSYS node or element file.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LineProblem {
    /// The node number is absent or not a number.
    #[error("bad node number")]
    NodeNumber,
    /// A coordinate field is empty (counted from 1).
    #[error("coordinate {0} missing")]
    CoordinateMissing(usize),
    /// A coordinate that is not a finite Fortran real.
    #[error("bad coordinate {0:?}")]
    Coordinate(String),
    /// A node number used twice in the node file.
    #[error("node {0} defined twice")]
    NodeTwice(u32),
    /// An element's node field (counted from 1) that is not a number.
    #[error("bad node number in field {0}")]
    ElementField(usize),
    /// An element that names a node the node file lacks.
    #[error("node {node} is not in {}", node_file.display())]
    UnknownNode {
        /// The node number.
        node: u32,
        /// The node file.
        node_file: PathBuf,
    },
    /// An element with fewer than four distinct nodes.
    #[error("element has only {0} distinct nodes")]
    TooFewNodes(usize),
}

/// A finite-element mesh read from ANSYS node and element files.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Fem {
    /// The file's node numbers, parallel to `nodes`.
    pub node_ids: Vec<u32>,
    /// Node positions, in file order.
    pub nodes: Vec<[f32; 3]>,
    /// Elements as 0-based indices into `nodes`, in ANSYS order I, J, K, L, M, N, O, P
    /// (repeated indices for wedges, pyramids and tetrahedra).
    pub elements: Vec<[u32; 8]>,
}

/// The six faces of an ANSYS hexahedron, as positions in I..P. Each is wound so that, for a
/// positively oriented element, its normal points out; [`Fem::boundary_faces`] checks the
/// orientation against the element's centre anyway.
const HEX_FACES: [[usize; 4]; 6] = [
    [0, 3, 2, 1], // bottom I L K J
    [4, 5, 6, 7], // top M N O P
    [0, 1, 5, 4], // I J N M
    [1, 2, 6, 5], // J K O N
    [2, 3, 7, 6], // K L P O
    [3, 0, 4, 7], // L I M P
];

impl Fem {
    /// Reads `node_path` and `elem_path`.
    pub fn read(node_path: &Path, elem_path: &Path) -> Result<Fem, BadinError> {
        let read = |path: &Path| {
            std::fs::read_to_string(path).map_err(|source| BadinError::Read {
                path: path.to_path_buf(),
                source,
            })
        };
        let nodes = read(node_path)?;
        let elems = read(elem_path)?;
        Self::parse(&nodes, node_path, &elems, elem_path)
    }

    /// Parses the two files' text; the paths only name the files in errors.
    pub fn parse(
        node_text: &str,
        node_path: &Path,
        elem_text: &str,
        elem_path: &Path,
    ) -> Result<Fem, BadinError> {
        let mut fem = Fem::default();
        let mut index: HashMap<u32, u32> = HashMap::new();
        for (ln, line) in node_text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let at = |problem| BadinError::Line {
                path: node_path.to_path_buf(),
                line: ln + 1,
                problem,
            };
            let id: u32 = field(line, 0, 8)
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| at(LineProblem::NodeNumber))?;
            let mut p = [0.0f32; 3];
            for (k, c) in p.iter_mut().enumerate() {
                let s = field(line, 8 + 20 * k, 20)
                    .ok_or_else(|| at(LineProblem::CoordinateMissing(k + 1)))?;
                *c = parse_float(s).ok_or_else(|| at(LineProblem::Coordinate(s.to_string())))?;
            }
            if index.insert(id, fem.nodes.len() as u32).is_some() {
                return Err(at(LineProblem::NodeTwice(id)));
            }
            fem.node_ids.push(id);
            fem.nodes.push(p);
        }
        for (ln, line) in elem_text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let at = |problem| BadinError::Line {
                path: elem_path.to_path_buf(),
                line: ln + 1,
                problem,
            };
            let mut e = [0u32; 8];
            for (k, slot) in e.iter_mut().enumerate() {
                let id: u32 = field(line, 6 * k, 6)
                    .and_then(|s| s.parse().ok())
                    .ok_or_else(|| at(LineProblem::ElementField(k + 1)))?;
                *slot = *index.get(&id).ok_or_else(|| {
                    at(LineProblem::UnknownNode {
                        node: id,
                        node_file: node_path.to_path_buf(),
                    })
                })?;
            }
            let mut distinct = e.to_vec();
            distinct.sort_unstable();
            distinct.dedup();
            if distinct.len() < 4 {
                return Err(at(LineProblem::TooFewNodes(distinct.len())));
            }
            fem.elements.push(e);
        }
        if fem.nodes.is_empty() {
            return Err(BadinError::NoNodes {
                path: node_path.to_path_buf(),
            });
        }
        if fem.elements.is_empty() {
            return Err(BadinError::NoElements {
                path: elem_path.to_path_buf(),
            });
        }
        Ok(fem)
    }

    /// The faces used by exactly one element, each wound so that its normal points out of its
    /// element (away from the element's centre). Faces of degenerate elements lose repeated
    /// corners (a wedge's quads collapse to its two triangles); faces left with fewer than three
    /// corners are dropped. Output order follows the elements, so it is deterministic.
    pub fn boundary_faces(&self) -> Vec<Vec<u32>> {
        let mut faces: Vec<(Vec<u32>, Vec<u32>)> = Vec::new(); // (key, oriented corners)
        for e in &self.elements {
            let centre = self.centre(&dedup_cyclic(e));
            for hf in HEX_FACES {
                let mut f = dedup_cyclic(&hf.map(|k| e[k]));
                if f.len() < 3 {
                    continue;
                }
                let n = newell(&self.nodes, &f);
                let c = self.centre(&f);
                let out = [c[0] - centre[0], c[1] - centre[1], c[2] - centre[2]];
                if n[0] * out[0] + n[1] * out[1] + n[2] * out[2] < 0.0 {
                    f.reverse();
                }
                let mut key = f.clone();
                key.sort_unstable();
                faces.push((key, f));
            }
        }
        let mut count: HashMap<&[u32], u32> = HashMap::new();
        for (key, _) in &faces {
            *count.entry(key.as_slice()).or_insert(0) += 1;
        }
        faces
            .iter()
            .filter(|(key, _)| count.get(key.as_slice()) == Some(&1))
            .map(|(_, f)| f.clone())
            .collect()
    }

    /// The boundary faces that are skin (see the module docs): those whose outward normal
    /// points away from `inside` (a point inside the head, e.g. the bones' centroid) and whose
    /// outward ray (from the face centre along the normal) meets none of the bones in `scene`.
    pub fn outer_skin(&self, scene: &BoneScene, inside: [f32; 3]) -> Vec<Vec<u32>> {
        self.boundary_faces()
            .into_iter()
            .filter(|f| {
                let n = newell(&self.nodes, f);
                let c = self.centre(f);
                let away = (0..3)
                    .map(|k| n[k] * (c[k] - inside[k] as f64))
                    .sum::<f64>()
                    > 0.0;
                away && scene
                    .first_hit(
                        [c[0] as f32, c[1] as f32, c[2] as f32],
                        [n[0] as f32, n[1] as f32, n[2] as f32],
                        f32::MAX,
                    )
                    .is_none()
            })
            .collect()
    }

    fn centre(&self, f: &[u32]) -> [f64; 3] {
        let mut c = [0.0f64; 3];
        for &v in f {
            for (ck, pk) in c.iter_mut().zip(self.nodes[v as usize]) {
                *ck += pk as f64;
            }
        }
        c.map(|x| x / f.len() as f64)
    }
}

/// Column `start..start + width` of `line`, trimmed; `None` past the end or if blank.
fn field(line: &str, start: usize, width: usize) -> Option<&str> {
    let end = (start + width).min(line.len());
    let s = line.get(start..end)?.trim();
    (!s.is_empty()).then_some(s)
}

/// A Fortran real: `E` or `D` exponent.
fn parse_float(s: &str) -> Option<f32> {
    let v: f64 = s.replace(['D', 'd'], "E").parse().ok()?;
    v.is_finite().then_some(v as f32)
}

/// The corners with consecutive (cyclic) repeats removed.
fn dedup_cyclic(f: &[u32]) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::with_capacity(f.len());
    for &v in f {
        if out.last() != Some(&v) {
            out.push(v);
        }
    }
    while out.len() > 1 && out.first() == out.last() {
        out.pop();
    }
    out
}

/// Newell's area vector of a polygon (twice the area times the unit normal).
fn newell(p: &[[f32; 3]], f: &[u32]) -> [f64; 3] {
    let mut n = [0.0f64; 3];
    for k in 0..f.len() {
        let a = p[f[k] as usize].map(f64::from);
        let b = p[f[(k + 1) % f.len()] as usize].map(f64::from);
        n[0] += (a[1] - b[1]) * (a[2] + b[2]);
        n[1] += (a[2] - b[2]) * (a[0] + b[0]);
        n[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    n
}

/// The whole Badin data set: the FEM and its two bones, all in metres.
#[derive(Clone, Debug)]
pub struct Badin {
    /// The face FEM.
    pub fem: Fem,
    /// `badinjaw.obj`.
    pub jaw: Mesh,
    /// `badinmaxilla.obj`.
    pub maxilla: Mesh,
}

/// The outer skin of the FEM as a mesh, with its constraints.
#[derive(Clone, Debug)]
pub struct BadinSkin {
    /// The skin faces (quads and the wedges' triangles) over the skin nodes only.
    pub mesh: Mesh,
    /// For each skin vertex, its index in [`Fem::nodes`].
    pub fem_node: Vec<u32>,
    /// Outward area-weighted vertex normals of `mesh`.
    pub normals: Vec<[f32; 3]>,
    /// The constraints of each skin vertex against jaw and maxilla.
    pub constraints: Constraints,
}

/// One row of the section-B comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BandRow {
    /// Band centre height (m).
    pub z: f32,
    /// The table's thickness (mm).
    pub table_mm: f32,
    /// The chosen node's index in [`Fem::nodes`].
    pub node: u32,
    /// Distance from that node to the nearest jaw or maxilla vertex, the table's own measure
    /// (mm): reproduces the table and so checks that the same node was picked.
    pub nearest_vertex_mm: f32,
    /// Our ray-based thickness (mm), `None` if the node has no constraint.
    pub ray_mm: Option<f32>,
    /// The bone the ray met.
    pub bone: Option<Bone>,
}

/// `fstt/soft_tissue_thickness.md` section B: (band centre z in m, thickness in mm).
pub const FSTT_BADIN_TABLE: [(f32, f32); 8] = [
    (0.045, 9.1),
    (0.055, 12.2),
    (0.065, 13.3),
    (0.075, 12.0),
    (0.085, 12.2),
    (0.095, 8.1),
    (0.105, 10.5),
    (0.115, 12.4),
];

/// Half the height of one table band (m).
pub const BAND_HALF_HEIGHT: f32 = 0.0025;

/// Nodes this close to y = 0 (m) count as midline (the FEM's midline nodes have y = 0 exactly).
pub const MIDLINE_TOLERANCE: f32 = 0.0005;

/// The deepest bone hit accepted on the Badin skin (m): deeper than any tissue in the table.
pub const BADIN_MAX_DEPTH: f32 = 0.03;

impl Badin {
    /// Reads `face.node`, `face.elem`, `badinjaw.obj` and `badinmaxilla.obj` from `dir`.
    pub fn open(dir: &Path) -> Result<Badin, BadinError> {
        let p = |n: &str| -> PathBuf { dir.join(n) };
        for n in ["face.node", "face.elem", "badinjaw.obj", "badinmaxilla.obj"] {
            if !p(n).is_file() {
                return Err(BadinError::Missing { path: p(n) });
            }
        }
        Ok(Badin {
            fem: Fem::read(&p("face.node"), &p("face.elem"))?,
            jaw: Mesh::read(&p("badinjaw.obj"))?,
            maxilla: Mesh::read(&p("badinmaxilla.obj"))?,
        })
    }

    /// The ray scene of the two bones.
    pub fn bone_scene(&self) -> BoneScene {
        let jt = self.jaw.triangles();
        let mt = self.maxilla.triangles();
        BoneScene::new(&[
            (Bone::Jaw, &self.jaw.positions, &jt),
            (Bone::Skull, &self.maxilla.positions, &mt),
        ])
    }

    /// The mean of all jaw and maxilla vertices: a point inside the head.
    pub fn bone_centroid(&self) -> [f32; 3] {
        let mut c = [0.0f64; 3];
        let all = self.jaw.positions.iter().chain(&self.maxilla.positions);
        let n = self.jaw.positions.len() + self.maxilla.positions.len();
        for p in all {
            for k in 0..3 {
                c[k] += p[k] as f64;
            }
        }
        c.map(|x| (x / n.max(1) as f64) as f32)
    }

    /// The outer skin and its constraints (ray depth up to `params.max_depth`).
    pub fn skin(&self, params: &ConstraintParams) -> BadinSkin {
        let scene = self.bone_scene();
        let all = Mesh::new(
            self.fem.nodes.clone(),
            self.fem.outer_skin(&scene, self.bone_centroid()),
        );
        let mut on_skin = vec![false; all.positions.len()];
        for f in &all.polygons {
            for &v in f {
                on_skin[v as usize] = true;
            }
        }
        let (mesh, fem_node) = all.submesh(|v| on_skin[v as usize]);
        let normals = mesh.vertex_normals();
        let constraints = scene.constraints(&mesh.positions, &normals, params);
        BadinSkin {
            mesh,
            fem_node,
            normals,
            constraints,
        }
    }

    /// The section-B comparison: for each table band, the most anterior (smallest x) midline
    /// skin node within the band, its nearest-bone-vertex distance and its ray thickness.
    /// Bands without a midline skin node are left out.
    pub fn midline_bands(&self, skin: &BadinSkin) -> Vec<BandRow> {
        let bone_vertices: Vec<[f32; 3]> = self
            .jaw
            .positions
            .iter()
            .chain(&self.maxilla.positions)
            .copied()
            .collect();
        let mut rows = Vec::new();
        for (z, table_mm) in FSTT_BADIN_TABLE {
            let best = skin
                .mesh
                .positions
                .iter()
                .enumerate()
                .filter(|(_, p)| {
                    p[1].abs() <= MIDLINE_TOLERANCE && (p[2] - z).abs() <= BAND_HALF_HEIGHT
                })
                .min_by(|a, b| a.1[0].total_cmp(&b.1[0]).then(a.0.cmp(&b.0)));
            let Some((i, p)) = best else { continue };
            let nearest = bone_vertices
                .iter()
                .map(|b| {
                    let d = [b[0] - p[0], b[1] - p[1], b[2] - p[2]];
                    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                })
                .fold(f32::INFINITY, f32::min);
            let c = skin.constraints.per_vertex[i];
            rows.push(BandRow {
                z,
                table_mm,
                node: skin.fem_node[i],
                nearest_vertex_mm: nearest * 1000.0,
                ray_mm: c.map(|c| c.thickness * 1000.0),
                bone: c.map(|c| c.bone),
            });
        }
        rows
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::io::data::data_dir;

    /// ANSYS node lines: id in 8 columns, coordinates right-aligned in 20 (a negative value
    /// fills all 20, so it touches the previous field, as in the real file).
    fn nodes_text() -> String {
        // Values here are 0, ±0.5, 1 or 2, written as ANSYS does: `0.d000000000000E+0e`.
        let f = |v: f32| {
            let (d, e) = match v.abs() {
                0.0 => return "0.000000000000".to_string(),
                0.5 => (5, 0),
                1.0 => (1, 1),
                _ => (2, 1),
            };
            let sign = if v < 0.0 { "-" } else { "" };
            format!("{sign}0.{d}000000000000E+0{e}")
        };
        let pts: [[f32; 3]; 10] = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
            [2.0, -0.5, 0.0],
            [2.0, -0.5, 1.0],
        ];
        pts.iter()
            .enumerate()
            .map(|(i, p)| format!("{:8}{:>20}{:>20}{:>20}\n", i + 1, f(p[0]), f(p[1]), f(p[2])))
            .collect()
    }

    // A unit cube and a wedge glued to its x = 1 face (K = L, O = P).
    const ELEMS: &str = r"
     1     2     3     4     5     6     7     8     1     1     1     1     0     1
     2     9     3     3     6    10     7     7     1     1     1     1     0     2
";

    #[test]
    fn parses_touching_fields_and_finds_outward_boundary() {
        let fem = Fem::parse(&nodes_text(), Path::new("n"), ELEMS, Path::new("e")).unwrap();
        assert_eq!(fem.nodes.len(), 10);
        assert_eq!(fem.nodes[8], [2.0, -0.5, 0.0]);
        assert_eq!(fem.elements[1], [1, 8, 2, 2, 5, 9, 6, 6]);
        let faces = fem.boundary_faces();
        // Cube: 6 faces, minus the one shared with the wedge; wedge: 2 triangles + 3 quads,
        // minus the shared one.
        assert_eq!(faces.len(), 5 + 4);
        assert_eq!(faces.iter().filter(|f| f.len() == 3).count(), 2);
        // Every boundary face points away from the solid's centre of mass (the solid is convex).
        let c = [1.0, 0.4, 0.5];
        for f in &faces {
            let n = newell(&fem.nodes, f);
            let m = fem.centre(f);
            let d = (m[0] - c[0]) * n[0] + (m[1] - c[1]) * n[1] + (m[2] - c[2]) * n[2];
            assert!(d > 0.0, "face {f:?} points inward");
        }
    }

    #[test]
    fn bad_files_name_file_and_line() {
        let e = Fem::parse(
            &nodes_text(),
            Path::new("face.node"),
            "     1     2",
            Path::new("face.elem"),
        )
        .unwrap_err();
        assert!(
            matches!(&e, BadinError::Line { path, line: 1, problem: LineProblem::ElementField(3) }
                if path == Path::new("face.elem")),
            "{e}"
        );
        let e = Fem::parse(
            "       1 x",
            Path::new("face.node"),
            ELEMS,
            Path::new("face.elem"),
        )
        .unwrap_err();
        assert!(
            matches!(&e, BadinError::Line { path, line: 1, problem: LineProblem::Coordinate(c) }
                if path == Path::new("face.node") && c == "x"),
            "{e}"
        );
        let e = Fem::parse(
            &nodes_text(),
            Path::new("face.node"),
            &ELEMS.replace("    10", "    99"),
            Path::new("face.elem"),
        )
        .unwrap_err();
        assert!(
            matches!(&e, BadinError::Line { problem: LineProblem::UnknownNode { node: 99, node_file }, .. }
                if node_file == Path::new("face.node")),
            "{e}"
        );
        // The message keeps the file, the line and the problem.
        assert!(
            e.to_string()
                .contains("face.elem: line 3: node 99 is not in face.node"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_or_damaged_data_set_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let err = Badin::open(dir.path()).unwrap_err();
        assert!(matches!(&err, BadinError::Missing { path } if path.ends_with("face.node")));
        std::fs::write(dir.path().join("face.node"), "       1 x\n").unwrap();
        std::fs::write(dir.path().join("face.elem"), ELEMS).unwrap();
        std::fs::write(dir.path().join("badinjaw.obj"), "v 0 0 0\n").unwrap();
        std::fs::write(dir.path().join("badinmaxilla.obj"), "v 0 0 0\n").unwrap();
        let err = Badin::open(dir.path()).unwrap_err();
        assert!(
            matches!(&err, BadinError::Line { path, line: 1, .. } if path.ends_with("face.node")),
            "{err}"
        );
        let err =
            Fem::read(&dir.path().join("none.node"), &dir.path().join("face.elem")).unwrap_err();
        assert!(matches!(&err, BadinError::Read { path, .. } if path.ends_with("none.node")));
    }

    #[test]
    fn real_badin_midline_thickness_matches_table() {
        let Some(dir) = data_dir() else { return };
        let badin = Badin::open(&dir.join("artisynth-badin")).unwrap();
        assert_eq!(badin.fem.nodes.len(), 8720);
        assert_eq!(badin.fem.elements.len(), 6342);
        let skin = badin.skin(&ConstraintParams::new(BADIN_MAX_DEPTH));
        let rows = badin.midline_bands(&skin);
        println!(
            "Badin skin: {} of {} FEM nodes, {} faces; constrained {:.1}%",
            skin.mesh.positions.len(),
            badin.fem.nodes.len(),
            skin.mesh.polygons.len(),
            100.0 * skin.constraints.fraction()
        );
        println!("z (m) | table mm | nearest-vertex mm | ray mm | bone");
        for r in &rows {
            println!(
                "{:.3} | {:.1} | {:.1} | {} | {:?}",
                r.z,
                r.table_mm,
                r.nearest_vertex_mm,
                r.ray_mm.map_or("-".into(), |v| format!("{v:.1}")),
                r.bone
            );
        }
        // AIM eq. 1 consistency of the constraints: |b + d n - s| (see constraints.rs).
        let mut eq1: Vec<f32> = skin
            .constraints
            .per_vertex
            .iter()
            .zip(&skin.mesh.positions)
            .filter_map(|(c, s)| {
                let r = c.as_ref()?.reconstruct();
                Some(
                    ((r[0] - s[0]).powi(2) + (r[1] - s[1]).powi(2) + (r[2] - s[2]).powi(2)).sqrt()
                        * 1000.0,
                )
            })
            .collect();
        eq1.sort_by(f32::total_cmp);
        println!(
            "eq. 1 residual |b + d n - s|: median {:.2} mm, 95th percentile {:.2} mm",
            eq1[eq1.len() / 2],
            eq1[eq1.len() * 95 / 100]
        );
        assert!(skin.constraints.fraction() > 0.2 && skin.constraints.skipped_triangles == 0);
        assert_eq!(rows.len(), FSTT_BADIN_TABLE.len());
        for r in &rows {
            let ray = r
                .ray_mm
                .unwrap_or_else(|| panic!("band z = {} has no constraint", r.z));
            assert!(
                (ray - r.table_mm).abs() <= 3.0,
                "band z = {}: ray {ray:.1} mm, table {} mm",
                r.z,
                r.table_mm
            );
        }
    }
}
