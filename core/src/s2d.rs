//! A baked S2D-Dec ("Sparse to Dense Dynamic 3D Facial Expression Generation", Otberdout et al.
//! 2022, §3.2): 68 landmark displacements → a dense per-vertex displacement of the template mesh.
//!
//! # Network
//! `inputs → (n_L + 1) · F` fully connected (the dummy row is not zeroed), then per stage, from
//! level `L − 1` down to 0: up-sampling by the CSR matrix `U_k`, a spiral convolution with ELU
//! (α = 1), and the dummy row zeroed; then an output spiral convolution at level 0 without
//! activation. Every level carries one dummy vertex (index `n_k`) that pads short spirals.
//!
//! # Sections (artefact kind [`ArtifactKind::S2dDecoder`])
//! The mesh hierarchy under prefix `s2d` as `sinew_host::s2d::hierarchy::write_sections` writes it
//! (of which the decoder reads `s2d.levels`, `s2d.h<k>.pos` for k = 0, `s2d.h<k>.spiral` and
//! `s2d.u<k>.*`), plus the network:
//!
//! | name | dtype | shape | meaning |
//! |---|---|---|---|
//! | `s2d.levels` | u32 | `[L + 1, 2]` | per level, finest first: vertices n_k (without the dummy), spiral length len_k |
//! | `s2d.h0.pos` | f32 | `[n_0, 3]` | the template's neutral positions |
//! | `s2d.h<k>.spiral` | u32 | `[n_k + 1, len_k]` | spirals of level k (indices ≤ n_k) |
//! | `s2d.u<k>.ptr`, `.col`, `.val` | u32, u32, f32 | `[n_k + 2]`, `[nnz]`, `[nnz]` | U_k: level k+1 → k, CSR `(n_k + 1) × (n_{k+1} + 1)` |
//! | `s2d.cfg` | u32 | `[3]` | inputs, F (features after the FC), outputs (3) |
//! | `s2d.input` | u32 | `[1]` | input normalisation code ([`INPUT_FROBENIUS`] or [`INPUT_NEUTRAL_SCALE`]) |
//! | `s2d.lmk` | u32 | `[inputs / 3]` | landmark vertex of each input landmark (< n_0) |
//! | `s2d.fc.w`, `s2d.fc.b` | f32 | `[(n_L + 1) · F, inputs]`, `[(n_L + 1) · F]` | the FC layer |
//! | `s2d.conv.<k>.w`, `.b` | f32 | `[out, len_k · in]`, `[out]` | the stage convolution at level k < L |
//! | `s2d.act`, `s2d.par` | u32, f32 | `[1]`, `[1]` | optional: the stages' activation code and parameter ([`Activation::from_code`]); absent: ELU, α = 1 |
//! | `s2d.out.w`, `s2d.out.b` | f32 | `[outputs, len_0 · in]`, `[outputs]` | the output convolution (identity) |

use core::fmt::Write;

use crate::error::{
    Argument, Bound, BufferError, EvalError, FormatError, InputError, InputErrorKind, SectionName,
};
use crate::format::{ArtifactKind, NAME_LEN, SinewFile};
use crate::input::check_values;
use crate::layout::MAX_FACTOR;
use crate::nn::{Activation, Dense};
use crate::sparse::Csr;
use crate::spiral::{SpiralConv, Spirals, zero_row};
use crate::tensor::{F32s, U32s};

/// Most levels (mesh resolutions) a baked decoder may have.
pub const MAX_LEVELS: usize = 8;

/// `s2d.input` code: each landmark set is centred on its mean and divided by its Frobenius norm;
/// the input is `normalised(expressive) − normalised(neutral)` ([`landmark_input`]).
pub const INPUT_FROBENIUS: u32 = 1;

/// `s2d.input` code: each landmark set is centred on its mean and both are divided by the
/// neutral set's Frobenius norm, so the input is linear in the landmark displacement
/// ([`landmark_input_neutral_scale`]).
pub const INPUT_NEUTRAL_SCALE: u32 = 2;

