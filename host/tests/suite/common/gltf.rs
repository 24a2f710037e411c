//! A reader of Sinew's `.glb` exports that poses them the way a glTF engine does (glTF 2.0 spec,
//! "Skins" and "Morph Targets": base + Σ w·target, then Σ weight·(joint world · inverse bind)
//! over the joints, with the joints' TRS sampled from the animation), from the file alone.

use gltf_json as json;
use json::validation::Checked::Valid;
use sinew_core::linalg::{Mat3, Vec3};

pub type M4 = [[f64; 4]; 4];

/// The golden ICT actor's bytes.
pub fn golden() -> Vec<u8> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/aim-ict.sinew");
    std::fs::read(p).unwrap()
}

/// A rotation about a unit axis, as the core's matrix.
pub fn axis_angle(axis: [f64; 3], angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    let [x, y, z] = axis;
    let r = [
        [
            c + x * x * (1.0 - c),
            x * y * (1.0 - c) - z * s,
            x * z * (1.0 - c) + y * s,
        ],
        [
            y * x * (1.0 - c) + z * s,
            c + y * y * (1.0 - c),
            y * z * (1.0 - c) - x * s,
        ],
        [
            z * x * (1.0 - c) - y * s,
            z * y * (1.0 - c) + x * s,
            c + z * z * (1.0 - c),
        ],
    ];
    let col = |j: usize| Vec3::new(r[0][j] as f32, r[1][j] as f32, r[2][j] as f32);
    Mat3::from_cols(col(0), col(1), col(2))
}

pub struct Gltf {
    pub root: json::Root,
    pub bin: Vec<u8>,
}

impl Gltf {
    pub fn parse(file: &[u8]) -> Self {
        let (text, bin) = sinew_host::io::glb::read(file).unwrap();
        Self {
            root: serde_json::from_slice(text).unwrap(),
            bin: bin.to_vec(),
        }
    }

    /// The face mesh's primitive.
    pub fn face(&self) -> &json::mesh::Primitive {
        &self.root.meshes[0].primitives[0]
    }

    pub fn attribute(&self, s: json::mesh::Semantic) -> Vec<f64> {
        self.accessor(self.face().attributes[&Valid(s)])
    }

    pub fn target_names(&self) -> Vec<String> {
        let extras: serde_json::Value =
            serde_json::from_str(self.root.meshes[0].extras.as_ref().unwrap().get()).unwrap();
        serde_json::from_value(extras["targetNames"].clone()).unwrap()
    }

