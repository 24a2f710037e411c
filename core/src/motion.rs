// S2D eq. 8 (exp map) and eq. 5 (decoding) after the generator G(z, c) of section 3.1.
//! A baked Motion3DGAN generator (S2D section 3.1): a label and a seed become a landmark motion,
//! the same bits on every target.
//!
//! The path: seed → PCG-32 (`rand_pcg`, a portable, maintained `no_std` generator) → standard
//! Gaussian noise by Box–Muller through `libm` ([`gaussian_noise`]) → the generator MLP on
//! `[z ‖ one-hot label]` → its output projected onto the tangent space at the reference motion p
//! → the exponential map ([`crate::srvf::exp_map`], a unit SRVF) → decoding onto a neutral's
//! landmarks ([`crate::srvf::decode`]) with a reach (the apex's distance from the neutral) drawn
//! from the label's training motions by the next value of the seed's Gaussian stream. No
//! allocation: every buffer is the caller's, sized by [`MotionGenerator::scratch_len`].

use rand_core::{RngCore, SeedableRng};

use crate::error::{Argument, Bound, BufferError, EvalError, FormatError};
use crate::format::{ArtifactKind, SinewFile, out_of_range};
use crate::input::check_values;
use crate::layout::UNIT_TOLERANCE;
use crate::network::{check_bound_within, load_mlp};
use crate::nn::Mlp;
use crate::srvf::{FRAMES, decode, exp_map, length_for_reach, project_tangent};
use crate::tensor::F32s;

/// The number of labels (CoMA's twelve expression classes), the one-hot code's width.
pub const LABELS: usize = 12;
/// `content` metadata of a baked generator.
pub const CONTENT: &str = "motion-generator";

/// Fills `out` with standard normal values drawn from a PCG-32 seeded with `seed`
/// (`Pcg32::seed_from_u64`): per value, two 32-bit draws `a`, `b`, `u1 = ((a >> 8) + 1) / 2²⁴`
/// in (0, 1], `u2 = (b >> 8) / 2²⁴`, and `z = √(−2 ln u1) · cos(2π u2)`, all in f32 through
/// `libm`, so the noise is the same on every target.
pub fn gaussian_noise(seed: u64, out: &mut [f32]) {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let scale = 1.0 / 16_777_216.0f32;
    for o in out {
        let u1 = ((rng.next_u32() >> 8) + 1) as f32 * scale;
        let u2 = (rng.next_u32() >> 8) as f32 * scale;
        *o = libm::sqrtf(-2.0 * libm::logf(u1)) * libm::cosf(core::f32::consts::TAU * u2);
    }
}

/// The largest magnitude of a value of [`gaussian_noise`] (defined with the other value bounds).
pub use crate::layout::NOISE_BOUND;

/// Per label, how the reach of a motion (its apex's distance from the neutral) is drawn from the
/// seed's Gaussian value g, `[LABELS, 2]` (mean, spread) pairs.
#[derive(Clone, Debug)]
enum Reaches<'a> {
    /// `motion.log_reach` (files baked since 2026-11-28): of the logarithm of the training
    /// motions' reaches, so a reach is `exp(mean + spread · g)`, always positive.
    LogNormal(F32s<'a>),
    /// `motion.reach` (files baked 2026-11-27): of the reaches themselves, so a reach is
    /// `max(0, mean + spread · g)`, 0 (a still face) for seeds far below the mean.
    Normal(F32s<'a>),
}

impl Reaches<'_> {
    /// (mean, spread) of `label` (below [`LABELS`]).
    fn of(&self, label: usize) -> (f32, f32) {
        let (Self::LogNormal(r) | Self::Normal(r)) = self;
        (r.at(2 * label), r.at(2 * label + 1))
    }

    /// The reach `label`'s draw `g` gives.
    fn drawn(&self, label: usize, g: f32) -> f32 {
        let (mean, spread) = self.of(label);
        match self {
            Self::LogNormal(_) => libm::expf(mean + spread * g),
            Self::Normal(_) => (mean + spread * g).max(0.0),
        }
    }

    /// The typical reach of `label`: the median `exp(mean)` of a log-normal draw, the mean of
    /// a normal one.
    fn typical(&self, label: usize) -> f32 {
        let (mean, _) = self.of(label);
        match self {
            Self::LogNormal(_) => libm::expf(mean),
            Self::Normal(_) => mean,
        }
    }
}

