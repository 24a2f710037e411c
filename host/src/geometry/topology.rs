//! Triangle-mesh topology: the triangles around each vertex and the ordered one-ring (fan) of a
//! vertex, which the S2D hierarchy's manifold check and the spirals walk.

/// The triangles incident to each vertex, in increasing triangle order.
pub fn incident_triangles(n: usize, triangles: &[[u32; 3]]) -> Vec<Vec<u32>> {
    let mut out = vec![Vec::new(); n];
    for (ti, t) in triangles.iter().enumerate() {
        for &v in t {
            out[v as usize].push(ti as u32);
        }
    }
    out
}

/// The neighbours of `v` in counter-clockwise order (seen with the triangles' orientation),
/// given its incident triangles. For a boundary vertex the order runs from the neighbour after
/// the boundary gap to the one before it. `None` if the triangles around `v` do not form a
/// single fan (a non-manifold vertex).
pub fn fan(v: u32, faces: &[u32], triangles: &[[u32; 3]]) -> Option<Vec<u32>> {
    // In a counter-clockwise triangle (v, a, b), `a` comes right before `b` around `v`.
    let mut next: Vec<(u32, u32)> = faces
        .iter()
        .map(|&t| {
            let tri = triangles[t as usize];
            let k = tri.iter().position(|&x| x == v).unwrap_or(0);
            (tri[(k + 1) % 3], tri[(k + 2) % 3])
        })
        .collect();
    next.sort_unstable();
    if next.windows(2).any(|w| w[0].0 == w[1].0) {
        return None;
    }
    let succ = |a: u32| {
        next.binary_search_by_key(&a, |e| e.0)
            .ok()
            .map(|i| next[i].1)
    };
    // A boundary fan starts at the one neighbour that no triangle leads to.
    let mut targets: Vec<u32> = next.iter().map(|e| e.1).collect();
    targets.sort_unstable();
    let starts: Vec<u32> = next
        .iter()
        .map(|e| e.0)
        .filter(|a| targets.binary_search(a).is_err())
        .collect();
    let start = match starts.as_slice() {
        [] => next.first()?.0,
        [s] => *s,
        _ => return None,
    };
    let mut order = vec![start];
    let mut cur = start;
    while let Some(b) = succ(cur) {
        if b == start {
            break;
        }
        order.push(b);
        cur = b;
        if order.len() > next.len() + 1 {
            return None;
        }
    }
    // Every triangle must have been walked: a closed fan has as many neighbours as triangles,
    // an open one one more.
    let expected = if starts.is_empty() {
        next.len()
    } else {
        next.len() + 1
    };
    (order.len() == expected).then_some(order)
}
