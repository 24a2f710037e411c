//! [`NetworkLimit`]: the limit a network's values are held to, which
//! [`super::FormatError::Unbounded`] names.

use crate::layout::{MAX_FACTOR, MAX_NETWORK_VALUE};

/// The limit a network's values must stay within ([`super::FormatError::Unbounded`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum NetworkLimit {
    /// ±[`MAX_NETWORK_VALUE`], for the values of every layer: evaluation cannot overflow `f32`.
    Values,
    /// ±[`MAX_FACTOR`], for the outputs of a network whose outputs are factors
    /// (the motion generator's tangent vectors).
    FactorOutputs,
}

impl NetworkLimit {
    /// The limit.
    pub const fn value(self) -> f32 {
        match self {
            Self::Values => MAX_NETWORK_VALUE,
            Self::FactorOutputs => MAX_FACTOR,
        }
    }

    /// What it limits, for messages.
    pub(super) const fn what(self) -> &'static str {
        match self {
            Self::Values => "values",
            Self::FactorOutputs => "outputs",
        }
    }
}
