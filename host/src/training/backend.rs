//! Which burn backend trains and evaluates. burn 0.22 picks the backend at run time through the
//! device; this enum is the command line's choice, with the cargo features that enable each.

use anyhow::{Result, bail};
use burn::tensor::Device;

/// A burn backend the host can run on.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// burn-flex: pure-Rust CPU backend, the default.
    #[default]
    Flex,
    /// burn-ndarray (deprecated upstream in favour of flex; cargo feature `ndarray`).
    Ndarray,
    /// wgpu (Vulkan/Metal/DX12) GPU backend (cargo feature `wgpu`).
    Wgpu,
    /// CUDA GPU backend (cargo feature `cuda`).
    Cuda,
}

impl Backend {
    /// The device for inference (no autodiff), seeded.
    pub fn device(self, seed: u64) -> Result<Device> {
        let device = match self {
            Self::Flex => Device::flex(),
            #[cfg(feature = "ndarray")]
            // burn deprecates ndarray in favour of flex; Sinew keeps it selectable because the
            // product design names it, and allows the warning only here.
            #[allow(deprecated)]
            Self::Ndarray => Device::ndarray(),
            #[cfg(feature = "wgpu")]
            Self::Wgpu => Device::wgpu(burn::tensor::DeviceKind::DefaultDevice),
            #[cfg(feature = "cuda")]
            Self::Cuda => Device::cuda(0usize),
            #[allow(unreachable_patterns)]
            other => bail!(
                "backend {other:?} is not built in: rebuild with `--features {}`",
                format!("{other:?}").to_lowercase()
            ),
        };
        device.seed(seed);
        Ok(device)
    }

    /// The device for training (autodiff enabled), seeded.
    pub fn autodiff_device(self, seed: u64) -> Result<Device> {
        let device = self.device(seed)?.autodiff();
        device.seed(seed);
        Ok(device)
    }
}

/// Whether `x` lives on burn-flex, with or without autodiff (the backend Sinew's CPU kernels and
/// the split training step serve; the others keep burn's own operations).
pub fn on_flex<const D: usize>(x: &burn::tensor::Tensor<D>) -> bool {
    use burn::backend::DispatchTensorKind;
    let x = x.clone().into_dispatch();
    match &x.kind {
        DispatchTensorKind::Flex(_) => true,
        DispatchTensorKind::Autodiff(inner) => matches!(**inner, DispatchTensorKind::Flex(_)),
        #[allow(unreachable_patterns)]
        _ => false,
    }
}
