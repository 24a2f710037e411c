//! Adam over a whole module, its state on the device the module trains on.
//!
//! The update is burn's own (`burn::optim::Adam`, one parameter at a time, so a step is the same
//! arithmetic as burn's `ModuleOptimizer` gives); the state is kept here. burn 0.22's
//! `ModuleOptimizer` materialises a loaded state on burn's *default* device and moves it on the
//! next step: in a GPU build that default is the GPU, so resuming a CPU run there touched the
//! GPU (and failed on a machine without one). [`Adam::load`] places the state on the device it is
//! given. Checkpoints keep burn's layout (burnpack; per parameter `ID.momentum.moment_1`,
//! `ID.momentum.moment_2`, the scalars `ID.momentum.time` and `ID.__rank`, the path under `ID`),
//! so the optimiser files written before this type read unchanged, and the other way round.

use std::collections::HashMap;

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param, ParamId};
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, AdamState, AdaptiveMomentumState, GradientsParams, Optimizer};
use burn::tensor::{Bytes, DType, Device, Shape, Tensor, TensorData};

/// What the state of one parameter is called in a record (after `ID.`).
const FIRST: &str = "momentum.moment_1";
const SECOND: &str = "momentum.moment_2";
const TIME: &str = "momentum.time";
const RANK: &str = "__rank";

/// An optimiser state that cannot be read.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AdamRecordError {
    /// Not a burnpack, or a damaged one.
    #[error("{0}")]
    Pack(#[from] burn_pack::Error),
    /// A parameter whose state lacks a part.
    #[error("parameter {param}: no {what}")]
    Missing {
        /// The parameter's id.
        param: u64,
        /// The part missing (`momentum.moment_1`, ...).
        what: &'static str,
    },
    /// A tensor of the state that belongs to no parameter or has a name it does not use.
    #[error("tensor {name}: not part of an Adam state")]
    Stray {
        /// The tensor's name.
        name: String,
    },
    /// A module without parameters, so without a device to load a state onto.
    #[error("the module has no parameters to place the state beside")]
    NoParameters,
    /// The two moments of a parameter of different shapes or of another shape than the
    /// parameter, values that are not `f32`, or a time that is not a count.
    #[error("parameter {param}: {detail}")]
    Inconsistent {
        /// The parameter's id.
        param: u64,
        /// What disagrees.
        detail: String,
    },
}

/// One parameter's moments, flattened (the parameter's shape kept beside them), and the number
/// of steps that made them.
#[derive(Clone, Debug)]
struct Moments {
    path: Option<String>,
    shape: Shape,
    time: usize,
    first: Tensor<1>,
    second: Tensor<1>,
}

/// The settings of an [`Adam`]: burn's defaults (β = 0.9, 0.999, ε = 1e-5, no weight decay)
/// unless set.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Settings {
    betas: (f32, f32),
    epsilon: f32,
    weight_decay: Option<f32>,
}

impl Settings {
    fn rule(self) -> burn::optim::Adam {
        AdamConfig::new()
            .with_beta_1(self.betas.0)
            .with_beta_2(self.betas.1)
            .with_epsilon(self.epsilon)
            .with_weight_decay(self.weight_decay.map(WeightDecayConfig::new))
            .build()
    }
}

/// Adam over every float parameter of a module that has a gradient.
#[derive(Clone)]
pub struct Adam {
    settings: Settings,
    rule: burn::optim::Adam,
    states: HashMap<ParamId, Moments>,
}

impl std::fmt::Debug for Adam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Adam")
            .field("settings", &self.settings)
            .field("parameters", &self.states.len())
            .finish_non_exhaustive()
    }
}

impl Default for Adam {
    /// burn's `AdamConfig::new()`: β = 0.9, 0.999, ε = 1e-5.
    fn default() -> Self {
        Self::with(Settings {
            betas: (0.9, 0.999),
            epsilon: 1e-5,
            weight_decay: None,
        })
    }
}

impl Adam {
    fn with(settings: Settings) -> Self {
        Self {
            settings,
            rule: settings.rule(),
            states: HashMap::new(),
        }
    }

    /// Adam (β = 0.9, 0.999) with `epsilon` added to the root of the second moment.
    pub fn new(epsilon: f32) -> Self {
        Self::with(Settings {
            epsilon,
            ..Self::default().settings
        })
    }

    /// The same with the moments' decay rates β₁ and β₂.
    pub fn with_betas(self, beta_1: f32, beta_2: f32) -> Self {
        Self::with(Settings {
            betas: (beta_1, beta_2),
            ..self.settings
        })
    }

    /// The same with L2 weight decay added to the gradient (`penalty · θ`, as PyTorch's `Adam`
    /// does, not AdamW's decoupled decay).
    pub fn with_weight_decay(self, penalty: f32) -> Self {
        Self::with(Settings {
            weight_decay: Some(penalty),
            ..self.settings
        })
    }

