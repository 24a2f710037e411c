//! The fit's forward pass: the fixed tensors of a fit and the actor posed by the fitted
//! variables (AIM eqs. 17–19), at a draw of template points or, in chunks, at every vertex.

use burn::tensor::{Int, Tensor, TensorData};

use crate::fit::baseline::mean_error_mm;
use crate::fit::setup::{Coefficients, FitNet};
use crate::io::performance::Performance;
use crate::training::nn::to_vec;
use crate::training::rotation::rotate_6d;

/// The fixed tensors of a fit.
pub(super) struct Fixed {
    pub(super) rest: Tensor<2>,
    pub(super) k: Tensor<2>,
    pub(super) correctives: Tensor<2>,
    pub(super) normalised: Tensor<2>,
    pub(super) pivot: Tensor<2>,
    /// Per frame, the head and jaw that a zero F_T output means, `[J, 18]`.
    pub(super) start: Tensor<2>,
    pub(super) targets: Tensor<3>,
    pub(super) frames: usize,
    /// Vertices V.
    pub(super) vertices: usize,
    pub(super) shapes: usize,
}

/// The fit at vertices `idx` of every frame.
pub(super) struct Posed {
    /// s*, `[J·P, 3]`.
    pub(super) skin: Tensor<2>,
    /// s*_lbs, `[J·P, 3]`.
    pub(super) lbs: Tensor<2>,
    /// w, `[J·P, M]` (local) or `[J, M]` (global); `None` for zero coefficients.
    pub(super) weights: Option<Tensor<2>>,
}

pub(super) fn pose(
    net: &FitNet,
    fx: &Fixed,
    idx: Tensor<1, Int>,
    coefficients: Coefficients,
) -> Posed {
    let (j, m) = (fx.frames, fx.shapes);
    let p = idx.dims()[0];
    let per_frame = |t: Tensor<2>| {
        let [_, w] = t.dims();
        t.reshape([1, p, w]).repeat_dim(0, j).reshape([j * p, w])
    };
    let per_point = |t: Tensor<2>| {
        let [_, w] = t.dims();
        t.reshape([j, 1, w]).repeat_dim(1, p).reshape([j * p, w])
    };
    let codes = net.codes.val();
    // AIM eq. 18: [T_g, T_b] = F_T(z_j), from the frame's start
    let t = per_point(net.ft.forward(codes.clone()) + fx.start.clone());
    let (head, jaw) = (t.clone().narrow(1, 0, 9), t.narrow(1, 9, 9));
    let s0 = per_frame(fx.rest.clone().select(0, idx.clone()));
    let k = per_frame(fx.k.clone().select(0, idx.clone()));
    let rel = s0.clone() - fx.pivot.clone();
    let moved =
        rotate_6d(jaw.clone().narrow(1, 0, 6), rel) + fx.pivot.clone() + jaw.narrow(1, 6, 3);
    // LBS(s0, T_b, k) = k T_b(s0) + (1 − k) s0
    let lbs = moved * k.clone() + s0 * k.neg().add_scalar(1.0);
    let global =
        |x: Tensor<2>| rotate_6d(head.clone().narrow(1, 0, 6), x) + head.clone().narrow(1, 6, 3);
    let (weights, per_row) = match coefficients {
        Coefficients::Zero => (None, None),
        // AIM eq. 19: w_j = F_W(z_j, c)
        Coefficients::Local => {
            let c = per_frame(fx.normalised.clone().select(0, idx.clone()));
            let w = net.fw.forward(Tensor::cat(vec![per_point(codes), c], 1));
            (Some(w.clone()), Some(w))
        }
        Coefficients::Global => {
            let w = net.fw.forward(codes);
            (Some(w.clone()), Some(per_point(w)))
        }
    };
    let body = match per_row {
        Some(w) => {
            let e = per_frame(fx.correctives.clone().select(0, idx)).reshape([j * p, m, 3]);
            let corr = (w.reshape([j * p, m, 1]) * e)
                .sum_dim(1)
                .reshape([j * p, 3]);
            lbs.clone() + corr
        }
        None => lbs.clone(),
    };
    // AIM eq. 17: s* = T_g(LBS(s0, T_b, k) + Σ w B_e)
    Posed {
        skin: global(body),
        lbs: global(lbs),
        weights,
    }
}

/// Every frame's fitted skin over all vertices (in chunks), in the actor's units, and each
/// frame's mean error in mm.
pub(super) fn evaluate(
    net: &FitNet,
    fx: &Fixed,
    coefficients: Coefficients,
    perf: &Performance,
    unit: crate::io::units::Unit,
    mm: f32,
) -> (Vec<Vec<[f32; 3]>>, Vec<f64>) {
    let v = perf.frames.first().map_or(0, Vec::len);
    let j = fx.frames;
    let device = fx.rest.device();
    let mut meshes = vec![Vec::with_capacity(v); j];
    for start in (0..v).step_by(2048) {
        let n = 2048.min(v - start);
        let idx: Vec<i64> = (start..start + n).map(|i| i as i64).collect();
        let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [n]), &device);
        let skin = to_vec(pose(net, fx, idx, coefficients).skin);
        for (f, rows) in skin.chunks_exact(3 * n).enumerate() {
            meshes[f].extend(
                rows.chunks_exact(3)
                    .map(|p| [p[0] / mm, p[1] / mm, p[2] / mm]),
            );
        }
    }
    let errors = meshes
        .iter()
        .zip(&perf.frames)
        .map(|(a, b)| mean_error_mm(a, b, unit))
        .collect();
    (meshes, errors)
}
