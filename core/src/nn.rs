//! Dense layers, activations (SIREN sine, exact GELU, ELU, ReLU) and small MLPs over weights that
//! stay in the model's bytes.
//!
//! # Summation order
//! A layer output is `act(z)` with `z = dot + bias`, where `dot = Σ_i w_oi · x_i` is
//! [`F32s::dot`]: accumulated from `0.0` in input order with separate multiply and add. The bias is
//! added once, after the dot product. Every implementation that must reproduce these bits (the
//! spiral convolution, golden tests) uses the same order.

use crate::error::{BufferError, FormatError};
use crate::layout::MAX_NETWORK_VALUE;
use crate::tensor::F32s;

/// Most layers an [`Mlp`] can hold.
pub const MAX_LAYERS: usize = 8;

/// An element-wise activation function.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Activation {
    /// `x` unchanged. Code 0.
    Identity,
    /// SIREN's sine, `sin(ω0 · x)` with `libm::sinf`. Code 1; parameter `ω0`.
    Sine {
        /// Frequency factor `ω0` (30 in the SIREN paper's first layer).
        omega0: f32,
    },
    /// Exact GELU, `x · 0.5 · (1 + erf(x · 1/√2))` with `libm::erff`. Code 2.
    Gelu,
    /// ELU, `x` if `x > 0`, else `α · expm1(x)` with `libm::expm1f`. Code 3; parameter `α`.
    Elu {
        /// Scale `α` of the negative branch (1 in the S2D decoder).
        alpha: f32,
    },
    /// ReLU, `0` if `x < 0`, else `x` (so `−0.0` and NaN pass through unchanged). Code 4.
    Relu,
    /// Leaky ReLU, `slope · x` if `x < 0`, else `x` (NaN passes through). Code 5; parameter
    /// `slope`.
    LeakyRelu {
        /// Gradient of the negative branch.
        slope: f32,
    },
}

impl Activation {
    /// The activation stored as `code` with parameter `param` (see each variant for its code).
    ///
    /// Variants without a parameter ignore `param`, which must still be finite.
    ///
    /// # Errors
    /// [`FormatError::UnknownCode`] (argument `code`) for a code above 5;
    /// [`FormatError::NonFinite`] if `param` is
    /// NaN or infinite.
    pub fn from_code(code: u32, param: f32) -> Result<Self, FormatError> {
        let act = match code {
            0 => Self::Identity,
            1 => Self::Sine { omega0: param },
            2 => Self::Gelu,
            3 => Self::Elu { alpha: param },
            4 => Self::Relu,
            5 => Self::LeakyRelu { slope: param },
            _ => return Err(FormatError::unknown_code("code", 0, code)),
        };
        if !param.is_finite() {
            return Err(FormatError::NonFinite);
        }
        Ok(act)
    }

    /// The code of this activation in the format: 0 Identity, 1 Sine, 2 Gelu, 3 Elu, 4 Relu,
    /// 5 LeakyRelu.
    pub const fn code(&self) -> u32 {
        match self {
            Self::Identity => 0,
            Self::Sine { .. } => 1,
            Self::Gelu => 2,
            Self::Elu { .. } => 3,
            Self::Relu => 4,
            Self::LeakyRelu { .. } => 5,
        }
    }

    /// The parameter stored with the code: `ω0` for Sine, `α` for Elu, the slope for LeakyRelu,
    /// `0.0` otherwise.
    pub const fn param(&self) -> f32 {
        match *self {
            Self::Sine { omega0 } => omega0,
            Self::Elu { alpha } => alpha,
            Self::LeakyRelu { slope } => slope,
            Self::Identity | Self::Gelu | Self::Relu => 0.0,
        }
    }

    /// Applies the activation to one pre-activation value `z`.
    #[inline]
    pub fn apply(&self, z: f32) -> f32 {
        match *self {
            Self::Identity => z,
            // SIREN: sin(ω0 (W x + b)), with W x + b already summed into z.
            Self::Sine { omega0 } => libm::sinf(omega0 * z),
            // Evaluated as (z · 0.5) · (1 + erf(z · FRAC_1_SQRT_2)), PyTorch's exact-GELU order.
            Self::Gelu => z * 0.5 * (1.0 + libm::erff(z * core::f32::consts::FRAC_1_SQRT_2)),
            Self::Elu { alpha } => {
                if z > 0.0 {
                    z
                } else {
                    alpha * libm::expm1f(z)
                }
            }
            Self::Relu => {
                if z < 0.0 {
                    0.0
                } else {
                    z
                }
            }
            Self::LeakyRelu { slope } => {
                if z < 0.0 {
                    slope * z
                } else {
                    z
                }
            }
        }
    }
}

