//! [`NetworkLimit`]: the limit a network's values are held to, which
//! [`super::FormatError::Unbounded`] names.

use core::fmt;

use super::words::Magnitude;
use crate::layout::{MAX_NETWORK_VALUE, MAX_TANGENT_NORM};

/// The limit a network's values must stay within ([`super::FormatError::Unbounded`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum NetworkLimit {
    /// ±[`MAX_NETWORK_VALUE`], for the values of every layer: evaluation cannot overflow `f32`.
    Values,
    /// ±[`MAX_TANGENT_NORM`]` / outputs`, for the outputs of a network whose `outputs` values are
    /// a tangent vector (the motion generator's): then the vector's Euclidean length is at most
    /// `MAX_TANGENT_NORM / √outputs`, so it, and its projection onto a tangent space (never
    /// longer), has a finite squared length, and its exponential map is a finite unit motion.
    Tangent {
        /// How many values the vector has.
        outputs: u32,
    },
}

impl NetworkLimit {
    /// The limit.
    pub fn value(self) -> f32 {
        match self {
            Self::Values => MAX_NETWORK_VALUE,
            Self::Tangent { outputs } => {
                (f64::from(MAX_TANGENT_NORM) / f64::from(outputs.max(1))) as f32
            }
        }
    }
}

/// "values exceed ±1e20", "outputs exceed ±1e18 / 6120, the limit of a tangent vector of 6120
/// values": what a network must not do, for [`super::FormatError::Unbounded`]'s message.
impl fmt::Display for NetworkLimit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Values => write!(f, "values exceed ±{}", Magnitude(MAX_NETWORK_VALUE)),
            Self::Tangent { outputs } => write!(
                f,
                "outputs exceed ±{} / {outputs}, the limit of a tangent vector of {outputs} values",
                Magnitude(MAX_TANGENT_NORM)
            ),
        }
    }
}
