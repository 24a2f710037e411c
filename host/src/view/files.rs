//! What `sinew view` serves: a fixed table from URL path to bytes, built once at start-up. The
//! page's files and the WebAssembly module are embedded in the binary at build time; the model,
//! replay and pose file are read and validated before the server listens. Nothing is ever read
//! from the file system because of a request, so no URL can name another file.

use std::path::Path;

use bytes::Bytes;
use serde::Serialize;
use sinew_core::aim::AimActor;
use sinew_core::performance::Performance;
use sinew_core::replay::{AimReplay, check_model};

use super::error::ViewError;
use super::webcam::{self, WebcamConfig, WebcamInputs};
use crate::aim::play::PoseFile;
use crate::driver::track::{self, Placement};

/// The page, its script and style, and the core's JavaScript binding (core/wasm/js).
const INDEX_HTML: &str = include_str!("web/index.html");
const VIEWER_JS: &str = include_str!("web/viewer.js");
const FACE_JS: &str = include_str!("web/face.js");
const WEBCAM_JS: &str = include_str!("web/webcam.js");
const STYLE_CSS: &str = include_str!("web/style.css");
const SINEW_MJS: &str = include_str!("../../../core/wasm/js/sinew.mjs");
/// The core compiled to WebAssembly from this checkout's sources by `host/build.rs`.
const SINEW_WASM: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/sinew_wasm.wasm"));

/// The content security policy: the page's own scripts and WebAssembly only.
pub const POLICY: &str = "default-src 'self'; script-src 'self' 'wasm-unsafe-eval'; \
     style-src 'self'; img-src 'self' data:; connect-src 'self'; frame-ancestors 'none'";

/// The policy with `--webcam`: MediaPipe Face Mesh's Emscripten glue makes functions from
/// strings, so its scripts (served from the same origin, like every script) need `unsafe-eval`.
pub const POLICY_WITH_TRACKER: &str = "default-src 'self'; \
     script-src 'self' 'wasm-unsafe-eval' 'unsafe-eval'; style-src 'self'; img-src 'self' data:; \
     connect-src 'self'; frame-ancestors 'none'";

/// One file the server answers with.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The URL path, starting with `/`.
    pub path: &'static str,
    /// Its `Content-Type`.
    pub content_type: &'static str,
    /// Its bytes, shared by every answer that sends them.
    pub body: Bytes,
}

/// The files the server answers with, by exact URL path.
#[derive(Clone, Debug)]
pub struct Site {
    entries: Vec<Entry>,
    /// Whether the table serves MediaPipe Face Mesh (`--webcam`), whose scripts need a wider
    /// content security policy.
    tracker: bool,
}

/// What the page learns from `/config.json` for an AIM actor: which data files exist and their
/// names.
#[derive(Debug, Serialize)]
struct Config<'a> {
    model: &'a str,
    /// `aim` (an S2D decoder's configuration is [`super::s2d`]'s).
    kind: &'static str,
    replay: Option<Described<'a>>,
    poses: Option<Described<'a>>,
    performance: Option<Described<'a>>,
    driver: Option<DriverConfig<'a>>,
    webcam: Option<WebcamConfig>,
}

#[derive(Debug, Serialize)]
struct Described<'a> {
    name: &'a str,
    frames: usize,
    /// A replay's numeric mode (`f32`, `q16`, `fast`); the page computes `f32` only.
    #[serde(skip_serializing_if = "Option::is_none")]
    mode: Option<String>,
    /// A performance's coefficients: `global` or `local`.
    #[serde(skip_serializing_if = "Option::is_none")]
    form: Option<&'static str>,
    /// Whether a performance carries its frames' hashes as baked.
    #[serde(skip_serializing_if = "Option::is_none")]
    hashes: Option<bool>,
}

impl<'a> Described<'a> {
    const fn new(name: &'a str, frames: usize) -> Self {
        Self {
            name,
            frames,
            mode: None,
            form: None,
            hashes: None,
        }
    }
}

/// The data files `sinew view` shows: a baked AIM actor, and optionally a replay recorded with
/// it, a pose file for it and a performance fitted to it; or an S2D decoder, and optionally a
/// landmark track and a neutral face in its topology.
#[derive(Clone, Copy, Debug)]
pub struct Inputs<'a> {
    /// The baked actor or S2D decoder (.sinew).
    pub model: &'a Path,
    /// A replay of the actor (.sinew, `sinew replay record`).
    pub replay: Option<&'a Path>,
    /// A pose file for the actor (JSON, `sinew play`'s format).
    pub poses: Option<&'a Path>,
    /// A performance fitted to the actor (.sinew, `sinew fit --out`).
    pub performance: Option<&'a Path>,
    /// An S2D decoder's landmark track: an S2D replay (.sinew, `sinew replay record`).
    pub track: Option<&'a Path>,
    /// A face in an S2D decoder's topology (.obj or .ply) to decode onto and draw.
    pub neutral: Option<&'a Path>,
    /// A landmark driver of the actor and the track it plays.
    pub driver: Option<DriverInputs<'a>>,
    /// A MediaPipe driver of the actor driven live from the browser's camera.
    pub webcam: Option<WebcamInputs<'a>>,
}

