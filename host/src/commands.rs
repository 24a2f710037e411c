//! The work behind each `sinew` subcommand, callable from tests. `main.rs` only parses.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use sinew_core::aim::AimActor;

use crate::aim::data::training_set;
use crate::aim::run::{Outputs, Report, run};
use crate::aim::train::TrainOptions;
use crate::aim::{AimConfig, TrainingSet};
use crate::backend::Backend;
use crate::ict::{DEFAULT_SHAPES, FACE_REGION, IctFaceKit};
use crate::mesh::Mesh;

/// Reads a JSON configuration file, naming it on error.
pub fn read_config(path: &Path) -> Result<AimConfig> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let config: AimConfig = serde_json::from_str(&text)
        .with_context(|| format!("{}: invalid AIM configuration", path.display()))?;
    config
        .validate()
        .with_context(|| format!("{}: invalid AIM configuration", path.display()))?;
    Ok(config)
}

/// The checkpoint folder that belongs to a model path: `MODEL.ckpt/` beside it.
pub fn checkpoint_dir_for(model: &Path) -> PathBuf {
    model.with_extension("ckpt")
}

/// The ICT-FaceKit actor of the default protocol (generic neutral, the 19 default expressions,
/// the face region) with bones from `bones_dir` (`skull.obj`, `jaw.obj`) or fitted now.
pub fn ict_training_set(
    data: &Path,
    bones_dir: Option<&Path>,
    config: &AimConfig,
) -> Result<(TrainingSet, String)> {
    let kit = IctFaceKit::open(data)?;
    let actor = kit.actor(&[], &DEFAULT_SHAPES, FACE_REGION)?;
    let (skull, jaw, said) = match bones_dir {
        Some(dir) => {
            let skull = Mesh::read(&dir.join("skull.obj"))?;
            let jaw = Mesh::read(&dir.join("jaw.obj"))?;
            (skull, jaw, format!("bones from {}", dir.display()))
        }
        None => {
            let templates_dir = default_bone_templates()?;
            let fitted = fit_bones(kit.neutral(), &kit.landmarks68()?, &templates_dir)?;
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

/// Fits the template bones in `templates` (a folder holding `artisynth-jaw/` and
/// `skull-odedstein/`) to an ICT-FaceKit neutral, using its iBUG-68 landmarks.
pub fn fit_bones(
    neutral: &Mesh,
    landmarks: &[u32],
    templates: &Path,
) -> Result<crate::bones::FittedBones> {
    let ibug: Vec<Option<u32>> = landmarks.iter().map(|&l| Some(l)).collect();
    let skin = crate::bones::SkinLandmarks::from_ibug68(neutral, &ibug, 10.0)?;
    let t = crate::bones::load_templates(templates)?;
    crate::bones::fit(neutral, &skin, &t)
}

/// `sinew bones fit`: fits template bones to the ICT neutral and writes `skull.obj`, `jaw.obj`,
/// `fit.json` and a picture (`bones.png`: the bones, and the skin coloured by the tissue
/// thickness of its constraints).
pub fn bones_fit(data: &Path, templates: &Path, out: &Path) -> Result<crate::bones::FitReport> {
    let kit = IctFaceKit::open(data)?;
    let fitted = fit_bones(kit.neutral(), &kit.landmarks68()?, templates)?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    fitted.skull.write(&out.join("skull.obj"))?;
    fitted.jaw.write(&out.join("jaw.obj"))?;
    crate::atomic::write(
        &out.join("fit.json"),
        serde_json::to_string_pretty(&fitted.report)?.as_bytes(),
    )?;
    let (face, _) = kit.neutral().submesh(|v| FACE_REGION.contains(&v));
    let anchors = crate::aim::data::anchors(
        &face,
        &fitted.skull,
        &fitted.jaw,
        AimConfig::default().max_constraint_depth,
    );
    let thickness: Vec<f32> = anchors
        .iter()
        .map(|a| a.map_or(f32::NAN, |a| a.thickness * 10.0))
        .collect();
    let view = crate::render::View {
        yaw_deg: 35.0,
        pitch_deg: 0.0,
        width: 560,
        height: 560,
    };
    let tri = face.triangles();
    let skin = crate::render::render_heatmap(
        &face.positions,
        &tri,
        &thickness,
        0.0,
        25.0,
        "mm",
        "constraint thickness",
        &view,
    );
    let mut bones = fitted.skull.clone();
    let offset = bones.positions.len() as u32;
    bones.positions.extend(&fitted.jaw.positions);
    bones.polygons.extend(
        fitted
            .jaw
            .polygons
            .iter()
            .map(|p| p.iter().map(|i| i + offset).collect()),
    );
    let colors: Vec<[u8; 3]> = (0..bones.positions.len())
        .map(|i| {
            if (i as u32) < offset {
                [225, 215, 190]
            } else {
                [190, 205, 230]
            }
        })
        .collect();
    let bone_img = crate::render::render(&bones.positions, &bones.triangles(), &colors, &view);
    crate::render::Image::hstack(&[bone_img, skin]).write_png(&out.join("bones.png"))?;
    Ok(fitted.report)
}

/// Where the template bones are: `$SINEW_DATA`, else `../shared/data` beside the working folder.
pub fn default_bone_templates() -> Result<PathBuf> {
    let root = std::env::var_os("SINEW_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("../shared/data"));
    if root.join("artisynth-jaw").is_dir() {
        Ok(root)
    } else {
        bail!(
            "{}: no template bones (artisynth-jaw, skull-odedstein) there; pass --bones DIR or set SINEW_DATA",
            root.display()
        )
    }
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
    run(set, config, &options, out)
}

/// One frame of a pose file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Frame {
    /// Head transform: 6D rotation + translation (identity if absent).
    #[serde(default = "identity9")]
    pub head: [f32; 9],
    /// Jaw transform about the actor's pivot: 6D rotation + translation (identity if absent).
    #[serde(default = "identity9")]
    pub jaw: [f32; 9],
    /// One coefficient per corrective shape.
    pub weights: Vec<f32>,
}

fn identity9() -> [f32; 9] {
    crate::aim::model::IDENTITY_9D
}

/// A pose file: `{"frames": [{"head": [...9], "jaw": [...9], "weights": [...]}, ...]}`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct PoseFile {
    /// The frames in order.
    pub frames: Vec<Frame>,
}

impl PoseFile {
    /// Reads a pose file for an actor with `shapes` coefficients; the error names the file and
    /// the first bad frame.
    pub fn read(path: &Path, shapes: usize) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        let file: PoseFile = serde_json::from_str(&text)
            .with_context(|| format!("{}: invalid pose file", path.display()))?;
        if file.frames.is_empty() {
            bail!("{}: no frames", path.display());
        }
        for (i, f) in file.frames.iter().enumerate() {
            if f.weights.len() != shapes {
                bail!(
                    "{}: frame {i} has {} weights, the model {shapes} shapes",
                    path.display(),
                    f.weights.len(),
                );
            }
            if f.head
                .iter()
                .chain(&f.jaw)
                .chain(&f.weights)
                .any(|v| !v.is_finite())
            {
                bail!("{}: frame {i} has a non-finite value", path.display());
            }
        }
        Ok(file)
    }
}

/// `sinew play`: poses the baked actor through the core, one OBJ per frame.
pub fn play(model: &Path, poses: &Path, out: &Path, template: Option<&Mesh>) -> Result<usize> {
    let bytes = crate::container::read(model)?;
    let actor =
        AimActor::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let file = PoseFile::read(poses, actor.shape_count())?;
    let mesh = match template {
        Some(t) => t.clone(),
        None => mesh_of(&actor),
    };
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    let mut buf = vec![0.0; 3 * actor.vertex_count()];
    for (i, f) in file.frames.iter().enumerate() {
        let pose = actor.pose_from_9d(&f.jaw, &f.head);
        actor
            .pose(&pose, &f.weights, &mut buf)
            .map_err(|e| anyhow::anyhow!("frame {i}: {e}"))?;
        let positions = crate::mesh::points(buf.iter().copied());
        mesh.with_positions(positions)
            .write(&out.join(format!("frame_{i:05}.obj")))?;
    }
    Ok(file.frames.len())
}

/// The baked template as a triangle mesh.
pub fn mesh_of(actor: &AimActor<'_>) -> Mesh {
    let t = actor.triangles().indices();
    let positions = crate::mesh::points(actor.template().iter());
    let polygons = t
        .iter()
        .collect::<Vec<u32>>()
        .chunks_exact(3)
        .map(<[u32]>::to_vec)
        .collect();
    Mesh::new(positions, polygons)
}

/// Reads a region file: JSON, either a list of vertex indices (weight 1) or an object
/// `{"weights": [w_0, …, w_{V−1}]}`; returns per-vertex weights in [0, 1].
pub fn read_region(path: &Path, vertices: usize) -> Result<Vec<f32>> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Region {
        Indices(Vec<u32>),
        Weights { weights: Vec<f32> },
    }
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let region: Region = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected a list of vertex indices or {{\"weights\": [...]}}",
            path.display()
        )
    })?;
    match region {
        Region::Indices(idx) => {
            let mut w = vec![0.0; vertices];
            for i in idx {
                *w.get_mut(i as usize).with_context(|| {
                    format!(
                        "{}: vertex {i} out of range (model has {vertices})",
                        path.display()
                    )
                })? = 1.0;
            }
            Ok(w)
        }
        Region::Weights { weights } => {
            if weights.len() != vertices {
                bail!(
                    "{}: {} weights for a model of {vertices} vertices",
                    path.display(),
                    weights.len()
                );
            }
            if let Some(w) = weights.iter().find(|w| !(0.0..=1.0).contains(*w)) {
                bail!("{}: weight {w} outside [0, 1]", path.display());
            }
            Ok(weights)
        }
    }
}

