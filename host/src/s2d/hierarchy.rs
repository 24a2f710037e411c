//! The S2D mesh hierarchy (S2D section 3.2 and appendix; CoMA-style sampling): quadric-error
//! decimation by half-edge collapse, the 0/1 down-sampling D, the barycentric up-sampling U and
//! the dummy-vertex padding of `shared/notes/s2d-reference.md`.
//!
//! Decimation (Garland and Heckbert 1997) collapses a vertex `u` onto a neighbour `v` that stays
//! where it is, so every coarse vertex *is* a fine vertex and D is an exact selection. Each level
//! is decimated from the previous level's mesh with fresh quadrics, as the reference does.
//!
//! Determinism: the priority queue orders candidates by `(cost, from, to)` with `f64::total_cmp`,
//! every adjacency list is a sorted `Vec`, and no hash map is iterated, so the same mesh and
//! factors give the same hierarchy byte for byte.

use std::path::{Path, PathBuf};

use sinew_core::SinewFile;
use sinew_core::format::ArtifactKind;

use super::{Hierarchy, Level, Sampling, spirals};
use crate::geometry::qem::decimate;
use crate::geometry::surface::closest_point_on_triangle;
use crate::geometry::topology::{fan, incident_triangles};
use crate::geometry::vec3::{cross, norm2, sub, to64};
use crate::io::container::{SinewWriter, WriterError};
use crate::io::mesh::Mesh;

mod error;
pub use error::{BuildError, HierarchyError, SectionError, SurfaceError};

/// The reference's decimation factors: four levels, each a quarter of the one before.
pub const DEFAULT_FACTORS: [usize; 4] = [4, 4, 4, 4];

/// Version of the algorithm, part of the cache key: bump it whenever the output may change.
const ALGORITHM_VERSION: u32 = 1;

/// One level's vertex positions and triangles.
type Geometry = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// What a hierarchy is built with.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Config {
    /// Decimation factor of each level: level `i + 1` has `ceil(n_i / factors[i])` vertices.
    pub factors: Vec<usize>,
    /// Spiral length of each level, overriding `int(mean + 2·std)` (e.g.
    /// [`spirals::REFERENCE_FLAME_LENGTHS`], to build the reference network's exact shapes).
    pub spiral_lengths: Option<Vec<usize>>,
}

impl Default for Config {
    /// The reference configuration: [`DEFAULT_FACTORS`], spiral lengths from the statistics.
    fn default() -> Self {
        Self {
            factors: DEFAULT_FACTORS.to_vec(),
            spiral_lengths: None,
        }
    }
}

impl Config {
    /// The reference network's exact shapes on FLAME: [`DEFAULT_FACTORS`] and the spiral
    /// lengths pinned to [`spirals::REFERENCE_FLAME_LENGTHS`].
    pub fn reference_flame() -> Self {
        Self {
            factors: DEFAULT_FACTORS.to_vec(),
            spiral_lengths: Some(spirals::REFERENCE_FLAME_LENGTHS.to_vec()),
        }
    }
}

/// [`build_with`] with `factors` and spiral lengths from the statistics.
pub fn build(mesh: &Mesh, factors: &[usize]) -> Result<Hierarchy, BuildError> {
    build_with(
        mesh,
        &Config {
            factors: factors.to_vec(),
            spiral_lengths: None,
        },
    )
}

