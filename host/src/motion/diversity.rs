//! Diversity of a generator (S2D section 4.3, Table 3's "diversity"): the mean geodesic distance
//! between motions of one label generated from different seeds, through the core's generator. A
//! deterministic generator (the LSTM baseline) scores 0.

use sinew_core::error::BufferError;
use sinew_core::motion::{LABELS, MotionGenerator};

use super::srvf::{self, SrvfError};

/// A diversity that cannot be measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DiversityError {
    /// Fewer than 2 seeds.
    #[error("diversity needs at least 2 seeds")]
    TooFewSeeds,
    /// The generator refused a motion.
    #[error("generating label {label}, seed {seed}")]
    Generate {
        /// The label.
        label: usize,
        /// The seed.
        seed: u64,
        /// What the core said.
        #[source]
        source: BufferError,
    },
    /// No groups.
    #[error("diversity needs at least one group")]
    NoGroups,
    /// A group of fewer than 2 motions.
    #[error("diversity needs at least 2 motions per group; group {group} has {motions}")]
    TooFewMotions {
        /// The group.
        group: usize,
        /// Its motions.
        motions: usize,
    },
    /// Motions with no geodesic distance (of different shapes).
    #[error(transparent)]
    Srvf(#[from] SrvfError),
}

/// Per label, the mean geodesic distance over every pair of the motions generated from seeds
/// `0..seeds`; then their mean over the labels, last.
///
/// # Errors
/// Fewer than 2 seeds, or a generation error.
pub fn diversity(
    generator: &MotionGenerator<'_>,
    seeds: u64,
) -> Result<(Vec<f32>, f32), DiversityError> {
    if seeds < 2 {
        return Err(DiversityError::TooFewSeeds);
    }
    let mut scratch = vec![0.0f32; generator.scratch_len()];
    let mut per_label = Vec::with_capacity(LABELS);
    for label in 0..LABELS {
        let motions = (0..seeds)
            .map(|seed| {
                let mut q = vec![0.0f32; generator.motion_len()];
                generator
                    .motion(label, seed, &mut scratch, &mut q)
                    .map(|()| q)
                    .map_err(|source| DiversityError::Generate {
                        label,
                        seed,
                        source,
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        per_label.push(motions);
    }
    mean_pairwise(&per_label)
}

/// Per group, the mean geodesic distance over every pair of its motions (unit SRVFs of one
/// shape); then the mean over the groups, last. Table 3's diversity with one group per label.
///
/// # Errors
/// No groups, a group of fewer than 2 motions, or motions of different shapes.
pub fn mean_pairwise(groups: &[Vec<Vec<f32>>]) -> Result<(Vec<f32>, f32), DiversityError> {
    if groups.is_empty() {
        return Err(DiversityError::NoGroups);
    }
    let mut per_group = Vec::with_capacity(groups.len());
    for (g, motions) in groups.iter().enumerate() {
        if motions.len() < 2 {
            return Err(DiversityError::TooFewMotions {
                group: g,
                motions: motions.len(),
            });
        }
        let (mut sum, mut pairs) = (0.0f64, 0usize);
        for a in 0..motions.len() {
            for b in a + 1..motions.len() {
                sum += f64::from(srvf::distance(&motions[a], &motions[b])?);
                pairs += 1;
            }
        }
        per_group.push((sum / pairs as f64) as f32);
    }
    let mean = per_group.iter().map(|&d| f64::from(d)).sum::<f64>() / groups.len() as f64;
    Ok((per_group, mean as f32))
}
