//! SIREN's activation, sin(ω·x), as one burn operation with a vectorised CPU kernel.
//!
//! Stock burn 0.22 evaluates `sin` on the flex backend one element at a time through the C
//! library, and its backward pass evaluates `cos` the same way: together about 45 % of an AIM
//! training step (`docs/BENCHMARKS.md`). Here the forward pass computes sine and cosine together
//! in one branch-free pass that the compiler vectorises, spread over the rayon pool, and keeps
//! ω·cos(ω·x) for the backward pass, which is then a single multiplication.
//!
//! The operation is a burn backend extension implemented for the flex backend and for autodiff
//! over it; [`siren_sine`] routes every other backend (ndarray, wgpu, ...) to burn's own `sin`,
//! so GPU training keeps its on-device kernels.
//!
//! Accuracy: Cody–Waite reduction by π/2 in three parts and the Cephes single-precision
//! polynomials on [−π/4, π/4], about 1e-7 absolute from the true values (a unit test checks it
//! against f64). Arguments beyond ±8192, and non-finite ones, go through the standard library. This code only
//! trains: the playback core evaluates sine with `libm` and is unaffected.

use burn::backend::autodiff::Autodiff;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::CheckpointStrategy;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::backend::flex::FlexTensor;
use burn::backend::ops::FloatTensorOps;
use burn::backend::tensor::FloatTensor;
use burn::backend::{Backend, DType, Dispatch, Flex, TensorMetadata, backend_extension};
use burn::tensor::Tensor;
use rayon::prelude::*;

/// sin(ω·x) for a SIREN layer: burn's `sin` on GPU backends, the vectorised kernel on flex.
pub fn siren_sine<const D: usize>(x: Tensor<D>, omega: f32) -> Tensor<D> {
    if crate::training::backend::on_flex(&x) {
        Tensor::from_dispatch(Dispatch::scaled_sin(x.into_dispatch(), omega))
    } else {
        x.mul_scalar(omega).sin()
    }
}

/// The backend extension behind [`siren_sine`].
#[backend_extension(Flex, Autodiff)]
pub trait SineOps: Backend {
    /// sin(ω·x), element-wise.
    fn scaled_sin(x: FloatTensor<Self>, omega: f32) -> FloatTensor<Self>;
    /// (sin(ω·x), ω·cos(ω·x)): the value and its derivative with respect to x.
    fn scaled_sin_grad(x: FloatTensor<Self>, omega: f32) -> (FloatTensor<Self>, FloatTensor<Self>);
}

impl SineOps for Flex {
    fn scaled_sin(x: FlexTensor, omega: f32) -> FlexTensor {
        if x.dtype() != DType::F32 {
            return Flex::float_sin(Flex::float_mul_scalar(x, omega.into()));
        }
        let x = contiguous(x);
        let values = x.as_slice::<f32>().unwrap_or_default();
        let mut sin = FlexTensor::empty(x.shape(), DType::F32);
        sin_cos_into(values, omega, sin.storage_mut::<f32>(), None);
        sin
    }

    fn scaled_sin_grad(x: FlexTensor, omega: f32) -> (FlexTensor, FlexTensor) {
        if x.dtype() != DType::F32 {
            let scaled = Flex::float_mul_scalar(x, omega.into());
            let cos = Flex::float_mul_scalar(Flex::float_cos(scaled.clone()), omega.into());
            return (Flex::float_sin(scaled), cos);
        }
        let x = contiguous(x);
        let values = x.as_slice::<f32>().unwrap_or_default();
        let mut sin = FlexTensor::empty(x.shape(), DType::F32);
        let mut cos = FlexTensor::empty(x.shape(), DType::F32);
        sin_cos_into(
            values,
            omega,
            sin.storage_mut::<f32>(),
            Some(cos.storage_mut::<f32>()),
        );
        (sin, cos)
    }
}

fn contiguous(x: FlexTensor) -> FlexTensor {
    if x.as_slice::<f32>().is_some() {
        x
    } else {
        x.to_contiguous()
    }
}

