//! S2D-Dec (S2D §3.2, Fig. 3): 68 landmark displacements → dense per-vertex displacements, a
//! fully connected layer followed by up-sampling and spiral-convolution stages over a
//! [`Hierarchy`]. `shared/notes/s2d-reference.md` fixes the reference configuration
//! ([`DecoderConfig::default`]).
//!
//! # Layout
//! Inside the network every feature map is vertex-major, a 2-D tensor `[vertices + 1, batch ·
//! features]` (the `+ 1` is the dummy vertex). The up-sampling and the spiral gathers then select
//! whole rows, whose backward in burn-flex is a row addition; selecting along dimension 1 of a 3-D
//! `[batch, vertices, features]` tensor takes the N-D path, with a division and a modulo per
//! element in the backward (see `docs/S2D.md` for the measured difference).

use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Device, Int, Tensor, TensorData};
use serde::{Deserialize, Serialize};
use sinew_core::nn::Activation;

use super::{Hierarchy, Sampling};
use crate::training::nn::{SpiralConv, pytorch_linear};

/// A decoder configuration, hierarchy or `s2d.input` code that does not make a decoder.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecoderError {
    /// An `s2d.input` code this build does not know.
    #[error("unknown input normalisation code {0}")]
    UnknownInputCode(u32),
    /// A hierarchy without levels.
    #[error("the hierarchy has no levels")]
    NoLevels,
    /// Not one up-sampling per neighbouring pair of levels.
    #[error("{levels} levels need {} up-samplings, found {found}", levels.saturating_sub(1))]
    UpSamplings {
        /// The levels.
        levels: usize,
        /// The up-samplings.
        found: usize,
    },
    /// A level whose spiral table has the wrong size.
    #[error(
        "level {level}: {indices} spiral indices for {vertices} vertices (+ dummy) of length {len}"
    )]
    SpiralCount {
        /// The level.
        level: usize,
        /// The indices in its table.
        indices: usize,
        /// Its vertices.
        vertices: usize,
        /// Its spiral length.
        len: usize,
    },
    /// A spiral index past the level's dummy vertex.
    #[error("level {level}: a spiral index exceeds the dummy vertex {vertices}")]
    SpiralIndex {
        /// The level.
        level: usize,
        /// Its vertices (the dummy vertex's index).
        vertices: usize,
    },
    /// A malformed up-sampling matrix.
    #[error("up-sampling {index}")]
    Sampling {
        /// The up-sampling (from level `index + 1` to `index`).
        index: usize,
        /// What is wrong with it.
        #[source]
        source: SamplingError,
    },
    /// A zero input, fully connected or output width.
    #[error("decoder widths must be positive")]
    Widths,
    /// Not one stage per up-sampling.
    #[error("the decoder has {stages} stages but the hierarchy {up} up-samplings")]
    Stages {
        /// The configuration's stages.
        stages: usize,
        /// The hierarchy's up-samplings.
        up: usize,
    },
    /// A stage with no filters.
    #[error("stage filters must be positive")]
    Filters,
}

/// What is wrong with an up-sampling matrix in CSR form.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SamplingError {
    /// Another shape than its levels need.
    #[error("is {rows}×{cols}, expected {expected_rows}×{expected_cols}")]
    Shape {
        /// Its rows.
        rows: usize,
        /// Its columns.
        cols: usize,
        /// The rows needed.
        expected_rows: usize,
        /// The columns needed.
        expected_cols: usize,
    },
    /// Row pointers that do not start at 0 or have the wrong count.
    #[error("row pointers do not start at 0 or have the wrong count")]
    RowStart,
    /// Row pointers that decrease or do not end at the entry count.
    #[error("row pointers decrease or do not end at the entry count")]
    RowOrder,
    /// A column index past the last column.
    #[error("a column index is out of range")]
    Column,
    /// A NaN or infinite value.
    #[error("a value is not finite")]
    NonFinite,
}

