//! Per-frame error heatmaps of several fits side by side (AIM Fig. 6's presentation): each
//! method's fitted mesh coloured by its per-vertex distance to the performance, 0–1 mm, as the
//! training figures are.

use std::path::{Path, PathBuf};

use crate::figures::render::{Image, View, render_heatmap};
use crate::io::performance::Performance;

/// Heatmaps that could not be drawn or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HeatmapError {
    /// A method without a fitted mesh for a frame asked for.
    #[error("frame {frame}: {method} has no fitted mesh for it")]
    MissingFrame {
        /// The frame.
        frame: usize,
        /// The method.
        method: String,
    },
    /// A picture that cannot be written.
    #[error("{}: cannot write the heatmap", path.display())]
    Png {
        /// The picture's file.
        path: PathBuf,
        /// What the picture writer said.
        #[source]
        source: crate::figures::render::PngError,
    },
}

/// The top of the colour scale, mm.
pub const ERROR_SCALE_MM: f32 = 1.0;

/// Per-vertex distance in mm between `fit` and `target` (`unit_mm` millimetres per unit).
pub fn vertex_errors_mm(fit: &[[f32; 3]], target: &[[f32; 3]], unit_mm: f64) -> Vec<f32> {
    fit.iter()
        .zip(target)
        .map(|(a, b)| {
            let d2: f64 = (0..3)
                .map(|c| (f64::from(a[c]) - f64::from(b[c])).powi(2))
                .sum();
            (d2.sqrt() * unit_mm) as f32
        })
        .collect()
}

/// Writes `heatmap_FFFFF.png` into `out` for each of `frames`: one panel per method (its name
/// and the frame's mean error as the title), left to right in the order given. Returns the
/// files written.
pub fn write(
    perf: &Performance,
    methods: &[(&str, &[Vec<[f32; 3]>])],
    frames: &[usize],
    out: &Path,
) -> Result<Vec<PathBuf>, HeatmapError> {
    let unit_mm = perf.unit.mm();
    let triangles = fan_triangles(&perf.polygons);
    let mut written = Vec::new();
    for &f in frames {
        let target = perf.frames.get(f);
        let mut panels = Vec::new();
        for (name, meshes) in methods {
            let (Some(mesh), Some(target)) = (meshes.get(f), target) else {
                return Err(HeatmapError::MissingFrame {
                    frame: f,
                    method: (*name).to_owned(),
                });
            };
            let errors = vertex_errors_mm(mesh, target, unit_mm);
            let mean =
                errors.iter().map(|&e| f64::from(e)).sum::<f64>() / errors.len().max(1) as f64;
            panels.push(render_heatmap(
                mesh,
                &triangles,
                &errors,
                0.0,
                ERROR_SCALE_MM,
                "error mm",
                &format!("{name}, frame {f}: {mean:.3} mm"),
                &View::front(360, 420),
            ));
        }
        let path = out.join(format!("heatmap_{f:05}.png"));
        Image::hstack(&panels)
            .save_png(&path)
            .map_err(|e| HeatmapError::Png {
                path: path.clone(),
                source: e,
            })?;
        written.push(path);
    }
    Ok(written)
}

/// Polygons as triangles (fans from each polygon's first corner).
fn fan_triangles(polygons: &[Vec<u32>]) -> Vec<[u32; 3]> {
    polygons
        .iter()
        .flat_map(|p| (1..p.len().saturating_sub(1)).map(move |k| [p[0], p[k], p[k + 1]]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::aim::FitConfig;
    use crate::fit::commands::eval_fit;
    use crate::io::data::data_dir;
    use crate::performance::tests::golden_actor;
    use crate::performance::{PerformanceConfig, generate};
    use crate::training::backend::Backend;

    #[test]
    fn errors_are_distances_in_mm_and_polygons_fan_out() {
        let e = vertex_errors_mm(
            &[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]],
            &[[0.3, 0.4, 0.0], [1.0, 1.0, 1.0]],
            10.0,
        );
        assert!((e[0] - 5.0).abs() < 1e-6 && e[1] == 0.0, "{e:?}");
        assert_eq!(
            fan_triangles(&[vec![0, 1, 2, 3], vec![4, 5, 6]]),
            vec![[0, 1, 2], [0, 2, 3], [4, 5, 6]]
        );
    }

    /// Width and height from a PNG's IHDR chunk.
    fn png_size(path: &Path) -> (u32, u32) {
        let b = std::fs::read(path).unwrap();
        assert_eq!(&b[1..4], b"PNG");
        let word = |o: usize| u32::from_be_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        (word(16), word(20))
    }

    #[test]
    fn eval_fit_draws_the_four_methods_side_by_side() {
        let Some(data) = data_dir() else { return };
        let dir = tempfile::tempdir().unwrap();
        let perf = dir.path().join("perf");
        let config = PerformanceConfig {
            seed: 5,
            frames: 2,
            ..PerformanceConfig::default()
        };
        generate(
            &data.join("ict-facekit"),
            Some(&golden_actor()),
            &config,
            &perf,
        )
        .unwrap();
        let fit = FitConfig {
            iterations: 10,
            hidden: 16,
            code: 4,
            points: 256,
            ..FitConfig::default()
        };
        let maps = dir.path().join("maps");
        let report = dir.path().join("report.json");
        let r = eval_fit(
            &golden_actor(),
            &perf,
            &report,
            &fit,
            false,
            Some(&maps),
            Backend::Flex,
        )
        .unwrap();
        assert_eq!(r.methods.len(), 4);
        let mut files: Vec<_> = std::fs::read_dir(&maps)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        files.sort();
        assert_eq!(files, ["heatmap_00000.png", "heatmap_00001.png"]);
        let (w, h) = png_size(&maps.join(&files[0]));
        assert_eq!((w, h), (4 * 360, 420));
    }

    #[test]
    fn a_missing_fit_and_an_unwritable_folder_are_refused_by_variant() {
        let Some(data) = data_dir() else { return };
        let dir = tempfile::tempdir().unwrap();
        let perf_dir = dir.path().join("perf");
        let config = PerformanceConfig {
            frames: 1,
            ..PerformanceConfig::default()
        };
        generate(
            &data.join("ict-facekit"),
            Some(&golden_actor()),
            &config,
            &perf_dir,
        )
        .unwrap();
        let perf = Performance::read(&perf_dir).unwrap();
        let e = write(&perf, &[("GBS", &[])], &[0], dir.path()).unwrap_err();
        assert!(
            matches!(&e, HeatmapError::MissingFrame { frame: 0, method } if method == "GBS"),
            "{e:?}"
        );
        // The output "folder" is a file: the picture cannot be written there.
        let file = dir.path().join("a-file");
        std::fs::write(&file, b"not a folder").unwrap();
        let e = write(&perf, &[("GBS", &perf.frames)], &[0], &file).unwrap_err();
        assert!(
            matches!(&e, HeatmapError::Png { path, .. } if path.starts_with(&file)),
            "{e:?}"
        );
    }
}
