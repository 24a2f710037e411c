//! [`Bound`]: the rule a value of a file broke, which [`super::FormatError::ValueOutOfRange`]
//! names.

use core::fmt;

use super::words::{Magnitude, RotationRule};
use crate::layout::{MAX_COORDINATE, MAX_FACTOR};

/// The rule a value of a file broke ([`super::FormatError::ValueOutOfRange`]); each names its limit, a
/// `pub const` of [`crate::layout`] (docs/FORMAT.md, "Value bounds").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Bound {
    /// A length in the model's unit: within ±[`MAX_COORDINATE`].
    Coordinate,
    /// A positive length: above 0, at most [`MAX_COORDINATE`].
    PositiveCoordinate,
    /// A dimensionless factor: within ±[`MAX_FACTOR`].
    Factor,
    /// A positive factor: above 0, at most [`MAX_FACTOR`].
    PositiveFactor,
    /// A spread: at least 0, at most [`MAX_FACTOR`].
    NonNegativeFactor,
    /// A motion that must be a unit SRVF: `⟨p, p⟩` within 1 ± [`crate::layout::UNIT_TOLERANCE`]
    /// (the index is 0: the rule is about the whole motion).
    UnitMotion,
    /// A log-normal draw that can pass [`MAX_FACTOR`]: a mean and a spread of a logarithm with
    /// `mean + NOISE_BOUND × spread` above `ln MAX_FACTOR`, where `NOISE_BOUND` is the largest
    /// Gaussian value a seed draws ([`crate::layout::NOISE_BOUND`]; the index is the spread's).
    LogNormalFactor,
    /// The first value of a 6D rotation that is not usable: the six values within
    /// ±[`crate::layout::MAX_ROTATION_ENTRY`], each column at least [`crate::layout::MIN_ROTATION_COLUMN`] long, the columns
    /// not parallel (as a caller's rotation, [`super::InputError`]).
    Rotation,
}

impl Bound {
    /// Whether `v` keeps the rule (always true for [`Bound::Rotation`], [`Bound::UnitMotion`] and
    /// [`Bound::LogNormalFactor`], which are about values together: see [`crate::rotation::try_from_6d`]). NaN keeps none.
    pub fn contains(self, v: f32) -> bool {
        match self {
            Self::Coordinate => (-MAX_COORDINATE..=MAX_COORDINATE).contains(&v),
            Self::PositiveCoordinate => v > 0.0 && v <= MAX_COORDINATE,
            Self::Factor => (-MAX_FACTOR..=MAX_FACTOR).contains(&v),
            Self::PositiveFactor => v > 0.0 && v <= MAX_FACTOR,
            Self::NonNegativeFactor => (0.0..=MAX_FACTOR).contains(&v),
            Self::Rotation | Self::UnitMotion | Self::LogNormalFactor => true,
        }
    }
}

impl fmt::Display for Bound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Coordinate => write!(
                f,
                "outside ±{}, the limit of a length",
                Magnitude(MAX_COORDINATE)
            ),
            Self::PositiveCoordinate => write!(
                f,
                "not a positive length of at most {}",
                Magnitude(MAX_COORDINATE)
            ),
            Self::Factor => write!(
                f,
                "outside ±{}, the limit of a factor",
                Magnitude(MAX_FACTOR)
            ),
            Self::PositiveFactor => {
                write!(f, "not positive and at most {}", Magnitude(MAX_FACTOR))
            }
            Self::NonNegativeFactor => {
                write!(f, "negative or above {}", Magnitude(MAX_FACTOR))
            }
            Self::Rotation => write!(f, "{}", RotationRule),
            Self::UnitMotion => write!(
                f,
                "part of a motion that is not of unit norm (⟨p, p⟩ must lie within 1 ± {})",
                Magnitude(crate::layout::UNIT_TOLERANCE)
            ),
            Self::LogNormalFactor => {
                // In tenths and with integers only: formatting an f32 would put `core`'s float
                // formatting (about 19 KiB) into every firmware image (firmware-sim/run.sh
                // fails when it is there).
                let tenths = (crate::layout::NOISE_BOUND * 10.0) as u32;
                write!(
                    f,
                    "a spread that lets exp(mean + {}.{} × spread), a drawn factor, pass {}",
                    tenths / 10,
                    tenths % 10,
                    Magnitude(MAX_FACTOR)
                )
            }
        }
    }
}
