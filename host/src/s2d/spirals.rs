//! Spiral orderings for the spiral convolution (Bouritsas et al. 2019, as S2D-Dec uses them;
//! `shared/notes/s2d-reference.md`, "Spirals").
//!
//! The spiral of a vertex `v` is `v` followed by its rings of neighbours, each walked
//! counter-clockwise (with the triangles' orientation). The note leaves these choices open;
//! Sinew fixes them as follows:
//!
//! - **Reference vertex**: in each connected component, the vertex of lowest index.
//! - **Start of the first ring**: the neighbour of `v` on its shortest path to the reference
//!   vertex (Dijkstra over edge lengths in `f64`; ties go to the lower-index predecessor); for
//!   the reference vertex itself, its nearest neighbour (ties: lower index). The ring then runs
//!   counter-clockwise around `v`; around a boundary vertex the fan is an open chain, and the
//!   walk wraps from its last neighbour to its first.
//! - **Later rings**: for each vertex `w` of the previous ring in order, the not yet visited
//!   neighbours of `w`, counter-clockwise around `w`, starting after the last visited
//!   neighbour that precedes an unvisited one. On a regular patch this continues the
//!   counter-clockwise turn of the previous ring.
//! - **Natural spiral**: `v` and `steps` rings.
//! - **Dilation** `d`: keep `s[0]`, then `s[1], s[1 + d], s[1 + 2d], …` (`s[:1] + s[1::d]`).
//! - **Length**: `int(mean + 2·std)` of the dilated lengths over the level's real vertices
//!   (population standard deviation), at least 1; shorter spirals are padded with the dummy
//!   index `n`, longer ones truncated. The dummy vertex's row is all `n`.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use crate::geometry::topology::{fan, incident_triangles};

/// A vertex whose triangles do not form one fan (a non-manifold vertex): it has no spiral.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("vertex {vertex}: its triangles do not form one fan (non-manifold vertex)")]
pub struct NonManifoldVertex {
    /// The vertex.
    pub vertex: usize,
}

/// The spiral lengths of the authors' reference configuration on FLAME, levels 0 to 4
/// (`shared/notes/s2d-reference.md`). Sinew's statistics give `[15, 13, 9, 9, 7]` on its own
/// FLAME hierarchy (see docs/S2D.md); pass these to reproduce the reference network's shapes.
pub const REFERENCE_FLAME_LENGTHS: [usize; 5] = [15, 14, 9, 9, 7];

/// Rings and dilation of each level, finest first, for a hierarchy of `levels` levels: the
/// reference's `[2, 2, 1, 1, 1]` for both, extended with `1` for deeper hierarchies.
pub fn reference_schedule(levels: usize) -> Vec<(usize, usize)> {
    (0..levels)
        .map(|i| if i < 2 { (2, 2) } else { (1, 1) })
        .collect()
}

/// The natural (undilated, unpadded) spiral of every vertex with `steps` rings.
///
/// # Errors
/// If a vertex's triangles do not form one fan (a non-manifold vertex).
pub fn natural(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    steps: usize,
) -> Result<Vec<Vec<u32>>, NonManifoldVertex> {
    let n = positions.len();
    let incident = incident_triangles(n, triangles);
    let mut rings = Vec::with_capacity(n);
    for (v, faces) in incident.iter().enumerate() {
        match fan(v as u32, faces, triangles) {
            Some(order) => rings.push(order),
            None => return Err(NonManifoldVertex { vertex: v }),
        }
    }
    let first = first_neighbours(positions, &rings);
    let mut out = Vec::with_capacity(n);
    for v in 0..n {
        let mut spiral = vec![v as u32];
        let ring1 = &rings[v];
        let start = ring1.iter().position(|&w| w == first[v]).unwrap_or(0);
        let mut ring: Vec<u32> = ring1[start..]
            .iter()
            .chain(&ring1[..start])
            .copied()
            .collect();
        spiral.extend_from_slice(&ring);
        for _ in 1..steps {
            let mut next = Vec::new();
            for &w in &ring {
                let around = &rings[w as usize];
                let len = around.len();
                let seen = |x: u32| spiral.contains(&x) || next.contains(&x);
                let from = (0..len)
                    .find(|&k| seen(around[k]) && !seen(around[(k + 1) % len]))
                    .unwrap_or(len.saturating_sub(1));
                for j in 1..=len {
                    let x = around[(from + j) % len];
                    if !spiral.contains(&x) && !next.contains(&x) {
                        next.push(x);
                    }
                }
            }
            if next.is_empty() {
                break;
            }
            spiral.extend_from_slice(&next);
            ring = next;
        }
        out.push(spiral);
    }
    Ok(out)
}

