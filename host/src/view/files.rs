//! What `sinew view` serves: a fixed table from URL path to bytes, built once at start-up. The
//! page's files and the WebAssembly module are embedded in the binary at build time; the model,
//! replay and pose file are read and validated before the server listens. Nothing is ever read
//! from the file system because of a request, so no URL can name another file.

use std::path::Path;

use anyhow::{Context, Result, anyhow, bail};
use serde::Serialize;
use sinew_core::aim::AimActor;
use sinew_core::replay::{AimReplay, check_model};

use crate::aim::play::PoseFile;

/// The page, its script and style, and the core's JavaScript binding (core/wasm/js).
const INDEX_HTML: &str = include_str!("web/index.html");
const VIEWER_JS: &str = include_str!("web/viewer.js");
const STYLE_CSS: &str = include_str!("web/style.css");
const SINEW_MJS: &str = include_str!("../../../core/wasm/js/sinew.mjs");
/// The core compiled to WebAssembly from this checkout's sources by `host/build.rs`.
const SINEW_WASM: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/sinew_wasm.wasm"));

/// One file the server answers with.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The URL path, starting with `/`.
    pub path: &'static str,
    /// Its `Content-Type`.
    pub content_type: &'static str,
    /// Its bytes.
    pub body: Vec<u8>,
}

/// The files the server answers with, by exact URL path.
#[derive(Clone, Debug)]
pub struct Site {
    entries: Vec<Entry>,
}

/// What the page learns from `/config.json`: which data files exist and their names.
#[derive(Debug, Serialize)]
struct Config<'a> {
    model: &'a str,
    replay: Option<Described<'a>>,
    poses: Option<Described<'a>>,
}

#[derive(Debug, Serialize)]
struct Described<'a> {
    name: &'a str,
    frames: usize,
    /// A replay's numeric mode (`f32`, `q16`, `fast`); the page computes `f32` only.
    #[serde(skip_serializing_if = "Option::is_none")]
    mode: Option<String>,
}

/// The data files `sinew view` shows: a baked AIM actor, and optionally a replay recorded with
/// it and a pose file for it.
#[derive(Clone, Copy, Debug)]
pub struct Inputs<'a> {
    /// The baked actor (.sinew).
    pub model: &'a Path,
    /// A replay of the actor (.sinew, `sinew replay record`).
    pub replay: Option<&'a Path>,
    /// A pose file for the actor (JSON, `sinew play`'s format).
    pub poses: Option<&'a Path>,
}

impl Site {
    /// Reads and validates the data files and builds the table. Errors name the file and what
    /// is wrong with it: not a `.sinew` artefact, not an AIM actor, a replay of another model, a
    /// pose file of the wrong shape.
    pub fn load(inputs: Inputs<'_>) -> Result<Self> {
        let model = crate::io::container::read(inputs.model)?;
        let actor = AimActor::from_bytes(&model).map_err(|e| {
            anyhow!(
                "{}: not an AIM actor that the viewer can show: {e}",
                inputs.model.display()
            )
        })?;
        let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
        let model_name = name(inputs.model).unwrap_or_default();

        let mut replay = None;
        if let Some(path) = inputs.replay {
            let bytes = crate::io::container::read(path)?;
            let parsed = AimReplay::from_bytes(&bytes)
                .map_err(|e| anyhow!("{}: not an AIM replay: {e}", path.display()))?;
            check_model(&model, &actor, &parsed).map_err(|e| {
                anyhow!(
                    "{}: does not play {}: {e}",
                    path.display(),
                    inputs.model.display()
                )
            })?;
            let mode = parsed.mode().to_string();
            replay = Some((name(path).unwrap_or_default(), parsed.frames(), mode, bytes));
        }
        let mut poses = None;
        if let Some(path) = inputs.poses {
            let file = PoseFile::read(path, actor.shape_count())?;
            let json = serde_json::to_vec(&file)
                .with_context(|| format!("{}: cannot serialise", path.display()))?;
            poses = Some((name(path).unwrap_or_default(), file.frames.len(), json));
        }

        let config = serde_json::to_vec(&Config {
            model: &model_name,
            replay: replay.as_ref().map(|(name, frames, mode, _)| Described {
                name,
                frames: *frames,
                mode: Some(mode.clone()),
            }),
            poses: poses.as_ref().map(|(name, frames, _)| Described {
                name,
                frames: *frames,
                mode: None,
            }),
        })?;

        let mut entries = vec![
            entry("/", "text/html; charset=utf-8", INDEX_HTML.as_bytes()),
            entry(
                "/viewer.js",
                "text/javascript; charset=utf-8",
                VIEWER_JS.as_bytes(),
            ),
            entry(
                "/style.css",
                "text/css; charset=utf-8",
                STYLE_CSS.as_bytes(),
            ),
            entry(
                "/sinew.mjs",
                "text/javascript; charset=utf-8",
                SINEW_MJS.as_bytes(),
            ),
            entry("/sinew_wasm.wasm", "application/wasm", SINEW_WASM),
            entry("/config.json", "application/json", &config),
            entry("/model.sinew", "application/octet-stream", &model),
        ];
        if let Some((_, _, _, bytes)) = replay {
            entries.push(Entry {
                path: "/replay.sinew",
                content_type: "application/octet-stream",
                body: bytes,
            });
        }
        if let Some((_, _, json)) = poses {
            entries.push(Entry {
                path: "/poses.json",
                content_type: "application/json",
                body: json,
            });
        }
        if entries.iter().any(|e| e.body.is_empty()) {
            bail!("an embedded file of the viewer is empty: the build is broken");
        }
        Ok(Self { entries })
    }

    /// The file at exactly `path` (`/` for the page), if the table has it.
    pub fn get(&self, path: &str) -> Option<&Entry> {
        self.entries.iter().find(|e| e.path == path)
    }

    /// Every file, in the order served on the page's load.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }
}

fn entry(path: &'static str, content_type: &'static str, body: &[u8]) -> Entry {
    Entry {
        path,
        content_type,
        body: body.to_vec(),
    }
}
