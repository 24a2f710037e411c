//! The face a baked S2D decoder decodes onto when the caller gives none: the decoder's template
//! neutral (`s2d.h0.pos`) with the template's triangles (`s2d.h0.tri`), read from the decoder's
//! file (docs/FORMAT.md, "S2D decoder").
//!
//! Decoders baked from 2026-11-23 to 2026-11-26 carry no triangles (only what decoding reads);
//! [`template`] says so with [`DecoderFaceError::NoTriangles`], and [`template_like`] takes the
//! triangles of a mesh with the same vertices instead (the template of the pairs the decoder was
//! trained on), checking that the vertices are the decoder's, bit for bit.

use std::path::{Path, PathBuf};

use sinew_core::{ArtifactKind, FormatError, SinewFile};

use super::mesh::Mesh;

/// The template's positions section of a baked decoder.
pub const POSITIONS: &str = "s2d.h0.pos";
/// The template's triangles section of a baked decoder.
pub const TRIANGLES: &str = "s2d.h0.tri";

/// Why a decoder's template face cannot be made; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DecoderFaceError {
    /// Bytes that are not a baked S2D decoder.
    #[error("{}: not an S2D decoder (from `sinew train s2d`)", path.display())]
    NotADecoder {
        /// The decoder file.
        path: PathBuf,
        /// What the core said, if it was the core.
        #[source]
        source: Option<FormatError>,
    },
    /// A decoder baked without its template's triangles.
    #[error(
        "{}: the decoder carries no template triangles ({TRIANGLES}; decoders baked from \
         2026-11-23 to 2026-11-26 lack them): make its face with `sinew s2d template --model {} \
         --pairs PAIRS --out face.obj`, PAIRS the pairs folder it was trained on, and pass \
         --neutral face.obj",
        path.display(),
        path.display()
    )]
    NoTriangles {
        /// The decoder file.
        path: PathBuf,
    },
    /// A triangles section that is not `[T, 3]` vertex indices below the template's count.
    #[error("{}: {TRIANGLES} is not [T, 3] indices below {vertices}", path.display())]
    BadTriangles {
        /// The decoder file.
        path: PathBuf,
        /// The template's vertices.
        vertices: usize,
    },
    /// A mesh whose vertices are not the decoder's template's.
    #[error(
        "{}: its {found} vertices are not the template of the decoder {} ({expected} vertices); \
         give the pairs the decoder was trained on",
        like.display(),
        path.display()
    )]
    NotTheTemplate {
        /// The mesh the triangles were to come from.
        like: PathBuf,
        /// The decoder file.
        path: PathBuf,
        /// Its vertices.
        found: usize,
        /// The template's.
        expected: usize,
    },
}

/// The template's positions of the decoder in `bytes` (read from `path`).
fn positions(path: &Path, file: &SinewFile<'_>) -> Result<Vec<[f32; 3]>, DecoderFaceError> {
    let not = |source| DecoderFaceError::NotADecoder {
        path: path.to_owned(),
        source: Some(source),
    };
    let (dims, rank) = file.dims_of(POSITIONS).map_err(not)?;
    if rank != 2 || dims[1] != 3 {
        return Err(DecoderFaceError::NotADecoder {
            path: path.to_owned(),
            source: None,
        });
    }
    let values: Vec<f32> = file
        .f32_tensor(POSITIONS, &dims[..2])
        .map_err(not)?
        .iter()
        .collect();
    Ok(values.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect())
}

fn open<'a>(path: &Path, bytes: &'a [u8]) -> Result<SinewFile<'a>, DecoderFaceError> {
    let not = |source| DecoderFaceError::NotADecoder {
        path: path.to_owned(),
        source: Some(source),
    };
    // The core's decoder validates everything decoding reads; the face needs its positions.
    sinew_core::s2d::S2dDecoder::from_bytes(bytes).map_err(not)?;
    SinewFile::from_bytes_of_kind(bytes, ArtifactKind::S2dDecoder).map_err(not)
}

