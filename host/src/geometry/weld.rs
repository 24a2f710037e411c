//! Welding: the vertices a file splits at UV seams (one position, several texture coordinates)
//! joined into one, so that learning sees one surface; the map back keeps every split copy for
//! what is written out.

use crate::geometry::vec3::{norm, sub, to64};

/// Which welded vertex each original vertex became.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Weld {
    /// Per original vertex, its welded vertex.
    pub welded: Vec<u32>,
    /// Per welded vertex, the first original vertex that became it.
    pub first: Vec<u32>,
}

impl Weld {
    /// The number of welded vertices.
    pub fn len(&self) -> usize {
        self.first.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// Per welded vertex, the value of its first original vertex.
    pub fn pick<T: Copy>(&self, values: &[T]) -> Vec<T> {
        self.first.iter().map(|&v| values[v as usize]).collect()
    }

    /// Per original vertex, the value of its welded vertex.
    pub fn spread<T: Copy>(&self, welded: &[T]) -> Vec<T> {
        self.welded.iter().map(|&w| welded[w as usize]).collect()
    }

    /// Polygons over the welded vertices; a polygon that two of its corners' welding made
    /// degenerate (a repeated corner) is dropped.
    pub fn polygons(&self, polygons: &[Vec<u32>]) -> Vec<Vec<u32>> {
        polygons
            .iter()
            .map(|p| {
                p.iter()
                    .map(|&v| self.welded[v as usize])
                    .collect::<Vec<u32>>()
            })
            .filter(|p| (0..p.len()).all(|i| !p[i + 1..].contains(&p[i])))
            .collect()
    }
}

/// Welds the vertices that lie within `tolerance` of an earlier kept vertex in the neutral and
/// move with it in every shape (`shapes`: per shape, an offset per vertex), so that surfaces that
/// only touch at rest (closed lips) stay apart.
pub fn weld(neutral: &[[f32; 3]], shapes: &[Vec<[f32; 3]>], tolerance: f64) -> Weld {
    let points: Vec<[f64; 3]> = neutral.iter().map(|&p| to64(p)).collect();
    let tree = crate::geometry::surface::point_tree(&points);
    let mut welded = vec![0u32; points.len()];
    let mut first: Vec<u32> = Vec::new();
    let mut kept = vec![false; points.len()];
    for i in 0..points.len() {
        let same_motion = |j: usize| {
            shapes
                .iter()
                .all(|s| norm(sub(to64(s[i]), to64(s[j]))) <= tolerance)
        };
        let found = tree
            .locate_within_distance(points[i], tolerance * tolerance)
            .map(|g| g.data)
            .filter(|&j| j < i && kept[j] && same_motion(j))
            .min();
        match found {
            Some(j) => welded[i] = welded[j],
            None => {
                kept[i] = true;
                welded[i] = first.len() as u32;
                first.push(i as u32);
            }
        }
    }
    Weld { welded, first }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seam_copies_weld_and_touching_surfaces_that_part_do_not() {
        // 0 and 2 share a position and move together (a seam); 1 and 3 share a position at rest
        // but part in the shape (closed lips).
        let neutral = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        let shape = vec![vec![
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, -1.0, 0.0],
        ]];
        let w = weld(&neutral, &shape, 1e-6);
        assert_eq!(w.welded, [0, 1, 0, 2]);
        assert_eq!(w.first, [0, 1, 3]);
        assert_eq!(w.spread(&w.pick(&[5, 6, 7, 8])), [5, 6, 5, 8]);
        let polys = w.polygons(&[vec![0, 1, 2], vec![0, 1, 3]]);
        assert_eq!(polys, [vec![0, 1, 2]]);
    }
}
