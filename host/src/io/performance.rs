//! A performance folder, as `sinew data performance` writes it and the fit, the driver and
//! `sinew view` read it back: synthetic facial performances with their ground truth.
//!
//! # Folder
//! - `frame_00000.obj` … one mesh per frame (cm);
//! - `openface.csv`: the 2D landmark track in OpenFace 2.0's CSV layout (what a webcam tracker
//!   gives `sinew drive`);
//! - `performance.json` ([`Manifest`]), written last: seed, frames, the ground-truth parameters
//!   per frame, the kit vertex of each mesh vertex, the camera and the 2D landmark tracks.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::io::dataset::{self, DataSetError};
use crate::io::mesh::{Mesh, MeshError};
use crate::io::units::{Unit, UnknownUnit};

/// The manifest's file name.
pub const MANIFEST: &str = "performance.json";
/// The folder's 2D track as an OpenFace 2.0 CSV (`sinew drive --landmarks` with the camera's
/// intrinsics), written before the manifest.
pub const OPENFACE_CSV: &str = "openface.csv";
/// The manifest's `format` value.
pub const FORMAT: &str = "sinew-performance";
/// The manifest's version.
pub const VERSION: u32 = 1;

/// A pinhole camera looking along −z from `position` (x right, y up in the world; the image's
/// v axis points down): `u = cx + fx·(x − px)/(pz − z)`, `v = cy − fy·(y − py)/(pz − z)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Focal lengths in pixels.
    pub fx: f32,
    /// Focal lengths in pixels.
    pub fy: f32,
    /// Principal point in pixels.
    pub cx: f32,
    /// Principal point in pixels.
    pub cy: f32,
    /// Camera centre in world units (cm).
    pub position: [f32; 3],
}

impl Camera {
    /// The pixel a world point projects to, or `None` behind the camera.
    pub fn project(&self, p: [f32; 3]) -> Option<[f32; 2]> {
        let depth = self.position[2] - p[2];
        if depth <= 0.0 {
            return None;
        }
        Some([
            self.cx + self.fx * (p[0] - self.position[0]) / depth,
            self.cy - self.fy * (p[1] - self.position[1]) / depth,
        ])
    }

    /// Whether a pixel lies inside the image.
    pub fn inside(&self, uv: [f32; 2]) -> bool {
        (0.0..self.width as f32).contains(&uv[0]) && (0.0..self.height as f32).contains(&uv[1])
    }
}

/// One frame's ground truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameParameters {
    /// The weight of each of [`Manifest::expressions`], in [0, 1].
    pub weights: Vec<f32>,
    /// Jaw: 6D rotation (first two columns) + translation, about [`Manifest::jaw_pivot`].
    pub jaw: [f32; 9],
    /// Head: 6D rotation + translation, applied last.
    pub head: [f32; 9],
}

/// The 2D landmark tracks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Landmarks {
    /// The mesh vertex of each of the 68 iBUG landmarks (the kit's landmark vertex, or the
    /// nearest vertex of the actor's template on the neutral when the template lacks it).
    pub vertices: Vec<u32>,
    /// Per frame, the 68 landmarks' pixels `[u, v]`.
    pub pixels: Vec<Vec<[f32; 2]>>,
}