/// A validated generator.
#[derive(Clone, Debug)]
pub struct MotionGenerator<'a> {
    mlp: Mlp<'a>,
    p: F32s<'a>,
    /// `motion.length`: one length for every label (`[1]`), or per label its mean and spread
    /// (`[LABELS, 2]`).
    lengths: F32s<'a>,
    /// How a motion's reach is drawn: from `motion.log_reach` or `motion.reach`; without
    /// either a motion is decoded at its drawn arc length.
    reaches: Option<Reaches<'a>>,
    noise: usize,
    dims: usize,
    /// The metadata `labels`: the labels' names, comma-separated, if the file records them.
    labels: Option<&'a str>,
}

impl<'a> MotionGenerator<'a> {
    /// Validates `bytes` as a motion generator: kind, `content` metadata, the MLP `motion.g`
    /// (inputs = noise + [`LABELS`], outputs = `FRAMES × dims`), the reference motion `motion.p`
    /// `[FRAMES, dims]` with `dims` whole 3D points, and `motion.length`: `[1]`, one positive
    /// length for every label, or `[LABELS, 2]`, per label a positive mean and a non-negative
    /// spread, all finite; and, if present, `motion.reach` `[LABELS, 2]`, per label a positive
    /// mean and a non-negative spread, all finite. Every value is bounded so that any seed,
    /// label, neutral within ±[`crate::layout::MAX_COORDINATE`] and intensity within
    /// ±[`MAX_FACTOR`](crate::layout::MAX_FACTOR) give a finite curve (docs/FORMAT.md, "Value bounds"): the generator's
    /// outputs within ±[`MAX_FACTOR`](crate::layout::MAX_FACTOR) for noise within ±[`NOISE_BOUND`], `motion.p` of unit
    /// norm within [`UNIT_TOLERANCE`], means positive and spreads non-negative, all at most
    /// [`MAX_FACTOR`](crate::layout::MAX_FACTOR).
    pub fn from_bytes(bytes: &'a [u8]) -> Result<Self, FormatError> {
        let file = SinewFile::from_bytes_of_kind(bytes, ArtifactKind::MotionGenerator)?;
        if file.metadata().get("content") != Some(CONTENT) {
            return Err(file.metadata().bad_entry("content"));
        }
        let mlp = load_mlp(&file, "motion.g")?;
        let (shape, rank) = file.dims_of("motion.p")?;
        let [frames, dims, ..] = shape;
        if rank != 2 || frames as usize != FRAMES || dims == 0 || dims % 3 != 0 {
            return Err(FormatError::incompatible_shapes("motion.p"));
        }
        let p = file.f32_tensor("motion.p", &[frames, dims])?;
        let dims = dims as usize;
        if mlp.inputs() <= LABELS || mlp.outputs() != FRAMES * dims {
            return Err(FormatError::incompatible_shapes("motion.g"));
        }
        check_bound_within(
            &mlp,
            "motion.g",
            f64::from(NOISE_BOUND),
            crate::error::NetworkLimit::Tangent {
                outputs: u32::try_from(mlp.outputs()).unwrap_or(u32::MAX),
            },
        )?;
        if libm::fabsf(squared_norm(&p) - 1.0) > UNIT_TOLERANCE {
            return Err(out_of_range("motion.p", 0, Bound::UnitMotion));
        }
        let (shape, rank) = file.dims_of("motion.length")?;
        let lengths = match (rank, shape[0]) {
            (1, 1) => file.f32_tensor("motion.length", &[1])?,
            (2, n) if n as usize == LABELS => {
                file.f32_tensor("motion.length", &[LABELS as u32, 2])?
            }
            _ => return Err(FormatError::incompatible_shapes("motion.length")),
        };
        check_spreads("motion.length", &lengths, rank == 2)?;
        let reaches = if file.section("motion.log_reach").is_some() {
            let reaches = file.f32_tensor("motion.log_reach", &[LABELS as u32, 2])?;
            check_log_spreads("motion.log_reach", &reaches)?;
            Some(Reaches::LogNormal(reaches))
        } else if file.section("motion.reach").is_some() {
            let reaches = file.f32_tensor("motion.reach", &[LABELS as u32, 2])?;
            check_spreads("motion.reach", &reaches, true)?;
            Some(Reaches::Normal(reaches))
        } else {
            None
        };
        let labels = file
            .metadata()
            .get("labels")
            .filter(|names| names.split(',').count() == LABELS);
        Ok(Self {
            labels,
            noise: mlp.inputs() - LABELS,
            mlp,
            p,
            lengths,
            reaches,
            dims,
        })
    }

