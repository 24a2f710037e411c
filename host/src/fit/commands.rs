//! The work behind `sinew fit` and `sinew eval fit`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};

use crate::fit::aim::{Coefficients, Constrain, FitConfig, FitResult, Mode, Start, fit, fit_from};
use crate::fit::bake::{bake, play};
use crate::fit::baseline::{Basis, Gbs, PATCH_GRID, Pbs, actor_shape_names, fit_performance};
use crate::fit::checkpoint::Checkpointing;
use crate::fit::retarget::{Input, RetargetReport, SourceFit, create_output, write_parts};
use crate::io::container::{self, read_actor};
use crate::io::mesh::Mesh;
use crate::io::performance::Performance;
use crate::training::backend::Backend;

/// Where a landmark driver put each frame's head and jaw, for `sinew fit --start driver`.
#[derive(Clone, Debug)]
pub struct DrivenStarts {
    /// The driver file.
    pub driver: PathBuf,
    /// Its content hash (16 hex digits), so that a fit resumed from another driver's answer is
    /// refused.
    pub driver_hash: String,
    /// Per frame, the head (9) and the jaw (9) the driver gave.
    pub starts: Vec<[f32; 18]>,
}

/// The `sinew fit` report: the fit without its meshes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitReport {
    /// Frames fitted.
    pub frames: usize,
    /// The fit.
    pub fit: FitResult,
}

/// `sinew fit`: fits the actor to the performance, checkpointing into `OUT.ckpt/` (or
/// continuing from `resume`); bakes the fit into `out` (a `.sinew` performance, docs/FORMAT.md),
/// writes the core's playback of it into `OUT_STEM.meshes/` and the report (with per-frame head,
/// jaw and, for a global fit, coefficients). With `driven` (and [`Start::Driver`]), each frame's
/// head and jaw start where a landmark driver put them for the performance's own track
/// (`crate::driver::commands::driven_starts`).
#[allow(clippy::too_many_arguments)]
pub fn fit_command(
    model: &Path,
    target: &Path,
    out: &Path,
    report: &Path,
    config: &FitConfig,
    resume: Option<&Path>,
    driven: Option<DrivenStarts>,
    backend: Backend,
) -> Result<FitReport> {
    let bytes = container::read(model)?;
    let actor = container::actor(model, &bytes)?;
    let perf = Performance::read(target)?;
    let own = crate::training::checkpoint::checkpoint_dir_for(out);
    let checkpoints = Checkpointing {
        dir: resume.unwrap_or(&own),
        resume: resume.is_some(),
    };
    let (config, driven) = match (config.start, driven) {
        (Start::Driver, Some(d)) => {
            let config = FitConfig {
                driver: Some(d.driver_hash),
                ..config.clone()
            };
            (config, Some(d.starts))
        }
        (Start::Driver, None) => bail!("--start driver needs the driver (--driver D.sinew)"),
        (_, Some(d)) => bail!(
            "{}: a driver is only read with --start driver",
            d.driver.display()
        ),
        (_, None) => (config.clone(), None),
    };
    let result = fit_from(
        &actor,
        &perf,
        &config,
        backend,
        Some(checkpoints),
        driven.as_deref(),
    )?;
    let baked = bake(&bytes, &result)?;
    let (played, _) = play(&bytes, &baked)?;
    let stem = out
        .file_stem()
        .map_or_else(|| "fit".into(), |s| s.to_string_lossy().into_owned());
    let mesh_dir = out
        .parent()
        .unwrap_or(Path::new("."))
        .join(format!("{stem}.meshes"));
    for (f, mesh) in played.iter().enumerate() {
        let vertices = mesh.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        Mesh::new(vertices, perf.polygons.clone())
            .write(&mesh_dir.join(format!("frame_{f:05}.obj")))?;
    }
    crate::io::atomic::write(out, &baked)?;
    let r = FitReport {
        frames: perf.frames.len(),
        fit: result,
    };
    crate::io::atomic::write(report, &serde_json::to_vec_pretty(&r)?)?;
    Ok(r)
}