/// Builds the hierarchy of `mesh`: level 0 is the mesh itself (polygons triangulated by fans),
/// level `i + 1` has `ceil(n_i / factors[i])` vertices. Spirals follow
/// [`spirals::reference_schedule`], their lengths the statistics or `config.spiral_lengths`.
///
/// # Errors
/// An empty mesh, an index out of range, a polygon with a repeated vertex or zero area, a
/// non-manifold edge or vertex, inconsistently oriented neighbours, duplicate faces, a vertex in
/// no face, a factor below 2, spiral lengths that are zero or not one per level, or a level that
/// cannot be decimated that far without breaking the surface. Errors name the face or vertex;
/// callers add the file name.
pub fn build_with(mesh: &Mesh, config: &Config) -> Result<Hierarchy, BuildError> {
    let factors = config.factors.as_slice();
    if let Some(lens) = &config.spiral_lengths
        && !(lens.len() == factors.len() + 1 && lens.iter().all(|&l| l > 0))
    {
        return Err(BuildError::SpiralLengths {
            lengths: lens.clone(),
            levels: factors.len() + 1,
        });
    }
    let triangles = checked_triangles(mesh)?;
    if let Some(i) = factors.iter().position(|&f| f < 2) {
        return Err(BuildError::Factor {
            index: i,
            factor: factors[i],
        });
    }
    let mut levels_geo: Vec<Geometry> = vec![(mesh.positions.clone(), triangles)];
    let mut kept_per_level: Vec<Vec<u32>> = Vec::with_capacity(factors.len());
    for (i, &factor) in factors.iter().enumerate() {
        let (positions, triangles) = &levels_geo[i];
        let target = positions.len().div_ceil(factor);
        let (kept, coarse_tris) =
            decimate(positions, triangles, target).map_err(|e| BuildError::Decimate {
                level: i,
                source: e,
            })?;
        let coarse_pos = kept.iter().map(|&v| positions[v as usize]).collect();
        kept_per_level.push(kept);
        levels_geo.push((coarse_pos, coarse_tris));
    }

    let mut down = Vec::with_capacity(factors.len());
    let mut up = Vec::with_capacity(factors.len());
    for (i, kept) in kept_per_level.iter().enumerate() {
        let (fine_pos, _) = &levels_geo[i];
        let (coarse_pos, coarse_tris) = &levels_geo[i + 1];
        down.push(selection(kept, fine_pos.len()));
        up.push(barycentric_upsampling(
            fine_pos,
            coarse_pos,
            coarse_tris,
            kept,
        ));
    }

    let schedule = spirals::reference_schedule(levels_geo.len());
    let levels = levels_geo
        .into_iter()
        .zip(schedule)
        .enumerate()
        .map(|(i, ((positions, triangles), (steps, dilation)))| {
            let len = config.spiral_lengths.as_ref().map(|l| l[i]);
            let (spiral_len, spirals) =
                spirals::build(&positions, &triangles, steps, dilation, len)
                    .map_err(|source| BuildError::Spirals { level: i, source })?;
            Ok(Level {
                positions,
                triangles,
                spiral_len,
                spirals,
            })
        })
        .collect::<Result<Vec<_>, BuildError>>()?;
    Ok(Hierarchy { levels, down, up })
}

/// Fan-triangulates `mesh` and checks that it is a manifold surface the hierarchy can be built
/// on (see [`build`] for the conditions).
pub fn checked_triangles(mesh: &Mesh) -> Result<Vec<[u32; 3]>, SurfaceError> {
    let n = mesh.positions.len();
    if n == 0 {
        return Err(SurfaceError::NoVertices);
    }
    if mesh.polygons.is_empty() {
        return Err(SurfaceError::NoFaces);
    }
    let mut triangles = Vec::new();
    let mut owner = Vec::new();
    for (pi, poly) in mesh.polygons.iter().enumerate() {
        if poly.len() < 3 {
            return Err(SurfaceError::Corners {
                face: pi,
                corners: poly.len(),
            });
        }
        for (k, &v) in poly.iter().enumerate() {
            if v as usize >= n {
                return Err(SurfaceError::VertexIndex {
                    face: pi,
                    vertex: v,
                    vertices: n,
                });
            }
            if poly[..k].contains(&v) {
                return Err(SurfaceError::RepeatedVertex {
                    face: pi,
                    vertex: v,
                });
            }
        }
        for k in 1..poly.len() - 1 {
            let t = [poly[0], poly[k], poly[k + 1]];
            let p = t.map(|v| to64(mesh.positions[v as usize]));
            if norm2(cross(sub(p[1], p[0]), sub(p[2], p[0]))) == 0.0 {
                return Err(SurfaceError::ZeroArea {
                    face: pi,
                    polygon: poly.clone(),
                });
            }
            triangles.push(t);
            owner.push(pi);
        }
    }

    // Every undirected edge with its faces; sorted, so the first error found is always the same.
    let mut edges: Vec<(u32, u32, bool, usize)> = Vec::with_capacity(triangles.len() * 3);
    for (ti, t) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), a < b, ti));
        }
    }
    edges.sort_unstable();
    for group in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        let (a, b) = (group[0].0, group[0].1);
        if group.len() > 2 {
            let faces: Vec<usize> = group.iter().map(|e| owner[e.3]).collect();
            return Err(SurfaceError::NonManifoldEdge {
                edge: (a, b),
                faces,
            });
        }
        if group.len() == 2 && group[0].2 == group[1].2 {
            return Err(SurfaceError::Orientation {
                faces: (owner[group[0].3], owner[group[1].3]),
                edge: (a, b),
            });
        }
    }
    let mut keys: Vec<([u32; 3], usize)> = triangles
        .iter()
        .enumerate()
        .map(|(ti, t)| {
            let mut k = *t;
            k.sort_unstable();
            (k, ti)
        })
        .collect();
    keys.sort_unstable();
    for w in keys.windows(2) {
        if w[0].0 == w[1].0 {
            return Err(SurfaceError::DuplicateFace {
                faces: (owner[w[0].1], owner[w[1].1]),
                vertices: w[0].0,
            });
        }
    }
    let incident = incident_triangles(n, &triangles);
    for (v, faces) in incident.iter().enumerate() {
        if faces.is_empty() {
            return Err(SurfaceError::IsolatedVertex { vertex: v });
        }
        if fan(v as u32, faces, &triangles).is_none() {
            return Err(SurfaceError::NonManifoldVertex {
                vertex: v,
                faces: faces.iter().map(|&t| owner[t as usize]).collect(),
            });
        }
    }
    Ok(triangles)
}

