//! Where a fit starts and what constrains it: each frame's head and jaw before the first step
//! (at rest, at a rigid alignment, or where a landmark driver put them) and the vertices a step
//! may draw.

use crate::fit::setup::{Constrain, FitConfig, Mode, Start};
use crate::geometry::align::fit_rigid;
use crate::io::performance::Performance;
use crate::training::random::Stream;

use super::cache::{ActorCache, IDENTITY_18};
use super::error::FitError;

/// Per frame, the head and jaw that a zero F_T output means (translations in mm): as
/// `config.start` says, from `driven` (per frame, the head and jaw a landmark driver gave, in
/// the actor's units) for [`Start::Driver`].
///
/// # Errors
/// [`FitError::DriverStart`] for a driver start without one driven pose per frame.
pub(super) fn starts(
    cache: &ActorCache,
    perf: &Performance,
    config: &FitConfig,
    subset: Option<&[i64]>,
    driven: Option<&[[f32; 18]]>,
) -> Result<Vec<[f32; 18]>, FitError> {
    Ok(match config.start {
        Start::Rigid => rigid_start(cache, perf, config.mode, subset, cache.mm),
        Start::Identity => vec![IDENTITY_18; perf.frames.len()],
        Start::Driver => match driven {
            Some(d) if d.len() == perf.frames.len() => d
                .iter()
                .map(|p| {
                    let mut start = *p;
                    for i in [6, 7, 8, 15, 16, 17] {
                        start[i] *= cache.mm;
                    }
                    start
                })
                .collect(),
            _ => {
                return Err(FitError::DriverStart {
                    frames: perf.frames.len(),
                    driven: driven.map_or(0, <[_]>::len),
                });
            }
        },
    })
}

/// Per frame, where F_T starts (its zero output): the head at the rigid motion (Horn) that best
/// takes the actor's neutral s0 to the frame's constrained vertices, and the jaw at rest; the
/// identity for both in a 2D fit, or when no rigid motion aligns them.
pub(super) fn rigid_start(
    cache: &ActorCache,
    perf: &Performance,
    mode: Mode,
    subset: Option<&[i64]>,
    mm: f32,
) -> Vec<[f32; 18]> {
    if mode == Mode::TwoD {
        return vec![IDENTITY_18; perf.frames.len()];
    }
    let rest: Vec<[f32; 3]> = cache
        .rest
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    let chosen: Vec<usize> = match subset {
        Some(s) => s.iter().map(|&i| i as usize).collect(),
        None => (0..rest.len()).collect(),
    };
    let from: Vec<[f32; 3]> = chosen.iter().map(|&i| rest[i]).collect();
    perf.frames
        .iter()
        .map(|frame| {
            let to: Vec<[f32; 3]> = chosen.iter().map(|&i| frame[i].map(|x| x * mm)).collect();
            match fit_rigid(&from, &to) {
                Some(r) => {
                    let mut start = IDENTITY_18;
                    for i in 0..3 {
                        // 6D: the rotation's first two columns.
                        start[i] = r.rotation[i][0] as f32;
                        start[3 + i] = r.rotation[i][1] as f32;
                        start[6 + i] = r.translation[i] as f32;
                    }
                    start
                }
                None => IDENTITY_18,
            }
        })
        .collect()
}

/// The vertices a 3D fit may draw from (`None`: all of them), or the landmark vertices of a 2D
/// fit; a fraction is drawn once, seeded.
pub(super) fn constrained_vertices(
    perf: &Performance,
    config: &FitConfig,
    rng: &mut Stream,
) -> Result<Option<Vec<i64>>, FitError> {
    let v = perf.frames.first().map_or(0, Vec::len);
    let landmarks = || -> Result<Vec<i64>, FitError> {
        let l = &perf.manifest.landmarks.vertices;
        if l.is_empty() || !l.iter().all(|&i| (i as usize) < v) {
            return Err(FitError::Landmarks {
                path: perf.dir.join("performance.json"),
            });
        }
        Ok(l.iter().map(|&i| i64::from(i)).collect())
    };
    Ok(match (config.mode, config.constrain) {
        (Mode::TwoD, _) | (Mode::ThreeD, Constrain::Landmarks) => Some(landmarks()?),
        (Mode::ThreeD, Constrain::All) => None,
        (Mode::ThreeD, Constrain::Fraction(p)) => {
            let n = ((p * v as f32).round() as usize).clamp(1, v.max(1));
            // A seeded partial Fisher–Yates shuffle: the first n of a random permutation.
            let mut all: Vec<i64> = (0..v as i64).collect();
            for i in 0..n {
                let r = i + rng.below(v - i);
                all.swap(i, r);
            }
            all.truncate(n);
            Some(all)
        }
    })
}
