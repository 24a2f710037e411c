//! Why a linear baseline (PCA, its landmark fitter, the sparse dictionary) cannot be fitted or
//! applied.

/// A PCA, fitter or dictionary that cannot be made or used with the data given.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BaselineModelError {
    /// Fewer than 2 samples.
    #[error("PCA needs at least 2 samples, got {got}")]
    TooFewSamples {
        /// The samples given.
        got: usize,
    },
    /// Empty samples or samples of different lengths.
    #[error("PCA samples must all have the same positive length")]
    SampleLengths,
    /// More components asked for than the PCA has, or none.
    #[error("{k} components asked of a PCA of rank {rank}")]
    Components {
        /// The components asked for.
        k: usize,
        /// The PCA's rank.
        rank: usize,
    },
    /// A landmark vertex past the modelled vertices.
    #[error("a landmark vertex is outside the {vertices} modelled vertices")]
    LandmarkOutside {
        /// The modelled vertices.
        vertices: usize,
    },
    /// A displacement of another length than the model's.
    #[error("a displacement of {found} values for a model of {expected}")]
    SampleLength {
        /// The displacement's values.
        found: usize,
        /// The model's.
        expected: usize,
    },
    /// A negative (or NaN) ridge weight.
    #[error("ridge weight {0} is negative")]
    NegativeRidge(f64),
    /// Landmark rows with no unique solution and no ridge to make one.
    #[error(
        "the landmark rows of the model's {k} components are rank-deficient; use a positive ridge"
    )]
    RankDeficient {
        /// The components (or atoms).
        k: usize,
    },
    /// Not one displacement per landmark.
    #[error("{found} landmark displacements for {expected} landmarks")]
    LandmarkCount {
        /// The displacements given.
        found: usize,
        /// The fitter's landmarks.
        expected: usize,
    },
    /// A dictionary of no atoms.
    #[error("a dictionary needs at least one atom")]
    NoAtoms,
    /// A sparsity weight that is negative or not finite.
    #[error("sparsity {0} is not a non-negative number")]
    Sparsity(f64),
    /// A PCA without components.
    #[error("the PCA has no component to learn a dictionary in")]
    EmptyPca,
    /// A dictionary learned in another PCA's coordinates.
    #[error("the dictionary was learned in {dictionary} coordinates, the PCA has {pca}")]
    Coordinates {
        /// The dictionary's coordinates.
        dictionary: usize,
        /// The PCA's rank.
        pca: usize,
    },
    /// A dictionary whose atoms no training sample uses.
    #[error("no atom of the dictionary is used")]
    NoAtomUsed,
}
