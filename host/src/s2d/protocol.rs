//! The S2D paper's cross-validation protocols (§4.1): identity-independent (test identities are
//! never seen in training) and expression-independent (test pairs combine only expression shapes
//! that no training pair uses), each in [`FOLDS`] folds.

use serde::{Deserialize, Serialize};

use super::data::{Manifest, SHAPE_GROUPS};

/// Folds of both protocols (the paper's 4-fold cross-validation).
pub const FOLDS: usize = SHAPE_GROUPS;

/// Which generalisation a split measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// Fold f holds out the f-th quarter of the identities (contiguous, as the paper's "first
    /// three identities"); training sees every expression shape.
    Identity,
    /// Fold f holds out shape group f of the data set (a quarter of the 53 shapes); every pair
    /// combines shapes of one group, so each pair is in exactly one fold's test set.
    Expression,
}

impl std::fmt::Display for Protocol {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Identity => "identity",
            Self::Expression => "expression",
        })
    }
}

/// One fold: which pairs train and which test, and what was held out.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Split {
    /// The protocol.
    pub protocol: Protocol,
    /// The fold, `0..FOLDS`.
    pub fold: usize,
    /// Held-out identities (identity protocol) or expression shapes (expression protocol), by
    /// index into the manifest's `identities` or name.
    pub held_out: Vec<String>,
    /// Training pairs, increasing.
    pub train: Vec<usize>,
    /// Test pairs, increasing.
    pub test: Vec<usize>,
}

/// The identities held out by `fold` of `identities`: the contiguous block
/// `fold·I/FOLDS .. (fold + 1)·I/FOLDS`.
fn identity_block(identities: usize, fold: usize) -> std::ops::Range<usize> {
    fold * identities / FOLDS..(fold + 1) * identities / FOLDS
}

/// A fold that the data set cannot give.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SplitError {
    /// A fold past the last.
    #[error("fold {fold}: the protocols have {FOLDS} folds")]
    Fold {
        /// The fold asked for.
        fold: usize,
    },
    /// Fewer identities than folds.
    #[error(
        "the identity protocol needs at least {FOLDS} identities (one per fold); the data set \
         has {identities}"
    )]
    Identities {
        /// The data set's identities.
        identities: usize,
    },
    /// Not one shape group per fold.
    #[error("the expression protocol needs {FOLDS} shape groups; the data set has {groups}")]
    ShapeGroups {
        /// The data set's shape groups.
        groups: usize,
    },
    /// A fold with no training or no test pairs.
    #[error("{protocol} fold {fold}: {train} training and {test} test pairs; generate more pairs")]
    Empty {
        /// The protocol.
        protocol: Protocol,
        /// The fold.
        fold: usize,
        /// Its training pairs.
        train: usize,
        /// Its test pairs.
        test: usize,
    },
}

