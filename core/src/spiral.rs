//! Spiral convolution (Bouritsas et al. 2019, Neural3DMM; used by the S2D decoder).
//!
//! For each output vertex the features of the vertices on its spiral are concatenated
//! spiral-position-major (position 0's `in_f` features, then position 1's, …) and passed through
//! one linear layer. See `shared/notes/s2d-reference.md` for the reference configuration,
//! including the dummy vertex whose row is zeroed after each stage ([`zero_row`]).

use crate::error::{BufferError, FormatError};
use crate::nn::{Activation, all_finite};
use crate::tensor::{F32s, U32s};

/// Validated spiral indices: one spiral of `len` source-vertex indices per output vertex.
///
/// # Shapes
/// `indices`: `[n_vertices, len]` row-major, every value `< n_source_vertices`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Spirals<'a> {
    indices: U32s<'a>,
    n_vertices: usize,
    len: usize,
    n_source_vertices: usize,
}

impl<'a> Spirals<'a> {
    /// Checks and wraps spiral indices.
    ///
    /// # Errors
    /// [`FormatError::IncompatibleShapes`] (argument `indices`) if `len` is zero or `indices`
    /// does not hold `n_vertices × len` values; [`FormatError::IndexOutOfRange`] (argument `indices`, the
    /// index's position) if an index is `>= n_source_vertices`.
    pub fn new(
        indices: U32s<'a>,
        n_vertices: usize,
        len: usize,
        n_source_vertices: usize,
    ) -> Result<Self, FormatError> {
        if len == 0 || Some(indices.len()) != n_vertices.checked_mul(len) {
            return Err(FormatError::incompatible_shapes("indices"));
        }
        if let Some(at) = indices.iter().position(|i| i as usize >= n_source_vertices) {
            return Err(FormatError::index_out_of_range("indices", at));
        }
        Ok(Self {
            indices,
            n_vertices,
            len,
            n_source_vertices,
        })
    }

    /// Number of spirals (output vertices).
    pub fn n_vertices(&self) -> usize {
        self.n_vertices
    }

    /// Number of indices per spiral.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether there are no spirals.
    pub fn is_empty(&self) -> bool {
        self.n_vertices == 0
    }

    /// Number of source vertices the indices refer to.
    pub fn n_source_vertices(&self) -> usize {
        self.n_source_vertices
    }

    /// The spiral of output vertex `v` (empty past the end).
    pub fn spiral(&self, v: usize) -> U32s<'a> {
        self.indices.slice(v.saturating_mul(self.len), self.len)
    }
}

/// A spiral convolution layer: gather along each spiral, then one dense layer and an activation.
///
/// # Shapes
/// `weight`: `[out_f, len · in_f]` row-major, column `j = p · in_f + c` multiplying feature `c`
/// of spiral position `p`; `bias`: `[out_f]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpiralConv<'a> {
    spirals: Spirals<'a>,
    weight: F32s<'a>,
    bias: F32s<'a>,
    in_f: usize,
    out_f: usize,
    activation: Activation,
}

impl<'a> SpiralConv<'a> {
    /// Checks and wraps a spiral convolution.
    ///
    /// # Errors
    /// [`FormatError::IncompatibleShapes`] naming `weight` if `in_f` or `out_f` is zero or
    /// `weight` does not hold `out_f × len × in_f` values, naming `bias` if `bias` does not hold
    /// `out_f` values; [`FormatError::NonFinite`] if a weight, a bias
    /// or the activation parameter is NaN or infinite.
    pub fn new(
        spirals: Spirals<'a>,
        weight: F32s<'a>,
        bias: F32s<'a>,
        in_f: usize,
        out_f: usize,
        activation: Activation,
    ) -> Result<Self, FormatError> {
        let width = spirals.len.checked_mul(in_f);
        let weights = width.and_then(|w| w.checked_mul(out_f));
        if in_f == 0 || out_f == 0 || Some(weight.len()) != weights {
            return Err(FormatError::incompatible_shapes("weight"));
        }
        if bias.len() != out_f {
            return Err(FormatError::incompatible_shapes("bias"));
        }
        if !all_finite(weight) || !all_finite(bias) || !activation.param().is_finite() {
            return Err(FormatError::NonFinite);
        }
        Ok(Self {
            spirals,
            weight,
            bias,
            in_f,
            out_f,
            activation,
        })
    }

