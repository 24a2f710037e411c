//! The One Euro filter (Casiez, Roussel and Vogel, "1€ Filter: A Simple Speed-based Low-pass
//! Filter for Noisy Input in Interactive Systems", CHI 2012): a first-order low-pass filter whose
//! cutoff rises with the signal's speed, so that a still face stops jittering and a moving one
//! does not lag. Off by default; a driver's caller applies it to each driven pose
//! ([`crate::driver`]), then makes the pose whole again with [`crate::driver::finish_pose`].
//!
//! Deterministic: a fixed frame rate ([`OneEuro::apply`]) or the caller's time stamps
//! ([`OneEuro::apply_at`]), never a clock; the state in the caller's buffer; only additions,
//! multiplications, divisions and `libm::fabsf`, in index order.

use crate::error::{Argument, BufferError, EvalError, InputError, InputErrorKind};
use crate::input::check_value;
use crate::layout::MAX_FACTOR;

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

    /// The state values for `n` values filtered at time stamps ([`Self::apply_at`]): a started
    /// flag, the last time stamp, then the last filtered value and the last filtered speed of
    /// each. A state of zeros is a filter that has seen nothing (a reset).
    pub const fn timed_state_len(n: usize) -> usize {
        2 + 2 * n
    }

    /// The smoothing factor of a low-pass at `cutoff` Hz for frames at `rate` Hz:
    /// `1 / (1 + τ · rate)`, `τ = 1 / (2π cutoff)`.
    fn alpha(cutoff: f32, rate: f32) -> f32 {
        let tau = 1.0 / (2.0 * core::f32::consts::PI * cutoff);
        1.0 / (1.0 + tau * rate)
    }

    /// Filters one frame's `values` in place, updating `state` (length
    /// [`Self::state_len`]`(values.len())`), at the settings' fixed frame rate. The first frame
    /// passes through.
    ///
    /// # Errors
    /// [`BufferError::Scratch`] for a state of another length (nothing changes then).
    pub fn apply(&self, state: &mut [f32], values: &mut [f32]) -> Result<(), BufferError> {
        let n = values.len();
        if state.len() != Self::state_len(n) {
            return Err(BufferError::Scratch);
        }
        let (flag, rest) = state.split_at_mut(1);
        let started = flag.first().is_some_and(|&f| f != 0.0);
        self.step(started, self.rate, rest, values);
        if let Some(f) = flag.first_mut() {
            *f = 1.0;
        }
        Ok(())
    }

    /// Filters one frame's `values` taken at `time` seconds in place, updating `state` (length
    /// [`Self::timed_state_len`]`(values.len())`): the frame rate of each step is
    /// `1 / (time − the last frame's time)`, as in the paper, for frames that arrive unevenly
    /// (the settings' own rate is not used). The first frame after a reset passes through.
    /// Time stamps are best counted from the track's start: an `f32` of seconds resolves a
    /// millisecond up to about 2 hours.
    ///
    /// # Errors
    /// [`BufferError::Scratch`] for a state of another length; [`InputError`] naming
    /// [`Argument::Time`] for a time stamp that is not finite or outside ±`MAX_COORDINATE`,
    /// or (`Degenerate`) less than `1 / MAX_FACTOR` (1 ms) after the last one. Nothing changes
    /// then.
    pub fn apply_at(
        &self,
        state: &mut [f32],
        time: f32,
        values: &mut [f32],
    ) -> Result<(), EvalError> {
        let n = values.len();
        if state.len() != Self::timed_state_len(n) {
            return Err(BufferError::Scratch.into());
        }
        check_value(Argument::Time, 0, time)?;
        let (head, rest) = state.split_at_mut(2);
        let (started, last) = match head {
            [flag, last] => (*flag != 0.0, *last),
            _ => (false, 0.0),
        };
        let mut rate = self.rate;
        if started {
            let dt = time - last;
            // Also refuses a NaN difference, which finite stamps within range cannot give.
            if dt.is_nan() || dt < 1.0 / MAX_FACTOR {
                return Err(InputError::new(Argument::Time, 0, InputErrorKind::Degenerate).into());
            }
            rate = 1.0 / dt;
        }
        self.step(started, rate, rest, values);
        if let [flag, last] = head {
            (*flag, *last) = (1.0, time);
        }
        Ok(())
    }

    /// One step at `rate` Hz over `memory` (the last filtered values, then their speeds).
    fn step(&self, started: bool, rate: f32, memory: &mut [f32], values: &mut [f32]) {
        let (last, speed) = memory.split_at_mut(values.len());
        let a_d = Self::alpha(self.d_cutoff, rate);
        for ((x, l), s) in values.iter_mut().zip(last.iter_mut()).zip(speed.iter_mut()) {
            if started {
                // 1€ filter, Casiez et al. 2012, Algorithm 1.
                let dx = (*x - *l) * rate;
                let ds = a_d * dx + (1.0 - a_d) * *s;
                let a = Self::alpha(self.min_cutoff + self.beta * libm::fabsf(ds), rate);
                *x = a * *x + (1.0 - a) * *l;
                *s = ds;
            } else {
                *s = 0.0;
            }
            *l = *x;
        }
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

    #[test]
    fn time_stamps_set_each_steps_rate_and_bad_ones_are_refused() {
        // Frames 1/32 s apart (exact in f32): the time-stamped filter is the fixed-rate one.
        let f = OneEuro::new(1.0, 0.5, 1.0, 32.0).unwrap();
        let (mut fixed, mut timed) = ([0.0f32; 5], [0.0f32; 6]);
        for k in 0..12 {
            let input = [libm::sinf(k as f32), 3.0 + libm::cosf(k as f32)];
            let (mut a, mut b) = (input, input);
            f.apply(&mut fixed, &mut a).unwrap();
            f.apply_at(&mut timed, k as f32 / 32.0, &mut b).unwrap();
            assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits), "frame {k}");
        }
        // A late frame is smoothed less than one on time: its rate is lower.
        let follow = |dt: f32| {
            let mut s = [0.0f32; 4];
            f.apply_at(&mut s, 0.0, &mut [0.0]).unwrap();
            let mut v = [1.0f32];
            f.apply_at(&mut s, dt, &mut v).unwrap();
            v[0]
        };
        assert!(
            follow(0.5) > follow(1.0 / 30.0),
            "{} {}",
            follow(0.5),
            follow(1.0 / 30.0)
        );
        // A stamp not 1 ms after the last, or not finite, is refused and changes nothing.
        let before = timed;
        let mut v = [9.0f32, 9.0];
        let time = |kind| EvalError::Input(InputError::new(Argument::Time, 0, kind));
        for (t, kind) in [
            (11.0 / 32.0, InputErrorKind::Degenerate),
            (11.0 / 32.0 + 1e-4, InputErrorKind::Degenerate),
            (f32::NAN, InputErrorKind::NonFinite),
            (1e9, InputErrorKind::OutOfRange),
        ] {
            assert_eq!(f.apply_at(&mut timed, t, &mut v), Err(time(kind)), "{t}");
        }
        assert_eq!((timed, v), (before, [9.0, 9.0]));
        assert_eq!(
            f.apply_at(&mut [0.0; 5], 1.0, &mut v),
            Err(EvalError::Buffer(BufferError::Scratch))
        );
        assert_eq!(
            alloc_free_message(time(InputErrorKind::Degenerate)),
            "time[0] is not at least 1e-3 s after the last frame's time stamp"
        );
    }

    /// The error's message, through a fixed buffer (the core has no `alloc`).
    fn alloc_free_message(e: EvalError) -> heapless::String<96> {
        use core::fmt::Write;
        let mut s = heapless::String::new();
        write!(s, "{e}").unwrap();
        s
    }
}