/// Fold `fold` of `protocol` on the data set of `m`.
pub fn split(m: &Manifest, protocol: Protocol, fold: usize) -> Result<Split, SplitError> {
    if fold >= FOLDS {
        return Err(SplitError::Fold { fold });
    }
    let (held_out, is_test): (Vec<String>, Box<dyn Fn(usize) -> bool>) = match protocol {
        Protocol::Identity => {
            if m.identities.len() < FOLDS {
                return Err(SplitError::Identities {
                    identities: m.identities.len(),
                });
            }
            let block = identity_block(m.identities.len(), fold);
            (
                block.clone().map(|i| i.to_string()).collect(),
                Box::new(move |p| block.contains(&m.pairs[p].identity)),
            )
        }
        Protocol::Expression => {
            if m.shape_groups.len() != FOLDS {
                return Err(SplitError::ShapeGroups {
                    groups: m.shape_groups.len(),
                });
            }
            (
                m.shape_groups[fold].clone(),
                Box::new(move |p| m.pairs[p].group == fold),
            )
        }
    };
    let (test, train): (Vec<usize>, Vec<usize>) = (0..m.pairs.len()).partition(|&p| is_test(p));
    if train.is_empty() || test.is_empty() {
        return Err(SplitError::Empty {
            protocol,
            fold,
            train: train.len(),
            test: test.len(),
        });
    }
    Ok(Split {
        protocol,
        fold,
        held_out,
        train,
        test,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s2d::data::{Component, MANIFEST_FORMAT, MANIFEST_VERSION, PairSpec, PairsConfig};

    /// A manifest of 8 identities and 8 shapes in 4 groups of 2, with pairs cycling through
    /// identities and groups as the generator does.
    fn manifest(identities: usize, pairs: usize) -> Manifest {
        let expressions: Vec<String> = (0..8).map(|i| format!("s{i}")).collect();
        let shape_groups: Vec<Vec<String>> = (0..4)
            .map(|g| vec![expressions[g].clone(), expressions[g + 4].clone()])
            .collect();
        let pairs = (0..pairs)
            .map(|p| {
                let group = (p / identities) % 4;
                PairSpec {
                    identity: p % identities,
                    group,
                    shapes: shape_groups[group]
                        .iter()
                        .take(1 + p % 2)
                        .map(|s| Component {
                            shape: s.clone(),
                            weight: 0.5,
                        })
                        .collect(),
                }
            })
            .collect();
        Manifest {
            format: MANIFEST_FORMAT.into(),
            version: MANIFEST_VERSION,
            config: PairsConfig::default(),
            units: crate::io::units::Unit::Centimetre,
            source: String::new(),
            vertices: 0,
            landmarks: Vec::new(),
            expressions,
            shape_groups,
            identities: vec![Vec::new(); identities],
            pairs,
        }
    }

    #[test]
    fn held_out_identities_never_train() {
        let m = manifest(10, 200);
        let mut tested = vec![0usize; 200];
        for fold in 0..FOLDS {
            let s = split(&m, Protocol::Identity, fold).unwrap();
            let held: Vec<usize> = s.held_out.iter().map(|h| h.parse().unwrap()).collect();
            assert!(!held.is_empty());
            assert!(
                s.train
                    .iter()
                    .all(|&p| !held.contains(&m.pairs[p].identity))
            );
            assert!(s.test.iter().all(|&p| held.contains(&m.pairs[p].identity)));
            assert_eq!(s.train.len() + s.test.len(), 200);
            for &p in &s.test {
                tested[p] += 1;
            }
        }
        // Every pair is tested in exactly one fold.
        assert!(tested.iter().all(|&n| n == 1));
        // 10 identities: blocks of 2, 3, 2, 3.
        let sizes: Vec<usize> = (0..FOLDS)
            .map(|f| split(&m, Protocol::Identity, f).unwrap().held_out.len())
            .collect();
        assert_eq!(sizes, [2, 3, 2, 3]);
    }

    #[test]
    fn held_out_shapes_never_train() {
        let m = manifest(3, 120);
        let mut tested = vec![0usize; 120];
        for fold in 0..FOLDS {
            let s = split(&m, Protocol::Expression, fold).unwrap();
            assert_eq!(s.held_out.len(), 2);
            for &p in &s.train {
                assert!(
                    m.pairs[p]
                        .shapes
                        .iter()
                        .all(|c| !s.held_out.contains(&c.shape))
                );
            }
            for &p in &s.test {
                assert!(
                    m.pairs[p]
                        .shapes
                        .iter()
                        .all(|c| s.held_out.contains(&c.shape))
                );
                tested[p] += 1;
            }
        }
        assert!(tested.iter().all(|&n| n == 1));
    }

    #[test]
    fn impossible_splits_are_refused() {
        let m = manifest(3, 40);
        let e = split(&m, Protocol::Identity, 0).unwrap_err();
        assert_eq!(e, SplitError::Identities { identities: 3 });
        assert_eq!(
            split(&m, Protocol::Expression, 4).unwrap_err(),
            SplitError::Fold { fold: 4 }
        );
        // 8 pairs cover only groups 0 and 1: folds 2 and 3 have no test pairs.
        let m = manifest(4, 8);
        assert!(split(&m, Protocol::Expression, 1).is_ok());
        let e = split(&m, Protocol::Expression, 2).unwrap_err();
        assert!(matches!(e, SplitError::Empty { test: 0, .. }), "{e:?}");
        // 4 pairs are all in group 0: holding it out leaves nothing to train on.
        let e = split(&manifest(4, 4), Protocol::Expression, 0).unwrap_err();
        assert!(matches!(e, SplitError::Empty { train: 0, .. }), "{e:?}");
    }
}
