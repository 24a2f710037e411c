//! Which burn backend trains and evaluates. burn 0.22 picks the backend at run time through the
//! device; this enum is the command line's choice, with the cargo features that enable each.

use burn::tensor::Device;

/// A backend that cannot run in this build.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BackendError {
    /// The backend's cargo feature was not enabled when the binary was built.
    #[error(
        "backend {} is not built in: rebuild with `--features {}`",
        backend.name(),
        backend.name()
    )]
    NotBuiltIn {
        /// The backend asked for.
        backend: Backend,
    },
    /// The backend is built in but finds no device to run on (no GPU adapter or driver).
    #[error(
        "backend {} finds no device on this machine (no GPU adapter or driver it can use); \
         train on the CPU with --backend flex",
        format!("{backend:?}").to_lowercase()
    )]
    Unavailable {
        /// The backend asked for.
        backend: Backend,
    },
}

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
    /// The backend's name, as `--backend` takes it and as its cargo feature is called.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Flex => "flex",
            Self::Ndarray => "ndarray",
            Self::Wgpu => "wgpu",
            Self::Cuda => "cuda",
        }
    }

    /// The device for inference (no autodiff), seeded.
    pub fn device(self, seed: u64) -> Result<Device, BackendError> {
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
            backend => return Err(BackendError::NotBuiltIn { backend }),
        };
        if self != Self::Flex && self != Self::Ndarray && !usable(&device) {
            return Err(BackendError::Unavailable { backend: self });
        }
        device.seed(seed);
        Ok(device)
    }

    /// The device for training (autodiff enabled), seeded.
    pub fn autodiff_device(self, seed: u64) -> Result<Device, BackendError> {
        let device = self.device(seed)?.autodiff();
        device.seed(seed);
        Ok(device)
    }
}

/// Whether a GPU device answers: burn acquires a GPU backend's device lazily, on a worker thread
/// that panics when no adapter exists, and the caller then panics on the dropped channel. One
/// tiny operation, run here with the panic caught (and its message kept off the terminal), turns
/// that into an answer.
fn usable(device: &Device) -> bool {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let ok = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        burn::tensor::Tensor::<1>::zeros([1], device)
            .into_data()
            .try_to_vec::<f32>()
            .is_ok()
    }))
    .unwrap_or(false);
    std::panic::set_hook(hook);
    ok
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flex_is_always_built_in() {
        assert!(Backend::Flex.device(0).is_ok());
        assert!(Backend::Flex.autodiff_device(0).is_ok());
    }

    #[cfg(not(feature = "cuda"))]
    #[test]
    fn a_backend_left_out_of_the_build_is_refused_by_name() {
        let err = Backend::Cuda.autodiff_device(0).unwrap_err();
        assert!(matches!(
            err,
            BackendError::NotBuiltIn {
                backend: Backend::Cuda
            }
        ));
        assert_eq!(
            err.to_string(),
            "backend cuda is not built in: rebuild with `--features cuda`"
        );
    }
}
