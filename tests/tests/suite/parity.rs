//! The core's kernels against burn on the same weights: the host trains with burn and the core
//! plays back, so both must compute the same function. Allowed differences are in
//! `sinew_host::training::tolerance`, one entry per kernel with its reason.

use burn::tensor::Device;
use sinew_core::SinewFile;
use sinew_core::network::load_mlp;
use sinew_core::nn::Activation;
use sinew_core::spiral::{SpiralConv as CoreSpiralConv, Spirals};
use sinew_host::SinewWriter;
use sinew_host::training::nn::{Mlp, SpiralConv, tensor, to_vec};
use sinew_host::training::tolerance::{self, Tolerance};
use sinew_tests::Rng;

fn device() -> Device {
    sinew_host::training::backend::Backend::Flex
        .device(7)
        .unwrap()
}

/// Runs the exported MLP through the core, row by row.
fn core_mlp(bytes: &[u8], input: &[f32], inputs: usize) -> Vec<f32> {
    let file = SinewFile::from_bytes(bytes).unwrap();
    let mlp = load_mlp(&file, "mlp").unwrap();
    let mut scratch = vec![0.0; mlp.scratch_len()];
    let mut out = vec![0.0; input.len() / inputs * mlp.outputs()];
    mlp.eval_batch(input, &mut out, &mut scratch).unwrap();
    out
}

fn assert_within(tol: &Tolerance, core: &[f32], burn: &[f32]) {
    if let Some((i, c, b)) = tol.first_violation(core, burn) {
        panic!(
            "{}: output {i}: core {c} vs burn {b} exceeds {} + {}·|burn| ({})",
            tol.what, tol.abs, tol.rel, tol.reason
        );
    }
    let max = core
        .iter()
        .zip(burn)
        .map(|(c, b)| (c - b).abs())
        .fold(0.0f32, f32::max);
    eprintln!(
        "{}: max |core - burn| = {max:e} over {} outputs",
        tol.what,
        core.len()
    );
    // The comparison must not pass vacuously: the outputs are not all zero.
    assert!(
        burn.iter().any(|v| v.abs() > 1e-3),
        "{}: degenerate outputs",
        tol.what
    );
}

fn export(mlp: &Mlp) -> Vec<u8> {
    let mut w = SinewWriter::new(sinew_core::ArtifactKind::Network);
    mlp.export(&mut w, "mlp").unwrap();
    w.to_bytes().unwrap()
}

#[test]
fn mlp_matches_burn() {
    let device = device();
    let acts = [
        Activation::Gelu,
        Activation::Elu { alpha: 1.0 },
        Activation::Relu,
        Activation::LeakyRelu { slope: 0.2 },
        Activation::Identity,
    ];
    let mlp = Mlp::new(&[3, 64, 64, 32, 16, 5], &acts, &device);
    let input = Rng::new(11).vec(256 * 3, -2.0, 2.0);
    let burn = to_vec(mlp.forward(tensor(input.clone(), [256, 3], &device)));
    assert_within(&tolerance::MLP, &core_mlp(&export(&mlp), &input, 3), &burn);
}

#[test]
fn siren_matches_burn() {
    let device = device();
    // The AIM network shape: 3 → 256 → 256 → 256 → out, ω0 = 30.
    let mlp = Mlp::siren(&[3, 256, 256, 256, 4], 30.0, &device);
    let input = Rng::new(12).vec(512 * 3, -1.0, 1.0);
    let burn = to_vec(mlp.forward(tensor(input.clone(), [512, 3], &device)));
    assert_within(
        &tolerance::SIREN,
        &core_mlp(&export(&mlp), &input, 3),
        &burn,
    );
}