    pub fn accessor(&self, i: json::Index<json::Accessor>) -> Vec<f64> {
        let a = &self.root.accessors[i.value()];
        let view = &self.root.buffer_views[a.buffer_view.unwrap().value()];
        let start = view.byte_offset.map_or(0, |o| o.0 as usize)
            + a.byte_offset.map_or(0, |o| o.0 as usize);
        let Valid(kind) = a.type_ else {
            panic!("accessor type")
        };
        let n = a.count.0 as usize * kind.multiplicity();
        let Valid(json::accessor::GenericComponentType(c)) = a.component_type else {
            panic!("component type")
        };
        let bytes = &self.bin[start..];
        match c {
            json::accessor::ComponentType::F32 => bytes
                .chunks_exact(4)
                .take(n)
                .map(|b| f64::from(f32::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            json::accessor::ComponentType::U8 => bytes[..n].iter().map(|b| f64::from(*b)).collect(),
            json::accessor::ComponentType::U32 => bytes
                .chunks_exact(4)
                .take(n)
                .map(|b| f64::from(u32::from_le_bytes(b.try_into().unwrap())))
                .collect(),
            other => panic!("component type {other:?} not read here"),
        }
    }

    /// `(translation, rotation xyzw)` of a node at time `t`: the animated values where a channel
    /// targets it (linear, slerp for the rotation), else its rest values.
    pub fn trs(&self, node: usize, t: f64) -> ([f64; 3], [f64; 4]) {
        let n = &self.root.nodes[node];
        let mut tr = n.translation.unwrap_or([0.0; 3]).map(f64::from);
        let mut rot = n
            .rotation
            .map_or([0.0, 0.0, 0.0, 1.0], |q| q.0.map(f64::from));
        for anim in &self.root.animations {
            for ch in &anim.channels {
                if ch.target.node.value() != node {
                    continue;
                }
                let s = &anim.samplers[ch.sampler.value()];
                let times = self.accessor(s.input);
                let out = self.accessor(s.output);
                let k = times.iter().rposition(|x| *x <= t).unwrap_or(0);
                let (k1, a) = if k + 1 < times.len() {
                    (k + 1, (t - times[k]) / (times[k + 1] - times[k]))
                } else {
                    (k, 0.0)
                };
                match ch.target.path {
                    Valid(json::animation::Property::Translation) => {
                        tr = std::array::from_fn(|i| {
                            out[3 * k + i] * (1.0 - a) + out[3 * k1 + i] * a
                        })
                    }
                    Valid(json::animation::Property::Rotation) => {
                        let q0: [f64; 4] = std::array::from_fn(|i| out[4 * k + i]);
                        let q1: [f64; 4] = std::array::from_fn(|i| out[4 * k1 + i]);
                        rot = slerp(q0, q1, a);
                    }
                    _ => {}
                }
            }
        }
        (tr, rot)
    }

    pub fn morph_weights(&self, node: usize, t: f64, m: usize) -> Vec<f64> {
        for anim in &self.root.animations {
            for ch in &anim.channels {
                if ch.target.node.value() == node
                    && ch.target.path == Valid(json::animation::Property::MorphTargetWeights)
                {
                    let s = &anim.samplers[ch.sampler.value()];
                    let times = self.accessor(s.input);
                    let out = self.accessor(s.output);
                    let k = times
                        .iter()
                        .position(|x| (*x - t).abs() < 1e-9)
                        .expect("keyframe");
                    return out[m * k..m * (k + 1)].to_vec();
                }
            }
        }
        vec![0.0; m]
    }

    /// A node's world matrix: its parents' times its own TRS.
    pub fn world(&self, node: usize, t: f64) -> M4 {
        let (tr, q) = self.trs(node, t);
        let local = trs_matrix(tr, q);
        let parent = self.root.nodes.iter().position(|p| {
            p.children
                .as_ref()
                .is_some_and(|c| c.iter().any(|c| c.value() == node))
        });
        match parent {
            Some(p) => mul(&self.world(p, t), &local),
            None => local,
        }
    }
}

pub fn slerp(q0: [f64; 4], mut q1: [f64; 4], a: f64) -> [f64; 4] {
    let mut d: f64 = (0..4).map(|i| q0[i] * q1[i]).sum();
    if d < 0.0 {
        q1 = q1.map(|x| -x);
        d = -d;
    }
    if a == 0.0 || d > 1.0 - 1e-12 {
        return std::array::from_fn(|i| q0[i] * (1.0 - a) + q1[i] * a);
    }
    let th = d.acos();
    let (s0, s1) = (((1.0 - a) * th).sin() / th.sin(), (a * th).sin() / th.sin());
    std::array::from_fn(|i| q0[i] * s0 + q1[i] * s1)
}

pub fn trs_matrix(t: [f64; 3], q: [f64; 4]) -> M4 {
    let [x, y, z, w] = q;
    [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - z * w),
            2.0 * (x * z + y * w),
            t[0],
        ],
        [
            2.0 * (x * y + z * w),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - x * w),
            t[1],
        ],
        [
            2.0 * (x * z - y * w),
            2.0 * (y * z + x * w),
            1.0 - 2.0 * (x * x + y * y),
            t[2],
        ],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

pub fn mul(a: &M4, b: &M4) -> M4 {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

pub fn apply(m: &M4, p: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

/// Every frame of the face mesh posed by glTF's rules, in metres, `[frames][V·3]`.
pub fn pose_gltf(g: &Gltf) -> Vec<Vec<f64>> {
    pose_gltf_keeping(g, usize::MAX)
}

/// [`pose_gltf`] with the morph weights of targets `keep..` held at 0, as an engine that drives
/// only the first `keep` targets by name poses it.
pub fn pose_gltf_keeping(g: &Gltf, keep: usize) -> Vec<Vec<f64>> {
    let face = g
        .root
        .nodes
        .iter()
        .position(|n| n.name.as_deref() == Some("face"))
        .unwrap();
    let node = &g.root.nodes[face];
    let mesh = &g.root.meshes[node.mesh.unwrap().value()];
    let skin = &g.root.skins[node.skin.unwrap().value()];
    let prim = &mesh.primitives[0];
    let attr = |s: json::mesh::Semantic| g.accessor(prim.attributes[&Valid(s)]);
    let base = attr(json::mesh::Semantic::Positions);
    let joints = attr(json::mesh::Semantic::Joints(0));
    let weights = attr(json::mesh::Semantic::Weights(0));
    let targets: Vec<Vec<f64>> = prim
        .targets
        .as_ref()
        .unwrap()
        .iter()
        .map(|t| g.accessor(t.positions.unwrap()))
        .collect();
    let ibm = g.accessor(skin.inverse_bind_matrices.unwrap());
    let times = {
        let anim = &g.root.animations[0];
        g.accessor(anim.samplers[0].input)
    };
    times
        .iter()
        .map(|&t| {
            let mut w = g.morph_weights(face, t, targets.len());
            for x in w.iter_mut().skip(keep) {
                *x = 0.0;
            }
            let jm: Vec<M4> = skin
                .joints
                .iter()
                .enumerate()
                .map(|(j, n)| {
                    // Inverse bind matrices are column-major.
                    let b: M4 =
                        std::array::from_fn(|r| std::array::from_fn(|c| ibm[16 * j + 4 * c + r]));
                    mul(&g.world(n.value(), t), &b)
                })
                .collect();
            let mut out = Vec::with_capacity(base.len());
            for v in 0..base.len() / 3 {
                let p: [f64; 3] = std::array::from_fn(|c| {
                    base[3 * v + c]
                        + (0..targets.len())
                            .map(|j| w[j] * targets[j][3 * v + c])
                            .sum::<f64>()
                });
                let mut s = [0.0; 3];
                for i in 0..4 {
                    let q = apply(&jm[joints[4 * v + i] as usize], p);
                    for c in 0..3 {
                        s[c] += weights[4 * v + i] * q[c];
                    }
                }
                out.extend(s);
            }
            out
        })
        .collect()
}