/// A fully connected layer `y = act(W x + b)` whose weights stay in the model's bytes.
///
/// # Shapes
/// `weight`: `[outputs, inputs]` row-major; `bias`: `[outputs]`; input `[inputs]`, output
/// `[outputs]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dense<'a> {
    weight: F32s<'a>,
    bias: F32s<'a>,
    inputs: usize,
    outputs: usize,
    activation: Activation,
}

impl<'a> Dense<'a> {
    /// Checks and wraps a layer.
    ///
    /// # Errors
    /// [`FormatError::IncompatibleShapes`] naming `weight` if `inputs` or `outputs` is zero or
    /// `weight` does not hold `outputs × inputs` values, naming `bias` if `bias` does not hold
    /// `outputs` values;
    /// [`FormatError::NonFinite`] if a weight, a bias or the activation parameter is NaN or
    /// infinite.
    pub fn new(
        weight: F32s<'a>,
        bias: F32s<'a>,
        inputs: usize,
        outputs: usize,
        activation: Activation,
    ) -> Result<Self, FormatError> {
        if inputs == 0 || outputs == 0 || Some(weight.len()) != outputs.checked_mul(inputs) {
            return Err(FormatError::incompatible_shapes("weight"));
        }
        if bias.len() != outputs {
            return Err(FormatError::incompatible_shapes("bias"));
        }
        if !all_finite(weight) || !all_finite(bias) || !activation.param().is_finite() {
            return Err(FormatError::NonFinite);
        }
        Ok(Self {
            weight,
            bias,
            inputs,
            outputs,
            activation,
        })
    }

    /// Number of inputs.
    pub fn inputs(&self) -> usize {
        self.inputs
    }

    /// Number of outputs.
    pub fn outputs(&self) -> usize {
        self.outputs
    }

    /// The activation.
    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// The worst-case magnitude of this layer's outputs for inputs of magnitude at most `x`:
    /// per output `Σ |w| · x + |b|` in `f64`, widened by the rounding of the `f32` sum, through
    /// the activation's worst case (docs/FORMAT.md, "Value bounds").
    ///
    /// # Errors
    /// The first output whose bound passes ±[`MAX_NETWORK_VALUE`].
    pub fn bound(&self, x: f64) -> Result<f64, usize> {
        layer_bound(self.weight, self.bias, self.inputs, self.activation, x)
    }

    /// The weights, `[outputs, inputs]` row-major.
    pub fn weight(&self) -> F32s<'a> {
        self.weight
    }

    /// The biases, `[outputs]`.
    pub fn bias(&self) -> F32s<'a> {
        self.bias
    }

    /// `y_o = act(dot(W_o, x) + b_o)` for every output `o` (see the module documentation for the
    /// order of the sums).
    ///
    /// # Shapes
    /// `x`: `[inputs]`; `y`: `[outputs]`.
    ///
    /// # Errors
    /// [`BufferError::Input`] or [`BufferError::Output`] if a length differs.
    pub fn forward(&self, x: &[f32], y: &mut [f32]) -> Result<(), BufferError> {
        if x.len() != self.inputs {
            return Err(BufferError::Input);
        }
        if y.len() != self.outputs {
            return Err(BufferError::Output);
        }
        self.forward_unchecked(x, y);
        Ok(())
    }

    /// [`Dense::forward`] for buffers whose lengths the caller has checked.
    #[inline]
    fn forward_unchecked(&self, x: &[f32], y: &mut [f32]) {
        for (o, (yo, b)) in y.iter_mut().zip(self.bias.iter()).enumerate() {
            let row = self.weight.slice(o * self.inputs, self.inputs);
            // Dot product first (from 0.0, in input order), bias added after.
            let acc = row.dot(x);
            *yo = self.activation.apply(acc + b);
        }
    }
}

/// The unit roundoff of `f32`, 2⁻²⁴: each operation's result is within this fraction of the
/// exact one.
pub(crate) const UNIT_ROUNDOFF: f64 = 5.960_464_477_539_063e-8;

