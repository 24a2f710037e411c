//! Compressed sparse row (CSR) matrices over the model's bytes, multiplied with dense row-major
//! feature matrices (S2D's mesh up- and down-sampling).

use crate::error::{BufferError, FormatError};
use crate::nn::all_finite;
use crate::tensor::{F32s, U32s};

/// A validated CSR matrix.
///
/// Row `r` holds the entries `row_ptr[r]..row_ptr[r + 1]` of `col_idx` (column) and `values`
/// (value), in stored order.
///
/// # Shapes
/// `row_ptr`: `[rows + 1]`; `col_idx`, `values`: `[nnz]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Csr<'a> {
    rows: usize,
    cols: usize,
    row_ptr: U32s<'a>,
    col_idx: U32s<'a>,
    values: F32s<'a>,
}

impl<'a> Csr<'a> {
    /// Checks and wraps a CSR matrix of `rows × cols`.
    ///
    /// # Errors
    /// - [`FormatError::IncompatibleShapes`] naming `row_ptr` if it does not hold `rows + 1`
    ///   values, naming `values` if `col_idx` and `values` differ in length;
    /// - [`FormatError::IndexOutOfRange`] naming `row_ptr` and the pointer's position if
    ///   `row_ptr[0] != 0`, `row_ptr` decreases anywhere or its last value is not `nnz`, or
    ///   naming `col_idx` and the entry if a column index is `>= cols`;
    /// - [`FormatError::NonFinite`] if a value is NaN or infinite.
    pub fn new(
        rows: usize,
        cols: usize,
        row_ptr: U32s<'a>,
        col_idx: U32s<'a>,
        values: F32s<'a>,
    ) -> Result<Self, FormatError> {
        if Some(row_ptr.len()) != rows.checked_add(1) {
            return Err(FormatError::incompatible_shapes("row_ptr"));
        }
        if col_idx.len() != values.len() {
            return Err(FormatError::incompatible_shapes("values"));
        }
        if row_ptr.get(0) != Some(0) {
            return Err(FormatError::index_out_of_range("row_ptr", 0));
        }
        let mut prev = 0usize;
        for (at, p) in row_ptr.iter().enumerate() {
            let p = p as usize;
            if p < prev {
                return Err(FormatError::index_out_of_range("row_ptr", at));
            }
            prev = p;
        }
        if prev != values.len() {
            return Err(FormatError::index_out_of_range("row_ptr", rows));
        }
        if let Some(at) = col_idx.iter().position(|c| c as usize >= cols) {
            return Err(FormatError::index_out_of_range("col_idx", at));
        }
        if !all_finite(values) {
            return Err(FormatError::NonFinite);
        }
        Ok(Self {
            rows,
            cols,
            row_ptr,
            col_idx,
            values,
        })
    }

