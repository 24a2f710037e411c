//! The driver measured against a performance's ground truth: the mean per-vertex distance of the
//! driven actor to the performance's meshes (mm), frame by frame and over the frames it performs
//! (after its frames at rest), what became of each frame under the live rules, and the core's
//! time per frame.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use sinew_core::live::Settings;

use super::drive::{Bound, DriveError, drive_track, meshes};
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
    /// The mean over the frames the performance performs (from its `rest_frames` on, which a
    /// calibration takes): the figure to compare across tracks with and without a calibration.
    pub performing_error_mm: f64,
    /// The largest frame error over the frames the performance performs.
    pub worst_frame_error_mm: f64,
    /// Frames the live rules found lost (their pose held).
    pub lost_frames: Vec<usize>,
    /// Frames the track has no landmarks for.
    pub missing_frames: Vec<usize>,
    /// What became of each frame (`driven`, `calibrating`, `missing`, `lost-residual`,
    /// `lost-jump`).
    pub outcomes: Vec<String>,
    /// The calibration's deviation (face sizes), and the frames above `drive::UNSTEADY`.
    pub calibration_deviation: Option<f32>,
    /// Calibration frames where the face was not at rest.
    pub unsteady_frames: Vec<usize>,
    /// Each calibration frame's deviation from the calibration's mean, in face sizes.
    pub calibration_frame_deviation: Vec<f32>,
    /// Per frame driven, its residual in face sizes (what the lost-frame rule bounds).
    pub frame_residual: Vec<Option<f32>>,
    /// Seconds per frame of the core's driver alone (landmarks to pose), best of 5 passes.
    pub drive_seconds_per_frame: f64,
    /// Seconds per frame of the driver and the actor's posing through the core.
    pub seconds_per_frame: f64,
    /// The driven poses, `[18 + M]` per frame.
    pub poses: Vec<Vec<f32>>,
}

/// Drives `bound` with `track` under `settings` and compares with `perf`'s meshes (`unit_mm`
/// millimetres per unit).
///
/// # Errors
/// As [`super::drive::drive_track`].
pub fn measure(
    bound: &Bound<'_>,
    driver_path: &std::path::Path,
    track: &Track,
    perf: &Performance,
    unit_mm: f64,
    settings: Settings,
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
    let run = drive_track(bound, driver_path, track, settings, None)?;
    let poses = run.poses.clone();
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
    let performing = &frame_error_mm[perf.manifest.rest_frames.min(frame_error_mm.len())..];
    Ok(DriverMeasure {
        frames: poses.len(),
        mean_error_mm: frame_error_mm.iter().sum::<f64>() / frame_error_mm.len().max(1) as f64,
        performing_error_mm: performing.iter().sum::<f64>() / performing.len().max(1) as f64,
        worst_frame_error_mm: performing.iter().copied().fold(0.0, f64::max),
        lost_frames: run.lost(),
        missing_frames: run.missing(),
        outcomes: run.outcomes.iter().map(|o| o.name().to_owned()).collect(),
        calibration_deviation: run.calibration.as_ref().map(|c| c.deviation),
        unsteady_frames: run
            .calibration
            .as_ref()
            .map(|c| c.unsteady.clone())
            .unwrap_or_default(),
        frame_residual: run.residuals.clone(),
        calibration_frame_deviation: run
            .calibration
            .as_ref()
            .map(|c| c.frame_deviation.clone())
            .unwrap_or_default(),
        frame_error_mm,
        drive_seconds_per_frame: best,
        seconds_per_frame: seconds,
        poses,
    })
}
