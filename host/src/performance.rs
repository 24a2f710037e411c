//! Synthetic facial performances on an ICT-FaceKit actor (`sinew data performance`), which the
//! fit, the driver and `sinew view` are measured on, and an identity's neutral on a baked actor's
//! vertices (`sinew data neutral`).
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
//! The folder it writes, and its reader, are [`crate::io::performance`]'s.

use std::collections::HashMap;
use std::path::Path;

use sinew_core::linalg::Vec3;
use sinew_core::skinning::{BoneTransform, lbs};

use crate::io::ict::{FACE_REGION, IctFaceKit};
use crate::io::mesh::Mesh;
use crate::io::performance::ConventionRecord;
use crate::io::performance::{
    Camera, FORMAT, FrameParameters, Landmarks, MANIFEST, Manifest, OPENFACE_CSV, VERSION,
};
use crate::training::random::Stream;
use crate::training::tracker::{Convention, Failures};

mod error;
mod trajectories;
pub use error::{GenerateError, InvalidPerformanceConfig};
use trajectories::{Ease, Trajectories};

/// How long a performance takes to ease in from its frames at rest, seconds.
pub const EASE_SECONDS: f64 = 0.5;

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
    /// Frames at rest looking at the camera before the performance eases in (over half a
    /// second): what a person holds while a live tool calibrates.
    pub rest_frames: usize,
    /// A tracker's convention on the 2D track: its seed (`None`: the landmark vertices).
    pub convention: Option<u64>,
    /// The convention's contour amplitude, mm.
    pub convention_mm: f32,
    /// Tracker failures on the 2D track (after the frames at rest).
    pub failures: usize,
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
            rest_frames: 0,
            convention: None,
            convention_mm: 4.0,
            failures: 0,
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
        if !(self.convention_mm.is_finite() && self.convention_mm >= 0.0) {
            return Err(Invalid::ConventionMm(self.convention_mm));
        }
        if self.rest_frames >= self.frames {
            return Err(Invalid::RestFrames {
                rest: self.rest_frames,
                frames: self.frames,
            });
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

/// The tracker's convention and failures: streams of their own, so that the meshes and the
/// landmark noise of a seed stay as they were without them.
fn tracker_stream(seed: u64, which: u128) -> Stream {
    Stream::new(
        seed,
        0x7a_c4_e2_00,
        0x00a0_2bdb_0000_0000_0000_0000_0000_0010 + which,
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
    let actor = crate::io::container::actor(actor_path, &bytes)?;
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
    let convention = config.convention.map(|seed| {
        let amplitude = f64::from(config.convention_mm) / face.units.mm();
        let c = Convention::draw(&mut tracker_stream(seed, 0), amplitude);
        ConventionRecord {
            seed,
            amplitude_mm: config.convention_mm,
            offsets: c.offsets,
        }
    });
    let failures = Failures::draw(
        &mut tracker_stream(config.seed, 1),
        config.failures,
        config.rest_frames,
        config.frames,
        f64::from(config.fps),
    );
    if failures.len() < config.failures {
        return Err(InvalidPerformanceConfig::Failures {
            failures: config.failures,
            frames: config.frames,
        }
        .into());
    }
    let mut scatter_rng = tracker_stream(config.seed, 2);
    let ramp = (f64::from(config.fps) * EASE_SECONDS).round() as usize;
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
        rest_frames: config.rest_frames,
        convention: convention.clone(),
        failures: failures.clone(),
    };
    crate::io::atomic::create_folder(out, "output folder")?;
    for f in 0..config.frames {
        let params = trajectories.at(
            f as f64 / f64::from(config.fps),
            topology.jaw.is_some(),
            Ease::at(f, config.rest_frames, ramp),
        );
        let turn = sinew_core::rotation::rigid_from_9d(&params.head).rot;
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
                let mut p = positions[v as usize];
                if let Some(c) = &convention {
                    let o = c.offsets[l].map(|x| x as f32);
                    p = (Vec3::from_array(p) + turn.mul_vec(Vec3::from_array(o))).to_array();
                }
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
        let mut pixels = pixels;
        for failure in failures.iter().filter(|x| x.covers(f)) {
            Failures::apply(failure, &mut pixels, &mut scatter_rng);
        }
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
    let track: Vec<_> = (manifest.landmarks.pixels.iter().enumerate())
        .map(|(f, p)| crate::io::openface::OpenFaceFrame {
            pixels: p.iter().flatten().copied().collect(),
            world: Vec::new(),
            confidence: 1.0,
            success: !manifest.tracker_lost(f),
            timestamp: None,
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

#[cfg(test)]
pub(crate) mod tests;
