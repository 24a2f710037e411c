//! The golden kernel suite on every target: each core kernel (MLP with GELU/ELU, SIREN, spiral
//! convolution, CSR product, eq. 17 skinning, vertex normals, 6D rotation, the jaw of a pose given
//! by coefficients alone) on seeded weights and inputs, hashed and compared with `tests/data/kernels.hashes`, pinned on the x86_64 host by
//! `tests/tests/suite/golden_kernels.rs`.
//!
//! The weights and inputs come from the same PCG32 stream as the host test's `sinew_tests::Rng`,
//! drawn in the same order, into caller-owned buffers (no allocation). This duplicates the host
//! test's case definitions value for value; the host test of this crate checks the hashes, so the
//! two cannot drift apart unnoticed.

use rand_core::RngCore;
use sinew_core::hash::frame_hash;
use sinew_core::jaw::LearnedJaws;
use sinew_core::linalg::Vec3;
use sinew_core::nn::{Activation, Dense, Mlp};
use sinew_core::skinning::{BoneTransform, Pose, Triangles, skin, vertex_normals};
use sinew_core::sparse::Csr;
use sinew_core::spiral::{SpiralConv, Spirals};
use sinew_core::{BufferError, F32s, FormatError, U32s, rotation};

/// The pinned kernel hashes: lines `<name> <16 hex digits> <value count>`.
pub const KERNEL_HASHES: &str = include_str!("../../../tests/data/kernels.hashes");

/// Bytes of weights the largest case needs (the 3→64→64→3 SIREN: 4,611 values).
pub const KERNEL_BYTES: usize = 20 * 1024;

/// Floats of input, output and scratch the largest case needs.
pub const KERNEL_FLOATS: usize = 1024;

/// Caller-owned buffers of the kernel suite (a `static` on the microcontrollers).
#[derive(Clone, Debug)]
pub struct KernelScratch {
    bytes: [u8; KERNEL_BYTES],
    a: [f32; KERNEL_FLOATS],
    b: [f32; KERNEL_FLOATS],
    c: [f32; KERNEL_FLOATS],
}

impl KernelScratch {
    /// Zeroed buffers.
    pub const fn new() -> Self {
        Self {
            bytes: [0; KERNEL_BYTES],
            a: [0.0; KERNEL_FLOATS],
            b: [0.0; KERNEL_FLOATS],
            c: [0.0; KERNEL_FLOATS],
        }
    }
}

impl Default for KernelScratch {
    fn default() -> Self {
        Self::new()
    }
}

/// Why a kernel case could not run (never expected: the cases are fixed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelError {
    /// A weight set was rejected.
    Format(FormatError),
    /// A buffer was too small or of the wrong length.
    Buffer(BufferError),
}

impl From<FormatError> for KernelError {
    fn from(e: FormatError) -> Self {
        Self::Format(e)
    }
}

impl From<BufferError> for KernelError {
    fn from(e: BufferError) -> Self {
        Self::Buffer(e)
    }
}

/// `sinew_tests::Rng`: PCG32 with the same stream, uniform floats from the top 24 bits.
struct Rng(rand_pcg::Pcg32);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(rand_pcg::Pcg32::new(seed, 0x0a02_bdbf_7bb3_c0a7))
    }

    fn uniform(&mut self, lo: f32, hi: f32) -> f32 {
        let u = (self.0.next_u32() >> 8) as f32 / (1u32 << 24) as f32;
        lo + (hi - lo) * u
    }

    fn fill(&mut self, out: &mut [f32], lo: f32, hi: f32) {
        for v in out {
            *v = self.uniform(lo, hi);
        }
    }

    /// Fills `out` with little-endian `f32`s.
    fn fill_bytes(&mut self, out: &mut [u8], lo: f32, hi: f32) {
        for c in out.chunks_exact_mut(4) {
            c.copy_from_slice(&self.uniform(lo, hi).to_le_bytes());
        }
    }
}

/// Splits `n` bytes off the front of `*rest`.
fn take<'a>(rest: &mut &'a mut [u8], n: usize) -> Result<&'a mut [u8], KernelError> {
    if rest.len() < n {
        return Err(KernelError::Buffer(BufferError::Scratch));
    }
    let (head, tail) = core::mem::take(rest).split_at_mut(n);
    *rest = tail;
    Ok(head)
}

fn f32s(b: &[u8]) -> Result<F32s<'_>, KernelError> {
    F32s::new(b).ok_or(KernelError::Format(FormatError::incompatible_shapes(
        "bytes",
    )))
}

