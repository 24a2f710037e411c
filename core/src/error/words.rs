//! How the errors write limits and rules in words, with integer formatting only.

use core::fmt;

use crate::layout::{MAX_ROTATION_ENTRY, MIN_ROTATION_COLUMN};

/// Writes a limit the way the documents do: `1e5`, `1e-6`, and `0` or `1` plainly. Every limit
/// of [`crate::layout`] is a power of ten (or zero), so only the exponent is printed, with
/// integer formatting: formatting an `f32` would add the float printer's tens of kilobytes to a
/// firmware image or WebAssembly module.
pub(super) struct Magnitude(pub(super) f32);

impl fmt::Display for Magnitude {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = f64::from(self.0);
        if v == 0.0 {
            return f.write_str("0");
        }
        let sign = if v < 0.0 { "-" } else { "" };
        // The exponent of the power of ten nearest to |v| (f32's 1e-6 is 9.99999997e-7).
        let (mut m, mut exponent) = (if v < 0.0 { -v } else { v }, 0i32);
        while m >= 9.5 {
            m /= 10.0;
            exponent += 1;
        }
        while m < 0.95 {
            m *= 10.0;
            exponent -= 1;
        }
        match exponent {
            0 => write!(f, "{sign}1"),
            1..=2 => write!(f, "{sign}{}", 10i32.pow(exponent.unsigned_abs())),
            _ => write!(f, "{sign}1e{exponent}"),
        }
    }
}

/// The rule of a usable 6D rotation, in words.
pub(super) struct RotationRule;

impl fmt::Display for RotationRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "not a usable 6D rotation (six values within ±{}, each column at least {} long, the \
             columns not parallel)",
            Magnitude(MAX_ROTATION_ENTRY),
            Magnitude(MIN_ROTATION_COLUMN)
        )
    }
}