/// A validated S2D decoder over the artefact's bytes.
#[derive(Clone, Debug)]
pub struct S2dDecoder<'a> {
    file: SinewFile<'a>,
    inputs: usize,
    fc_features: usize,
    vertices: heapless::Vec<usize, MAX_LEVELS>,
    fc: Dense<'a>,
    ups: heapless::Vec<Csr<'a>, MAX_LEVELS>,
    convs: heapless::Vec<SpiralConv<'a>, MAX_LEVELS>,
    out: SpiralConv<'a>,
    neutral: F32s<'a>,
    landmarks: U32s<'a>,
    input_code: u32,
    half: usize,
    conv_scratch: usize,
}

fn name(parts: core::fmt::Arguments<'_>) -> Result<heapless::String<NAME_LEN>, FormatError> {
    let mut s = heapless::String::new();
    s.write_fmt(parts).map_err(|_| {
        // What fits names the section; the length is that of the whole name.
        let mut len = Length(0);
        let _ = len.write_fmt(parts);
        FormatError::limit_exceeded(&s, len.0, NAME_LEN)
    })?;
    Ok(s)
}

/// Counts the bytes written to it.
struct Length(usize);

impl Write for Length {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.0 = self.0.saturating_add(s.len());
        Ok(())
    }
}

/// `n`, a dimension of the section `section`, as the format's `u32`.
fn to_u32(section: &str, n: usize) -> Result<u32, FormatError> {
    u32::try_from(n).map_err(|_| FormatError::limit_exceeded(section, n, u32::MAX as usize))
}

/// [`FormatError::Unbounded`] for `row` of the section `section`.
fn unbounded(section: &str, row: usize) -> FormatError {
    FormatError::Unbounded {
        section: SectionName::new(section),
        row: u32::try_from(row).unwrap_or(u32::MAX),
        limit: crate::error::NetworkLimit::Values,
    }
}

/// The dimensions of a rank-2 section.
fn dims2(file: &SinewFile<'_>, name: &str) -> Result<[u32; 2], FormatError> {
    let ([a, b, ..], rank) = file.dims_of(name)?;
    if rank != 2 {
        return Err(FormatError::incompatible_shapes(name));
    }
    Ok([a, b])
}

