//! A fit's settings and its variables (AIM Sec. 4.2): what `sinew fit` is asked to do, and the
//! frame codes with F_T and F_W that it optimises.

use burn::module::{Module, Param};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};
use sinew_core::nn::Activation;

use crate::training::nn::Mlp;

/// How the corrective coefficients vary.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum, Default)]
#[serde(rename_all = "lowercase")]
pub enum Coefficients {
    /// w_j(c) = F_W(z_j, c): spatially varying (the paper's AIM).
    #[default]
    Local,
    /// w_j = F_W(z_j): one vector per frame (the paper's "Ours (G)").
    Global,
    /// w = 0: head and jaw only (a reference the others must beat).
    Zero,
}

/// What the fit is constrained by (AIM Sec. 4.2.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// 3D positions of the performance's meshes (eq. 20).
    #[default]
    #[value(name = "3d")]
    #[serde(rename = "3d")]
    ThreeD,
    /// The 68 landmarks' pixels through the performance's camera (eq. 21).
    #[value(name = "2d")]
    #[serde(rename = "2d")]
    TwoD,
}

/// Where each frame's head starts, the transform a zero F_T output means.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum, Default)]
#[serde(rename_all = "lowercase")]
pub enum Start {
    /// At the rigid motion (Horn) that best takes the actor's neutral to the frame's
    /// constrained vertices (3D fits; a 2D fit starts at the identity).
    #[default]
    Rigid,
    /// At the identity.
    Identity,
    /// Where a landmark driver put each frame's head and jaw (`sinew fit --start driver
    /// --driver D.sinew`): the fit refines the driver's answer.
    Driver,
}

impl Start {
    /// Checkpoints written before the rigid start existed started at the identity.
    fn before_rigid() -> Self {
        Self::Identity
    }
}

/// Which vertices of the meshes constrain a 3D fit (AIM Fig. 7).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Constrain {
    /// Every vertex (dense).
    #[default]
    All,
    /// The 68 landmark vertices.
    Landmarks,
    /// A seeded random fraction in (0, 1] of the vertices.
    Fraction(f32),
}

impl std::str::FromStr for Constrain {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "all" => Ok(Self::All),
            "landmarks" => Ok(Self::Landmarks),
            _ => match s.parse::<f32>() {
                Ok(f) if f > 0.0 && f <= 1.0 => Ok(Self::Fraction(f)),
                _ => Err(format!(
                    "{s:?}: expected all, landmarks or a fraction in (0, 1]"
                )),
            },
        }
    }
}

/// The fit's settings (the paper's unless said otherwise).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitConfig {
    /// Adam steps (the paper: 1e4).
    pub iterations: usize,
    /// Adam learning rate at the first step (the paper: 1e-3, constant).
    pub lr: f64,
    /// Adam learning rate at the last step; the rate decays exponentially from `lr` to it.
    #[serde(default = "FitConfig::paper_lr")]
    pub lr_final: f64,
    /// Frame code size f (the paper does not give it).
    pub code: usize,
    /// Hidden width of F_T and F_W (not given in the paper).
    pub hidden: usize,
    /// Template points constrained per step (all frames at once).
    pub points: usize,
    /// λ_3D of eq. 20 (not given in the paper; positions in mm, so that λ_W's 0.75 on
    /// coefficients of order 1 stays the weak regulariser the paper calls it at errors of tenths
    /// of a millimetre).
    pub lambda_3d: f64,
    /// λ_W of eq. 22 (the paper: 0.75).
    pub lambda_w: f64,
    /// λ_T of eq. 23 (the paper: 0.05).
    pub lambda_t: f64,
    /// λ_2D of eq. 21 (not given in the paper; pixels², where 1 mm at the camera's 60 cm is
    /// about 2 px).
    pub lambda_2d: f64,
    /// ω0 of a sine first layer of a local F_W, `sin(ω0 (W [z; ĉ] + b))` (0: GELU, the
    /// paper's); `None`: [`FitConfig::DENSE_OMEGA0`] for 3D fits to all or a fraction of the
    /// vertices, 0 for fits to the 68 landmarks or their 2D tracks. A GELU MLP on the template
    /// point learns slowly how coefficients vary over the face; the sine layer lets it vary them
    /// from the first steps (SIREN's first layer), which a few landmarks cannot hold in place.
    #[serde(default = "FitConfig::all_gelu")]
    pub fw_omega0: Option<f32>,
    /// Where each frame's head starts.
    #[serde(default = "Start::before_rigid")]
    pub start: Start,
    /// For [`Start::Driver`], the driver's content hash (16 hex digits), so that a fit resumed
    /// from another driver's answer is refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub driver: Option<String>,
    /// Local, global or no coefficients.
    pub coefficients: Coefficients,
    /// 3D meshes or 2D landmarks.
    pub mode: Mode,
    /// Which vertices constrain a 3D fit.
    pub constrain: Constrain,
    /// Seed of the initial weights, the codes and the point draws.
    pub seed: u64,
}

