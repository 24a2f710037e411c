//! ARKit captures driving a baked actor: which capture channel plays which of the actor's shapes,
//! and the capture's rows as pose frames.
//!
//! ICT-FaceKit names its shapes after ARKit's blendshapes in camelCase and splits the sided ones
//! with `_L`/`_R` (`mouthSmile_L`), where a Live Link Face capture writes PascalCase with a
//! `Left`/`Right` suffix (`MouthSmileLeft`), and a studio's rig may write `mouthSmile.L` or
//! `blendShape1.mouthSmileLeft`. Names are compared as `io::arkit::comparable` reduces them
//! (case, punctuation, namespaces and side spellings set aside). A channel plays
//! 1. the shape whose name compares equal (`JawOpen` → `jawOpen`, `MouthSmileLeft` →
//!    `mouthSmile_L`); otherwise
//! 2. both sides of a shape ARKit does not split: `BrowInnerUp` → `browInnerUp_L` and
//!    `browInnerUp_R` (ICT-FaceKit splits `browInnerUp` and `cheekPuff`).
//!
//! `HeadYaw`, `HeadPitch` and `HeadRoll` (radians) turn the head about the jaw's hinge centre
//! (between the ears): `R = R_y(yaw) · R_x(pitch) · R_z(roll)` in the actor's face frame (+x to
//! the actor's left, +y up, +z forward). A channel that plays none of the actor's shapes (the
//! eye rotations, and every shape the actor was not trained on) is reported, never silently
//! dropped. Every played shape also moves the jaw as it learned to: the frame's jaw is every
//! shape's learned jaw transform (`train.jaw`) blended by the coefficients and held within the
//! range the shapes span, the core's rule for a pose given by coefficients alone
//! ([`sinew_core::jaw`], `AimActor::jaw_from_weights`). On a studio's rig `mouthClose`,
//! `mouthFunnel` or the smiles turn the jaw by several degrees, and their correctives were
//! learned on top of that jaw.

use std::path::{Path, PathBuf};

use serde::Serialize;
use sinew_core::aim::AimActor;

use crate::aim::model::IDENTITY_9D;
use crate::aim::play::{Frame, PlayError};
use crate::io::arkit::{
    ARKIT_SHAPES, Capture, CaptureError, CaptureFrame, LIVE_LINK_FACE_CHANNELS, comparable,
};
use crate::io::atomic::AtomicWriteError;