/// `sinew edit thickness`: scales the learned thickness in a region, writes the edited neutral
/// and a before/after picture.
pub fn edit_thickness(model: &Path, region: &Path, scale: f32, out: &Path) -> Result<()> {
    let bytes = crate::container::read(model)?;
    let actor =
        AimActor::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    if !scale.is_finite() || scale < 0.0 {
        bail!("--scale must be a finite non-negative number, got {scale}");
    }
    let mask = read_region(region, actor.vertex_count())?;
    let mut edited = vec![0.0; 3 * actor.vertex_count()];
    actor
        .edit_thickness(&mask, scale, &mut edited)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let mesh = mesh_of(&actor);
    let before: Vec<[f32; 3]> = crate::mesh::points(actor.rest().iter());
    let after: Vec<[f32; 3]> = crate::mesh::points(edited.iter().copied());
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    mesh.with_positions(after.clone())
        .write(&out.join("edited_neutral.obj"))?;
    let tri = mesh.triangles();
    let moved: Vec<f32> = before
        .iter()
        .zip(&after)
        .map(|(a, b)| {
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
        })
        .collect();
    let hi = moved.iter().copied().fold(1e-6f32, f32::max);
    let view = crate::render::View {
        yaw_deg: 30.0,
        pitch_deg: 0.0,
        width: 560,
        height: 560,
    };
    let a = crate::render::render_heatmap(
        &before,
        &tri,
        &mask,
        0.0,
        1.0,
        "mask",
        "before (edit region)",
        &view,
    );
    let b = crate::render::render_heatmap(
        &after,
        &tri,
        &moved,
        0.0,
        hi,
        "moved",
        &format!("after (thickness x{scale})"),
        &view,
    );
    crate::render::Image::hstack(&[a, b]).write_png(&out.join("edit.png"))
}

