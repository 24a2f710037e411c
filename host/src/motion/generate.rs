// S2D eq. 5 (decoding onto a neutral) and §4.4 (geodesic interpolation between two motions).
//! `sinew generate` and `sinew interpolate`: a baked Motion3DGAN generator and a baked S2D-Dec
//! through `sinew-core` turn a label and a seed into meshes of a face (S2D sections 3, 4.4).
//!
//! The generator makes the landmark curve on the neutral's own landmarks (the decoder's `s2d.lmk`
//! vertices), and for each frame the decoder turns the landmark displacement into a dense one,
//! added to the neutral. Frames are written as `frame_NN.obj` (1 to 30; frame 0 would be the
//! neutral itself) with the neutral's polygons, and a PNG strip of chosen frames beside them.

use std::path::{Path, PathBuf};

use sinew_core::error::{BufferError, FormatError};
use sinew_core::motion::MotionGenerator;
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::srvf::{FRAMES, decode};

use super::srvf::{self, SrvfError};
use crate::figures::render::{Image, View, render};
use crate::io::container::ContainerError;
use crate::io::decoder_face::DecoderFaceError;
use crate::io::mesh::{Mesh, MeshError};

/// A generation or interpolation that was refused or failed; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MotionGenerateError {
    /// A model or decoder file that cannot be read as a `.sinew` file (the error names it).
    #[error(transparent)]
    Read(#[from] ContainerError),
    /// A model file that is not a Motion3DGAN generator.
    #[error("{}: not a Motion3DGAN generator (from `sinew train motion`)", path.display())]
    NotAGenerator {
        /// The model file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A generator that does not list one label per class.
    #[error("{}: the generator lists {found} labels, {expected} expected", path.display())]
    LabelCount {
        /// The model file.
        path: PathBuf,
        /// The labels it lists.
        found: usize,
        /// The classes.
        expected: usize,
    },
    /// A decoder file that is not an S2D decoder.
    #[error("{}: not an S2D decoder", path.display())]
    NotADecoder {
        /// The decoder file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A decoder that reads other landmarks than the generator moves.
    #[error(
        "{}: the decoder reads {landmarks} landmarks, but the generator {} moves {moved}",
        decoder.display(),
        model.display()
    )]
    DecoderLandmarks {
        /// The decoder file.
        decoder: PathBuf,
        /// The model file.
        model: PathBuf,
        /// The decoder's landmarks.
        landmarks: usize,
        /// The generator's.
        moved: usize,
    },
    /// A decoder that the core's sequence refuses with the generator.
    #[error("{}: does not fit the generator {}", decoder.display(), model.display())]
    Mismatch {
        /// The decoder file.
        decoder: PathBuf,
        /// The model file.
        model: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// An intensity that is negative or not finite.
    #[error(
        "--intensity {0} must be a finite number of at least 0 (1 is the training motions' mean)"
    )]
    Intensity(f32),
    /// Fewer than 2 interpolation steps.
    #[error("--steps must be at least 2 (the two ends)")]
    Steps,
    /// A neutral or frame mesh that cannot be read or written (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// No `--neutral`, and the decoder's own template face cannot be made (the error names the
    /// decoder and says what to do).
    #[error(transparent)]
    Template(#[from] DecoderFaceError),
    /// A neutral of another vertex count than the decoder's template.
    #[error(
        "{}: {found} vertices, the decoder's template has {expected} (the neutral must share \
         its topology)",
        path.display()
    )]
    NeutralVertices {
        /// The neutral mesh file.
        path: PathBuf,
        /// Its vertices.
        found: usize,
        /// The template's.
        expected: usize,
    },
    /// A label the generator does not know.
    #[error(
        "{}: unknown label {label:?}; the generator knows {}",
        path.display(),
        known.join(", ")
    )]
    UnknownLabel {
        /// The model file.
        path: PathBuf,
        /// The label asked for.
        label: String,
        /// The labels it knows.
        known: Vec<String>,
    },
    /// The core refused to generate a motion.
    #[error("generating")]
    Generating(#[source] sinew_core::EvalError),
    /// The motion's curve cannot be decoded onto the neutral.
    #[error("decoding the motion")]
    DecodeMotion(#[source] BufferError),
    /// A frame the decoder refused.
    #[error("decoding frame {frame}")]
    DecodeFrame {
        /// The frame.
        frame: usize,
        /// What the core said.
        #[source]
        source: sinew_core::EvalError,
    },
    /// Two motions with no geodesic between them.
    #[error(transparent)]
    Srvf(#[from] SrvfError),
    /// The output folder cannot be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// The strip picture cannot be written.
    #[error("{}: cannot write the strip", path.display())]
    Strip {
        /// The picture's file.
        path: PathBuf,
        /// What the picture writer said.
        #[source]
        source: crate::figures::render::PngError,
    },
}

/// What to generate, and where.
#[derive(Clone, Debug)]
pub struct Generate {
    /// The baked generator.
    pub model: PathBuf,
    /// The baked S2D decoder.
    pub decoder: PathBuf,
    /// The neutral face (the decoder's topology); `None`: the decoder's own template neutral
    /// with the triangles it carries (`io::decoder_face::template`).
    pub neutral: Option<PathBuf>,
    /// The seed of the noise.
    pub seed: u64,
    /// Scale of the motion (1: a length drawn from the label's training curves; interpolation
    /// blends the two labels' mean lengths).
    pub intensity: f32,
    /// The output folder.
    pub out: PathBuf,
}

/// The frames the PNG strip shows (1-based, 30 the apex).
pub const STRIP: [usize; 5] = [1, 8, 15, 22, 30];

/// The generator, the decoder and the neutral, checked against each other.
struct Loaded<'a> {
    sequence: Sequence<'a>,
    labels: Vec<String>,
    neutral: Mesh,
    neutral_lmk: Vec<f32>,
}

/// A baked generator (from `sinew train motion`) and its labels; errors name `path`.
pub(crate) fn open_generator<'a>(
    path: &Path,
    bytes: &'a [u8],
) -> Result<(MotionGenerator<'a>, Vec<String>), MotionGenerateError> {
    let generator = MotionGenerator::from_bytes(bytes).map_err(|source| {
        MotionGenerateError::NotAGenerator {
            path: path.to_owned(),
            source,
        }
    })?;
    let labels: Vec<String> = sinew_core::SinewFile::from_bytes(bytes)
        .ok()
        .and_then(|f| f.metadata().get("labels").map(str::to_owned))
        .map(|l| l.split(',').map(str::to_owned).collect())
        .unwrap_or_default();
    if labels.len() != sinew_core::motion::LABELS {
        return Err(MotionGenerateError::LabelCount {
            path: path.to_owned(),
            found: labels.len(),
            expected: sinew_core::motion::LABELS,
        });
    }
    Ok((generator, labels))
}