impl FitConfig {
    /// ω0 of F_W's sine first layer when the constraints are dense enough to hold it.
    pub const DENSE_OMEGA0: f32 = 30.0;

    /// Checkpoints written before the sine layer existed had an all-GELU F_W.
    fn all_gelu() -> Option<f32> {
        Some(0.0)
    }

    /// ω0 of F_W's sine first layer, 0 for none ([`FitConfig::fw_omega0`]).
    pub fn omega0(&self) -> f32 {
        let sparse = self.mode == Mode::TwoD || self.constrain == Constrain::Landmarks;
        match self.fw_omega0 {
            Some(w) => w,
            None if sparse => 0.0,
            None => Self::DENSE_OMEGA0,
        }
    }

    /// The paper's constant learning rate, for checkpoints written before the decay existed.
    fn paper_lr() -> f64 {
        1e-3
    }

    /// Adam's learning rate at `step` of `iterations`: `lr · (lr_final / lr)^(step / (iterations − 1))`.
    pub fn lr_at(&self, step: usize) -> f64 {
        let last = self.iterations.saturating_sub(1).max(1) as f64;
        let t = (step as f64 / last).min(1.0);
        self.lr * (self.lr_final / self.lr).powf(t)
    }
}

impl Default for FitConfig {
    /// Sinew's defaults, chosen for a fit of at most 1 s a frame on a 2-core CPU (docs/FIT.md,
    /// "Defaults beyond the paper").
    fn default() -> Self {
        Self {
            iterations: 600,
            lr: 1e-2,
            lr_final: 1e-3,
            code: 32,
            hidden: 64,
            points: 96,
            lambda_3d: 10.0,
            lambda_w: 0.75,
            lambda_t: 0.05,
            lambda_2d: 0.25,
            fw_omega0: None,
            start: Start::Rigid,
            driver: None,
            coefficients: Coefficients::Local,
            mode: Mode::ThreeD,
            constrain: Constrain::All,
            seed: 1,
        }
    }
}

/// The fitted variables: the codes, F_T and F_W.
#[derive(Module, Debug)]
pub struct FitNet {
    /// z_j, `[J, f]`.
    pub codes: Param<Tensor<2>>,
    /// F_T: z → [T_g, T_b] (18 outputs, added to the identity).
    pub ft: Mlp,
    /// F_W: (z, ĉ) → w (local) or z → w (global).
    pub fw: Mlp,
}

/// F_W for `config`: a GELU MLP, with a sine first layer for local coefficients when
/// [`FitConfig::omega0`] is positive.
pub fn fw_mlp(config: &FitConfig, inputs: usize, outputs: usize, device: &Device) -> Mlp {
    let omega0 = config.omega0();
    let first = if omega0 > 0.0 && config.coefficients == Coefficients::Local {
        Activation::Sine { omega0 }
    } else {
        Activation::Gelu
    };
    four_layers(first, inputs, config.hidden, outputs, device)
}

/// A 4-layer GELU MLP (F_T, and F_W without its sine layer).
pub fn gelu_mlp(inputs: usize, hidden: usize, outputs: usize, device: &Device) -> Mlp {
    four_layers(Activation::Gelu, inputs, hidden, outputs, device)
}

/// Four layers: `first`, then two GELU layers of `hidden` units, then a linear output.
fn four_layers(
    first: Activation,
    inputs: usize,
    hidden: usize,
    outputs: usize,
    device: &Device,
) -> Mlp {
    let acts = [
        first,
        Activation::Gelu,
        Activation::Gelu,
        Activation::Identity,
    ];
    Mlp::new(&[inputs, hidden, hidden, hidden, outputs], &acts, device)
}