/// `sinew demo`: the procedural actor, trained small with `config` (normally
/// [`AimConfig::demo`]), baked, measured, played back and pictured.
pub fn demo(out: &Path, config: &AimConfig, quiet: bool) -> Result<Report> {
    let (actor, bones) = crate::procedural::actor(crate::procedural::DEFAULT_RESOLUTION);
    config.validate()?;
    let set = training_set(
        &actor,
        &bones.skull,
        &bones.jaw,
        Some(bones.jaw_pivot),
        config.max_constraint_depth,
    )?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    bones.skull.write(&out.join("bone_skull.obj"))?;
    bones.jaw.write(&out.join("bone_jaw.obj"))?;
    let model = out.join("actor.sinew");
    let outputs = Outputs {
        model: model.clone(),
        report: out.join("report.json"),
        pictures: Some(out.to_path_buf()),
    };
    let report = train_aim(&set, config, Backend::Flex, &outputs, None, quiet)?;

    // Play a short sequence back through the core: open the jaw, then smile on both sides.
    let bytes = crate::container::read(&model)?;
    let actor =
        AimActor::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let poses = crate::aim::eval::training_poses(&actor)?;
    let index = |name: &str| set.names.iter().position(|n| n == name);
    let frames: Vec<serde_json::Value> = (0..24)
        .map(|f| {
            let t = (f as f32 / 23.0 * std::f32::consts::PI).sin();
            let mut w = vec![0.0f32; actor.shape_count()];
            let mut jaw = crate::aim::model::IDENTITY_9D;
            if let Some(i) = index("jawOpen") {
                w[i - 1] = t;
                for (j, v) in jaw.iter_mut().enumerate() {
                    *v += t * (poses[i][j] - crate::aim::model::IDENTITY_9D[j]);
                }
            }
            for name in ["smile_L", "smile_R"] {
                if let Some(i) = index(name) {
                    w[i - 1] = if f >= 12 { t } else { 0.0 };
                }
            }
            serde_json::json!({ "jaw": jaw, "weights": w })
        })
        .collect();
    let poses_path = out.join("poses.json");
    crate::atomic::write(
        &poses_path,
        serde_json::to_string_pretty(&serde_json::json!({ "frames": frames }))?.as_bytes(),
    )?;
    let play_dir = out.join("play");
    play(&model, &poses_path, &play_dir, Some(&set.template))?;
    let tri = set.template.triangles();
    let view = crate::render::View {
        yaw_deg: 25.0,
        pitch_deg: 0.0,
        width: 320,
        height: 320,
    };
    let strip: Vec<crate::render::Image> = [0, 8, 16, 20]
        .iter()
        .map(|f| {
            let m = Mesh::read(&play_dir.join(format!("frame_{f:05}.obj")))?;
            Ok(crate::render::render(&m.positions, &tri, &[], &view))
        })
        .collect::<Result<_>>()?;
    crate::render::Image::hstack(&strip).write_png(&out.join("playback.png"))?;
    Ok(report)
}

