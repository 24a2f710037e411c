//! `sinew demo`: the built-in face (the ICT-FaceKit face region, [`super::demo_face`]) trained,
//! baked, measured, played back and pictured, with no data files.

use std::path::Path;

use crate::aim::AimConfig;
use crate::aim::config::InvalidConfig;
use crate::aim::demo_face::DemoFaceError;
use crate::aim::eval::EvalError;
use crate::aim::play::{PlayError, play};
use crate::aim::run::{Outputs, Report, RunError, run};
use crate::aim::train::TrainOptions;
use crate::figures::render::{Image, PngError, View, render};
use crate::io::atomic::AtomicWriteError;
use crate::io::container::ContainerError;
use crate::io::mesh::{Mesh, MeshError};
use crate::training::backend::Backend;
use crate::training::checkpoint::checkpoint_dir_for;

/// Why `sinew demo` failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemoError {
    /// The configuration breaks a rule.
    #[error(transparent)]
    Config(#[from] InvalidConfig),
    /// The built-in face could not be read.
    #[error(transparent)]
    Face(#[from] DemoFaceError),
    /// The output folder could not be created.
    #[error(transparent)]
    CreateFolder(#[from] crate::io::atomic::CreateFolderError),
    /// Training, baking or measuring failed.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The baked actor could not be read back.
    #[error(transparent)]
    Container(#[from] ContainerError),
    /// The actor carries no training poses.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// The pose file could not be laid out as JSON.
    #[error(transparent)]
    Json(serde_json::Error),
    /// The pose file could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
    /// The playback could not be posed or written.
    #[error(transparent)]
    Play(#[from] PlayError),
    /// A played frame could not be read back.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The picture could not be written.
    #[error(transparent)]
    Png(#[from] PngError),
}

/// Skin colour of the playback pictures.
const SKIN: [u8; 3] = [226, 190, 168];

/// Frames of the playback sequence shown in `playback.png`: rest, jaw half open, jaw open with a
/// smile, and the smile fading.
const STRIP_FRAMES: [usize; 4] = [0, 8, 16, 20];

/// `sinew demo`: the built-in face, trained small with `config` (normally [`AimConfig::demo`]),
/// baked, measured, played back and pictured.
pub fn demo(out: &Path, config: &AimConfig, quiet: bool) -> Result<Report, DemoError> {
    config.validate()?;
    let set = crate::aim::demo_face::builtin()?;
    crate::io::atomic::create_folder(out, "folder")?;
    let model = out.join("actor.sinew");
    let outputs = Outputs {
        model: model.clone(),
        report: out.join("report.json"),
        pictures: Some(out.to_path_buf()),
    };
    let options = TrainOptions {
        backend: Backend::Flex,
        checkpoint_dir: checkpoint_dir_for(&model),
        resume: false,
        stop_after: None,
        quiet,
        target: None,
        prior: None,
    };
    let report = run(&set, config, &options, &outputs)?;

    // Play a short sequence back through the core: open the jaw, then smile on both sides.
    let bytes = crate::io::container::read(&model)?;
    let actor = crate::io::container::actor(&model, &bytes)?;
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
            for name in ["mouthSmile_L", "mouthSmile_R"] {
                if let Some(i) = index(name) {
                    w[i - 1] = if f >= 12 { t } else { 0.0 };
                }
            }
            serde_json::json!({ "jaw": jaw, "weights": w })
        })
        .collect();
    let poses_path = out.join("poses.json");
    crate::io::atomic::write(
        &poses_path,
        serde_json::to_string_pretty(&serde_json::json!({ "frames": frames }))
            .map_err(DemoError::Json)?
            .as_bytes(),
    )?;
    let play_dir = out.join("play");
    play(&model, &poses_path, &play_dir, Some(&set.template))?;
    let tri = set.template.triangles();
    let frames: Vec<Mesh> = STRIP_FRAMES
        .iter()
        .map(|f| Mesh::read(&play_dir.join(format!("frame_{f:05}.obj"))))
        .collect::<Result<_, _>>()?;
    let colors = vec![SKIN; set.vertices()];
    // One row from the front, one from three-quarters.
    let rows: Vec<Image> = crate::aim::run::VIEWS
        .iter()
        .map(|&(yaw_deg, _)| {
            let view = View {
                yaw_deg,
                pitch_deg: 0.0,
                width: 320,
                height: 320,
            };
            Image::hstack(
                &frames
                    .iter()
                    .map(|m| render(&m.positions, &tri, &colors, &view))
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    Image::vstack(&rows).save_png(&out.join("playback.png"))?;
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_config_or_a_blocked_folder_is_refused_before_training() {
        let dir = tempfile::tempdir().unwrap();
        let bad = AimConfig {
            hidden: 0,
            ..AimConfig::demo()
        };
        let err = demo(dir.path(), &bad, true).unwrap_err();
        assert!(
            matches!(err, DemoError::Config(InvalidConfig::Size)),
            "{err}"
        );
        let file = dir.path().join("a-file");
        std::fs::write(&file, b"").unwrap();
        let out = file.join("demo");
        let err = demo(&out, &AimConfig::demo(), true).unwrap_err();
        assert!(
            matches!(&err, DemoError::CreateFolder(e) if e.path == out),
            "{err}"
        );
    }
}
