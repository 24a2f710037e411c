//! Synthetic facial performances on an ICT-FaceKit actor, for fitting (`sinew data performance`).
//!
//! The data are synthetic: per frame, smooth seeded trajectories of all 53 of the kit's
//! expression weights, a jaw transform about the actor's jaw pivot and a head transform pose the
//! kit's own neutral and deltas in AIM eq. 17's form,
//! `x = T_g(LBS(n, T_b, k) + Σ_i w_i d_i)` (n: the kit's generic neutral; d_i: its expression
//! deltas; k: the actor's baked jaw skinning weight), with optional Gaussian noise. The meshes are
//! in the actor's topology (`--actor`: its template, whose every vertex must be a vertex of the
//! kit's face region, as for the decimated golden actor; otherwise the full face region), and 68
//! iBUG landmarks are projected through a pinhole camera.
//!
//! # Folder
//! - `frame_00000.obj` … one mesh per frame (cm);
//! - `openface.csv`: the 2D landmark track in OpenFace 2.0's CSV layout (what a webcam tracker
//!   gives `sinew drive`);
//! - `performance.json` ([`Manifest`]), written last: seed, frames, the ground-truth parameters
//!   per frame, the kit vertex of each mesh vertex, the camera and the 2D landmark tracks.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;
use sinew_core::linalg::{Mat3, Vec3};
use sinew_core::rotation::to_6d;
use sinew_core::skinning::{BoneTransform, lbs};

use crate::io::dataset::{self, DataSetError};
use crate::io::ict::{FACE_REGION, IctFaceKit};
use crate::io::mesh::{Mesh, MeshError};
use crate::training::random::Stream;

mod error;
pub use error::{GenerateError, InvalidPerformanceConfig};

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
    /// Length unit of the meshes and the camera.
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
}

/// What `sinew data performance` varies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerformanceConfig {
    /// Seed of the trajectories and the noise.
    pub seed: u64,
    /// Number of frames.
    pub frames: usize,
    /// Gaussian noise on every coordinate, in mm (0: none).
    pub noise_mm: f32,
    /// Gaussian noise on every landmark pixel coordinate, in pixels (0: none).
    pub landmark_noise_px: f32,
    /// Frames per second.
    pub fps: f32,
    /// Image size in pixels (the camera is placed in front of the face, looking at it).
    pub image: [u32; 2],
    /// Focal length in pixels.
    pub focal: f32,
    /// Distance from the face's front to the camera, in cm.
    pub distance: f32,
}

impl Default for PerformanceConfig {
    fn default() -> Self {
        Self {
            seed: 1,
            frames: 60,
            noise_mm: 0.0,
            landmark_noise_px: 0.0,
            fps: 30.0,
            image: [640, 480],
            focal: 1200.0,
            distance: 60.0,
        }
    }
}

impl PerformanceConfig {
    /// Rejects settings that cannot make a performance.
    pub fn validate(&self) -> Result<(), InvalidPerformanceConfig> {
        use InvalidPerformanceConfig as Invalid;
        if self.frames == 0 {
            return Err(Invalid::NoFrames);
        }
        if !(self.noise_mm.is_finite() && self.noise_mm >= 0.0) {
            return Err(Invalid::NoiseMm(self.noise_mm));
        }
        if !(self.landmark_noise_px.is_finite() && self.landmark_noise_px >= 0.0) {
            return Err(Invalid::LandmarkNoisePx(self.landmark_noise_px));
        }
        if self.fps.is_nan() || self.fps <= 0.0 {
            return Err(Invalid::Fps);
        }
        if !(self.focal > 0.0 && self.distance > 0.0 && self.image.iter().all(|&s| s > 0)) {
            return Err(Invalid::Camera);
        }
        Ok(())
    }
}

/// The stream of the trajectories and the mesh noise.
fn trajectory_stream(seed: u64) -> Stream {
    Stream::new(
        seed,
        0xfa_ce_5e_90,
        0x00a0_2bdb_0000_0000_0000_0000_0000_0001,
    )
}

