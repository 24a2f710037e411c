//! burn twins of the core's layers: an MLP with per-layer activations (SIREN when the activation
//! is a sine) and the spiral convolution. Each can export itself into the sections that
//! `sinew_core::network::load_mlp` and `sinew_core::spiral` read, so the host trains and the core
//! plays back the same weights.

use burn::module::{Module, Param};
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::{elu, gelu, leaky_relu, relu};
use burn::tensor::{Device, Distribution, Int, Tensor, TensorData};
use sinew_core::nn::Activation;

use crate::io::container::{SinewWriter, WriterError};

pub use super::tensor::{tensor, to_vec};

/// Applies `act` as the core does (same formula; rounding differs, see `tolerance`).
pub fn activate<const D: usize>(x: Tensor<D>, act: Activation) -> Tensor<D> {
    match act {
        Activation::Identity => x,
        Activation::Sine { omega0 } => crate::training::sine::siren_sine(x, omega0),
        Activation::Gelu => gelu(x),
        Activation::Elu { alpha } => elu(x, f64::from(alpha)),
        Activation::Relu => relu(x),
        Activation::LeakyRelu { slope } => leaky_relu(x, f64::from(slope)),
    }
}

/// A multi-layer perceptron with one activation per layer.
#[derive(Module, Debug)]
pub struct Mlp {
    /// The affine layers, first to last.
    pub layers: Vec<Linear>,
    /// The activation after each layer.
    #[module(skip)]
    pub activations: Vec<Activation>,
}

impl Mlp {
    /// A SIREN (Sitzmann et al. 2020): `widths[0]` inputs, sine layers of `omega0` in between and
    /// a linear last layer, with SIREN's initialisation (first layer U(−1/in, 1/in), later layers
    /// U(−√(6/in)/ω0, √(6/in)/ω0)). Seed the device first for reproducible weights.
    pub fn siren(widths: &[usize], omega0: f32, device: &Device) -> Self {
        let n = widths.len().saturating_sub(1);
        let acts = (0..n)
            .map(|i| {
                if i + 1 == n {
                    Activation::Identity
                } else {
                    Activation::Sine { omega0 }
                }
            })
            .collect::<Vec<_>>();
        let layers = widths
            .windows(2)
            .enumerate()
            .map(|(i, w)| {
                let fan_in = w[0] as f64;
                let bound = if i == 0 {
                    1.0 / fan_in
                } else {
                    (6.0 / fan_in).sqrt() / f64::from(omega0)
                };
                uniform_linear(w[0], w[1], bound, 1.0 / fan_in.sqrt(), device)
            })
            .collect();
        Self {
            layers,
            activations: acts,
        }
    }

    /// A generic MLP with the given widths and activations (uniform ±1/√in initialisation).
    pub fn new(widths: &[usize], activations: &[Activation], device: &Device) -> Self {
        let layers = widths
            .windows(2)
            .map(|w| {
                let b = 1.0 / (w[0] as f64).sqrt();
                uniform_linear(w[0], w[1], b, b, device)
            })
            .collect();
        Self {
            layers,
            activations: activations.to_vec(),
        }
    }

    /// # Shapes
    /// - input: `[n, inputs]`
    /// - output: `[n, outputs]`
    pub fn forward(&self, x: Tensor<2>) -> Tensor<2> {
        self.layers
            .iter()
            .zip(&self.activations)
            .fold(x, |x, (layer, &act)| activate(layer.forward(x), act))
    }

    /// The MLP whose layers are `layers` (the core's layout, as [`Mlp::weights`] gives them).
    pub fn from_weights(layers: &[LayerWeights], device: &Device) -> Self {
        let linear = layers
            .iter()
            .map(|l| {
                let mut layer = LinearConfig::new(l.inputs, l.outputs).init(device);
                // The core stores one row per output; burn [inputs, outputs].
                let mut weight = vec![0.0; l.inputs * l.outputs];
                for (o, row) in l.weight.chunks_exact(l.inputs).enumerate() {
                    for (i, &w) in row.iter().enumerate() {
                        weight[i * l.outputs + o] = w;
                    }
                }
                layer.weight = Param::from_tensor(Tensor::from_data(
                    TensorData::new(weight, [l.inputs, l.outputs]),
                    device,
                ));
                layer.bias = Some(Param::from_tensor(Tensor::from_data(
                    TensorData::new(l.bias.clone(), [l.outputs]),
                    device,
                )));
                layer
            })
            .collect();
        Self {
            layers: linear,
            activations: layers.iter().map(|l| l.activation).collect(),
        }
    }