/// The down-sampling of one level: coarse vertex `j` (and the dummy) selects one fine vertex.
///
/// # Shapes
/// `(m + 1) × (n + 1)` with `m = kept.len()`, `n = n_fine`.
fn selection(kept: &[u32], n_fine: usize) -> Sampling {
    let m = kept.len();
    let mut col_idx: Vec<u32> = kept.to_vec();
    col_idx.push(n_fine as u32);
    Sampling {
        rows: m + 1,
        cols: n_fine + 1,
        row_ptr: (0..=m as u32 + 1).collect(),
        col_idx,
        values: vec![1.0; m + 1],
    }
}

/// The up-sampling of one level: a kept fine vertex copies its coarse vertex; any other fine
/// vertex takes the barycentric weights of its closest point on the coarse surface (the
/// nearest coarse triangle, first in triangle order on ties). Zero weights are not stored; each
/// row's columns are increasing.
///
/// # Shapes
/// `(n + 1) × (m + 1)`, `n = fine.len()`, `m = coarse.len()`.
fn barycentric_upsampling(
    fine: &[[f32; 3]],
    coarse: &[[f32; 3]],
    coarse_tris: &[[u32; 3]],
    kept: &[u32],
) -> Sampling {
    let n = fine.len();
    let m = coarse.len();
    let mut coarse_of = vec![u32::MAX; n];
    for (j, &v) in kept.iter().enumerate() {
        coarse_of[v as usize] = j as u32;
    }
    let tris: Vec<[[f64; 3]; 3]> = coarse_tris
        .iter()
        .map(|t| t.map(|v| to64(coarse[v as usize])))
        .collect();
    let boxes: Vec<([f64; 3], [f64; 3])> = tris
        .iter()
        .map(|t| {
            let mut lo = t[0];
            let mut hi = t[0];
            for p in &t[1..] {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
            (lo, hi)
        })
        .collect();
    let mut row_ptr = Vec::with_capacity(n + 2);
    let mut col_idx = Vec::with_capacity(3 * n + 1);
    let mut values = Vec::with_capacity(3 * n + 1);
    row_ptr.push(0u32);
    for (i, &p) in fine.iter().enumerate() {
        if coarse_of[i] != u32::MAX {
            col_idx.push(coarse_of[i]);
            values.push(1.0f32);
        } else {
            let p = to64(p);
            let mut best = (f64::INFINITY, 0usize, [1.0, 0.0, 0.0]);
            for (ti, (t, (lo, hi))) in tris.iter().zip(&boxes).enumerate() {
                let mut d2 = 0.0;
                for k in 0..3 {
                    let gap = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
                    d2 += gap * gap;
                }
                if d2 >= best.0 {
                    continue;
                }
                let (q, w) = closest_point_on_triangle(p, t);
                let d2 = norm2(sub(p, q));
                if d2 < best.0 {
                    best = (d2, ti, w);
                }
            }
            let t = coarse_tris[best.1];
            let mut entries: Vec<(u32, f64)> = (0..3)
                .filter(|&k| best.2[k] > 0.0)
                .map(|k| (t[k], best.2[k]))
                .collect();
            entries.sort_unstable_by_key(|e| e.0);
            // Rounded to f32 the weights may miss 1 by an ulp; the last one takes the remainder
            // so that each row reproduces constants as closely as f32 allows.
            let total: f64 = entries.iter().map(|e| e.1).sum();
            let last = entries.len() - 1;
            let mut acc = 0.0f32;
            for (k, &(c, w)) in entries.iter().enumerate() {
                let w = if k == last {
                    1.0 - acc
                } else {
                    (w / total) as f32
                };
                acc += w;
                col_idx.push(c);
                values.push(w);
            }
        }
        row_ptr.push(col_idx.len() as u32);
    }
    col_idx.push(m as u32);
    values.push(1.0);
    row_ptr.push(col_idx.len() as u32);
    Sampling {
        rows: n + 1,
        cols: m + 1,
        row_ptr,
        col_idx,
        values,
    }
}

/// Which of a hierarchy's sections to write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sections {
    /// Everything [`read_sections`] reads back (hierarchy files and the cache).
    All,
    /// What `sinew_core::s2d::S2dDecoder` reads (a baked decoder): `p.levels`, `p.h0.pos`,
    /// every `p.h<i>.spiral` and `p.u<i>.*`, and the template's triangles `p.h0.tri` (which the
    /// core ignores: the face `sinew generate` decodes onto by default,
    /// `io::decoder_face`); not the coarser levels' positions and triangles or the
    /// down-samplings.
    Playback,
}

