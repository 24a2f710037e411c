//! `sinew view` on an S2D decoder: a landmark track played through the decoder in the page. The
//! track is an S2D replay (`sinew replay record --model S2D.sinew`, docs/FORMAT.md "S2D
//! replays"): per frame the decoder's input, the 68 landmarks' motion from the neutral, and the
//! hash recorded for it. The face decoded onto is `--neutral` (a face in the decoder's topology,
//! whose polygons the page draws), else the replay's neutral, else the decoder's template.

use serde::Serialize;
use sinew_core::replay::{S2dReplay, check_s2d_model};
use sinew_core::s2d::S2dDecoder;

use super::error::ViewError;
use super::files::{Entry, Inputs, Site, file_name, page};
use crate::io::mesh::Mesh;

/// What the page learns from `/config.json` for an S2D decoder.
#[derive(Debug, Serialize)]
struct Config<'a> {
    model: &'a str,
    /// `s2d`.
    kind: &'static str,
    track: Option<Track<'a>>,
    neutral: Option<Neutral<'a>>,
}

#[derive(Debug, Serialize)]
struct Track<'a> {
    name: &'a str,
    frames: usize,
    /// Whether the replay carries the neutral its frames were recorded onto.
    neutral: bool,
    /// Whether the page decodes onto the face the hashes were recorded with (no `--neutral`),
    /// so that it can compare them.
    compare: bool,
}

#[derive(Debug, Serialize)]
struct Neutral<'a> {
    name: &'a str,
    vertices: usize,
    triangles: usize,
}

/// `/neutral.json`: the face to decode onto and its triangles.
#[derive(Debug, Serialize)]
struct NeutralFile {
    /// `[V·3]`.
    positions: Vec<f32>,
    /// `[T·3]`, polygons fan-triangulated.
    triangles: Vec<u32>,
}