impl<'a> Inputs<'a> {
    /// The model alone, with nothing else to play.
    pub fn of(model: &'a Path) -> Self {
        Self {
            model,
            replay: None,
            poses: None,
            performance: None,
            track: None,
            neutral: None,
            driver: None,
            webcam: None,
        }
    }
}

/// A landmark driver and its track, as `sinew drive` reads them (docs/FIT.md, "Live driver").
#[derive(Clone, Copy, Debug)]
pub struct DriverInputs<'a> {
    /// The driver (.sinew, `sinew train driver`).
    pub driver: &'a Path,
    /// The track: an OpenFace 2.0 CSV or a performance folder.
    pub landmarks: &'a Path,
    /// A CSV's camera, for a 2D driver.
    pub intrinsics: Option<sinew_core::driver::Intrinsics>,
    /// A CSV row below this confidence is a lost frame.
    pub min_confidence: f32,
}

/// The landmarks `/landmarks.json` serves: per frame the driver's input (`null` where the tracker
/// lost the face), already normalised by the camera or placed in the actor's frame.
#[derive(Debug, Serialize)]
struct Landmarks {
    space: &'static str,
    frames: Vec<Option<Vec<f32>>>,
}

/// What the page learns of the driver and its track.
#[derive(Debug, Serialize)]
struct DriverConfig<'a> {
    name: &'a str,
    landmarks: &'a str,
    frames: usize,
    lost: usize,
    space: &'static str,
}

/// The file name of `path`, for the page.
pub(super) fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

