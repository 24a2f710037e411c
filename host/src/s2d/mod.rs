//! S2D-Dec ("Sparse to Dense Dynamic 3D Facial Expression Generation", sections 3.2 and 4):
//! the mesh hierarchy and spirals it runs on, the decoder from 68 landmark displacements to dense
//! per-vertex displacements, its training data and protocols, and its bake into `.sinew`.
//!
//! `shared/notes/s2d-reference.md` fixes the reference network's configuration; the types here
//! follow it: every level has one extra "dummy" vertex (index `n_vertices`) used as padding.

/// A sparse matrix in compressed-sparse-row form, as `sinew_core::sparse::Csr` reads it.
///
/// # Shapes
/// `row_ptr`: `[rows + 1]`; `col_idx`, `values`: `[nnz]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampling {
    /// Number of rows (output vertices, dummy included).
    pub rows: usize,
    /// Number of columns (input vertices, dummy included).
    pub cols: usize,
    /// Start of each row's entries in `col_idx` / `values`, plus the end.
    pub row_ptr: Vec<u32>,
    /// Column of each entry.
    pub col_idx: Vec<u32>,
    /// Value of each entry.
    pub values: Vec<f32>,
}

/// One level of the mesh hierarchy (level 0 is the full-resolution template).
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Vertex positions of this level's mesh (without the dummy vertex).
    pub positions: Vec<[f32; 3]>,
    /// Triangles of this level's mesh.
    pub triangles: Vec<[u32; 3]>,
    /// Spiral length of this level (after dilation).
    pub spiral_len: usize,
    /// Spiral indices, `[(n + 1) × spiral_len]` row-major, `n = positions.len()`; the dummy
    /// vertex's row (the last) and the padding of short spirals hold the dummy index `n`.
    pub spirals: Vec<u32>,
}

/// The mesh hierarchy of one template: levels 0 (finest) to L (coarsest) and the samplings
/// between neighbouring levels.
#[derive(Clone, Debug, PartialEq)]
pub struct Hierarchy {
    /// The levels, finest first.
    pub levels: Vec<Level>,
    /// `down[i]`: level `i` → level `i + 1`, a 0/1 selection, `(n_{i+1} + 1) × (n_i + 1)`.
    pub down: Vec<Sampling>,
    /// `up[i]`: level `i + 1` → level `i`, barycentric weights, `(n_i + 1) × (n_{i+1} + 1)`.
    pub up: Vec<Sampling>,
}

pub mod apply;
pub mod bake;
pub mod baseline;
pub mod checkpoint;
pub mod data;
pub mod decoder;
pub mod experiment;
pub mod hierarchy;
pub mod objective;
pub mod pairs_file;
pub mod protocol;
pub mod report;
pub mod spirals;
pub mod symmetry;
#[cfg(any(test, feature = "test-support"))]
pub mod synthetic;
pub mod train;