    /// The number of parameters with a state (those stepped at least once, or loaded).
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// Whether no parameter has a state yet.
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// The devices the state lives on (one entry per parameter), for checks.
    pub fn devices(&self) -> Vec<Device> {
        self.states.values().map(|m| m.first.device()).collect()
    }

    /// One step at learning rate `lr` on every parameter of `module` that `grads` holds.
    pub fn step<M: Module>(&mut self, lr: f64, module: M, mut grads: GradientsParams) -> M {
        module.map(&mut Stepper {
            rule: &self.rule,
            lr,
            grads: &mut grads,
            states: &mut self.states,
            path: Vec::new(),
        })
    }

    /// The state as burnpack bytes, in burn's `ModuleOptimizer` layout (parameters in id order).
    pub fn into_bytes(&self) -> Result<Bytes, burn_pack::Error> {
        let mut ids: Vec<&ParamId> = self.states.keys().collect();
        ids.sort_by_key(|id| id.val());
        let mut tensors = Vec::with_capacity(2 * ids.len());
        let mut scalars = Vec::with_capacity(2 * ids.len());
        let mut paths = Vec::new();
        for id in ids {
            let m = &self.states[id];
            let prefix = id.val().to_string();
            for (what, t) in [(FIRST, &m.first), (SECOND, &m.second)] {
                let (bytes, _, dtype) = t.to_data().into_parts();
                tensors.push(burn_pack::Tensor::new(
                    format!("{prefix}.{what}"),
                    dtype,
                    m.shape.clone(),
                    Some(id.val()),
                    bytes,
                ));
            }
            scalars.push((format!("{prefix}.{TIME}"), m.time));
            scalars.push((format!("{prefix}.{RANK}"), m.shape.num_dims()));
            if let Some(path) = &m.path {
                paths.push((prefix, path.clone()));
            }
        }
        let mut writer = burn_pack::Writer::new(tensors);
        for (key, value) in scalars {
            writer = writer.with_scalar(&key, burn_pack::Scalar::from(value));
        }
        for (key, value) in paths {
            writer = writer.with_metadata(&key, &value);
        }
        writer.into_bytes()
    }

    /// This optimiser with the state read from `bytes` (written by [`Adam::into_bytes`] or by
    /// burn's `ModuleOptimizer` for Adam) for the parameters of `module`, every tensor of it on
    /// the device they train on.
    pub fn load<M: Module>(self, bytes: Vec<u8>, module: &M) -> Result<Self, AdamRecordError> {
        let device = module
            .devices()
            .into_iter()
            .next()
            .ok_or(AdamRecordError::NoParameters)?;
        let loaded = self.load_on(bytes, &device)?;
        let mut shapes = Shapes(HashMap::new());
        module.visit(&mut shapes);
        for (id, m) in &loaded.states {
            if let Some(shape) = shapes.0.get(id)
                && *shape != m.shape
            {
                return Err(AdamRecordError::Inconsistent {
                    param: id.val(),
                    detail: format!(
                        "a state of shape {:?} for a parameter of shape {shape:?}",
                        m.shape
                    ),
                });
            }
        }
        Ok(loaded)
    }

    /// [`Adam::load`] onto `device` (autodiff or not).
    pub fn load_on(mut self, bytes: Vec<u8>, device: &Device) -> Result<Self, AdamRecordError> {
        let device = device.clone().without_autodiff();
        let reader = burn_pack::Reader::from_bytes(Bytes::from_bytes_vec(bytes))?;
        let scalars = reader.scalars().clone();
        let paths = reader.metadata().clone();
        let mut parts: HashMap<u64, [Option<(Shape, Tensor<1>)>; 2]> = HashMap::new();
        for tensor in reader.into_tensors()? {
            let (name, dtype, shape, id, bytes) = tensor.into_parts()?;
            let (Some(id), Some((prefix, what))) = (id, name.split_once('.')) else {
                return Err(AdamRecordError::Stray { name });
            };
            let slot = match what {
                FIRST => 0,
                SECOND => 1,
                _ => return Err(AdamRecordError::Stray { name }),
            };
            if prefix != id.to_string() {
                return Err(AdamRecordError::Stray { name });
            }
            let n = shape.num_elements();
            if dtype != DType::F32 || bytes.len() != 4 * n {
                return Err(AdamRecordError::Inconsistent {
                    param: id,
                    detail: format!(
                        "{name}: {} bytes of {dtype:?} for {n} f32 values",
                        bytes.len()
                    ),
                });
            }
            let flat = Shape::new([n]);
            let data = TensorData::from_bytes(bytes, flat, dtype);
            parts.entry(id).or_default()[slot] = Some((shape, Tensor::from_data(data, &device)));
        }
        let mut states = HashMap::with_capacity(parts.len());
        for (id, [first, second]) in parts {
            let missing = |what| AdamRecordError::Missing { param: id, what };
            let (shape, first) = first.ok_or_else(|| missing(FIRST))?;
            let (other, second) = second.ok_or_else(|| missing(SECOND))?;
            if shape != other {
                return Err(AdamRecordError::Inconsistent {
                    param: id,
                    detail: format!("first moment {shape:?}, second {other:?}"),
                });
            }
            let time = scalars
                .get(&format!("{id}.{TIME}"))
                .ok_or_else(|| missing(TIME))
                .and_then(|t| {
                    usize::try_from(*t).map_err(|_| AdamRecordError::Inconsistent {
                        param: id,
                        detail: format!("{TIME} {t:?} is not a count of steps"),
                    })
                })?;
            let moments = Moments {
                path: paths.get(&id.to_string()).cloned(),
                shape,
                time,
                first,
                second,
            };
            states.insert(ParamId::from(id), moments);
        }
        self.states = states;
        Ok(self)
    }
}