impl<'a> S2dDecoder<'a> {
    /// Validates `bytes` as an S2D decoder (container checks, then every section's role, shape and
    /// bound: CSR structure and columns, spiral indices, chained widths, finite weights).
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        Self::from_file(SinewFile::from_bytes_of_kind(
            bytes,
            ArtifactKind::S2dDecoder,
        )?)
    }

    /// Validates the S2D sections of an already-checked container (of any kind, so that a
    /// decoder can travel inside another artefact). Besides every shape and index, the template
    /// must lie within ±[`crate::layout::MAX_COORDINATE`], the up-sampling weights and the
    /// activation's parameter within ±[`MAX_FACTOR`], and the layers, chained, must stay within
    /// ±[`crate::layout::MAX_NETWORK_VALUE`] for every input within ±[`MAX_FACTOR`]
    /// (docs/FORMAT.md, "Value bounds").
    pub fn from_file(file: SinewFile<'a>) -> Result<Self, FormatError> {
        let cfg = file.u32_tensor("s2d.cfg", &[3])?;
        let [inputs, fc_features, outputs] = [0, 1, 2].map(|i| cfg.get(i).unwrap_or(0) as usize);
        if inputs == 0 || fc_features == 0 || outputs != 3 || !inputs.is_multiple_of(3) {
            return Err(FormatError::incompatible_shapes("s2d.cfg"));
        }
        let input_code = file.u32_tensor("s2d.input", &[1])?.at(0);
        if input_code != INPUT_FROBENIUS && input_code != INPUT_NEUTRAL_SCALE {
            return Err(FormatError::unknown_code("s2d.input", 0, input_code));
        }
        let [levels, two] = dims2(&file, "s2d.levels")?;
        let levels = levels as usize;
        if levels > MAX_LEVELS {
            return Err(FormatError::limit_exceeded(
                "s2d.levels",
                levels,
                MAX_LEVELS,
            ));
        }
        if levels == 0 || two != 2 {
            return Err(FormatError::incompatible_shapes("s2d.levels"));
        }
        let table = file.u32_tensor("s2d.levels", &[to_u32("s2d.levels", levels)?, 2])?;
        let too_many = FormatError::limit_exceeded("s2d.levels", levels, MAX_LEVELS);
        let mut vertices = heapless::Vec::<usize, MAX_LEVELS>::new();
        let mut spirals = heapless::Vec::<Spirals<'a>, MAX_LEVELS>::new();
        for k in 0..levels {
            let (n, len) = (table.at(2 * k), table.at(2 * k + 1));
            // n + 1 (the dummy) must stay representable as a u32 section dimension.
            let rows = n.checked_add(1).ok_or(FormatError::LimitExceeded {
                section: SectionName::new("s2d.levels"),
                value: n,
                limit: u32::MAX - 1,
            })?;
            if n == 0 {
                return Err(FormatError::incompatible_shapes("s2d.levels"));
            }
            let sp = name(format_args!("s2d.h{k}.spiral"))?;
            let idx = file.u32_tensor(&sp, &[rows, len])?;
            let s = Spirals::new(idx, rows as usize, len as usize, rows as usize)
                .map_err(|e| e.in_section(&sp))?;
            vertices.push(n as usize).map_err(|_| too_many)?;
            spirals.push(s).map_err(|_| too_many)?;
        }
        let n_at = |k: usize| vertices.get(k).copied().unwrap_or(0);
        let n0 = n_at(0);
        let coarsest = n_at(levels - 1) + 1;

        let neutral = file.f32_tensor_within(
            "s2d.h0.pos",
            &[to_u32("s2d.h0.pos", n0)?, 3],
            Bound::Coordinate,
        )?;
        let landmarks = file.u32_tensor("s2d.lmk", &[to_u32("s2d.lmk", inputs / 3)?])?;
        if let Some(i) = landmarks.iter().position(|i| i as usize >= n0) {
            return Err(FormatError::index_out_of_range("s2d.lmk", i));
        }

        let fc_out = coarsest
            .checked_mul(fc_features)
            .ok_or(FormatError::size_overflow(
                "s2d.fc.w",
                coarsest,
                fc_features,
                0,
            ))?;
        let fc_rows = to_u32("s2d.fc.w", fc_out)?;
        let fc_w = file.f32_tensor("s2d.fc.w", &[fc_rows, to_u32("s2d.fc.w", inputs)?])?;
        let fc_b = file.f32_tensor("s2d.fc.b", &[fc_rows])?;
        let fc = Dense::new(fc_w, fc_b, inputs, fc_out, Activation::Identity)
            .map_err(|e| e.in_section("s2d.fc.w"))?;
        // The worst case of every feature map, layer after layer, for inputs within ±MAX_FACTOR.
        let mut bound = fc
            .bound(f64::from(MAX_FACTOR))
            .map_err(|row| unbounded("s2d.fc.w", row))?;

        let conv_at = |prefix: &str, k: Option<usize>, inputs: usize, act: Activation| {
            let spirals = *spirals
                .get(k.unwrap_or(0))
                .ok_or(FormatError::incompatible_shapes("s2d.levels"))?;
            let len = spirals.len();
            let (wn, bn) = match k {
                Some(k) => (
                    name(format_args!("{prefix}.{k}.w"))?,
                    name(format_args!("{prefix}.{k}.b"))?,
                ),
                None => (
                    name(format_args!("{prefix}.w"))?,
                    name(format_args!("{prefix}.b"))?,
                ),
            };
            let [out, width] = dims2(&file, &wn)?;
            if Some(width as usize) != len.checked_mul(inputs) {
                return Err(FormatError::incompatible_shapes(&wn));
            }
            let w = file.f32_tensor(&wn, &[out, width])?;
            let b = file.f32_tensor(&bn, &[out])?;
            // The bias has `out` values (checked above): only the weight's shape can be at fault.
            SpiralConv::new(spirals, w, b, inputs, out as usize, act).map_err(|e| e.in_section(&wn))
        };

        // The stages' activation: ELU (α = 1) as in the reference, or the one the artefact names.
        let stage_act = match file.section("s2d.act") {
            None => Activation::Elu { alpha: 1.0 },
            Some(_) => Activation::from_code(
                file.u32_tensor("s2d.act", &[1])?.at(0),
                file.f32_tensor_within("s2d.par", &[1], Bound::Factor)?
                    .at(0),
            )
            .map_err(|e| e.in_section("s2d.act"))?,
        };

        let mut half = fc_out;
        let grow = |half: usize, rows: usize, width: usize, section: &str| {
            let n = rows
                .checked_mul(width)
                .ok_or(FormatError::size_overflow(section, rows, width, 0))?;
            Ok::<_, FormatError>(half.max(n))
        };
        let mut ups = heapless::Vec::new();
        let mut convs = heapless::Vec::new();
        let mut width = fc_features;
        for k in (0..levels - 1).rev() {
            let (rows, cols) = (n_at(k) + 1, n_at(k + 1) + 1);
            let ptr_name = name(format_args!("s2d.u{k}.ptr"))?;
            let ptr = file.u32_tensor(&ptr_name, &[to_u32(&ptr_name, rows + 1)?])?;
            let col_name = name(format_args!("s2d.u{k}.col"))?;
            let ([nnz, ..], rank) = file.dims_of(&col_name)?;
            if rank != 1 {
                return Err(FormatError::incompatible_shapes(&col_name));
            }
            let col = file.u32_tensor(&col_name, &[nnz])?;
            let val_name = name(format_args!("s2d.u{k}.val"))?;
            let val = file.f32_tensor_within(&val_name, &[nnz], Bound::Factor)?;
            let up = Csr::new(rows, cols, ptr, col, val).map_err(|e| match e {
                FormatError::IndexOutOfRange { section, .. } if section.as_str() == "col_idx" => {
                    e.in_section(&col_name)
                }
                e => e.in_section(&ptr_name),
            })?;
            bound = up.bound(bound).map_err(|row| unbounded(&val_name, row))?;
            ups.push(up).map_err(|_| too_many)?;
            half = grow(half, rows, width, &ptr_name)?;
            let conv = conv_at("s2d.conv", Some(k), width, stage_act)?;
            let conv_name = name(format_args!("s2d.conv.{k}.w"))?;
            bound = conv
                .bound(bound)
                .map_err(|row| unbounded(&conv_name, row))?;
            width = conv.out_features();
            half = grow(half, rows, width, &conv_name)?;
            convs.push(conv).map_err(|_| too_many)?;
        }
        let out = conv_at("s2d.out", None, width, Activation::Identity)?;
        if out.out_features() != outputs {
            return Err(FormatError::incompatible_shapes("s2d.out.w"));
        }
        out.bound(bound)
            .map_err(|row| unbounded("s2d.out.w", row))?;
        half = grow(half, n0 + 1, outputs, "s2d.out.w")?;
        // The largest convolution's repacked weight block (`SpiralConv::scratch_len`).
        let conv_scratch = convs
            .iter()
            .chain(core::iter::once(&out))
            .map(SpiralConv::scratch_len)
            .max()
            .unwrap_or(0);
        half.checked_mul(2)
            .and_then(|h| h.checked_add(conv_scratch))
            .ok_or(FormatError::size_overflow("s2d", half, 2, conv_scratch))?;
        Ok(Self {
            file,
            inputs,
            fc_features,
            vertices,
            fc,
            ups,
            convs,
            out,
            neutral,
            landmarks,
            input_code,
            half,
            conv_scratch,
        })
    }

    /// The container (metadata, sections).
    pub const fn file(&self) -> &SinewFile<'a> {
        &self.file
    }

    /// Input width (3 × landmarks).
    pub const fn input_len(&self) -> usize {
        self.inputs
    }

    /// Features per coarsest-level vertex after the fully connected layer.
    pub const fn fc_features(&self) -> usize {
        self.fc_features
    }

    /// Vertices of the output mesh (level 0, without the dummy).
    pub fn vertex_count(&self) -> usize {
        self.vertices.first().copied().unwrap_or(0)
    }

    /// Vertices of each level, finest first, without the dummy.
    pub fn level_sizes(&self) -> &[usize] {
        &self.vertices
    }

    /// The template's neutral positions, `[n_0, 3]`.
    pub const fn neutral(&self) -> F32s<'a> {
        self.neutral
    }

    /// The landmark vertex indices, `[inputs / 3]`.
    pub const fn landmarks(&self) -> U32s<'a> {
        self.landmarks
    }

    /// The `s2d.input` code: how [`Self::input`] normalises landmarks ([`INPUT_FROBENIUS`] or
    /// [`INPUT_NEUTRAL_SCALE`]).
    pub const fn input_normalisation(&self) -> u32 {
        self.input_code
    }

    /// This decoder's input from a neutral and an expressive landmark set, normalised as it was
    /// trained ([`landmark_input`] or [`landmark_input_neutral_scale`]).
    ///
    /// # Errors
    /// As [`landmark_input`].
    pub fn input(
        &self,
        neutral: &[f32],
        expressive: &[f32],
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        if self.input_code == INPUT_NEUTRAL_SCALE {
            landmark_input_neutral_scale(neutral, expressive, out)
        } else {
            landmark_input(neutral, expressive, out)
        }
    }

    /// Scratch length [`Self::decode`] needs: two buffers of the largest feature map (dummy rows
    /// included), then room for the largest convolution's repacked weight block
    /// ([`SpiralConv::scratch_len`]).
    pub const fn scratch_len(&self) -> usize {
        2 * self.half + self.conv_scratch
    }

    /// Dense displacements from landmark displacements (see the module documentation).
    ///
    /// # Shapes
    /// `input`: `[inputs]`; `out`: `[n_0, 3]`; `scratch`: at least [`Self::scratch_len`] values
    /// (contents on entry ignored, on exit unspecified).
    ///
    /// # Errors
    /// [`BufferError::Input`], [`BufferError::Output`] for wrong lengths,
    /// [`BufferError::Scratch`] if `scratch` is too short; [`EvalError::Input`] for an input
    /// value that is not finite or outside ±[`MAX_FACTOR`] (the range the decoder was bounded
    /// for at load). Nothing is written then.
    pub fn displacements(
        &self,
        input: &[f32],
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        if input.len() != self.inputs {
            return Err(BufferError::Input.into());
        }
        if Some(out.len()) != self.vertex_count().checked_mul(3) {
            return Err(BufferError::Output.into());
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch.into());
        }
        check_values(Argument::Input, input)?;
        Ok(self.displacements_unchecked(input, scratch, out)?)
    }

    /// [`Self::displacements`] once the lengths and the input are checked.
    fn displacements_unchecked(
        &self,
        input: &[f32],
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), BufferError> {
        // Every length below was bounded by `half` in `from_file`, so each `get` succeeds and each
        // kernel's own length check passes; the `?`s cannot fire on a validated model.
        let (a, rest) = scratch
            .split_at_mut_checked(self.half)
            .ok_or(BufferError::Scratch)?;
        let (b, packed) = rest
            .split_at_mut_checked(self.half)
            .ok_or(BufferError::Scratch)?;
        let fc_out = self.fc.outputs();
        self.fc
            .forward(input, a.get_mut(..fc_out).ok_or(BufferError::Scratch)?)?;
        let mut width = self.fc_features;
        for (up, conv) in self.ups.iter().zip(&self.convs) {
            let (rows, cols) = (up.rows(), up.cols());
            let x = a.get(..cols * width).ok_or(BufferError::Scratch)?;
            let fine = b.get_mut(..rows * width).ok_or(BufferError::Scratch)?;
            up.mul_dense(x, width, fine)?;
            let out_f = conv.out_features();
            let y = a.get_mut(..rows * out_f).ok_or(BufferError::Scratch)?;
            conv.forward_blocked(fine, y, packed)?;
            zero_row(y, rows.saturating_sub(1), out_f)?;
            width = out_f;
        }
        let rows = self.vertex_count() + 1;
        let x = a.get(..rows * width).ok_or(BufferError::Scratch)?;
        let y = b.get_mut(..rows * 3).ok_or(BufferError::Scratch)?;
        self.out.forward_blocked(x, y, packed)?;
        out.copy_from_slice(y.get(..out.len()).ok_or(BufferError::Scratch)?);
        Ok(())
    }

    /// The expressive template: neutral positions plus [`Self::displacements`].
    ///
    /// # Shapes and errors
    /// As [`Self::displacements`]; `out_vertices`: `[n_0, 3]`.
    pub fn decode(
        &self,
        input: &[f32],
        scratch: &mut [f32],
        out_vertices: &mut [f32],
    ) -> Result<(), EvalError> {
        self.displacements(input, scratch, out_vertices)?;
        for (o, n) in out_vertices.iter_mut().zip(self.neutral.iter()) {
            *o += n;
        }
        Ok(())
    }

    /// Another neutral face (same topology) plus [`Self::displacements`]: S2D's expression
    /// transfer to a new identity.
    ///
    /// # Errors
    /// [`BufferError::Input`] if `neutral` is not `[n_0, 3]`; [`EvalError::Input`] for a neutral
    /// value that is not finite or outside ±[`crate::layout::MAX_COORDINATE`]; else as
    /// [`Self::displacements`].
    pub fn decode_onto(
        &self,
        neutral: &[f32],
        input: &[f32],
        scratch: &mut [f32],
        out_vertices: &mut [f32],
    ) -> Result<(), EvalError> {
        if neutral.len() != self.neutral.len() {
            return Err(BufferError::Input.into());
        }
        if input.len() == self.inputs && out_vertices.len() == neutral.len() {
            check_values(Argument::Neutral, neutral)?;
        }
        self.displacements(input, scratch, out_vertices)?;
        for (o, n) in out_vertices.iter_mut().zip(neutral) {
            *o += *n;
        }
        Ok(())
    }
}

