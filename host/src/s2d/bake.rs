//! Bakes a trained S2D decoder with its hierarchy into the `s2d.` sections that
//! `sinew_core::s2d::S2dDecoder` reads (tables in `docs/FORMAT.md`, "S2D mesh hierarchy" and
//! "S2D decoder"): the hierarchy's own sections, then the network's.

use sinew_core::{ArtifactKind, FormatError};

use super::Hierarchy;
use super::decoder::{DecoderError, S2dDecoder};
use crate::io::container::{SinewWriter, WriterError};
use crate::training::nn::{SpiralConv, to_vec};

/// A decoder that cannot be baked over its hierarchy and landmarks.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum S2dBakeError {
    /// A configuration that does not fit the hierarchy.
    #[error(transparent)]
    Config(#[from] DecoderError),
    /// A decoder built for other levels than the hierarchy's.
    #[error(
        "the decoder was built for levels of {decoder:?} vertices, the hierarchy has {hierarchy:?}"
    )]
    Levels {
        /// The decoder's levels.
        decoder: Vec<usize>,
        /// The hierarchy's.
        hierarchy: Vec<usize>,
    },
    /// Not one landmark per three inputs.
    #[error("{landmarks} landmarks for {inputs} inputs")]
    Landmarks {
        /// The landmarks given.
        landmarks: usize,
        /// The decoder's inputs.
        inputs: usize,
    },
    /// A landmark vertex past the template's last.
    #[error("a landmark vertex is outside the template")]
    LandmarkOutside,
    /// A section that cannot be laid out.
    #[error(transparent)]
    Layout(#[from] WriterError),
    /// Bytes the core refuses: a bug of the writer, caught before the file is written.
    #[error("the baked decoder does not validate")]
    Invalid(#[source] FormatError),
}

/// Writes `decoder` over `hierarchy`, with the landmark vertex indices of the template (level 0),
/// as `s2d.` sections of `w`.
pub fn write(
    decoder: &S2dDecoder,
    hierarchy: &Hierarchy,
    landmarks: &[u32],
    w: &mut SinewWriter,
) -> Result<(), S2dBakeError> {
    let c = &decoder.config;
    c.validate(hierarchy)?;
    let vertices: Vec<usize> = hierarchy.levels.iter().map(|l| l.positions.len()).collect();
    if vertices != decoder.vertices {
        return Err(S2dBakeError::Levels {
            decoder: decoder.vertices.clone(),
            hierarchy: vertices,
        });
    }
    if landmarks.len() * 3 != c.inputs {
        return Err(S2dBakeError::Landmarks {
            landmarks: landmarks.len(),
            inputs: c.inputs,
        });
    }
    if landmarks.iter().any(|&i| i as usize >= vertices[0]) {
        return Err(S2dBakeError::LandmarkOutside);
    }
    let levels = vertices.len();
    // The parts of the hierarchy the decoder reads: the template positions, spirals and U.
    super::hierarchy::write_sections(hierarchy, w, "s2d", super::hierarchy::Sections::Playback)?;
    let u32s = |v: &[usize]| v.iter().map(|&x| x as u32).collect::<Vec<_>>();
    w.u32s(
        "s2d.cfg",
        &[3],
        &u32s(&[c.inputs, c.fc_features, c.outputs]),
    )?;
    w.u32s("s2d.input", &[1], &[c.input.code()])?;
    w.u32s("s2d.lmk", &[landmarks.len()], landmarks)?;
    let act = c.activation.activation();
    w.u32s("s2d.act", &[1], &[act.code()])?;
    w.f32s("s2d.par", &[1], &[act.param()])?;

    // burn stores [in, out]; the core reads one row per output.
    let fc_w = decoder.fc.weight.val().transpose();
    let [out, inp] = fc_w.dims();
    w.f32s("s2d.fc.w", &[out, inp], &to_vec(fc_w))?;
    w.f32s("s2d.fc.b", &[out], &bias(&decoder.fc, out))?;

    let n_convs = decoder.convs.len();
    for (stage, conv) in decoder.convs.iter().enumerate() {
        let prefix = if stage + 1 == n_convs {
            "s2d.out".to_owned()
        } else {
            format!("s2d.conv.{}", levels - 2 - stage)
        };
        write_conv(w, &prefix, conv)?;
    }
    Ok(())
}

/// A complete S2D-decoder artefact: the sections of [`write()`] and metadata.
pub fn bake(
    decoder: &S2dDecoder,
    hierarchy: &Hierarchy,
    landmarks: &[u32],
    metadata: &[(String, String)],
) -> Result<Vec<u8>, S2dBakeError> {
    let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
    for (k, v) in metadata {
        w.meta(k, v);
    }
    write(decoder, hierarchy, landmarks, &mut w)?;
    let bytes = w.to_bytes()?;
    // The core must accept what the host writes.
    sinew_core::s2d::S2dDecoder::from_bytes(&bytes).map_err(S2dBakeError::Invalid)?;
    Ok(bytes)
}

fn bias(linear: &burn::nn::Linear, outputs: usize) -> Vec<f32> {
    linear
        .bias
        .as_ref()
        .map_or_else(|| vec![0.0; outputs], |b| to_vec(b.val()))
}

fn write_conv(w: &mut SinewWriter, prefix: &str, conv: &SpiralConv) -> Result<(), WriterError> {
    let weight = conv.linear.weight.val().transpose();
    let [outputs, inputs] = weight.dims();
    w.f32s(&format!("{prefix}.w"), &[outputs, inputs], &to_vec(weight))?;
    w.f32s(
        &format!("{prefix}.b"),
        &[outputs],
        &bias(&conv.linear, outputs),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s2d::synthetic;

    #[test]
    fn baked_decoder_loads_and_decodes() {
        let device = crate::training::backend::Backend::Flex.device(4).unwrap();
        let h = synthetic::hierarchy(&[30, 12, 5], &[5, 4, 3], 6);
        let config = synthetic::small_config();
        let dec = S2dDecoder::new(&config, &h, &device).unwrap();
        let meta = [("units".to_owned(), "m".to_owned())];
        let bytes = bake(&dec, &h, &[3, 17], &meta).unwrap();
        let core = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).unwrap();
        assert_eq!(core.level_sizes(), &[30, 12, 5]);
        assert_eq!(core.landmarks().iter().collect::<Vec<_>>(), [3, 17]);
        assert_eq!(core.file().metadata().get("units"), Some("m"));
        // What playback reads and the template's triangles (the default face of `sinew
        // generate`); no coarse positions or triangles, no down-samplings.
        let names: Vec<&str> = core.file().sections().map(|s| s.name()).collect();
        assert!(
            names.contains(&"s2d.h0.pos")
                && names.contains(&"s2d.h0.tri")
                && names.contains(&"s2d.u1.val"),
            "{names:?}"
        );
        assert!(
            !names
                .iter()
                .any(|n| (n.ends_with(".tri") && *n != "s2d.h0.tri")
                    || n.starts_with("s2d.d")
                    || *n == "s2d.h1.pos"),
            "{names:?}"
        );
        let face =
            crate::io::decoder_face::template(std::path::Path::new("d.sinew"), &bytes).unwrap();
        assert_eq!(face.positions, h.levels[0].positions);
        let tri: Vec<Vec<u32>> = h.levels[0].triangles.iter().map(|t| t.to_vec()).collect();
        assert_eq!(face.polygons, tri);
        assert!(matches!(
            bake(&dec, &h, &[3], &meta),
            Err(S2dBakeError::Landmarks {
                landmarks: 1,
                inputs: 6
            })
        ));
        assert!(matches!(
            bake(&dec, &h, &[3, 30], &meta),
            Err(S2dBakeError::LandmarkOutside)
        ));
        let other = synthetic::hierarchy(&[31, 12, 5], &[5, 4, 3], 6);
        assert!(matches!(
            bake(&dec, &other, &[3, 17], &meta),
            Err(S2dBakeError::Levels { .. })
        ));
    }
}