    /// The name of `label` (below [`LABELS`]) as the file records it (metadata `labels`, e.g.
    /// `mouth_open`); `None` past the end or when the file records no names or not [`LABELS`] of
    /// them.
    pub fn label_name(&self, label: usize) -> Option<&'a str> {
        self.labels?.split(',').nth(label).map(str::trim)
    }

    /// Noise dimensions.
    pub fn noise_len(&self) -> usize {
        self.noise
    }

    /// Coordinates per frame (3 × landmarks).
    pub fn dims(&self) -> usize {
        self.dims
    }

    /// Length of a motion, `FRAMES × dims`.
    pub fn motion_len(&self) -> usize {
        FRAMES * self.dims
    }

    /// Length of a decoded landmark curve, `(FRAMES + 1) × dims` (frame 0 the neutral).
    pub fn curve_len(&self) -> usize {
        (FRAMES + 1) * self.dims
    }

    /// The mean arc length of `label`'s training curves (of all labels', for a file with one
    /// length): the length a motion of intensity 1 has on average. 0 for a label not below
    /// [`LABELS`].
    pub fn length(&self, label: usize) -> f32 {
        self.length_of(label).0
    }

    /// The standard deviation of `label`'s training curves' arc length (0 for a file with one
    /// length, or a label not below [`LABELS`]).
    pub fn length_spread(&self, label: usize) -> f32 {
        self.length_of(label).1
    }

    /// The typical reach of `label`'s training motions (the distance of the apex from the
    /// neutral, in units of the per-frame normalised landmarks): their median `exp(mean)` where
    /// the file draws reaches log-normally (`motion.log_reach`), their mean where it draws them
    /// normally (`motion.reach`); `None` without reaches or for a label not below [`LABELS`].
    pub fn reach(&self, label: usize) -> Option<f32> {
        let reaches = self.reaches.as_ref().filter(|_| label < LABELS)?;
        Some(reaches.typical(label))
    }

    /// The length `q` (a motion of `label`, `[FRAMES × dims]`) decodes with at intensity 1 and
    /// the label's typical draw: [`crate::srvf::length_for_reach`] of
    /// [`MotionGenerator::reach`] where the file has reaches, the mean arc length otherwise.
    ///
    /// # Errors
    /// [`BufferError::Input`] for a label not below [`LABELS`] or a `q` of another length.
    pub fn mean_length(&self, label: usize, q: &[f32]) -> Result<f32, BufferError> {
        if label >= LABELS || q.len() != self.motion_len() {
            return Err(BufferError::Input);
        }
        match self.reach(label) {
            Some(reach) => length_for_reach(q, self.dims, reach),
            None => Ok(self.length(label)),
        }
    }

    /// (mean, spread) of `label`'s arc length.
    fn length_of(&self, label: usize) -> (f32, f32) {
        if label >= LABELS {
            return (0.0, 0.0);
        }
        if self.lengths.iter().len() == 1 {
            return (self.lengths.at(0), 0.0);
        }
        (self.lengths.at(2 * label), self.lengths.at(2 * label + 1))
    }

    /// Scratch length [`MotionGenerator::motion`] and [`MotionGenerator::landmarks`] need.
    pub fn scratch_len(&self) -> usize {
        self.mlp.inputs() + 3 * self.motion_len() + self.mlp.scratch_len()
    }

    /// The motion of `label` from `seed`: `exp_p(project_p(G([z ‖ one-hot(label)])))`, a unit
    /// SRVF, into `out` (`[FRAMES × dims]`).
    ///
    /// # Errors
    /// [`BufferError::Input`] for a label not below [`LABELS`]; [`BufferError::Output`],
    /// [`BufferError::Scratch`] for wrong buffer lengths.
    pub fn motion(
        &self,
        label: usize,
        seed: u64,
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), BufferError> {
        if label >= LABELS {
            return Err(BufferError::Input);
        }
        if out.len() != self.motion_len() {
            return Err(BufferError::Output);
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch);
        }
        self.motion_into(label, seed, scratch, out).map(|_| ())
    }

    /// The landmark curve of `label` from `seed` on `neutral` (`[dims]`, the face's landmarks):
    /// [`MotionGenerator::motion`] decoded into `out` (`[(FRAMES + 1) × dims]`, frame 0 the
    /// neutral) so that its apex lies `intensity × max(0, m + s · g)` from the neutral (in
    /// normalised landmarks; [`crate::srvf::length_for_reach`]), where `m` and `s` are the mean
    /// and spread of the label's training reaches and `g` is the seed's standard normal value
    /// drawn right after the noise: the SRVF is scale-free, so how far a motion goes is drawn
    /// from its label's training motions. A file without reaches draws the arc length instead,
    /// from [`MotionGenerator::length`] and [`MotionGenerator::length_spread`].
    ///
    /// # Errors
    /// [`BufferError::Input`] for a label not below [`LABELS`] or a neutral of another length;
    /// [`BufferError::Output`], [`BufferError::Scratch`] for wrong buffer lengths;
    /// [`EvalError::Input`] for an intensity outside ±[`MAX_FACTOR`](crate::layout::MAX_FACTOR) or a neutral coordinate
    /// outside ±[`crate::layout::MAX_COORDINATE`] (or either not finite).
    pub fn landmarks(
        &self,
        label: usize,
        seed: u64,
        intensity: f32,
        neutral: &[f32],
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<(), EvalError> {
        if neutral.len() != self.dims {
            return Err(BufferError::Input.into());
        }
        if scratch.len() < self.scratch_len() {
            return Err(BufferError::Scratch.into());
        }
        if label < LABELS && out.len() == self.curve_len() {
            check_values(Argument::Intensity, &[intensity])?;
            check_values(Argument::Neutral, neutral)?;
        }
        // The motion itself lives in the first motion-sized part of the scratch.
        let (q, rest) = scratch.split_at_mut(self.motion_len());
        let g = self.motion_into(label, seed, rest, q)?;
        let length = match &self.reaches {
            Some(reaches) => length_for_reach(q, self.dims, reaches.drawn(label, g))?,
            None => {
                let (mean, spread) = self.length_of(label);
                (mean + spread * g).max(0.0)
            }
        };
        Ok(decode(q, neutral, intensity * length, out)?)
    }

    /// [`MotionGenerator::motion`] with scratch of at least `scratch_len() − motion_len()`;
    /// returns the seed's Gaussian value after the noise (the one that draws the length).
    fn motion_into(
        &self,
        label: usize,
        seed: u64,
        scratch: &mut [f32],
        out: &mut [f32],
    ) -> Result<f32, BufferError> {
        if label >= LABELS {
            return Err(BufferError::Input);
        }
        let need = self.mlp.inputs() + 2 * self.motion_len() + self.mlp.scratch_len();
        let scratch = scratch.get_mut(..need).ok_or(BufferError::Scratch)?;
        let (input, rest) = scratch.split_at_mut(self.mlp.inputs());
        let (s, rest) = rest.split_at_mut(self.motion_len());
        let (p, rest) = rest.split_at_mut(self.motion_len());
        // The seed's stream gives the noise and then one more value, the length's draw; the
        // code's first slot holds it until the code is written.
        let drawn = input.get_mut(..=self.noise).ok_or(BufferError::Scratch)?;
        gaussian_noise(seed, drawn);
        let g = drawn.last().copied().unwrap_or(0.0);
        let (_, code) = input.split_at_mut(self.noise);
        for (k, c) in code.iter_mut().enumerate() {
            *c = if k == label { 1.0 } else { 0.0 };
        }
        for (d, v) in p.iter_mut().zip(self.p.iter()) {
            *d = v;
        }
        self.mlp.eval(input, s, rest)?;
        project_tangent(p, s)?;
        exp_map(p, s, out)?;
        Ok(g)
    }
}