/// `(1 + 2⁻²⁴)^operations`, how far the roundings of that many `f32` additions and products in a
/// row can take a sum beyond its exact value, by squaring in `f64` (whose own rounding, 2⁻⁵³
/// per step, is far below the 2⁻²⁴ being raised).
pub(crate) fn rounding_growth(operations: usize) -> f64 {
    let (mut base, mut k, mut out) = (1.0 + UNIT_ROUNDOFF, operations, 1.0f64);
    while k > 0 {
        if k & 1 == 1 {
            out *= base;
        }
        base *= base;
        k >>= 1;
    }
    out
}

/// The worst-case magnitude of a layer's outputs `act(W x + b)` for inputs of magnitude at most
/// `x` (`weight`: `[outputs, inputs]` row-major), computed in `f64`: per row `Σ |w| · x + |b|`,
/// widened by the rounding a sum of `inputs + 1` terms in `f32` can add, `(1 + 2⁻²⁴)^(inputs + 2)`,
/// then through the activation: sine 1, ELU at least `−|α|`, leaky ReLU `|slope|` times, the
/// others at most the pre-activation (with one more rounding).
///
/// # Errors
/// The first row whose pre-activation, or the activation's product with its parameter, can pass
/// ±[`MAX_NETWORK_VALUE`].
pub(crate) fn layer_bound(
    weight: F32s<'_>,
    bias: F32s<'_>,
    inputs: usize,
    activation: Activation,
    x: f64,
) -> Result<f64, usize> {
    layer_bound_within(weight, bias, inputs, activation, x, MAX_NETWORK_VALUE)
}

/// [`layer_bound`] with another limit than [`MAX_NETWORK_VALUE`] for the outputs.
pub(crate) fn layer_bound_within(
    weight: F32s<'_>,
    bias: F32s<'_>,
    inputs: usize,
    activation: Activation,
    x: f64,
    output_limit: f32,
) -> Result<f64, usize> {
    let limit = f64::from(MAX_NETWORK_VALUE);
    let output_limit = f64::from(output_limit);
    let rounding = rounding_growth(inputs + 2);
    let param = f64::from(libm::fabsf(activation.param()));
    let mut out = 0.0f64;
    for (row, b) in bias.iter().enumerate() {
        let mut sum = 0.0f64;
        for w in weight.slice(row * inputs, inputs).iter() {
            sum += f64::from(libm::fabsf(w));
        }
        let z = (sum * x + f64::from(libm::fabsf(b))) * rounding;
        let y = match activation {
            Activation::Sine { .. } => {
                if z * param > limit {
                    return Err(row);
                }
                1.0
            }
            Activation::Elu { .. } => z.max(param),
            Activation::LeakyRelu { .. } => z * param.max(1.0),
            Activation::Identity | Activation::Gelu | Activation::Relu => z,
        } * (1.0 + 4.0 * UNIT_ROUNDOFF);
        // `!(y <= limit)` also catches a NaN bound (only from an input bound that was NaN).
        if !(z <= limit && y <= limit && y <= output_limit) {
            return Err(row);
        }
        out = out.max(y);
    }
    Ok(out)
}

/// Whether every value of `v` is finite.
pub(crate) fn all_finite(v: F32s<'_>) -> bool {
    v.iter().all(f32::is_finite)
}

/// A chain of up to [`MAX_LAYERS`] dense layers, evaluated with caller-provided scratch memory.
#[derive(Clone, Debug, PartialEq)]
pub struct Mlp<'a> {
    layers: heapless::Vec<Dense<'a>, MAX_LAYERS>,
}

