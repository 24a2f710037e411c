//! The work behind `sinew fit` and `sinew eval fit`.

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{Context, Result, anyhow};
use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use crate::fit::aim::{Coefficients, FitConfig, FitResult, fit};
use crate::fit::bake::{bake, play};
use crate::fit::baseline::{Basis, Gbs, PATCH_GRID, Pbs, actor_shape_names, fit_performance};
use crate::fit::performance::Performance;
use crate::io::mesh::Mesh;
use crate::training::backend::Backend;

/// The `sinew fit` report: the fit without its meshes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitReport {
    /// Frames fitted.
    pub frames: usize,
    /// The fit.
    pub fit: FitResult,
}

fn read_actor(model: &Path) -> Result<Vec<u8>> {
    let bytes = crate::io::container::read(model)?;
    AimActor::from_bytes(&bytes)
        .map_err(|e| anyhow!("{}: not an AIM actor: {e}", model.display()))?;
    Ok(bytes)
}

/// `sinew fit`: fits the actor to the performance; bakes the fit into `out` (a `.sinew`
/// performance, docs/FORMAT.md), writes the core's playback of it into `OUT_STEM.meshes/` and
/// the report (with per-frame head, jaw and, for a global fit, coefficients).
pub fn fit_command(
    model: &Path,
    target: &Path,
    out: &Path,
    report: &Path,
    config: &FitConfig,
    backend: Backend,
) -> Result<FitReport> {
    let bytes = read_actor(model)?;
    let actor = AimActor::from_bytes(&bytes).map_err(|e| anyhow!("{}: {e}", model.display()))?;
    let perf = Performance::read(target)?;
    let result = fit(&actor, &perf, config, backend)?;
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
    let bytes = read_actor(model)?;
    let actor = AimActor::from_bytes(&bytes).map_err(|e| anyhow!("{}: {e}", model.display()))?;
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
}

/// `sinew eval fit`: GBS, PBS and the global and local AIM fits on one performance.
pub fn eval_fit(
    model: &Path,
    target: &Path,
    report: &Path,
    config: &FitConfig,
    backend: Backend,
) -> Result<EvalReport> {
    let bytes = read_actor(model)?;
    let actor = AimActor::from_bytes(&bytes).map_err(|e| anyhow!("{}: {e}", model.display()))?;
    let perf = Performance::read(target)?;
    let names = actor_shape_names(model, &bytes)?;
    let basis = Basis::of_performance(&perf, &names)?;
    let mut methods = BTreeMap::new();
    let (_, gbs) = fit_performance(&Gbs::new(basis.clone()), &perf)?;
    let (_, pbs) = fit_performance(&Pbs::new(basis, PATCH_GRID), &perf)?;
    for (name, r) in [("gbs", gbs), ("pbs", pbs)] {
        methods.insert(
            name.to_owned(),
            MethodLine {
                mean_error_mm: r.mean_error_mm,
                seconds_per_frame: r.seconds_per_frame,
            },
        );
    }
    for (name, c) in [
        ("aim_global", Coefficients::Global),
        ("aim_local", Coefficients::Local),
    ] {
        let cfg = FitConfig {
            coefficients: c,
            ..config.clone()
        };
        let r = fit(&actor, &perf, &cfg, backend)?;
        methods.insert(
            name.to_owned(),
            MethodLine {
                mean_error_mm: r.mean_error_mm,
                seconds_per_frame: r.seconds_per_frame,
            },
        );
    }
    let r = EvalReport {
        frames: perf.frames.len(),
        methods,
        aim_config: config.clone(),
    };
    crate::io::atomic::write(report, &serde_json::to_vec_pretty(&r)?)?;
    Ok(r)
}