    /// The worst-case magnitude of [`Self::mul_dense`]'s outputs for inputs of magnitude at most
    /// `x`: per row `Σ |v| · x` in `f64`, widened by the rounding of the `f32` sum.
    ///
    /// # Errors
    /// The first row whose bound passes ±[`crate::layout::MAX_NETWORK_VALUE`].
    pub fn bound(&self, x: f64) -> Result<f64, usize> {
        let limit = f64::from(crate::layout::MAX_NETWORK_VALUE);
        let mut ptrs = self.row_ptr.iter();
        let mut start = ptrs.next().unwrap_or(0) as usize;
        let mut out = 0.0f64;
        for (row, end) in ptrs.enumerate() {
            let end = end as usize;
            let len = end.saturating_sub(start);
            let mut sum = 0.0f64;
            for v in self.values.slice(start, len).iter() {
                sum += f64::from(libm::fabsf(v));
            }
            let rounding = crate::nn::rounding_growth(len + 1);
            let y = sum * x * rounding;
            if y.is_nan() || y > limit {
                return Err(row);
            }
            out = out.max(y);
            start = end;
        }
        Ok(out)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of stored entries.
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// `out = A · x` for a dense matrix `x` with `f` columns (features).
    ///
    /// Each output row is `out_r = Σ_k values_k · x_{col_k}` over the row's entries in stored
    /// order, accumulated per feature from `0.0` with separate multiply and add. Empty rows give
    /// zeros.
    ///
    /// # Shapes
    /// `x`: `[cols, f]` row-major; `out`: `[rows, f]` row-major.
    ///
    /// # Errors
    /// [`BufferError::Input`] if `x.len() != cols × f`; [`BufferError::Output`] if
    /// `out.len() != rows × f`.
    pub fn mul_dense(&self, x: &[f32], f: usize, out: &mut [f32]) -> Result<(), BufferError> {
        if Some(x.len()) != self.cols.checked_mul(f) {
            return Err(BufferError::Input);
        }
        if Some(out.len()) != self.rows.checked_mul(f) {
            return Err(BufferError::Output);
        }
        if f == 0 {
            return Ok(());
        }
        let mut ptrs = self.row_ptr.iter();
        let mut start = ptrs.next().unwrap_or(0) as usize;
        for (out_row, end) in out.chunks_exact_mut(f).zip(ptrs) {
            let end = end as usize;
            let len = end.saturating_sub(start);
            out_row.fill(0.0);
            let entries = self
                .col_idx
                .slice(start, len)
                .iter()
                .zip(self.values.slice(start, len).iter());
            for (c, v) in entries {
                let c = c as usize;
                // c < cols (validated), so c · f + f ≤ cols · f = x.len().
                let x_row = x.get(c * f..c * f + f).unwrap_or(&[]);
                for (o, xv) in out_row.iter_mut().zip(x_row) {
                    *o += v * *xv;
                }
            }
            start = end;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    fn fb(v: &[f32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    fn ub(v: &[u32]) -> Vec<u8> {
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn multiplies_hand_computed() {
        // A (3 × 4) = [[2, 0, 0, 1],
        //              [0, 0, 0, 0],
        //              [0, −1, 0.5, 0]]   stored row 2 as (col 2, 0.5) then (col 1, −1).
        let rp = ub(&[0, 2, 2, 4]);
        let ci = ub(&[0, 3, 2, 1]);
        let va = fb(&[2.0, 1.0, 0.5, -1.0]);
        let a = Csr::new(
            3,
            4,
            U32s::new(&rp).unwrap(),
            U32s::new(&ci).unwrap(),
            F32s::new(&va).unwrap(),
        )
        .unwrap();
        assert_eq!((a.rows(), a.cols(), a.nnz()), (3, 4, 4));
        // x (4 × 2) = [[1, 2], [3, 4], [5, 6], [7, 8]]
        let x = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        let mut out = [f32::NAN; 6];
        a.mul_dense(&x, 2, &mut out).unwrap();
        // row 0: 2·[1, 2] + 1·[7, 8] = [9, 12]
        // row 1: empty → [0, 0]
        // row 2: 0.5·[5, 6] + (−1)·[3, 4] = [2.5 − 3, 3 − 4] = [−0.5, −1]
        assert_eq!(out, [9.0, 12.0, 0.0, 0.0, -0.5, -1.0]);

        // One feature = matrix–vector product: [2 + 4, 0, 1.5 − 2] with x = [1, 2, 3, 4].
        let mut y = [0.0; 3];
        a.mul_dense(&[1.0, 2.0, 3.0, 4.0], 1, &mut y).unwrap();
        assert_eq!(y, [6.0, 0.0, -0.5]);

        assert_eq!(a.mul_dense(&x[..7], 2, &mut out), Err(BufferError::Input));
        assert_eq!(a.mul_dense(&x, 2, &mut out[..4]), Err(BufferError::Output));
        assert_eq!(a.mul_dense(&[], 0, &mut []), Ok(()));
    }

    #[test]
    fn sums_in_stored_order() {
        // Row entries 1e8, 1, −1e8 applied to x = [1, 1, 1]:
        // ((0 + 1e8) + 1) − 1e8 = 1e8 − 1e8 = 0 (the 1 is lost against 1e8, whose ulp is 8).
        let rp = ub(&[0, 3]);
        let ci = ub(&[0, 1, 2]);
        let va = fb(&[1e8, 1.0, -1e8]);
        let a = Csr::new(
            1,
            3,
            U32s::new(&rp).unwrap(),
            U32s::new(&ci).unwrap(),
            F32s::new(&va).unwrap(),
        )
        .unwrap();
        let mut y = [9.0];
        a.mul_dense(&[1.0, 1.0, 1.0], 1, &mut y).unwrap();
        assert_eq!(y, [0.0]);
    }

    #[test]
    fn validation() {
        let u = |v: &[u32]| ub(v);
        let (rp, ci, va) = (u(&[0, 1, 2]), u(&[0, 1]), fb(&[1.0, 2.0]));
        let mk = |rows, cols, rp: &[u8], ci: &[u8], va: &[u8]| {
            let rp = std::vec::Vec::from(rp);
            let ci = std::vec::Vec::from(ci);
            let va = std::vec::Vec::from(va);
            Csr::new(
                rows,
                cols,
                U32s::new(&rp).unwrap(),
                U32s::new(&ci).unwrap(),
                F32s::new(&va).unwrap(),
            )
            .map(|_| ())
        };
        assert_eq!(mk(2, 2, &rp, &ci, &va), Ok(()));
        let row_ptr = Err(FormatError::incompatible_shapes("row_ptr"));
        assert_eq!(mk(3, 2, &rp, &ci, &va), row_ptr);
        assert_eq!(
            mk(2, 2, &rp, &ci[..4], &va),
            Err(FormatError::incompatible_shapes("values"))
        );
        let out_of_range = |what, at| Err(FormatError::index_out_of_range(what, at));
        assert_eq!(
            mk(2, 2, &u(&[1, 1, 2]), &ci, &va),
            out_of_range("row_ptr", 0)
        );
        assert_eq!(
            mk(2, 2, &u(&[0, 2, 1]), &ci, &va),
            out_of_range("row_ptr", 2)
        );
        assert_eq!(
            mk(2, 2, &u(&[0, 1, 1]), &ci, &va),
            out_of_range("row_ptr", 2)
        );
        assert_eq!(mk(2, 1, &rp, &ci, &va), out_of_range("col_idx", 1));
        assert_eq!(
            mk(2, 2, &rp, &ci, &fb(&[1.0, f32::NAN])),
            Err(FormatError::NonFinite)
        );
        // An empty matrix with no rows is valid.
        assert_eq!(mk(0, 5, &u(&[0]), &[], &[]), Ok(()));
        assert_eq!(mk(0, 5, &[], &[], &[]), row_ptr);
    }
}