/// Number of landmarks the decoder reads (iBUG-68).
pub const LANDMARKS: usize = 68;

/// The shape of an S2D decoder (the mesh sizes come from the [`Hierarchy`]).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DecoderConfig {
    /// Input width: 3 × landmarks (204).
    pub inputs: usize,
    /// Features per coarsest-level vertex after the fully connected layer (128).
    pub fc_features: usize,
    /// Filters of each up-sampling stage, coarsest first (`[64, 32, 32, 16]`); one per
    /// up-sampling of the hierarchy.
    pub filters: Vec<usize>,
    /// Features of the output (3: a displacement).
    pub outputs: usize,
    /// The activation after each stage's spiral convolution (ELU in the reference).
    #[serde(default)]
    pub activation: StageActivation,
    /// How the input is made from the landmark sets (the reference's Frobenius normalisation).
    #[serde(default)]
    pub input: InputNormalisation,
}

/// How the decoder's input is made from a neutral and an expressive landmark set.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum InputNormalisation {
    /// The reference's (S2D §3.2): each set centred and scaled to unit Frobenius norm, then
    /// `normalised(expressive) − normalised(neutral)`.
    #[default]
    Frobenius,
    /// Each set centred, both divided by the neutral set's Frobenius norm: the landmark
    /// displacement less its mean, in units of the face's size, linear in the displacement.
    NeutralScale,
}

impl InputNormalisation {
    /// The `s2d.input` code the core reads.
    pub const fn code(self) -> u32 {
        match self {
            Self::Frobenius => sinew_core::s2d::INPUT_FROBENIUS,
            Self::NeutralScale => sinew_core::s2d::INPUT_NEUTRAL_SCALE,
        }
    }

    /// The normalisation of an `s2d.input` code.
    pub fn from_code(code: u32) -> Result<Self, DecoderError> {
        match code {
            sinew_core::s2d::INPUT_FROBENIUS => Ok(Self::Frobenius),
            sinew_core::s2d::INPUT_NEUTRAL_SCALE => Ok(Self::NeutralScale),
            _ => Err(DecoderError::UnknownInputCode(code)),
        }
    }
}

/// The activation after each up-sampling stage's spiral convolution.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum StageActivation {
    /// ELU with α = 1, the reference's.
    #[default]
    Elu,
    /// Leaky ReLU, negative slope 0.2: piecewise linear, so it does not flatten large negative
    /// pre-activations as ELU does (ELU tends to −1).
    LeakyRelu,
    /// None: the whole decoder is a linear map of its input.
    Identity,
}

/// Negative slope of [`StageActivation::LeakyRelu`].
pub const LEAKY_SLOPE: f32 = 0.2;

impl StageActivation {
    /// The core's activation.
    pub const fn activation(self) -> Activation {
        match self {
            Self::Elu => Activation::Elu { alpha: 1.0 },
            Self::LeakyRelu => Activation::LeakyRelu { slope: LEAKY_SLOPE },
            Self::Identity => Activation::Identity,
        }
    }
}

impl Default for DecoderConfig {
    /// The reference configuration (S2D-Dec on the CoMA/FLAME hierarchy).
    fn default() -> Self {
        Self {
            inputs: 3 * LANDMARKS,
            fc_features: 128,
            filters: vec![64, 32, 32, 16],
            outputs: 3,
            activation: StageActivation::Elu,
            input: InputNormalisation::Frobenius,
        }
    }
}

impl DecoderConfig {
    /// Checks that this configuration fits `hierarchy` (which must itself be well formed: see
    /// [`check_hierarchy`]).
    pub fn validate(&self, hierarchy: &Hierarchy) -> Result<(), DecoderError> {
        check_hierarchy(hierarchy)?;
        if self.inputs == 0 || self.fc_features == 0 || self.outputs == 0 {
            return Err(DecoderError::Widths);
        }
        if self.filters.len() != hierarchy.up.len() {
            return Err(DecoderError::Stages {
                stages: self.filters.len(),
                up: hierarchy.up.len(),
            });
        }
        if self.filters.contains(&0) {
            return Err(DecoderError::Filters);
        }
        Ok(())
    }

