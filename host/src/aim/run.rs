//! One AIM run end to end: train (or resume), bake, measure through the core, and write the
//! report, the configuration, the loss curve and the pictures.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use serde::Serialize;
use sinew_core::aim::AimActor;

use super::bake::{BakeInput, bake, metadata};
use super::eval::{SkinningWeightMeans, shape_errors, thickness_deviation};
use super::train::{TERMS, TrainOptions, Trained, train};
use super::{AimConfig, ErrorStats, TrainingSet};
use crate::figures::render::{Image, View, render_heatmap};

/// The JSON report of `sinew train aim` and `sinew eval aim`.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// Training shapes N (neutral included).
    pub shapes: usize,
    /// Their names, neutral first.
    pub shape_names: Vec<String>,
    /// Template vertices V.
    pub vertices: usize,
    /// Optimisation steps run.
    pub iterations: usize,
    /// Training wall-clock seconds.
    pub seconds: f64,
    /// Per-vertex error over all training shapes, mm.
    pub mean_error_mm: f64,
    /// Median, mm.
    pub median_error_mm: f64,
    /// 95th percentile, mm.
    pub p95_error_mm: f64,
    /// Maximum, mm.
    pub max_error_mm: f64,
    /// Per-shape errors, mm.
    pub per_shape: Vec<(String, ErrorStats)>,
    /// Fraction of template vertices with a bone constraint.
    pub constrained_fraction: f64,
    /// Template vertices whose learned thickness is negative.
    pub negative_thickness_count: usize,
    /// |learned − constrained thickness| over constrained vertices, mm.
    pub thickness_deviation_mm: ErrorStats,
    /// Mean learned jaw skinning weight k over the jaw-constrained vertices and the forehead.
    pub skinning_weight: SkinningWeightMeans,
    /// Data unit and source.
    pub units: crate::io::units::Unit,
    /// Where the data came from.
    pub source: String,
    /// The configuration used.
    pub config: AimConfig,
    /// The backend used.
    pub backend: crate::training::backend::Backend,
    /// The baked model file.
    pub model: String,
}

/// Where a run writes.
#[derive(Clone, Debug)]
pub struct Outputs {
    /// The baked model.
    pub model: PathBuf,
    /// The JSON report.
    pub report: PathBuf,
    /// Folder for pictures and OBJs (`None`: no pictures).
    pub pictures: Option<PathBuf>,
}

