// S2D eq. 5 (decoding onto a neutral) and §4.4 (geodesic interpolation between two motions).
//! `sinew generate` and `sinew interpolate`: a baked Motion3DGAN generator and a baked S2D-Dec
//! through `sinew-core` turn a label and a seed into meshes of a face (S2D sections 3, 4.4).
//!
//! The generator makes the landmark curve on the neutral's own landmarks (the decoder's `s2d.lmk`
//! vertices), and for each frame the decoder turns the landmark displacement into a dense one,
//! added to the neutral. Frames are written as `frame_NN.obj` (1 to 30; frame 0 would be the
//! neutral itself) with the neutral's polygons, and a PNG strip of chosen frames beside them.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use sinew_core::motion::MotionGenerator;
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};
use sinew_core::srvf::{FRAMES, decode};

use super::srvf;
use crate::figures::render::{Image, View, render};
use crate::io::mesh::Mesh;

/// What to generate, and where.
#[derive(Clone, Debug)]
pub struct Generate {
    /// The baked generator.
    pub model: PathBuf,
    /// The baked S2D decoder.
    pub decoder: PathBuf,
    /// The neutral face (the decoder's topology).
    pub neutral: PathBuf,
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
) -> Result<(MotionGenerator<'a>, Vec<String>)> {
    let generator = MotionGenerator::from_bytes(bytes).map_err(|e| {
        anyhow!(
            "{}: not a Motion3DGAN generator (from `sinew train motion`): {e}",
            path.display()
        )
    })?;
    let labels: Vec<String> = sinew_core::SinewFile::from_bytes(bytes)
        .ok()
        .and_then(|f| f.metadata().get("labels").map(str::to_owned))
        .map(|l| l.split(',').map(str::to_owned).collect())
        .unwrap_or_default();
    if labels.len() != sinew_core::motion::LABELS {
        bail!(
            "{}: the generator lists {} labels, {} expected",
            path.display(),
            labels.len(),
            sinew_core::motion::LABELS
        );
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
) -> Result<S2dDecoder<'a>> {
    let decoder = S2dDecoder::from_bytes(bytes)
        .map_err(|e| anyhow!("{}: not an S2D decoder: {e}", path.display()))?;
    let k = decoder.landmarks().iter().count();
    if 3 * k != generator.dims() {
        bail!(
            "{}: the decoder reads {k} landmarks, but the generator {} moves {}",
            path.display(),
            model.display(),
            generator.dims() / 3
        );
    }
    Ok(decoder)
}

fn load<'a>(opts: &Generate, gen_bytes: &'a [u8], dec_bytes: &'a [u8]) -> Result<Loaded<'a>> {
    if !(opts.intensity.is_finite() && opts.intensity >= 0.0) {
        bail!(
            "--intensity {} must be a finite number of at least 0 (1 is the training motions' \
             mean)",
            opts.intensity
        );
    }
    let (generator, labels) = open_generator(&opts.model, gen_bytes)?;
    let decoder = open_decoder(&opts.decoder, dec_bytes, &generator, &opts.model)?;
    let neutral = Mesh::read(&opts.neutral)?;
    let n = decoder.vertex_count();
    if neutral.positions.len() != n {
        bail!(
            "{}: {} vertices, the decoder's template has {n} (the neutral must share its \
             topology)",
            opts.neutral.display(),
            neutral.positions.len()
        );
    }
    let neutral_lmk = decoder
        .landmarks()
        .iter()
        .flat_map(|v| neutral.positions[v as usize])
        .collect();
    let sequence = Sequence::new(generator, decoder).map_err(|e| {
        anyhow!(
            "{}: does not fit the generator {}: {e}",
            opts.decoder.display(),
            opts.model.display()
        )
    })?;
    Ok(Loaded {
        sequence,
        labels,
        neutral,
        neutral_lmk,
    })
}

impl Loaded<'_> {
    fn label(&self, label: &str, model: &Path) -> Result<usize> {
        self.labels.iter().position(|l| l == label).ok_or_else(|| {
            anyhow!(
                "{}: unknown label {label:?}; the generator knows {}",
                model.display(),
                self.labels.join(", ")
            )
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
    fn mesh(&self, b: &mut Buffers, t: usize) -> Result<Vec<f32>> {
        let mut buf = b.view();
        self.sequence
            .frame(t, &mut buf)
            .map_err(|e| anyhow!("decoding frame {t}: {e}"))?;
        Ok(buf.vertices.to_vec())
    }

    /// Writes `frame_NN.obj` for each mesh (numbered from `first`) and the strip of `strip`
    /// (indices into `meshes`) as `strip.png`.
    fn write(&self, out: &Path, meshes: &[Vec<f32>], first: usize, strip: &[usize]) -> Result<()> {
        std::fs::create_dir_all(out)
            .with_context(|| format!("{}: cannot create folder", out.display()))?;
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
        Image::hstack(&pictures).write_png(&out.join("strip.png"))
    }
}

/// `sinew generate`: the 30 frames of `label`'s motion from the seed. Returns the landmark curve
/// (`[(FRAMES + 1) × dims]`, frame 0 the neutral's landmarks).
pub fn generate(opts: &Generate, label: &str) -> Result<Vec<f32>> {
    let gen_bytes = crate::io::container::read(&opts.model)?;
    let dec_bytes = crate::io::container::read(&opts.decoder)?;
    let l = load(opts, &gen_bytes, &dec_bytes)?;
    let label = l.label(label, &opts.model)?;
    let mut b = l.buffers();
    l.sequence
        .curve(label, opts.seed, opts.intensity, &mut b.view())
        .map_err(|e| anyhow!("generating: {e}"))?;
    let meshes = (1..=FRAMES)
        .map(|t| l.mesh(&mut b, t))
        .collect::<Result<Vec<_>>>()?;
    let strip: Vec<usize> = STRIP.iter().map(|&f| f - 1).collect();
    l.write(&opts.out, &meshes, 1, &strip)?;
    Ok(b.curve)
}

/// `sinew interpolate`: the motions of `from` and `to` (same seed) joined by the geodesic
/// (S2D §4.4); `steps` points along it, each decoded and shown at its apex (the last frame), as
/// the paper's interpolation between expression peaks. Writes `frame_NN.obj` (1 to `steps`) and
/// the strip of all of them. Returns each step's apex landmarks.
pub fn interpolate(opts: &Generate, from: &str, to: &str, steps: usize) -> Result<Vec<Vec<f32>>> {
    if steps < 2 {
        bail!("--steps must be at least 2 (the two ends)");
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
        .map_err(|e| anyhow!("generating: {e}"))?;
    let d = generator.dims();
    let mut buffers = l.buffers();
    let mut apexes = Vec::with_capacity(steps);
    let mut meshes = Vec::with_capacity(steps);
    for k in 0..steps {
        let tau = k as f32 / (steps - 1) as f32;
        let q = srvf::interpolate(&q1, &q2, tau)?;
        // The length blends the two labels' mean lengths as the motion blends them.
        let length = (1.0 - tau) * generator.length(a) + tau * generator.length(b);
        decode(
            &q,
            &l.neutral_lmk,
            opts.intensity * length,
            &mut buffers.curve,
        )
        .map_err(|e| anyhow!("decoding the motion: {e}"))?;
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