impl Site {
    /// Reads and validates the data files of an AIM actor (`model` holds its bytes, a valid
    /// container; [`Site::load`] chooses by the model's kind) and builds the table. Errors name
    /// the file and what is wrong with it: not an AIM actor, a replay of another model, a pose
    /// file of the wrong shape, a performance fitted to another actor, a file for an S2D decoder.
    pub(super) fn load_aim(inputs: Inputs<'_>, model: Vec<u8>) -> Result<Self, ViewError> {
        let actor = AimActor::from_bytes(&model).map_err(|source| ViewError::NotViewable {
            path: inputs.model.to_path_buf(),
            source,
        })?;
        for (flag, path) in [("--track", inputs.track), ("--neutral", inputs.neutral)] {
            if let Some(path) = path {
                return Err(ViewError::S2dFileForActor {
                    path: path.to_path_buf(),
                    flag,
                    model: inputs.model.to_path_buf(),
                });
            }
        }
        let model_name = file_name(inputs.model);

        let mut replay = None;
        if let Some(path) = inputs.replay {
            let bytes = crate::io::container::read(path)?;
            let parsed =
                AimReplay::from_bytes(&bytes).map_err(|source| ViewError::NotAnAimReplay {
                    path: path.to_path_buf(),
                    source,
                })?;
            check_model(&model, &actor, &parsed).map_err(|source| ViewError::DoesNotPlay {
                path: path.to_path_buf(),
                model: inputs.model.to_path_buf(),
                source,
            })?;
            let mode = parsed.mode().to_string();
            replay = Some((file_name(path), parsed.frames(), mode, bytes));
        }
        let mut poses = None;
        if let Some(path) = inputs.poses {
            let file = PoseFile::read(path, actor.shape_count())?;
            let json = serde_json::to_vec(&file).map_err(|source| ViewError::Serialise {
                path: path.to_path_buf(),
                source,
            })?;
            poses = Some((file_name(path), file.frames.len(), json));
        }

        let mut performance = None;
        if let Some(path) = inputs.performance {
            let bytes = crate::io::container::read(path)?;
            let parsed =
                Performance::from_bytes(&bytes).map_err(|source| ViewError::NotAPerformance {
                    path: path.to_path_buf(),
                    source,
                })?;
            parsed
                .check_actor(&model, &actor)
                .map_err(|reason| ViewError::OtherActor {
                    path: path.to_path_buf(),
                    model: inputs.model.to_path_buf(),
                    reason,
                })?;
            let described = (
                file_name(path),
                parsed.frames(),
                if parsed.is_local() { "local" } else { "global" },
                parsed.expected(0).is_some(),
            );
            drop(parsed);
            performance = Some((described, bytes));
        }

        let mut driven = None;
        if let Some(d) = inputs.driver {
            let bytes = crate::io::container::read(d.driver)?;
            let bound = crate::driver::drive::bind(inputs.model, &model, d.driver, &bytes)?;
            let placement = Placement::of(inputs.model, &bound.actor, &bound.driver)?;
            let space = bound.driver.space();
            let track = track::read(
                d.landmarks,
                space,
                d.intrinsics,
                d.min_confidence,
                placement,
            )?;
            drop(bound);
            let counts = (
                track.frames.len(),
                track.frames.iter().filter(|f| f.is_none()).count(),
            );
            let json = serde_json::to_vec(&Landmarks {
                space: space.name(),
                frames: track.frames,
            })
            .map_err(|source| ViewError::Serialise {
                path: d.landmarks.to_path_buf(),
                source,
            })?;
            driven = Some((
                file_name(d.driver),
                file_name(d.landmarks),
                space.name(),
                counts,
                bytes,
                json,
            ));
        }
        let live = match &inputs.webcam {
            Some(w) => Some(webcam::load(w, file_name(w.driver), inputs.model, &model)?),
            None => None,
        };
        let (webcam, webcam_entries) = live.unzip();
        let config = serde_json::to_vec(&Config {
            model: &model_name,
            kind: "aim",
            replay: replay.as_ref().map(|(name, frames, mode, _)| Described {
                mode: Some(mode.clone()),
                ..Described::new(name, *frames)
            }),
            poses: poses
                .as_ref()
                .map(|(name, frames, _)| Described::new(name, *frames)),
            performance: performance
                .as_ref()
                .map(|((name, frames, form, hashes), _)| Described {
                    form: Some(form),
                    hashes: Some(*hashes),
                    ..Described::new(name, *frames)
                }),
            driver: driven
                .as_ref()
                .map(
                    |(name, landmarks, space, (frames, lost), _, _)| DriverConfig {
                        name,
                        landmarks,
                        frames: *frames,
                        lost: *lost,
                        space,
                    },
                ),
            webcam,
        })
        .map_err(ViewError::Json)?;

        let mut entries = page(&config, &model);
        if let Some((_, _, _, bytes)) = replay {
            entries.push(Entry {
                path: "/replay.sinew",
                content_type: "application/octet-stream",
                body: bytes.into(),
            });
        }
        if let Some((_, _, json)) = poses {
            entries.push(Entry {
                path: "/poses.json",
                content_type: "application/json",
                body: json.into(),
            });
        }
        if let Some((_, bytes)) = performance {
            entries.push(Entry {
                path: "/performance.sinew",
                content_type: "application/octet-stream",
                body: bytes.into(),
            });
        }
        if let Some((_, _, _, _, bytes, json)) = driven {
            entries.push(Entry {
                path: "/driver.sinew",
                content_type: "application/octet-stream",
                body: bytes.into(),
            });
            entries.push(Entry {
                path: "/landmarks.json",
                content_type: "application/json",
                body: json.into(),
            });
        }
        let tracker = webcam_entries.is_some();
        entries.extend(
            webcam_entries
                .into_iter()
                .flatten()
                .map(|(path, content_type, body)| Entry {
                    path,
                    content_type,
                    body: body.into(),
                }),
        );
        Ok(Self {
            tracker,
            ..Self::new(entries)?
        })
    }

    /// The table of `entries`, refused if one is empty (an embedded file missing from the build).
    pub(super) fn new(entries: Vec<Entry>) -> Result<Self, ViewError> {
        if entries.iter().any(|e| e.body.is_empty()) {
            return Err(ViewError::EmptyEntry);
        }
        Ok(Self {
            entries,
            tracker: false,
        })
    }

    /// The content security policy of every answer: [`POLICY`], or [`POLICY_WITH_TRACKER`]
    /// where the page runs MediaPipe Face Mesh.
    pub fn policy(&self) -> &'static str {
        if self.tracker {
            POLICY_WITH_TRACKER
        } else {
            POLICY
        }
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

/// The page, its script, style and WebAssembly, `/config.json` and the model: what every
/// table starts with.
pub(super) fn page(config: &[u8], model: &[u8]) -> Vec<Entry> {
    vec![
        entry("/", "text/html; charset=utf-8", INDEX_HTML.as_bytes()),
        entry(
            "/viewer.js",
            "text/javascript; charset=utf-8",
            VIEWER_JS.as_bytes(),
        ),
        entry(
            "/face.js",
            "text/javascript; charset=utf-8",
            FACE_JS.as_bytes(),
        ),
        entry(
            "/webcam.js",
            "text/javascript; charset=utf-8",
            WEBCAM_JS.as_bytes(),
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
        entry("/config.json", "application/json", config),
        entry("/model.sinew", "application/octet-stream", model),
    ]
}

fn entry(path: &'static str, content_type: &'static str, body: &[u8]) -> Entry {
    Entry {
        path,
        content_type,
        body: Bytes::copy_from_slice(body),
    }
}