/// `performance.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// Always true: every performance of this format is generated.
    pub synthetic: bool,
    /// Where the geometry comes from (the kit's attribution and folder).
    pub source: String,
    /// The seed of the trajectories and the noise.
    pub seed: u64,
    /// Number of frames.
    pub frames: usize,
    /// Frames per second of the trajectories.
    pub fps: f32,
    /// Standard deviation of the Gaussian noise on every coordinate, in mm.
    pub noise_mm: f32,
    /// Standard deviation of the Gaussian noise on every landmark pixel coordinate (a 2D
    /// detector's error), on top of what the meshes' noise moves them; 0 in performances made
    /// before the option existed.
    #[serde(default)]
    pub landmark_noise_px: f32,
    /// Length unit of the meshes and the camera (a [`Unit`]'s name; [`Performance::unit`] is
    /// it resolved).
    pub units: String,
    /// Vertices per mesh.
    pub vertices: usize,
    /// The ICT-FaceKit folder the performance was made from.
    pub data: PathBuf,
    /// The actor whose topology, jaw weights and pivot were used.
    pub actor: Option<PathBuf>,
    /// The kit vertex each mesh vertex is.
    pub kit_vertices: Vec<u32>,
    /// The jaw pivot (the actor's); `None` without an actor, when the jaw moves through the
    /// kit's jaw shapes only.
    pub jaw_pivot: Option<[f32; 3]>,
    /// The kit's expression names, in weight order (all 53).
    pub expressions: Vec<String>,
    /// The mesh file of each frame, relative to the folder.
    pub files: Vec<String>,
    /// The ground truth of each frame.
    pub parameters: Vec<FrameParameters>,
    /// The camera the landmarks were projected through.
    pub camera: Camera,
    /// The 2D landmark tracks.
    pub landmarks: Landmarks,
    /// Frames at rest, looking at the camera, at the start (0 in performances made before the
    /// option existed).
    #[serde(default)]
    pub rest_frames: usize,
    /// The tracker's convention the 2D track carries, if any.
    #[serde(default)]
    pub convention: Option<ConventionRecord>,
    /// The tracker's failures the 2D track carries (frames its landmarks are misread on).
    #[serde(default)]
    pub failures: Vec<FailureRun>,
}

impl Manifest {
    /// Whether the tracker found no face in frame `f` (a [`Failure::Lost`] failure): the 2D
    /// track's row says `success` 0 there.
    pub fn tracker_lost(&self, f: usize) -> bool {
        self.failures
            .iter()
            .any(|x| x.failure == Failure::Lost && x.covers(f))
    }
}

/// A track's tracker convention (`training::tracker::Convention`): how it was drawn and the
/// offsets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConventionRecord {
    /// Its seed.
    pub seed: u64,
    /// The contour's amplitude, mm.
    pub amplitude_mm: f32,
    /// Per landmark its offset from the landmark vertex in the face's frame, in the meshes' unit.
    pub offsets: Vec<[f64; 3]>,
}

/// How a tracker fails on a frame (`training::tracker` draws them).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Failure {
    /// The face read smaller than it is, about the landmarks' centre: the head seems further
    /// away.
    Smaller {
        /// The scale, below 1.
        factor: f64,
    },
    /// The face found elsewhere in the image: every landmark moved by this many pixels.
    Elsewhere {
        /// The move, pixels.
        shift: [f64; 2],
    },
    /// The points scattered about their places (motion blur): noise of this many pixels.
    Scattered {
        /// The noise's standard deviation, pixels.
        pixels: f64,
    },
    /// No face found (OpenFace's `success` 0); the points are left as they were.
    Lost,
}

/// One failure: what, and the frames it lasts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FailureRun {
    /// The first frame.
    pub first: usize,
    /// How many frames.
    pub frames: usize,
    /// What the tracker does on them.
    pub failure: Failure,
}

