//! S2D's applications (paper section 4.4) through the core's decoder: expression neutralisation
//! (`sinew s2d neutralize`) and expression transfer of a landmark motion onto another identity
//! (`sinew s2d transfer`). Every mesh must have the decoder's template topology; the landmarks
//! are the decoder's own (`s2d.lmk`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, anyhow, bail};
use sinew_core::s2d::S2dDecoder;

use crate::io::mesh::Mesh;

/// A loaded decoder with its buffers.
struct Decoder<'a> {
    core: S2dDecoder<'a>,
    scratch: Vec<f32>,
}

impl<'a> Decoder<'a> {
    fn new(bytes: &'a [u8], path: &Path) -> Result<Self> {
        let core = S2dDecoder::from_bytes(bytes)
            .map_err(|e| anyhow!("{}: not an S2D decoder: {e}", path.display()))?;
        let scratch = vec![0.0; core.scratch_len()];
        Ok(Self { core, scratch })
    }

    /// Checks that `mesh` (read from `path`) has the template's vertex count.
    fn check(&self, mesh: &Mesh, path: &Path) -> Result<()> {
        let n = self.core.vertex_count();
        if mesh.positions.len() != n {
            bail!(
                "{}: {} vertices, the decoder's template has {n} (meshes must share its topology)",
                path.display(),
                mesh.positions.len()
            );
        }
        Ok(())
    }

    /// The decoder's landmarks on `positions`, `[K · 3]`.
    fn landmarks(&self, positions: &[f32]) -> Vec<f32> {
        self.core
            .landmarks()
            .iter()
            .flat_map(|v| {
                let i = 3 * v as usize;
                [positions[i], positions[i + 1], positions[i + 2]]
            })
            .collect()
    }

    /// `base + decode(input(from, to))` for landmark sets `from`, `to`, the input normalised as
    /// the decoder was trained ([`S2dDecoder::input`]).
    fn apply(&mut self, base: &[f32], from: &[f32], to: &[f32]) -> Result<Vec<f32>> {
        let mut input = vec![0.0; from.len()];
        self.core
            .input(from, to, &mut input)
            .map_err(|e| anyhow!("landmarks: {e}"))?;
        let mut out = vec![0.0; base.len()];
        self.core
            .decode_onto(base, &input, &mut self.scratch, &mut out)
            .map_err(|e| anyhow!("decoding: {e}"))?;
        Ok(out)
    }
}

fn flat(mesh: &Mesh) -> Vec<f32> {
    mesh.positions.iter().flatten().copied().collect()
}

/// Expression neutralisation: the decoder is asked for the displacement that takes the
/// expressive face's landmarks to the template's neutral landmarks, and that displacement is
/// added to the expressive face. Writes the result with the input's polygons and UVs.
pub fn neutralize(model: &Path, expressive: &Path, out: &Path) -> Result<()> {
    let bytes = crate::io::container::read(model)?;
    let mut dec = Decoder::new(&bytes, model)?;
    let mesh = Mesh::read(expressive)?;
    dec.check(&mesh, expressive)?;
    let positions = flat(&mesh);
    let neutral: Vec<f32> = dec.core.neutral().iter().collect();
    let from = dec.landmarks(&positions);
    let to = dec.landmarks(&neutral);
    let result = dec.apply(&positions, &from, &to)?;
    mesh.with_positions(crate::io::mesh::points(result))
        .write(out)?;
    Ok(())
}

/// Expression transfer: each frame's landmark motion relative to the source neutral, decoded onto
/// the target neutral. `frames` are the source meshes in order; writes `frame_NNNNN.obj` per frame
/// into `out` with the target's polygons and UVs. Returns the number of frames.
pub fn transfer(
    model: &Path,
    source_neutral: &Path,
    frames: &[PathBuf],
    target: &Path,
    out: &Path,
) -> Result<usize> {
    if frames.is_empty() {
        bail!("no source frames");
    }
    let bytes = crate::io::container::read(model)?;
    let mut dec = Decoder::new(&bytes, model)?;
    let src = Mesh::read(source_neutral)?;
    dec.check(&src, source_neutral)?;
    let tgt = Mesh::read(target)?;
    dec.check(&tgt, target)?;
    let from = dec.landmarks(&flat(&src));
    let base = flat(&tgt);
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    for (i, path) in frames.iter().enumerate() {
        let frame = Mesh::read(path)?;
        dec.check(&frame, path)?;
        let to = dec.landmarks(&flat(&frame));
        let result = dec
            .apply(&base, &from, &to)
            .with_context(|| format!("{}", path.display()))?;
        tgt.with_positions(crate::io::mesh::points(result))
            .write(&out.join(format!("frame_{i:05}.obj")))?;
    }
    Ok(frames.len())
}

