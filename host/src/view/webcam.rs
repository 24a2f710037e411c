//! `sinew view --webcam`: a person's own face drives the actor live. The page asks for the
//! camera, runs MediaPipe Face Mesh on every frame (its web files served from a local folder,
//! nothing fetched from the internet), and drives, filters and poses the actor through the core
//! compiled to WebAssembly (`web/webcam.js`). This part checks the driver and reads the tracker's
//! files into the table at start-up; docs/VIEW.md, "A webcam".

use std::path::Path;

use serde::Serialize;
use sinew_core::driver::Intrinsics;

use super::error::ViewError;
use crate::driver::mediapipe::{IBUG_POINTS, reads_mediapipe};

/// The npm package (Apache-2.0) whose web files the page runs, at the version the page is tested
/// with; `npm install` of it puts them in `node_modules/@mediapipe/face_mesh`.
pub const TRACKER_PACKAGE: &str = "@mediapipe/face_mesh@0.4.1633559619";

/// Where `--tracker-dir` looks when not told: what `npm install` of [`TRACKER_PACKAGE`] makes in
/// the folder it runs in.
pub const DEFAULT_TRACKER_DIR: &str = "node_modules/@mediapipe/face_mesh";

/// The package's files the page loads, their URL paths and types. The solution picks the SIMD or
/// plain WebAssembly build by what the browser supports, so both are served.
const TRACKER_FILES: &[(&str, &str, &str)] = &[
    (
        "face_mesh.js",
        "/mediapipe/face_mesh.js",
        "text/javascript; charset=utf-8",
    ),
    (
        "face_mesh.binarypb",
        "/mediapipe/face_mesh.binarypb",
        "application/octet-stream",
    ),
    (
        "face_mesh_solution_packed_assets_loader.js",
        "/mediapipe/face_mesh_solution_packed_assets_loader.js",
        "text/javascript; charset=utf-8",
    ),
    (
        "face_mesh_solution_packed_assets.data",
        "/mediapipe/face_mesh_solution_packed_assets.data",
        "application/octet-stream",
    ),
    (
        "face_mesh_solution_simd_wasm_bin.js",
        "/mediapipe/face_mesh_solution_simd_wasm_bin.js",
        "text/javascript; charset=utf-8",
    ),
    (
        "face_mesh_solution_simd_wasm_bin.wasm",
        "/mediapipe/face_mesh_solution_simd_wasm_bin.wasm",
        "application/wasm",
    ),
    (
        "face_mesh_solution_wasm_bin.js",
        "/mediapipe/face_mesh_solution_wasm_bin.js",
        "text/javascript; charset=utf-8",
    ),
    (
        "face_mesh_solution_wasm_bin.wasm",
        "/mediapipe/face_mesh_solution_wasm_bin.wasm",
        "application/wasm",
    ),
];

/// A MediaPipe landmark driver of the actor and the folder of MediaPipe Face Mesh's web files.
#[derive(Clone, Copy, Debug)]
pub struct WebcamInputs<'a> {
    /// The driver (.sinew, `sinew train driver --input mediapipe`).
    pub driver: &'a Path,
    /// The folder holding [`TRACKER_PACKAGE`]'s files (`face_mesh.js`, …).
    pub tracker: &'a Path,
    /// The camera's intrinsics in pixels; without them the page takes a webcam's usual field of
    /// view for the video's size (`driver::mediapipe::webcam_intrinsics`).
    pub intrinsics: Option<Intrinsics>,
}

/// What the page learns of the webcam driver.
#[derive(Debug, Serialize)]
pub(super) struct WebcamConfig {
    /// The driver's file name.
    driver: String,
    /// The tracker package served.
    tracker: &'static str,
    /// MediaPipe's point at each of iBUG's 68 places, the driver's inputs in order.
    points: Vec<u16>,
    /// `[fx, fy, cx, cy]`, or none for a webcam's usual field of view.
    intrinsics: Option<[f32; 4]>,
}

/// A file to serve: its URL path, its type and its bytes.
pub(super) type Served = (&'static str, &'static str, Vec<u8>);