/// Writes `h` as sections under `prefix` (see docs/FORMAT.md, "S2D mesh hierarchy"):
/// `p.levels`, per level `p.h<i>.pos`, `p.h<i>.tri`, `p.h<i>.spiral`, and per sampling
/// `p.d<i>.{ptr,col,val}` and `p.u<i>.{ptr,col,val}`; with [`Sections::Playback`] only those the
/// core's decoder reads.
pub fn write_sections(
    h: &Hierarchy,
    w: &mut SinewWriter,
    prefix: &str,
    which: Sections,
) -> Result<(), WriterError> {
    let all = which == Sections::All;
    let table: Vec<u32> = h
        .levels
        .iter()
        .flat_map(|l| [l.positions.len() as u32, l.spiral_len as u32])
        .collect();
    w.u32s(&format!("{prefix}.levels"), &[h.levels.len(), 2], &table)?;
    for (i, l) in h.levels.iter().enumerate() {
        let n = l.positions.len();
        if all || i == 0 {
            let pos: Vec<f32> = l.positions.iter().flatten().copied().collect();
            w.f32s(&format!("{prefix}.h{i}.pos"), &[n, 3], &pos)?;
            let tri: Vec<u32> = l.triangles.iter().flatten().copied().collect();
            w.u32s(&format!("{prefix}.h{i}.tri"), &[l.triangles.len(), 3], &tri)?;
        }
        w.u32s(
            &format!("{prefix}.h{i}.spiral"),
            &[n + 1, l.spiral_len],
            &l.spirals,
        )?;
    }
    let samplings: &[(&str, &Vec<Sampling>)] = if all {
        &[("d", &h.down), ("u", &h.up)]
    } else {
        &[("u", &h.up)]
    };
    for (tag, list) in samplings {
        for (i, s) in list.iter().enumerate() {
            let p = format!("{prefix}.{tag}{i}");
            w.u32s(&format!("{p}.ptr"), &[s.row_ptr.len()], &s.row_ptr)?;
            w.u32s(&format!("{p}.col"), &[s.col_idx.len()], &s.col_idx)?;
            w.f32s(&format!("{p}.val"), &[s.values.len()], &s.values)?;
        }
    }
    Ok(())
}