/// Why a Live Link Face capture could not be played on an actor.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ArkitError {
    /// The capture could not be read.
    #[error(transparent)]
    Capture(#[from] CaptureError),
    /// No capture channel drives any of the actor's shapes.
    #[error(
        "{}: no capture channel matches any of the actor's shapes (channels {}; shapes {})",
        path.display(),
        channels.join(","),
        shapes.join(",")
    )]
    NoMatch {
        /// The capture.
        path: PathBuf,
        /// Its channels.
        channels: Vec<String>,
        /// The actor's corrective shapes.
        shapes: Vec<String>,
    },
    /// A row's coefficients cannot pose the actor (a value beyond the core's limits).
    #[error("{}: row {} (frame {frame})", path.display(), frame + 1)]
    Frame {
        /// The capture.
        path: PathBuf,
        /// The frame, from 0.
        frame: usize,
        /// The core's reason.
        #[source]
        source: sinew_core::EvalError,
    },
    /// The actor could not be read or posed, or a frame not written.
    #[error(transparent)]
    Play(#[from] PlayError),
    /// The mapping summary could not be laid out as JSON.
    #[error("{}: cannot lay out the mapping", path.display())]
    Summary {
        /// The summary file.
        path: PathBuf,
        /// What the JSON writer said.
        #[source]
        source: serde_json::Error,
    },
    /// The mapping summary could not be written.
    #[error(transparent)]
    Write(#[from] AtomicWriteError),
}

/// Which capture channel drives which corrective shape.
#[derive(Clone, Debug, Serialize)]
pub struct Mapping {
    /// `(capture channel, actor shape)` pairs: the channel's value is the shape's coefficient.
    pub played: Vec<(String, String)>,
    /// Capture channels that drive none of the actor's shapes, in capture order.
    pub unplayable: Vec<String>,
    /// The actor's corrective shapes that no channel drives (they stay at rest).
    pub at_rest: Vec<String>,
    /// The played shapes whose learned jaw turns the jaw by more than [`MOVES_JAW_DEGREES`],
    /// with that angle in degrees, in the actor's shape order (every shape's learned jaw plays;
    /// these are the ones that matter).
    pub jaw_shapes: Vec<(String, f32)>,
    /// The head rotation channels the capture has (`HeadYaw`, `HeadPitch`, `HeadRoll`), which
    /// turn the head.
    pub head: Vec<String>,
    #[serde(skip)]
    head_routes: [Option<usize>; 3],
    #[serde(skip)]
    routes: Vec<(usize, usize)>,
}

impl Mapping {
    /// Maps capture `channels` onto the actor's corrective `shapes` (neutral excluded); `path`
    /// names the capture in the error when no channel plays any shape.
    pub fn new(path: &Path, channels: &[String], shapes: &[String]) -> Result<Self, ArkitError> {
        let keys: Vec<String> = shapes.iter().map(|s| comparable(s)).collect();
        let mut head_routes = [None; 3];
        let mut routes = Vec::new();
        let mut unplayable = Vec::new();
        for (c, name) in channels.iter().enumerate() {
            if let Some(h) = HEAD_CHANNELS
                .iter()
                .position(|h| h.eq_ignore_ascii_case(name))
            {
                head_routes[h] = Some(c);
                continue;
            }
            let before = routes.len();
            let key = comparable(name);
            routes.extend(
                (0..shapes.len())
                    .filter(|&s| keys[s] == key)
                    .map(|s| (c, s)),
            );
            if routes.len() == before && !key.ends_with("left") && !key.ends_with("right") {
                for side in ["left", "right"] {
                    let sided = format!("{key}{side}");
                    routes.extend(
                        (0..shapes.len())
                            .filter(|&s| keys[s] == sided)
                            .map(|s| (c, s)),
                    );
                }
            }
            if routes.len() == before {
                unplayable.push(name.clone());
            }
        }
        if routes.is_empty() {
            return Err(ArkitError::NoMatch {
                path: path.to_path_buf(),
                channels: channels.to_vec(),
                shapes: shapes.to_vec(),
            });
        }
        let at_rest = (0..shapes.len())
            .filter(|s| !routes.iter().any(|r| r.1 == *s))
            .map(|s| shapes[s].clone())
            .collect();
        Ok(Self {
            played: routes
                .iter()
                .map(|&(c, s)| (channels[c].clone(), shapes[s].clone()))
                .collect(),
            unplayable,
            at_rest,
            jaw_shapes: Vec::new(),
            head: head_routes
                .iter()
                .flatten()
                .map(|&c| channels[c].clone())
                .collect(),
            head_routes,
            routes,
        })
    }

    /// One frame's head transform (9D) from a capture row: the rotation of its `HeadYaw`,
    /// `HeadPitch` and `HeadRoll` (radians) about `pivot`.
    pub fn head(&self, row: &CaptureFrame, pivot: [f32; 3]) -> [f32; 9] {
        let angle = |k: usize| self.head_routes[k].map_or(0.0, |c| f64::from(row.values[c]));
        let (yaw, pitch, roll) = (angle(0), angle(1), angle(2));
        if yaw == 0.0 && pitch == 0.0 && roll == 0.0 {
            return IDENTITY_9D;
        }
        let (sy, cy) = yaw.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sr, cr) = roll.sin_cos();
        let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
        let rx = [[1.0, 0.0, 0.0], [0.0, cp, -sp], [0.0, sp, cp]];
        let rz = [[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]];
        let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| -> [[f64; 3]; 3] {
            std::array::from_fn(|i| {
                std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum())
            })
        };
        let r = mul(mul(ry, rx), rz);
        let p = pivot.map(f64::from);
        // x ↦ R x + (p − R p): the rotation about the pivot.
        let t: [f64; 3] =
            std::array::from_fn(|i| p[i] - (0..3).map(|k| r[i][k] * p[k]).sum::<f64>());
        [
            r[0][0], r[1][0], r[2][0], r[0][1], r[1][1], r[2][1], t[0], t[1], t[2],
        ]
        .map(|v| v as f32)
    }

    /// One frame's coefficients (`[M]`) from a capture row.
    pub fn weights(&self, row: &CaptureFrame, shapes: usize) -> Vec<f32> {
        let mut w = vec![0.0; shapes];
        for &(c, s) in &self.routes {
            w[s] = row.values[c];
        }
        w
    }
}

