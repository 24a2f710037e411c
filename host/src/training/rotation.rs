//! Rotations in burn: the continuous 6D representation (Zhou et al. 2019) applied to row
//! vectors, shared by AIM training (the jaw) and fitting (head and jaw).

use burn::tensor::Tensor;

/// Rotates `v` by the rotation whose 6D representation (Zhou et al. 2019) is `r6`: columns
/// b1 = a1/|a1|, b2 = normalise(a2 − (b1·a2) b1), b3 = b1 × b2; R v = b1 v_x + b2 v_y + b3 v_z.
///
/// # Shapes
/// - `r6`: `[B, 6]`, `v`: `[B, 3]`, output `[B, 3]`
pub fn rotate_6d(r6: Tensor<2>, v: Tensor<2>) -> Tensor<2> {
    let unit = |t: Tensor<2>| {
        let n = t.clone().square().sum_dim(1).add_scalar(1e-12).sqrt();
        t / n
    };
    let b1 = unit(r6.clone().narrow(1, 0, 3));
    let a2 = r6.narrow(1, 3, 3);
    let b2 = unit(a2.clone() - b1.clone() * (b1.clone() * a2).sum_dim(1));
    let b3 = cross(b1.clone(), b2.clone());
    b1 * v.clone().narrow(1, 0, 1) + b2 * v.clone().narrow(1, 1, 1) + b3 * v.narrow(1, 2, 1)
}

/// Row-wise cross product of `[B, 3]` tensors.
pub fn cross(a: Tensor<2>, b: Tensor<2>) -> Tensor<2> {
    let c = |t: &Tensor<2>, i| t.clone().narrow(1, i, 1);
    let x = c(&a, 1) * c(&b, 2) - c(&a, 2) * c(&b, 1);
    let y = c(&a, 2) * c(&b, 0) - c(&a, 0) * c(&b, 2);
    let z = c(&a, 0) * c(&b, 1) - c(&a, 1) * c(&b, 0);
    Tensor::cat(vec![x, y, z], 1)
}
