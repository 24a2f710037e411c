//! Det-LM's landmarks: every frame of a motion decoded by S2D-Dec onto the decoder's neutral and
//! its landmark vertices read back ([`Redetector`]), for a whole reading at once ([`Reading`]).

use std::collections::HashMap;

use rayon::prelude::*;
use sinew_core::s2d::S2dDecoder;

/// A frame the decoder refused while its landmarks were re-extracted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum RedetectError {
    /// The frame cannot be the decoder's input.
    #[error("decoder input")]
    Input(#[source] sinew_core::EvalError),
    /// The frame cannot be decoded.
    #[error("decoding")]
    Decode(#[source] sinew_core::EvalError),
}

/// Landmark frames (`[K · 3]` each) re-extracted through S2D-Dec on the decoder's neutral.
pub(super) struct Redetector<'a> {
    decoder: &'a S2dDecoder<'a>,
    base: Vec<f32>,
    lmk: Vec<usize>,
}

impl<'a> Redetector<'a> {
    pub(super) fn new(decoder: &'a S2dDecoder<'a>) -> Self {
        Self {
            decoder,
            base: decoder.neutral().iter().collect(),
            lmk: decoder.landmarks().iter().map(|v| v as usize).collect(),
        }
    }

    /// The decoder neutral's landmarks, `[K · 3]`.
    pub(super) fn neutral_landmarks(&self) -> Vec<f32> {
        self.lmk
            .iter()
            .flat_map(|&v| self.base[3 * v..3 * v + 3].iter().copied())
            .collect()
    }

    /// Each frame decoded (`input(frames[0], frame)`) onto the neutral, its landmarks read back.
    pub(super) fn frames(&self, frames: &[Vec<f32>]) -> Result<Vec<Vec<f32>>, RedetectError> {
        let d = self.decoder;
        let mut scratch = vec![0.0f32; d.scratch_len()];
        let mut input = vec![0.0f32; d.input_len()];
        let mut mesh = vec![0.0f32; self.base.len()];
        frames
            .iter()
            .map(|f| {
                d.input(&frames[0], f, &mut input)
                    .map_err(RedetectError::Input)?;
                d.decode_onto(&self.base, &input, &mut scratch, &mut mesh)
                    .map_err(RedetectError::Decode)?;
                Ok(self
                    .lmk
                    .iter()
                    .flat_map(|&v| mesh[3 * v..3 * v + 3].iter().copied())
                    .collect())
            })
            .collect()
    }

    /// [`Self::frames`] of each sequence. Decoding is a pure function of a sequence's bits, so a
    /// sequence that repeats an earlier one bit for bit (the LSTM's diversity group: one motion a
    /// label, once per seed) is decoded once and copied.
    pub(super) fn all(&self, seqs: &[Vec<Vec<f32>>]) -> Result<Vec<Vec<Vec<f32>>>, RedetectError> {
        // Each sequence's slot among the distinct ones, and the first sequence of each slot.
        let mut slot_of: HashMap<Vec<u32>, usize> = HashMap::new();
        let mut distinct: Vec<usize> = Vec::new();
        let slots: Vec<usize> = seqs
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let mut bits: Vec<u32> = s.iter().flatten().map(|x| x.to_bits()).collect();
                bits.extend(s.iter().map(|f| f.len() as u32));
                *slot_of.entry(bits).or_insert_with(|| {
                    distinct.push(i);
                    distinct.len() - 1
                })
            })
            .collect();
        let decoded = distinct
            .par_iter()
            .map(|&i| self.frames(&seqs[i]))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(slots.iter().map(|&k| decoded[k].clone()).collect())
    }
}

/// The three rows of motions and the diversity groups, as one reading (landmark frames).
pub(super) struct Reading {
    pub(super) rows: [Vec<Vec<Vec<f32>>>; 3],
    /// Per label: Motion3DGAN's motions, then the LSTM's, one per diversity seed.
    pub(super) diversity: [Vec<Vec<Vec<Vec<f32>>>>; 2],
}

impl Reading {
    pub(super) fn redetected(&self, r: &Redetector<'_>) -> Result<Self, RedetectError> {
        let rows = [
            r.all(&self.rows[0])?,
            r.all(&self.rows[1])?,
            r.all(&self.rows[2])?,
        ];
        let group = |g: &Vec<Vec<Vec<Vec<f32>>>>| -> Result<Vec<_>, RedetectError> {
            g.iter().map(|label| r.all(label)).collect()
        };
        Ok(Self {
            rows,
            diversity: [group(&self.diversity[0])?, group(&self.diversity[1])?],
        })
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    #[test]
    fn repeated_sequences_are_redetected_once_and_as_each_alone() {
        let bytes = std::fs::read(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/s2d-ict.sinew"),
        )
        .unwrap();
        let decoder = S2dDecoder::from_bytes(&bytes).unwrap();
        let r = Redetector::new(&decoder);
        let neutral = r.neutral_landmarks();
        // Three motions of three frames on the decoder's neutral: a, b, then a again.
        let motion = |s: f32| -> Vec<Vec<f32>> {
            (0..3)
                .map(|t| {
                    let mut f = neutral.clone();
                    for (k, x) in f.iter_mut().enumerate() {
                        *x += s * t as f32 * (0.01 + 0.001 * (k % 7) as f32);
                    }
                    f
                })
                .collect()
        };
        let (a, b) = (motion(1.0), motion(-0.5));
        let seqs = vec![a.clone(), b.clone(), a.clone()];
        let got = r.all(&seqs).unwrap();
        assert_eq!(got.len(), 3);
        assert_eq!(got[0], r.frames(&a).unwrap());
        assert_eq!(got[1], r.frames(&b).unwrap());
        assert_eq!(got[2], got[0]);
        assert_ne!(got[0], got[1]);
        // A sequence that differs from another in one value is its own.
        let mut c = a.clone();
        c[2][5] += 0.05;
        let alone = r.frames(&c).unwrap();
        assert_ne!(alone, got[0]);
        let got = r.all(&[a.clone(), c]).unwrap();
        assert_eq!(got[1], alone);
    }
}
