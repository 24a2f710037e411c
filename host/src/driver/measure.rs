//! The driver measured against a performance's ground truth: the mean per-vertex distance of the
//! driven actor to the performance's meshes (mm), and the core's time per frame.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::drive::{Bound, DriveError, meshes};
use super::track::Track;
use crate::io::performance::Performance;

/// The driver on one performance.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DriverMeasure {
    /// Frames.
    pub frames: usize,
    /// Mean per-vertex distance to the performance's meshes over every vertex of every frame, mm.
    pub mean_error_mm: f64,
    /// The same per frame.
    pub frame_error_mm: Vec<f64>,
    /// Seconds per frame of the core's driver alone (landmarks to pose), best of 5 passes.
    pub drive_seconds_per_frame: f64,
    /// Seconds per frame of the driver and the actor's posing through the core.
    pub seconds_per_frame: f64,
    /// The driven poses, `[18 + M]` per frame.
    pub poses: Vec<Vec<f32>>,
}

/// Drives `bound` with `track` and compares with `perf`'s meshes (`unit_mm` millimetres per
/// unit).
///
/// # Errors
/// As [`super::drive::poses`].
pub fn measure(
    bound: &Bound<'_>,
    driver_path: &std::path::Path,
    track: &Track,
    perf: &Performance,
    unit_mm: f64,
) -> Result<DriverMeasure, DriveError> {
    let d = &bound.driver;
    let mut scratch = vec![0.0; d.scratch_len()];
    let mut pose = vec![0.0; d.output_len()];
    let found: Vec<&Vec<f32>> = track.frames.iter().flatten().collect();
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        for l in &found {
            d.drive(l, &mut scratch, &mut pose)
                .map_err(|source| DriveError::Frame { frame: 0, source })?;
        }
        best = best.min(t.elapsed().as_secs_f64() / found.len().max(1) as f64);
    }
    let t = Instant::now();
    let poses = super::drive::poses(bound, driver_path, track, None)?;
    let driven = meshes(&bound.actor, &poses)?;
    let seconds = t.elapsed().as_secs_f64() / poses.len().max(1) as f64;
    let frame_error_mm: Vec<f64> = driven
        .iter()
        .zip(&perf.frames)
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(p, q)| {
                    (0..3)
                        .map(|c| f64::from(p[c] - q[c]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .sum::<f64>()
                / a.len().max(1) as f64
                * unit_mm
        })
        .collect();
    Ok(DriverMeasure {
        frames: poses.len(),
        mean_error_mm: frame_error_mm.iter().sum::<f64>() / frame_error_mm.len().max(1) as f64,
        frame_error_mm,
        drive_seconds_per_frame: best,
        seconds_per_frame: seconds,
        poses,
    })
}