fn u32s(b: &[u8]) -> Result<U32s<'_>, KernelError> {
    U32s::new(b).ok_or(KernelError::Format(FormatError::incompatible_shapes(
        "bytes",
    )))
}

fn slot(buf: &mut [f32], n: usize) -> Result<&mut [f32], KernelError> {
    buf.get_mut(..n)
        .ok_or(KernelError::Buffer(BufferError::Scratch))
}

/// An MLP with `widths` and `acts` on 64 seeded rows; returns the output's hash.
fn mlp(
    s: &mut KernelScratch,
    seed: u64,
    widths: &[usize; 4],
    acts: &[Activation; 3],
) -> Result<(u64, usize), KernelError> {
    const ROWS: usize = 64;
    let mut rng = Rng::new(seed);
    let mut rest: &mut [u8] = &mut s.bytes;
    let mut parts: [(&[u8], &[u8]); 3] = [(&[], &[]); 3];
    for (part, dims) in parts.iter_mut().zip(widths.windows(2)) {
        let &[i, o] = dims else {
            return Err(KernelError::Format(FormatError::incompatible_shapes(
                "widths",
            )));
        };
        let bound = libm::sqrtf(6.0 / i as f32) / 30.0;
        let w = take(&mut rest, 4 * i * o)?;
        rng.fill_bytes(w, -bound * 30.0, bound * 30.0);
        let b = take(&mut rest, 4 * o)?;
        rng.fill_bytes(b, -0.5, 0.5);
        *part = (w, b);
    }
    let mut layers = [None, None, None];
    for (((layer, (w, b)), act), dims) in layers
        .iter_mut()
        .zip(&parts)
        .zip(acts)
        .zip(widths.windows(2))
    {
        let &[i, o] = dims else {
            return Err(KernelError::Format(FormatError::incompatible_shapes(
                "widths",
            )));
        };
        *layer = Some(Dense::new(f32s(w)?, f32s(b)?, i, o, *act)?);
    }
    let [Some(l0), Some(l1), Some(l2)] = layers else {
        return Err(KernelError::Format(FormatError::incompatible_shapes(
            "layers",
        )));
    };
    let layers = [l0, l1, l2];
    let net = Mlp::new(&layers)?;
    let input = slot(&mut s.a, ROWS * widths.first().copied().unwrap_or(0))?;
    rng.fill(input, -1.0, 1.0);
    let n = ROWS * net.outputs();
    let out = slot(&mut s.b, n)?;
    let scratch = slot(&mut s.c, net.scratch_len())?;
    net.eval_batch(input, out, scratch)?;
    Ok((frame_hash(out), n))
}

fn spiral(s: &mut KernelScratch) -> Result<(u64, usize), KernelError> {
    let mut rng = Rng::new(3);
    let (sources, vertices, len, fin, fout) = (50usize, 30usize, 9usize, 8usize, 4usize);
    let mut rest: &mut [u8] = &mut s.bytes;
    let idx = take(&mut rest, 4 * vertices * len)?;
    for c in idx.chunks_exact_mut(4) {
        let v = (rng.uniform(0.0, sources as f32) as u32).min(sources as u32 - 1);
        c.copy_from_slice(&v.to_le_bytes());
    }
    let w = take(&mut rest, 4 * fout * len * fin)?;
    rng.fill_bytes(w, -0.3, 0.3);
    let b = take(&mut rest, 4 * fout)?;
    rng.fill_bytes(b, -0.1, 0.1);
    let spirals = Spirals::new(u32s(idx)?, vertices, len, sources)?;
    let conv = SpiralConv::new(
        spirals,
        f32s(w)?,
        f32s(b)?,
        fin,
        fout,
        Activation::Elu { alpha: 1.0 },
    )?;
    let x = slot(&mut s.a, sources * fin)?;
    rng.fill(x, -1.0, 1.0);
    let out = slot(&mut s.b, vertices * fout)?;
    conv.forward(x, out)?;
    Ok((frame_hash(out), vertices * fout))
}

fn csr(s: &mut KernelScratch) -> Result<(u64, usize), KernelError> {
    let mut rng = Rng::new(4);
    let mut rest: &mut [u8] = &mut s.bytes;
    let ptr = take(&mut rest, 4 * 5)?;
    let cols = take(&mut rest, 4 * 12)?;
    for (c, v) in ptr.chunks_exact_mut(4).zip([0u32, 3, 6, 9, 12]) {
        c.copy_from_slice(&v.to_le_bytes());
    }
    for (c, v) in cols
        .chunks_exact_mut(4)
        .zip([0u32, 1, 2, 1, 2, 3, 2, 3, 4, 0, 3, 4])
    {
        c.copy_from_slice(&v.to_le_bytes());
    }
    let vals = take(&mut rest, 4 * 12)?;
    rng.fill_bytes(vals, 0.0, 1.0);
    let m = Csr::new(4, 5, u32s(ptr)?, u32s(cols)?, f32s(vals)?)?;
    let x = slot(&mut s.a, 15)?;
    rng.fill(x, -1.0, 1.0);
    let out = slot(&mut s.b, 12)?;
    m.mul_dense(x, 3, out)?;
    Ok((frame_hash(out), 12))
}