/// `sinew play --performance`: plays a baked performance on its actor through the core, one OBJ
/// per frame in `out`; returns the frame count.
pub fn play_performance(model: &Path, performance: &Path, out: &Path) -> Result<usize> {
    let bytes = container::read(model)?;
    let actor = container::actor(model, &bytes)?;
    let baked = crate::io::container::read(performance)?;
    let (frames, _) = play(&bytes, &baked).with_context(|| {
        format!(
            "{}: cannot play on {}",
            performance.display(),
            model.display()
        )
    })?;
    let mesh = Mesh::of_actor(&actor);
    for (f, positions) in frames.iter().enumerate() {
        let p = crate::io::mesh::points(positions.iter().copied());
        mesh.with_positions(p)
            .write(&out.join(format!("frame_{f:05}.obj")))?;
    }
    Ok(frames.len())
}

/// One method's line of the `sinew eval fit` report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MethodLine {
    /// Mean per-vertex error over all frames, mm.
    pub mean_error_mm: f64,
    /// Wall-clock seconds per frame.
    pub seconds_per_frame: f64,
    /// AIM fits: mean landmark reprojection error, pixels.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub reprojection_px: Option<f64>,
    /// AIM fits: the largest relative edge-length change from the actor's neutral.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub worst_edge_change: Option<f64>,
}

impl MethodLine {
    fn of_fit(r: &FitResult) -> Self {
        Self {
            mean_error_mm: r.mean_error_mm,
            seconds_per_frame: r.seconds_per_frame,
            reprojection_px: Some(r.reprojection_px),
            worst_edge_change: Some(r.worst_edge_change),
        }
    }
}

/// The `sinew eval fit` report (AIM's Table 1).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    /// Frames fitted.
    pub frames: usize,
    /// `gbs`, `pbs`, `aim_global`, `aim_local`.
    pub methods: BTreeMap<String, MethodLine>,
    /// The AIM fits' settings (`coefficients` aside).
    pub aim_config: FitConfig,
    /// The performance's own worst edge-length change from the actor's neutral, to read the
    /// fits' against.
    pub target_worst_edge_change: f64,
}

/// The AIM fits `sinew eval fit` runs: Table 1's two, and with `constraints` Fig. 7's sparse
/// and 2D ones.
fn aim_rows(config: &FitConfig, constraints: bool) -> Vec<(&'static str, FitConfig)> {
    let with = |coefficients, mode, constrain| FitConfig {
        coefficients,
        mode,
        constrain,
        ..config.clone()
    };
    let (local, all, three) = (Coefficients::Local, Constrain::All, Mode::ThreeD);
    let mut rows = vec![
        ("aim_global", with(Coefficients::Global, three, all)),
        ("aim_local", with(local, three, all)),
    ];
    if constraints {
        rows.push((
            "aim_local_10pct",
            with(local, three, Constrain::Fraction(0.1)),
        ));
        rows.push((
            "aim_local_landmarks",
            with(local, three, Constrain::Landmarks),
        ));
        rows.push(("aim_local_2d", with(local, Mode::TwoD, all)));
    }
    rows
}