/// `⟨p, p⟩ = Σ p_i² / FRAMES`, summed in index order as [`crate::srvf::inner`].
fn squared_norm(p: &F32s<'_>) -> f32 {
    let mut s = 0.0f32;
    for x in p.iter() {
        s += x * x;
    }
    s / FRAMES as f32
}

/// Checks section `name`'s `values` as (mean, spread) pairs (`pairs`) or single means: each mean
/// positive, each spread non-negative, all at most [`MAX_FACTOR`](crate::layout::MAX_FACTOR).
fn check_spreads(name: &str, values: &F32s<'_>, pairs: bool) -> Result<(), FormatError> {
    for (i, v) in values.iter().enumerate() {
        let bound = if pairs && i % 2 == 1 {
            Bound::NonNegativeFactor
        } else {
            Bound::PositiveFactor
        };
        if !bound.contains(v) {
            return Err(out_of_range(name, i, bound));
        }
    }
    Ok(())
}

/// Checks section `name`'s `values` as (mean, spread) pairs of a logarithm: each mean within
/// ±[`MAX_FACTOR`](crate::layout::MAX_FACTOR), each spread non-negative and at most
/// [`MAX_FACTOR`](crate::layout::MAX_FACTOR), and every draw `exp(mean + spread · g)`, for
/// `|g|` up to [`NOISE_BOUND`], at most [`MAX_FACTOR`](crate::layout::MAX_FACTOR)
/// ([`Bound::LogNormalFactor`], naming the spread): the reaches a normal draw may reach too.
fn check_log_spreads(name: &str, values: &F32s<'_>) -> Result<(), FormatError> {
    let largest = libm::logf(crate::layout::MAX_FACTOR);
    for i in 0..values.iter().len() / 2 {
        let (mean, spread) = (values.at(2 * i), values.at(2 * i + 1));
        if !Bound::Factor.contains(mean) {
            return Err(out_of_range(name, 2 * i, Bound::Factor));
        }
        if !Bound::NonNegativeFactor.contains(spread) {
            return Err(out_of_range(name, 2 * i + 1, Bound::NonNegativeFactor));
        }
        if mean + NOISE_BOUND * spread > largest {
            return Err(out_of_range(name, 2 * i + 1, Bound::LogNormalFactor));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;

    #[test]
    fn gaussian_noise_is_seeded_and_standard() {
        let mut a = vec![0.0f32; 20_000];
        let mut b = a.clone();
        gaussian_noise(7, &mut a);
        gaussian_noise(7, &mut b);
        assert_eq!(a, b);
        gaussian_noise(8, &mut b);
        assert_ne!(a, b);
        let n = a.len() as f32;
        let mean = a.iter().sum::<f32>() / n;
        let var = a.iter().map(|x| (x - mean) * (x - mean)).sum::<f32>() / n;
        assert!(mean.abs() < 0.03, "{mean}");
        assert!((var - 1.0).abs() < 0.05, "{var}");
        assert!(a.iter().all(|x| x.is_finite()));
    }

    #[test]
    fn other_kinds_are_refused() {
        let s2d = include_bytes!("../../tests/data/s2d-ict.sinew");
        assert_eq!(
            MotionGenerator::from_bytes(s2d).err(),
            Some(FormatError::WrongKind)
        );
    }
}