/// A capture turned into an actor's pose frames, with the mapping that did it.
#[derive(Clone, Debug)]
pub struct Playback {
    /// The mapping from capture channels to shapes.
    pub mapping: Mapping,
    /// One pose frame per capture row.
    pub frames: Vec<Frame>,
}

/// The head rotation channels, in the order yaw, pitch, roll.
const HEAD_CHANNELS: [&str; 3] = ["HeadYaw", "HeadPitch", "HeadRoll"];

/// A learned jaw rotation above which a shape is said to move the jaw: reported in the mapping
/// (`jaw_shapes`), and the shapes the export's tests hold to the core one by one. Every shape's
/// learned jaw plays, whatever its angle.
pub const MOVES_JAW_DEGREES: f32 = 0.5;

/// Each corrective shape's learned jaw rotation in degrees, in shape order; empty when the actor
/// records no learned jaws.
pub fn jaw_degrees(actor: &AimActor<'_>) -> Vec<f32> {
    actor.learned_jaws().map_or_else(Vec::new, |jaws| {
        (0..jaws.shape_count())
            .map(|s| crate::aim::eval::rotation_degrees(&jaws.shape(s)) as f32)
            .collect()
    })
}

/// Reads a Live Link Face capture and maps it onto `actor`.
pub fn playback(actor: &AimActor<'_>, capture_path: &Path) -> Result<Playback, ArkitError> {
    let capture = Capture::read(capture_path)?;
    playback_of(actor, capture_path, &capture)
}

/// Maps a parsed capture onto `actor`; `path` names the capture in errors.
pub fn playback_of(
    actor: &AimActor<'_>,
    path: &Path,
    capture: &Capture,
) -> Result<Playback, ArkitError> {
    let shapes = crate::aim::play::corrective_names(actor);
    let mut mapping = Mapping::new(path, &capture.channels, &shapes)?;
    let degrees = jaw_degrees(actor);
    mapping.jaw_shapes = degrees
        .iter()
        .enumerate()
        .filter(|&(s, d)| *d > MOVES_JAW_DEGREES && mapping.routes.iter().any(|r| r.1 == s))
        .map(|(s, d)| (shapes[s].clone(), *d))
        .collect();
    let pivot = actor.jaw_pivot();
    let frames = capture
        .frames
        .iter()
        .enumerate()
        .map(|(f, row)| {
            let weights = mapping.weights(row, shapes.len());
            let jaw = actor
                .jaw_from_weights(&weights)
                .map_err(|source| ArkitError::Frame {
                    path: path.to_path_buf(),
                    frame: f,
                    source,
                })?;
            Ok(Frame {
                head: mapping.head(row, [pivot.x, pivot.y, pivot.z]),
                jaw,
                weights,
            })
        })
        .collect::<Result<_, ArkitError>>()?;
    Ok(Playback { mapping, frames })
}

