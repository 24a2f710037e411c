//! A trained driver baked into a `.sinew` driver (docs/FORMAT.md, "Driver"): the actor's content
//! hash, its landmark vertices, the normalisation and the network, as `sinew_core::driver` reads
//! them.

use sinew_core::ArtifactKind;
use sinew_core::driver::{INPUT_NORM, LANDMARK_VERTICES, MODEL_HASH, NETWORK, OUTPUT_NORM};
use sinew_core::replay::hash_words;

use super::DriverConfig;
use super::train::Normalisation;
use crate::io::container::{SinewWriter, WriterError};
use crate::training::nn::Mlp;

/// `content` metadata of a baked driver.
pub const CONTENT: &str = "landmark-driver";

/// What a baked driver records beside its network.
#[derive(Clone, Copy, Debug)]
pub struct BakeInputs<'a> {
    /// The actor's content hash.
    pub actor_hash: u64,
    /// The actor's unit (`units` metadata).
    pub units: &'a str,
    /// The actor's vertex of each landmark.
    pub vertices: &'a [u32],
    /// The canonical camera's centre.
    pub camera: [f32; 3],
}

/// The driver's bytes.
///
/// # Errors
/// [`WriterError`] for sections that do not fit their shapes.
pub fn bake(
    net: &Mlp,
    norm: &Normalisation,
    config: &DriverConfig,
    inputs: &BakeInputs<'_>,
) -> Result<Vec<u8>, WriterError> {
    let d = norm.input_mean.len();
    let p = norm.output_offset.len();
    let mut w = SinewWriter::new(ArtifactKind::Driver);
    w.meta("content", CONTENT)
        .meta("version", 1)
        .meta("input", config.input.name())
        .meta("units", inputs.units)
        .meta(
            "camera",
            format!(
                "{},{},{}",
                inputs.camera[0], inputs.camera[1], inputs.camera[2]
            ),
        )
        .meta("seed", config.seed)
        .meta("config", serde_json::to_string(config).unwrap_or_default())
        .meta(
            "source",
            "sinew train driver: synthetic performances of the actor itself",
        );
    if config.tracker == super::Tracker::MediaPipe {
        w.meta(super::mediapipe::META.0, super::mediapipe::META.1);
    }
    if config.convention_amplitude > 0.0 && config.input == sinew_core::driver::Space::Image {
        w.meta(
            sinew_core::driver::CALIBRATION_DEPTH,
            super::CALIBRATION_DEPTH_SHARE,
        );
    }
    let [lo, hi] = hash_words(inputs.actor_hash);
    w.u32s(MODEL_HASH, &[2], &[lo, hi])?;
    w.u32s(LANDMARK_VERTICES, &[inputs.vertices.len()], inputs.vertices)?;
    let input: Vec<f32> = norm
        .input_mean
        .iter()
        .chain(&norm.input_scale)
        .copied()
        .collect();
    w.f32s(INPUT_NORM, &[2, d], &input)?;
    let output: Vec<f32> = norm
        .output_offset
        .iter()
        .chain(&norm.output_scale)
        .copied()
        .collect();
    w.f32s(OUTPUT_NORM, &[2, p], &output)?;
    net.export(&mut w, NETWORK)?;
    w.to_bytes()
}
