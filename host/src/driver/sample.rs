//! What a driver learns from: performances of the actor itself, drawn on the fly. Each sample is
//! a random pose of the actor (coefficients, the jaw its training shapes move, a head within a
//! webcam's reach), its 68 landmarks through the core's skinning, seen by a camera of random
//! focal length with a tracker's noise and dropout, its landmarks off the vertices by a
//! tracker's convention drawn for the sample (`training::tracker`), and the pose as the target.

use sinew_core::aim::AimActor;
use sinew_core::driver::{LANDMARKS, Space, finish_pose};
use sinew_core::linalg::{Mat3, Vec3};
use sinew_core::rotation::to_6d;
use sinew_core::skinning::skin_vertex;
use sinew_core::tensor::F32s;

use super::DriverConfig;
use crate::training::random::Stream;
use crate::training::tracker::Convention;

/// The identity transform's 9 values.
const IDENTITY_9: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];

/// The actor as samples need it: its landmark vertices' rest positions, skinning weights and
/// correctives, its training jaws, and the canonical camera.
#[derive(Clone, Debug)]
pub struct Sampler {
    space: Space,
    shapes: usize,
    rest: Vec<Vec3>,
    k: Vec<f32>,
    /// Per landmark, its correctives' little-endian bytes (`[M, 3]`), as the core reads them.
    correctives: Vec<Vec<u8>>,
    pivot: Vec3,
    jaws: Vec<[f32; 9]>,
    /// The canonical camera's centre (the actor's unit): in front of the template's frontmost
    /// point by [`DriverConfig::distance`], centred on its landmarks, looking along −z.
    pub camera: [f32; 3],
    config: DriverConfig,
}

/// One sample: the landmarks as a tracker gives them, their features as the driver's network
/// reads them, and the pose that made them.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// `[68 × dims]`.
    pub input: Vec<f32>,
    /// `[dims' features]`: `sinew_core::driver::features` of `input`.
    pub features: Vec<f32>,
    /// `[18 + M]`: head, jaw, coefficients.
    pub pose: Vec<f32>,
}

impl Sampler {
    /// The sampler of `actor` with landmark vertices `vertices`.
    pub fn new(actor: &AimActor<'_>, vertices: &[u32], config: &DriverConfig) -> Self {
        let m = actor.shape_count();
        let (s0, e) = (actor.rest(), actor.correctives());
        let at = |t: F32s<'_>, v: usize| Vec3::new(t.at(3 * v), t.at(3 * v + 1), t.at(3 * v + 2));
        let rest = vertices.iter().map(|&v| at(s0, v as usize)).collect();
        let k = vertices
            .iter()
            .map(|&v| actor.skinning_weights().at(v as usize))
            .collect();
        let correctives = vertices
            .iter()
            .map(|&v| e.slice(v as usize * 3 * m, 3 * m).as_bytes().to_vec())
            .collect();
        let jaws = actor
            .file()
            .f32_tensor("train.jaw", &[m as u32, 9])
            .map(|t| {
                (0..m)
                    .map(|i| std::array::from_fn(|c| t.at(9 * i + c)))
                    .collect()
            })
            .unwrap_or_default();
        let tpl = actor.template();
        let n = vertices.len().max(1) as f32;
        let mean = |c: usize| {
            vertices
                .iter()
                .map(|&v| tpl.at(3 * v as usize + c))
                .sum::<f32>()
                / n
        };
        let front = tpl.iter().skip(2).step_by(3).fold(f32::MIN, f32::max);
        Self {
            space: config.input,
            shapes: m,
            rest,
            k,
            correctives,
            pivot: actor.jaw_pivot(),
            jaws,
            camera: [mean(0), mean(1), front + config.distance],
            config: config.clone(),
        }
    }

    /// The sample of `rng`'s next draws: the first whose landmarks the core accepts (a face
    /// within the drawn range always is; a refused draw is drawn again, from the same stream).
    pub fn sample(&self, rng: &mut Stream) -> Sample {
        loop {
            let (input, pose) = self.draw(rng);
            let mut features = vec![0.0; self.space.features()];
            if sinew_core::driver::features(self.space, &input, &mut features).is_ok() {
                return Sample {
                    input,
                    features,
                    pose,
                };
            }
        }
    }