/// Eq. 17 skinning of 64 seeded vertices, then normals of a 5×5 grid lifted by the results.
fn skinning(s: &mut KernelScratch) -> Result<[(u64, usize); 2], KernelError> {
    const N: usize = 64;
    const SHAPES: usize = 4;
    const SIDE: u32 = 5;
    let mut rng = Rng::new(5);
    let (a, rest_a) = s.a.split_at_mut(3 * N);
    let rest = a;
    rng.fill(rest, -10.0, 10.0);
    let k = slot(rest_a, N)?;
    rng.fill(k, 0.0, 1.0);
    let mut bytes: &mut [u8] = &mut s.bytes;
    let correctives = take(&mut bytes, 4 * N * SHAPES * 3)?;
    rng.fill_bytes(correctives, -0.5, 0.5);
    let mut weights = [0.0f32; SHAPES];
    rng.fill(&mut weights, 0.0, 1.0);
    let jaw6: [f32; 9] = [1.0, 0.1, -0.05, -0.08, 0.97, 0.2, 0.3, -0.4, 0.1];
    let head6: [f32; 9] = [0.98, -0.1, 0.05, 0.12, 1.0, -0.02, 1.5, 2.0, -0.5];
    let pose = Pose {
        jaw: BoneTransform::from_9d(&jaw6, Vec3::new(0.0, -2.0, -5.0)),
        head: rotation::rigid_from_9d(&head6),
    };
    let out = slot(&mut s.b, 3 * N)?;
    skin(rest, k, f32s(correctives)?, &weights, &pose, out)?;
    let skinned = (frame_hash(out), 3 * N);
    let tris = take(&mut bytes, 4 * 6 * ((SIDE - 1) * (SIDE - 1)) as usize)?;
    let mut chunks = tris.chunks_exact_mut(4);
    for r in 0..SIDE - 1 {
        for c in 0..SIDE - 1 {
            let v = r * SIDE + c;
            for i in [v, v + 1, v + SIDE, v + 1, v + SIDE + 1, v + SIDE] {
                if let Some(ch) = chunks.next() {
                    ch.copy_from_slice(&i.to_le_bytes());
                }
            }
        }
    }
    let verts = (SIDE * SIDE) as usize;
    let positions = slot(&mut s.c, 3 * verts)?;
    for (i, p) in positions.chunks_exact_mut(3).enumerate() {
        let h = out.get(i).copied().unwrap_or(0.0);
        p.copy_from_slice(&[(i as u32 % SIDE) as f32, (i as u32 / SIDE) as f32, h * 0.1]);
    }
    let triangles = Triangles::new(u32s(tris)?, verts)?;
    let normals = slot(&mut s.a, 3 * verts)?;
    vertex_normals(&triangles, positions, normals)?;
    Ok([skinned, (frame_hash(normals), 3 * verts)])
}

/// Computes every case and calls `report(name, hash, values)` for each, in the order of
/// `kernels.hashes`.
pub fn run_kernels(
    s: &mut KernelScratch,
    mut report: impl FnMut(&str, u64, usize),
) -> Result<(), KernelError> {
    let (h, n) = mlp(
        s,
        1,
        &[3, 32, 32, 3],
        &[
            Activation::Gelu,
            Activation::Elu { alpha: 1.0 },
            Activation::Identity,
        ],
    )?;
    report("mlp-gelu-elu", h, n);
    let (h, n) = mlp(
        s,
        2,
        &[3, 64, 64, 3],
        &[
            Activation::Sine { omega0: 30.0 },
            Activation::Sine { omega0: 30.0 },
            Activation::Identity,
        ],
    )?;
    report("siren-w30", h, n);
    let (h, n) = spiral(s)?;
    report("spiral-conv-elu", h, n);
    let (h, n) = csr(s)?;
    report("csr-mul", h, n);
    let [(h1, n1), (h2, n2)] = skinning(s)?;
    report("skin-eq17", h1, n1);
    report("vertex-normals", h2, n2);
    let r = rotation::from_6d(&[0.3, -1.2, 0.5, 2.0, 0.1, -0.7]);
    let mut values = [0.0f32; 9];
    for (o, c) in values.chunks_exact_mut(3).zip(r.cols) {
        o.copy_from_slice(&c.to_array());
    }
    report("rotation-6d", frame_hash(&values), 9);
    let (h, n) = jaw_blend(s)?;
    report("jaw-blend", h, n);
    Ok(())
}