/// `sinew play --arkit`: poses the baked actor from a Live Link Face capture, one OBJ per frame,
/// and writes the channel mapping to `arkit.json` beside them.
pub fn play_arkit(model: &Path, capture: &Path, out: &Path) -> Result<Playback, ArkitError> {
    let bytes = crate::io::container::read(model).map_err(PlayError::from)?;
    let actor = crate::io::container::actor(model, &bytes).map_err(PlayError::from)?;
    let playback = playback(&actor, capture)?;
    crate::aim::play::play_frames(&actor, &playback.frames, out, None)?;
    let summary = serde_json::json!({
        "capture": capture.display().to_string(),
        "frames": playback.frames.len(),
        "mapping": playback.mapping,
    });
    let path = out.join("arkit.json");
    let json = serde_json::to_string_pretty(&summary).map_err(|source| ArkitError::Summary {
        path: path.clone(),
        source,
    })?;
    crate::io::atomic::write(&path, json.as_bytes())?;
    Ok(playback)
}

/// The sample capture `tests/data/arkit-sample.csv`: 30 frames at 30 fps of Live Link Face's 61
/// channels, zero except smooth curves on a few: the jaw opening and closing, a smile rising on
/// both sides, the inner brows, a blink, a cheek puff, and two channels the golden ICT actor
/// cannot play (`MouthClose`, the head's yaw).
pub fn sample_capture() -> Capture {
    let channels: Vec<String> = LIVE_LINK_FACE_CHANNELS.map(String::from).to_vec();
    type Curve = fn(f64) -> f64;
    let curves: [(&str, Curve); 8] = [
        ("JawOpen", |t| (std::f64::consts::PI * t).sin() * 0.8),
        ("MouthSmileLeft", |t| t * t),
        ("MouthSmileRight", |t| t * t * 0.9),
        ("BrowInnerUp", |t| {
            0.5 - 0.5 * (2.0 * std::f64::consts::PI * t).cos()
        }),
        ("EyeBlinkRight", |t| (-((t - 0.5) / 0.08).powi(2)).exp()),
        ("CheekPuff", |t| 0.6 * t),
        ("MouthClose", |t| 0.3 * (std::f64::consts::PI * t).sin()),
        ("HeadYaw", |t| 0.2 * (2.0 * std::f64::consts::PI * t).sin()),
    ];
    let frames = (0..30)
        .map(|f| {
            let t = f as f64 / 29.0;
            let mut values = vec![0.0f32; channels.len()];
            for (name, curve) in &curves {
                if let Some(c) = channels.iter().position(|n| n == name) {
                    // Four decimals, as the CSV stores them, so the file reads back exactly (and
                    // `+ 0.0` turns a rounded −0 into 0).
                    values[c] = ((curve(t) * 1e4).round() / 1e4) as f32 + 0.0;
                }
            }
            CaptureFrame {
                timecode: format!("00:00:01:{f:02}.000"),
                values,
            }
        })
        .collect();
    Capture { channels, frames }
}