/// The landmark pixels' noise: a stream of its own, so that adding it left the meshes of a seed
/// as they were.
fn landmark_stream(seed: u64) -> Stream {
    Stream::new(
        seed,
        0x1a_4d_a2_c5,
        0x00a0_2bdb_0000_0000_0000_0000_0000_0003,
    )
}

/// A smooth signal in [−1, 1]: the mean of three sinusoids of 0.1–0.8 Hz with random phases.
struct Wave([(f64, f64); 3]);

impl Wave {
    fn new(rng: &mut Stream) -> Self {
        Self([(); 3].map(|()| {
            (
                rng.uniform(0.1, 0.8),
                rng.uniform(0.0, std::f64::consts::TAU),
            )
        }))
    }

    fn at(&self, seconds: f64) -> f64 {
        self.0
            .iter()
            .map(|(f, phase)| (std::f64::consts::TAU * f * seconds + phase).sin())
            .sum::<f64>()
            / 3.0
    }
}

/// An expression weight's trajectory: `clamp(offset + amplitude · wave, 0, 1)`; the offset is
/// mostly negative, so each shape is active part of the time, as in a real performance.
struct Weight {
    wave: Wave,
    offset: f64,
    amplitude: f64,
}

/// Rotation `Rz(γ) Ry(β) Rx(α)`.
fn euler(a: f64, b: f64, g: f64) -> Mat3 {
    let (sa, ca) = a.sin_cos();
    let (sb, cb) = b.sin_cos();
    let (sg, cg) = g.sin_cos();
    let m = [
        [cg * cb, cg * sb * sa - sg * ca, cg * sb * ca + sg * sa],
        [sg * cb, sg * sb * sa + cg * ca, sg * sb * ca - cg * sa],
        [-sb, cb * sa, cb * ca],
    ];
    let col = |j: usize| Vec3::new(m[0][j] as f32, m[1][j] as f32, m[2][j] as f32);
    Mat3 {
        cols: [col(0), col(1), col(2)],
    }
}

fn nine(rot: &Mat3, t: [f64; 3]) -> [f32; 9] {
    let r = to_6d(rot);
    [
        r[0],
        r[1],
        r[2],
        r[3],
        r[4],
        r[5],
        t[0] as f32,
        t[1] as f32,
        t[2] as f32,
    ]
}

/// The trajectories of every parameter, seeded.
struct Trajectories {
    weights: Vec<Weight>,
    /// Jaw opening, yaw, and translation x, y, z.
    jaw: [Wave; 5],
    /// Head rotations about x, y, z and translation x, y, z.
    head: [Wave; 6],
}

impl Trajectories {
    fn new(rng: &mut Stream, shapes: usize) -> Self {
        let weights = (0..shapes)
            .map(|_| Weight {
                wave: Wave::new(rng),
                offset: rng.uniform(-0.6, 0.2),
                amplitude: rng.uniform(0.4, 1.0),
            })
            .collect();
        Self {
            weights,
            jaw: [(); 5].map(|()| Wave::new(rng)),
            head: [(); 6].map(|()| Wave::new(rng)),
        }
    }

    /// The parameters at time `t` seconds; `jaw` false keeps the jaw transform the identity.
    fn at(&self, t: f64, jaw: bool) -> FrameParameters {
        let weights = self
            .weights
            .iter()
            .map(|w| (w.offset + w.amplitude * w.wave.at(t)).clamp(0.0, 1.0) as f32)
            .collect();
        let j = |i: usize| self.jaw[i].at(t);
        // Opening 0–0.12 rad about x (positive opens: the chin, in front of the pivot, goes
        // down), ±0.03 rad of yaw, ±0.5 mm of translation.
        let jaw = if jaw {
            nine(
                &euler(0.06 * (1.0 + j(0)), 0.03 * j(1), 0.0),
                [0.05 * j(2), 0.05 * j(3), 0.05 * j(4)],
            )
        } else {
            nine(&Mat3::IDENTITY, [0.0; 3])
        };
        let h = |i: usize| self.head[i].at(t);
        // ±0.08 rad about each axis, ±8 mm of translation.
        let head = nine(
            &euler(0.08 * h(0), 0.08 * h(1), 0.08 * h(2)),
            [0.8 * h(3), 0.8 * h(4), 0.8 * h(5)],
        );
        FrameParameters { weights, jaw, head }
    }
}

