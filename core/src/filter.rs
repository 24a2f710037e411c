//! The One Euro filter (Casiez, Roussel and Vogel, "1€ Filter: A Simple Speed-based Low-pass
//! Filter for Noisy Input in Interactive Systems", CHI 2012): a first-order low-pass filter whose
//! cutoff rises with the signal's speed, so that a still face stops jittering and a moving one
//! does not lag. Off by default; a driver's caller applies it to each driven pose
//! ([`crate::driver`]), then makes the pose whole again with [`crate::driver::finish_pose`].
//!
//! Deterministic: a fixed frame rate (no clock), the state in the caller's buffer, only
//! additions, multiplications, divisions and `libm::fabsf`, in index order.

use crate::error::{Argument, BufferError, InputError, InputErrorKind};
use crate::input::check_value;

/// The filter's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OneEuro {
    min_cutoff: f32,
    beta: f32,
    d_cutoff: f32,
    rate: f32,
}

impl OneEuro {
    /// A filter of minimum cutoff `min_cutoff` Hz, speed coefficient `beta`, derivative cutoff
    /// `d_cutoff` Hz, for frames at `rate` Hz.
    ///
    /// # Errors
    /// [`InputError`] naming [`Argument::Filter`] and the value (0: `min_cutoff`, 1: `beta`,
    /// 2: `d_cutoff`, 3: `rate`): not finite, outside `[0, MAX_FACTOR]`, or a cutoff or rate of 0.
    pub fn new(min_cutoff: f32, beta: f32, d_cutoff: f32, rate: f32) -> Result<Self, InputError> {
        for (i, v) in [min_cutoff, beta, d_cutoff, rate].into_iter().enumerate() {
            check_value(Argument::Filter, i, v)?;
            if i != 1 && v <= 0.0 {
                return Err(InputError::new(
                    Argument::Filter,
                    i,
                    InputErrorKind::OutOfRange,
                ));
            }
        }
        Ok(Self {
            min_cutoff,
            beta,
            d_cutoff,
            rate,
        })
    }

    /// The state values for `n` filtered values: a started flag, then the last filtered value
    /// and the last filtered speed of each. A state of zeros is a filter that has seen nothing.
    pub const fn state_len(n: usize) -> usize {
        1 + 2 * n
    }

    /// The smoothing factor of a low-pass at `cutoff` Hz: `1 / (1 + τ · rate)`,
    /// `τ = 1 / (2π cutoff)`.
    fn alpha(&self, cutoff: f32) -> f32 {
        let tau = 1.0 / (2.0 * core::f32::consts::PI * cutoff);
        1.0 / (1.0 + tau * self.rate)
    }

    /// Filters one frame's `values` in place, updating `state` (length
    /// [`Self::state_len`]`(values.len())`). The first frame passes through.
    ///
    /// # Errors
    /// [`BufferError::Scratch`] for a state of another length ( nothing changes then).
    pub fn apply(&self, state: &mut [f32], values: &mut [f32]) -> Result<(), BufferError> {
        let n = values.len();
        if state.len() != Self::state_len(n) {
            return Err(BufferError::Scratch);
        }
        let (flag, rest) = state.split_at_mut(1);
        let (last, speed) = rest.split_at_mut(n);
        let started = flag.first().is_some_and(|&f| f != 0.0);
        let a_d = self.alpha(self.d_cutoff);
        for ((x, l), s) in values.iter_mut().zip(last.iter_mut()).zip(speed.iter_mut()) {
            if started {
                // 1€ filter, Casiez et al. 2012, Algorithm 1.
                let dx = (*x - *l) * self.rate;
                let ds = a_d * dx + (1.0 - a_d) * *s;
                let a = self.alpha(self.min_cutoff + self.beta * libm::fabsf(ds));
                *x = a * *x + (1.0 - a) * *l;
                *s = ds;
            } else {
                *s = 0.0;
            }
            *l = *x;
        }
        if let Some(f) = flag.first_mut() {
            *f = 1.0;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_still_signal_settles_and_a_step_is_followed() {
        let f = OneEuro::new(1.0, 0.0, 1.0, 30.0).unwrap();
        let mut state = [0.0f32; 3];
        let mut first = [2.0f32];
        f.apply(&mut state, &mut first).unwrap();
        assert_eq!(first, [2.0], "the first frame passes through");
        // Jitter around 2 is smoothed: every output stays nearer 2 than its input.
        for k in 0..30 {
            let input = if k % 2 == 0 { 2.1 } else { 1.9 };
            let mut v = [input];
            f.apply(&mut state, &mut v).unwrap();
            assert!((v[0] - 2.0).abs() < 0.1, "{k}: {}", v[0]);
        }
        // A step to 5 is reached, faster with a speed coefficient.
        let reach = |beta: f32| {
            let g = OneEuro::new(1.0, beta, 1.0, 30.0).unwrap();
            let mut s = [0.0f32; 3];
            let mut v = [0.0f32];
            g.apply(&mut s, &mut v).unwrap();
            (0..10)
                .map(|_| {
                    let mut v = [5.0f32];
                    g.apply(&mut s, &mut v).unwrap();
                    v[0]
                })
                .last()
                .unwrap()
        };
        assert!(reach(0.0) > 3.0 && reach(0.0) < 5.0, "{}", reach(0.0));
        assert!(reach(1.0) > reach(0.0), "{} {}", reach(1.0), reach(0.0));
    }

    #[test]
    fn the_same_inputs_give_the_same_bits_and_bad_settings_are_refused() {
        let f = OneEuro::new(0.5, 0.3, 1.0, 60.0).unwrap();
        let run = || {
            let mut s = [0.0f32; 5];
            let mut out = [0u32; 20];
            for k in 0..10 {
                let mut v = [libm::sinf(k as f32), libm::cosf(k as f32)];
                f.apply(&mut s, &mut v).unwrap();
                out[2 * k] = v[0].to_bits();
                out[2 * k + 1] = v[1].to_bits();
            }
            out
        };
        assert_eq!(run(), run());
        let refused = |i| InputError::new(Argument::Filter, i, InputErrorKind::OutOfRange);
        assert_eq!(OneEuro::new(0.0, 0.0, 1.0, 30.0), Err(refused(0)));
        assert_eq!(OneEuro::new(1.0, -1.0, 1.0, 30.0), Err(refused(1)));
        assert_eq!(OneEuro::new(1.0, 0.0, 1.0, 0.0), Err(refused(3)));
        assert_eq!(
            OneEuro::new(f32::NAN, 0.0, 1.0, 30.0),
            Err(InputError::new(
                Argument::Filter,
                0,
                InputErrorKind::NonFinite
            ))
        );
        let mut short = [0.0f32; 2];
        assert_eq!(f.apply(&mut short, &mut [1.0]), Err(BufferError::Scratch));
    }
}
