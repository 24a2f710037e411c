//! The random draws of an AIM training step: which template points, shapes and auxiliary points
//! step `t` samples, from a generator seeded by (seed, step) alone, so that a resumed run draws
//! what an uninterrupted one would.

use super::{AimConfig, TrainingSet};
use crate::training::random::Stream;

/// The random draws of one step, from a generator seeded by (seed, step) alone.
pub(crate) struct Draw {
    pub(crate) points: Vec<u32>,
    pub(crate) shapes: Vec<u32>,
    pub(crate) symmetry: Vec<u32>,
    pub(crate) forehead: Vec<u32>,
    /// Jaw-constrained points for L_J (empty when `lambda_jaw` = 0).
    pub(crate) jaw: Vec<u32>,
}

pub(crate) fn draw(set: &TrainingSet, config: &AimConfig, step: usize) -> Draw {
    let mut rng = Stream::new(config.seed, step as u64, 0xda3e_39cb_94b9_5bdb);
    let mut below = |n: usize| rng.below(n) as u32;
    let v = set.vertices();
    let n = set.shapes.len();
    // One shape per sample keeps its own order of draws (every point, then every shape), so
    // that runs recorded before `shapes_per_point` existed resume with the samples they drew.
    let (points, shapes) = if config.shapes_per_point <= 1 {
        (
            (0..config.batch).map(|_| below(v)).collect(),
            (0..config.batch).map(|_| below(n)).collect(),
        )
    } else {
        // Each point with `shapes_per_point` different shapes: a partial Fisher–Yates shuffle
        // of `order` per point (uniform over subsets from any starting permutation).
        let per = config.shapes_per_point.min(n);
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut points = Vec::with_capacity(config.batch);
        let mut shapes = Vec::with_capacity(config.batch);
        while points.len() < config.batch {
            let p = below(v);
            for j in 0..per.min(config.batch - points.len()) {
                order.swap(j, j + below(n - j) as usize);
                points.push(p);
                shapes.push(order[j]);
            }
        }
        (points, shapes)
    };
    let symmetry = (0..config.symmetry_batch).map(|_| below(v)).collect();
    let forehead = if set.forehead.is_empty() {
        Vec::new()
    } else {
        (0..config.forehead_batch)
            .map(|_| set.forehead[below(set.forehead.len()) as usize])
            .collect()
    };
    // Drawn last, and only when used, so the paper's objective draws exactly what it did before.
    let jaw_vertices = if config.lambda_jaw > 0.0 {
        set.jaw_constrained()
    } else {
        Vec::new()
    };
    let jaw = if jaw_vertices.is_empty() {
        Vec::new()
    } else {
        (0..config.forehead_batch)
            .map(|_| jaw_vertices[below(jaw_vertices.len()) as usize])
            .collect()
    };
    Draw {
        points,
        shapes,
        symmetry,
        forehead,
        jaw,
    }
}

/// How many network rows step `step` evaluates: the distinct sample points (every network), the
/// symmetry term's points (B, twice: the point and its mirror), and the forehead's and the jaw
/// term's points (K). What a step's arithmetic is counted from (the `aim_train_step` benchmark's
/// FLOPs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepRows {
    /// Distinct sample points, each through all five networks.
    pub distinct: usize,
    /// Symmetry points, each through B at the point and at its mirror image.
    pub symmetry: usize,
    /// Forehead points (K).
    pub forehead: usize,
    /// Jaw-constrained points (K), 0 without L_J.
    pub jaw: usize,
}

/// The rows step `step` of a run of `config` on `set` evaluates ([`StepRows`]).
pub fn step_rows(set: &TrainingSet, config: &AimConfig, step: usize) -> StepRows {
    let d = draw(set, config, step);
    StepRows {
        distinct: distinct_points(&d.points, set.vertices()).0.len(),
        symmetry: d.symmetry.len(),
        forehead: d.forehead.len(),
        jaw: d.jaw.len(),
    }
}

/// The distinct entries of `points` (vertex indices below `vertices`) in order of first
/// appearance, and for each entry its position in that list.
pub(crate) fn distinct_points(points: &[u32], vertices: usize) -> (Vec<u32>, Vec<i64>) {
    let mut seen = vec![u32::MAX; vertices];
    let mut distinct = Vec::new();
    let slot = points
        .iter()
        .map(|&p| {
            let at = &mut seen[p as usize];
            if *at == u32::MAX {
                *at = distinct.len() as u32;
                distinct.push(p);
            }
            i64::from(*at)
        })
        .collect();
    (distinct, slot)
}