/// The capture `tests/data/arkit-each.csv`: Live Link Face's 61 channels, frame 0 at rest, then
/// each of ARKit's 52 blendshape channels alone at 1 for one frame (53 frames at 30 fps): every
/// shape an ARKit rig plays, one at a time, with the jaw it learned.
pub fn each_channel_capture() -> Capture {
    let channels: Vec<String> = LIVE_LINK_FACE_CHANNELS.map(String::from).to_vec();
    let frames = (0..=ARKIT_SHAPES)
        .map(|f| CaptureFrame {
            timecode: format!("00:00:{:02}:{:02}.000", f / 30, f % 30),
            values: (0..channels.len())
                .map(|c| if c + 1 == f { 1.0 } else { 0.0 })
                .collect(),
        })
        .collect();
    Capture { channels, frames }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repo(path: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
    }

    fn golden() -> Vec<u8> {
        std::fs::read(repo("tests/data/aim-ict.sinew")).unwrap()
    }

    /// The committed sample is what [`sample_capture`] makes; only `UPDATE_EXPECT=1` rewrites it.
    #[test]
    fn sample_capture_is_the_committed_file() {
        let path = repo("tests/data/arkit-sample.csv");
        let made = sample_capture().to_csv();
        if std::env::var_os("UPDATE_EXPECT").is_some_and(|v| v == "1") {
            crate::io::atomic::write(&path, made.as_bytes()).unwrap();
        }
        let committed = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (UPDATE_EXPECT=1 writes it)", path.display()));
        assert_eq!(committed, made, "{} is stale", path.display());
        assert_eq!(Capture::read(&path).unwrap(), sample_capture());
    }

    /// The committed one-channel-at-a-time capture is what [`each_channel_capture`] makes.
    #[test]
    fn each_channel_capture_is_the_committed_file() {
        let path = repo("tests/data/arkit-each.csv");
        let made = each_channel_capture().to_csv();
        if std::env::var_os("UPDATE_EXPECT").is_some_and(|v| v == "1") {
            crate::io::atomic::write(&path, made.as_bytes()).unwrap();
        }
        let committed = std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("{}: {e} (UPDATE_EXPECT=1 writes it)", path.display()));
        assert_eq!(committed, made, "{} is stale", path.display());
        let read = Capture::read(&path).unwrap();
        assert_eq!(read.frames.len(), 53);
        // Frame f + 1 raises channel f alone.
        for (f, frame) in read.frames.iter().enumerate() {
            let raised: Vec<usize> = (0..61).filter(|&c| frame.values[c] != 0.0).collect();
            let want: Vec<usize> = f.checked_sub(1).into_iter().collect();
            assert_eq!(raised, want, "frame {f}");
        }
    }

    #[test]
    fn maps_live_link_names_onto_the_kit_shapes() {
        let bytes = golden();
        let actor = AimActor::from_bytes(&bytes).unwrap();
        let capture = sample_capture();
        let p = playback_of(&actor, Path::new("sample.csv"), &capture).unwrap();
        let pair = |c: &str, s: &str| (c.to_string(), s.to_string());
        for want in [
            pair("JawOpen", "jawOpen"),
            pair("MouthSmileLeft", "mouthSmile_L"),
            pair("MouthSmileRight", "mouthSmile_R"),
            pair("BrowInnerUp", "browInnerUp_L"),
            pair("CheekPuff", "cheekPuff_L"),
            pair("EyeBlinkRight", "eyeBlink_R"),
            pair("MouthRollLower", "mouthRollLower"),
        ] {
            assert!(
                p.mapping.played.contains(&want),
                "{want:?} not in {:?}",
                p.mapping.played
            );
        }
        // The actor learned all 19 of its shapes from ARKit-named kit shapes: a full capture
        // drives each of them.
        assert_eq!(p.mapping.played.len(), 19);
        assert!(p.mapping.at_rest.is_empty(), "{:?}", p.mapping.at_rest);
        assert_eq!(p.mapping.head, ["HeadYaw", "HeadPitch", "HeadRoll"]);
        for lost in ["MouthClose", "EyeBlinkLeft", "TongueOut", "RightEyeRoll"] {
            assert!(
                p.mapping.unplayable.iter().any(|c| c == lost),
                "{lost} should be unplayable"
            );
        }
        assert_eq!(p.mapping.unplayable.len(), 61 - 19 - 3);
        // Every played shape whose learned jaw turns by more than the threshold is listed with
        // its angle, jawOpen's 21.1° among them.
        let shapes = crate::aim::play::corrective_names(&actor);
        let degrees = jaw_degrees(&actor);
        assert_eq!(degrees.len(), shapes.len());
        let moving: Vec<(String, f32)> = shapes
            .iter()
            .zip(&degrees)
            .filter(|(_, d)| **d > MOVES_JAW_DEGREES)
            .map(|(n, d)| (n.clone(), *d))
            .collect();
        eprintln!("shapes that move the jaw: {moving:?}");
        assert_eq!(p.mapping.jaw_shapes, moving);
        let open = moving.iter().find(|(n, _)| n == "jawOpen").unwrap().1;
        assert!((open - 21.1).abs() < 0.05, "jawOpen turns {open}°");
    }

    #[test]
    fn frames_move_where_the_capture_says() {
        let bytes = golden();
        let actor = AimActor::from_bytes(&bytes).unwrap();
        let capture = sample_capture();
        let p = playback_of(&actor, Path::new("sample.csv"), &capture).unwrap();
        assert_eq!(p.frames.len(), 30);
        let shapes = crate::aim::play::corrective_names(&actor);
        let s = |n: &str| shapes.iter().position(|x| x == n).unwrap();
        let c = |n: &str| capture.channel(n).unwrap();
        // The first frame is at rest: no weight, the jaw and head the identity.
        assert!(p.frames[0].weights.iter().all(|w| *w == 0.0));
        assert_eq!(p.frames[0].jaw, IDENTITY_9D);
        for (f, (frame, row)) in p.frames.iter().zip(&capture.frames).enumerate() {
            assert_eq!(
                frame.weights[s("jawOpen")],
                row.values[c("JawOpen")],
                "frame {f}"
            );
            assert_eq!(
                frame.weights[s("mouthSmile_L")],
                row.values[c("MouthSmileLeft")]
            );
            assert_eq!(
                frame.weights[s("browInnerUp_L")],
                row.values[c("BrowInnerUp")]
            );
            assert_eq!(
                frame.weights[s("eyeBlink_R")],
                row.values[c("EyeBlinkRight")]
            );
            assert_eq!(frame.weights[s("noseSneer_R")], 0.0);
            // The head turns by the capture's yaw about the jaw's hinge, which stays put.
            let yaw = f64::from(row.values[c("HeadYaw")]);
            let angle = f64::from(frame.head[0]).clamp(-1.0, 1.0).acos();
            assert!(
                (angle - yaw.abs()).abs() < 1e-5,
                "frame {f}: {angle} against {yaw}"
            );
            assert!(
                (f64::from(frame.head[2]) + yaw.sin()).abs() < 1e-6,
                "frame {f}"
            );
            let pivot = actor.jaw_pivot();
            let r = sinew_core::rotation::rigid_from_9d(&frame.head);
            let moved = r.apply(pivot);
            assert!((moved - pivot).norm() < 1e-4, "frame {f}: the hinge moved");
            // The jaw is the core's for the frame's coefficients: every shape's learned jaw.
            assert_eq!(
                frame.jaw,
                actor.jaw_from_weights(&frame.weights).unwrap(),
                "frame {f}"
            );
        }
        // At the jaw's widest (frame 15, JawOpen 0.8 with the smiles and brows up) it opens by
        // most of jawOpen's learned 21°.
        let opened = crate::aim::eval::rotation_degrees(&p.frames[15].jaw);
        assert!((14.0..21.2).contains(&opened), "{opened}°");
        // Posed through the core, the blink at mid-sequence moves the right eyelid: the vertex
        // that moves most between the first frame and the blink's peak (frame 14, where the
        // brows are also up and the jaw open) lies in the upper face, and the right lid (x < 0:
        // x points to the actor's left) moves while the left one stays.
        let pose = |f: &Frame| {
            let mut out = vec![0.0; 3 * actor.vertex_count()];
            actor
                .pose(
                    &actor.pose_from_9d(&f.jaw, &f.head).unwrap(),
                    &f.weights,
                    &mut out,
                )
                .unwrap();
            out
        };
        let rest = pose(&p.frames[0]);
        let mut blink_only = p.frames[0].clone();
        blink_only.weights[s("eyeBlink_R")] = p.frames[14].weights[s("eyeBlink_R")];
        let blink = pose(&blink_only);
        let moved: Vec<(usize, f32)> = (0..actor.vertex_count())
            .map(|i| {
                let d = (0..3)
                    .map(|k| (blink[3 * i + k] - rest[3 * i + k]).powi(2))
                    .sum::<f32>();
                (i, d.sqrt())
            })
            .collect();
        let (top, amount) = moved
            .iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        assert!(amount > 0.3, "the blink moves the lid by {amount} cm");
        assert!(
            rest[3 * top] < 0.0,
            "the blink moves the actor's right side (x < 0)"
        );
        let mirrored_max = moved
            .iter()
            .filter(|(i, _)| rest[3 * i] > 1.0)
            .map(|m| m.1)
            .fold(0.0f32, f32::max);
        assert!(
            mirrored_max < 0.1 * amount,
            "the left side moves {mirrored_max} cm"
        );
        // With the jaw open most (frame 15), the vertex that moves most lies below the jaw's
        // pivot, and it moves down.
        let open = pose(&p.frames[15]);
        let lowest = (0..actor.vertex_count())
            .max_by(|&a, &b| {
                let d = |i: usize| {
                    (0..3)
                        .map(|k| (open[3 * i + k] - rest[3 * i + k]).powi(2))
                        .sum::<f32>()
                };
                d(a).total_cmp(&d(b))
            })
            .unwrap();
        assert!(
            rest[3 * lowest + 1] < actor.jaw_pivot().y,
            "the lower face moves most"
        );
        assert!(
            open[3 * lowest + 1] < rest[3 * lowest + 1] - 0.5,
            "and it drops"
        );
    }

    #[test]
    fn a_capture_matching_no_shape_is_an_error_naming_the_file() {
        let bytes = golden();
        let actor = AimActor::from_bytes(&bytes).unwrap();
        let capture = Capture::parse(
            Path::new("odd.csv"),
            "Timecode,BlendshapeCount,HeadYaw,TongueOut\na,2,0.1,0.2\n",
        )
        .unwrap();
        let e = playback_of(&actor, Path::new("odd.csv"), &capture).unwrap_err();
        assert!(
            matches!(&e, ArkitError::NoMatch { path, channels, .. }
                if path == Path::new("odd.csv") && channels.len() == 2),
            "{e}"
        );
        assert!(
            e.to_string()
                .starts_with("odd.csv: no capture channel matches"),
            "{e}"
        );
    }

    #[test]
    fn a_missing_capture_or_model_is_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let model = dir.path().join("actor.sinew");
        std::fs::write(&model, golden()).unwrap();
        let missing = dir.path().join("missing.csv");
        let e = play_arkit(&model, &missing, &dir.path().join("out")).unwrap_err();
        assert!(matches!(e, ArkitError::Capture(_)), "{e}");
        let damaged = dir.path().join("damaged.sinew");
        std::fs::write(&damaged, &golden()[..100]).unwrap();
        let e = play_arkit(&damaged, &missing, &dir.path().join("out")).unwrap_err();
        assert!(
            matches!(e, ArkitError::Play(PlayError::Container(_))),
            "{e}"
        );
    }

    #[test]
    fn sides_map_only_onto_sided_kits() {
        let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let channels = names(&["MouthSmileLeft", "BrowInnerUp", "JawOpen"]);
        // A kit without `_L`/`_R` names: only exact names match.
        let plain = Mapping::new(
            Path::new("c.csv"),
            &channels,
            &names(&["jawopen", "mouthSmileLeft"]),
        )
        .unwrap();
        assert_eq!(plain.routes, [(0, 1), (2, 0)]);
        assert!(plain.unplayable == ["BrowInnerUp"]);
        let sided = Mapping::new(
            Path::new("c.csv"),
            &channels,
            &names(&["mouthSmile_L", "browInnerUp_L", "browInnerUp_R"]),
        )
        .unwrap();
        assert_eq!(sided.routes, [(0, 0), (1, 1), (1, 2)]);
        assert_eq!(sided.unplayable, ["JawOpen"]);
    }
}