    /// The `(inputs, outputs, spiral length)` of each spiral convolution in evaluation order: one
    /// per stage (at levels L−1 down to 0), then the output convolution at level 0.
    pub fn convolutions(&self, hierarchy: &Hierarchy) -> Vec<(usize, usize, usize)> {
        let levels = hierarchy.levels.len();
        let len = |level: usize| hierarchy.levels.get(level).map_or(0, |l| l.spiral_len);
        let mut width = self.fc_features;
        let mut convs = Vec::new();
        for (stage, &f) in self.filters.iter().enumerate() {
            convs.push((width, f, len(levels.saturating_sub(2 + stage))));
            width = f;
        }
        convs.push((width, self.outputs, len(0)));
        convs
    }

    /// Number of trainable parameters: the fully connected layer `inputs → (n_L + 1) · fc` and
    /// every spiral convolution `len · in → out`, with biases.
    pub fn parameter_count(&self, hierarchy: &Hierarchy) -> usize {
        let coarsest = hierarchy.levels.last().map_or(0, |l| l.positions.len()) + 1;
        let fc_out = coarsest * self.fc_features;
        let fc = (self.inputs + 1) * fc_out;
        fc + self
            .convolutions(hierarchy)
            .iter()
            .map(|&(i, o, len)| (len * i + 1) * o)
            .sum::<usize>()
    }
}

/// Checks the shapes of a hierarchy: at least one level, one up-sampling per neighbouring pair of
/// levels, spirals of `(n + 1) × len` indices `≤ n`, and each up-sampling a well-formed CSR matrix
/// of `(n_i + 1) × (n_{i+1} + 1)`.
pub fn check_hierarchy(h: &Hierarchy) -> Result<(), DecoderError> {
    if h.levels.is_empty() {
        return Err(DecoderError::NoLevels);
    }
    if h.up.len() + 1 != h.levels.len() {
        return Err(DecoderError::UpSamplings {
            levels: h.levels.len(),
            found: h.up.len(),
        });
    }
    for (i, level) in h.levels.iter().enumerate() {
        let n = level.positions.len();
        if level.spiral_len == 0 || level.spirals.len() != (n + 1) * level.spiral_len {
            return Err(DecoderError::SpiralCount {
                level: i,
                indices: level.spirals.len(),
                vertices: n,
                len: level.spiral_len,
            });
        }
        if level.spirals.iter().any(|&s| s as usize > n) {
            return Err(DecoderError::SpiralIndex {
                level: i,
                vertices: n,
            });
        }
    }
    for (i, up) in h.up.iter().enumerate() {
        let rows = h.levels[i].positions.len() + 1;
        let cols = h.levels[i + 1].positions.len() + 1;
        check_sampling(up, rows, cols)
            .map_err(|source| DecoderError::Sampling { index: i, source })?;
    }
    Ok(())
}

fn check_sampling(s: &Sampling, rows: usize, cols: usize) -> Result<(), SamplingError> {
    if s.rows != rows || s.cols != cols {
        return Err(SamplingError::Shape {
            rows: s.rows,
            cols: s.cols,
            expected_rows: rows,
            expected_cols: cols,
        });
    }
    if !(s.row_ptr.len() == rows + 1 && s.row_ptr.first() == Some(&0)) {
        return Err(SamplingError::RowStart);
    }
    if !(s.row_ptr.windows(2).all(|w| w[0] <= w[1])
        && s.row_ptr.last().map(|&p| p as usize) == Some(s.values.len())
        && s.col_idx.len() == s.values.len())
    {
        return Err(SamplingError::RowOrder);
    }
    if s.col_idx.iter().any(|&c| c as usize >= cols) {
        return Err(SamplingError::Column);
    }
    if !s.values.iter().all(|v| v.is_finite()) {
        return Err(SamplingError::NonFinite);
    }
    Ok(())
}

