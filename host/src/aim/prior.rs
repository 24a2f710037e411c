//! Starting a run from an actor trained before: the prior's five networks, its input
//! normalisation and, for every shape the two share by name, its corrective outputs and its
//! learned jaw transform, in place of random weights.
//!
//! The networks are functions of a point in Sinew's face frame (every actor learned from the kit
//! or from a rig is trained there: centimetres, +Y up, +Z forward, the head placed by its
//! landmarks), so an actor of another identity, topology or resolution gives a new face a start
//! that is already near its anatomy and its correctives: the run then learns the difference. A
//! prior must have the run's network sizes and frequency, its thickness activation and units,
//! and its networks (an actor baked with `--playback-only` has none).

use std::path::{Path, PathBuf};

use burn::tensor::Device;
use sinew_core::nn::Activation;

use super::AimConfig;
use super::config::ThicknessActivation;
use super::model::AimNet;
use crate::io::container::ContainerError;
use crate::training::nn::{LayerWeights, Mlp};

/// Why an actor cannot start a run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PriorError {
    /// The file could not be read, or is not an AIM actor.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The actor was baked without its networks.
    #[error(
        "{}: a playback-only actor carries no networks to start from (bake the prior without --playback-only)",
        path.display()
    )]
    NoNetworks {
        /// The prior.
        path: PathBuf,
    },
    /// A section the prior needs is missing or malformed.
    #[error("{}: section {section}: {what}", path.display())]
    Section {
        /// The prior.
        path: PathBuf,
        /// The section.
        section: String,
        /// What is wrong.
        what: String,
    },
    /// The prior's networks or units differ from the run's.
    #[error("{}: the prior {what}; train with the prior's settings or without --prior", path.display())]
    Mismatch {
        /// The prior.
        path: PathBuf,
        /// What differs, with both values.
        what: String,
    },
    /// The prior shares no shape with the run.
    #[error("{}: the prior shares no shape name with the training set ({names})", path.display())]
    NoSharedShape {
        /// The prior.
        path: PathBuf,
        /// The prior's shape names.
        names: String,
    },
}

/// The learning rate a run started from a prior begins at, unless one is asked for: three
/// quarters of a fresh run's, on the shorter schedule of [`STEPS`] (docs/results/AIM.md, "Time
/// to an accuracy on a rig": measured against 5e-5 and 1e-4).
pub const LEARNING_RATE: f64 = 1.5e-4;

/// The schedule's length, and so the most steps, of a run started from a prior unless one is
/// asked for (`--steps`, `--config`): the learning rate decays to its end over these steps
/// instead of a fresh run's 10,000, and the run stops earlier where it meets its target. On the
/// farthest rig measured the default target came at step 3,750.
pub const STEPS: usize = 4_000;

/// Sets the learning rate and the schedule's length a run was not given (`lr_asked`,
/// `steps_asked`: on the command line): a run from a prior takes [`LEARNING_RATE`] and
/// [`STEPS`]; a resumed run (`resumed`: its checkpoint's settings) keeps the ones it began with;
/// another keeps the configuration's.
pub fn run_defaults(
    config: &mut crate::aim::AimConfig,
    lr_asked: bool,
    steps_asked: bool,
    from_prior: bool,
    resumed: Option<&crate::aim::AimConfig>,
) {
    if !lr_asked {
        if from_prior {
            config.lr = LEARNING_RATE;
        } else if let Some(c) = resumed {
            config.lr = c.lr;
        }
    }
    if !steps_asked {
        if from_prior {
            config.iterations = STEPS;
        } else if let Some(c) = resumed {
            config.iterations = c.iterations;
        }
    }
}

/// The metadata entry of an actor whose training started from a prior: the prior's file name and
/// how many of the run's shapes it knew.
pub const METADATA_KEY: &str = "prior";

/// Where the built-in prior lives in the repository.
pub const BUILTIN_PATH: &str = "host/data/prior-ict.sinew";

/// The built-in prior's bytes: an actor trained by Sinew with its defaults on the ICT-FaceKit
/// generic neutral as a rig (`sinew data rig`, all 53 shapes; NOTICE and docs/AIM.md give the
/// commands), baked with its networks on a coarse face.
const BUILTIN: &[u8] = include_bytes!("../../data/prior-ict.sinew");

/// The networks' names in a baked actor and in [`AimNet`], in this order.
const NETWORKS: [&str; 5] = ["net.b", "net.d", "net.n", "net.k", "net.e"];

/// A trained actor's networks, read to start a run.
#[derive(Clone, Debug)]
pub struct Prior {
    path: PathBuf,
    /// B, D, N, K and E, each layer in the core's layout.
    networks: Vec<Vec<LayerWeights>>,
    /// The input normalisation the networks were trained with.
    pub normalisation: [f32; 4],
    /// The corrective shapes' names (the neutral not among them).
    names: Vec<String>,
    /// Each corrective shape's learned jaw transform (9 values).
    jaw: Vec<[f32; 9]>,
    thickness_activation: u32,
    units: Option<String>,
}

