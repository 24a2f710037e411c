//! The work behind `sinew fit` and `sinew eval fit`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Result, anyhow};
use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use crate::fit::aim::{Coefficients, FitConfig, FitResult, fit};
use crate::fit::baseline::{Basis, Gbs, PATCH_GRID, Pbs, actor_shape_names, fit_performance};
use crate::fit::performance::Performance;
use crate::io::mesh::Mesh;
use crate::training::backend::Backend;

/// One frame of `FIT.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FittedFrame {
    /// Head: 6D rotation + translation (the actor's units).
    pub head: [f32; 9],
    /// Jaw about the actor's pivot: 6D rotation + translation.
    pub jaw: [f32; 9],
    /// The global coefficients (global fits only; a local fit's vary per point).
    pub weights: Option<Vec<f32>>,
    /// The fitted mesh, relative to `FIT.json`'s folder.
    pub mesh: String,
}

/// `FIT.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitFile {
    /// The actor.
    pub model: PathBuf,
    /// The performance.
    pub target: PathBuf,
    /// The fit's settings.
    pub config: FitConfig,
    /// Per frame.
    pub frames: Vec<FittedFrame>,
}

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

/// `sinew fit`: fits the actor to the performance; writes `out` (per-frame parameters), the
/// fitted meshes into `OUT_STEM.meshes/` and the report.
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
    let stem = out
        .file_stem()
        .map_or_else(|| "fit".into(), |s| s.to_string_lossy().into_owned());
    let mesh_dir = format!("{stem}.meshes");
    let base = out.parent().unwrap_or(Path::new("."));
    let mut frames = Vec::new();
    for (f, mesh) in result.meshes.iter().enumerate() {
        let name = format!("{mesh_dir}/frame_{f:05}.obj");
        Mesh::new(mesh.clone(), perf.polygons.clone()).write(&base.join(&name))?;
        frames.push(FittedFrame {
            head: result.head[f],
            jaw: result.jaw[f],
            weights: result.weights.as_ref().map(|w| w[f].clone()),
            mesh: name,
        });
    }
    let file = FitFile {
        model: model.to_owned(),
        target: target.to_owned(),
        config: config.clone(),
        frames,
    };
    crate::io::atomic::write(out, &serde_json::to_vec_pretty(&file)?)?;
    let r = FitReport {
        frames: perf.frames.len(),
        fit: result,
    };
    crate::io::atomic::write(report, &serde_json::to_vec_pretty(&r)?)?;
    Ok(r)
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