/// Reads the sections [`write_sections`] wrote under `prefix`, checking every shape and index
/// with the core's own validation (`Csr::new`, `Spirals::new`).
pub fn read_sections(f: &SinewFile<'_>, prefix: &str) -> Result<Hierarchy, SectionError> {
    let fmt = |source, name: &str| SectionError::Format {
        name: name.to_owned(),
        source,
    };
    let name = format!("{prefix}.levels");
    let (dims, rank) = f.dims_of(&name).map_err(|e| fmt(e, &name))?;
    if !(rank == 2 && dims[1] == 2 && dims[0] >= 1) {
        return Err(SectionError::Shape {
            name,
            rule: "shape must be [levels, 2]",
        });
    }
    let table: Vec<u32> = f
        .u32_tensor(&name, &dims[..2])
        .map_err(|e| fmt(e, &name))?
        .iter()
        .collect();
    let mut levels = Vec::new();
    for (i, row) in table.chunks_exact(2).enumerate() {
        let (n, len) = (row[0], row[1]);
        let rows = n.checked_add(1).ok_or_else(|| SectionError::TooLarge {
            name: format!("{prefix}.levels"),
            level: i,
        })?;
        let name = format!("{prefix}.h{i}.pos");
        let pos = f.f32_tensor(&name, &[n, 3]).map_err(|e| fmt(e, &name))?;
        let positions = pos
            .iter()
            .collect::<Vec<_>>()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let name = format!("{prefix}.h{i}.tri");
        let (dims, rank) = f.dims_of(&name).map_err(|e| fmt(e, &name))?;
        if !(rank == 2 && dims[1] == 3) {
            return Err(SectionError::Shape {
                name,
                rule: "shape must be [T, 3]",
            });
        }
        let tri = f.u32_tensor(&name, &dims[..2]).map_err(|e| fmt(e, &name))?;
        if !tri.iter().all(|v| v < n) {
            return Err(SectionError::VertexIndex { name });
        }
        let triangles = tri
            .iter()
            .collect::<Vec<_>>()
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        let name = format!("{prefix}.h{i}.spiral");
        let sp = f
            .u32_tensor(&name, &[rows, len])
            .map_err(|e| fmt(e, &name))?;
        sinew_core::spiral::Spirals::new(sp, rows as usize, len as usize, rows as usize)
            .map_err(|e| fmt(e, &name))?;
        levels.push(Level {
            positions,
            triangles,
            spiral_len: len as usize,
            spirals: sp.iter().collect(),
        });
    }
    let sizes: Vec<usize> = levels.iter().map(|l| l.positions.len() + 1).collect();
    let mut down = Vec::new();
    let mut up = Vec::new();
    for i in 0..sizes.len() - 1 {
        down.push(read_sampling(
            f,
            &format!("{prefix}.d{i}"),
            sizes[i + 1],
            sizes[i],
        )?);
        up.push(read_sampling(
            f,
            &format!("{prefix}.u{i}"),
            sizes[i],
            sizes[i + 1],
        )?);
    }
    Ok(Hierarchy { levels, down, up })
}

fn read_sampling(
    f: &SinewFile<'_>,
    p: &str,
    rows: usize,
    cols: usize,
) -> Result<Sampling, SectionError> {
    let fmt = |source, name: &str| SectionError::Format {
        name: name.to_owned(),
        source,
    };
    let vector = |name: &str| SectionError::Shape {
        name: name.to_owned(),
        rule: "must be a vector",
    };
    let vec_u32 = |name: &str| -> Result<sinew_core::tensor::U32s<'_>, SectionError> {
        let (dims, rank) = f.dims_of(name).map_err(|e| fmt(e, name))?;
        if rank != 1 {
            return Err(vector(name));
        }
        f.u32_tensor(name, &dims[..1]).map_err(|e| fmt(e, name))
    };
    let (ptr_name, col_name, val_name) =
        (format!("{p}.ptr"), format!("{p}.col"), format!("{p}.val"));
    let ptr = vec_u32(&ptr_name)?;
    let col = vec_u32(&col_name)?;
    let (dims, rank) = f.dims_of(&val_name).map_err(|e| fmt(e, &val_name))?;
    if rank != 1 {
        return Err(vector(&val_name));
    }
    let val = f
        .f32_tensor(&val_name, &dims[..1])
        .map_err(|e| fmt(e, &val_name))?;
    sinew_core::sparse::Csr::new(rows, cols, ptr, col, val).map_err(|e| fmt(e, p))?;
    Ok(Sampling {
        rows,
        cols,
        row_ptr: ptr.iter().collect(),
        col_idx: col.iter().collect(),
        values: val.iter().collect(),
    })
}

/// The hierarchy as a stand-alone `.sinew` file (kind S2D decoder, hierarchy sections only,
/// under prefix `s2d`), with the cache key and factors as metadata.
pub fn to_bytes(h: &Hierarchy, key: u64, config: &Config) -> Result<Vec<u8>, WriterError> {
    let list = |v: &[usize]| v.iter().map(usize::to_string).collect::<Vec<_>>().join(",");
    let mut w = SinewWriter::new(ArtifactKind::S2dDecoder);
    w.meta("tool", concat!("sinew ", env!("CARGO_PKG_VERSION")))
        .meta("content", "s2d-hierarchy")
        .meta("key", format!("{key:016x}"))
        .meta("factors", list(&config.factors));
    if let Some(lens) = &config.spiral_lengths {
        w.meta("spiral_lengths", list(lens));
    }
    write_sections(h, &mut w, "s2d", Sections::All)?;
    w.to_bytes()
}

