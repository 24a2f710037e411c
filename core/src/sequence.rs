// S2D section 3: a Motion3DGAN landmark curve (eq. 5) decoded frame by frame by S2D-Dec.
//! A generated sequence: a baked Motion3DGAN generator and a baked S2D decoder played together,
//! the one path by which a label and a seed become dense meshes (`sinew generate`, the host's
//! golden test and every firmware target call it).
//!
//! Two steps, so that the memory of the first serves the second: [`Sequence::curve`] generates
//! the whole landmark curve on the neutral's landmarks ([`MotionGenerator::landmarks`]), then
//! [`Sequence::frame`] turns one curve frame into the dense face (the decoder's input from
//! frame 0 and frame `t`, decoded onto the neutral). The scratch is shared: the generator's
//! working memory is free again before the first frame is decoded. Nothing allocates; every
//! buffer is the caller's ([`SequenceBuffers`]), sized by [`Sequence`]'s `*_len` methods.

use crate::error::{Argument, BufferError, EvalError, FormatError};
use crate::hash::frame_hash;
use crate::input::{check_value, check_values};
use crate::motion::MotionGenerator;
use crate::s2d::S2dDecoder;
use crate::srvf::FRAMES;

/// A generator and the decoder whose landmarks it moves, checked against each other.
#[derive(Debug)]
pub struct Sequence<'a> {
    generator: MotionGenerator<'a>,
    decoder: S2dDecoder<'a>,
}

/// Caller-owned buffers of a [`Sequence`] with `D` landmark coordinates and `V` vertices.
#[derive(Debug)]
pub struct SequenceBuffers<'b> {
    /// `[(FRAMES + 1) × D]` the landmark curve, frame 0 the neutral's landmarks: written by
    /// [`Sequence::curve`], read by [`Sequence::frame`].
    pub curve: &'b mut [f32],
    /// `[D]` the decoder's input (while the curve is generated, the neutral's landmarks).
    pub input: &'b mut [f32],
    /// `[V, 3]` the neutral face to play on, or empty to play on the decoder's template.
    pub neutral: &'b [f32],
    /// At least [`Sequence::scratch_len`] values, shared by the generator and the decoder.
    pub scratch: &'b mut [f32],
    /// `[V, 3]` the decoded vertices of the last frame.
    pub vertices: &'b mut [f32],
}

impl<'a> Sequence<'a> {
    /// Pairs `generator` with `decoder`.
    ///
    /// # Errors
    /// [`FormatError::IncompatibleShapes`] naming the generator's `motion.p` if the generator does
    /// not move the decoder's landmarks (`3 × landmarks ≠ dims`).
    pub fn new(
        generator: MotionGenerator<'a>,
        decoder: S2dDecoder<'a>,
    ) -> Result<Self, FormatError> {
        if decoder.input_len() != generator.dims()
            || 3 * decoder.landmarks().len() != generator.dims()
        {
            return Err(FormatError::incompatible_shapes("motion.p"));
        }
        Ok(Self { generator, decoder })
    }

