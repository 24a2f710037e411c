//! S2D's applications (paper section 4.4) through the core's decoder: expression neutralisation
//! (`sinew s2d neutralize`) and expression transfer of a landmark motion onto another identity
//! (`sinew s2d transfer`); a decoder's own face (`sinew s2d template`), and the triangles of that
//! face added to a decoder baked without them (`sinew s2d add-triangles`). Every mesh must have the decoder's template topology; the landmarks
//! are the decoder's own (`s2d.lmk`).

use std::path::{Path, PathBuf};

use sinew_core::error::FormatError;
use sinew_core::s2d::S2dDecoder;

use crate::io::atomic::AtomicWriteError;
use crate::io::container::{ContainerError, SinewWriter, WriterError};
use crate::io::mesh::{Mesh, MeshError};

/// A neutralisation or transfer that was refused or failed; each names the file concerned.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ApplyError {
    /// The model file cannot be read as a `.sinew` file (the error names it).
    #[error(transparent)]
    Read(#[from] ContainerError),
    /// A model file that is not an S2D decoder.
    #[error("{}: not an S2D decoder", path.display())]
    NotADecoder {
        /// The model file.
        path: PathBuf,
        /// What the core said.
        #[source]
        source: FormatError,
    },
    /// A mesh that cannot be read or written (the error names the file).
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// A mesh of another vertex count than the decoder's template.
    #[error(
        "{}: {found} vertices, the decoder's template has {expected} (meshes must share its \
         topology)",
        path.display()
    )]
    VertexCount {
        /// The mesh file.
        path: PathBuf,
        /// Its vertices.
        found: usize,
        /// The template's.
        expected: usize,
    },
    /// A mesh whose landmark motion the decoder refuses.
    #[error("{}", path.display())]
    Decode {
        /// The mesh file.
        path: PathBuf,
        /// What the core refused.
        #[source]
        source: DecodeError,
    },
    /// A transfer without source frames.
    #[error("no source frames")]
    NoFrames,
    /// The output folder cannot be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// A folder that cannot be listed.
    #[error("{}: cannot list", path.display())]
    List {
        /// The folder.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// A folder without meshes.
    #[error("{}: no meshes (.obj, .obj.gz, .ply)", path.display())]
    NoMeshes {
        /// The folder.
        path: PathBuf,
    },
    /// The decoder's template face cannot be made (the error names the file and the cure).
    #[error(transparent)]
    Template(#[from] crate::io::decoder_face::DecoderFaceError),
    /// A pairs folder that cannot be read (the error names the file).
    #[error(transparent)]
    Pairs(#[from] crate::io::dataset::DataSetError),
    /// A decoder that carries its template's triangles already.
    #[error("{}: the decoder carries its template's triangles already", path.display())]
    HasTriangles {
        /// The decoder file.
        path: PathBuf,
    },
    /// A decoder that cannot be laid out again with its triangles.
    #[error(transparent)]
    Layout(#[from] WriterError),
    /// A decoder that cannot be written (the error names the file).
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}

/// `sinew s2d template`: the face a decoder decodes onto by default, its template neutral with
/// its triangles, written to `out` (atomically). The triangles come from the decoder
/// (`s2d.h0.tri`); a decoder baked without them takes them from `pairs`, the pairs folder it was
/// trained on, whose template must have the decoder's vertices bit for bit. With the template's
/// triangles in the decoder, `pairs` is not read.
pub fn write_template(model: &Path, pairs: Option<&Path>, out: &Path) -> Result<Mesh, ApplyError> {
    use crate::io::decoder_face::{self, DecoderFaceError};
    let bytes = crate::io::container::read(model)?;
    let face = match (decoder_face::template(model, &bytes), pairs) {
        (Err(DecoderFaceError::NoTriangles { .. }), Some(dir)) => {
            let set = super::data::PairSet::read(dir)?;
            let file = dir.join(super::data::DATA_FILE);
            decoder_face::template_like(model, &bytes, &file, &set.template)?
        }
        (face, _) => face?,
    };
    face.write(out)?;
    Ok(face)
}

/// `sinew s2d add-triangles`: the decoder at `model`, baked without its template's triangles
/// (from 2026-11-23 to 2026-11-26), written to `out` with them (`s2d.h0.tri`), taken from
/// `pairs`, the pairs folder it was trained on, whose template must have the decoder's vertices
/// bit for bit. Everything else is kept as it was ([`with_triangles`]), so the new file decodes
/// to the same bits; it then decodes onto its own face without a `--neutral`. Returns the face.
pub fn add_triangles(model: &Path, pairs: &Path, out: &Path) -> Result<Mesh, ApplyError> {
    use crate::io::decoder_face::{self, DecoderFaceError};
    let bytes = crate::io::container::read(model)?;
    match decoder_face::template(model, &bytes) {
        Err(DecoderFaceError::NoTriangles { .. }) => {}
        Ok(_) => {
            return Err(ApplyError::HasTriangles {
                path: model.to_owned(),
            });
        }
        Err(e) => return Err(e.into()),
    }
    let set = super::data::PairSet::read(pairs)?;
    let file = pairs.join(super::data::DATA_FILE);
    let face = decoder_face::template_like(model, &bytes, &file, &set.template)?;
    let with = with_triangles(model, &bytes, &face)?;
    crate::io::atomic::write(out, &with)?;
    Ok(face)
}

/// The decoder in `bytes` (read from `model`) with `face`'s triangles as its template's
/// (`s2d.h0.tri`, after every section it has): the kind, flags, metadata and every other section
/// as they were, so that it decodes to the same bits. `face` must be the decoder's template
/// (`io::decoder_face::template_like` checks it).
pub fn with_triangles(model: &Path, bytes: &[u8], face: &Mesh) -> Result<Vec<u8>, ApplyError> {
    let not_a_decoder = |source| ApplyError::NotADecoder {
        path: model.to_owned(),
        source,
    };
    S2dDecoder::from_bytes(bytes).map_err(not_a_decoder)?;
    let file = sinew_core::SinewFile::from_bytes(bytes).map_err(not_a_decoder)?;
    let mut w = SinewWriter::from_file(&file)?;
    let triangles = face.triangles();
    let flat: Vec<u32> = triangles.iter().flatten().copied().collect();
    w.u32s(
        crate::io::decoder_face::TRIANGLES,
        &[triangles.len(), 3],
        &flat,
    )?;
    let with = w.to_bytes()?;
    // The core must accept what the host writes.
    S2dDecoder::from_bytes(&with).map_err(not_a_decoder)?;
    Ok(with)
}

/// The step of decoding that the core refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum DecodeError {
    /// The landmarks cannot be the decoder's input.
    #[error("landmarks")]
    Landmarks(#[source] sinew_core::EvalError),
    /// The input cannot be decoded.
    #[error("decoding")]
    Decoding(#[source] sinew_core::EvalError),
}

/// A loaded decoder with its buffers.
struct Decoder<'a> {
    core: S2dDecoder<'a>,
    scratch: Vec<f32>,
}

impl<'a> Decoder<'a> {
    fn new(bytes: &'a [u8], path: &Path) -> Result<Self, ApplyError> {
        let core = S2dDecoder::from_bytes(bytes).map_err(|source| ApplyError::NotADecoder {
            path: path.to_owned(),
            source,
        })?;
        let scratch = vec![0.0; core.scratch_len()];
        Ok(Self { core, scratch })
    }

    /// Checks that `mesh` (read from `path`) has the template's vertex count.
    fn check(&self, mesh: &Mesh, path: &Path) -> Result<(), ApplyError> {
        let n = self.core.vertex_count();
        if mesh.positions.len() != n {
            return Err(ApplyError::VertexCount {
                path: path.to_owned(),
                found: mesh.positions.len(),
                expected: n,
            });
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
    fn apply(&mut self, base: &[f32], from: &[f32], to: &[f32]) -> Result<Vec<f32>, DecodeError> {
        let mut input = vec![0.0; from.len()];
        self.core
            .input(from, to, &mut input)
            .map_err(DecodeError::Landmarks)?;
        let mut out = vec![0.0; base.len()];
        self.core
            .decode_onto(base, &input, &mut self.scratch, &mut out)
            .map_err(DecodeError::Decoding)?;
        Ok(out)
    }
}

fn flat(mesh: &Mesh) -> Vec<f32> {
    mesh.positions.iter().flatten().copied().collect()
}

/// Expression neutralisation: the decoder is asked for the displacement that takes the
/// expressive face's landmarks to the template's neutral landmarks, and that displacement is
/// added to the expressive face. Writes the result with the input's polygons and UVs.
pub fn neutralize(model: &Path, expressive: &Path, out: &Path) -> Result<(), ApplyError> {
    let bytes = crate::io::container::read(model)?;
    let mut dec = Decoder::new(&bytes, model)?;
    let mesh = Mesh::read(expressive)?;
    dec.check(&mesh, expressive)?;
    let positions = flat(&mesh);
    let neutral: Vec<f32> = dec.core.neutral().iter().collect();
    let from = dec.landmarks(&positions);
    let to = dec.landmarks(&neutral);
    let result = dec
        .apply(&positions, &from, &to)
        .map_err(|source| ApplyError::Decode {
            path: expressive.to_owned(),
            source,
        })?;
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
) -> Result<usize, ApplyError> {
    if frames.is_empty() {
        return Err(ApplyError::NoFrames);
    }
    let bytes = crate::io::container::read(model)?;
    let mut dec = Decoder::new(&bytes, model)?;
    let src = Mesh::read(source_neutral)?;
    dec.check(&src, source_neutral)?;
    let tgt = Mesh::read(target)?;
    dec.check(&tgt, target)?;
    let from = dec.landmarks(&flat(&src));
    let base = flat(&tgt);
    crate::io::atomic::create_folder(out, "folder")?;
    for (i, path) in frames.iter().enumerate() {
        let frame = Mesh::read(path)?;
        dec.check(&frame, path)?;
        let to = dec.landmarks(&flat(&frame));
        let result = dec
            .apply(&base, &from, &to)
            .map_err(|source| ApplyError::Decode {
                path: path.clone(),
                source,
            })?;
        tgt.with_positions(crate::io::mesh::points(result))
            .write(&out.join(format!("frame_{i:05}.obj")))?;
    }
    Ok(frames.len())
}

/// The meshes (`.obj`, `.obj.gz`, `.ply`) of a folder in name order, or the one file given.
pub fn mesh_files(path: &Path) -> Result<Vec<PathBuf>, ApplyError> {
    if path.is_file() {
        return Ok(vec![path.to_owned()]);
    }
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .map_err(|source| ApplyError::List {
            path: path.to_owned(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let n = p.to_string_lossy();
            n.ends_with(".obj") || n.ends_with(".obj.gz") || n.ends_with(".ply")
        })
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(ApplyError::NoMeshes {
            path: path.to_owned(),
        });
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
        let e = transfer(&model, &src, &files, &small, &out).unwrap_err();
        assert!(
            matches!(&e, ApplyError::VertexCount { path, found: 4, .. } if *path == small),
            "{e:?}"
        );
        // A missing model, an empty folder and a missing one are named.
        let missing = dir.path().join("missing.sinew");
        let e = neutralize(&missing, &src, &dir.path().join("n.obj")).unwrap_err();
        assert!(
            matches!(&e, ApplyError::Read(ContainerError::Read { path, .. }) if *path == missing),
            "{e:?}"
        );
        let empty = dir.path().join("empty");
        std::fs::create_dir_all(&empty).unwrap();
        let e = mesh_files(&empty).unwrap_err();
        assert!(
            matches!(&e, ApplyError::NoMeshes { path } if *path == empty),
            "{e:?}"
        );
        let e = mesh_files(&dir.path().join("nowhere")).unwrap_err();
        assert!(matches!(e, ApplyError::List { .. }), "{e:?}");
        assert!(matches!(
            transfer(&model, &src, &[], &tgt, &out),
            Err(ApplyError::NoFrames)
        ));
    }
}
