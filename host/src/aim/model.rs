//! The AIM model in burn: five SIRENs over normalised template points and one jaw transform per
//! training expression, and the training objective (eqs. 11–16).

use burn::module::{Module, Param};
use burn::tensor::{Device, Int, Tensor, TensorData};

use super::config::AimConfig;
use crate::training::nn::Mlp;
pub use crate::training::rotation::{cross, rotate_6d};

/// The five networks B, D, N, K, E and the per-shape jaw transforms T_b,i.
#[derive(Module, Debug)]
pub struct AimNet {
    /// B: bone point, as a residual from c (3 outputs).
    pub b: Mlp,
    /// D: soft-tissue thickness (1 output).
    pub d: Mlp,
    /// N: bone normal before normalisation (3 outputs).
    pub n: Mlp,
    /// K: jaw skinning weight (1 output).
    pub k: Mlp,
    /// E: corrective displacements of the N − 1 expressions (3·(N − 1) outputs).
    pub e: Mlp,
    /// Jaw transform of each expression: `[N − 1, 9]` = 6D rotation (two columns) + translation.
    /// The neutral's is the identity and is not a parameter.
    pub jaw: Param<Tensor<2>>,
    /// How D's output becomes the thickness.
    #[module(skip)]
    pub thickness_activation: super::config::ThicknessActivation,
}

/// The anatomy and deformation the networks predict at a batch of points.
#[derive(Debug)]
pub struct Prediction {
    /// b0 `[B, 3]` (eq. 3).
    pub bone: Tensor<2>,
    /// d0 `[B, 1]` (eq. 4).
    pub thickness: Tensor<2>,
    /// Unit n0 `[B, 3]` (eq. 5).
    pub normal: Tensor<2>,
    /// s0 = b0 + d0·n0 `[B, 3]` (eq. 6).
    pub skin: Tensor<2>,
    /// k `[B, 1]` (eq. 7).
    pub k: Tensor<2>,
    /// B_e `[B, N − 1, 3]` (eq. 8).
    pub correctives: Tensor<3>,
}

impl Prediction {
    /// The rows `index` of every field, in that order (a row may repeat): the predictions of a
    /// batch that holds some points more than once, from one evaluation per distinct point.
    /// Gradients flowing back through the copies add up at the shared row.
    ///
    /// # Shapes
    /// - `index`: `[B']` rows of this `[B, …]` prediction; output `[B', …]`
    pub fn select(self, index: Tensor<1, Int>) -> Self {
        Self {
            bone: self.bone.select(0, index.clone()),
            thickness: self.thickness.select(0, index.clone()),
            normal: self.normal.select(0, index.clone()),
            skin: self.skin.select(0, index.clone()),
            k: self.k.select(0, index.clone()),
            correctives: self.correctives.select(0, index),
        }
    }
}

/// The identity in AIM's 9 jaw parameters.
pub const IDENTITY_9D: [f32; 9] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];

impl AimNet {
    /// A freshly initialised model for `shapes` training shapes (neutral included), its jaw
    /// transforms the identity. Seed the device first.
    pub fn new(config: &AimConfig, shapes: usize, device: &Device) -> Self {
        Self::with_jaw(config, &vec![IDENTITY_9D; shapes.saturating_sub(1)], device)
    }

    /// A freshly initialised model whose jaw transforms start at `jaw`, one per expression (so
    /// `jaw.len() + 1` training shapes). Seed the device first.
    pub fn with_jaw(config: &AimConfig, jaw: &[[f32; 9]], device: &Device) -> Self {
        let widths = |out: usize| {
            let mut w = vec![3];
            w.extend(std::iter::repeat_n(config.hidden, config.layers));
            w.push(out);
            w
        };
        let m = jaw.len();
        let jaw: Vec<f32> = jaw.iter().flatten().copied().collect();
        Self {
            b: Mlp::siren(&widths(3), config.omega0, device),
            d: Mlp::siren(&widths(1), config.omega0, device),
            n: Mlp::siren(&widths(3), config.omega0, device),
            k: Mlp::siren(&widths(1), config.omega0, device),
            e: Mlp::siren(&widths(3 * m), config.omega0, device),
            jaw: Param::from_tensor(Tensor::from_data(TensorData::new(jaw, [m, 9]), device)),
            thickness_activation: config.thickness_activation,
        }
    }

    /// Number of corrective shapes N − 1.
    pub fn corrective_shapes(&self) -> usize {
        self.jaw.val().dims()[0]
    }

    /// The networks at points `c` (world units) whose normalised coordinates are `x`.
    ///
    /// # Shapes
    /// - `x`, `c`: `[B, 3]`
    pub fn predict(&self, x: Tensor<2>, c: Tensor<2>) -> Prediction {
        let [batch, _] = x.dims();
        let bone = c + self.b.forward(x.clone());
        let thickness = match self.thickness_activation {
            super::config::ThicknessActivation::Identity => self.d.forward(x.clone()),
            // ln(1 + e^x), linear above 20 (as the core's `softplus`).
            super::config::ThicknessActivation::Softplus => {
                burn::tensor::activation::softplus(self.d.forward(x.clone()), 1.0)
            }
        };
        let raw = self.n.forward(x.clone());
        let norm = raw.clone().square().sum_dim(1).add_scalar(1e-12).sqrt();
        let normal = raw / norm;
        // AIM eq. 6: s0 = b0 + d0·n0
        let skin = bone.clone() + normal.clone() * thickness.clone();
        let k = self.k.forward(x.clone());
        let m = self.corrective_shapes();
        let correctives = self.e.forward(x).reshape([batch, m, 3]);
        Prediction {
            bone,
            thickness,
            normal,
            skin,
            k,
            correctives,
        }
    }