/// Trains, bakes, evaluates and reports.
pub fn run(
    set: &TrainingSet,
    config: &AimConfig,
    options: &TrainOptions,
    out: &Outputs,
) -> Result<Report> {
    let Trained {
        model,
        state,
        complete,
    } = train(set, config, options)?;
    anyhow::ensure!(
        complete,
        "training stopped at step {} of {}",
        state.steps_done,
        config.iterations
    );
    let device = options.backend.device(config.seed)?;
    let triangles = set.template.triangles();
    let input = BakeInput {
        points: &set.template.positions,
        triangles: &triangles,
        jaw_pivot: set.jaw_pivot,
        normalisation: state.normalisation,
        playback_only: false,
        metadata: metadata(set, config)?,
    };
    let (bytes, _) = bake(&model, &input, &device)?;
    crate::io::atomic::write(&out.model, &bytes)?;
    crate::io::atomic::write(
        &out.model.with_extension("config.json"),
        serde_json::to_string_pretty(config)?.as_bytes(),
    )?;

    let report = evaluate(
        &bytes,
        set,
        config,
        options.backend,
        state.seconds,
        state.steps_done,
        &out.model,
    )?;
    crate::io::atomic::write(
        &out.report,
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    if let Some(dir) = &out.pictures {
        let series: Vec<(&str, Vec<(f64, f64)>)> = TERMS
            .iter()
            .enumerate()
            .map(|(t, name)| {
                (
                    *name,
                    state
                        .history
                        .iter()
                        .map(|r| (r.step as f64, f64::from(r.terms[t])))
                        .collect(),
                )
            })
            .collect();
        let borrowed: Vec<(&str, &[(f64, f64)])> =
            series.iter().map(|(n, s)| (*n, s.as_slice())).collect();
        crate::figures::plot::loss_curves(&borrowed, "AIM training loss", true, 900, 600)
            .write_png(&dir.join("loss.png"))?;
        pictures(&bytes, set, dir)?;
    }
    Ok(report)
}

/// Measures a baked actor on its training set.
pub fn evaluate(
    bytes: &[u8],
    set: &TrainingSet,
    config: &AimConfig,
    backend: crate::training::backend::Backend,
    seconds: f64,
    iterations: usize,
    model: &Path,
) -> Result<Report> {
    let actor =
        AimActor::from_bytes(bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let errors = shape_errors(&actor, &set.names, &set.shapes, set.mm_per_unit)?;
    let thickness = actor.thickness();
    Ok(Report {
        shapes: set.shapes.len(),
        shape_names: set.names.clone(),
        vertices: set.vertices(),
        iterations,
        seconds,
        mean_error_mm: errors.overall.mean,
        median_error_mm: errors.overall.median,
        p95_error_mm: errors.overall.p95,
        max_error_mm: errors.overall.max,
        per_shape: errors.per_shape,
        constrained_fraction: set.constrained_fraction(),
        negative_thickness_count: thickness.iter().filter(|&d| d < 0.0).count(),
        thickness_deviation_mm: thickness_deviation(&actor, &set.anchors, set.mm_per_unit),
        skinning_weight: SkinningWeightMeans::of(
            &actor.skinning_weights().iter().collect::<Vec<_>>(),
            set,
        ),
        units: set.units,
        source: set.source.clone(),
        config: config.clone(),
        backend,
        model: model.display().to_string(),
    })
}

/// The pictures people look at: error heatmap (0–1 mm), anatomy surface with thickness, skinning
/// weights; and OBJs of the skin and the anatomy surface.
pub fn pictures(bytes: &[u8], set: &TrainingSet, dir: &Path) -> Result<()> {
    let actor = AimActor::from_bytes(bytes).map_err(|e| anyhow::anyhow!("model: {e}"))?;
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create folder", dir.display()))?;
    let errors = shape_errors(&actor, &set.names, &set.shapes, set.mm_per_unit)?;
    let tri = set.template.triangles();
    let view = View {
        yaw_deg: 20.0,
        pitch_deg: 0.0,
        width: 640,
        height: 640,
    };
    let skin: Vec<[f32; 3]> = crate::io::mesh::points(actor.rest().iter());
    let worst = errors
        .per_shape
        .iter()
        .enumerate()
        .skip(1)
        .max_by(|a, b| a.1.1.mean.total_cmp(&b.1.1.mean))
        .map_or(0, |(i, _)| i);
    let poses = super::eval::training_poses(&actor)?;
    let posed = super::eval::pose_training_shape(&actor, &poses[worst], worst);
    let posed: Vec<[f32; 3]> = crate::io::mesh::points(posed.iter().copied());
    let err_neutral = render_heatmap(
        &skin,
        &tri,
        &errors.per_shape_vertex[0],
        0.0,
        1.0,
        "error mm",
        "neutral: error",
        &view,
    );
    let err_worst = render_heatmap(
        &posed,
        &tri,
        &errors.per_shape_vertex[worst],
        0.0,
        1.0,
        "error mm",
        &format!("{}: error", set.names[worst]),
        &view,
    );
    Image::hstack(&[err_neutral, err_worst]).write_png(&dir.join("error.png"))?;

    let anatomy = anatomy_surface(bytes)?;
    let d_mm: Vec<f32> = actor
        .thickness()
        .iter()
        .map(|d| d * set.mm_per_unit)
        .collect();
    let hi = d_mm.iter().copied().fold(1.0f32, f32::max);
    let thick = render_heatmap(
        &anatomy,
        &tri,
        &d_mm,
        0.0,
        hi,
        "thickness mm",
        "learned anatomy",
        &view,
    );
    let k: Vec<f32> = actor.skinning_weights().iter().collect();
    let weights = render_heatmap(&skin, &tri, &k, 0.0, 1.0, "k", "jaw skinning weight", &view);
    Image::hstack(&[thick, weights]).write_png(&dir.join("anatomy.png"))?;
    set.template
        .with_positions(skin)
        .write(&dir.join("skin.obj"))?;
    set.template
        .with_positions(anatomy)
        .write(&dir.join("anatomy.obj"))?;
    Ok(())
}

/// The learned anatomy surface b0 at the template vertices.
pub fn anatomy_surface(bytes: &[u8]) -> Result<Vec<[f32; 3]>> {
    let file =
        sinew_core::SinewFile::from_bytes(bytes).map_err(|e| anyhow::anyhow!("model: {e}"))?;
    let b = file
        .section("cache.b0")
        .and_then(|s| s.f32s())
        .context("model has no cache.b0")?;
    Ok(crate::io::mesh::points(b.iter()))
}
