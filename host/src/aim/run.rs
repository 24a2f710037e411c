//! One AIM run end to end: train (or resume), bake, measure through the core, and write the
//! report, the configuration, the loss curve and the pictures.

use std::path::{Path, PathBuf};

use serde::Serialize;
use sinew_core::FormatError;
use sinew_core::aim::AimActor;

use super::bake::{BakeInput, bake, metadata};
use super::eval::{EvalError, SkinningWeightMeans, shape_errors, thickness_deviation};
use super::train::{TERMS, TrainError, TrainOptions, Trained, train};
use super::{AimConfig, ErrorStats, TrainingSet};
use crate::figures::render::{Image, PngError, View, render_heatmap};
use crate::io::atomic::AtomicWriteError;
use crate::io::container::{ContainerError, WriterError};
use crate::io::mesh::MeshError;

/// Why an AIM run (train, bake, measure, report) or its pictures failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RunError {
    /// Training failed or was interrupted.
    #[error(transparent)]
    Train(#[from] TrainError),
    /// Training ended before its last step.
    #[error("training stopped at step {steps_done} of {iterations}")]
    Incomplete {
        /// The steps done.
        steps_done: usize,
        /// The steps configured.
        iterations: usize,
    },
    /// The configuration or report could not be laid out as JSON.
    #[error(transparent)]
    Json(serde_json::Error),
    /// The baked actor could not be laid out.
    #[error(transparent)]
    Bake(#[from] WriterError),
    /// The template's texture coordinates could not be recorded.
    #[error(transparent)]
    Uv(crate::geometry::uv::UvError),
    /// The model, configuration or report could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// The model file is not an AIM actor (the error names it).
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The model's bytes are not an AIM actor (no file involved).
    #[error("model")]
    Model(#[source] FormatError),
    /// The baked actor lacks its anatomy cache.
    #[error("model has no cache.b0")]
    NoAnatomyCache,
    /// The actor could not be measured against its training shapes.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// The pictures' folder could not be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// A picture could not be written.
    #[error(transparent)]
    Png(#[from] PngError),
    /// An OBJ could not be written.
    #[error(transparent)]
    Mesh(#[from] MeshError),
}

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
    /// Per shape, the angle of the jaw rotation learned for it, in degrees (the jaw's part of
    /// the shape: on ICT-FaceKit, jawOpen turns the jaw by well over 10°).
    pub jaw_degrees: Vec<(String, f64)>,
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
    /// What ended the training (`target` or `steps`; absent when only measuring).
    pub ended: Option<super::target::Ending>,
    /// The accuracy the run aimed for, if any.
    pub target: Option<super::target::Target>,
    /// The accuracy checks made on the way.
    pub checks: Vec<super::target::Check>,
    /// How far the last check was from the target, when the step limit came first.
    pub missed: Vec<String>,
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
) -> Result<Report, RunError> {
    let Trained {
        model,
        state,
        complete,
        ending,
    } = train(set, config, options)?;
    if !complete {
        return Err(RunError::Incomplete {
            steps_done: state.steps_done,
            iterations: config.iterations,
        });
    }
    let device = options
        .backend
        .device(config.seed)
        .map_err(TrainError::backend)?;
    let triangles = set.template.triangles();
    let mut recorded = metadata(set, config).map_err(RunError::Json)?;
    // Where the run started, recorded in its checkpoint.
    recorded.extend(
        state
            .metadata
            .iter()
            .filter(|(k, _)| k == crate::aim::prior::METADATA_KEY)
            .cloned(),
    );
    recorded.extend(
        crate::aim::bake::uv_metadata(&recorded, &set.template, &triangles, None)
            .map_err(RunError::Uv)?,
    );
    let input = BakeInput {
        points: &set.template.positions,
        triangles: &triangles,
        jaw_pivot: set.jaw_pivot,
        normalisation: state.normalisation,
        playback_only: false,
        metadata: recorded,
    };
    let (bytes, _) = bake(&model, &input, &device)?;
    crate::io::atomic::write(&out.model, &bytes)?;
    crate::io::atomic::write(
        &out.model.with_extension("config.json"),
        serde_json::to_string_pretty(config)
            .map_err(RunError::Json)?
            .as_bytes(),
    )?;

    let mut report = evaluate(
        &bytes,
        set,
        config,
        options.backend,
        state.seconds,
        state.steps_done,
        &out.model,
    )?;
    if let Some(target) = &options.target {
        report.missed = match (&ending, state.checks.as_slice()) {
            (super::target::Ending::Steps, [.., previous, last]) => {
                target.shortfall(last, Some(previous))
            }
            (super::target::Ending::Steps, [last]) => target.shortfall(last, None),
            _ => Vec::new(),
        };
    }
    report.ended = Some(ending);
    report.target.clone_from(&options.target);
    report.checks = state.checks.clone();
    crate::io::atomic::write(
        &out.report,
        serde_json::to_string_pretty(&report)
            .map_err(RunError::Json)?
            .as_bytes(),
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
            .save_png(&dir.join("loss.png"))?;
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
) -> Result<Report, RunError> {
    let actor = crate::io::container::actor(model, bytes)?;
    let errors = shape_errors(&actor, &set.names, &set.shapes, set.mm_per_unit)?;
    let jaw_degrees = crate::aim::eval::training_poses(&actor)?
        .iter()
        .zip(&set.names)
        .skip(1)
        .map(|(pose, name)| (name.clone(), super::eval::rotation_degrees(pose)))
        .collect();
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
        jaw_degrees,
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
        ended: None,
        target: None,
        checks: Vec::new(),
        missed: Vec::new(),
    })
}

/// The views every figure shows, as (yaw in degrees, name): the front and a three-quarter view.
pub const VIEWS: [(f32, &str); 2] = [(0.0, "front"), (-35.0, "three-quarter")];

/// The pictures people look at, each from the front and from three-quarters: error heatmaps
/// (0–1 mm) of the neutral and the worst expression (`error.png`), the anatomy surface coloured by
/// thickness and the skin by skinning weight (`anatomy.png`); and OBJs of the skin and the
/// anatomy surface.
pub fn pictures(bytes: &[u8], set: &TrainingSet, dir: &Path) -> Result<(), RunError> {
    let actor = AimActor::from_bytes(bytes).map_err(RunError::Model)?;
    crate::io::atomic::create_folder(dir, "folder")?;
    let errors = shape_errors(&actor, &set.names, &set.shapes, set.mm_per_unit)?;
    let tri = set.template.triangles();
    let skin: Vec<[f32; 3]> = crate::io::mesh::points(actor.rest().iter());
    let worst = errors
        .per_shape
        .iter()
        .enumerate()
        .skip(1)
        .max_by(|a, b| a.1.1.mean.total_cmp(&b.1.1.mean))
        .map_or(0, |(i, _)| i);
    let poses = super::eval::training_poses(&actor)?;
    let posed = super::eval::pose_training_shape(&actor, &poses[worst], worst)?;
    let posed: Vec<[f32; 3]> = crate::io::mesh::points(posed.iter().copied());
    // Each figure from the front and from three-quarters, side by side.
    let both = |positions: &[[f32; 3]], values: &[f32], hi: f32, label: &str, title: &str| {
        let panels: Vec<Image> = VIEWS
            .iter()
            .map(|&(yaw_deg, side)| {
                let view = View {
                    yaw_deg,
                    pitch_deg: 0.0,
                    width: 480,
                    height: 480,
                };
                let title = format!("{title}, {side}");
                render_heatmap(positions, &tri, values, 0.0, hi, label, &title, &view)
            })
            .collect();
        Image::hstack(&panels)
    };
    let neutral = both(
        &skin,
        &errors.per_shape_vertex[0],
        1.0,
        "error mm",
        "neutral: error",
    );
    let worst_img = both(
        &posed,
        &errors.per_shape_vertex[worst],
        1.0,
        "error mm",
        &format!("{}: error", set.names[worst]),
    );
    Image::vstack(&[neutral, worst_img]).save_png(&dir.join("error.png"))?;

    let anatomy = anatomy_surface(bytes)?;
    let d_mm: Vec<f32> = actor
        .thickness()
        .iter()
        .map(|d| d * set.mm_per_unit)
        .collect();
    let hi = d_mm.iter().copied().fold(1.0f32, f32::max);
    // The anatomy is drawn where it is bone: see [`bone_triangles`].
    let bone_tri = bone_triangles(&set.anchors, &skin, &anatomy, &tri);
    let thick = {
        let panels: Vec<Image> = VIEWS
            .iter()
            .map(|&(yaw_deg, side)| {
                let view = View {
                    yaw_deg,
                    pitch_deg: 0.0,
                    width: 480,
                    height: 480,
                };
                let title = format!("learned anatomy under bone, {side}");
                render_heatmap(
                    &anatomy,
                    &bone_tri,
                    &d_mm,
                    0.0,
                    hi,
                    "thickness mm",
                    &title,
                    &view,
                )
            })
            .collect();
        Image::hstack(&panels)
    };
    let k: Vec<f32> = actor.skinning_weights().iter().collect();
    let weights = both(&skin, &k, 1.0, "k (0-1)", "jaw skinning weight");
    Image::vstack(&[thick, weights]).save_png(&dir.join("anatomy.png"))?;
    set.template
        .with_positions(skin)
        .write(&dir.join("skin.obj"))?;
    set.template
        .with_positions(anatomy)
        .write(&dir.join("anatomy.obj"))?;
    Ok(())
}

/// Largest ratio of a triangle edge's length on the anatomy surface to its length on the skin for
/// [`bone_triangles`].
pub const MAX_BONE_STRETCH: f32 = 3.0;

/// The triangles of the anatomy figure: those whose three corners have a bone constraint and
/// whose edges on the anatomy surface `bone` are at most [`MAX_BONE_STRETCH`] times as long as on
/// the `skin`. The others are not a bone surface: where no bone lies within
/// `max_constraint_depth` (nose cartilage, eyelids, lips, ears, the neck) only L_D acts and the
/// learned thickness goes to zero, so b0 sits on the skin beside constrained neighbours up to
/// 2.5 cm deeper; and neighbouring constraints whose rays reach different bones (the nasal bone
/// and the maxilla behind the piriform aperture, the zygoma and the orbit floor) are joined by
/// triangles across the gap. Drawn, both made the spikes of earlier anatomy pictures
/// (docs/AIM.md, "The anatomy picture").
pub fn bone_triangles(
    anchors: &[Option<super::Anchor>],
    skin: &[[f32; 3]],
    bone: &[[f32; 3]],
    triangles: &[[u32; 3]],
) -> Vec<[u32; 3]> {
    let dist = |p: &[[f32; 3]], a: usize, b: usize| -> Option<f32> {
        let (a, b) = (p.get(a)?, p.get(b)?);
        Some((0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f32>().sqrt())
    };
    triangles
        .iter()
        .copied()
        .filter(|t| {
            let v = t.map(|i| i as usize);
            v.iter()
                .all(|&i| anchors.get(i).is_some_and(Option::is_some))
                && (0..3).all(|e| {
                    let (a, b) = (v[e], v[(e + 1) % 3]);
                    matches!(
                        (dist(bone, a, b), dist(skin, a, b)),
                        (Some(db), Some(ds)) if db <= MAX_BONE_STRETCH * ds
                    )
                })
        })
        .collect()
}

/// The learned anatomy surface b0 at the template vertices.
pub fn anatomy_surface(bytes: &[u8]) -> Result<Vec<[f32; 3]>, RunError> {
    let file = sinew_core::SinewFile::from_bytes(bytes).map_err(RunError::Model)?;
    let b = file
        .section("cache.b0")
        .and_then(|s| s.f32s())
        .ok_or(RunError::NoAnatomyCache)?;
    Ok(crate::io::mesh::points(b.iter()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::anatomy::constraints::Bone;

    #[test]
    fn the_anatomy_figure_keeps_bone_and_drops_the_gaps() {
        // Four skin vertices in a unit square over a bone 1 cm deep; vertex 3 has no constraint.
        let skin = [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
            [1.0, 1.0, 1.0],
        ];
        let anchor = |p: [f32; 3]| {
            Some(super::super::Anchor {
                bone: [p[0], p[1], 0.0],
                thickness: 1.0,
                normal: [0.0, 0.0, 1.0],
                on: Bone::Skull,
            })
        };
        let mut anchors: Vec<_> = skin.iter().map(|&p| anchor(p)).collect();
        anchors[3] = None;
        let tri = [[0, 1, 2], [1, 3, 2]];
        let mut bone: Vec<[f32; 3]> = skin.iter().map(|p| [p[0], p[1], 0.0]).collect();
        assert_eq!(
            bone_triangles(&anchors, &skin, &bone, &tri),
            vec![[0, 1, 2]]
        );
        // All constrained: both stay, until a bone point jumps 5 cm deeper than its neighbours.
        anchors[3] = anchor(skin[3]);
        assert_eq!(bone_triangles(&anchors, &skin, &bone, &tri).len(), 2);
        bone[1][2] = -5.0;
        assert!(bone_triangles(&anchors, &skin, &bone, &tri).is_empty());
        // Indices beyond the vertices drop the triangle rather than panic.
        assert!(bone_triangles(&anchors, &skin, &bone, &[[0, 2, 9]]).is_empty());
    }

    #[test]
    fn damaged_models_and_blocked_folders_are_refused() {
        let golden = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/data/aim-procedural.sinew"
        ))
        .unwrap();
        let set = crate::aim::testing::procedural_training_set(8);
        let dir = tempfile::tempdir().unwrap();
        let err = pictures(&golden[..64], &set, dir.path()).unwrap_err();
        assert!(matches!(err, RunError::Model(_)), "{err}");
        let file = dir.path().join("a-file");
        std::fs::write(&file, b"").unwrap();
        let err = pictures(&golden, &set, &file.join("pictures")).unwrap_err();
        assert!(matches!(err, RunError::CreateFolder(_)), "{err}");
        let err = evaluate(
            &golden[..64],
            &set,
            &AimConfig::default(),
            crate::training::backend::Backend::Flex,
            0.0,
            0,
            &file,
        )
        .unwrap_err();
        assert!(
            matches!(&err, RunError::Container(ContainerError::NotAnActor { path, .. }) if *path == file),
            "{err}"
        );
        assert!(anatomy_surface(&golden).is_ok());
    }
}