impl FailureRun {
    /// Whether `frame` is one of its frames.
    pub fn covers(&self, frame: usize) -> bool {
        (self.first..self.first + self.frames).contains(&frame)
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PerformanceError {
    /// `performance.json` cannot be read, is not a performance manifest, or of another version.
    #[error(transparent)]
    Manifest(#[from] DataSetError),
    /// A per-frame list of the manifest with another length than its frame count.
    #[error("{}: {list} has {len} entries for {frames} frames", path.display())]
    ListLength {
        /// The manifest.
        path: PathBuf,
        /// The list: `files`, `parameters` or `landmarks.pixels`.
        list: &'static str,
        /// Its length.
        len: usize,
        /// The manifest's frame count.
        frames: usize,
    },
    /// `kit_vertices` with another length than the vertex count.
    #[error("{}: kit_vertices has {len} entries for {vertices} vertices", path.display())]
    KitVertices {
        /// The manifest.
        path: PathBuf,
        /// Its length.
        len: usize,
        /// The manifest's vertex count.
        vertices: usize,
    },
    /// A frame the manifest lists that is not there.
    #[error("{}: frame {frame} is missing (listed in {})", path.display(), manifest.display())]
    MissingFrame {
        /// The frame's mesh file.
        path: PathBuf,
        /// The frame.
        frame: usize,
        /// The manifest listing it.
        manifest: PathBuf,
    },
    /// A manifest whose `units` names no length unit.
    #[error("{}: the performance's unit", path.display())]
    Unit {
        /// The manifest.
        path: PathBuf,
        /// The unit it names.
        #[source]
        source: UnknownUnit,
    },
    /// A frame's mesh that cannot be read (the mesh error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A frame's mesh with another vertex count than the performance.
    #[error("{}: {found} vertices, the performance has {expected}", path.display())]
    VertexCount {
        /// The frame's mesh file.
        path: PathBuf,
        /// Its vertex count.
        found: usize,
        /// The manifest's.
        expected: usize,
    },
}

/// A performance read back: the manifest and every frame's positions.
#[derive(Clone, Debug)]
pub struct Performance {
    /// The folder it was read from.
    pub dir: PathBuf,
    /// `performance.json`.
    pub manifest: Manifest,
    /// The length unit of the meshes and the camera, resolved from the manifest's `units`.
    pub unit: Unit,
    /// Per frame, the mesh positions `[V]`.
    pub frames: Vec<Vec<[f32; 3]>>,
    /// The first frame's polygons (every frame shares them).
    pub polygons: Vec<Vec<u32>>,
}

impl Performance {
    /// Reads a performance folder, checking the manifest against itself and every frame's mesh
    /// (present, finite, with the manifest's vertex count); every error names the file.
    pub fn read(dir: &Path) -> Result<Self, PerformanceError> {
        let (manifest, path): (Manifest, _) =
            dataset::read_manifest(dir, MANIFEST, "a performance manifest")?;
        dataset::check_version(
            &path,
            (&manifest.format, manifest.version),
            (FORMAT, VERSION),
        )?;
        let m = &manifest;
        let lists = [
            ("files", m.files.len()),
            ("parameters", m.parameters.len()),
            ("landmarks.pixels", m.landmarks.pixels.len()),
        ];
        for (list, len) in lists {
            if len != m.frames {
                return Err(PerformanceError::ListLength {
                    path,
                    list,
                    len,
                    frames: m.frames,
                });
            }
        }
        let unit = m.units.parse().map_err(|source| PerformanceError::Unit {
            path: path.clone(),
            source,
        })?;
        if m.kit_vertices.len() != m.vertices {
            return Err(PerformanceError::KitVertices {
                path,
                len: m.kit_vertices.len(),
                vertices: m.vertices,
            });
        }
        let mut frames = Vec::with_capacity(m.frames);
        let mut polygons = Vec::new();
        for (f, file) in m.files.iter().enumerate() {
            let mesh_path = dir.join(file);
            if !mesh_path.is_file() {
                return Err(PerformanceError::MissingFrame {
                    path: mesh_path,
                    frame: f,
                    manifest: path,
                });
            }
            let mesh = Mesh::read(&mesh_path)?;
            if mesh.positions.len() != m.vertices {
                return Err(PerformanceError::VertexCount {
                    path: mesh_path,
                    found: mesh.positions.len(),
                    expected: m.vertices,
                });
            }
            if f == 0 {
                polygons = mesh.polygons;
            }
            frames.push(mesh.positions);
        }
        Ok(Self {
            dir: dir.to_owned(),
            manifest,
            unit,
            frames,
            polygons,
        })
    }

    /// The mesh file of frame `f`.
    pub fn frame_path(&self, f: usize) -> PathBuf {
        self.dir.join(&self.manifest.files[f])
    }
}