    /// The worst-case magnitude of the outputs for inputs of magnitude at most `x`: each output
    /// is a [`crate::nn::Dense`] row over the gathered spiral, bounded the same way
    /// ([`crate::nn::Dense::bound`]).
    ///
    /// # Errors
    /// The first output feature whose bound passes ±[`crate::layout::MAX_NETWORK_VALUE`].
    pub fn bound(&self, x: f64) -> Result<f64, usize> {
        let width = self.spirals.len * self.in_f;
        crate::nn::layer_bound(self.weight, self.bias, width, self.activation, x)
    }

    /// The spirals.
    pub fn spirals(&self) -> Spirals<'a> {
        self.spirals
    }

    /// Output features per vertex.
    pub fn out_features(&self) -> usize {
        self.out_f
    }

    /// The activation.
    pub fn activation(&self) -> Activation {
        self.activation
    }

    /// `out[v, o] = act(Σ_j W[o, j] · g_v[j] + b[o])`, where `g_v` is the spiral-position-major
    /// concatenation of `x[s(v, p), 0..in_f]` for `p = 0..len`.
    ///
    /// The sum runs over `j = 0..len · in_f` in order from `0.0` with separate multiply and add,
    /// then the bias is added: the same bits as [`crate::nn::Dense`] applied to the gathered
    /// vector, without materialising it. `out` itself is the accumulator.
    ///
    /// # Shapes
    /// `x`: `[n_source_vertices, in_f]` row-major; `out`: `[n_vertices, out_f]` row-major.
    ///
    /// # Errors
    /// [`BufferError::Input`] if `x.len() != n_source_vertices × in_f`;
    /// [`BufferError::Output`] if `out.len() != n_vertices × out_f`.
    pub fn forward(&self, x: &[f32], out: &mut [f32]) -> Result<(), BufferError> {
        if Some(x.len()) != self.spirals.n_source_vertices.checked_mul(self.in_f) {
            return Err(BufferError::Input);
        }
        if Some(out.len()) != self.spirals.n_vertices.checked_mul(self.out_f) {
            return Err(BufferError::Output);
        }
        // Neural3DMM spiral conv (S2D-Dec): out_v = act(W · ‖_p x[s(v, p)] + b)
        let in_f = self.in_f;
        let width = self.spirals.len * in_f;
        for (v, out_row) in out.chunks_exact_mut(self.out_f).enumerate() {
            out_row.fill(0.0);
            // Positions in order, and within a position features in order: for each output the
            // accumulation visits j = p · in_f + c in increasing order. Four outputs advance
            // together (their sums are independent, so the additions overlap instead of each
            // waiting on the previous one); the order within each output's sum is unchanged.
            for (p, s) in self.spirals.spiral(v).iter().enumerate() {
                let s = s as usize;
                // s < n_source_vertices (validated), so the row lies inside x.
                let xs = x.get(s * in_f..s * in_f + in_f).unwrap_or(&[]);
                let weight = self.weight;
                let row = move |o: usize| {
                    weight
                        .slice(o * width + p * in_f, in_f)
                        .as_bytes()
                        .chunks_exact(4)
                        .map(|b| b.try_into().map_or(0.0, f32::from_le_bytes))
                };
                let mut quads = out_row.chunks_exact_mut(4);
                for (q, accs) in (&mut quads).enumerate() {
                    if let [a0, a1, a2, a3] = accs {
                        let o = 4 * q;
                        let ws = row(o).zip(row(o + 1)).zip(row(o + 2)).zip(row(o + 3));
                        for ((((w0, w1), w2), w3), x) in ws.zip(xs) {
                            *a0 += w0 * *x;
                            *a1 += w1 * *x;
                            *a2 += w2 * *x;
                            *a3 += w3 * *x;
                        }
                    }
                }
                let done = self.out_f / 4 * 4;
                for (k, acc) in quads.into_remainder().iter_mut().enumerate() {
                    for (wj, xj) in row(done + k).zip(xs) {
                        *acc += wj * *xj;
                    }
                }
            }
            for (acc, b) in out_row.iter_mut().zip(self.bias.iter()) {
                *acc = self.activation.apply(*acc + b);
            }
        }
        Ok(())
    }
}