impl<B: Backend + SineOps, C: CheckpointStrategy> SineOps for Autodiff<B, C> {
    fn scaled_sin(x: FloatTensor<Self>, omega: f32) -> FloatTensor<Self> {
        /// The backward pass of sin(ω·x): the incoming gradient times the stored ω·cos(ω·x).
        #[derive(Debug)]
        struct ScaledSin;

        impl<B: Backend> Backward<B, 1> for ScaledSin {
            type State = B::FloatTensorPrimitive;

            fn backward(
                self,
                ops: Ops<Self::State, 1>,
                grads: &mut Gradients,
                _checkpointer: &mut Checkpointer,
            ) {
                let derivative = ops.state;
                unary::<B, _>(ops.parents, ops.node, grads, |grad| {
                    B::float_mul(grad, derivative)
                });
            }
        }

        match ScaledSin
            .prepare::<C>([x.node()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => {
                let (sin, derivative) = B::scaled_sin_grad(x.into_primitive(), omega);
                prep.finish(derivative, sin)
            }
            OpsKind::UnTracked(prep) => prep.finish(B::scaled_sin(x.into_primitive(), omega)),
        }
    }

    fn scaled_sin_grad(x: FloatTensor<Self>, omega: f32) -> (FloatTensor<Self>, FloatTensor<Self>) {
        // Only reached if a caller asks an autodiff tensor for the pair directly; the derivative
        // is then an ordinary differentiable expression.
        let scaled = Self::float_mul_scalar(x, omega.into());
        let cos = Self::float_mul_scalar(Self::float_cos(scaled.clone()), omega.into());
        (Self::scaled_sin(scaled, 1.0), cos)
    }
}

/// Elements per parallel task: large enough to amortise scheduling, small enough to share out a
/// 4096×256 activation over the pool.
const CHUNK: usize = 16 * 1024;

/// Beyond this |ω·x| the three-part reduction loses exactness (k·P2 needs k < 2^13); such rare
/// arguments, and non-finite ones, are evaluated by the standard library.
const LIMIT: f32 = 8192.0;

/// Writes sin(ω·x) into `sin` and, when given, ω·cos(ω·x) into `cos`.
fn sin_cos_into(x: &[f32], omega: f32, sin: &mut [f32], cos: Option<&mut [f32]>) {
    match cos {
        Some(cos) => x
            .par_chunks(CHUNK)
            .zip(sin.par_chunks_mut(CHUNK))
            .zip(cos.par_chunks_mut(CHUNK))
            .for_each(|((x, s), c)| sin_cos_chunk(x, omega, s, c)),
        None => x
            .par_chunks(CHUNK)
            .zip(sin.par_chunks_mut(CHUNK))
            .for_each(|(x, s)| {
                let mut scratch = [0.0f32; CHUNK];
                sin_cos_chunk(x, omega, s, &mut scratch[..x.len()]);
            }),
    }
}

fn sin_cos_chunk(x: &[f32], omega: f32, sin: &mut [f32], cos: &mut [f32]) {
    for ((&x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
        let (sv, cv) = sin_cos(omega * x);
        *s = sv;
        *c = omega * cv;
    }
    let outside = x
        .iter()
        .fold(false, |any, &x| any | !within_limit(omega * x));
    if outside {
        for ((&x, s), c) in x.iter().zip(sin.iter_mut()).zip(cos.iter_mut()) {
            let v = omega * x;
            if !within_limit(v) {
                *s = v.sin();
                *c = omega * v.cos();
            }
        }
    }
}

/// Whether the fast path covers `v`: false beyond ±[`LIMIT`] and for NaN.
#[inline(always)]
fn within_limit(v: f32) -> bool {
    v.abs() <= LIMIT
}

/// sin(v) and cos(v) for |v| ≤ [`LIMIT`], branch-free so that loops over it vectorise.
#[inline(always)]
fn sin_cos(v: f32) -> (f32, f32) {
    // Adding 1.5·2^23 rounds v·2/π to the nearest integer k and leaves k's low bits in the
    // mantissa (exact for |k| < 2^22).
    const SHIFTER: f32 = 12_582_912.0;
    // π/2 split so that k·P1 and k·P2 are exact for |k| < 2^13.
    const P1: f32 = 1.570_312_5;
    const P2: f32 = 4.837_513e-4;
    const P3: f32 = 7.549_79e-8;
    let y = v * core::f32::consts::FRAC_2_PI + SHIFTER;
    let quadrant = y.to_bits();
    let k = y - SHIFTER;
    let r = ((v - k * P1) - k * P2) - k * P3;
    let r2 = r * r;
    let s = r + r * r2 * (-1.666_665_5e-1 + r2 * (8.332_161e-3 + r2 * -1.951_529_6e-4));
    let c =
        1.0 - 0.5 * r2 + r2 * r2 * (4.166_664_6e-2 + r2 * (-1.388_731_6e-3 + r2 * 2.443_315_7e-5));
    let (a, b) = if quadrant & 1 != 0 { (c, s) } else { (s, c) };
    let sin = if quadrant & 2 != 0 { -a } else { a };
    let cos = if quadrant.wrapping_add(1) & 2 != 0 {
        -b
    } else {
        b
    };
    (sin, cos)
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Device;

    #[test]
    fn kernel_matches_f64_sine_and_cosine() {
        // Every quadrant, both signs, the exact-reduction edge and the libm fallback.
        let mut xs: Vec<f32> = (-200_000..=200_000).map(|i| i as f32 * 0.0437).collect();
        xs.extend([
            0.0,
            -0.0,
            1e-30,
            8191.9,
            8192.1,
            -9000.0,
            1e6,
            -3.4e38,
            f32::MIN_POSITIVE,
        ]);
        let mut s = vec![0.0; xs.len()];
        let mut c = vec![0.0; xs.len()];
        sin_cos_into(&xs, 1.0, &mut s, Some(&mut c));
        for ((&x, &s), &c) in xs.iter().zip(&s).zip(&c) {
            let (es, ec) = (f64::from(x).sin(), f64::from(x).cos());
            assert!(
                (f64::from(s) - es).abs() < 2e-7,
                "sin({x}) = {s}, want {es}"
            );
            assert!(
                (f64::from(c) - ec).abs() < 2e-7,
                "cos({x}) = {c}, want {ec}"
            );
        }
        let mut nan = [0.0f32];
        sin_cos_into(&[f32::NAN], 1.0, &mut nan, None);
        assert!(nan[0].is_nan());
    }

    #[test]
    fn forward_and_gradient_match_burn_on_flex() {
        let device = Device::flex().autodiff();
        let values: Vec<f32> = (0..3 * 70_001)
            .map(|i| ((i * 7919) % 2001) as f32 * 1e-3 - 1.0)
            .collect();
        let make =
            || crate::training::tensor::tensor(values.clone(), [3, 70_001], &device).require_grad();
        let omega = 30.0;

        let x = make();
        let ours = siren_sine(x.clone(), omega);
        let grad_ours = ours
            .clone()
            .mul(ours.clone())
            .sum()
            .add(ours.clone().sum())
            .backward();
        let gx = x.grad(&grad_ours).expect("gradient reaches x");

        let y = make();
        let stock = y.clone().mul_scalar(omega).sin();
        let grad_stock = stock
            .clone()
            .mul(stock.clone())
            .sum()
            .add(stock.clone().sum())
            .backward();
        let gy = y.grad(&grad_stock).expect("gradient reaches y");

        let (a, b) = (
            crate::training::tensor::to_vec(ours),
            crate::training::tensor::to_vec(stock),
        );
        let worst = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 5e-7, "forward differs from burn's sin by {worst}");
        let (a, b) = (
            crate::training::tensor::to_vec(gx),
            crate::training::tensor::to_vec(gy),
        );
        let worst = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0f32, f32::max);
        // d/dx (s² + s) = (2s + 1)·ω·cos: magnitudes up to 90.
        assert!(worst < 1e-4, "gradient differs from burn's by {worst}");
    }

    #[test]
    fn untracked_and_non_flex_paths_agree() {
        let values: Vec<f32> = (0..1000).map(|i| i as f32 * 0.01 - 5.0).collect();
        let flex = crate::training::tensor::to_vec(siren_sine(
            crate::training::tensor::tensor(values.clone(), [10, 100], &Device::flex()),
            3.0,
        ));
        for (v, s) in values.iter().zip(&flex) {
            // The argument is rounded to f32 first, as burn's `mul_scalar` rounds it.
            assert!((f64::from(*s) - f64::from(3.0 * v).sin()).abs() < 2e-7);
        }
        #[cfg(feature = "ndarray")]
        {
            let nd = crate::training::tensor::to_vec(siren_sine(
                crate::training::tensor::tensor(
                    values,
                    [10, 100],
                    &crate::training::backend::Backend::Ndarray
                        .device(0)
                        .expect("ndarray device"),
                ),
                3.0,
            ));
            for (a, b) in flex.iter().zip(&nd) {
                assert!((a - b).abs() < 5e-7);
            }
        }
    }
}