    /// Skin positions of samples in shape `shape[i]` (0 = neutral): AIM eq. 10,
    /// `s_i = LBS(s0, T_b,i, k) + e_i`, with `LBS(x) = k (R (x − p) + p + t) + (1 − k) x`.
    ///
    /// # Shapes
    /// - `shape`: `[B]` shape indices in `0..N`
    /// - `pivot`: `[1, 3]`
    /// - output: `[B, 3]`
    pub fn pose(&self, p: &Prediction, shape: Tensor<1, Int>, pivot: Tensor<2>) -> Tensor<2> {
        let device = p.skin.device();
        let [batch, _] = p.skin.dims();
        let m = self.corrective_shapes();
        let identity =
            Tensor::<2>::from_data(TensorData::new(IDENTITY_9D.to_vec(), [1, 9]), &device);
        let table = Tensor::cat(vec![identity, self.jaw.val()], 0);
        let t = table.select(0, shape.clone());
        let rel = p.skin.clone() - pivot.clone();
        let moved = rotate_6d(t.clone().narrow(1, 0, 6), rel) + pivot + t.narrow(1, 6, 3);
        let skinned = moved * p.k.clone() + p.skin.clone() * p.k.clone().neg().add_scalar(1.0);
        let zeros = Tensor::<3>::zeros([batch, 1, 3], &device);
        let all = Tensor::cat(vec![zeros, p.correctives.clone()], 1);
        let index = shape.reshape([batch, 1, 1]).repeat_dim(2, 3);
        debug_assert_eq!(all.dims()[1], m + 1);
        skinned + all.gather(1, index).reshape([batch, 3])
    }
}

/// The input normalisation of a template: centre of its bounding box and half its largest extent,
/// so SIREN sees coordinates in [−1, 1].
pub fn normalisation(points: &[[f32; 3]]) -> [f32; 4] {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for p in points {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let scale = (0..3).map(|i| hi[i] - lo[i]).fold(0.0f32, f32::max) * 0.5;
    [
        (lo[0] + hi[0]) * 0.5,
        (lo[1] + hi[1]) * 0.5,
        (lo[2] + hi[2]) * 0.5,
        scale.max(1e-6),
    ]
}

/// Normalised coordinates of `p`.
pub fn normalise(p: [f32; 3], n: [f32; 4]) -> [f32; 3] {
    [
        (p[0] - n[0]) / n[3],
        (p[1] - n[1]) / n[3],
        (p[2] - n[2]) / n[3],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::training::nn::{tensor, to_vec};

    #[test]
    fn rotate_6d_matches_the_core() {
        let device = crate::training::backend::Backend::Flex.device(1).unwrap();
        let r = [0.3f32, -1.2, 0.5, 2.0, 0.1, -0.7];
        let v = [1.5f32, -0.25, 2.0];
        let burn = to_vec(rotate_6d(
            tensor(r.to_vec(), [1, 6], &device),
            tensor(v.to_vec(), [1, 3], &device),
        ));
        let m = sinew_core::rotation::from_6d(&r);
        let core = m
            .mul_vec(sinew_core::linalg::Vec3::from_array(v))
            .to_array();
        for (a, b) in burn.iter().zip(core) {
            assert!((a - b).abs() < 1e-5, "{burn:?} vs {core:?}");
        }
    }

    #[test]
    fn neutral_samples_are_unposed_and_expressions_add_their_corrective() {
        let device = crate::training::backend::Backend::Flex.device(3).unwrap();
        let config = AimConfig {
            hidden: 8,
            layers: 1,
            ..AimConfig::default()
        };
        let net = AimNet::new(&config, 3, &device);
        let x = tensor(
            vec![0.1, 0.2, 0.3, 0.1, 0.2, 0.3, 0.1, 0.2, 0.3],
            [3, 3],
            &device,
        );
        let p = net.predict(x.clone(), x);
        let shapes = Tensor::<1, Int>::from_data(TensorData::new(vec![0i64, 1, 2], [3]), &device);
        let pivot = tensor(vec![0.0, 0.0, 0.0], [1, 3], &device);
        let posed = to_vec(net.pose(&p, shapes, pivot));
        let s0 = to_vec(p.skin.clone());
        let e = to_vec(p.correctives.clone());
        // Identity jaw: shape 0 is s0, shape j adds corrective j − 1.
        for i in 0..3 {
            assert!((posed[i] - s0[i]).abs() < 1e-6);
            assert!((posed[3 + i] - (s0[3 + i] + e[6 + i])).abs() < 1e-5);
            assert!((posed[6 + i] - (s0[6 + i] + e[12 + 3 + i])).abs() < 1e-5);
        }
    }
}