    /// One draw: the landmarks and the pose.
    fn draw(&self, rng: &mut Stream) -> (Vec<f32>, Vec<f32>) {
        let c = &self.config;
        let m = self.shapes;
        let weights: Vec<f32> = (0..m)
            .map(|_| {
                if rng.unit() < c.active {
                    rng.uniform_f32(0.0, 1.0)
                } else {
                    0.0
                }
            })
            .collect();
        // The jaw the actor's training shapes move, in from the identity by their weights.
        let mut jaw = IDENTITY_9;
        for (w, j) in weights.iter().zip(&self.jaws) {
            for ((o, x), i) in jaw.iter_mut().zip(j).zip(IDENTITY_9) {
                *o += w * (x - i);
            }
        }
        // On top, the jaw's own motion as `sinew data performance` draws it: an opening about
        // x, a little yaw and translation about the pivot.
        let own = euler(
            rng.uniform(0.0, c.jaw_opening),
            rng.uniform(-c.jaw_yaw, c.jaw_yaw),
            0.0,
        );
        let tied = sinew_core::rotation::from_6d(&std::array::from_fn(|i| jaw[i]));
        let rot = to_6d(&own.mul_mat(&tied));
        jaw[..6].copy_from_slice(&rot);
        for t in &mut jaw[6..] {
            *t += rng.uniform(-c.jaw_translation, c.jaw_translation) as f32;
        }
        let mut pose = Vec::with_capacity(18 + m);
        let r = c.head_rotation;
        let head_rot = euler(
            rng.uniform(-r[0], r[0]),
            rng.uniform(-r[1], r[1]),
            rng.uniform(-r[2], r[2]),
        );
        let t = c.head_translation;
        let head_t = [
            rng.uniform(-t[0], t[0]),
            rng.uniform(-t[1], t[1]),
            rng.uniform(t[2], t[3]),
        ];
        pose.extend(to_6d(&head_rot));
        pose.extend(head_t.map(|x| x as f32));
        pose.extend(jaw);
        pose.extend(&weights);
        finish_pose(&mut pose);
        let mut landmarks = self.landmarks(&pose);
        // A tracker's lost points fall back on its shape prior: the face at rest, same head.
        let mut rest_pose = pose.clone();
        rest_pose[9..18].copy_from_slice(&IDENTITY_9);
        rest_pose[18..].iter_mut().for_each(|w| *w = 0.0);
        let mut prior = self.landmarks(&rest_pose);
        // A tracker's convention: its points off the landmark vertices in the face's frame,
        // turned with the head (its prior follows it too).
        if c.convention_amplitude > 0.0 {
            let convention = Convention::draw(rng, c.convention_amplitude);
            let turn = sinew_core::rotation::from_6d(&std::array::from_fn(|i| pose[i]));
            for (l, o) in convention.offsets.iter().enumerate() {
                let o = turn.mul_vec(Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32));
                landmarks[l] = landmarks[l] + o;
                prior[l] = prior[l] + o;
            }
        }
        let dropped = if rng.unit() < c.dropout {
            let len = 3 + rng.below(8);
            let first = rng.below(LANDMARKS);
            (first..first + len).map(|l| l % LANDMARKS).collect()
        } else {
            Vec::new()
        };
        let focal = rng.uniform(c.focal[0], c.focal[1]);
        let noise = rng.uniform(0.0, c.noise);
        let mut input = Vec::with_capacity(LANDMARKS * self.space.dims());
        for (l, (p, q)) in landmarks.iter().zip(&prior).enumerate() {
            let p = if dropped.contains(&l) { q } else { p };
            match self.space {
                Space::Image => {
                    let depth = f64::from(self.camera[2] - p.z).max(1e-3);
                    let x = f64::from(p.x - self.camera[0]) / depth;
                    let y = -f64::from(p.y - self.camera[1]) / depth;
                    // Pixel noise, normalised by this camera's focal length.
                    input.push((x + noise / focal * rng.normal()) as f32);
                    input.push((y + noise / focal * rng.normal()) as f32);
                }
                Space::World => {
                    for v in [p.x, p.y, p.z] {
                        input.push((f64::from(v) + c.noise_3d * rng.normal()) as f32);
                    }
                }
            }
        }
        (input, pose)
    }

    /// The landmarks of the actor in `pose` (`[18 + M]`), through the core's skinning.
    pub fn landmarks(&self, pose: &[f32]) -> Vec<Vec3> {
        let head: [f32; 9] = std::array::from_fn(|i| pose[i]);
        let jaw: [f32; 9] = std::array::from_fn(|i| pose[9 + i]);
        let built = sinew_core::skinning::Pose {
            head: sinew_core::rotation::rigid_from_9d(&head),
            jaw: sinew_core::skinning::BoneTransform::from_9d(&jaw, self.pivot),
        };
        let w = &pose[18..];
        self.rest
            .iter()
            .zip(&self.k)
            .zip(&self.correctives)
            .map(|((&s0, &k), e)| {
                let e = F32s::new(e).unwrap_or(F32s::empty());
                skin_vertex(s0, k, e, w, &built)
            })
            .collect()
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The contour's and the nose-and-eyes' root mean square offset of `a` from `b`.
    fn offsets(a: &[f32], b: &[f32]) -> (f64, f64) {
        let d = |l: usize| {
            (0..3)
                .map(|c| f64::from(a[3 * l + c] - b[3 * l + c]).powi(2))
                .sum::<f64>()
        };
        let rms = |ls: &mut dyn Iterator<Item = usize>| {
            let v: Vec<f64> = ls.map(d).collect();
            (v.iter().sum::<f64>() / v.len() as f64).sqrt()
        };
        (rms(&mut (0..17)), rms(&mut (27..48)))
    }

    #[test]
    fn each_sample_draws_its_own_convention_off_the_landmark_vertices_and_keeps_its_pose() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew");
        let bytes = std::fs::read(&path).unwrap();
        let actor = crate::io::container::actor(&path, &bytes).unwrap();
        let vertices = super::super::landmark_vertices(&path, &actor).unwrap();
        // 3D landmarks without noise or dropout: what moves them is the convention alone.
        let exact = DriverConfig {
            input: Space::World,
            noise_3d: 0.0,
            dropout: 0.0,
            convention_amplitude: 0.0,
            ..DriverConfig::default()
        };
        let with = DriverConfig {
            convention_amplitude: 0.4,
            ..exact.clone()
        };
        let (plain, tracked) = (
            Sampler::new(&actor, &vertices, &exact),
            Sampler::new(&actor, &vertices, &with),
        );
        let (mut r0, mut r1) = (Stream::new(5, 0, 0), Stream::new(5, 0, 0));
        let mut seen: Vec<Vec<f32>> = Vec::new();
        let (mut contour, mut steady) = (0.0, 0.0);
        let n = 20;
        for _ in 0..n {
            let (a, b) = (plain.sample(&mut r0), tracked.sample(&mut r1));
            assert_eq!(
                a.pose, b.pose,
                "the convention moves the landmarks, not the pose"
            );
            let (c, s) = offsets(&b.input, &a.input);
            contour += c / f64::from(n);
            steady += s / f64::from(n);
            let moved: Vec<f32> = b.input.iter().zip(&a.input).map(|(x, y)| x - y).collect();
            assert!(!seen.contains(&moved), "a new convention for each sample");
            seen.push(moved);
            // The streams stay in step only while both draw the same; resynchronise.
            r0 = r1.clone();
        }
        // 0.4 of the actor's unit (cm: 4 mm) on the contour; the nose and eyes a tenth of it.
        assert!((0.2..0.8).contains(&contour), "contour {contour}");
        assert!(
            steady < 0.2 * contour,
            "nose and eyes {steady} against {contour}"
        );
    }
}