/// `f32` lanes of the target's vector registers, as far as the compile-time target features
/// tell: the blocks below are sized so that their accumulators fill about eight registers. This
/// chooses a loop shape only: every output's sum runs in the same order whatever the block, so
/// the bits do not depend on it.
const LANES: usize = if cfg!(target_feature = "avx512f") {
    16
} else if cfg!(target_feature = "avx2") {
    8
} else {
    4
};

impl SpiralConv<'_> {
    /// Output channels computed together by [`Self::forward_blocked`]: 4, 8 or (128-bit vectors
    /// only) 16.
    fn block_outputs(&self) -> usize {
        if self.out_f <= 4 {
            4
        } else if self.out_f <= 8 || LANES >= 8 {
            8
        } else {
            16
        }
    }

    /// Scratch length [`Self::forward_blocked`] needs: one block of output channels' weights,
    /// repacked input-major, `len · in_f` rows of 4 (up to 4 outputs), 8 (up to 8) or 16
    /// values. The same on every target, although a target with narrower blocks (8 channels
    /// with AVX2 or AVX-512) uses half of it for wide layers. (Saturates instead of overflowing;
    /// no buffer that long can exist.)
    pub fn scratch_len(&self) -> usize {
        let block = if self.out_f <= 8 {
            self.block_outputs()
        } else {
            16
        };
        self.spirals
            .len
            .saturating_mul(self.in_f)
            .saturating_mul(block)
    }

    /// [`Self::forward`], the same bits, computing a block of vertices times a block of output
    /// channels together.
    ///
    /// Each output is still `act((Σ_j W[o, j] · g_v[j]) + b[o])` with the sum over
    /// `j = p · in_f + c` in increasing order from `0.0`, separate multiply and add: only
    /// independent sums (other vertices, other channels) are interleaved, which hides the latency
    /// of the additions and lets the compiler vectorise across channels. The block's weights are
    /// first copied into `scratch` as `[len · in_f, block]` (zeros past the last channel), so
    /// that one step reads a contiguous row of weights for all channels of the block.
    ///
    /// # Shapes
    /// As [`Self::forward`]; `scratch`: at least [`Self::scratch_len`] values (contents on entry
    /// ignored, on exit unspecified).
    ///
    /// # Errors
    /// As [`Self::forward`], and [`BufferError::Scratch`] if `scratch` is too short.
    pub fn forward_blocked(
        &self,
        x: &[f32],
        out: &mut [f32],
        scratch: &mut [f32],
    ) -> Result<(), BufferError> {
        if Some(x.len()) != self.spirals.n_source_vertices.checked_mul(self.in_f) {
            return Err(BufferError::Input);
        }
        if Some(out.len()) != self.spirals.n_vertices.checked_mul(self.out_f) {
            return Err(BufferError::Output);
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch);
        }
        let used = self.spirals.len * self.in_f * self.block_outputs();
        let packed = scratch.get_mut(..used).ok_or(BufferError::Scratch)?;
        // Eight accumulator registers: 8 vertices × 8 channels in 256-bit registers (AVX2, and
        // AVX-512, where 16-channel blocks came out slower: the compiler assembled each weight
        // row from pieces), 2 × 16 or 4 × 8 in 128-bit ones; 8 × 4 for the 3-output layer.
        match self.block_outputs() {
            4 => self.blocks8::<4>(x, out, packed),
            8 if LANES >= 8 => self.blocks8::<8>(x, out, packed),
            8 => self.blocks4::<8>(x, out, packed),
            _ => self.blocks2::<16>(x, out, packed),
        }
        Ok(())
    }

    /// Copies the weights of channels `o0..o0 + OB` into `packed` as `packed[j][k] = W[o0 + k, j]`,
    /// zero for channels past `out_f` (computed, never stored).
    fn pack<const OB: usize>(&self, o0: usize, packed: &mut [[f32; OB]]) {
        let width = self.spirals.len * self.in_f;
        packed.fill([0.0; OB]);
        for k in 0..OB.min(self.out_f.saturating_sub(o0)) {
            let row = self.weight.slice((o0 + k) * width, width);
            for (dst, w) in packed.iter_mut().zip(row.iter()) {
                if let Some(d) = dst.get_mut(k) {
                    *d = w;
                }
            }
        }
    }

    /// The source row of vertex `v` at spiral position `p`. Indices are validated
    /// (< n_source_vertices) and `x` checked, so the row is whole; the empty fallback cannot
    /// occur.
    #[inline(always)]
    fn row<'x>(&self, x: &'x [f32], v: usize, p: usize) -> &'x [f32] {
        let s = self.spirals.indices.at(v * self.spirals.len + p) as usize;
        x.get(s * self.in_f..s * self.in_f + self.in_f)
            .unwrap_or(&[])
    }

    /// `out[v, o0 + k] = act(acc[b][k] + bias[o0 + k])` for the block's vertices `v = v0 + b`,
    /// `b < count`, and its channels below `out_f`.
    fn store<const OB: usize>(
        &self,
        acc: &[[f32; OB]],
        v0: usize,
        o0: usize,
        count: usize,
        out: &mut [f32],
    ) {
        let out_f = self.out_f;
        let bias = self.bias.slice(o0, OB);
        for (b, a) in acc.iter().enumerate().take(count) {
            let start = (v0 + b) * out_f + o0;
            let end = (start + OB).min((v0 + b + 1) * out_f);
            if let Some(dst) = out.get_mut(start..end) {
                for ((d, ak), bo) in dst.iter_mut().zip(a).zip(bias.iter()) {
                    *d = self.activation.apply(*ak + bo);
                }
            }
        }
    }

    /// The body of [`Self::forward_blocked`] for blocks of 4 vertices × `OB` channels; the
    /// caller has checked every length (`packed` holds `len · in_f · OB` values).
    #[inline(never)]
    fn blocks4<const OB: usize>(&self, x: &[f32], out: &mut [f32], packed: &mut [f32]) {
        let (in_f, len, n) = (self.in_f, self.spirals.len, self.spirals.n_vertices);
        let (packed, _) = packed.as_chunks_mut::<OB>();
        for o0 in (0..self.out_f).step_by(OB) {
            self.pack(o0, packed);
            for v0 in (0..n).step_by(4) {
                // A short last block repeats its last vertex (those sums are dropped).
                let last = (n - v0).min(4) - 1;
                let mut acc = [[0.0f32; OB]; 4];
                for (p, wp) in packed.chunks_exact(in_f).take(len).enumerate() {
                    let row = |b: usize| self.row(x, v0 + b.min(last), p);
                    let [a0, a1, a2, a3] = &mut acc;
                    // Neural3DMM spiral conv: acc[v][o] += W[o, p · in_f + c] · x[s(v, p), c]
                    // for c in order, so each output's sum keeps the order of `forward`. The
                    // rows advance in lockstep through one iterator: indexing each row instead
                    // lets the compiler vectorise across rows, with gathers.
                    let steps = wp.iter().zip(row(0)).zip(row(1)).zip(row(2)).zip(row(3));
                    for ((((w, x0), x1), x2), x3) in steps {
                        axpy(a0, w, *x0);
                        axpy(a1, w, *x1);
                        axpy(a2, w, *x2);
                        axpy(a3, w, *x3);
                    }
                }
                self.store(&acc, v0, o0, last + 1, out);
            }
        }
    }

    /// [`Self::blocks4`] with blocks of 2 vertices.
    #[inline(never)]
    fn blocks2<const OB: usize>(&self, x: &[f32], out: &mut [f32], packed: &mut [f32]) {
        let (in_f, len, n) = (self.in_f, self.spirals.len, self.spirals.n_vertices);
        let (packed, _) = packed.as_chunks_mut::<OB>();
        for o0 in (0..self.out_f).step_by(OB) {
            self.pack(o0, packed);
            for v0 in (0..n).step_by(2) {
                let last = (n - v0).min(2) - 1;
                let mut acc = [[0.0f32; OB]; 2];
                for (p, wp) in packed.chunks_exact(in_f).take(len).enumerate() {
                    let row = |b: usize| self.row(x, v0 + b.min(last), p);
                    let [a0, a1] = &mut acc;
                    for ((w, x0), x1) in wp.iter().zip(row(0)).zip(row(1)) {
                        axpy(a0, w, *x0);
                        axpy(a1, w, *x1);
                    }
                }
                self.store(&acc, v0, o0, last + 1, out);
            }
        }
    }

    /// [`Self::blocks4`] with blocks of 8 vertices.
    #[inline(never)]
    fn blocks8<const OB: usize>(&self, x: &[f32], out: &mut [f32], packed: &mut [f32]) {
        let (in_f, len, n) = (self.in_f, self.spirals.len, self.spirals.n_vertices);
        let (packed, _) = packed.as_chunks_mut::<OB>();
        for o0 in (0..self.out_f).step_by(OB) {
            self.pack(o0, packed);
            for v0 in (0..n).step_by(8) {
                let last = (n - v0).min(8) - 1;
                let mut acc = [[0.0f32; OB]; 8];
                for (p, wp) in packed.chunks_exact(in_f).take(len).enumerate() {
                    let row = |b: usize| self.row(x, v0 + b.min(last), p);
                    let [a0, a1, a2, a3, a4, a5, a6, a7] = &mut acc;
                    let steps = wp.iter().zip(row(0)).zip(row(1)).zip(row(2)).zip(row(3));
                    let steps = steps.zip(row(4)).zip(row(5)).zip(row(6)).zip(row(7));
                    for ((((((((w, x0), x1), x2), x3), x4), x5), x6), x7) in steps {
                        axpy(a0, w, *x0);
                        axpy(a1, w, *x1);
                        axpy(a2, w, *x2);
                        axpy(a3, w, *x3);
                        axpy(a4, w, *x4);
                        axpy(a5, w, *x5);
                        axpy(a6, w, *x6);
                        axpy(a7, w, *x7);
                    }
                }
                self.store(&acc, v0, o0, last + 1, out);
            }
        }
    }
}