/// An up-sampling `U` (S2D §3.2: fine = U · coarse) as a fixed-arity gather: every fine vertex
/// reads `arity` coarse rows (its barycentric parents, padded with weight 0) and sums them
/// weighted. No dense matrix is formed: `U` at 5023 × 1257 would cost ~3 GFLOP per batch-16 pass.
#[derive(Module, Debug)]
pub struct Upsample {
    /// Parent of each (fine vertex, slot), flattened `[(n_fine + 1) · arity]`.
    pub parents: Tensor<1, Int>,
    /// Weight of each (fine vertex, slot), `[n_fine + 1, arity, 1]`.
    pub weights: Tensor<3>,
    /// Parents per fine vertex (the largest row of `U`).
    #[module(skip)]
    pub arity: usize,
}

impl Upsample {
    /// The gather form of a CSR up-sampling matrix (checked by [`check_hierarchy`]).
    pub fn new(u: &Sampling, device: &Device) -> Self {
        let arity = u
            .row_ptr
            .windows(2)
            .map(|w| (w[1] - w[0]) as usize)
            .max()
            .unwrap_or(0)
            .max(1);
        let mut parents = Vec::with_capacity(u.rows * arity);
        let mut weights = Vec::with_capacity(u.rows * arity);
        for w in u.row_ptr.windows(2) {
            let (a, b) = (w[0] as usize, w[1] as usize);
            for k in 0..arity {
                if a + k < b {
                    parents.push(i64::from(u.col_idx[a + k]));
                    weights.push(u.values[a + k]);
                } else {
                    // Padding: any valid row times 0 (every value is finite, so 0 · x = ±0).
                    parents.push(0);
                    weights.push(0.0);
                }
            }
        }
        Self {
            parents: Tensor::from_data(TensorData::new(parents, [u.rows * arity]), device),
            weights: Tensor::from_data(TensorData::new(weights, [u.rows, arity, 1]), device),
            arity,
        }
    }

    /// `fine_v = Σ_k w_vk · coarse_{parent(v, k)}`.
    ///
    /// # Shapes
    /// - input: `[n_coarse + 1, width]`
    /// - output: `[n_fine + 1, width]`
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        let [_, width] = x.dims();
        let rows = self.weights.dims()[0];
        x.select(0, self.parents.clone())
            .reshape([rows, self.arity, width])
            .mul(self.weights.clone())
            .sum_dim(1)
            .reshape([rows, width])
    }

    /// [`Upsample::forward`] on a batch-major tensor (see [`S2dDecoder::forward_batch_major`]).
    ///
    /// # Shapes
    /// - input: `[batch, n_coarse + 1, features]`
    /// - output: `[batch, n_fine + 1, features]`
    pub fn forward_batch_major(&self, x: Tensor<3>) -> Tensor<3> {
        let [batch, _, features] = x.dims();
        let rows = self.weights.dims()[0];
        x.select(1, self.parents.clone())
            .reshape([batch, rows, self.arity, features])
            .mul(self.weights.clone().reshape([1, rows, self.arity, 1]))
            .sum_dim(2)
            .reshape([batch, rows, features])
    }
}

/// The S2D decoder.
#[derive(Module, Debug)]
pub struct S2dDecoder {
    /// Fully connected layer `inputs → (n_L + 1) · fc_features`.
    pub fc: Linear,
    /// Up-samplings in evaluation order (`U_{L−1}` first, `U_0` last).
    pub ups: Vec<Upsample>,
    /// Spiral convolutions: one per stage (ELU), then the output convolution (identity).
    pub convs: Vec<SpiralConv>,
    /// Per stage, `[n + 1, 1]` ones with a zero in the dummy row.
    pub masks: Vec<Tensor<2>>,
    /// The configuration.
    #[module(skip)]
    pub config: DecoderConfig,
    /// Vertices (without dummy) of each level, finest first.
    #[module(skip)]
    pub vertices: Vec<usize>,
}