/// The decoder's input from two landmark sets ([`INPUT_FROBENIUS`]): each set, `[K, 3]`, is
/// centred on its mean and divided by its Frobenius norm, and
/// `out = normalised(expressive) − normalised(neutral)`, `[K · 3]`.
///
/// # Errors
/// [`BufferError::Input`] if the sets differ in length or are not whole points;
/// [`BufferError::Output`] if `out` has another length; [`EvalError::Input`] for a landmark
/// coordinate that is not finite or outside ±[`crate::layout::MAX_COORDINATE`], or a set whose
/// points all coincide (nothing to normalise by). Nothing is written then.
pub fn landmark_input(
    neutral: &[f32],
    expressive: &[f32],
    out: &mut [f32],
) -> Result<(), EvalError> {
    centred_difference(neutral, expressive, out, true, |e, n, se, sn| {
        e * se - n * sn
    })
}

/// The decoder's input from two landmark sets ([`INPUT_NEUTRAL_SCALE`]): each set, `[K, 3]`, is
/// centred on its mean, and `out = (centred(expressive) − centred(neutral)) / ‖centred(neutral)‖`,
/// `[K · 3]`: the landmark displacement, less its mean, in units of the neutral's size.
///
/// # Errors
/// As [`landmark_input`], except that only the neutral's points must not all coincide (the
/// expressive set is not normalised by its own size).
pub fn landmark_input_neutral_scale(
    neutral: &[f32],
    expressive: &[f32],
    out: &mut [f32],
) -> Result<(), EvalError> {
    centred_difference(neutral, expressive, out, false, |e, n, _, sn| (e - n) * sn)
}

