//! Spatial queries on meshes and point sets: connected components, outward normals per component,
//! geodesic (edge-path) labels, a uniform grid for nearest neighbours, bounding boxes.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use crate::geometry::vec3::{add, dot, norm, scale, sub, to64};
use crate::io::mesh::Mesh;
/// Connected component of every vertex (over polygon edges), numbered by lowest vertex.
pub(crate) fn components(mesh: &Mesh) -> Vec<u32> {
    let n = mesh.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for poly in &mesh.polygons {
        for w in poly.windows(2) {
            let (a, b) = (find(&mut parent, w[0]), find(&mut parent, w[1]));
            // Union towards the lower root, so the labels do not depend on polygon order.
            match a.cmp(&b) {
                Ordering::Less => parent[b as usize] = a,
                Ordering::Greater => parent[a as usize] = b,
                Ordering::Equal => {}
            }
        }
    }
    (0..n as u32).map(|v| find(&mut parent, v)).collect()
}

/// Vertex normals, flipped per component if they point inward on the whole (the component's
/// normals then mostly point away from its centroid).
pub(crate) fn oriented_normals(mesh: &Mesh, comp: &[u32]) -> Vec<[f64; 3]> {
    let mut normals: Vec<[f64; 3]> = mesh.vertex_normals().into_iter().map(to64).collect();
    let mut centre: HashMap<u32, ([f64; 3], usize)> = HashMap::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        let e = centre.entry(comp[v]).or_insert(([0.0; 3], 0));
        e.0 = add(e.0, to64(*p));
        e.1 += 1;
    }
    let mut score: HashMap<u32, f64> = HashMap::new();
    for (v, p) in mesh.positions.iter().enumerate() {
        let (c, n) = centre[&comp[v]];
        let c = scale(c, 1.0 / n as f64);
        *score.entry(comp[v]).or_insert(0.0) += dot(normals[v], sub(to64(*p), c));
    }
    for (v, n) in normals.iter_mut().enumerate() {
        if score[&comp[v]] < 0.0 {
            *n = scale(*n, -1.0);
        }
    }
    normals
}

/// The vertex of component `c` nearest to `q` (lowest index on ties).
pub(crate) fn nearest_in_component(mesh: &Mesh, comp: &[u32], c: u32, q: [f64; 3]) -> Option<u32> {
    mesh.positions
        .iter()
        .enumerate()
        .filter(|(v, _)| comp[*v] == c)
        .map(|(v, p)| (norm(sub(to64(*p), q)), v))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map(|(_, v)| v as u32)
}

/// Multi-source Dijkstra over mesh edges: every vertex within its nearest source's radius gets
/// that source's index. Ties go to the lower source index.
pub(crate) fn geodesic_labels(
    mesh: &Mesh,
    pos: &[[f64; 3]],
    sources: &[(u32, f64)],
) -> Vec<Option<usize>> {
    let n = pos.len();
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for poly in &mesh.polygons {
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    #[derive(PartialEq)]
    struct Item(f64, usize, u32);
    impl Eq for Item {}
    impl PartialOrd for Item {
        fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Item {
        // Reversed: BinaryHeap is a max-heap and we want the smallest distance first.
        fn cmp(&self, o: &Self) -> Ordering {
            o.0.total_cmp(&self.0)
                .then(o.1.cmp(&self.1))
                .then(o.2.cmp(&self.2))
        }
    }
    let mut dist = vec![f64::INFINITY; n];
    let mut label: Vec<Option<usize>> = vec![None; n];
    let mut heap = BinaryHeap::new();
    for (k, &(v, r)) in sources.iter().enumerate() {
        if r > 0.0 && (v as usize) < n {
            heap.push(Item(0.0, k, v));
        }
    }
    while let Some(Item(d, k, v)) = heap.pop() {
        let vi = v as usize;
        if label[vi].is_some() {
            continue;
        }
        label[vi] = Some(k);
        dist[vi] = d;
        for &w in &adj[vi] {
            let nd = d + norm(sub(pos[w as usize], pos[vi]));
            if nd <= sources[k].1 && nd < dist[w as usize] && label[w as usize].is_none() {
                dist[w as usize] = nd;
                heap.push(Item(nd, k, w));
            }
        }
    }
    label
}

// ---------------------------------------------------------------------------------------------
// Nearest neighbours.

/// A uniform grid over points for nearest-neighbour queries.
pub(crate) struct Grid {
    pub(crate) cell: f64,
    pub(crate) cells: HashMap<[i64; 3], Vec<u32>>,
}

impl Grid {
    pub(crate) fn new(pts: &[[f64; 3]], cell: f64) -> Self {
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, p) in pts.iter().enumerate() {
            cells.entry(Self::key(p, cell)).or_default().push(i as u32);
        }
        Self { cell, cells }
    }

    pub(crate) fn key(p: &[f64; 3], cell: f64) -> [i64; 3] {
        p.map(|x| (x / cell).floor() as i64)
    }

    /// The nearest point passing `ok` within the 27 cells around `q` (so anything closer than
    /// one cell is always found): index and distance; ties go to the lower index.
    pub(crate) fn nearest_where(
        &self,
        pts: &[[f64; 3]],
        q: [f64; 3],
        ok: impl Fn(usize) -> bool,
    ) -> Option<(usize, f64)> {
        let k = Self::key(&q, self.cell);
        let mut best: Option<(usize, f64)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                        continue;
                    };
                    for &i in list {
                        let i = i as usize;
                        let d = norm(sub(pts[i], q));
                        let better = match best {
                            None => true,
                            Some((bi, bd)) => d < bd || (d == bd && i < bi),
                        };
                        if better && ok(i) {
                            best = Some((i, d));
                        }
                    }
                }
            }
        }
        best
    }

    /// The exact nearest point: grows the searched shell of cells until no closer point can be
    /// outside it.
    pub(crate) fn nearest(&self, pts: &[[f64; 3]], q: [f64; 3]) -> Option<(usize, f64)> {
        if pts.is_empty() {
            return None;
        }
        let k = Self::key(&q, self.cell);
        let mut best: Option<(usize, f64)> = None;
        for r in 0i64.. {
            for dx in -r..=r {
                for dy in -r..=r {
                    for dz in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        let Some(list) = self.cells.get(&[k[0] + dx, k[1] + dy, k[2] + dz]) else {
                            continue;
                        };
                        for &i in list {
                            let i = i as usize;
                            let d = norm(sub(pts[i], q));
                            if best.is_none_or(|(bi, bd)| d < bd || (d == bd && i < bi)) {
                                best = Some((i, d));
                            }
                        }
                    }
                }
            }
            // Every point outside shell r is at least r cells away.
            if let Some((_, bd)) = best
                && bd <= r as f64 * self.cell
            {
                break;
            }
            // Far outside the data: stop once the shell covers every cell.
            if r > 1 << 20 {
                break;
            }
        }
        best
    }
}

/// A cell size giving about `per_side` cells along the largest extent of `pts`.
pub(crate) fn cell_for(pts: &[[f64; 3]], per_side: usize) -> f64 {
    let (lo, hi) = bbox(pts);
    let span = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    if span > 0.0 {
        span / per_side as f64
    } else {
        1.0
    }
}

pub(crate) fn bbox(pts: &[[f64; 3]]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pts {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if pts.is_empty() {
        ([0.0; 3], [0.0; 3])
    } else {
        (lo, hi)
    }
}