impl S2dDecoder {
    /// A decoder over `hierarchy` with PyTorch's default initialisation of every linear layer
    /// (uniform ±1/√fan-in for weights and biases). Seed the device first for reproducible weights.
    pub fn new(
        config: &DecoderConfig,
        hierarchy: &Hierarchy,
        device: &Device,
    ) -> Result<Self, DecoderError> {
        config.validate(hierarchy)?;
        let levels = hierarchy.levels.len();
        let vertices: Vec<usize> = hierarchy.levels.iter().map(|l| l.positions.len()).collect();
        let coarsest = vertices[levels - 1] + 1;
        let fc = pytorch_linear(config.inputs, coarsest * config.fc_features, device);
        let mut ups = Vec::new();
        let mut convs = Vec::new();
        let mut masks = Vec::new();
        let shapes = config.convolutions(hierarchy);
        for (stage, &(inputs, outputs, len)) in shapes.iter().enumerate() {
            let last = stage + 1 == shapes.len();
            let level = if last { 0 } else { levels - 2 - stage };
            let l = &hierarchy.levels[level];
            let activation = if last {
                Activation::Identity
            } else {
                config.activation.activation()
            };
            convs.push(SpiralConv::new(
                &l.spirals, len, inputs, outputs, activation, device,
            ));
            if !last {
                ups.push(Upsample::new(&hierarchy.up[level], device));
                let n = vertices[level];
                let mut m = vec![1.0f32; n + 1];
                m[n] = 0.0;
                masks.push(Tensor::from_data(TensorData::new(m, [n + 1, 1]), device));
            }
        }
        Ok(Self {
            fc,
            ups,
            convs,
            masks,
            config: config.clone(),
            vertices,
        })
    }

    /// Number of vertices of the output mesh (level 0, without dummy).
    pub fn output_vertices(&self) -> usize {
        self.vertices[0]
    }

    /// Number of trainable parameters.
    pub fn parameter_count(&self) -> usize {
        self.num_params()
    }

    /// Dense displacements from landmark displacements (S2D §3.2):
    /// FC (no zeroing of the dummy row: it pads the first convolution), then per stage
    /// `ELU(SpiralConv(U · x))` with the dummy row zeroed, then the output convolution.
    ///
    /// # Shapes
    /// - input: `[batch, inputs]`
    /// - output: `[batch, n_0, outputs]`
    pub fn forward(&self, x: Tensor<2>) -> Tensor<3> {
        let [batch, _] = x.dims();
        let f = self.config.fc_features;
        let coarsest = self.vertices[self.vertices.len() - 1] + 1;
        let mut h = self
            .fc
            .forward(x)
            .reshape([batch, coarsest, f])
            .swap_dims(0, 1)
            .reshape([coarsest, batch * f]);
        for ((up, conv), mask) in self.ups.iter().zip(&self.convs).zip(&self.masks) {
            h = conv
                .forward_vertex_major(up.forward(h), batch)
                .mul(mask.clone());
        }
        let out = &self.convs[self.convs.len() - 1];
        let n0 = self.vertices[0];
        let o = self.config.outputs;
        out.forward_vertex_major(h, batch)
            .reshape([n0 + 1, batch, o])
            .narrow(0, 0, n0)
            .swap_dims(0, 1)
    }

