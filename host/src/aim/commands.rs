//! The work behind `sinew train aim`, `sinew eval aim` and `sinew bake` on the ICT-FaceKit actor
//! of the default protocol.

use std::path::Path;

use anyhow::{Context, Result, bail};

use crate::aim::data::training_set;
use crate::aim::run::{Outputs, Report, run};
use crate::aim::train::TrainOptions;
use crate::aim::{AimConfig, TrainingSet};
use crate::anatomy::fit::{bone_templates, fit_bones};
use crate::io::ict::{DEFAULT_SHAPES, FACE_REGION, IctFaceKit};
use crate::io::mesh::Mesh;
use crate::training::backend::Backend;
use crate::training::checkpoint::checkpoint_dir_for;

/// The ICT-FaceKit actor of the default protocol (the 19 default expressions, the face region) of
/// an identity (weights of the kit's identity modes; empty: the generic neutral), with bones
/// from `bones_dir` (`skull.obj`, `jaw.obj`) or fitted now.
pub fn ict_training_set(
    data: &Path,
    identity: &[f32],
    bones_dir: Option<&Path>,
    templates: &Path,
    config: &AimConfig,
) -> Result<(TrainingSet, String)> {
    let kit = IctFaceKit::open(data)?;
    let actor = kit.actor(identity, &DEFAULT_SHAPES, FACE_REGION)?;
    let (skull, jaw, said) = match bones_dir {
        Some(dir) => {
            let skull = Mesh::read(&dir.join("skull.obj"))?;
            let jaw = Mesh::read(&dir.join("jaw.obj"))?;
            (skull, jaw, format!("bones from {}", dir.display()))
        }
        None => {
            let templates_dir = bone_templates(templates)?;
            let fitted = fit_bones(
                &kit.neutral_of(identity)?,
                &kit.landmarks68()?,
                &templates_dir,
            )?;
            (
                fitted.skull,
                fitted.jaw,
                format!(
                    "bones fitted now from the templates in {}",
                    templates_dir.display()
                ),
            )
        }
    };
    let set = training_set(&actor, &skull, &jaw, None, config.max_constraint_depth)?;
    Ok((set, said))
}

/// `sinew train aim`: trains (or resumes from `resume`, a checkpoint folder) and writes the
/// outputs; checkpoints go to `MODEL.ckpt/` unless resuming.
pub fn train_aim(
    set: &TrainingSet,
    config: &AimConfig,
    backend: Backend,
    out: &Outputs,
    resume: Option<&Path>,
    quiet: bool,
) -> Result<Report> {
    let options = TrainOptions {
        backend,
        checkpoint_dir: resume.map_or_else(|| checkpoint_dir_for(&out.model), Path::to_path_buf),
        resume: resume.is_some(),
        stop_after: None,
        quiet,
    };
    Ok(run(set, config, &options, out)?)
}

/// `sinew eval aim`: the baked actor against its ICT-FaceKit training shapes (of `identity`, as
/// it was trained).
pub fn eval_aim(
    model: &Path,
    data: &Path,
    identity: &[f32],
    bones: Option<&Path>,
    templates: &Path,
) -> Result<Report> {
    let bytes = crate::io::container::read(model)?;
    let file = sinew_core::SinewFile::from_bytes(&bytes)
        .map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let config: AimConfig = match file.metadata().get("config") {
        Some(c) => serde_json::from_str::<serde_json::Value>(c)
            .and_then(AimConfig::from_recorded)
            .with_context(|| format!("{}: invalid config metadata", model.display()))?,
        None => AimConfig::default(),
    };
    let (set, said) = ict_training_set(data, identity, bones, templates, &config)?;
    eprintln!("{said}");
    if let Some(names) = file.metadata().get("shapes") {
        let names: Vec<&str> = names.split(',').collect();
        if names != set.names.iter().map(String::as_str).collect::<Vec<_>>() {
            bail!(
                "{}: trained on shapes {names:?}, not the default ICT protocol's",
                model.display()
            );
        }
    }
    Ok(crate::aim::run::evaluate(
        &bytes,
        &set,
        &config,
        Backend::Flex,
        0.0,
        config.iterations,
        model,
    )?)
}

/// `sinew bake`: re-bakes a checkpoint, optionally at another template's vertices.
pub fn bake(
    checkpoint: &Path,
    out: &Path,
    template: Option<&Path>,
    playback_only: bool,
    q16: bool,
) -> Result<()> {
    let (net, state) = crate::aim::train::load_model(checkpoint, Backend::Flex)?;
    let mesh = match template {
        Some(p) => Mesh::read(p)?,
        None => Mesh::read(&checkpoint.join("template.obj"))?,
    };
    let triangles = mesh.triangles();
    let input = crate::aim::bake::BakeInput {
        points: &mesh.positions,
        triangles: &triangles,
        jaw_pivot: state.jaw_pivot,
        normalisation: state.normalisation,
        playback_only,
        metadata: state.metadata.clone(),
    };
    let device = Backend::Flex.device(state.config.seed)?;
    let (mut bytes, _) = crate::aim::bake::bake(&net, &input, &device)?;
    if q16 {
        bytes = crate::aim::bake::with_q16_cache(&bytes)?;
    }
    Ok(crate::io::atomic::write(out, &bytes)?)
}
