//! A baked Motion3DGAN generator that owns its bytes, played with an S2D decoder
//! ([`sinew_core::sequence::Sequence`], the path of `sinew generate` and every firmware target):
//! a label and a seed become a landmark curve, and each curve frame a dense face.

use self_cell::self_cell;
use sinew_core::format::{ArtifactKind, SinewFile};
use sinew_core::motion::{LABELS, MotionGenerator};
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::srvf::FRAMES;

use crate::error::Error;
use crate::model::{Kind, Model, ModelInner, check_len};

self_cell!(
    struct MotionCell {
        owner: Box<[u8]>,
        #[covariant]
        dependent: MotionGenerator,
    }
    impl {Debug}
);

/// A validated motion generator that owns its bytes.
#[derive(Debug)]
pub struct Motion {
    cell: MotionCell,
}

impl Motion {
    /// Validates `bytes` as a motion generator ([`MotionGenerator::from_bytes`]).
    ///
    /// # Errors
    /// The core's [`sinew_core::FormatError`] message; for another kind of artefact, that of
    /// `WrongKind` with the kind found.
    pub fn load(bytes: Vec<u8>) -> Result<Self, Error> {
        let file = SinewFile::from_bytes(&bytes)?;
        if file.kind != ArtifactKind::MotionGenerator {
            return Err(Error::new(format!(
                "{} ({}, not a motion generator)",
                sinew_core::FormatError::WrongKind,
                file.kind
            )));
        }
        let cell = MotionCell::try_new(bytes.into_boxed_slice(), |b| {
            MotionGenerator::from_bytes(b).map_err(Error::from)
        })?;
        Ok(Self { cell })
    }

    fn generator(&self) -> &MotionGenerator<'_> {
        self.cell.borrow_dependent()
    }

    /// Labels the generator knows.
    pub const fn label_count(&self) -> usize {
        LABELS
    }

    /// Frames of a motion after its neutral frame 0.
    pub const fn frame_count(&self) -> usize {
        FRAMES
    }

    /// Landmarks the generator moves.
    pub fn landmark_count(&self) -> usize {
        self.generator().dims() / 3
    }

    /// Noise values drawn from a seed.
    pub fn noise_len(&self) -> usize {
        self.generator().noise_len()
    }

    /// The labels' names as the file records them (`mouth_open`, …), or `label_0` … when it
    /// records none.
    pub fn label_names(&self) -> Vec<String> {
        (0..LABELS)
            .map(|i| {
                self.generator()
                    .label_name(i)
                    .map_or_else(|| format!("label_{i}"), str::to_owned)
            })
            .collect()
    }

    /// This generator paired with the S2D decoder of `decoder`.
    fn sequence<'s>(&'s self, decoder: &'s Model) -> Result<Sequence<'s>, Error> {
        let ModelInner::S2d { cell, .. } = &decoder.inner else {
            return Err(Error::new(format!(
                "a motion plays on {}, this model is {}",
                Kind::S2d.long_name(),
                decoder.kind().long_name()
            )));
        };
        let d: &S2dDecoder<'_> = cell.borrow_dependent();
        let (dims, inputs) = (self.generator().dims(), d.input_len());
        Sequence::new(self.generator().clone(), d.clone()).map_err(|_| {
            Error::new(format!(
                "the generator moves {} landmarks, the decoder reads {}",
                dims / 3,
                inputs / 3
            ))
        })
    }

    /// The landmark curve of `label` from `seed` at `intensity` on `neutral` (a face in the
    /// decoder's topology; `None`: the decoder's template): [`Sequence::curve`].
    ///
    /// # Shapes
    /// `neutral`: `[V, 3]`; returns `[(FRAMES + 1) × 3K]`, frame 0 the neutral's landmarks.
    ///
    /// # Errors
    /// `decoder` not an S2D decoder of the generator's landmarks, a label past the labels, a
    /// neutral of the wrong length, or an intensity or neutral coordinate the core refuses.
    pub fn curve(
        &self,
        decoder: &Model,
        label: usize,
        seed: u64,
        intensity: f32,
        neutral: Option<&[f32]>,
    ) -> Result<Vec<f32>, Error> {
        let sequence = self.sequence(decoder)?;
        if label >= LABELS {
            return Err(Error::new(format!(
                "label {label} is past the generator's {LABELS} labels"
            )));
        }
        let neutral = neutral.unwrap_or(&[]);
        if !neutral.is_empty() {
            check_len("neutral", neutral.len(), sequence.vertex_len())?;
        }
        let mut curve = vec![0.0; sequence.curve_len()];
        let mut input = vec![0.0; sequence.input_len()];
        let mut scratch = vec![0.0; sequence.scratch_len()];
        let mut buf = SequenceBuffers {
            curve: &mut curve,
            input: &mut input,
            neutral,
            scratch: &mut scratch,
            vertices: &mut [],
        };
        sequence
            .curve(label, seed, intensity, &mut buf)
            .map_err(|e| Error::eval(e, &[]))?;
        Ok(curve)
    }

    /// Frame `t` (0 to [`FRAMES`]) of `curve` decoded onto `neutral` (the one the curve was
    /// generated on; `None`: the decoder's template): [`Sequence::frame_of`].
    ///
    /// # Shapes
    /// `curve`: `[(FRAMES + 1) × 3K]`; `neutral`: `[V, 3]`; returns `[V, 3]` vertices.
    ///
    /// # Errors
    /// `decoder` not an S2D decoder of the generator's landmarks, `t` past [`FRAMES`], a curve or
    /// neutral of the wrong length, or a curve value or a neutral coordinate the core refuses.
    pub fn frame(
        &self,
        decoder: &Model,
        curve: &[f32],
        t: usize,
        neutral: Option<&[f32]>,
    ) -> Result<Vec<f32>, Error> {
        let sequence = self.sequence(decoder)?;
        if t > FRAMES {
            return Err(Error::new(format!(
                "frame {t} is past the motion's {FRAMES} frames"
            )));
        }
        check_len("curve", curve.len(), sequence.curve_len())?;
        let neutral = neutral.unwrap_or(&[]);
        if !neutral.is_empty() {
            check_len("neutral", neutral.len(), sequence.vertex_len())?;
        }
        let mut input = vec![0.0; sequence.input_len()];
        let mut scratch = vec![0.0; sequence.scratch_len()];
        let mut vertices = vec![0.0; sequence.vertex_len()];
        sequence
            .frame_of(t, curve, neutral, &mut input, &mut scratch, &mut vertices)
            .map_err(|e| Error::eval(e, &[]))?;
        Ok(vertices)
    }
}