    /// The weights in the core's layout.
    pub fn weights(&self) -> Vec<LayerWeights> {
        self.layers
            .iter()
            .zip(&self.activations)
            .map(|(layer, &activation)| {
                // burn stores [in, out]; the core reads one row per output: transpose.
                let weight = layer.weight.val().transpose();
                let [outputs, inputs] = weight.dims();
                let bias = layer
                    .bias
                    .as_ref()
                    .map_or_else(|| vec![0.0; outputs], |b| to_vec(b.val()));
                LayerWeights {
                    weight: to_vec(weight),
                    bias,
                    inputs,
                    outputs,
                    activation,
                }
            })
            .collect()
    }

    /// Writes the weights as the core's MLP sections under `prefix`.
    pub fn export(&self, w: &mut SinewWriter, prefix: &str) -> Result<(), WriterError> {
        write_mlp(w, prefix, &self.weights())
    }
}

/// One layer's weights in the core's layout: `weight` is row-major `[outputs, inputs]`.
#[derive(Clone, Debug)]
pub struct LayerWeights {
    /// Row-major `[outputs, inputs]`.
    pub weight: Vec<f32>,
    /// `[outputs]`.
    pub bias: Vec<f32>,
    /// Input width.
    pub inputs: usize,
    /// Output width.
    pub outputs: usize,
    /// Activation after the affine map.
    pub activation: Activation,
}

/// Writes an MLP as the sections `sinew_core::network::load_mlp` reads (see docs/FORMAT.md).
pub fn write_mlp(
    w: &mut SinewWriter,
    prefix: &str,
    layers: &[LayerWeights],
) -> Result<(), WriterError> {
    let codes: Vec<u32> = layers.iter().map(|l| l.activation.code()).collect();
    let params: Vec<f32> = layers.iter().map(|l| l.activation.param()).collect();
    w.u32s(&format!("{prefix}.act"), &[codes.len()], &codes)?;
    w.f32s(&format!("{prefix}.par"), &[params.len()], &params)?;
    // A layer whose weights or bias do not have its shape is refused by the writer
    // (`WriterError::ShapeMismatch`, naming the section).
    for (i, l) in layers.iter().enumerate() {
        w.f32s(
            &format!("{prefix}.{i}.w"),
            &[l.outputs, l.inputs],
            &l.weight,
        )?;
        w.f32s(&format!("{prefix}.{i}.b"), &[l.outputs], &l.bias)?;
    }
    Ok(())
}

/// A linear layer with PyTorch's default `nn.Linear` initialisation: weight and bias uniform in
/// ±1/√inputs (kaiming-uniform with a = √5 gives exactly that bound for the weight).
pub fn pytorch_linear(inputs: usize, outputs: usize, device: &Device) -> Linear {
    let b = 1.0 / (inputs as f64).sqrt();
    uniform_linear(inputs, outputs, b, b, device)
}

fn uniform_linear(
    inputs: usize,
    outputs: usize,
    w_bound: f64,
    b_bound: f64,
    device: &Device,
) -> Linear {
    let mut layer = LinearConfig::new(inputs, outputs).init(device);
    layer.weight = Param::from_tensor(Tensor::random(
        [inputs, outputs],
        Distribution::Uniform(-w_bound, w_bound),
        device,
    ));
    layer.bias = Some(Param::from_tensor(Tensor::random(
        [outputs],
        Distribution::Uniform(-b_bound, b_bound),
        device,
    )));
    layer
}

/// The spiral convolution (Gong et al. 2019, as S2D's reference uses it): gather each vertex's
/// spiral of neighbours' features, position-major, then one linear layer.
#[derive(Module, Debug)]
pub struct SpiralConv {
    /// The linear layer over the concatenated spiral, `[len·in, out]` in burn's layout.
    pub linear: Linear,
    /// Spiral indices, flattened `[vertices·len]`.
    pub spirals: Tensor<1, Int>,
    /// Spiral length.
    #[module(skip)]
    pub len: usize,
    /// Activation after the linear layer.
    #[module(skip)]
    pub activation: Activation,
}

impl SpiralConv {
    /// A spiral convolution over `spirals` (row-major `[vertices, len]`).
    pub fn new(
        spirals: &[u32],
        len: usize,
        inputs: usize,
        outputs: usize,
        activation: Activation,
        device: &Device,
    ) -> Self {
        let b = 1.0 / ((inputs * len) as f64).sqrt();
        let idx: Vec<i64> = spirals.iter().map(|&i| i64::from(i)).collect();
        Self {
            linear: uniform_linear(inputs * len, outputs, b, b, device),
            spirals: Tensor::from_data(TensorData::new(idx, [spirals.len()]), device),
            len,
            activation,
        }
    }