/// A baked S2D decoder whose landmarks `generator` (read from `model`) moves; errors name the
/// files.
pub(crate) fn open_decoder<'a>(
    path: &Path,
    bytes: &'a [u8],
    generator: &MotionGenerator<'_>,
    model: &Path,
) -> Result<S2dDecoder<'a>, MotionGenerateError> {
    let decoder =
        S2dDecoder::from_bytes(bytes).map_err(|source| MotionGenerateError::NotADecoder {
            path: path.to_owned(),
            source,
        })?;
    let k = decoder.landmarks().iter().count();
    if 3 * k != generator.dims() {
        return Err(MotionGenerateError::DecoderLandmarks {
            decoder: path.to_owned(),
            model: model.to_owned(),
            landmarks: k,
            moved: generator.dims() / 3,
        });
    }
    Ok(decoder)
}

fn load<'a>(
    opts: &Generate,
    gen_bytes: &'a [u8],
    dec_bytes: &'a [u8],
) -> Result<Loaded<'a>, MotionGenerateError> {
    if !(opts.intensity.is_finite() && opts.intensity >= 0.0) {
        return Err(MotionGenerateError::Intensity(opts.intensity));
    }
    let (generator, labels) = open_generator(&opts.model, gen_bytes)?;
    let decoder = open_decoder(&opts.decoder, dec_bytes, &generator, &opts.model)?;
    let neutral = match &opts.neutral {
        Some(path) => {
            let neutral = Mesh::read(path)?;
            let n = decoder.vertex_count();
            if neutral.positions.len() != n {
                return Err(MotionGenerateError::NeutralVertices {
                    path: path.clone(),
                    found: neutral.positions.len(),
                    expected: n,
                });
            }
            neutral
        }
        None => crate::io::decoder_face::template(&opts.decoder, dec_bytes)?,
    };
    let neutral_lmk = decoder
        .landmarks()
        .iter()
        .flat_map(|v| neutral.positions[v as usize])
        .collect();
    let sequence =
        Sequence::new(generator, decoder).map_err(|source| MotionGenerateError::Mismatch {
            decoder: opts.decoder.clone(),
            model: opts.model.clone(),
            source,
        })?;
    Ok(Loaded {
        sequence,
        labels,
        neutral,
        neutral_lmk,
    })
}