    /// The generator.
    pub const fn generator(&self) -> &MotionGenerator<'a> {
        &self.generator
    }

    /// The decoder.
    pub const fn decoder(&self) -> &S2dDecoder<'a> {
        &self.decoder
    }

    /// Length of [`SequenceBuffers::curve`].
    pub fn curve_len(&self) -> usize {
        self.generator.curve_len()
    }

    /// Length of [`SequenceBuffers::input`] (3 × landmarks).
    pub fn input_len(&self) -> usize {
        self.generator.dims()
    }

    /// Length of [`SequenceBuffers::vertices`] and of a non-empty [`SequenceBuffers::neutral`].
    pub fn vertex_len(&self) -> usize {
        3 * self.decoder.vertex_count()
    }

    /// Scratch both steps need: the larger of the generator's and the decoder's.
    pub fn scratch_len(&self) -> usize {
        self.generator.scratch_len().max(self.decoder.scratch_len())
    }

    /// Values of all buffers together, the neutral excluded: what a firmware's arena must hold.
    pub fn buffer_len(&self) -> usize {
        self.curve_len() + self.input_len() + self.vertex_len() + self.scratch_len()
    }

    /// Generates the landmark curve of `label` from `seed` at `intensity` (1: a length drawn
    /// from the label's training motions, [`MotionGenerator::landmarks`]) on the neutral's landmarks (`buf.neutral`'s, or the template's
    /// when it is empty) into `buf.curve`.
    ///
    /// # Errors
    /// [`BufferError::Input`] for a label out of range or a neutral of the wrong length;
    /// [`BufferError::Output`], [`BufferError::Scratch`] for wrong buffer lengths;
    /// [`EvalError::Input`] for an intensity or a neutral the generator refuses
    /// ([`MotionGenerator::landmarks`]).
    pub fn curve(
        &self,
        label: usize,
        seed: u64,
        intensity: f32,
        buf: &mut SequenceBuffers<'_>,
    ) -> Result<(), EvalError> {
        if buf.input.len() != self.input_len() {
            return Err(BufferError::Input.into());
        }
        self.neutral_landmarks(buf.neutral, buf.input)?;
        // The whole face is checked, so that a refusal names the value's index in it (the
        // generator checks the landmarks gathered from it, and would name their index).
        check_values(Argument::Neutral, buf.neutral)?;
        let scratch = buf
            .scratch
            .get_mut(..self.generator.scratch_len())
            .ok_or(BufferError::Scratch)?;
        self.generator
            .landmarks(label, seed, intensity, buf.input, scratch, buf.curve)
    }

    /// Decodes frame `t` (0 to [`FRAMES`]) of `buf.curve` into `buf.vertices`: the decoder's
    /// input from curve frames 0 and `t`, decoded onto `buf.neutral` (or the template).
    ///
    /// # Errors
    /// [`BufferError::Input`] for `t` past [`FRAMES`] or a buffer of the wrong length;
    /// [`BufferError::Output`], [`BufferError::Scratch`] as the decoder reports them;
    /// [`EvalError::Input`] for curve frames or a neutral the decoder refuses
    /// ([`S2dDecoder::input`], [`S2dDecoder::decode_onto`]).
    pub fn frame(&self, t: usize, buf: &mut SequenceBuffers<'_>) -> Result<(), EvalError> {
        self.frame_of(
            t,
            buf.curve,
            buf.neutral,
            buf.input,
            buf.scratch,
            buf.vertices,
        )
    }

    /// [`Sequence::frame`] over buffers given one by one, the curve only read: for callers that
    /// keep a generated curve apart from the buffers of the frames (the C API).
    ///
    /// # Errors
    /// As [`Sequence::frame`].
    pub fn frame_of(
        &self,
        t: usize,
        curve: &[f32],
        neutral: &[f32],
        input: &mut [f32],
        scratch: &mut [f32],
        vertices: &mut [f32],
    ) -> Result<(), EvalError> {
        let d = self.input_len();
        if t > FRAMES || curve.len() != self.curve_len() {
            return Err(BufferError::Input.into());
        }
        let (first, rest) = curve.split_at(d);
        let to = match t.checked_sub(1) {
            None => first,
            Some(k) => rest.get(k * d..(k + 1) * d).ok_or(BufferError::Input)?,
        };
        // The two frames are checked where they lie in the curve, so that a refusal names the
        // value's index in it (the decoder would name its index in one landmark set).
        for (offset, frame) in [(0, first), (t * d, to)] {
            for (i, &v) in frame.iter().enumerate() {
                check_value(Argument::Curve, offset + i, v)?;
            }
        }
        self.decoder.input(first, to, input)?;
        let scratch = scratch
            .get_mut(..self.decoder.scratch_len())
            .ok_or(BufferError::Scratch)?;
        if neutral.is_empty() {
            self.decoder.decode(input, scratch, vertices)
        } else {
            self.decoder.decode_onto(neutral, input, scratch, vertices)
        }
    }

    /// [`Sequence::frame`], then the frame's hash: the decoded vertices' bits
    /// ([`frame_hash`], the hash of every golden).
    ///
    /// # Errors
    /// As [`Sequence::frame`].
    pub fn decode_frame_hash(
        &self,
        t: usize,
        buf: &mut SequenceBuffers<'_>,
    ) -> Result<u64, EvalError> {
        self.frame(t, buf)?;
        Ok(frame_hash(buf.vertices))
    }

    /// Copies the landmark vertices of `neutral` (`[V, 3]`, or the template when empty) into
    /// `out` (`[D]`).
    fn neutral_landmarks(&self, neutral: &[f32], out: &mut [f32]) -> Result<(), BufferError> {
        let landmarks = self.decoder.landmarks().iter();
        if neutral.is_empty() {
            let template = self.decoder.neutral();
            gather(landmarks, |i| template.get(i), out)
        } else if neutral.len() == self.vertex_len() {
            gather(landmarks, |i| neutral.get(i).copied(), out)
        } else {
            Err(BufferError::Input)
        }
    }
}