/// Reads and checks an S2D decoder's files (`model` holds the decoder's bytes, a valid
/// container) and builds the table.
pub(super) fn load(inputs: Inputs<'_>, model: Vec<u8>) -> Result<Site, ViewError> {
    let decoder = S2dDecoder::from_bytes(&model).map_err(|source| ViewError::NotAnS2dDecoder {
        path: inputs.model.to_path_buf(),
        source,
    })?;
    for (flag, path) in [
        ("--replay", inputs.replay),
        ("--poses", inputs.poses),
        ("--performance", inputs.performance),
        ("--driver", inputs.driver.map(|d| d.driver)),
        ("--webcam --driver", inputs.webcam.map(|w| w.driver)),
    ] {
        if let Some(path) = path {
            return Err(ViewError::ActorFileForS2d {
                path: path.to_path_buf(),
                flag,
                model: inputs.model.to_path_buf(),
            });
        }
    }

    let mut track = None;
    if let Some(path) = inputs.track {
        let bytes = crate::io::container::read(path)?;
        let parsed = S2dReplay::from_bytes(&bytes).map_err(|source| ViewError::NotAnS2dReplay {
            path: path.to_path_buf(),
            source,
        })?;
        check_s2d_model(&model, &decoder, &parsed).map_err(|source| ViewError::DoesNotPlay {
            path: path.to_path_buf(),
            model: inputs.model.to_path_buf(),
            source,
        })?;
        let carries = parsed.neutral().is_some();
        track = Some((file_name(path), parsed.frames(), carries, bytes));
    }

    let mut neutral = None;
    if let Some(path) = inputs.neutral {
        let mesh = Mesh::read(path)?;
        let vertices = decoder.vertex_count();
        if mesh.positions.len() != vertices {
            return Err(ViewError::NeutralVertices {
                path: path.to_path_buf(),
                vertices: mesh.positions.len(),
                model: inputs.model.to_path_buf(),
                expected: vertices,
            });
        }
        let file = NeutralFile {
            positions: mesh.positions.iter().flatten().copied().collect(),
            triangles: mesh.triangles().into_iter().flatten().collect(),
        };
        if file.positions.iter().any(|x| !x.is_finite()) {
            return Err(ViewError::NeutralNonFinite {
                path: path.to_path_buf(),
            });
        }
        let json = serde_json::to_vec(&file).map_err(ViewError::Json)?;
        neutral = Some((file_name(path), vertices, file.triangles.len() / 3, json));
    }

    let model_name = file_name(inputs.model);
    let config = serde_json::to_vec(&Config {
        model: &model_name,
        kind: "s2d",
        track: track.as_ref().map(|(name, frames, carries, _)| Track {
            name,
            frames: *frames,
            neutral: *carries,
            compare: neutral.is_none(),
        }),
        neutral: neutral
            .as_ref()
            .map(|(name, vertices, triangles, _)| Neutral {
                name,
                vertices: *vertices,
                triangles: *triangles,
            }),
    })
    .map_err(ViewError::Json)?;
    let mut entries = page(&config, &model);
    if let Some((_, _, _, bytes)) = track {
        entries.push(Entry {
            path: "/track.sinew",
            content_type: "application/octet-stream",
            body: bytes.into(),
        });
    }
    if let Some((_, _, _, json)) = neutral {
        entries.push(Entry {
            path: "/neutral.json",
            content_type: "application/json",
            body: json.into(),
        });
    }
    Site::new(entries)
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    use super::*;

    fn data(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data")
            .join(name)
    }

    fn body<'a>(site: &'a Site, path: &str) -> Option<&'a [u8]> {
        site.get(path).map(|e| &e.body[..])
    }

    fn config(site: &Site) -> serde_json::Value {
        serde_json::from_slice(body(site, "/config.json").unwrap()).unwrap()
    }

    /// The golden decoder's template written as a mesh file, with made-up triangles (the
    /// decoder stores none), `drop` vertices fewer.
    fn template_mesh(dir: &Path, drop: usize) -> (PathBuf, Vec<f32>) {
        let bytes = std::fs::read(data("s2d-ict.sinew")).unwrap();
        let decoder = S2dDecoder::from_bytes(&bytes).unwrap();
        let mut positions: Vec<f32> = decoder.neutral().iter().collect();
        positions.truncate(positions.len() - 3 * drop);
        let n = positions.len() as u32 / 3;
        let faces = (0..n - 2)
            .step_by(3)
            .map(|i| vec![i, i + 1, i + 2])
            .collect();
        let path = dir.join("face.obj");
        Mesh::new(crate::io::mesh::points(positions.clone()), faces)
            .write(&path)
            .unwrap();
        (path, positions)
    }

    #[test]
    fn serves_a_decoder_and_its_landmark_track() {
        let (model, track) = (data("s2d-ict.sinew"), data("s2d-ict.replay.sinew"));
        let site = Site::load(Inputs {
            track: Some(&track),
            ..Inputs::of(&model)
        })
        .unwrap();
        let c = config(&site);
        assert_eq!(c["kind"], "s2d");
        assert_eq!(c["model"], "s2d-ict.sinew");
        assert_eq!(c["track"]["name"], "s2d-ict.replay.sinew");
        assert_eq!(c["track"]["frames"], 16);
        assert_eq!(c["track"]["neutral"], true);
        assert_eq!(c["track"]["compare"], true);
        assert!(c["neutral"].is_null());
        assert_eq!(
            body(&site, "/track.sinew").unwrap(),
            &std::fs::read(&track).unwrap()[..]
        );
        assert_eq!(
            body(&site, "/model.sinew").unwrap(),
            &std::fs::read(&model).unwrap()[..]
        );
        assert!(body(&site, "/neutral.json").is_none());
        assert!(body(&site, "/replay.sinew").is_none());
        // A decoder alone: its template, nothing to play.
        let alone = Site::load(Inputs::of(&model)).unwrap();
        assert!(config(&alone)["track"].is_null());
        assert!(body(&alone, "/track.sinew").is_none());
    }

    #[test]
    fn serves_a_neutral_in_the_decoders_topology_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let (face, positions) = template_mesh(dir.path(), 0);
        let (model, track) = (data("s2d-ict.sinew"), data("s2d-ict.replay.sinew"));
        let site = Site::load(Inputs {
            track: Some(&track),
            neutral: Some(&face),
            driver: None,
            webcam: None,
            ..Inputs::of(&model)
        })
        .unwrap();
        let c = config(&site);
        assert_eq!(c["neutral"]["name"], "face.obj");
        assert_eq!(c["neutral"]["vertices"], 1177);
        assert_eq!(c["neutral"]["triangles"], 1177 / 3);
        // Decoded onto another face, the recorded hashes do not apply.
        assert_eq!(c["track"]["compare"], false);
        let served: serde_json::Value =
            serde_json::from_slice(body(&site, "/neutral.json").unwrap()).unwrap();
        let read_back: Vec<f32> = served["positions"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        // The OBJ holds the template as written; JSON carries each f32 exactly.
        let from_obj: Vec<f32> = Mesh::read(&face)
            .unwrap()
            .positions
            .iter()
            .flatten()
            .copied()
            .collect();
        assert_eq!(read_back.len(), positions.len());
        assert!(
            read_back
                .iter()
                .zip(&from_obj)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert_eq!(
            served["triangles"].as_array().unwrap().len(),
            3 * (1177 / 3)
        );
    }

    #[test]
    fn refuses_files_of_the_wrong_kind_or_topology_naming_them() {
        let err = |inputs: Inputs<'_>| Site::load(inputs).unwrap_err();
        let model = data("s2d-ict.sinew");
        let replay = data("aim-ict.f32.replay.sinew");
        let e = err(Inputs {
            replay: Some(&replay),
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::ActorFileForS2d { path, flag: "--replay", .. } if *path == replay),
            "{e}"
        );
        let fit = data("fit-ict.sinew");
        let e = err(Inputs {
            performance: Some(&fit),
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::ActorFileForS2d { path, flag: "--performance", .. } if *path == fit),
            "{e}"
        );
        // An AIM replay is not a landmark track.
        let e = err(Inputs {
            track: Some(&replay),
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::NotAnS2dReplay { path, .. } if *path == replay),
            "{e}"
        );
        let dir = tempfile::tempdir().unwrap();
        let (face, _) = template_mesh(dir.path(), 5);
        let e = err(Inputs {
            neutral: Some(&face),
            driver: None,
            webcam: None,
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::NeutralVertices { path, vertices: 1172, expected: 1177, .. }
                if *path == face),
            "{e}"
        );
        let missing = dir.path().join("missing.obj");
        let e = err(Inputs {
            neutral: Some(&missing),
            driver: None,
            webcam: None,
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::Mesh(crate::io::mesh::MeshError::Read { path, .. }) if *path == missing),
            "{e}"
        );
    }
}