impl<'a> Mlp<'a> {
    /// Checks that the layers chain (each layer's inputs equal the previous layer's outputs).
    ///
    /// # Errors
    /// [`FormatError::IncompatibleShapes`] (argument `layers`) if `layers` is empty or two
    /// neighbours do not chain; [`FormatError::LimitExceeded`] for more than [`MAX_LAYERS`] layers.
    pub fn new(layers: &[Dense<'a>]) -> Result<Self, FormatError> {
        if layers.is_empty() {
            return Err(FormatError::incompatible_shapes("layers"));
        }
        let mut v = heapless::Vec::new();
        v.extend_from_slice(layers)
            .map_err(|()| FormatError::limit_exceeded("layers", layers.len(), MAX_LAYERS))?;
        if layers
            .windows(2)
            .any(|w| matches!(w, [a, b] if a.outputs != b.inputs))
        {
            return Err(FormatError::incompatible_shapes("layers"));
        }
        Ok(Self { layers: v })
    }

    /// The worst-case magnitude of the network's outputs for inputs of magnitude at most
    /// `input`, layer by layer as [`Dense::bound`].
    ///
    /// # Errors
    /// `(layer, row)`: the first layer and output whose bound passes ±[`MAX_NETWORK_VALUE`].
    pub fn bound(&self, input: f64) -> Result<f64, (usize, usize)> {
        self.bound_within(input, MAX_NETWORK_VALUE)
    }

    /// [`Mlp::bound`], the outputs (the last layer's) held to `output_limit` as well.
    ///
    /// # Errors
    /// `(layer, row)`: the first layer and output whose bound passes its limit.
    pub fn bound_within(&self, input: f64, output_limit: f32) -> Result<f64, (usize, usize)> {
        let mut x = input;
        let last = self.layers.len().saturating_sub(1);
        for (layer, d) in self.layers.iter().enumerate() {
            let limit = if layer == last {
                output_limit
            } else {
                MAX_NETWORK_VALUE
            };
            x = layer_bound_within(d.weight, d.bias, d.inputs, d.activation, x, limit)
                .map_err(|row| (layer, row))?;
        }
        Ok(x)
    }

    /// The layers in evaluation order.
    pub fn layers(&self) -> &[Dense<'a>] {
        &self.layers
    }

    /// Width of the input (the first layer's inputs).
    pub fn inputs(&self) -> usize {
        self.layers.first().map_or(0, Dense::inputs)
    }

    /// Width of the output (the last layer's outputs).
    pub fn outputs(&self) -> usize {
        self.layers.last().map_or(0, Dense::outputs)
    }

    /// Scratch length [`Mlp::eval`] needs: two buffers (ping-pong) of the widest hidden layer,
    /// i.e. `2 × max(outputs of every layer but the last)`; 0 for a single layer. The first layer
    /// reads the input and the last writes the output directly.
    pub fn scratch_len(&self) -> usize {
        let hidden = self.layers.len().saturating_sub(1);
        2 * self
            .layers
            .iter()
            .take(hidden)
            .map(Dense::outputs)
            .max()
            .unwrap_or(0)
    }

    /// Evaluates the network on one input vector.
    ///
    /// # Shapes
    /// `input`: `[inputs]`; `output`: `[outputs]`; `scratch`: at least [`Mlp::scratch_len`]
    /// values (contents on entry are ignored, on exit unspecified).
    ///
    /// # Errors
    /// [`BufferError::Input`], [`BufferError::Output`] for wrong lengths,
    /// [`BufferError::Scratch`] if `scratch` is too short.
    pub fn eval(
        &self,
        input: &[f32],
        output: &mut [f32],
        scratch: &mut [f32],
    ) -> Result<(), BufferError> {
        if input.len() != self.inputs() {
            return Err(BufferError::Input);
        }
        if output.len() != self.outputs() {
            return Err(BufferError::Output);
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch);
        }
        self.eval_unchecked(input, output, scratch);
        Ok(())
    }

