//! Weighted gather-sums of rows, as one burn operation with a parallel CPU kernel and a parallel
//! adjoint: the spiral convolutions' and up-samplings' gathers of S2D-Dec.
//!
//! A gather-sum reads, for every output row `v`, a fixed number of source rows (its *terms*)
//! and sums them, optionally weighted. Each output row is `blocks` blocks of `width` values;
//! block `b` of term `k` reads `width` values of the term's source row from column
//! `b · block_stride + k · term_stride`:
//!
//! ```text
//! out[v][b·width + j] = Σ_k w(v, k) · x[source(v, k)][b·block_stride + k·term_stride + j]
//! ```
//!
//! - An up-sampling (`fine = U · coarse`): one block spanning the row, strides 0, the
//!   barycentric weights.
//! - A spiral convolution after one product `Y = x · W` of every source vertex with every
//!   spiral position's weights (a row of `Y` holds `[batch, positions, outputs]`): one block
//!   per sample, `block_stride = positions · outputs`, `term_stride = outputs`, no weights.
//!
//! burn-flex runs `select` and its backward (`select_add`) on one thread, and a convolution
//! built from them takes a select, an add and, backward, a zero-filled scatter per spiral
//! position. Here the forward pass fills each output row once and the backward pass each source
//! row once, from an inverse index built with the plan, both spread over the rayon pool: no two
//! tasks write the same row, so the result does not depend on the thread count. Other backends
//! (wgpu, ndarray) keep burn's own operations (see the callers).

use std::sync::Arc;

use burn::backend::autodiff::Autodiff;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::CheckpointStrategy;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind, unary};
use burn::backend::flex::FlexTensor;
use burn::backend::ops::FloatTensorOps;
use burn::backend::tensor::FloatTensor;
use burn::backend::{Backend, DType, Dispatch, DispatchTensorKind, Flex, backend_extension};
use burn::tensor::{Shape, Tensor};
use rayon::prelude::*;

/// The fixed part of a gather-sum: which source rows (and weights) every output row sums, and
/// the inverse, which (row, term) pairs read every source row.
#[derive(Debug)]
pub struct GatherIndex {
    /// One more than the largest source index: the fewest source rows the gather can read.
    min_sources: usize,
    rows: usize,
    terms: usize,
    /// Source row of (row, term), `[rows · terms]`.
    source: Vec<u32>,
    /// Weight of (row, term), `[rows · terms]`; `None` sums unweighted.
    weight: Option<Vec<f32>>,
    /// Inverse in CSR form: the (row · terms + term) entries reading source `s` are
    /// `readers[reader_ptr[s]..reader_ptr[s + 1]]`, ascending.
    reader_ptr: Vec<u32>,
    readers: Vec<u32>,
}

impl GatherIndex {
    /// The gather of `rows = source.len() / terms` output rows, entry `row · terms + term`
    /// reading source row `source[entry]` (weighted by `weight[entry]`).
    ///
    /// # Panics
    /// If `terms` is 0, `source.len()` is not a multiple of it or `weight` has another length:
    /// these come from a checked hierarchy, never from input.
    pub fn new(terms: usize, source: Vec<u32>, weight: Option<Vec<f32>>) -> Self {
        assert!(
            terms > 0 && source.len() % terms == 0,
            "gather: bad term count"
        );
        let sources = source.iter().map(|&s| s as usize + 1).max().unwrap_or(0);
        assert!(
            weight.as_ref().is_none_or(|w| w.len() == source.len()),
            "gather: one weight per entry"
        );
        let mut reader_ptr = vec![0u32; sources + 1];
        for &s in &source {
            reader_ptr[s as usize + 1] += 1;
        }
        for s in 0..sources {
            reader_ptr[s + 1] += reader_ptr[s];
        }
        let mut next = reader_ptr.clone();
        let mut readers = vec![0u32; source.len()];
        for (entry, &s) in source.iter().enumerate() {
            readers[next[s as usize] as usize] = entry as u32;
            next[s as usize] += 1;
        }
        Self {
            min_sources: sources,
            rows: source.len() / terms,
            terms,
            source,
            weight,
            reader_ptr,
            readers,
        }
    }

    /// Output rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The fewest source rows the gather can read.
    pub fn min_sources(&self) -> usize {
        self.min_sources
    }
}

