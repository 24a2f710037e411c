//! Length units: the one place where a unit's name (as artefacts, manifests and reports write it)
//! and its size in millimetres are defined.

use serde::{Deserialize, Serialize};

/// The unit of a model's or data set's coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Unit {
    /// Millimetres (`mm`).
    #[serde(rename = "mm")]
    Millimetre,
    /// Centimetres (`cm`): ICT-FaceKit's unit.
    #[serde(rename = "cm")]
    Centimetre,
    /// Metres (`m`): FLAME's unit.
    #[serde(rename = "m")]
    Metre,
}

/// A unit name that is none of `mm`, `cm`, `m`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown length unit {0:?} (mm, cm or m)")]
pub struct UnknownUnit(pub String);

impl Unit {
    /// The name written in metadata and reports.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Millimetre => "mm",
            Self::Centimetre => "cm",
            Self::Metre => "m",
        }
    }

    /// Millimetres per unit.
    pub const fn mm(self) -> f64 {
        match self {
            Self::Millimetre => 1.0,
            Self::Centimetre => 10.0,
            Self::Metre => 1000.0,
        }
    }
}

impl std::str::FromStr for Unit {
    type Err = UnknownUnit;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [Self::Millimetre, Self::Centimetre, Self::Metre]
            .into_iter()
            .find(|u| u.name() == s)
            .ok_or_else(|| UnknownUnit(s.to_owned()))
    }
}

impl std::fmt::Display for Unit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_sizes_and_parsing_agree() {
        for u in [Unit::Millimetre, Unit::Centimetre, Unit::Metre] {
            assert_eq!(u.name().parse::<Unit>(), Ok(u));
            assert_eq!(serde_json::to_string(&u).unwrap(), format!("\"{u}\""));
        }
        assert_eq!(Unit::Centimetre.mm(), 10.0);
        assert_eq!("inch".parse::<Unit>(), Err(UnknownUnit("inch".into())));
        assert!(serde_json::from_str::<Unit>("\"km\"").is_err());
    }
}