/// The mesh vertices of a performance in kit terms: which kit vertex each is, the triangles, and
/// the jaw (weight per vertex, pivot) when an actor gave them.
struct Topology {
    kit_vertices: Vec<u32>,
    polygons: Vec<Vec<u32>>,
    jaw: Option<(Vec<f32>, [f32; 3])>,
}

/// The actor's topology in terms of the kit's face region: each template point must be, bit for
/// bit, a vertex of the face region (decimation keeps vertices; it does not move them).
fn actor_topology(actor_path: &Path, face: &Mesh) -> Result<Topology, GenerateError> {
    let bytes = crate::io::container::read(actor_path)?;
    let actor = AimActor::from_bytes(&bytes).map_err(|source| GenerateError::NotAnActor {
        path: actor_path.to_owned(),
        source,
    })?;
    let by_bits: HashMap<[u32; 3], u32> = face
        .positions
        .iter()
        .enumerate()
        .map(|(i, p)| (p.map(f32::to_bits), i as u32))
        .collect();
    let tpl = actor.template();
    let kit_vertices = (0..actor.vertex_count())
        .map(|i| {
            let p = [tpl.at(3 * i), tpl.at(3 * i + 1), tpl.at(3 * i + 2)];
            by_bits
                .get(&p.map(f32::to_bits))
                .copied()
                .ok_or_else(|| GenerateError::OffTheKit {
                    path: actor_path.to_owned(),
                    vertex: i,
                    position: p,
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let tri = actor.triangles().indices();
    let polygons = (0..tri.len() / 3)
        .map(|t| vec![tri.at(3 * t), tri.at(3 * t + 1), tri.at(3 * t + 2)])
        .collect();
    let k = actor.skinning_weights().iter().collect();
    Ok(Topology {
        kit_vertices,
        polygons,
        jaw: Some((k, actor.jaw_pivot().to_array())),
    })
}

/// Generates a performance into `out` (see the module documentation) and returns its manifest.
pub fn generate(
    data: &Path,
    actor: Option<&Path>,
    config: &PerformanceConfig,
    out: &Path,
) -> Result<Manifest, GenerateError> {
    config.validate()?;
    let kit = IctFaceKit::open(data)?;
    let names = kit.expression_names();
    let refs: Vec<&str> = names.iter().map(String::as_str).collect();
    let face = kit.actor(&[], &refs, FACE_REGION)?;
    let topology = match actor {
        Some(path) => actor_topology(path, &face.template)?,
        None => Topology {
            kit_vertices: (0..face.template.positions.len() as u32).collect(),
            polygons: face.template.polygons.clone(),
            jaw: None,
        },
    };
    let pick = |shape: &[[f32; 3]]| -> Vec<[f32; 3]> {
        topology
            .kit_vertices
            .iter()
            .map(|&v| shape[v as usize])
            .collect()
    };
    let neutral = pick(&face.shapes[0]);
    let deltas: Vec<Vec<[f32; 3]>> = face.shapes[1..]
        .iter()
        .map(|s| {
            pick(s)
                .iter()
                .zip(&neutral)
                .map(|(p, n)| [p[0] - n[0], p[1] - n[1], p[2] - n[2]])
                .collect()
        })
        .collect();
    let landmark_vertices = landmark_vertices(&face.landmarks, &face.template, &topology)?;
    let camera = camera_for(&neutral, &landmark_vertices, config);

    let mut rng = trajectory_stream(config.seed);
    let trajectories = Trajectories::new(&mut rng, names.len());
    let noise_cm = f64::from(config.noise_mm) / face.units.mm();
    let mut pixel_rng = landmark_stream(config.seed);
    let mut manifest = Manifest {
        format: FORMAT.into(),
        version: VERSION,
        synthetic: true,
        source: format!(
            "synthetic performance (seeded trajectories of the kit's expression weights, jaw and \
             head) on {}",
            face.source
        ),
        seed: config.seed,
        frames: config.frames,
        fps: config.fps,
        noise_mm: config.noise_mm,
        landmark_noise_px: config.landmark_noise_px,
        units: face.units.name().into(),
        vertices: neutral.len(),
        data: data.to_owned(),
        actor: actor.map(Path::to_owned),
        kit_vertices: topology.kit_vertices.clone(),
        jaw_pivot: topology.jaw.as_ref().map(|(_, p)| *p),
        expressions: names.clone(),
        files: Vec::new(),
        parameters: Vec::new(),
        camera,
        landmarks: Landmarks {
            vertices: landmark_vertices.clone(),
            pixels: Vec::new(),
        },
    };
    crate::io::atomic::create_folder(out, "output folder")?;
    for f in 0..config.frames {
        let params = trajectories.at(f as f64 / f64::from(config.fps), topology.jaw.is_some());
        let mut positions = pose(&neutral, &deltas, topology.jaw.as_ref(), &params);
        if noise_cm > 0.0 {
            for p in &mut positions {
                for c in p.iter_mut() {
                    *c += (noise_cm * rng.normal()) as f32;
                }
            }
        }
        let pixels = landmark_vertices
            .iter()
            .enumerate()
            .map(|(l, &v)| {
                let p = positions[v as usize];
                let detected = |[u, w]: [f32; 2]| {
                    let sd = f64::from(config.landmark_noise_px);
                    if sd > 0.0 {
                        let du = sd * pixel_rng.normal();
                        let dw = sd * pixel_rng.normal();
                        [u + du as f32, w + dw as f32]
                    } else {
                        [u, w]
                    }
                };
                camera
                    .project(p)
                    .map(detected)
                    .filter(|uv| camera.inside(*uv))
                    .ok_or_else(|| GenerateError::LandmarkOutsideImage {
                        path: out.to_owned(),
                        frame: f,
                        landmark: l,
                        vertex: v,
                        position: p,
                        width: camera.width,
                        height: camera.height,
                        camera: camera.position,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let file = format!("frame_{f:05}.obj");
        Mesh::new(positions, topology.polygons.clone()).write(&out.join(&file))?;
        manifest.files.push(file);
        manifest.parameters.push(params);
        manifest.landmarks.pixels.push(pixels);
    }
    let json = serde_json::to_vec_pretty(&manifest).map_err(|source| GenerateError::Encode {
        path: out.join(MANIFEST),
        source,
    })?;
    let track: Vec<_> = (manifest.landmarks.pixels.iter())
        .map(|p| crate::io::openface::OpenFaceFrame {
            pixels: p.iter().flatten().copied().collect(),
            world: Vec::new(),
            confidence: 1.0,
            success: true,
        })
        .collect();
    let csv = crate::io::openface::write_csv(&track, config.fps);
    crate::io::atomic::write(&out.join(OPENFACE_CSV), csv.as_bytes())?;
    crate::io::atomic::write(&out.join(MANIFEST), &json)?;
    Ok(manifest)
}

/// `sinew data neutral`: the kit's face region on an identity (`identity`: weights of the kit's
/// identity modes; empty: the generic neutral), on the vertices and triangles of `like` when
/// given (a baked actor made on the generic neutral, such as the decimated golden), written to
/// `out` as OBJ. It is the template on which an actor of that identity is baked in vertex
/// correspondence with `like` (`sinew bake --template`), as retargeting needs.
pub fn write_neutral(
    data: &Path,
    identity: &[f32],
    like: Option<&Path>,
    out: &Path,
) -> Result<Mesh, GenerateError> {
    let kit = IctFaceKit::open(data)?;
    let face = kit.actor(identity, &[], FACE_REGION)?;
    let mesh = match like {
        Some(path) => {
            let generic = kit.actor(&[], &[], FACE_REGION)?;
            let t = actor_topology(path, &generic.template)?;
            let positions = t
                .kit_vertices
                .iter()
                .map(|&v| face.template.positions[v as usize])
                .collect();
            Mesh::new(positions, t.polygons)
        }
        None => face.template,
    };
    mesh.write(out)?;
    Ok(mesh)
}

/// A frame's mesh: `T_g(LBS(n, T_b, k) + Σ_i w_i d_i)` (AIM eq. 17's form over the kit's
/// deltas).
fn pose(
    neutral: &[[f32; 3]],
    deltas: &[Vec<[f32; 3]>],
    jaw: Option<&(Vec<f32>, [f32; 3])>,
    params: &FrameParameters,
) -> Vec<[f32; 3]> {
    let head = sinew_core::rotation::rigid_from_9d(&params.head);
    let bone = jaw.map(|(_, pivot)| BoneTransform::from_9d(&params.jaw, Vec3::from_array(*pivot)));
    neutral
        .iter()
        .enumerate()
        .map(|(v, &n)| {
            let n = Vec3::from_array(n);
            let mut x = match (&bone, jaw) {
                (Some(bone), Some((k, _))) => lbs(n, bone, k[v]),
                _ => n,
            };
            for (d, &w) in deltas.iter().zip(&params.weights) {
                x = x + Vec3::from_array(d[v]) * w;
            }
            head.apply(x).to_array()
        })
        .collect()
}

/// The mesh vertex of each kit landmark: the same kit vertex, else the nearest mesh vertex on
/// the neutral (ties to the lower index).
fn landmark_vertices(
    landmarks: &[Option<u32>],
    face: &Mesh,
    topology: &Topology,
) -> Result<Vec<u32>, GenerateError> {
    let index: HashMap<u32, u32> = topology
        .kit_vertices
        .iter()
        .enumerate()
        .map(|(i, &v)| (v, i as u32))
        .collect();
    landmarks
        .iter()
        .enumerate()
        .map(|(l, v)| {
            let v = v.ok_or(GenerateError::LandmarkOutsideRegion { landmark: l })?;
            if let Some(&i) = index.get(&v) {
                return Ok(i);
            }
            let p = face.positions[v as usize];
            let d2 = |q: [f32; 3]| (0..3).map(|c| (q[c] - p[c]).powi(2)).sum::<f32>();
            let (best, _) = topology.kit_vertices.iter().enumerate().fold(
                (0, f32::INFINITY),
                |best, (i, &k)| {
                    let d = d2(face.positions[k as usize]);
                    if d < best.1 { (i as u32, d) } else { best }
                },
            );
            Ok(best)
        })
        .collect()
}

/// A camera `config.distance` in front of the neutral's frontmost point, centred on its
/// landmarks.
fn camera_for(neutral: &[[f32; 3]], landmarks: &[u32], config: &PerformanceConfig) -> Camera {
    let n = landmarks.len().max(1) as f32;
    let mean = |c: usize| {
        landmarks
            .iter()
            .map(|&v| neutral[v as usize][c])
            .sum::<f32>()
            / n
    };
    let front = neutral.iter().map(|p| p[2]).fold(f32::MIN, f32::max);
    Camera {
        width: config.image[0],
        height: config.image[1],
        fx: config.focal,
        fy: config.focal,
        cx: config.image[0] as f32 / 2.0,
        cy: config.image[1] as f32 / 2.0,
        position: [mean(0), mean(1), front + config.distance],
    }
}

/// A performance folder that could not be read, always naming the file.
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
            frames,
            polygons,
        })
    }

    /// The mesh file of frame `f`.
    pub fn frame_path(&self, f: usize) -> PathBuf {
        self.dir.join(&self.manifest.files[f])
    }
}

#[cfg(test)]
pub(crate) mod tests;