    /// # Shapes
    /// - input: `[batch, source_vertices, in]`
    /// - output: `[batch, vertices, out]`
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let [batch, _, features] = x.dims();
        let vertices = self.spirals.dims()[0] / self.len;
        let gathered =
            x.select(1, self.spirals.clone())
                .reshape([batch, vertices, self.len * features]);
        activate(self.linear.forward(gathered), self.activation)
    }

    /// The same convolution on a vertex-major batch: `x` holds one row per source vertex with the
    /// `batch` samples' features side by side (`[sources, batch, in]` row-major).
    ///
    /// One product per spiral position, before the gather: `Y_p = x · W_p`, with `W_p` the rows
    /// of the linear layer's weight that read position p, holds position p's contribution of
    /// every source vertex, `[sources, batch · out]`; output `v` sums `Y_p[s(v, p)]` over p.
    /// Gathering the inputs first would build a `[vertices · len, batch · in]` tensor and then
    /// transpose it into the linear layer's rows (154 MB at 5023 vertices, len 15, in 32, batch
    /// 16, written twice forward and twice backward). Here every gather selects whole rows of
    /// `batch · out` values from a 2-D tensor, which burn-flex copies as rows and whose backward
    /// (`select_add`) adds as rows. docs/S2D.md has the measured steps of each formulation.
    ///
    /// # Shapes
    /// - input: `[source_vertices, batch · in]`
    /// - output: `[vertices, batch · out]`
    pub fn forward_vertex_major(&self, x: Tensor<2>, batch: usize) -> Tensor<2> {
        let [sources, width] = x.dims();
        let features = width / batch.max(1);
        let vertices = self.spirals.dims()[0] / self.len;
        let weight = self.linear.weight.val();
        let outputs = weight.dims()[1];
        let rows = x.reshape([sources * batch, features]);
        let spirals: Vec<i64> = self
            .spirals
            .clone()
            .into_data()
            .convert::<i64>()
            .try_to_vec::<i64>()
            .unwrap_or_default();
        let device = self.spirals.device();
        let mut z: Option<Tensor<2>> = None;
        for p in 0..self.len {
            // Position p's contribution of every source vertex, `[sources, batch · out]`: rows
            // of whole samples, so the gather and its backward move batch · out values per row.
            let y = rows
                .clone()
                .matmul(weight.clone().narrow(0, p * features, features))
                .reshape([sources, batch * outputs]);
            let index: Vec<i64> = spirals.iter().skip(p).step_by(self.len).copied().collect();
            let index = Tensor::<1, Int>::from_data(TensorData::new(index, [vertices]), &device);
            let g = y.select(0, index);
            z = Some(match z {
                Some(z) => z + g,
                None => g,
            });
        }
        let mut z = z
            .unwrap_or_else(|| Tensor::zeros([vertices, batch * outputs], &device))
            .reshape([vertices * batch, outputs]);
        if let Some(b) = &self.linear.bias {
            z = z + b.val().reshape([1, outputs]);
        }
        activate(z, self.activation).reshape([vertices, batch * outputs])
    }

    /// Writes the layer as sections `prefix.idx` (`u32 [vertices, len]`), `prefix.w`
    /// (`f32 [out, len·in]`) and `prefix.b` (`f32 [out]`).
    pub fn export(&self, w: &mut SinewWriter, prefix: &str) -> Result<(), WriterError> {
        let idx: Vec<u32> = self
            .spirals
            .clone()
            .into_data()
            .convert::<i64>()
            .try_to_vec::<i64>()
            .unwrap_or_default()
            .into_iter()
            .map(|i| i as u32)
            .collect();
        w.u32s(
            &format!("{prefix}.idx"),
            &[idx.len() / self.len, self.len],
            &idx,
        )?;
        let weight = self.linear.weight.val().transpose();
        let [outputs, inputs] = weight.dims();
        w.f32s(&format!("{prefix}.w"), &[outputs, inputs], &to_vec(weight))?;
        let bias = self
            .linear
            .bias
            .as_ref()
            .map_or_else(|| vec![0.0; outputs], |b| to_vec(b.val()));
        w.f32s(&format!("{prefix}.b"), &[outputs], &bias)?;
        Ok(())
    }
}