/// The meshes (`.obj`, `.obj.gz`, `.ply`) of a folder in name order, or the one file given.
pub fn mesh_files(path: &Path) -> Result<Vec<PathBuf>> {
    if path.is_file() {
        return Ok(vec![path.to_owned()]);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .with_context(|| format!("{}: cannot list", path.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let n = p.to_string_lossy();
            n.ends_with(".obj") || n.ends_with(".obj.gz") || n.ends_with(".ply")
        })
        .collect();
    files.sort();
    if files.is_empty() {
        bail!("{}: no meshes (.obj, .obj.gz, .ply)", path.display());
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::s2d::synthetic;

    /// A decoder on a synthetic 8-vertex template with two landmarks, and a mesh of it.
    fn fixture(dir: &Path) -> (PathBuf, Mesh) {
        let (h, bytes) = synthetic::tiny_baked_decoder();
        let model = dir.join("dec.sinew");
        std::fs::write(&model, bytes).unwrap();
        let positions = h.levels[0].positions.clone();
        let polygons = h.levels[0].triangles.iter().map(|t| t.to_vec()).collect();
        let mesh = Mesh::new(positions, polygons);
        (model, mesh)
    }

    #[test]
    fn neutralizing_the_neutral_changes_it_by_the_decoder_at_zero_input_only() {
        let dir = tempfile::tempdir().unwrap();
        let (model, mesh) = fixture(dir.path());
        let input = dir.path().join("neutral.obj");
        mesh.write(&input).unwrap();
        let out = dir.path().join("out.obj");
        neutralize(&model, &input, &out).unwrap();
        let got = Mesh::read(&out).unwrap();
        // Zero landmark motion: the output is the neutral plus the decoder's response to a zero
        // input, exactly what the core decodes for zeros.
        let bytes = std::fs::read(&model).unwrap();
        let core = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).unwrap();
        let mut d = vec![0.0; 3 * core.vertex_count()];
        let mut s = vec![0.0; core.scratch_len()];
        core.displacements(&[0.0; 6], &mut s, &mut d).unwrap();
        for (v, (g, n)) in got.positions.iter().zip(&mesh.positions).enumerate() {
            for k in 0..3 {
                assert!((g[k] - (n[k] + d[3 * v + k])).abs() < 1e-6);
            }
        }
        assert_eq!(got.polygons, mesh.polygons);
    }

    #[test]
    fn transfer_writes_a_frame_per_source_mesh_and_names_bad_inputs() {
        let dir = tempfile::tempdir().unwrap();
        let (model, mesh) = fixture(dir.path());
        let src = dir.path().join("src.obj");
        mesh.write(&src).unwrap();
        let frames_dir = dir.path().join("frames");
        std::fs::create_dir_all(&frames_dir).unwrap();
        for f in 0..3 {
            let moved: Vec<[f32; 3]> = mesh
                .positions
                .iter()
                .map(|p| [p[0], p[1] + 0.01 * f as f32 * p[0], p[2]])
                .collect();
            mesh.with_positions(moved)
                .write(&frames_dir.join(format!("f{f}.obj")))
                .unwrap();
        }
        let target: Vec<[f32; 3]> = mesh
            .positions
            .iter()
            .map(|p| [p[0] * 1.1, p[1], p[2]])
            .collect();
        let tgt = dir.path().join("tgt.obj");
        mesh.with_positions(target).write(&tgt).unwrap();
        let out = dir.path().join("out");
        let files = mesh_files(&frames_dir).unwrap();
        assert_eq!(transfer(&model, &src, &files, &tgt, &out).unwrap(), 3);
        let f0 = Mesh::read(&out.join("frame_00000.obj")).unwrap();
        let f2 = Mesh::read(&out.join("frame_00002.obj")).unwrap();
        assert_ne!(
            f0.positions, f2.positions,
            "different motion, different frames"
        );
        // A mesh of another topology is named.
        let small = dir.path().join("small.obj");
        Mesh::new(mesh.positions[..4].to_vec(), vec![vec![0, 1, 2]])
            .write(&small)
            .unwrap();
        let e = transfer(&model, &src, &files, &small, &out)
            .unwrap_err()
            .to_string();
        assert!(e.contains("small.obj") && e.contains("4 vertices"), "{e}");
    }
}