/// For every vertex, the neighbour its first ring starts at (see the module documentation).
fn first_neighbours(positions: &[[f32; 3]], rings: &[Vec<u32>]) -> Vec<u32> {
    let n = positions.len();
    let dist_between = |a: usize, b: usize| {
        let (p, q) = (positions[a], positions[b]);
        let d: f64 = (0..3)
            .map(|k| (f64::from(p[k]) - f64::from(q[k])).powi(2))
            .sum();
        d.sqrt()
    };
    let mut dist = vec![f64::INFINITY; n];
    let mut parent = vec![u32::MAX; n];
    let mut first = vec![u32::MAX; n];
    for root in 0..n {
        if dist[root].is_finite() {
            continue;
        }
        // A new component; its lowest-index vertex is `root` since roots are tried in order.
        dist[root] = 0.0;
        let mut heap = BinaryHeap::new();
        heap.push(Reverse((Key(0.0), root as u32)));
        while let Some(Reverse((Key(d), v))) = heap.pop() {
            if d > dist[v as usize] {
                continue;
            }
            for &w in &rings[v as usize] {
                let nd = d + dist_between(v as usize, w as usize);
                let wi = w as usize;
                if nd < dist[wi] || (nd == dist[wi] && v < parent[wi] && wi != root) {
                    let improved = nd < dist[wi];
                    dist[wi] = nd;
                    parent[wi] = v;
                    if improved {
                        heap.push(Reverse((Key(nd), w)));
                    }
                }
            }
        }
        first[root] = rings[root]
            .iter()
            .copied()
            .min_by(|&a, &b| {
                dist_between(root, a as usize)
                    .total_cmp(&dist_between(root, b as usize))
                    .then(a.cmp(&b))
            })
            .unwrap_or(root as u32);
    }
    for v in 0..n {
        if first[v] == u32::MAX {
            first[v] = parent[v];
        }
    }
    first
}

/// An `f64` with a total order, for the Dijkstra queue.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Key(f64);
impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Key {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Keeps `s[0]`, then every `dilation`-th element from `s[1]` on.
pub fn dilate(spiral: &[u32], dilation: usize) -> Vec<u32> {
    let step = dilation.max(1);
    spiral
        .iter()
        .take(1)
        .chain(spiral.iter().skip(1).step_by(step))
        .copied()
        .collect()
}

/// `int(mean + 2·std)` of the lengths (population standard deviation), at least 1.
pub fn reference_length(lengths: &[usize]) -> usize {
    if lengths.is_empty() {
        return 1;
    }
    let n = lengths.len() as f64;
    let mean = lengths.iter().map(|&l| l as f64).sum::<f64>() / n;
    let var = lengths
        .iter()
        .map(|&l| (l as f64 - mean).powi(2))
        .sum::<f64>()
        / n;
    ((mean + 2.0 * var.sqrt()) as usize).max(1)
}

/// The padded spirals of one level: `(len, indices)` with `indices` row-major
/// `[(n + 1) × len]`, the dummy vertex `n` padding short spirals and filling the last row.
/// `len` is [`reference_length`] of the dilated spirals unless `fixed_len` is given.
pub fn build(
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    steps: usize,
    dilation: usize,
    fixed_len: Option<usize>,
) -> Result<(usize, Vec<u32>), NonManifoldVertex> {
    let n = positions.len();
    let spirals: Vec<Vec<u32>> = natural(positions, triangles, steps)?
        .iter()
        .map(|s| dilate(s, dilation))
        .collect();
    let lengths: Vec<usize> = spirals.iter().map(Vec::len).collect();
    let len = fixed_len
        .unwrap_or_else(|| reference_length(&lengths))
        .max(1);
    let dummy = n as u32;
    let mut out = Vec::with_capacity((n + 1) * len);
    for s in &spirals {
        out.extend(s.iter().copied().chain(std::iter::repeat(dummy)).take(len));
    }
    out.extend(std::iter::repeat_n(dummy, len));
    Ok((len, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hexagon fan around vertex 0, counter-clockwise seen from +z; vertex 4 is a little
    /// closer to the centre than the others, so the centre's first ring starts there.
    fn hexagon() -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        let mut positions = vec![[0.0, 0.0, 0.0]];
        for k in 0..6 {
            let a = std::f32::consts::PI / 3.0 * k as f32;
            let r = if k == 3 { 0.9 } else { 1.0 };
            positions.push([r * a.cos(), r * a.sin(), 0.0]);
        }
        let triangles = (1..=6).map(|i| [0, i, i % 6 + 1]).collect();
        (positions, triangles)
    }

    #[test]
    fn rings_run_counter_clockwise_from_the_reference_direction() {
        let (p, t) = hexagon();
        let s = natural(&p, &t, 1).unwrap();
        assert_eq!(s[0], [0, 4, 5, 6, 1, 2, 3]);
        // Boundary vertex 1: its open fan 2, 0, 6 starts towards the reference vertex 0 and
        // wraps; the second ring continues the counter-clockwise turn.
        let s = natural(&p, &t, 2).unwrap();
        assert_eq!(s[1], [1, 0, 6, 2, 3, 4, 5]);
        // Mirrored winding mirrors the order.
        let flipped: Vec<[u32; 3]> = t.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let s = natural(&p, &flipped, 1).unwrap();
        assert_eq!(s[0], [0, 4, 3, 2, 1, 6, 5]);
    }

    #[test]
    fn padding_truncation_and_dilation() {
        assert_eq!(dilate(&[0, 1, 2, 3, 4, 5], 2), [0, 1, 3, 5]);
        assert_eq!(dilate(&[0, 1, 2], 1), [0, 1, 2]);
        assert_eq!(reference_length(&[7, 4, 4, 4, 4, 4, 4]), 6);
        let (p, t) = hexagon();
        let (len, rows) = build(&p, &t, 1, 1, None).unwrap();
        assert_eq!(len, 6);
        assert_eq!(rows.len(), 8 * 6);
        assert_eq!(&rows[..6], &[0, 4, 5, 6, 1, 2]);
        assert_eq!(&rows[6..12], &[1, 0, 6, 2, 7, 7]);
        assert_eq!(&rows[42..], &[7; 6]);
        let (len, rows) = build(&p, &t, 1, 1, Some(8)).unwrap();
        assert_eq!(len, 8);
        assert_eq!(&rows[..8], &[0, 4, 5, 6, 1, 2, 3, 7]);
    }
}