/// Four learned jaw transforms (an opening, a smaller one, a sideways turn, a slight closing),
/// as `tests/tests/suite/golden_kernels.rs` writes them.
const JAWS: [[f32; 9]; 4] = [
    [1.0, 0.0, 0.0, 0.0, 0.94, 0.34, 0.0, -0.12, 0.05],
    [1.0, 0.0, 0.0, 0.0, 0.995, 0.1, 0.0, 0.0, 0.02],
    [0.998, 0.0, -0.06, 0.0, 1.0, 0.0, 0.03, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0, 0.9998, -0.02, 0.0, 0.01, 0.0],
];

/// Coefficients within the shapes' range, past it, far outside [0, 1], and one shape alone.
const JAW_WEIGHTS: [[f32; 4]; 4] = [
    [0.5, 0.3, 0.2, 0.0],
    [1.0, 1.0, 1.0, 1.0],
    [-0.7, 2.0, -1.5, 3.0],
    [0.0, 0.0, 1.0, 0.0],
];

/// The jaw of a pose given by coefficients alone (`sinew_core::jaw`) for each of
/// [`JAW_WEIGHTS`] over [`JAWS`]: 36 values.
fn jaw_blend(s: &mut KernelScratch) -> Result<(u64, usize), KernelError> {
    let bytes = s
        .bytes
        .get_mut(..4 * 36)
        .ok_or(KernelError::Buffer(BufferError::Scratch))?;
    for (c, v) in bytes.chunks_exact_mut(4).zip(JAWS.iter().flatten()) {
        c.copy_from_slice(&v.to_le_bytes());
    }
    let jaws = LearnedJaws::new(f32s(bytes)?)?;
    let out = slot(&mut s.a, 36)?;
    for (o, w) in out.chunks_exact_mut(9).zip(&JAW_WEIGHTS) {
        o.copy_from_slice(&jaws.blend(w));
    }
    Ok((frame_hash(out), 36))
}

/// The pinned hash of kernel case `name` in [`KERNEL_HASHES`], with its value count.
pub fn pinned(name: &str) -> Option<(u64, usize)> {
    pinned_in(KERNEL_HASHES, name)
}

fn pinned_in(list: &str, name: &str) -> Option<(u64, usize)> {
    list.lines().find_map(|line| {
        let mut f = line.split_ascii_whitespace();
        if f.next()? != name {
            return None;
        }
        let h = u64::from_str_radix(f.next()?, 16).ok()?;
        let n = f.next()?.parse().ok()?;
        Some((h, n))
    })
}

/// Runs the suite and compares with [`KERNEL_HASHES`]; `report(name, ok)` after each case.
/// Returns `(cases, mismatches)`; a case missing from the pinned list counts as a mismatch.
pub fn check_kernels(
    s: &mut KernelScratch,
    report: impl FnMut(&str, u64, bool),
) -> Result<(usize, usize), KernelError> {
    check_against(KERNEL_HASHES, s, report)
}

fn check_against(
    list: &str,
    s: &mut KernelScratch,
    mut report: impl FnMut(&str, u64, bool),
) -> Result<(usize, usize), KernelError> {
    let (mut cases, mut bad) = (0, 0);
    run_kernels(s, |name, h, n| {
        let ok = pinned_in(list, name) == Some((h, n));
        cases += 1;
        if !ok {
            bad += 1;
        }
        report(name, h, ok);
    })?;
    Ok((cases, bad))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::boxed::Box;
    use std::string::String;

    #[test]
    fn a_changed_or_missing_pin_is_a_mismatch() {
        // Change one digit of the SIREN's hash and drop the rotation line.
        let list: String = KERNEL_HASHES
            .lines()
            .filter(|l| !l.starts_with("rotation-6d"))
            .map(|l| {
                if l.starts_with("siren-w30 0") {
                    std::format!("{}\n", l.replacen("siren-w30 0", "siren-w30 1", 1))
                } else {
                    std::format!("{l}\n")
                }
            })
            .collect();
        let mut bad = std::vec::Vec::new();
        let (cases, mismatches) = check_against(&list, &mut Box::default(), |name, _, ok| {
            if !ok {
                bad.push(String::from(name));
            }
        })
        .unwrap();
        assert_eq!((cases, mismatches), (8, 2));
        assert_eq!(bad, ["siren-w30", "rotation-6d"]);
    }
}