/// `sinew eval aim`: the baked actor against its ICT-FaceKit training shapes.
pub fn eval_aim(model: &Path, data: &Path, bones: Option<&Path>) -> Result<Report> {
    let bytes = crate::container::read(model)?;
    let file = sinew_core::SinewFile::from_bytes(&bytes)
        .map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let config: AimConfig = match file.metadata().get("config") {
        Some(c) => serde_json::from_str::<serde_json::Value>(c)
            .and_then(AimConfig::from_recorded)
            .with_context(|| format!("{}: invalid config metadata", model.display()))?,
        None => AimConfig::default(),
    };
    let (set, said) = ict_training_set(data, bones, &config)?;
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
    crate::aim::run::evaluate(
        &bytes,
        &set,
        &config,
        Backend::Flex,
        0.0,
        config.iterations,
        model,
    )
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
    crate::atomic::write(out, &bytes)
}

/// One frame of an S2D input file.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct S2dInputFrame {
    /// The decoder input, `[I]` (`sinew_core::s2d::S2dDecoder::input`).
    input: Vec<f32>,
}

/// The input file of an S2D replay: the frames, and optionally the neutral to decode onto.
#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct S2dInputFile {
    frames: Vec<S2dInputFrame>,
    #[serde(default)]
    neutral: Option<Vec<f32>>,
}