/// `acc[k] += w[k] · x`: one step of `OB` independent sums.
#[inline(always)]
fn axpy<const OB: usize>(acc: &mut [f32; OB], w: &[f32; OB], x: f32) {
    for (a, wk) in acc.iter_mut().zip(w) {
        *a += *wk * x;
    }
}

/// Sets row `row` of a row-major `[_, width]` array to zero: the S2D reference zeroes the dummy
/// vertex's row (the last one) after every spiral stage, so that it pads short spirals with zeros.
///
/// # Errors
/// [`BufferError::Output`] if the row lies outside `out`; nothing is written then.
pub fn zero_row(out: &mut [f32], row: usize, width: usize) -> Result<(), BufferError> {
    let start = row.checked_mul(width).ok_or(BufferError::Output)?;
    let end = start.checked_add(width).ok_or(BufferError::Output)?;
    out.get_mut(start..end)
        .ok_or(BufferError::Output)?
        .fill(0.0);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nn::Dense;
    use std::vec;
    use std::vec::Vec;

    fn fb(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn ub(v: &[u32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn spirals_validation() {
        let b = ub(&[0, 1, 2, 2, 0, 1]);
        let idx = U32s::new(&b).unwrap();
        let s = Spirals::new(idx, 2, 3, 3).unwrap();
        assert_eq!(
            (s.n_vertices(), s.len(), s.n_source_vertices(), s.is_empty()),
            (2, 3, 3, false)
        );
        assert_eq!(s.spiral(1).iter().collect::<Vec<_>>(), [2, 0, 1]);
        assert_eq!(
            Spirals::new(idx, 2, 3, 2),
            Err(FormatError::index_out_of_range("indices", 2))
        );
        let indices = Err(FormatError::incompatible_shapes("indices"));
        assert_eq!(Spirals::new(idx, 3, 3, 3), indices);
        assert_eq!(Spirals::new(U32s::empty(), 2, 0, 3), indices);
    }

    #[test]
    fn forward_hand_computed() {
        // 3 source vertices with in_f = 2: x = [[1, 2], [3, 4], [5, 6]].
        // 2 spirals of length 2: v0 = (0, 2), v1 = (1, 1).
        // out_f = 2, W = [[1, 0, 0, 1],     (x[s0][0] + x[s1][1])
        //                 [0.5, 0.5, −1, 0]] (0.5 (x[s0][0] + x[s0][1]) − x[s1][0]), b = [0, 10]
        // v0: gathered [1, 2, 5, 6] → [1 + 6, 0.5 + 1 − 5 + 10] = [7, 6.5]
        // v1: gathered [3, 4, 3, 4] → [3 + 4, 1.5 + 2 − 3 + 10] = [7, 10.5]
        let sb = ub(&[0, 2, 1, 1]);
        let spirals = Spirals::new(U32s::new(&sb).unwrap(), 2, 2, 3).unwrap();
        let wb = fb(&[1.0, 0.0, 0.0, 1.0, 0.5, 0.5, -1.0, 0.0]);
        let bb = fb(&[0.0, 10.0]);
        let w = F32s::new(&wb).unwrap();
        let b = F32s::new(&bb).unwrap();
        let conv = SpiralConv::new(spirals, w, b, 2, 2, Activation::Identity).unwrap();
        let x = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let mut out = [f32::NAN; 4];
        conv.forward(&x, &mut out).unwrap();
        assert_eq!(out, [7.0, 6.5, 7.0, 10.5]);

        // ELU(α = 1) with b = [0, −10]: output 1 becomes −3.5 − 10 = −13.5 (v0) and 0.5 − 10 = −9.5 (v1).
        let bb = fb(&[0.0, -10.0]);
        let conv = SpiralConv::new(
            spirals,
            w,
            F32s::new(&bb).unwrap(),
            2,
            2,
            Activation::Elu { alpha: 1.0 },
        )
        .unwrap();
        conv.forward(&x, &mut out).unwrap();
        assert_eq!(out, [7.0, libm::expm1f(-13.5), 7.0, libm::expm1f(-9.5)]);

        assert_eq!(conv.forward(&x[..5], &mut out), Err(BufferError::Input));
        assert_eq!(conv.forward(&x, &mut out[..3]), Err(BufferError::Output));
    }

    #[test]
    fn same_bits_as_dense_on_the_gathered_vector() {
        // Values chosen so that the order of the sum matters: any other order of the 6 products
        // changes the rounding.
        let xs = [1e8f32, 3.0, -1e8, 0.1, 7.25, 1e-3];
        let sb = ub(&[2, 0, 1, 1, 2, 0]);
        let spirals = Spirals::new(U32s::new(&sb).unwrap(), 2, 3, 3).unwrap();
        let wv = [1.0, 0.3, 1.0, -0.7, 1.0, 2.5, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
        let wb = fb(&wv);
        let bb = fb(&[0.125, -3.0]);
        let (w, b) = (F32s::new(&wb).unwrap(), F32s::new(&bb).unwrap());
        let act = Activation::Sine { omega0: 30.0 };
        let conv = SpiralConv::new(spirals, w, b, 2, 2, act).unwrap();
        let x = [xs[0], xs[1], xs[2], xs[3], xs[4], xs[5]];
        let mut out = [0.0; 4];
        conv.forward(&x, &mut out).unwrap();

        let dense = Dense::new(w, b, 6, 2, act).unwrap();
        for v in 0..2 {
            let mut gathered = Vec::new();
            for s in spirals.spiral(v).iter() {
                gathered.extend_from_slice(&x[s as usize * 2..s as usize * 2 + 2]);
            }
            let mut y = [0.0; 2];
            dense.forward(&gathered, &mut y).unwrap();
            assert_eq!(y[0].to_bits(), out[v * 2].to_bits());
            assert_eq!(y[1].to_bits(), out[v * 2 + 1].to_bits());
        }
    }

    /// A straightforward spiral convolution in the documented order, kept here as the
    /// definition the optimised kernels must match bit for bit: for each vertex and output,
    /// `acc = 0.0`, then `acc += W[o, j] · g_v[j]` for `j = p · in_f + c` in increasing order,
    /// then `act(acc + b[o])`.
    fn reference(
        idx: &[u32],
        len: usize,
        w: &[f32],
        b: &[f32],
        in_f: usize,
        act: Activation,
        x: &[f32],
    ) -> Vec<f32> {
        let out_f = b.len();
        let mut out = Vec::new();
        for spiral in idx.chunks(len) {
            for o in 0..out_f {
                let mut acc = 0.0f32;
                for (p, &s) in spiral.iter().enumerate() {
                    for c in 0..in_f {
                        acc += w[o * len * in_f + p * in_f + c] * x[s as usize * in_f + c];
                    }
                }
                out.push(act.apply(acc + b[o]));
            }
        }
        out
    }

    /// A small xorshift generator: values of mixed sign and magnitude (1e-3 to 1e3), so that
    /// almost any change of a sum's order changes its rounding.
    struct Mixed(u64);

    impl Mixed {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            let u = (self.0 >> 40) as f32 / (1u64 << 24) as f32;
            let scale = [1e-3, 1.0, 1e3][(self.0 % 3) as usize];
            (2.0 * u - 1.0) * scale
        }

        fn vec(&mut self, n: usize) -> Vec<f32> {
            (0..n).map(|_| self.next()).collect()
        }
    }

    #[test]
    fn blocked_keeps_every_sums_order() {
        let mut rng = Mixed(0x9e37_79b9_7f4a_7c15);
        // Vertex counts around the 4-vertex block, channel counts around the 4/8/16 blocks,
        // odd feature counts and spiral lengths.
        let shapes = [
            (1, 1, 1, 1, 1),
            (3, 5, 2, 3, 3),
            (5, 7, 3, 1, 4),
            (6, 4, 5, 7, 5),
            (9, 11, 4, 2, 8),
            (7, 13, 2, 5, 9),
            (13, 8, 3, 3, 16),
            (10, 17, 5, 2, 17),
            (4, 6, 1, 33, 33),
            (2, 3, 7, 4, 64),
        ];
        for (vertices, sources, len, in_f, out_f) in shapes {
            let idx: Vec<u32> = (0..vertices * len)
                .map(|_| (rng.next().abs() * 1e6) as u32 % sources as u32)
                .collect();
            let (w, b, x) = (
                rng.vec(out_f * len * in_f),
                rng.vec(out_f),
                rng.vec(sources * in_f),
            );
            let (ib, wb, bb) = (ub(&idx), fb(&w), fb(&b));
            let spirals = Spirals::new(U32s::new(&ib).unwrap(), vertices, len, sources).unwrap();
            for act in [Activation::Identity, Activation::Elu { alpha: 1.0 }] {
                let conv = SpiralConv::new(
                    spirals,
                    F32s::new(&wb).unwrap(),
                    F32s::new(&bb).unwrap(),
                    in_f,
                    out_f,
                    act,
                )
                .unwrap();
                let expected = reference(&idx, len, &w, &b, in_f, act, &x);
                let mut scratch = vec![f32::NAN; conv.scratch_len()];
                let mut blocked = vec![f32::NAN; vertices * out_f];
                conv.forward_blocked(&x, &mut blocked, &mut scratch)
                    .unwrap();
                let mut plain = vec![f32::NAN; vertices * out_f];
                conv.forward(&x, &mut plain).unwrap();
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                let shape = (vertices, sources, len, in_f, out_f);
                assert_eq!(bits(&blocked), bits(&expected), "blocked, shape {shape:?}");
                assert_eq!(bits(&plain), bits(&expected), "forward, shape {shape:?}");
                // Every block shape, not only the one this target selects (2, 4 and 8 vertices;
                // 4, 8 and 16 channels), so that a portable test run covers the AVX2 and AVX-512 paths.
                type Kernel<'k> = fn(&SpiralConv<'k>, &[f32], &mut [f32], &mut [f32]);
                let kernels: [(Kernel<'_>, usize, &str); 9] = [
                    (SpiralConv::blocks2::<4>, 4, "2 × 4"),
                    (SpiralConv::blocks2::<8>, 8, "2 × 8"),
                    (SpiralConv::blocks2::<16>, 16, "2 × 16"),
                    (SpiralConv::blocks4::<4>, 4, "4 × 4"),
                    (SpiralConv::blocks4::<8>, 8, "4 × 8"),
                    (SpiralConv::blocks4::<16>, 16, "4 × 16"),
                    (SpiralConv::blocks8::<4>, 4, "8 × 4"),
                    (SpiralConv::blocks8::<8>, 8, "8 × 8"),
                    (SpiralConv::blocks8::<16>, 16, "8 × 16"),
                ];
                for (kernel, ob, name) in kernels {
                    let mut packed = vec![f32::NAN; len * in_f * ob];
                    let mut y = vec![f32::NAN; vertices * out_f];
                    kernel(&conv, &x, &mut y, &mut packed);
                    assert_eq!(bits(&y), bits(&expected), "{name}, shape {shape:?}");
                }
                // A longer scratch is fine, a shorter one is refused before any write.
                let mut long = vec![0.0; conv.scratch_len() + 3];
                conv.forward_blocked(&x, &mut blocked, &mut long).unwrap();
                assert_eq!(bits(&blocked), bits(&expected));
                let short = conv.scratch_len() - 1;
                assert_eq!(
                    conv.forward_blocked(&x, &mut blocked, &mut scratch[..short]),
                    Err(BufferError::Scratch)
                );
            }
        }
    }

    #[test]
    fn blocked_scratch_and_errors() {
        // A 4-channel block for 3 outputs: 2 positions × 1 feature × 4.
        let sb = ub(&[0, 1]);
        let spirals = Spirals::new(U32s::new(&sb).unwrap(), 1, 2, 2).unwrap();
        let wb = fb(&[1.0; 6]);
        let bb = fb(&[0.0; 3]);
        let (w, b) = (F32s::new(&wb).unwrap(), F32s::new(&bb).unwrap());
        let conv = SpiralConv::new(spirals, w, b, 1, 3, Activation::Identity).unwrap();
        assert_eq!(conv.scratch_len(), 2 * 4);
        let mut out = [0.0; 3];
        let mut scratch = [0.0; 8];
        assert_eq!(
            conv.forward_blocked(&[1.0], &mut out, &mut scratch),
            Err(BufferError::Input)
        );
        assert_eq!(
            conv.forward_blocked(&[1.0, 2.0], &mut out[..2], &mut scratch),
            Err(BufferError::Output)
        );
        conv.forward_blocked(&[1.0, 2.0], &mut out, &mut scratch)
            .unwrap();
        assert_eq!(out, [3.0; 3]);
    }

    #[test]
    fn conv_validation() {
        let sb = ub(&[0, 1]);
        let spirals = Spirals::new(U32s::new(&sb).unwrap(), 1, 2, 2).unwrap();
        let wb = fb(&[1.0; 4]);
        let bb = fb(&[0.0]);
        let (w, b) = (F32s::new(&wb).unwrap(), F32s::new(&bb).unwrap());
        let id = Activation::Identity;
        assert!(SpiralConv::new(spirals, w, b, 2, 1, id).is_ok());
        let weight = Err(FormatError::incompatible_shapes("weight"));
        assert_eq!(SpiralConv::new(spirals, w, b, 1, 1, id), weight);
        assert_eq!(SpiralConv::new(spirals, w, b, 0, 1, id), weight);
        assert_eq!(
            SpiralConv::new(spirals, w, F32s::empty(), 2, 1, id),
            Err(FormatError::incompatible_shapes("bias"))
        );
        let nb = fb(&[1.0, 1.0, f32::INFINITY, 1.0]);
        assert_eq!(
            SpiralConv::new(spirals, F32s::new(&nb).unwrap(), b, 2, 1, id),
            Err(FormatError::NonFinite)
        );
        let elu = Activation::Elu { alpha: f32::NAN };
        assert_eq!(
            SpiralConv::new(spirals, w, b, 2, 1, elu),
            Err(FormatError::NonFinite)
        );
    }

    #[test]
    fn zero_row_zeroes_one_row() {
        let mut a = [1.0f32; 6];
        zero_row(&mut a, 2, 2).unwrap();
        assert_eq!(a, [1.0, 1.0, 1.0, 1.0, 0.0, 0.0]);
        assert_eq!(zero_row(&mut a, 3, 2), Err(BufferError::Output));
        assert_eq!(zero_row(&mut a, usize::MAX, 2), Err(BufferError::Output));
        assert_eq!(zero_row(&mut a, 0, 0), Ok(()));
    }
}