/// Centres both `[K, 3]` sets and writes `combine(e, n, se, sn)` for each coordinate, with `e`, `n`
/// the centred coordinates and `se`, `sn` the reciprocal norms of the expressive and neutral sets;
/// the neutral's norm, and with `both` the expressive's, must be positive.
fn centred_difference(
    neutral: &[f32],
    expressive: &[f32],
    out: &mut [f32],
    both: bool,
    combine: impl Fn(f32, f32, f32, f32) -> f32,
) -> Result<(), EvalError> {
    if neutral.len() != expressive.len() || !neutral.len().is_multiple_of(3) {
        return Err(BufferError::Input.into());
    }
    if out.len() != neutral.len() {
        return Err(BufferError::Output.into());
    }
    check_values(Argument::Neutral, neutral)?;
    check_values(Argument::Expressive, expressive)?;
    let degenerate = |argument| InputError::new(argument, 0, InputErrorKind::Degenerate);
    let (cn, sn) = centre_scale(neutral).ok_or(degenerate(Argument::Neutral))?;
    let (ce, se) = match centre_scale(expressive) {
        Some(c) => c,
        None if both => return Err(degenerate(Argument::Expressive).into()),
        None => (centre_size(expressive).0, 1.0),
    };
    for ((o, n), e) in out
        .chunks_exact_mut(3)
        .zip(neutral.chunks_exact(3))
        .zip(expressive.chunks_exact(3))
    {
        for (((o, n), e), (a, b)) in o.iter_mut().zip(n).zip(e).zip(cn.iter().zip(&ce)) {
            *o = combine(*e - b, *n - a, se, sn);
        }
    }
    Ok(())
}