/// Reads a hierarchy file written by [`to_bytes`].
pub fn from_bytes(bytes: &[u8]) -> Result<Hierarchy, SectionError> {
    let f = SinewFile::from_bytes(bytes).map_err(SectionError::NotASinewFile)?;
    read_sections(&f, "s2d")
}

/// A stable 64-bit key of the mesh's positions and faces, the configuration and the algorithm
/// version (CRC-64/XZ over their little-endian bytes; a cache key, not a security hash).
pub fn cache_key(mesh: &Mesh, config: &Config) -> u64 {
    let crc = crc::Crc::<u64>::new(&crc::CRC_64_XZ);
    let mut d = crc.digest();
    d.update(b"sinew-s2d-hierarchy");
    d.update(&ALGORITHM_VERSION.to_le_bytes());
    d.update(&(mesh.positions.len() as u64).to_le_bytes());
    for p in &mesh.positions {
        for c in p {
            d.update(&c.to_bits().to_le_bytes());
        }
    }
    d.update(&(mesh.polygons.len() as u64).to_le_bytes());
    for poly in &mesh.polygons {
        d.update(&(poly.len() as u32).to_le_bytes());
        for v in poly {
            d.update(&v.to_le_bytes());
        }
    }
    d.update(&(config.factors.len() as u64).to_le_bytes());
    for f in &config.factors {
        d.update(&(*f as u64).to_le_bytes());
    }
    match &config.spiral_lengths {
        None => d.update(&[0]),
        Some(lens) => {
            d.update(&[1]);
            d.update(&(lens.len() as u64).to_le_bytes());
            for l in lens {
                d.update(&(*l as u64).to_le_bytes());
            }
        }
    }
    d.finalize()
}

/// The path [`cached_with`] uses in `cache_dir` for `mesh` and `config`.
pub fn cache_path(mesh: &Mesh, config: &Config, cache_dir: &Path) -> PathBuf {
    cache_dir.join(format!(
        "s2d-hierarchy-{:016x}.sinew",
        cache_key(mesh, config)
    ))
}

/// [`cached_with`] with `factors` and spiral lengths from the statistics.
pub fn cached(
    mesh: &Mesh,
    factors: &[usize],
    cache_dir: &Path,
) -> Result<Hierarchy, HierarchyError> {
    let config = Config {
        factors: factors.to_vec(),
        spiral_lengths: None,
    };
    cached_with(mesh, &config, cache_dir)
}

/// The hierarchy of `mesh`, read from `cache_dir` if an entry for this mesh and configuration
/// exists and matches, else built and written there atomically (so training and playback build
/// it once). An entry that cannot be read, or whose key or level-0 positions differ, is rebuilt
/// and replaced.
pub fn cached_with(
    mesh: &Mesh,
    config: &Config,
    cache_dir: &Path,
) -> Result<Hierarchy, HierarchyError> {
    let key = cache_key(mesh, config);
    let path = cache_path(mesh, config, cache_dir);
    if let Ok(bytes) = std::fs::read(&path)
        && let Ok(f) = SinewFile::from_bytes(&bytes)
        && f.metadata().get("key") == Some(format!("{key:016x}").as_str())
        && let Ok(h) = read_sections(&f, "s2d")
        && h.levels
            .first()
            .is_some_and(|l| l.positions == mesh.positions)
    {
        return Ok(h);
    }
    let h = build_with(mesh, config)?;
    crate::io::atomic::write(&path, &to_bytes(&h, key, config)?)?;
    Ok(h)
}

/// `sinew s2d hierarchy`: builds the S2D mesh hierarchy of `template` with `config` and writes
/// it to `out` (see `s2d::hierarchy::to_bytes`). Errors name the template file.
pub fn s2d_hierarchy(
    template: &Path,
    out: &Path,
    config: &crate::s2d::hierarchy::Config,
) -> Result<crate::s2d::Hierarchy, HierarchyError> {
    use crate::s2d::hierarchy;
    let mesh = Mesh::read(template)?;
    let h = hierarchy::build_with(&mesh, config).map_err(|source| HierarchyError::BuildFile {
        path: template.to_owned(),
        source,
    })?;
    let key = hierarchy::cache_key(&mesh, config);
    crate::io::atomic::write(out, &hierarchy::to_bytes(&h, key, config)?)?;
    Ok(h)
}

#[cfg(test)]
mod tests;