/// `sinew eval fit`: GBS, PBS and the global and local AIM fits on one performance; with
/// `constraints` also the local fit to 10 % of the vertices, to the 68 landmarks, and to the 2D
/// landmark tracks (AIM Fig. 7, Sec. 4.2.1); with `heatmaps` the four methods' error heatmaps of
/// the first, middle and last frames side by side in that folder.
pub fn eval_fit(
    model: &Path,
    target: &Path,
    report: &Path,
    config: &FitConfig,
    constraints: bool,
    heatmaps: Option<&Path>,
    backend: Backend,
) -> Result<EvalReport> {
    let bytes = container::read(model)?;
    let actor = container::actor(model, &bytes)?;
    let perf = Performance::read(target)?;
    let names = actor_shape_names(model, &bytes)?;
    let basis = Basis::of_performance(&perf, &names)?;
    let mut methods = BTreeMap::new();
    let (gbs_meshes, gbs) = fit_performance(&Gbs::new(basis.clone()), &perf)?;
    let (pbs_meshes, pbs) = fit_performance(&Pbs::new(basis, PATCH_GRID), &perf)?;
    for (name, r) in [("gbs", gbs), ("pbs", pbs)] {
        methods.insert(
            name.to_owned(),
            MethodLine {
                mean_error_mm: r.mean_error_mm,
                seconds_per_frame: r.seconds_per_frame,
                reprojection_px: None,
                worst_edge_change: None,
            },
        );
    }
    let mut target_worst_edge_change = 0.0;
    let mut fitted = vec![("GBS", gbs_meshes), ("PBS", pbs_meshes)];
    for (name, cfg) in aim_rows(config, constraints) {
        let r = fit(&actor, &perf, &cfg, backend)?;
        target_worst_edge_change = r.target_worst_edge_change;
        methods.insert(name.to_owned(), MethodLine::of_fit(&r));
        match name {
            "aim_global" => fitted.push(("AIM (G)", r.meshes)),
            "aim_local" => fitted.push(("AIM", r.meshes)),
            _ => {}
        }
    }
    if let Some(dir) = heatmaps {
        let j = perf.frames.len();
        let mut frames = vec![0, j / 2, j.saturating_sub(1)];
        frames.dedup();
        let panels: Vec<(&str, &[Vec<[f32; 3]>])> =
            fitted.iter().map(|(n, m)| (*n, m.as_slice())).collect();
        crate::fit::heatmaps::write(&perf, &panels, &frames, dir)?;
    }
    let r = EvalReport {
        frames: perf.frames.len(),
        methods,
        aim_config: config.clone(),
        target_worst_edge_change,
    };
    crate::io::atomic::write(report, &serde_json::to_vec_pretty(&r)?)?;
    Ok(r)
}

/// `sinew retarget`: the source's performance (fitted now or baked before) played on the target,
/// written to `out`: `target.sinew`, `jaw.sinew`, `soft.sinew` (performances of the target),
/// one OBJ per frame of each in `target/`, `jaw/`, `soft/`, `strip.png` (rows: `strip` frames;
/// columns: the source as fitted, the target, jaw only, soft tissue only) and `report.json`.
/// With a performance folder the source's fit goes to `source.sinew` (and its report and
/// meshes beside it).
pub fn retarget_command(
    source: &Path,
    target: &Path,
    input: &SourceFit,
    out: &Path,
    strip: Option<&[usize]>,
) -> Result<RetargetReport> {
    let source_bytes = read_actor(source)?;
    let target_bytes = read_actor(target)?;
    create_output(out)?;
    let (fit_path, fit_seconds, fit_error) = match input {
        SourceFit::Baked(path) => (path.clone(), None, None),
        SourceFit::Fit {
            performance,
            config,
            backend,
        } => {
            let path = out.join("source.sinew");
            let start = Instant::now();
            let r = fit_command(
                source,
                performance,
                &path,
                &out.join("source.json"),
                config,
                None,
                None,
                *backend,
            )?;
            let seconds = start.elapsed().as_secs_f64() / r.frames.max(1) as f64;
            (path, Some(seconds), Some(r.fit.mean_error_mm))
        }
    };
    let parts = write_parts(
        Input {
            path: source,
            bytes: &source_bytes,
        },
        Input {
            path: target,
            bytes: &target_bytes,
        },
        &fit_path,
        out,
        strip,
    )?;
    parts.strip.save_png(&out.join("strip.png"))?;
    let report = RetargetReport {
        frames: parts.frames,
        source: source.to_owned(),
        target: target.to_owned(),
        performance: out.join("target.sinew"),
        fit_seconds_per_frame: fit_seconds,
        fit_mean_error_mm: fit_error,
        seconds_per_frame: parts.seconds_per_frame,
        strip_frames: parts.strip_frames,
        correspondence: parts.plan.correspondence().to_owned(),
        shapes_at_rest: parts.plan.unmatched.clone(),
    };
    crate::io::atomic::write(
        &out.join("report.json"),
        &serde_json::to_vec_pretty(&report)?,
    )?;
    Ok(report)
}
