//! `sinew demo`: the built-in face (the ICT-FaceKit face region, [`super::demo_face`]) trained,
//! baked, measured, played back and pictured, with no data files.

use std::path::Path;

use anyhow::{Context, Result};
use sinew_core::aim::AimActor;

use crate::aim::AimConfig;
use crate::aim::commands::train_aim;
use crate::aim::play::play;
use crate::aim::run::{Outputs, Report};
use crate::figures::render::{Image, View, render};
use crate::io::mesh::Mesh;
use crate::training::backend::Backend;

/// Skin colour of the playback pictures.
const SKIN: [u8; 3] = [226, 190, 168];

/// Frames of the playback sequence shown in `playback.png`: rest, jaw half open, jaw open with a
/// smile, and the smile fading.
const STRIP_FRAMES: [usize; 4] = [0, 8, 16, 20];

/// `sinew demo`: the built-in face, trained small with `config` (normally [`AimConfig::demo`]),
/// baked, measured, played back and pictured.
pub fn demo(out: &Path, config: &AimConfig, quiet: bool) -> Result<Report> {
    config.validate()?;
    let set = crate::aim::demo_face::builtin()?;
    std::fs::create_dir_all(out)
        .with_context(|| format!("{}: cannot create folder", out.display()))?;
    let model = out.join("actor.sinew");
    let outputs = Outputs {
        model: model.clone(),
        report: out.join("report.json"),
        pictures: Some(out.to_path_buf()),
    };
    let report = train_aim(&set, config, Backend::Flex, &outputs, None, quiet)?;

    // Play a short sequence back through the core: open the jaw, then smile on both sides.
    let bytes = crate::io::container::read(&model)?;
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
        serde_json::to_string_pretty(&serde_json::json!({ "frames": frames }))?.as_bytes(),
    )?;
    let play_dir = out.join("play");
    play(&model, &poses_path, &play_dir, Some(&set.template))?;
    let tri = set.template.triangles();
    let frames: Vec<Mesh> = STRIP_FRAMES
        .iter()
        .map(|f| Ok(Mesh::read(&play_dir.join(format!("frame_{f:05}.obj")))?))
        .collect::<Result<_>>()?;
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
    Image::vstack(&rows).write_png(&out.join("playback.png"))?;
    Ok(report)
}