/// Mean of a `[K, 3]` set and the reciprocal of its centred Frobenius norm; `None` for a zero
/// norm (an empty set, or points that all coincide).
fn centre_scale(points: &[f32]) -> Option<([f32; 3], f32)> {
    let (c, norm) = centre_size(points);
    (norm > 0.0).then(|| (c, 1.0 / norm))
}

/// Mean of a `[K, 3]` set and its centred Frobenius norm, summed in point order (the landmark
/// size both the decoder's input and the SRVF encoding divide by).
pub(crate) fn centre_size(points: &[f32]) -> ([f32; 3], f32) {
    let k = (points.len() / 3).max(1) as f32;
    let mut c = [0.0f32; 3];
    for p in points.chunks_exact(3) {
        for (ci, pi) in c.iter_mut().zip(p) {
            *ci += *pi;
        }
    }
    for ci in &mut c {
        *ci /= k;
    }
    let mut sq = 0.0f32;
    for p in points.chunks_exact(3) {
        for (pi, ci) in p.iter().zip(&c) {
            let d = *pi - *ci;
            sq += d * d;
        }
    }
    (c, libm::sqrtf(sq))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn section_names_fit() {
        assert_eq!(
            name(format_args!("s2d.u{}.ptr", MAX_LEVELS))
                .unwrap()
                .as_str(),
            "s2d.u8.ptr"
        );
        assert!(name(format_args!("{}", "x".repeat(NAME_LEN + 1).as_str())).is_err());
    }

    /// Each value of `got` within 1e-6 of `want`'s, and as many.
    fn assert_close(got: &[f32], want: &[f32]) {
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-6, "{got:?} against {want:?}");
        }
    }

    #[test]
    fn landmark_input_hand_computed() {
        // Neutral (0,0,0), (2,0,0): centre (1,0,0), norm √2 → ±(1/√2, 0, 0).
        // Expressive (0,0,0), (0,4,0): centre (0,2,0), norm √8 → ∓(0, 1/√2, 0).
        let neutral = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0];
        let expressive = [0.0, 0.0, 0.0, 0.0, 4.0, 0.0];
        let mut out = [0.0; 6];
        landmark_input(&neutral, &expressive, &mut out).unwrap();
        let s = core::f32::consts::FRAC_1_SQRT_2;
        assert_close(&out, &[s, -s, 0.0, -s, s, 0.0]);
        // Scale and translation of a set do not matter.
        let moved = [5.0, 1.0, 1.0, 5.0, 9.0, 1.0];
        let mut again = [0.0; 6];
        landmark_input(&neutral, &moved, &mut again).unwrap();
        assert_close(&again, &out);
        assert_eq!(
            landmark_input(&neutral, &expressive[..3], &mut out),
            Err(BufferError::Input.into())
        );
        assert_eq!(
            landmark_input(&neutral, &expressive, &mut out[..5]),
            Err(BufferError::Output.into())
        );
        // A set whose points all coincide has no size to normalise by: refused, nothing
        // written, naming the set.
        let mut z = [9.0; 6];
        let degenerate = |argument| {
            Err(EvalError::Input(InputError::new(
                argument,
                0,
                InputErrorKind::Degenerate,
            )))
        };
        assert_eq!(
            landmark_input(&[1.0; 6], &expressive, &mut z),
            degenerate(Argument::Neutral)
        );
        assert_eq!(
            landmark_input(&neutral, &[1.0; 6], &mut z),
            degenerate(Argument::Expressive)
        );
        assert_eq!(z, [9.0; 6]);
        // The neutral-scale input only divides by the neutral's size.
        landmark_input_neutral_scale(&neutral, &[1.0; 6], &mut z).unwrap();
        assert_eq!(
            landmark_input_neutral_scale(&[1.0; 6], &expressive, &mut z),
            degenerate(Argument::Neutral)
        );
        // NaN and out-of-range coordinates are refused by index.
        let mut bad = neutral;
        bad[4] = f32::NAN;
        assert_eq!(
            landmark_input(&bad, &expressive, &mut z),
            Err(EvalError::Input(InputError::new(
                Argument::Neutral,
                4,
                InputErrorKind::NonFinite
            )))
        );
        bad[4] = 1e6;
        assert_eq!(
            landmark_input(&neutral, &bad, &mut z),
            Err(EvalError::Input(InputError::new(
                Argument::Expressive,
                4,
                InputErrorKind::OutOfRange
            )))
        );
    }

    #[test]
    fn neutral_scale_input_hand_computed() {
        // Neutral (0,0,0), (2,0,0): centre (1,0,0), norm √2. Expressive (0,0,0), (0,4,0): centre
        // (0,2,0), centred (0,−2,0), (0,2,0). Displacement of the centred sets: (1,−2,0),
        // (−1,2,0), divided by √2.
        let neutral = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0];
        let expressive = [0.0, 0.0, 0.0, 0.0, 4.0, 0.0];
        let mut out = [0.0; 6];
        landmark_input_neutral_scale(&neutral, &expressive, &mut out).unwrap();
        let s = core::f32::consts::FRAC_1_SQRT_2;
        assert_close(&out, &[s, -2.0 * s, 0.0, -s, 2.0 * s, 0.0]);
        // A translated expressive set gives the same input; a scaled one a scaled input
        // (unlike `landmark_input`, whose sets are each scaled to unit norm).
        let moved = [5.0, 1.0, 1.0, 5.0, 5.0, 1.0];
        let mut again = [0.0; 6];
        landmark_input_neutral_scale(&neutral, &moved, &mut again).unwrap();
        assert_close(&again, &out);
        // Twice the displacement, twice the input.
        let twice = [0.0, 0.0, 0.0, -2.0, 8.0, 0.0];
        landmark_input_neutral_scale(&neutral, &twice, &mut again).unwrap();
        assert_close(&again, &[2.0 * s, -4.0 * s, 0.0, -2.0 * s, 4.0 * s, 0.0]);
        assert_eq!(
            landmark_input_neutral_scale(&neutral, &expressive[..3], &mut out),
            Err(BufferError::Input.into())
        );
        assert_eq!(
            landmark_input_neutral_scale(&neutral, &expressive, &mut out[..5]),
            Err(BufferError::Output.into())
        );
    }
}