/// The per-call part of a gather-sum: how output and source rows are laid out (see the module
/// documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GatherLayout {
    /// Source rows (at least [`GatherIndex::min_sources`]).
    pub sources: usize,
    /// Values per source row.
    pub source_width: usize,
    /// Blocks per output row.
    pub blocks: usize,
    /// Values per block.
    pub width: usize,
    /// Source column of block `b` of term 0: `b · block_stride`.
    pub block_stride: usize,
    /// Added per term: term `k` reads from `k · term_stride` on.
    pub term_stride: usize,
}

impl GatherLayout {
    fn row_width(&self) -> usize {
        self.blocks * self.width
    }

    fn check(&self, index: &GatherIndex) {
        assert!(
            self.sources >= index.min_sources,
            "gather: {} source rows, the index reads {}",
            self.sources,
            index.min_sources
        );
        let last = self.blocks.saturating_sub(1) * self.block_stride
            + (index.terms - 1) * self.term_stride
            + self.width;
        assert!(
            self.blocks == 0 || self.width == 0 || last <= self.source_width,
            "gather: layout reads past the source row ({last} > {})",
            self.source_width
        );
    }
}

/// The gather-sum of `x` (`[sources, source_width]`), `[rows, blocks · width]`, laid out as
/// `layout` says (its `sources` and `source_width` are `x`'s shape): burn-flex's tensors (with
/// autodiff or without) take the parallel kernel; call it only on those ([`on_flex`]).
pub fn gather_sum(
    x: Tensor<2>,
    index: &Arc<GatherIndex>,
    blocks: usize,
    width: usize,
    block_stride: usize,
    term_stride: usize,
) -> Tensor<2> {
    let [sources, source_width] = x.dims();
    let layout = GatherLayout {
        sources,
        source_width,
        blocks,
        width,
        block_stride,
        term_stride,
    };
    layout.check(index);
    Tensor::from_dispatch(Dispatch::gather_sum(
        x.into_dispatch(),
        Arc::clone(index),
        layout,
    ))
}

/// Whether `x` lives on burn-flex (with or without autodiff), where [`gather_sum`] runs.
pub fn on_flex<const D: usize>(x: &Tensor<D>) -> bool {
    let x = x.clone().into_dispatch();
    match &x.kind {
        DispatchTensorKind::Flex(_) => true,
        DispatchTensorKind::Autodiff(inner) => matches!(**inner, DispatchTensorKind::Flex(_)),
        #[allow(unreachable_patterns)]
        _ => false,
    }
}

/// The backend extension behind [`gather_sum`].
#[backend_extension(Flex, Autodiff)]
pub trait GatherOps: Backend {
    /// The gather-sum.
    fn gather_sum(
        x: FloatTensor<Self>,
        index: Arc<GatherIndex>,
        layout: GatherLayout,
    ) -> FloatTensor<Self>;
    /// Its adjoint: `[rows, blocks · width]` back to `[sources, source_width]`.
    fn scatter_sum(
        grad: FloatTensor<Self>,
        index: Arc<GatherIndex>,
        layout: GatherLayout,
    ) -> FloatTensor<Self>;
}

fn f32_contiguous(x: FlexTensor) -> FlexTensor {
    let x = if x.dtype() == DType::F32 {
        x
    } else {
        Flex::float_cast(x, DType::F32.into())
    };
    if x.as_slice::<f32>().is_some() {
        x
    } else {
        x.to_contiguous()
    }
}

impl GatherOps for Flex {
    fn gather_sum(x: FlexTensor, index: Arc<GatherIndex>, layout: GatherLayout) -> FlexTensor {
        let x = f32_contiguous(x);
        let mut out = FlexTensor::empty(Shape::new([index.rows, layout.row_width()]), DType::F32);
        gather_into(
            &index,
            layout,
            x.as_slice::<f32>().unwrap_or_default(),
            out.storage_mut::<f32>(),
        );
        out
    }

    fn scatter_sum(grad: FlexTensor, index: Arc<GatherIndex>, layout: GatherLayout) -> FlexTensor {
        let grad = f32_contiguous(grad);
        let mut out = FlexTensor::empty(
            Shape::new([layout.sources, layout.source_width]),
            DType::F32,
        );
        scatter_into(
            &index,
            layout,
            grad.as_slice::<f32>().unwrap_or_default(),
            out.storage_mut::<f32>(),
        );
        out
    }
}

