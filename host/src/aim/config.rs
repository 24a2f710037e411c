//! AIM training configuration: every knob with the paper's value or the one that worked here,
//! saved as JSON beside every output so a run can be repeated.

use serde::{Deserialize, Serialize};

/// How the learning rate moves from `lr` to `lr_end` over the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Schedule {
    /// `lr` throughout.
    Constant,
    /// Geometric decay: `lr · (lr_end / lr)^(t / T)`.
    Exponential,
    /// Cosine from `lr` down to `lr_end`.
    Cosine,
}

/// How the thickness network's output becomes the soft-tissue thickness d0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ThicknessActivation {
    /// d0 = D(c), as in the paper (eq. 4); the thickness can turn negative where eq. 13 pulls
    /// it to zero (about 610 of the ICT actor's 9,409 vertices after a full run, docs/AIM.md).
    Identity,
    /// d0 = softplus(D(c)) = ln(1 + e^D(c)): positive by construction; the default, since a
    /// full ICT run with it fitted the skin as closely as the paper's identity (docs/AIM.md).
    #[default]
    Softplus,
}

impl ThicknessActivation {
    /// The code of section `aim.dact` (`sinew_core::aim::THICKNESS_SOFTPLUS`, …).
    pub const fn code(self) -> u32 {
        match self {
            Self::Identity => sinew_core::aim::THICKNESS_IDENTITY,
            Self::Softplus => sinew_core::aim::THICKNESS_SOFTPLUS,
        }
    }
}

/// The AIM training configuration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AimConfig {
    /// Hidden width of every network.
    pub hidden: usize,
    /// Hidden layers per network.
    pub layers: usize,
    /// SIREN frequency ω0 of every sine layer.
    pub omega0: f32,
    /// (point, shape) samples per step.
    pub batch: usize,
    /// Points per step for the symmetry term (eq. 14).
    pub symmetry_batch: usize,
    /// Forehead points per step for the skinning-weight term (eq. 15).
    pub forehead_batch: usize,
    /// Optimisation steps.
    pub iterations: usize,
    /// Initial learning rate (Adam).
    pub lr: f64,
    /// Final learning rate.
    pub lr_end: f64,
    /// Learning-rate schedule.
    pub schedule: Schedule,
    /// Seed of initialisation and sampling.
    pub seed: u64,
    /// λ_S, skin position (eq. 11).
    pub lambda_skin: f32,
    /// λ_b, bone point constraint (eq. 12).
    pub lambda_bone: f32,
    /// λ_d, thickness constraint (eq. 12).
    pub lambda_thickness: f32,
    /// λ_n, bone normal constraint (eq. 12).
    pub lambda_normal: f32,
    /// λ_D^Reg, thickness regulariser (eq. 13).
    pub lambda_thickness_reg: f32,
    /// λ_sym, symmetry of B (eq. 14).
    pub lambda_symmetry: f32,
    /// λ_K, zero skinning weight on the forehead (eq. 15).
    pub lambda_forehead: f32,
    /// Steps between checkpoints.
    pub checkpoint_every: usize,
    /// Largest skin-to-bone depth for a constraint, in the data's unit.
    pub max_constraint_depth: f32,
    /// The thickness network's output activation.
    pub thickness_activation: ThicknessActivation,
}

impl Default for AimConfig {
    fn default() -> Self {
        Self {
            hidden: 256,
            layers: 3,
            omega0: 30.0,
            batch: 4096,
            symmetry_batch: 512,
            forehead_batch: 512,
            iterations: 10_000,
            // The paper's 2e-3 stalled at a 3.8 mm noise floor in a PyTorch reference on ICT;
            // 1e-4 decaying to 1e-5 worked best there; over a full run here 2e-4 did better
            // still, and ending at 1e-6 rather than 1e-5 took the residual noise of the fit
            // down by a third (docs/AIM.md compares the schedules).
            lr: 2e-4,
            lr_end: 1e-6,
            schedule: Schedule::Exponential,
            seed: 42,
            lambda_skin: 1.0,
            lambda_bone: 1.0,
            lambda_thickness: 1.0,
            lambda_normal: 1.0,
            lambda_thickness_reg: 7.5e-4,
            lambda_symmetry: 1e-4,
            lambda_forehead: 1e2,
            checkpoint_every: 1000,
            max_constraint_depth: 2.5,
            thickness_activation: ThicknessActivation::Softplus,
        }
    }
}

impl AimConfig {
    /// The small configuration of `sinew demo`: minutes on two cores.
    pub fn demo() -> Self {
        Self {
            hidden: 64,
            batch: 2048,
            symmetry_batch: 256,
            forehead_batch: 256,
            iterations: 1500,
            lr: 1e-3,
            lr_end: 1e-4,
            checkpoint_every: 500,
            ..Self::default()
        }
    }

    /// Learning rate at step `t`.
    pub fn lr_at(&self, t: usize) -> f64 {
        let f = t as f64 / self.iterations.max(1) as f64;
        match self.schedule {
            Schedule::Constant => self.lr,
            Schedule::Exponential => self.lr * (self.lr_end / self.lr).powf(f),
            Schedule::Cosine => {
                self.lr_end
                    + 0.5 * (self.lr - self.lr_end) * (1.0 + (std::f64::consts::PI * f).cos())
            }
        }
    }

    /// Checks ranges; the error names the field.
    pub fn validate(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.hidden > 0 && self.layers > 0,
            "hidden and layers must be positive"
        );
        anyhow::ensure!(
            self.layers < sinew_core::nn::MAX_LAYERS,
            "layers: at most {}",
            sinew_core::nn::MAX_LAYERS - 1
        );
        anyhow::ensure!(
            self.batch > 0 && self.iterations > 0,
            "batch and iterations must be positive"
        );
        anyhow::ensure!(
            self.lr > 0.0 && self.lr_end > 0.0,
            "learning rates must be positive"
        );
        anyhow::ensure!(
            self.checkpoint_every > 0,
            "checkpoint_every must be positive"
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules_start_and_end_where_configured() {
        let mut c = AimConfig {
            iterations: 100,
            ..AimConfig::default()
        };
        for s in [Schedule::Exponential, Schedule::Cosine] {
            c.schedule = s;
            assert!((c.lr_at(0) - 2e-4).abs() < 1e-12);
            assert!((c.lr_at(100) - 1e-6).abs() < 1e-12);
            assert!(c.lr_at(50) < 2e-4 && c.lr_at(50) > 1e-6);
        }
        c.schedule = Schedule::Constant;
        assert_eq!(c.lr_at(77), 2e-4);
    }

    #[test]
    fn config_round_trips_and_rejects_unknown_fields() {
        let c = AimConfig::demo();
        let json = serde_json::to_string(&c).unwrap();
        assert_eq!(serde_json::from_str::<AimConfig>(&json).unwrap(), c);
        assert!(serde_json::from_str::<AimConfig>(r#"{"hiden": 3}"#).is_err());
        let partial: AimConfig = serde_json::from_str(r#"{"iterations": 5}"#).unwrap();
        assert_eq!(partial.iterations, 5);
        assert_eq!(partial.hidden, 256);
    }
}
