//! The checks of a caller's numbers: every evaluation entry runs them on its inputs before it
//! computes anything, and refuses with an [`InputError`] naming the argument and the value.
//!
//! The ranges are [`Argument::range`] (docs/FORMAT.md, "Value bounds"); the 6D rotation's rule is
//! [`crate::rotation::try_from_6d`]'s. The checks only compare, so an accepted input gives the
//! same output bits as before they existed.

use crate::error::{Argument, InputError, InputErrorKind};

/// Checks that every value of `values` is finite and within `argument`'s range
/// ([`Argument::range`], by index).
///
/// # Errors
/// [`InputError`] for the first value that is not.
pub fn check_values(argument: Argument, values: &[f32]) -> Result<(), InputError> {
    for (index, &v) in values.iter().enumerate() {
        check_value(argument, index, v)?;
    }
    Ok(())
}

/// Checks value `index` of `argument`: finite and within [`Argument::range`].
///
/// # Errors
/// [`InputError`] if it is not.
pub fn check_value(argument: Argument, index: usize, v: f32) -> Result<(), InputError> {
    let (lo, hi) = argument.range(index);
    if !v.is_finite() {
        Err(InputError::new(argument, index, InputErrorKind::NonFinite))
    } else if v < lo || v > hi {
        Err(InputError::new(argument, index, InputErrorKind::OutOfRange))
    } else {
        Ok(())
    }
}

/// Checks that every value of `values` is finite (for arguments without a range, such as posed
/// positions, whose normals stay finite for any finite positions).
///
/// # Errors
/// [`InputError`] for the first value that is not.
pub fn check_finite(argument: Argument, values: &[f32]) -> Result<(), InputError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(InputError::new(argument, index, InputErrorKind::NonFinite)),
        None => Ok(()),
    }
}