/// Checks the driver against the actor (`model` holds its bytes) and that it reads MediaPipe's
/// points, reads the tracker's files, and gives the page's configuration (the driver shown as
/// `driver_name`) and the files to serve.
pub(super) fn load(
    inputs: &WebcamInputs<'_>,
    driver_name: String,
    model_path: &Path,
    model: &[u8],
) -> Result<(WebcamConfig, Vec<Served>), ViewError> {
    let bytes = crate::io::container::read(inputs.driver)?;
    drop(crate::driver::drive::bind(
        model_path,
        model,
        inputs.driver,
        &bytes,
    )?);
    if !reads_mediapipe(&bytes) {
        return Err(ViewError::NotAMediaPipeDriver {
            path: inputs.driver.to_path_buf(),
        });
    }
    let mut entries = Vec::with_capacity(TRACKER_FILES.len() + 1);
    for &(file, path, content_type) in TRACKER_FILES {
        let missing = |problem: String| ViewError::TrackerMissing {
            dir: inputs.tracker.to_path_buf(),
            file,
            problem,
            package: TRACKER_PACKAGE,
        };
        let body = std::fs::read(inputs.tracker.join(file)).map_err(|e| {
            missing(if e.kind() == std::io::ErrorKind::NotFound {
                "is missing".to_owned()
            } else {
                format!("cannot be read: {e}")
            })
        })?;
        if body.is_empty() {
            return Err(missing("is empty".to_owned()));
        }
        entries.push((path, content_type, body));
    }
    entries.push(("/driver.sinew", "application/octet-stream", bytes));
    let config = WebcamConfig {
        driver: driver_name,
        tracker: TRACKER_PACKAGE,
        points: IBUG_POINTS.to_vec(),
        intrinsics: inputs.intrinsics.map(|c| [c.fx, c.fy, c.cx, c.cy]),
    };
    Ok((config, entries))
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    use super::*;
    use crate::view::{Inputs, Site};

    fn data(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data")
            .join(name)
    }

    /// A tracker folder with every file the page loads, each holding its own name.
    fn tracker() -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        for (file, _, _) in TRACKER_FILES {
            std::fs::write(dir.path().join(file), file).unwrap();
        }
        dir
    }

    fn load(driver: &str, tracker: &Path) -> Result<Site, ViewError> {
        load_for("aim-ict.sinew", driver, tracker)
    }

    /// The site of actor `model` with `driver` and the tracker folder.
    fn load_for(model: &str, driver: &str, tracker: &Path) -> Result<Site, ViewError> {
        Site::load(Inputs {
            webcam: Some(WebcamInputs {
                driver: &data(driver),
                tracker,
                intrinsics: None,
            }),
            ..Inputs::of(&data(model))
        })
    }

    /// The MediaPipe driver and the tracker's files are served, the configuration names the
    /// points the page reads, and the policy lets MediaPipe's glue evaluate strings only here.
    #[test]
    fn serves_the_driver_and_the_trackers_files() {
        let dir = tracker();
        let site = load("driver-ict-mediapipe.sinew", dir.path()).unwrap();
        for (file, path, content_type) in TRACKER_FILES {
            let entry = site.get(path).unwrap();
            assert_eq!(&entry.body[..], file.as_bytes());
            assert_eq!(entry.content_type, *content_type);
        }
        let driver = std::fs::read(data("driver-ict-mediapipe.sinew")).unwrap();
        assert_eq!(&site.get("/driver.sinew").unwrap().body[..], &driver[..]);
        let config: serde_json::Value =
            serde_json::from_slice(&site.get("/config.json").unwrap().body).unwrap();
        let webcam = &config["webcam"];
        assert_eq!(webcam["driver"], "driver-ict-mediapipe.sinew");
        assert_eq!(webcam["tracker"], TRACKER_PACKAGE);
        let points: Vec<u16> = serde_json::from_value(webcam["points"].clone()).unwrap();
        assert_eq!(points, IBUG_POINTS);
        assert!(webcam["intrinsics"].is_null());
        assert!(site.policy().contains("'unsafe-eval'"));
        assert!(site.get("/landmarks.json").is_none());
    }

    /// A missing or empty tracker file names the folder, the file and the command that installs
    /// it; an iBUG driver, or one of another actor, is refused naming it.
    #[test]
    fn refuses_a_missing_tracker_and_a_driver_that_does_not_read_it() {
        let dir = tracker();
        std::fs::remove_file(dir.path().join("face_mesh_solution_simd_wasm_bin.wasm")).unwrap();
        let e = load("driver-ict-mediapipe.sinew", dir.path())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&dir.path().display().to_string())
                && e.contains("face_mesh_solution_simd_wasm_bin.wasm is missing")
                && e.contains("npm install @mediapipe/face_mesh@0.4.1633559619"),
            "{e}"
        );
        let dir = tracker();
        std::fs::write(dir.path().join("face_mesh.binarypb"), b"").unwrap();
        let e = load("driver-ict-mediapipe.sinew", dir.path())
            .unwrap_err()
            .to_string();
        assert!(e.contains("face_mesh.binarypb is empty"), "{e}");

        let dir = tracker();
        let e = load("driver-ict.sinew", dir.path()).unwrap_err();
        assert!(
            matches!(&e, ViewError::NotAMediaPipeDriver { path } if path.ends_with("driver-ict.sinew")),
            "{e}"
        );
        let other = load_for(
            "aim-procedural.sinew",
            "driver-ict-mediapipe.sinew",
            dir.path(),
        )
        .unwrap_err()
        .to_string();
        assert!(other.contains("driver-ict-mediapipe.sinew"), "{other}");
    }
}
