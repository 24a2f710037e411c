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
    /// Adam learning rate (the paper: 1e-3).
    pub lr: f64,
    /// Frame code size f (the paper does not give it).
    pub code: usize,
    /// Hidden width of F_T and F_W (not given in the paper).
    pub hidden: usize,
    /// Template points constrained per step (all frames at once).
    pub points: usize,
    /// λ_3D of eq. 20 (not given in the paper; positions in mm).
    pub lambda_3d: f64,
    /// λ_W of eq. 22 (the paper: 0.75).
    pub lambda_w: f64,
    /// λ_T of eq. 23 (the paper: 0.05).
    pub lambda_t: f64,
    /// λ_2D of eq. 21 (not given in the paper; pixels², where 1 mm at the camera's 60 cm is
    /// about 2 px).
    pub lambda_2d: f64,
    /// Local, global or no coefficients.
    pub coefficients: Coefficients,
    /// 3D meshes or 2D landmarks.
    pub mode: Mode,
    /// Which vertices constrain a 3D fit.
    pub constrain: Constrain,
    /// Seed of the initial weights, the codes and the point draws.
    pub seed: u64,
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            iterations: 1000,
            lr: 1e-3,
            code: 32,
            hidden: 128,
            points: 1024,
            lambda_3d: 1.0,
            lambda_w: 0.75,
            lambda_t: 0.05,
            lambda_2d: 0.25,
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

/// A 4-layer GELU MLP (F_T and F_W).
pub fn gelu_mlp(inputs: usize, hidden: usize, outputs: usize, device: &Device) -> Mlp {
    let acts = [
        Activation::Gelu,
        Activation::Gelu,
        Activation::Gelu,
        Activation::Identity,
    ];
    Mlp::new(&[inputs, hidden, hidden, hidden, outputs], &acts, device)
}