/// Writes the three coordinates of each landmark vertex `v` (read with `value(3v + c)`) into
/// `out`, landmark-major.
fn gather(
    landmarks: impl Iterator<Item = u32>,
    value: impl Fn(usize) -> Option<f32>,
    out: &mut [f32],
) -> Result<(), BufferError> {
    let mut slots = out.chunks_exact_mut(3);
    for v in landmarks {
        let slot = slots.next().ok_or(BufferError::Output)?;
        for (c, o) in slot.iter_mut().enumerate() {
            *o = value(3 * v as usize + c).ok_or(BufferError::Input)?;
        }
    }
    if slots.next().is_some() {
        return Err(BufferError::Output);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    const GENERATOR: &[u8] = include_bytes!("../../tests/data/motion-ict.sinew");
    const DECODER: &[u8] = include_bytes!("../../tests/data/s2d-ict.sinew");

    fn sequence() -> Sequence<'static> {
        Sequence::new(
            MotionGenerator::from_bytes(GENERATOR).unwrap(),
            S2dDecoder::from_bytes(DECODER).unwrap(),
        )
        .unwrap()
    }

    /// Owned buffers for `s`, on `neutral` (empty: the template).
    struct Owned {
        curve: Vec<f32>,
        input: Vec<f32>,
        neutral: Vec<f32>,
        scratch: Vec<f32>,
        vertices: Vec<f32>,
    }

    impl Owned {
        fn new(s: &Sequence<'_>, neutral: Vec<f32>) -> Self {
            Self {
                curve: vec![0.0; s.curve_len()],
                input: vec![0.0; s.input_len()],
                neutral,
                scratch: vec![0.0; s.scratch_len()],
                vertices: vec![0.0; s.vertex_len()],
            }
        }

        fn view(&mut self) -> SequenceBuffers<'_> {
            SequenceBuffers {
                curve: &mut self.curve,
                input: &mut self.input,
                neutral: &self.neutral,
                scratch: &mut self.scratch,
                vertices: &mut self.vertices,
            }
        }
    }

    #[test]
    fn frame_zero_is_the_decoders_rest_and_the_curve_starts_on_the_neutral() {
        let s = sequence();
        let mut b = Owned::new(&s, Vec::new());
        s.curve(9, 7, 1.0, &mut b.view()).unwrap();
        // Curve frame 0 is the template's landmark vertices.
        let template: Vec<f32> = s.decoder().neutral().iter().collect();
        for (k, v) in s.decoder().landmarks().iter().enumerate() {
            let v = 3 * v as usize;
            assert_eq!(b.curve[3 * k..3 * k + 3], template[v..v + 3]);
        }
        // Frame 0's input is zero: the decoder's output for no motion.
        s.frame(0, &mut b.view()).unwrap();
        assert!(b.input.iter().all(|&x| x == 0.0));
        let mut scratch = vec![0.0; s.decoder().scratch_len()];
        let mut rest = vec![0.0; s.vertex_len()];
        let zero = vec![0.0; s.input_len()];
        s.decoder().decode(&zero, &mut scratch, &mut rest).unwrap();
        assert_eq!(b.vertices, rest);
    }

    #[test]
    fn the_template_given_as_a_neutral_plays_the_same_bits() {
        let s = sequence();
        let mut a = Owned::new(&s, Vec::new());
        let mut b = Owned::new(&s, s.decoder().neutral().iter().collect());
        s.curve(3, 11, 0.8, &mut a.view()).unwrap();
        s.curve(3, 11, 0.8, &mut b.view()).unwrap();
        assert_eq!(a.curve, b.curve);
        for t in [1, 15, FRAMES] {
            let ha = s.decode_frame_hash(t, &mut a.view()).unwrap();
            let hb = s.decode_frame_hash(t, &mut b.view()).unwrap();
            assert_eq!(ha, hb, "frame {t}");
            assert_eq!(ha, frame_hash(&a.vertices));
        }
        // Another seed is another sequence.
        let first = s.decode_frame_hash(FRAMES, &mut a.view()).unwrap();
        s.curve(3, 12, 0.8, &mut a.view()).unwrap();
        assert_ne!(s.decode_frame_hash(FRAMES, &mut a.view()).unwrap(), first);
    }

    #[test]
    fn bad_buffers_labels_and_frames_are_refused() {
        let s = sequence();
        let mut b = Owned::new(&s, vec![0.0; 6]);
        assert_eq!(
            s.curve(0, 1, 1.0, &mut b.view()),
            Err(BufferError::Input.into())
        );
        let mut b = Owned::new(&s, Vec::new());
        assert_eq!(
            s.curve(12, 1, 1.0, &mut b.view()),
            Err(BufferError::Input.into())
        );
        s.curve(0, 1, 1.0, &mut b.view()).unwrap();
        assert_eq!(
            s.frame(FRAMES + 1, &mut b.view()),
            Err(BufferError::Input.into())
        );
        b.scratch.truncate(s.scratch_len() - 1);
        assert!(s.frame(1, &mut b.view()).is_err());
        let mut b = Owned::new(&s, Vec::new());
        b.input.pop();
        assert_eq!(
            s.curve(0, 1, 1.0, &mut b.view()),
            Err(BufferError::Input.into())
        );
        let mut b = Owned::new(&s, Vec::new());
        b.curve.pop();
        assert_eq!(s.frame(1, &mut b.view()), Err(BufferError::Input.into()));
    }

    #[test]
    fn scratch_is_shared_and_buffers_add_up() {
        let s = sequence();
        assert_eq!(
            s.scratch_len(),
            s.generator().scratch_len().max(s.decoder().scratch_len())
        );
        assert_eq!(
            s.buffer_len(),
            s.curve_len() + s.input_len() + s.vertex_len() + s.scratch_len()
        );
        assert_eq!(s.curve_len(), (FRAMES + 1) * s.input_len());
    }
}