/// Each float parameter's shape, by id.
struct Shapes(HashMap<ParamId, Shape>);

impl ModuleVisitor for Shapes {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        self.0.insert(param.id, param.shape());
    }
}

/// The walk over a module's parameters that steps each.
struct Stepper<'a> {
    rule: &'a burn::optim::Adam,
    lr: f64,
    grads: &'a mut GradientsParams,
    states: &'a mut HashMap<ParamId, Moments>,
    path: Vec<String>,
}

impl ModuleMapper for Stepper<'_> {
    fn enter_module(&mut self, name: &str, _container_type: &str) {
        self.path.push(name.to_owned());
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.path.pop();
    }

    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let (id, tensor, mapper) = param.consume();
        let Some(grad) = self.grads.remove::<D>(id) else {
            return Param::from_mapped_value(id, tensor, mapper);
        };
        let device = grad.device();
        let require_grad = tensor.is_require_grad();
        let checkpointing = tensor.gradient_checkpointing_strategy();
        let value = tensor.inner();
        let value = if value.device() == device {
            value
        } else {
            value.to_device(&device)
        };
        let shape = value.shape();
        let on = |t: Tensor<1>| {
            if t.device() == device {
                t
            } else {
                t.to_device(&device)
            }
        };
        let state = self.states.remove(&id).map(|m| {
            AdamState::new(AdaptiveMomentumState::new(
                m.time,
                on(m.first).reshape(shape.clone()),
                on(m.second).reshape(shape.clone()),
            ))
        });
        let (value, state) = self.rule.step(self.lr, value, grad, state);
        if let Some(state) = state {
            let n = shape.num_elements();
            let m = state.momentum;
            self.states.insert(
                id,
                Moments {
                    path: Some(self.path.join(".")),
                    shape,
                    time: m.time,
                    first: m.moment_1.reshape([n]),
                    second: m.moment_2.reshape([n]),
                },
            );
        }
        let mut value = Tensor::from_inner(value);
        if let Some(strategy) = checkpointing {
            value = value.with_gradient_checkpointing_strategy(strategy);
        }
        if require_grad {
            value = value.require_grad();
        }
        Param::from_mapped_value(id, value, mapper)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::module::Module;
    use burn::nn::{Linear, LinearConfig};

    #[derive(Module, Debug)]
    struct Two {
        a: Linear,
        b: Linear,
    }

    fn net(device: &Device) -> Two {
        Two {
            a: LinearConfig::new(3, 4).init(device),
            b: LinearConfig::new(4, 2).init(device),
        }
    }

    fn loss(net: &Two, device: &Device, k: usize) -> Tensor<1> {
        let x = Tensor::<2>::from_data(
            TensorData::new(
                (0..6).map(|i| ((i + k) as f32 * 0.37).sin()).collect(),
                [2, 3],
            ),
            device,
        );
        net.b.forward(net.a.forward(x).tanh()).powi_scalar(2).sum()
    }

    fn values(net: &Two) -> Vec<f32> {
        let mut out = Vec::new();
        for t in [
            net.a.weight.val().flatten::<1>(0, 1),
            net.b.weight.val().flatten::<1>(0, 1),
        ] {
            out.extend(t.into_data().try_to_vec::<f32>().unwrap());
        }
        out
    }

    /// Three steps of `optim` on a copy of `start`, with the gradient of step k.
    fn run(
        mut net: Two,
        steps: std::ops::Range<usize>,
        mut step: impl FnMut(Two, GradientsParams) -> Two,
        device: &Device,
    ) -> Two {
        for k in steps {
            let grads = GradientsParams::from_grads(loss(&net, device, k).backward(), &net);
            net = step(net, grads);
        }
        net
    }

    #[test]
    fn steps_as_burns_module_optimiser_and_resumes_from_its_records_and_its_own() {
        let device = Device::flex().autodiff();
        device.seed(7);
        let start = net(&device);
        let lr = 1e-2;

        // burn's ModuleOptimizer: three steps, saved, three more after loading.
        let mut theirs = AdamConfig::new().with_epsilon(1e-8).init();
        let half = run(start.clone(), 0..3, |n, g| theirs.step(lr, n, g), &device);
        let their_bytes = theirs.into_bytes().unwrap().to_vec();
        let mut theirs = AdamConfig::new()
            .with_epsilon(1e-8)
            .init()
            .from_bytes(Bytes::from_bytes_vec(their_bytes.clone()))
            .unwrap();
        let expected = run(half.clone(), 3..6, |n, g| theirs.step(lr, n, g), &device);

        // This Adam, the same six steps: bit for bit the same weights.
        let mut ours = Adam::new(1e-8);
        let ours_half = run(start, 0..3, |n, g| ours.step(lr, n, g), &device);
        assert_eq!(values(&ours_half), values(&half));
        let our_bytes = ours.into_bytes().unwrap().to_vec();
        let mut resumed = Adam::new(1e-8).load_on(our_bytes.clone(), &device).unwrap();
        assert_eq!(resumed.len(), 4);
        let got = run(
            ours_half.clone(),
            3..6,
            |n, g| resumed.step(lr, n, g),
            &device,
        );
        assert_eq!(values(&got), values(&expected));

        // burn's record resumes this Adam, and this Adam's record resumes burn's.
        let mut from_theirs = Adam::new(1e-8).load_on(their_bytes, &device).unwrap();
        let got = run(
            half.clone(),
            3..6,
            |n, g| from_theirs.step(lr, n, g),
            &device,
        );
        assert_eq!(values(&got), values(&expected));
        let mut theirs_from_ours = AdamConfig::new()
            .with_epsilon(1e-8)
            .init()
            .from_bytes(Bytes::from_bytes_vec(our_bytes))
            .unwrap();
        let got = run(half, 3..6, |n, g| theirs_from_ours.step(lr, n, g), &device);
        assert_eq!(values(&got), values(&expected));
    }

    #[test]
    fn a_loaded_state_lives_on_the_device_it_is_given() {
        let device = Device::flex().autodiff();
        let mut adam = Adam::new(1e-8);
        run(net(&device), 0..1, |n, g| adam.step(1e-3, n, g), &device);
        let bytes = adam.into_bytes().unwrap().to_vec();
        let loaded = Adam::new(1e-8).load(bytes, &net(&device)).unwrap();
        assert_eq!(loaded.len(), 4);
        let inner = device.clone().without_autodiff();
        assert!(loaded.devices().iter().all(|d| *d == inner));
    }

    #[test]
    fn a_damaged_state_is_named() {
        let device = Device::flex().autodiff();
        let e = Adam::new(1e-8)
            .load_on(b"not a pack".to_vec(), &device)
            .unwrap_err();
        assert!(matches!(e, AdamRecordError::Pack(_)), "{e}");

        // A state with its second moments left out names the parameter and the part.
        let tensor = burn_pack::Tensor::new(
            format!("5.{FIRST}"),
            burn::tensor::DType::F32,
            Shape::new([2]),
            Some(5),
            Bytes::from_bytes_vec([1.0f32, 2.0].iter().flat_map(|v| v.to_le_bytes()).collect()),
        );
        let bytes = burn_pack::Writer::new(vec![tensor])
            .with_scalar(&format!("5.{TIME}"), burn_pack::Scalar::from(3usize))
            .into_bytes()
            .unwrap()
            .to_vec();
        let e = Adam::new(1e-8).load_on(bytes, &device).unwrap_err();
        assert_eq!(e.to_string(), "parameter 5: no momentum.moment_2");

        // A state made for another network, one of whose parameters shares an id but not a
        // shape.
        let mut adam = Adam::new(1e-8);
        let small = net(&device);
        run(small.clone(), 0..1, |n, g| adam.step(1e-3, n, g), &device);
        let bytes = adam.into_bytes().unwrap().to_vec();
        let mut wide = net(&device);
        wide.a.weight = Param::initialized(small.a.weight.id, Tensor::zeros([5, 4], &device));
        let e = Adam::new(1e-8).load(bytes, &wide);
        assert!(
            matches!(&e, Err(AdamRecordError::Inconsistent { detail, .. }) if detail.contains("for a parameter of shape")),
            "{e:?}"
        );
    }
}