/// `sinew replay record`: returns the number of frames recorded. An AIM actor takes a pose file;
/// an S2D decoder takes `{"frames": [{"input": [I]}, ...], "neutral": [V·3]}` (neutral
/// optional).
pub fn replay_record(
    model: &Path,
    poses: &Path,
    out: &Path,
    mode: sinew_core::replay::Mode,
) -> Result<usize> {
    let bytes = crate::container::read(model)?;
    if sinew_core::SinewFile::from_bytes(&bytes)
        .is_ok_and(|f| f.kind == sinew_core::ArtifactKind::S2dDecoder)
    {
        if mode != sinew_core::replay::Mode::F32 {
            anyhow::bail!("S2D replays are f32 only (--mode {mode})");
        }
        let text = std::fs::read_to_string(poses)
            .with_context(|| format!("{}: cannot read", poses.display()))?;
        let file: S2dInputFile = serde_json::from_str(&text).with_context(|| {
            format!(
                "{}: not an S2D input file {{\"frames\": [{{\"input\": [I]}}, ...], \"neutral\": [V·3]?}}",
                poses.display()
            )
        })?;
        let inputs: Vec<Vec<f32>> = file.frames.into_iter().map(|f| f.input).collect();
        let replay = crate::replay::record_s2d(&bytes, &inputs, file.neutral.as_deref())
            .with_context(|| format!("recording {} with {}", poses.display(), model.display()))?;
        crate::atomic::write(out, &replay)?;
        return Ok(inputs.len());
    }
    let actor =
        AimActor::from_bytes(&bytes).map_err(|e| anyhow::anyhow!("{}: {e}", model.display()))?;
    let file = PoseFile::read(poses, actor.shape_count())?;
    let replay = crate::replay::record(&bytes, mode, &file.frames)
        .with_context(|| format!("recording {} with {}", poses.display(), model.display()))?;
    crate::atomic::write(out, &replay)?;
    Ok(file.frames.len())
}

/// `sinew replay verify`.
pub fn replay_verify(model: &Path, replay: &Path) -> Result<crate::replay::Verification> {
    let m = crate::container::read(model)?;
    let r = crate::container::read(replay)?;
    crate::replay::verify(&m, &r)
        .with_context(|| format!("verifying {} against {}", replay.display(), model.display()))
}

/// The deviation of a replay's numeric mode from the `f32` reference (`sinew replay verify`).
pub fn replay_deviation(model: &Path, replay: &Path) -> Result<crate::replay::Deviation> {
    let m = crate::container::read(model)?;
    let r = crate::container::read(replay)?;
    crate::replay::deviation(&m, &r)
        .with_context(|| format!("measuring {} against {}", replay.display(), model.display()))
}

/// `sinew s2d hierarchy`: builds the S2D mesh hierarchy of `template` with `config` and writes
/// it to `out` (see `s2d::hierarchy::to_bytes`). Errors name the template file.
pub fn s2d_hierarchy(
    template: &Path,
    out: &Path,
    config: &crate::s2d::hierarchy::Config,
) -> Result<crate::s2d::Hierarchy> {
    use crate::s2d::hierarchy;
    let mesh = Mesh::read(template)?;
    let h = hierarchy::build_with(&mesh, config)
        .with_context(|| format!("{}: cannot build the S2D hierarchy", template.display()))?;
    let key = hierarchy::cache_key(&mesh, config);
    crate::atomic::write(out, &hierarchy::to_bytes(&h, key, config)?)?;
    Ok(h)
}