#[test]
fn spiral_conv_matches_burn() {
    let device = device();
    let (sources, vertices, len, inputs, outputs) = (60, 40, 9, 16, 8);
    let mut rng = Rng::new(13);
    let spirals: Vec<u32> = (0..vertices * len)
        .map(|_| (rng.uniform(0.0, 1.0) * sources as f32) as u32 % sources as u32)
        .collect();
    let conv = SpiralConv::new(
        &spirals,
        len,
        inputs,
        outputs,
        Activation::Elu { alpha: 1.0 },
        &device,
    );
    let x = rng.vec(sources * inputs, -1.0, 1.0);
    let burn = to_vec(conv.forward(tensor(x.clone(), [1, sources, inputs], &device)));

    let mut w = SinewWriter::new(sinew_core::ArtifactKind::Network);
    conv.export(&mut w, "conv").unwrap();
    let bytes = w.to_bytes().unwrap();
    let file = SinewFile::from_bytes(&bytes).unwrap();
    let idx = file
        .u32_tensor("conv.idx", &[vertices as u32, len as u32])
        .unwrap();
    let weight = file
        .f32_tensor("conv.w", &[outputs as u32, (len * inputs) as u32])
        .unwrap();
    let bias = file.f32_tensor("conv.b", &[outputs as u32]).unwrap();
    let spirals = Spirals::new(idx, vertices, len, sources).unwrap();
    let core = CoreSpiralConv::new(
        spirals,
        weight,
        bias,
        inputs,
        outputs,
        Activation::Elu { alpha: 1.0 },
    )
    .unwrap();
    let mut out = vec![0.0; vertices * outputs];
    core.forward(&x, &mut out).unwrap();
    assert_within(&tolerance::SPIRAL_CONV, &out, &burn);
}

/// The whole decoder at the reference size (random weights, synthetic connectivity with the
/// FLAME hierarchy's sizes): burn's training forward against the core's baked decode, with each
/// stage activation.
#[test]
fn s2d_decoder_matches_burn() {
    use sinew_host::s2d::decoder::{DecoderConfig, S2dDecoder, StageActivation};
    use sinew_host::s2d::synthetic::{self, REFERENCE_SIZES, REFERENCE_SPIRALS};
    let device = device();
    let h = synthetic::hierarchy(&REFERENCE_SIZES, &REFERENCE_SPIRALS, 21);
    for activation in [
        StageActivation::Elu,
        StageActivation::LeakyRelu,
        StageActivation::Identity,
    ] {
        let config = DecoderConfig {
            activation,
            ..DecoderConfig::default()
        };
        let dec = S2dDecoder::new(&config, &h, &device).unwrap();
        let landmarks: Vec<u32> = (0..68).map(|i| i * 70).collect();
        let bytes = sinew_host::s2d::bake::bake(&dec, &h, &landmarks, &[]).unwrap();
        let core = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).unwrap();
        let batch = 3;
        // Landmark displacements of the size normalisation gives (a few hundredths).
        let input = Rng::new(22).vec(batch * 204, -0.05, 0.05);
        let burn = to_vec(dec.forward(tensor(input.clone(), [batch, 204], &device)));
        let v = REFERENCE_SIZES[0];
        let mut out = vec![0.0; batch * v * 3];
        let mut scratch = vec![0.0; core.scratch_len()];
        for (x, y) in input.chunks(204).zip(out.chunks_mut(v * 3)) {
            core.displacements(x, &mut scratch, y).unwrap();
        }
        assert_within(&tolerance::S2D_DECODER, &out, &burn);
    }
}

/// The same on the real FLAME hierarchy built with the reference's spiral lengths: the reference
/// network's 666,083 parameters, and the core's decode against burn's.
#[test]
fn s2d_decoder_matches_burn_on_flame() {
    use sinew_host::s2d::decoder::{DecoderConfig, S2dDecoder};
    use sinew_host::s2d::hierarchy::{Config, build_with};
    let Some(dir) = sinew_host::io::data::data_dir() else {
        return;
    };
    let mesh = sinew_host::io::mesh::Mesh::read(&dir.join("flame/FLAME_template.ply")).unwrap();
    let h = build_with(&mesh, &Config::reference_flame()).unwrap();
    let device = device();
    let config = DecoderConfig::default();
    let dec = S2dDecoder::new(&config, &h, &device).unwrap();
    assert_eq!(config.parameter_count(&h), 666_083);
    assert_eq!(dec.parameter_count(), 666_083);
    let landmarks: Vec<u32> = (0..68).map(|i| i * 73).collect();
    let bytes = sinew_host::s2d::bake::bake(&dec, &h, &landmarks, &[]).unwrap();
    let core = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).unwrap();
    let input = Rng::new(23).vec(2 * 204, -0.05, 0.05);
    let burn = to_vec(dec.forward(tensor(input.clone(), [2, 204], &device)));
    let v = core.vertex_count();
    let mut out = vec![0.0; 2 * v * 3];
    let mut scratch = vec![0.0; core.scratch_len()];
    for (x, y) in input.chunks(204).zip(out.chunks_mut(v * 3)) {
        core.displacements(x, &mut scratch, y).unwrap();
    }
    assert_within(&tolerance::S2D_DECODER, &out, &burn);
}