impl Prior {
    /// Reads the actor at `path` as a prior.
    ///
    /// # Errors
    /// [`PriorError`] naming the file: not an actor, playback-only, a section missing.
    pub fn read(path: &Path) -> Result<Self, PriorError> {
        let bytes = crate::io::container::read_actor(path)?;
        Self::from_bytes(path, &bytes)
    }

    /// The prior in `bytes` (an AIM actor with its networks), read from `path`.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Self, PriorError> {
        let actor = crate::io::container::actor(path, bytes)?;
        if actor.networks().is_none() {
            return Err(PriorError::NoNetworks {
                path: path.to_owned(),
            });
        }
        let file = actor.file();
        let section = |name: &str, what: &str| PriorError::Section {
            path: path.to_owned(),
            section: name.to_owned(),
            what: what.to_owned(),
        };
        let f32s = |name: &str| -> Result<Vec<f32>, PriorError> {
            Ok(file
                .section(name)
                .and_then(|s| s.f32s())
                .ok_or_else(|| section(name, "missing or not f32"))?
                .iter()
                .collect())
        };
        let mut networks = Vec::with_capacity(NETWORKS.len());
        for prefix in NETWORKS {
            let codes: Vec<u32> = file
                .section(&format!("{prefix}.act"))
                .and_then(|s| s.u32s())
                .ok_or_else(|| section(&format!("{prefix}.act"), "missing or not u32"))?
                .iter()
                .collect();
            let params = f32s(&format!("{prefix}.par"))?;
            let mut layers = Vec::with_capacity(codes.len());
            for (i, (&code, &param)) in codes.iter().zip(&params).enumerate() {
                let name = format!("{prefix}.{i}.w");
                let dims = file
                    .section(&name)
                    .map(|s| s.dims().to_vec())
                    .ok_or_else(|| section(&name, "missing"))?;
                let [outputs, inputs] = dims[..] else {
                    return Err(section(&name, "not a matrix"));
                };
                let activation = Activation::from_code(code, param)
                    .map_err(|e| section(&format!("{prefix}.act"), &e.to_string()))?;
                layers.push(LayerWeights {
                    weight: f32s(&name)?,
                    bias: f32s(&format!("{prefix}.{i}.b"))?,
                    inputs: inputs as usize,
                    outputs: outputs as usize,
                    activation,
                });
            }
            networks.push(layers);
        }
        let norm = f32s("aim.norm")?;
        let normalisation: [f32; 4] = norm
            .try_into()
            .map_err(|_| section("aim.norm", "not 4 values"))?;
        let m = actor.shape_count();
        let names: Vec<String> = (0..m)
            .map(|i| actor.shape_name(i).map(str::to_owned))
            .collect::<Option<_>>()
            .ok_or_else(|| PriorError::Section {
                path: path.to_owned(),
                section: "metadata shapes".into(),
                what: format!("does not name the {m} corrective shapes"),
            })?;
        let jaw = f32s("train.jaw")?
            .chunks_exact(9)
            .map(|c| <[f32; 9]>::try_from(c).unwrap_or(super::model::IDENTITY_9D))
            .collect::<Vec<_>>();
        if jaw.len() != m {
            return Err(section("train.jaw", "not one transform per shape"));
        }
        let thickness_activation = file
            .section("aim.dact")
            .and_then(|s| s.u32s())
            .and_then(|s| s.get(0))
            .unwrap_or(sinew_core::aim::THICKNESS_IDENTITY);
        Ok(Self {
            path: path.to_owned(),
            networks,
            normalisation,
            names,
            jaw,
            thickness_activation,
            units: file.metadata().get("units").map(str::to_owned),
        })
    }

    /// The built-in prior ([`BUILTIN_PATH`]).
    ///
    /// # Errors
    /// [`PriorError`] if the embedded file does not read (a build from a damaged checkout).
    pub fn builtin() -> Result<Self, PriorError> {
        Self::from_bytes(Path::new(BUILTIN_PATH), BUILTIN)
    }

    /// Whether the prior can start a run of `config` on the shapes `names` (the neutral first)
    /// in `units`: the same network sizes, frequency, thickness activation and units, and a
    /// shape in common.
    pub fn fits(&self, config: &AimConfig, names: &[String], units: &str) -> bool {
        self.check(config, units).is_ok() && self.shared(names) > 0
    }

    /// The file the prior was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The model a run of `config` on the shapes `names` (the neutral first, as in a
    /// [`super::TrainingSet`]) in `units` starts from: the prior's networks, E's outputs and the
    /// jaw transforms of the shapes it knows by name, and for the others E's fresh outputs and
    /// `jaw` (the run's own initial transforms, one per corrective shape). Seed the device first.
    ///
    /// # Errors
    /// [`PriorError::Mismatch`] when the prior's sizes, frequency, thickness activation or units
    /// differ from the run's; [`PriorError::NoSharedShape`] when it knows none of the shapes.
    pub fn start(
        &self,
        config: &AimConfig,
        names: &[String],
        units: &str,
        jaw: &[[f32; 9]],
        device: &Device,
    ) -> Result<AimNet, PriorError> {
        self.check(config, units)?;
        let corrective = names.get(1..).unwrap_or_default();
        let shared: Vec<(usize, usize)> = corrective
            .iter()
            .enumerate()
            .filter_map(|(j, n)| Some((j, self.names.iter().position(|p| p == n)?)))
            .collect();
        if shared.is_empty() {
            return Err(PriorError::NoSharedShape {
                path: self.path.clone(),
                names: self.names.join(","),
            });
        }
        let mut jaw = jaw.to_vec();
        for &(j, i) in &shared {
            jaw[j] = self.jaw[i];
        }
        let mut net = AimNet::with_jaw(config, &jaw, device);
        net.b = Mlp::from_weights(&self.networks[0], device);
        net.d = Mlp::from_weights(&self.networks[1], device);
        net.n = Mlp::from_weights(&self.networks[2], device);
        net.k = Mlp::from_weights(&self.networks[3], device);
        // E: every hidden layer is the prior's; the last layer's rows (x, y, z per shape) are
        // the prior's for a shared shape, the fresh initialisation's for the others.
        let mut e = self.networks[4].clone();
        let fresh = net.e.weights();
        if let (Some(last), Some(own)) = (e.last_mut(), fresh.last()) {
            let inputs = own.inputs;
            let mut weight = own.weight.clone();
            let mut bias = own.bias.clone();
            for &(j, i) in &shared {
                let (to, from) = (3 * j * inputs..3 * (j + 1) * inputs, 3 * i * inputs..);
                weight[to.clone()].copy_from_slice(&last.weight[from][..to.len()]);
                bias[3 * j..3 * j + 3].copy_from_slice(&last.bias[3 * i..3 * i + 3]);
            }
            *last = LayerWeights {
                weight,
                bias,
                outputs: own.outputs,
                ..own.clone()
            };
        }
        net.e = Mlp::from_weights(&e, device);
        Ok(net)
    }

    /// How many of the corrective shapes of `names` (the neutral first) the prior knows.
    pub fn shared(&self, names: &[String]) -> usize {
        names
            .get(1..)
            .unwrap_or_default()
            .iter()
            .filter(|n| self.names.contains(n))
            .count()
    }

    fn check(&self, config: &AimConfig, units: &str) -> Result<(), PriorError> {
        let mismatch = |what: String| PriorError::Mismatch {
            path: self.path.clone(),
            what,
        };
        for (name, layers) in NETWORKS.iter().zip(&self.networks) {
            let hidden: Vec<usize> = layers.iter().skip(1).map(|l| l.inputs).collect();
            if layers.first().map(|l| l.inputs) != Some(3)
                || hidden.len() != config.layers
                || hidden.iter().any(|&h| h != config.hidden)
            {
                return Err(mismatch(format!(
                    "network {name} has hidden widths {hidden:?}, the run {} layers of {} (--config hidden, layers)",
                    config.layers, config.hidden
                )));
            }
            let omega: Vec<f32> = layers
                .iter()
                .filter_map(|l| match l.activation {
                    Activation::Sine { omega0 } => Some(omega0),
                    _ => None,
                })
                .collect();
            if omega.len() != config.layers || omega.iter().any(|&w| w != config.omega0) {
                return Err(mismatch(format!(
                    "network {name} has sine frequencies {omega:?}, the run ω0 {} (--config omega0)",
                    config.omega0
                )));
            }
        }
        let run_thickness = match config.thickness_activation {
            ThicknessActivation::Identity => sinew_core::aim::THICKNESS_IDENTITY,
            ThicknessActivation::Softplus => sinew_core::aim::THICKNESS_SOFTPLUS,
        };
        if self.thickness_activation != run_thickness {
            return Err(mismatch(format!(
                "thickness activation differs from the run's {:?} (--thickness-activation)",
                config.thickness_activation
            )));
        }
        if let Some(u) = &self.units
            && u != units
        {
            return Err(mismatch(format!(
                "was trained in {u}, the run is in {units}"
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aim::AimConfig;

    #[test]
    fn a_run_takes_the_rate_and_schedule_it_was_not_given() {
        let base = AimConfig::default();
        let mut from_prior = base.clone();
        run_defaults(&mut from_prior, false, false, true, None);
        assert_eq!(
            (from_prior.lr, from_prior.iterations),
            (LEARNING_RATE, STEPS)
        );
        let mut asked = AimConfig {
            lr: 3e-4,
            iterations: 777,
            ..base.clone()
        };
        run_defaults(&mut asked, true, true, true, None);
        assert_eq!((asked.lr, asked.iterations), (3e-4, 777));
        let began = AimConfig {
            lr: 1.5e-4,
            iterations: 4_000,
            ..base.clone()
        };
        let mut resumed = base.clone();
        run_defaults(&mut resumed, false, false, false, Some(&began));
        assert_eq!((resumed.lr, resumed.iterations), (1.5e-4, 4_000));
        let mut fresh = base.clone();
        run_defaults(&mut fresh, false, false, false, None);
        assert_eq!(fresh, base);
    }
}