impl Loaded<'_> {
    fn label(&self, label: &str, model: &Path) -> Result<usize, MotionGenerateError> {
        self.labels.iter().position(|l| l == label).ok_or_else(|| {
            MotionGenerateError::UnknownLabel {
                path: model.to_owned(),
                label: label.to_owned(),
                known: self.labels.clone(),
            }
        })
    }

    /// Buffers for [`Sequence::curve`] and [`Sequence::frame`] on this neutral.
    fn buffers(&self) -> Buffers {
        let s = &self.sequence;
        Buffers {
            curve: vec![0.0; s.curve_len()],
            input: vec![0.0; s.input_len()],
            neutral: self.neutral.positions.iter().flatten().copied().collect(),
            scratch: vec![0.0; s.scratch_len()],
            vertices: vec![0.0; s.vertex_len()],
        }
    }

    /// The dense face of frame `t` of the curve in `b` ([`Sequence::frame`]).
    fn mesh(&self, b: &mut Buffers, t: usize) -> Result<Vec<f32>, MotionGenerateError> {
        let mut buf = b.view();
        self.sequence
            .frame(t, &mut buf)
            .map_err(|source| MotionGenerateError::DecodeFrame { frame: t, source })?;
        Ok(buf.vertices.to_vec())
    }

    /// Writes `frame_NN.obj` for each mesh (numbered from `first`) and the strip of `strip`
    /// (indices into `meshes`) as `strip.png`.
    fn write(
        &self,
        out: &Path,
        meshes: &[Vec<f32>],
        first: usize,
        strip: &[usize],
    ) -> Result<(), MotionGenerateError> {
        crate::io::atomic::create_folder(out, "folder")?;
        for (i, m) in meshes.iter().enumerate() {
            self.neutral
                .with_positions(crate::io::mesh::points(m.clone()))
                .write(&out.join(format!("frame_{:02}.obj", first + i)))?;
        }
        let triangles = self.neutral.triangles();
        let view = View::front(240, 300);
        let pictures: Vec<Image> = strip
            .iter()
            .filter_map(|&i| meshes.get(i))
            .map(|m| render(&crate::io::mesh::points(m.clone()), &triangles, &[], &view))
            .collect();
        let path = out.join("strip.png");
        Image::hstack(&pictures)
            .save_png(&path)
            .map_err(|e| MotionGenerateError::Strip { path, source: e })
    }
}

/// `sinew generate`: the 30 frames of `label`'s motion from the seed. Returns the landmark curve
/// (`[(FRAMES + 1) × dims]`, frame 0 the neutral's landmarks).
pub fn generate(opts: &Generate, label: &str) -> Result<Vec<f32>, MotionGenerateError> {
    let gen_bytes = crate::io::container::read(&opts.model)?;
    let dec_bytes = crate::io::container::read(&opts.decoder)?;
    let l = load(opts, &gen_bytes, &dec_bytes)?;
    let label = l.label(label, &opts.model)?;
    let mut b = l.buffers();
    l.sequence
        .curve(label, opts.seed, opts.intensity, &mut b.view())
        .map_err(MotionGenerateError::Generating)?;
    let meshes = (1..=FRAMES)
        .map(|t| l.mesh(&mut b, t))
        .collect::<Result<Vec<_>, _>>()?;
    let strip: Vec<usize> = STRIP.iter().map(|&f| f - 1).collect();
    l.write(&opts.out, &meshes, 1, &strip)?;
    Ok(b.curve)
}