    /// Evaluates the network on each row of a batch, reusing the same scratch.
    ///
    /// # Shapes
    /// `input`: `[n, inputs]` row-major; `output`: `[n, outputs]`; `scratch` as in [`Mlp::eval`].
    ///
    /// # Errors
    /// [`BufferError::Input`] if `input.len()` is not a multiple of `inputs`,
    /// [`BufferError::Output`] if `output.len() != n × outputs`, [`BufferError::Scratch`] if
    /// `scratch` is too short.
    pub fn eval_batch(
        &self,
        input: &[f32],
        output: &mut [f32],
        scratch: &mut [f32],
    ) -> Result<(), BufferError> {
        let (ni, no) = (self.inputs(), self.outputs());
        // `new` rejects empty MLPs and zero-width layers, so `ni` and `no` are positive.
        if ni == 0 || no == 0 || !input.len().is_multiple_of(ni) {
            return Err(BufferError::Input);
        }
        if Some(output.len()) != (input.len() / ni).checked_mul(no) {
            return Err(BufferError::Output);
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch);
        }
        for (x, y) in input.chunks_exact(ni).zip(output.chunks_exact_mut(no)) {
            self.eval_unchecked(x, y, scratch);
        }
        Ok(())
    }

    /// Ping-pong evaluation; the caller has checked every length.
    fn eval_unchecked(&self, input: &[f32], output: &mut [f32], scratch: &mut [f32]) {
        let half = self.scratch_len() / 2;
        let (mut src, mut dst) = scratch.split_at_mut(half.min(scratch.len()));
        let last = self.layers.len().saturating_sub(1);
        for (i, layer) in self.layers.iter().enumerate() {
            let x: &[f32] = if i == 0 {
                input
            } else {
                src.get(..layer.inputs).unwrap_or(&[])
            };
            if i == last {
                layer.forward_unchecked(x, output);
            } else {
                let y = dst.get_mut(..layer.outputs).unwrap_or(&mut []);
                layer.forward_unchecked(x, y);
                core::mem::swap(&mut src, &mut dst);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn bytes(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn f(b: &[u8]) -> F32s<'_> {
        F32s::new(b).unwrap()
    }

    #[test]
    fn activation_codes_round_trip() {
        for a in [
            Activation::Identity,
            Activation::Sine { omega0: 30.0 },
            Activation::Gelu,
            Activation::Elu { alpha: 1.0 },
            Activation::Relu,
            Activation::LeakyRelu { slope: 0.2 },
        ] {
            assert_eq!(Activation::from_code(a.code(), a.param()), Ok(a));
        }
        assert_eq!(
            Activation::from_code(6, 0.0),
            Err(FormatError::unknown_code("code", 0, 6))
        );
        assert_eq!(
            Activation::from_code(1, f32::NAN),
            Err(FormatError::NonFinite)
        );
        assert_eq!(
            Activation::from_code(3, f32::INFINITY),
            Err(FormatError::NonFinite)
        );
        assert_eq!(
            Activation::from_code(0, f32::NAN),
            Err(FormatError::NonFinite)
        );
        assert_eq!(Activation::from_code(2, 7.0), Ok(Activation::Gelu));
    }

    #[test]
    fn activation_values() {
        assert_eq!(Activation::Identity.apply(-3.5), -3.5);
        // sin(2 · 0) = 0; sin(ω0 · z) with ω0 z = π/2 is 1 to f32 precision.
        assert_eq!(Activation::Sine { omega0: 2.0 }.apply(0.0), 0.0);
        assert_eq!(
            Activation::Sine { omega0: 2.0 }.apply(core::f32::consts::FRAC_PI_4),
            libm::sinf(core::f32::consts::FRAC_PI_2)
        );
        assert_eq!(
            Activation::Sine { omega0: 2.0 }.apply(core::f32::consts::FRAC_PI_4),
            1.0
        );
        // GELU(0) = 0; GELU(x) → x for large x (erf(10/√2) = 1 in f32); GELU(−10) = −5 · (1 − 1) = 0.
        assert_eq!(Activation::Gelu.apply(0.0), 0.0);
        assert_eq!(Activation::Gelu.apply(10.0), 10.0);
        assert_eq!(Activation::Gelu.apply(-10.0), 0.0);
        // GELU(1) = 0.5 · (1 + erf(0.70710677)) = 0.5 · 1.6826895 = 0.8413447 (Φ(1) = 0.841344746…).
        assert!((Activation::Gelu.apply(1.0) - 0.841_344_7).abs() <= 3e-7);
        // ELU: positive passes; α · (e^−1 − 1) = 2 · (−0.63212055) = −1.2642411; large negative → −α.
        let elu = Activation::Elu { alpha: 2.0 };
        assert_eq!(elu.apply(3.0), 3.0);
        assert_eq!(elu.apply(0.0), 0.0);
        assert_eq!(elu.apply(-1.0), 2.0 * libm::expm1f(-1.0));
        assert!((elu.apply(-1.0) + 1.264_241_1).abs() <= 3e-7);
        assert_eq!(elu.apply(-100.0), -2.0);
        assert_eq!(Activation::Relu.apply(-2.0), 0.0);
        assert_eq!(Activation::Relu.apply(2.5), 2.5);
        assert!(Activation::Relu.apply(f32::NAN).is_nan());
        let leaky = Activation::LeakyRelu { slope: 0.25 };
        assert_eq!(leaky.apply(-2.0), -0.5);
        assert_eq!(leaky.apply(2.5), 2.5);
        assert!(leaky.apply(f32::NAN).is_nan());
    }

    #[test]
    fn dense_forward_hand_computed() {
        // W = [[1, 2], [−1, 0.5]], b = [0.5, −1], x = [3, 4]
        // y0 = (1·3 + 2·4) + 0.5 = 11.5; y1 = (−3 + 2) − 1 = −2
        let w = bytes(&[1.0, 2.0, -1.0, 0.5]);
        let b = bytes(&[0.5, -1.0]);
        let d = Dense::new(f(&w), f(&b), 2, 2, Activation::Identity).unwrap();
        let mut y = [0.0; 2];
        d.forward(&[3.0, 4.0], &mut y).unwrap();
        assert_eq!(y, [11.5, -2.0]);
        let relu = Dense::new(f(&w), f(&b), 2, 2, Activation::Relu).unwrap();
        relu.forward(&[3.0, 4.0], &mut y).unwrap();
        assert_eq!(y, [11.5, 0.0]);
        assert_eq!(d.forward(&[3.0], &mut y), Err(BufferError::Input));
        assert_eq!(
            d.forward(&[3.0, 4.0], &mut y[..1]),
            Err(BufferError::Output)
        );
    }

    #[test]
    fn bias_is_added_after_the_dot_product() {
        // x = [1e8, 1], w = [1, 1], b = −1e8.
        // dot first: (0 + 1e8) + 1 = 1e8 (1 is below half an ulp of 1e8, which is 8), then
        // + (−1e8) = 0. Adding the bias first would give (−1e8 + 1e8) + 1 = 1.
        let w = bytes(&[1.0, 1.0]);
        let b = bytes(&[-1e8]);
        let d = Dense::new(f(&w), f(&b), 2, 1, Activation::Identity).unwrap();
        let mut y = [9.0];
        d.forward(&[1e8, 1.0], &mut y).unwrap();
        assert_eq!(y, [0.0]);
    }

    #[test]
    fn siren_layer_is_dense_with_sine() {
        // z = 0.25 · 2 + 0.0 = 0.5; sin(30 · 0.5) = sin(15)
        let w = bytes(&[0.25]);
        let b = bytes(&[0.0]);
        let d = Dense::new(f(&w), f(&b), 1, 1, Activation::Sine { omega0: 30.0 }).unwrap();
        let mut y = [0.0];
        d.forward(&[2.0], &mut y).unwrap();
        assert_eq!(y, [libm::sinf(15.0)]);
        // sin(15) = 0.650287840…
        assert!((y[0] - 0.650_287_8).abs() < 1e-6);
    }

    #[test]
    fn dense_validation() {
        let w = bytes(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let b = bytes(&[0.0, 0.0]);
        let id = Activation::Identity;
        assert!(Dense::new(f(&w), f(&b), 3, 2, id).is_ok());
        let (weight, bias) = (
            Err(FormatError::incompatible_shapes("weight")),
            Err(FormatError::incompatible_shapes("bias")),
        );
        assert_eq!(Dense::new(f(&w), f(&b), 2, 2, id), weight);
        assert_eq!(Dense::new(f(&w), f(&b[..4]), 3, 2, id), bias);
        assert_eq!(Dense::new(F32s::empty(), F32s::empty(), 0, 0, id), weight);
        assert_eq!(Dense::new(f(&w), f(&b), usize::MAX, 2, id), weight);
        let bad = bytes(&[1.0, f32::NAN, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(
            Dense::new(f(&bad), f(&b), 3, 2, id),
            Err(FormatError::NonFinite)
        );
        let badb = bytes(&[0.0, f32::NEG_INFINITY]);
        assert_eq!(
            Dense::new(f(&w), f(&badb), 3, 2, id),
            Err(FormatError::NonFinite)
        );
        let sine = Activation::Sine { omega0: f32::NAN };
        assert_eq!(
            Dense::new(f(&w), f(&b), 3, 2, sine),
            Err(FormatError::NonFinite)
        );
    }

    #[test]
    fn mlp_chains_and_ping_pongs() {
        // L0: 2 → 3, W0 = [[1, 0], [0, 1], [1, 1]], b0 = [0, 0, −10], ReLU
        // L1: 3 → 2, W1 = [[1, 1, 1], [1, −1, 0]], b1 = [1, 0], Identity
        // L2: 2 → 1, W2 = [[2, 1]], b2 = [0.5], Identity
        // x = [2, 3]: h0 = relu([2, 3, 5 − 10]) = [2, 3, 0]
        //             h1 = [2 + 3 + 0 + 1, 2 − 3 + 0 + 0] = [6, −1]
        //             y  = [2·6 + 1·(−1) + 0.5] = [11.5]
        let w0 = bytes(&[1.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
        let b0 = bytes(&[0.0, 0.0, -10.0]);
        let w1 = bytes(&[1.0, 1.0, 1.0, 1.0, -1.0, 0.0]);
        let b1 = bytes(&[1.0, 0.0]);
        let w2 = bytes(&[2.0, 1.0]);
        let b2 = bytes(&[0.5]);
        let l0 = Dense::new(f(&w0), f(&b0), 2, 3, Activation::Relu).unwrap();
        let l1 = Dense::new(f(&w1), f(&b1), 3, 2, Activation::Identity).unwrap();
        let l2 = Dense::new(f(&w2), f(&b2), 2, 1, Activation::Identity).unwrap();
        let mlp = Mlp::new(&[l0, l1, l2]).unwrap();
        assert_eq!((mlp.inputs(), mlp.outputs(), mlp.scratch_len()), (2, 1, 6));
        let mut scratch = [f32::NAN; 6];
        let mut y = [0.0];
        mlp.eval(&[2.0, 3.0], &mut y, &mut scratch).unwrap();
        assert_eq!(y, [11.5]);
        // A longer scratch is fine, a shorter one is refused.
        let mut big = [0.0; 10];
        mlp.eval(&[2.0, 3.0], &mut y, &mut big).unwrap();
        assert_eq!(y, [11.5]);
        assert_eq!(
            mlp.eval(&[2.0, 3.0], &mut y, &mut scratch[..5]),
            Err(BufferError::Scratch)
        );
        assert_eq!(
            mlp.eval(&[2.0], &mut y, &mut scratch),
            Err(BufferError::Input)
        );
        assert_eq!(
            mlp.eval(&[2.0, 3.0], &mut [], &mut scratch),
            Err(BufferError::Output)
        );

        // Batch: second row x = [0, 1]: h0 = [0, 1, 0]; h1 = [2, −1]; y = [4 − 1 + 0.5] = [3.5]
        let mut yb = [0.0; 2];
        mlp.eval_batch(&[2.0, 3.0, 0.0, 1.0], &mut yb, &mut scratch)
            .unwrap();
        assert_eq!(yb, [11.5, 3.5]);
        assert_eq!(
            mlp.eval_batch(&[2.0, 3.0, 0.0], &mut yb, &mut scratch),
            Err(BufferError::Input)
        );
        assert_eq!(
            mlp.eval_batch(&[2.0, 3.0], &mut yb, &mut scratch),
            Err(BufferError::Output)
        );
        assert_eq!(mlp.eval_batch(&[], &mut [], &mut scratch), Ok(()));

        // A single layer needs no scratch.
        let one = Mlp::new(&[l2]).unwrap();
        assert_eq!(one.scratch_len(), 0);
        one.eval(&[6.0, -1.0], &mut y, &mut []).unwrap();
        assert_eq!(y, [11.5]);
    }

    #[test]
    fn mlp_validation() {
        let w = bytes(&[1.0; 4]);
        let b = bytes(&[0.0; 2]);
        let l = Dense::new(f(&w), f(&b), 2, 2, Activation::Identity).unwrap();
        let l21 = Dense::new(f(&w[..8]), f(&b[..4]), 2, 1, Activation::Identity).unwrap();
        let layers = Err(FormatError::incompatible_shapes("layers"));
        assert_eq!(Mlp::new(&[]), layers);
        assert_eq!(Mlp::new(&[l21, l]), layers);
        assert!(Mlp::new(&[l; MAX_LAYERS]).is_ok());
        assert_eq!(
            Mlp::new(&[l; MAX_LAYERS + 1]),
            Err(FormatError::limit_exceeded(
                "layers",
                MAX_LAYERS + 1,
                MAX_LAYERS
            ))
        );
    }
}