impl<B: Backend + GatherOps, C: CheckpointStrategy> GatherOps for Autodiff<B, C> {
    fn gather_sum(
        x: FloatTensor<Self>,
        index: Arc<GatherIndex>,
        layout: GatherLayout,
    ) -> FloatTensor<Self> {
        /// The backward pass of a gather-sum, which is linear: its adjoint of the gradient.
        #[derive(Debug)]
        struct GatherSum;

        impl<B: Backend + GatherOps> Backward<B, 1> for GatherSum {
            type State = (Arc<GatherIndex>, GatherLayout);

            fn backward(
                self,
                ops: Ops<Self::State, 1>,
                grads: &mut Gradients,
                _checkpointer: &mut Checkpointer,
            ) {
                let (index, layout) = ops.state;
                unary::<B, _>(ops.parents, ops.node, grads, |grad| {
                    B::scatter_sum(grad, index, layout)
                });
            }
        }

        match GatherSum
            .prepare::<C>([x.node()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => {
                let out = B::gather_sum(x.into_primitive(), Arc::clone(&index), layout);
                prep.finish((index, layout), out)
            }
            OpsKind::UnTracked(prep) => {
                prep.finish(B::gather_sum(x.into_primitive(), index, layout))
            }
        }
    }

    fn scatter_sum(
        grad: FloatTensor<Self>,
        index: Arc<GatherIndex>,
        layout: GatherLayout,
    ) -> FloatTensor<Self> {
        // Only the backward pass calls the adjoint, on the inner backend's gradients; asked for
        // it directly, an autodiff tensor gets it as a constant.
        FloatTensor::<Self>::new(B::scatter_sum(grad.into_primitive(), index, layout))
    }
}

/// Output rows per parallel task (an up-sampled row of batch 16 × 64 features is 4 KB).
const ROWS_PER_TASK: usize = 32;

/// The forward kernel: every output row of `out` from `x`.
pub fn gather_into(index: &GatherIndex, layout: GatherLayout, x: &[f32], out: &mut [f32]) {
    let row = layout.row_width();
    let (terms, width) = (index.terms, layout.width);
    if row == 0 {
        return;
    }
    out.par_chunks_mut(row)
        .with_min_len(ROWS_PER_TASK)
        .enumerate()
        .for_each(|(v, out)| {
            for k in 0..terms {
                let entry = v * terms + k;
                let s = index.source[entry] as usize;
                let w = index.weight.as_ref().map(|w| w[entry]);
                let src = &x[s * layout.source_width..(s + 1) * layout.source_width];
                for b in 0..layout.blocks {
                    let from = &src[b * layout.block_stride + k * layout.term_stride..][..width];
                    let to = &mut out[b * width..(b + 1) * width];
                    match (k, w) {
                        (0, None) => to.copy_from_slice(from),
                        (0, Some(w)) => to.iter_mut().zip(from).for_each(|(t, f)| *t = w * f),
                        (_, None) => to.iter_mut().zip(from).for_each(|(t, f)| *t += f),
                        (_, Some(w)) => to.iter_mut().zip(from).for_each(|(t, f)| *t += w * f),
                    }
                }
            }
        });
}

/// The adjoint kernel: every source row of `out` (zeroed first) from the output gradient
/// `grad`, each entry reading it added in ascending (row, term) order.
pub fn scatter_into(index: &GatherIndex, layout: GatherLayout, grad: &[f32], out: &mut [f32]) {
    let (terms, width, row) = (index.terms, layout.width, layout.row_width());
    if layout.source_width == 0 {
        return;
    }
    out.par_chunks_mut(layout.source_width)
        .with_min_len(ROWS_PER_TASK)
        .enumerate()
        .for_each(|(s, out)| {
            out.fill(0.0);
            let readers = match index.reader_ptr.get(s..s + 2) {
                Some(&[a, b]) => &index.readers[a as usize..b as usize],
                _ => &[],
            };
            for &entry in readers {
                let entry = entry as usize;
                let (v, k) = (entry / terms, entry % terms);
                let w = index.weight.as_ref().map(|w| w[entry]);
                let g = &grad[v * row..(v + 1) * row];
                for b in 0..layout.blocks {
                    let from = &g[b * width..(b + 1) * width];
                    let to = &mut out[b * layout.block_stride + k * layout.term_stride..][..width];
                    match w {
                        None => to.iter_mut().zip(from).for_each(|(t, f)| *t += f),
                        Some(w) => to.iter_mut().zip(from).for_each(|(t, f)| *t += w * f),
                    }
                }
            }
        });
}