/// `sinew interpolate`: the motions of `from` and `to` (same seed) joined by the geodesic
/// (S2D §4.4); `steps` points along it, each decoded and shown at its apex (the last frame), as
/// the paper's interpolation between expression peaks. Writes `frame_NN.obj` (1 to `steps`) and
/// the strip of all of them. Returns each step's apex landmarks.
pub fn interpolate(
    opts: &Generate,
    from: &str,
    to: &str,
    steps: usize,
) -> Result<Vec<Vec<f32>>, MotionGenerateError> {
    if steps < 2 {
        return Err(MotionGenerateError::Steps);
    }
    let gen_bytes = crate::io::container::read(&opts.model)?;
    let dec_bytes = crate::io::container::read(&opts.decoder)?;
    let l = load(opts, &gen_bytes, &dec_bytes)?;
    let (a, b) = (l.label(from, &opts.model)?, l.label(to, &opts.model)?);
    let generator = l.sequence.generator();
    let mut scratch = vec![0.0f32; generator.scratch_len()];
    let mut q1 = vec![0.0f32; generator.motion_len()];
    let mut q2 = q1.clone();
    generator
        .motion(a, opts.seed, &mut scratch, &mut q1)
        .and_then(|()| generator.motion(b, opts.seed, &mut scratch, &mut q2))
        .map_err(|e| MotionGenerateError::Generating(e.into()))?;
    let d = generator.dims();
    let mut buffers = l.buffers();
    let mut apexes = Vec::with_capacity(steps);
    let mut meshes = Vec::with_capacity(steps);
    for k in 0..steps {
        let tau = k as f32 / (steps - 1) as f32;
        let q = srvf::interpolate(&q1, &q2, tau)?;
        // The length blends the two labels' mean lengths (for this motion) as the motion
        // blends them.
        let length = generator
            .mean_length(a, &q)
            .and_then(|la| Ok((1.0 - tau) * la + tau * generator.mean_length(b, &q)?))
            .map_err(MotionGenerateError::DecodeMotion)?;
        decode(
            &q,
            &l.neutral_lmk,
            opts.intensity * length,
            &mut buffers.curve,
        )
        .map_err(MotionGenerateError::DecodeMotion)?;
        meshes.push(l.mesh(&mut buffers, FRAMES)?);
        apexes.push(buffers.curve[FRAMES * d..].to_vec());
    }
    let strip: Vec<usize> = (0..steps).collect();
    l.write(&opts.out, &meshes, 1, &strip)?;
    Ok(apexes)
}

/// Owned buffers of a [`Sequence`] on one neutral.
struct Buffers {
    curve: Vec<f32>,
    input: Vec<f32>,
    neutral: Vec<f32>,
    scratch: Vec<f32>,
    vertices: Vec<f32>,
}

impl Buffers {
    fn view(&mut self) -> SequenceBuffers<'_> {
        SequenceBuffers {
            curve: &mut self.curve,
            input: &mut self.input,
            neutral: &self.neutral,
            scratch: &mut self.scratch,
            vertices: &mut self.vertices,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn golden(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data")
            .join(name)
    }

    #[test]
    fn a_missing_or_wrong_model_and_bad_settings_are_refused_by_variant() {
        let dir = tempfile::tempdir().unwrap();
        let opts = |model: PathBuf, intensity: f32| Generate {
            model,
            decoder: golden("s2d-ict.sinew"),
            neutral: Some(dir.path().join("neutral.obj")),
            seed: 0,
            intensity,
            out: dir.path().join("out"),
        };
        let missing = dir.path().join("missing.sinew");
        let e = generate(&opts(missing.clone(), 1.0), "smile").unwrap_err();
        assert!(
            matches!(&e, MotionGenerateError::Read(ContainerError::Read { path, .. }) if *path == missing),
            "{e:?}"
        );
        let e = generate(&opts(golden("s2d-ict.sinew"), 1.0), "smile").unwrap_err();
        assert!(
            matches!(&e, MotionGenerateError::NotAGenerator { path, .. } if path.ends_with("s2d-ict.sinew")),
            "{e:?}"
        );
        let e = generate(&opts(golden("motion-ict.sinew"), -1.0), "smile").unwrap_err();
        assert!(
            matches!(e, MotionGenerateError::Intensity(i) if i == -1.0),
            "{e:?}"
        );
        let e = interpolate(&opts(golden("motion-ict.sinew"), 1.0), "a", "b", 1).unwrap_err();
        assert!(matches!(e, MotionGenerateError::Steps), "{e:?}");
    }
}