/// The decoder's template face (the bytes of the decoder file `path`): its neutral positions and
/// triangles. A decoder without triangles is refused with [`DecoderFaceError::NoTriangles`].
pub fn template(path: &Path, bytes: &[u8]) -> Result<Mesh, DecoderFaceError> {
    let file = open(path, bytes)?;
    let positions = positions(path, &file)?;
    let n = positions.len();
    let bad = || DecoderFaceError::BadTriangles {
        path: path.to_owned(),
        vertices: n,
    };
    if file.section(TRIANGLES).is_none() {
        return Err(DecoderFaceError::NoTriangles {
            path: path.to_owned(),
        });
    }
    let (dims, rank) = file.dims_of(TRIANGLES).map_err(|_| bad())?;
    if rank != 2 || dims[1] != 3 {
        return Err(bad());
    }
    let tri: Vec<u32> = file
        .u32_tensor(TRIANGLES, &dims[..2])
        .map_err(|_| bad())?
        .iter()
        .collect();
    if tri.iter().any(|&i| i as usize >= n) {
        return Err(bad());
    }
    Ok(Mesh::new(
        positions,
        tri.chunks_exact(3).map(<[u32]>::to_vec).collect(),
    ))
}

/// The decoder's template face with the triangles of `like` (read from `like_path`), whose
/// vertices must be the template's, bit for bit: for decoders baked without triangles, `like`
/// the template of the pairs it was trained on.
pub fn template_like(
    path: &Path,
    bytes: &[u8],
    like_path: &Path,
    like: &Mesh,
) -> Result<Mesh, DecoderFaceError> {
    let file = open(path, bytes)?;
    let positions = positions(path, &file)?;
    let same = like.positions.len() == positions.len()
        && like
            .positions
            .iter()
            .flatten()
            .zip(positions.iter().flatten())
            .all(|(a, b)| a.to_bits() == b.to_bits());
    if !same {
        return Err(DecoderFaceError::NotTheTemplate {
            like: like_path.to_owned(),
            path: path.to_owned(),
            found: like.positions.len(),
            expected: positions.len(),
        });
    }
    Ok(Mesh::new(
        positions,
        like.triangles().iter().map(|t| t.to_vec()).collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn golden() -> (PathBuf, Vec<u8>) {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/s2d-ict.sinew");
        let bytes = std::fs::read(&path).unwrap();
        (path, bytes)
    }

    /// The golden decoder as decoders were baked before 2026-11-27: without its triangles.
    fn without_triangles() -> (PathBuf, Vec<u8>) {
        let (path, bytes) = golden();
        let file = SinewFile::from_bytes(&bytes).unwrap();
        let mut w = crate::io::container::SinewWriter::from_file(&file).unwrap();
        assert_eq!(w.remove_prefixed(TRIANGLES), 1);
        (path, w.to_bytes().unwrap())
    }

    #[test]
    fn the_golden_decoders_face_is_its_template_with_its_triangles() {
        let (path, bytes) = golden();
        let face = template(&path, &bytes).unwrap();
        let file = SinewFile::from_bytes(&bytes).unwrap();
        assert_eq!(face.positions, positions(&path, &file).unwrap());
        assert_eq!(face.positions.len(), 1177);
        assert_eq!(face.polygons.len(), 2104);
    }

    #[test]
    fn missing_triangles_other_vertices_and_other_files_are_refused_by_variant() {
        let (path, bytes) = without_triangles();
        let e = template(&path, &bytes).unwrap_err();
        assert!(
            matches!(&e, DecoderFaceError::NoTriangles { path: p } if *p == path),
            "{e}"
        );
        // The template's own positions with any triangles are accepted; others are not.
        let file = SinewFile::from_bytes(&bytes).unwrap();
        let own = positions(&path, &file).unwrap();
        let like = Mesh::new(own.clone(), vec![vec![0, 1, 2]]);
        let face = template_like(&path, &bytes, Path::new("like.obj"), &like).unwrap();
        assert_eq!(face.positions, own);
        assert_eq!(face.polygons, vec![vec![0, 1, 2]]);
        let mut moved = own;
        moved[5][1] += 1e-3;
        let e = template_like(
            &path,
            &bytes,
            Path::new("like.obj"),
            &Mesh::new(moved, vec![]),
        )
        .unwrap_err();
        assert!(
            matches!(&e, DecoderFaceError::NotTheTemplate { like, expected: 1177, .. } if like.ends_with("like.obj")),
            "{e}"
        );
        let generator =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/motion-ict.sinew");
        let other = std::fs::read(&generator).unwrap();
        let e = template(&generator, &other).unwrap_err();
        assert!(matches!(e, DecoderFaceError::NotADecoder { .. }), "{e}");
    }
}