    /// The same function as [`S2dDecoder::forward`] with batch-major `[batch, vertices,
    /// features]` feature maps, gathering along dimension 1. Slower to train (its gathers'
    /// backward takes burn-flex's N-D path); kept as the benchmark's baseline and as a check of
    /// the vertex-major layout.
    ///
    /// # Shapes
    /// - input: `[batch, inputs]`
    /// - output: `[batch, n_0, outputs]`
    pub fn forward_batch_major(&self, x: Tensor<2>) -> Tensor<3> {
        let [batch, _] = x.dims();
        let f = self.config.fc_features;
        let coarsest = self.vertices[self.vertices.len() - 1] + 1;
        let mut h = self.fc.forward(x).reshape([batch, coarsest, f]);
        for ((up, conv), mask) in self.ups.iter().zip(&self.convs).zip(&self.masks) {
            let rows = mask.dims()[0];
            h = conv
                .forward(up.forward_batch_major(h))
                .mul(mask.clone().reshape([1, rows, 1]));
        }
        let out = &self.convs[self.convs.len() - 1];
        out.forward(h).narrow(1, 0, self.vertices[0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s2d::synthetic;
    use crate::training::nn::{tensor, to_vec};

    fn device() -> Device {
        crate::training::backend::Backend::Flex.device(3).unwrap()
    }

    #[test]
    fn reference_parameter_count() {
        // Only the level sizes and spiral lengths matter: the FLAME hierarchy's
        // 5023/1256/314/79/20 vertices and spirals [15, 14, 9, 9, 7].
        let h = synthetic::hierarchy(&synthetic::REFERENCE_SIZES, &[15, 14, 9, 9, 7], 1);
        let config = DecoderConfig::default();
        // FC 205·21·128 = 551,040; convs (9·128+1)·64 = 73,792, (9·64+1)·32 = 18,464,
        // (14·32+1)·32 = 14,368, (15·32+1)·16 = 7,696, (15·16+1)·3 = 723.
        assert_eq!(config.parameter_count(&h), 666_083);
        let dec = S2dDecoder::new(&config, &h, &device()).unwrap();
        assert_eq!(dec.parameter_count(), 666_083);
    }

    #[test]
    fn upsample_is_the_sparse_product() {
        let device = device();
        // U (3 × 3): row 0 = 0.5·c0 + 0.5·c1 (two parents, padded to three);
        // row 1 = 0.2·c0 + 0.3·c1 + 0.5·c0 (a repeated parent); row 2 (dummy) = 1·c2.
        let u = Sampling {
            rows: 3,
            cols: 3,
            row_ptr: vec![0, 2, 5, 6],
            col_idx: vec![0, 1, 0, 1, 0, 2],
            values: vec![0.5, 0.5, 0.2, 0.3, 0.5, 1.0],
        };
        let up = Upsample::new(&u, &device);
        assert_eq!(up.arity, 3);
        // coarse rows c0 = [1, 10], c1 = [3, 30], c2 = [0, 0].
        let x = tensor(vec![1.0, 10.0, 3.0, 30.0, 0.0, 0.0], [3, 2], &device);
        let y = to_vec(up.forward(x));
        // row 0: [2, 20]; row 1: 0.7·[1, 10] + 0.3·[3, 30] = [1.6, 16]; row 2: [0, 0].
        let expected = [2.0, 20.0, 1.6, 16.0, 0.0, 0.0];
        for (a, b) in y.iter().zip(expected) {
            assert!((a - b).abs() < 1e-6, "{y:?}");
        }
    }

    /// The decoder evaluated sample by sample with plain loops over the CSR matrices and spirals.
    fn reference_decode(dec: &S2dDecoder, h: &Hierarchy, x: &[f32], batch: usize) -> Vec<f32> {
        let fc_w = to_vec(dec.fc.weight.val()); // [in, out]
        let fc_b = to_vec(dec.fc.bias.as_ref().unwrap().val());
        let (fin, fout) = (dec.config.inputs, fc_b.len());
        let levels = h.levels.len();
        let mut all = Vec::new();
        for s in 0..batch {
            let xs = &x[s * fin..(s + 1) * fin];
            let mut feat: Vec<f32> = (0..fout)
                .map(|o| (0..fin).map(|i| xs[i] * fc_w[i * fout + o]).sum::<f32>() + fc_b[o])
                .collect();
            let mut width = dec.config.fc_features;
            for (stage, conv) in dec.convs.iter().enumerate() {
                let last = stage + 1 == dec.convs.len();
                let level = if last { 0 } else { levels - 2 - stage };
                if !last {
                    let u = &h.up[level];
                    let mut up = vec![0.0; u.rows * width];
                    for r in 0..u.rows {
                        for k in u.row_ptr[r] as usize..u.row_ptr[r + 1] as usize {
                            let c = u.col_idx[k] as usize;
                            for f in 0..width {
                                up[r * width + f] += u.values[k] * feat[c * width + f];
                            }
                        }
                    }
                    feat = up;
                }
                let l = &h.levels[level];
                let w = to_vec(conv.linear.weight.val()); // [len·in, out]
                let b = to_vec(conv.linear.bias.as_ref().unwrap().val());
                let out = b.len();
                let n = l.positions.len() + 1;
                let mut next = vec![0.0; n * out];
                for v in 0..n {
                    for o in 0..out {
                        let mut acc = b[o];
                        for p in 0..l.spiral_len {
                            let src = l.spirals[v * l.spiral_len + p] as usize;
                            for f in 0..width {
                                acc += feat[src * width + f] * w[(p * width + f) * out + o];
                            }
                        }
                        next[v * out + o] = if last || acc > 0.0 { acc } else { acc.exp_m1() };
                    }
                }
                if !last {
                    next[(n - 1) * out..].fill(0.0);
                }
                feat = next;
                width = out;
            }
            let n0 = h.levels[0].positions.len();
            all.extend_from_slice(&feat[..n0 * width]);
        }
        all
    }

    /// The vertex-major forward equals a direct per-sample evaluation with dense matrices.
    #[test]
    fn forward_matches_a_dense_reference() {
        let device = device();
        let h = synthetic::hierarchy(&[30, 12, 5], &[5, 4, 3], 2);
        let config = synthetic::small_config();
        let dec = S2dDecoder::new(&config, &h, &device).unwrap();
        let mut rng = synthetic::Rng::new(9);
        let batch = 3;
        let x: Vec<f32> = (0..batch * 6).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let y = to_vec(dec.forward(tensor(x.clone(), [batch, 6], &device)));
        assert_eq!(y.len(), batch * 30 * 3);
        let reference = reference_decode(&dec, &h, &x, batch);
        let max = y
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(max < 1e-5, "max difference {max}");
        assert!(reference.iter().any(|v| v.abs() > 1e-2));
        let z = to_vec(dec.forward_batch_major(tensor(x, [batch, 6], &device)));
        let max = z
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(max < 1e-5, "batch-major: max difference {max}");
    }

    #[test]
    fn rejects_a_mismatched_configuration() {
        let h = synthetic::hierarchy(&[30, 12, 5], &[5, 4, 3], 2);
        let config = DecoderConfig::default();
        assert!(matches!(
            S2dDecoder::new(&config, &h, &device()),
            Err(DecoderError::Stages { stages: 4, up: 2 })
        ));
        let mut bad = h.clone();
        bad.levels[1].spirals[0] = 99;
        assert_eq!(
            check_hierarchy(&bad),
            Err(DecoderError::SpiralIndex {
                level: 1,
                vertices: 12
            })
        );
        let mut bad = h.clone();
        bad.up[0].col_idx[0] = 13;
        assert_eq!(
            check_hierarchy(&bad),
            Err(DecoderError::Sampling {
                index: 0,
                source: SamplingError::Column
            })
        );
        let mut bad = h;
        bad.up.pop();
        assert_eq!(
            check_hierarchy(&bad),
            Err(DecoderError::UpSamplings {
                levels: 3,
                found: 1
            })
        );
    }
}
