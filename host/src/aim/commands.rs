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
use crate::rig::Rig;
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

/// How `sinew train aim` runs, besides its set, configuration and outputs.
#[derive(Debug, Default)]
pub struct TrainAimRun<'a> {
    /// Continue from this checkpoint folder (else checkpoints go to `MODEL.ckpt/`).
    pub resume: Option<&'a Path>,
    /// Hide the progress bar and the check lines.
    pub quiet: bool,
    /// Stop once this accuracy is reached.
    pub target: Option<crate::aim::target::Target>,
    /// Start from this actor's networks.
    pub prior: Option<crate::aim::prior::Prior>,
}

/// `sinew train aim`: trains (or resumes) and writes the outputs.
pub fn train_aim(
    set: &TrainingSet,
    config: &AimConfig,
    backend: Backend,
    out: &Outputs,
    run_as: TrainAimRun<'_>,
) -> Result<Report> {
    let options = TrainOptions {
        backend,
        checkpoint_dir: run_as
            .resume
            .map_or_else(|| checkpoint_dir_for(&out.model), Path::to_path_buf),
        resume: run_as.resume.is_some(),
        stop_after: None,
        quiet: run_as.quiet,
        target: run_as.target,
        prior: run_as.prior,
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
    evaluate_model(model, |config, _| {
        ict_training_set(data, identity, bones, templates, config)
    })
}

/// `sinew eval aim --rig`: the baked actor against the rig's shapes it was trained on.
pub fn eval_aim_rig(
    model: &Path,
    rig: &Rig,
    bones: Option<&Path>,
    templates: &Path,
) -> Result<Report> {
    evaluate_model(model, |config, trained| {
        rig_training_set(rig, trained, bones, templates, config)
    })
}

/// A baked actor against the training set `set_for` builds from its configuration and the
/// shape names it records (neutral left out).
fn evaluate_model(
    model: &Path,
    set_for: impl FnOnce(&AimConfig, &[String]) -> Result<(TrainingSet, String)>,
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
    let trained: Vec<String> = file
        .metadata()
        .get("shapes")
        .map(|names| names.split(',').skip(1).map(str::to_owned).collect())
        .unwrap_or_default();
    let (set, said) = set_for(&config, &trained)?;
    eprintln!("{said}");
    if !trained.is_empty() && trained[..] != set.names[1..] {
        bail!(
            "{}: trained on shapes {trained:?}, not the data's {:?}",
            model.display(),
            &set.names[1..]
        );
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
    // Texture coordinates: the template's, or the training template's carried onto it.
    let training = checkpoint.join("template.obj");
    let training = match template {
        Some(_) if training.exists() => Some(Mesh::read(&training)?),
        _ => None,
    };
    let mut metadata = state.metadata.clone();
    metadata.retain(|(k, _)| k != crate::geometry::uv::KEY);
    // The rig record maps the rig's vertices onto the training template's: an actor baked on
    // another mesh cannot go back into the rig, so it does not carry the record.
    if training
        .as_ref()
        .is_some_and(|t| t.positions != mesh.positions)
        && metadata.iter().any(|(k, _)| k == crate::rig::record::KEY)
    {
        metadata.retain(|(k, _)| k != crate::rig::record::KEY);
        eprintln!(
            "{}: baked on another mesh than the rig's, so without the rig record (no export or \
             play in the rig's own frame)",
            out.display()
        );
    }
    metadata.extend(crate::aim::bake::uv_metadata(
        &metadata,
        &mesh,
        &triangles,
        training.as_ref(),
    )?);
    let input = crate::aim::bake::BakeInput {
        points: &mesh.positions,
        triangles: &triangles,
        jaw_pivot: state.jaw_pivot,
        normalisation: state.normalisation,
        playback_only,
        metadata,
    };
    let device = Backend::Flex.device(state.config.seed)?;
    let (mut bytes, _) = crate::aim::bake::bake(&net, &input, &device)?;
    if q16 {
        bytes = crate::aim::bake::with_q16_cache(&bytes)?;
    }
    Ok(crate::io::atomic::write(out, &bytes)?)
}

/// The actor of a resolved rig: its welded neutral in Sinew's face frame with the shapes
/// `shapes` names (every shape of the rig when empty), with bones from `bones_dir` (`skull.obj`,
/// `jaw.obj` in the face frame, as `sinew bones fit --rig` writes them) or fitted now by its
/// landmarks. The baked actor records the rig's conventions and welding (`rig`) and its ARKit
/// binding (`arkit`).
pub fn rig_training_set(
    rig: &Rig,
    shapes: &[String],
    bones_dir: Option<&Path>,
    templates: &Path,
    config: &AimConfig,
) -> Result<(TrainingSet, String)> {
    let names = rig.names();
    let picked: Vec<usize> = if shapes.is_empty() {
        (0..names.len()).collect()
    } else {
        shapes
            .iter()
            .map(|s| {
                names.iter().position(|n| n == s).ok_or_else(|| {
                    anyhow::anyhow!(
                        "{}: no shape {s:?}; the rig's shapes: {}",
                        rig.path().display(),
                        names.join(", ")
                    )
                })
            })
            .collect::<Result<_>>()?
    };
    if let Some(&k) = picked.iter().find(|&&k| names[k].contains(',')) {
        bail!(
            "{}: shape {:?} has a comma in its name, which the baked actor's shape list cannot \
             hold; rename it or leave it out with --shapes",
            rig.path().display(),
            names[k]
        );
    }
    let neutral = rig.face.positions.clone();
    let mut all = vec![neutral.clone()];
    all.extend(picked.iter().map(|&k| {
        neutral
            .iter()
            .zip(&rig.deltas[k])
            .map(|(p, d)| [p[0] + d[0], p[1] + d[1], p[2] + d[2]])
            .collect()
    }));
    let mut shape_names = vec!["neutral".to_owned()];
    shape_names.extend(picked.iter().map(|&k| names[k].clone()));
    let landmarks = rig.landmarks.welded_vertices();
    let actor = crate::io::ict::Actor {
        template: rig.face.clone(),
        shapes: all,
        names: shape_names,
        landmarks: landmarks.iter().map(|&l| Some(l)).collect(),
        units: crate::io::units::Unit::Centimetre,
        source: format!(
            "rig {} (mesh {:?})",
            rig.path().file_name().map_or_else(
                || rig.path().display().to_string(),
                |n| n.to_string_lossy().into_owned()
            ),
            rig.file.mesh_name
        ),
    };
    let (skull, jaw, said) = match bones_dir {
        Some(dir) => (
            Mesh::read(&dir.join("skull.obj"))?,
            Mesh::read(&dir.join("jaw.obj"))?,
            format!("bones from {}", dir.display()),
        ),
        None => {
            let templates_dir = bone_templates(templates)?;
            let fitted = fit_bones(&rig.face, &landmarks, &templates_dir)?;
            (
                fitted.skull,
                fitted.jaw,
                format!(
                    "bones fitted now to the rig's landmarks from the templates in {}",
                    templates_dir.display()
                ),
            )
        }
    };
    let mut set = training_set(&actor, &skull, &jaw, None, config.max_constraint_depth)?;
    set.provenance = vec![
        (
            crate::rig::record::KEY.into(),
            serde_json::to_string(&crate::rig::record::Record::of(rig))?,
        ),
        (
            "arkit".into(),
            serde_json::to_string(&rig_arkit(rig, &picked))?,
        ),
    ];
    Ok((set, said))
}

/// ARKit name → the trained shapes that play it.
fn rig_arkit(rig: &Rig, picked: &[usize]) -> std::collections::BTreeMap<String, Vec<String>> {
    rig.arkit
        .iter()
        .map(|(a, s)| {
            let kept: Vec<String> = s
                .iter()
                .filter(|k| picked.contains(k))
                .map(|&k| rig.names()[k].clone())
                .collect();
            (a.clone(), kept)
        })
        .filter(|(_, s)| !s.is_empty())
        .collect()
}

/// `sinew bones fit --rig`: the template bones fitted to a rig by its landmarks, written in
/// Sinew's face frame (as `train aim --rig --bones` reads them).
pub fn bones_fit_rig(
    rig: &Rig,
    templates: &Path,
    out: &Path,
) -> Result<crate::anatomy::bones::FitReport> {
    let templates = bone_templates(templates)?;
    Ok(crate::anatomy::fit::bones_fit_on(
        &rig.face,
        &rig.landmarks.welded_vertices(),
        &rig.face,
        &templates,
        out,
    )?)
}
