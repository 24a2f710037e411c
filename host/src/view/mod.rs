//! `sinew view`: a baked AIM actor or S2D decoder in a web browser. A small server on 127.0.0.1
//! serves a page (WebGL2, `web/`) that poses the actor, or decodes a landmark track, through the
//! core compiled to WebAssembly, with sliders, orbit controls and playback; docs/VIEW.md.
//!
//! [`files`] is the fixed table of what is served (`s2d` its S2D decoder's part), [`server`]
//! the HTTP side and its safety rules.

mod error;
pub mod files;
mod s2d;
pub mod server;
pub mod webcam;

use std::time::{Duration, Instant};

use sinew_core::format::{ArtifactKind, SinewFile};

pub use error::ViewError;
pub use files::{DriverInputs, Inputs, Site};
pub use server::Viewer;
pub use webcam::WebcamInputs;

impl Site {
    /// Reads and validates the data files and builds the table, for an AIM actor
    /// (`files`) or an S2D decoder (`s2d`) as the model's header says. Errors name the file
    /// and what is wrong with it: not a `.sinew` artefact, neither an AIM actor nor an S2D
    /// decoder, a replay of another model, a pose file of the wrong shape, a performance fitted
    /// to another actor, a file given for the other kind of model, a neutral of another
    /// topology.
    pub fn load(inputs: Inputs<'_>) -> Result<Self, ViewError> {
        let model = crate::io::container::read(inputs.model)?;
        let kind = SinewFile::from_bytes(&model)
            .map_err(|source| ViewError::Model {
                path: inputs.model.to_path_buf(),
                source,
            })?
            .kind;
        if kind == ArtifactKind::S2dDecoder {
            s2d::load(inputs, model)
        } else {
            Site::load_aim(inputs, model)
        }
    }
}

/// `sinew view`: loads and checks the files, listens on 127.0.0.1:`port` (0: any free port),
/// hands the page's address to `ready` (the command prints it as its first line), and serves
/// until Ctrl-C or, with `exit_after`, until that time has passed.
pub fn view(
    inputs: Inputs<'_>,
    port: u16,
    exit_after: Option<Duration>,
    ready: impl FnOnce(&str),
) -> Result<(), ViewError> {
    let viewer = Viewer::bind(Site::load(inputs)?, port)?;
    crate::training::interrupt::watch_ctrl_c();
    ready(&viewer.url());
    viewer.serve(
        exit_after.map(|d| Instant::now() + d),
        crate::training::interrupt::take_stop_request,
    )
}

#[cfg(test)]
mod tests {
    use std::io::{Read, Write};
    use std::net::{Ipv4Addr, SocketAddr, TcpStream};
    use std::path::{Path, PathBuf};
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    use hyper::Method;

    use super::server::respond;
    use super::*;

    pub(crate) fn data(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/data")
            .join(name)
    }

    /// The procedural golden actor and its replay, served.
    pub(crate) fn site() -> Site {
        Site::load(Inputs {
            replay: Some(&data("aim-procedural.f32.replay.sinew")),
            ..Inputs::of(&data("aim-procedural.sinew"))
        })
        .unwrap()
    }

    const LOCAL: Option<SocketAddr> = Some(SocketAddr::new(
        std::net::IpAddr::V4(Ipv4Addr::LOCALHOST),
        50000,
    ));

    fn get(site: &Site, url: &str) -> server::Reply {
        respond(site, &Method::GET, url, LOCAL, Some("127.0.0.1:8000"), 8000)
    }

    #[test]
    fn serves_its_table_and_nothing_else() {
        let site = site();
        for entry in site.entries() {
            let reply = get(&site, entry.path);
            assert_eq!(reply.status, 200, "{}", entry.path);
            assert_eq!(reply.body, &entry.body[..]);
        }
        let model = std::fs::read(data("aim-procedural.sinew")).unwrap();
        assert_eq!(get(&site, "/model.sinew").body, &model[..]);
        assert_eq!(get(&site, "/model.sinew?x=1").body, &model[..]);
        assert_eq!(get(&site, "/sinew_wasm.wasm").body[..4], *b"\0asm");
        assert_eq!(
            get(&site, "/sinew_wasm.wasm").content_type,
            "application/wasm"
        );
        let config: serde_json::Value =
            serde_json::from_slice(&get(&site, "/config.json").body).unwrap();
        assert_eq!(config["replay"]["frames"], 16);
        assert_eq!(config["replay"]["mode"], "f32");
        assert!(config["poses"].is_null());
        for url in [
            "/../Cargo.toml",
            "/%2e%2e/",
            "/%2e%2e/Cargo.toml",
            "/..%2fCargo.toml",
            "//etc/passwd",
            "/index.html/../model.sinew",
            "/poses.json",
            "/Cargo.toml",
            "../Cargo.toml",
            "",
            "/model.sinew/",
            "/MODEL.SINEW",
        ] {
            assert_eq!(get(&site, url).status, 404, "{url}");
        }
    }

    #[test]
    fn refuses_other_peers_hosts_and_methods() {
        let site = site();
        let host = Some("127.0.0.1:8000");
        for peer in [
            "192.168.1.20:5000",
            "10.0.0.1:80",
            "[2001:db8::1]:80",
            "0.0.0.0:1",
        ] {
            let peer: SocketAddr = peer.parse().unwrap();
            let reply = respond(&site, &Method::GET, "/", Some(peer), host, 8000);
            assert_eq!(reply.status, 403, "{peer}");
        }
        assert_eq!(
            respond(&site, &Method::GET, "/", None, host, 8000).status,
            403
        );
        let ipv6_loopback: SocketAddr = "[::1]:5000".parse().unwrap();
        let reply = respond(&site, &Method::GET, "/", Some(ipv6_loopback), host, 8000);
        assert_eq!(reply.status, 200);
        for host in [
            None,
            Some("evil.example:8000"),
            Some("127.0.0.1:8001"),
            Some("127.0.0.1"),
        ] {
            assert_eq!(
                respond(&site, &Method::GET, "/", LOCAL, host, 8000).status,
                421
            );
        }
        assert_eq!(
            respond(
                &site,
                &Method::GET,
                "/",
                LOCAL,
                Some("LOCALHOST:8000"),
                8000
            )
            .status,
            200
        );
        for method in [Method::POST, Method::PUT, Method::DELETE, Method::OPTIONS] {
            assert_eq!(respond(&site, &method, "/", LOCAL, host, 8000).status, 405);
        }
        assert_eq!(
            respond(&site, &Method::HEAD, "/", LOCAL, host, 8000).status,
            200
        );
    }

    #[test]
    fn serves_a_checked_pose_file() {
        let dir = tempfile::tempdir().unwrap();
        let poses = dir.path().join("smile.json");
        std::fs::write(
            &poses,
            r#"{"frames": [{"weights": [0, 0.5, 0, 0, 0, 1]}, {"jaw": [1, 0, 0, 0, 0.9, 0.1, 0, 0, 0], "weights": [0, 0, 0, 0, 0, 0]}]}"#,
        )
        .unwrap();
        let site = Site::load(Inputs {
            poses: Some(&poses),
            ..Inputs::of(&data("aim-procedural.sinew"))
        })
        .unwrap();
        let config: serde_json::Value =
            serde_json::from_slice(&get(&site, "/config.json").body).unwrap();
        assert_eq!(config["poses"]["name"], "smile.json");
        assert_eq!(config["poses"]["frames"], 2);
        assert!(config["replay"].is_null());
        assert_eq!(get(&site, "/replay.sinew").status, 404);
        let served: serde_json::Value =
            serde_json::from_slice(&get(&site, "/poses.json").body).unwrap();
        // Absent head and jaw are served as the identity, so the page need not know the default.
        assert_eq!(served["frames"][0]["head"][0], 1.0);
        assert_eq!(served["frames"][0]["weights"][5], 1.0);
        assert_eq!(served["frames"][1]["jaw"][5].as_f64().unwrap() as f32, 0.1);
    }

    #[test]
    fn bad_files_are_named() {
        let err = |inputs: Inputs<'_>| Site::load(inputs).unwrap_err();
        // A replay is neither kind of model.
        let other = data("aim-ict.f32.replay.sinew");
        let e = err(Inputs::of(&other));
        assert!(
            matches!(&e, ViewError::NotViewable { path, .. } if *path == other),
            "{e}"
        );
        let model = data("aim-procedural.sinew");
        // A landmark track is for an S2D decoder.
        let track = data("s2d-ict.replay.sinew");
        let e = err(Inputs {
            track: Some(&track),
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::S2dFileForActor { path, flag: "--track", .. } if *path == track),
            "{e}"
        );
        let e = err(Inputs {
            replay: Some(&other),
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::DoesNotPlay { path, model: m, .. } if *path == other && *m == model),
            "{e}"
        );
        let e = err(Inputs {
            replay: Some(&model),
            ..Inputs::of(&model)
        });
        assert!(matches!(e, ViewError::NotAnAimReplay { .. }), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let poses = dir.path().join("p.json");
        std::fs::write(&poses, r#"{"frames": [{"weights": [1]}]}"#).unwrap();
        let e = err(Inputs {
            poses: Some(&poses),
            ..Inputs::of(&model)
        });
        assert!(
            matches!(&e, ViewError::Poses(crate::aim::play::PoseFileError::WeightCount { path, .. }) if *path == poses),
            "{e}"
        );
        let missing = dir.path().join("missing.sinew");
        let e = err(Inputs::of(&missing));
        assert!(
            matches!(&e, ViewError::Container(crate::io::container::ContainerError::Read { path, .. }) if *path == missing),
            "{e}"
        );
        // A damaged model is refused by the container reader, naming it.
        let damaged = dir.path().join("damaged.sinew");
        std::fs::write(&damaged, &std::fs::read(&model).unwrap()[..100]).unwrap();
        let e = err(Inputs::of(&damaged));
        assert!(
            matches!(&e, ViewError::Container(crate::io::container::ContainerError::Invalid { path, .. }) if *path == damaged),
            "{e}"
        );
    }

    #[test]
    fn serves_a_performance_fitted_to_the_actor() {
        let site = Site::load(Inputs {
            performance: Some(&data("fit-ict.sinew")),
            ..Inputs::of(&data("aim-ict.sinew"))
        })
        .unwrap();
        let config: serde_json::Value =
            serde_json::from_slice(&get(&site, "/config.json").body).unwrap();
        assert_eq!(config["performance"]["name"], "fit-ict.sinew");
        assert_eq!(config["performance"]["frames"], 4);
        assert_eq!(config["performance"]["hashes"], true);
        let form = config["performance"]["form"].as_str().unwrap();
        assert!(form == "global" || form == "local", "{form}");
        assert!(config["replay"].is_null() && config["poses"].is_null());
        let fit = std::fs::read(data("fit-ict.sinew")).unwrap();
        assert_eq!(get(&site, "/performance.sinew").body, &fit[..]);
        assert_eq!(get(&site, "/replay.sinew").status, 404);
        // Without one, nothing is served there.
        assert_eq!(get(&self::site(), "/performance.sinew").status, 404);
    }

    /// The golden driver and its OpenFace track: served as the driver's bytes and its input per
    /// frame (normalised by the camera), described in the configuration; a driver of another
    /// actor, a track without the camera or a broken row are refused naming the file.
    #[test]
    fn serves_a_driver_and_its_track() {
        let camera = sinew_core::driver::Intrinsics {
            fx: 1200.0,
            fy: 1200.0,
            cx: 320.0,
            cy: 240.0,
        };
        let load = |model: &str, track: &Path, intrinsics| {
            Site::load(Inputs {
                driver: Some(DriverInputs {
                    driver: &data("driver-ict.sinew"),
                    landmarks: track,
                    intrinsics,
                    min_confidence: 0.5,
                }),
                ..Inputs::of(&data(model))
            })
        };
        let csv = data("driver-ict.csv");
        let site = load("aim-ict.sinew", &csv, Some(camera)).unwrap();
        let config: serde_json::Value =
            serde_json::from_slice(&get(&site, "/config.json").body).unwrap();
        assert_eq!(config["driver"]["name"], "driver-ict.sinew");
        assert_eq!(config["driver"]["landmarks"], "driver-ict.csv");
        assert_eq!(config["driver"]["frames"], 20);
        assert_eq!(config["driver"]["lost"], 0);
        assert_eq!(config["driver"]["space"], "2d");
        let driver = std::fs::read(data("driver-ict.sinew")).unwrap();
        assert_eq!(get(&site, "/driver.sinew").body, &driver[..]);
        let served: serde_json::Value =
            serde_json::from_slice(&get(&site, "/landmarks.json").body).unwrap();
        // Each frame is the track's pixels through the camera, as `sinew drive` reads them.
        let rows = crate::io::openface::read(&csv).unwrap();
        let mut want = vec![0.0f32; 136];
        sinew_core::driver::normalise_pixels(&rows[3].pixels, &camera, &mut want).unwrap();
        let got: Vec<f32> = serde_json::from_value(served["frames"][3].clone()).unwrap();
        assert_eq!(got, want);

        let e = load("aim-procedural.sinew", &csv, Some(camera)).unwrap_err();
        assert!(e.to_string().contains("driver-ict.sinew"), "{e}");
        let e = load("aim-ict.sinew", &csv, None).unwrap_err();
        assert!(e.to_string().contains("--intrinsics"), "{e}");
        let dir = tempfile::tempdir().unwrap();
        let broken = dir.path().join("broken.csv");
        let text = std::fs::read_to_string(&csv).unwrap();
        let mut lines: Vec<&str> = text.lines().collect();
        lines.truncate(3);
        let bad = lines[2].replacen(", 1, ", ", 1, x", 1);
        lines[2] = &bad;
        std::fs::write(&broken, lines.join("\n")).unwrap();
        let e = load("aim-ict.sinew", &broken, Some(camera)).unwrap_err();
        assert!(e.to_string().contains("broken.csv: row 3"), "{e}");
        // An S2D decoder has no use for a driver.
        let e = load("s2d-ict.sinew", &csv, Some(camera)).unwrap_err();
        assert!(
            matches!(
                &e,
                ViewError::ActorFileForS2d {
                    flag: "--driver",
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn refuses_a_performance_of_another_actor_naming_it() {
        let err = |model: &str, performance: &str| {
            Site::load(Inputs {
                performance: Some(&data(performance)),
                ..Inputs::of(&data(model))
            })
            .unwrap_err()
        };
        // fit-ict.sinew was fitted to aim-ict.sinew, not to the procedural actor.
        let e = err("aim-procedural.sinew", "fit-ict.sinew");
        assert!(
            matches!(&e, ViewError::OtherActor { path, model, .. }
                if path.ends_with("fit-ict.sinew") && model.ends_with("aim-procedural.sinew")),
            "{e}"
        );
        assert!(
            e.to_string().contains("was fitted to another actor than"),
            "{e}"
        );
        let e = err("aim-ict.sinew", "aim-ict.f32.replay.sinew");
        assert!(
            matches!(&e, ViewError::NotAPerformance { path, .. } if path.ends_with("aim-ict.f32.replay.sinew")),
            "{e}"
        );
    }

    /// One raw HTTP/1.1 request (raw, so that the path reaches the server as written), and the
    /// status line and body of the answer.
    fn raw(port: u16, method: &str, path: &str) -> (String, Vec<u8>) {
        let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        write!(
            stream,
            "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut answer = Vec::new();
        stream.read_to_end(&mut answer).unwrap();
        let split = answer.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        let head = String::from_utf8_lossy(&answer[..split]).into_owned();
        let status = head.lines().next().unwrap().to_owned();
        (status, answer[split + 4..].to_vec())
    }

    #[test]
    fn serves_over_tcp_on_loopback_and_stops() {
        let viewer = Arc::new(Viewer::bind(site(), 0).unwrap());
        let port = viewer.port();
        assert_eq!(viewer.url(), format!("http://127.0.0.1:{port}/"));
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let (viewer, stop) = (viewer.clone(), stop.clone());
            std::thread::spawn(move || viewer.serve(None, || stop.load(Ordering::SeqCst)))
        };
        let (status, body) = raw(port, "GET", "/");
        assert!(status.contains(" 200 "), "{status}");
        assert!(String::from_utf8_lossy(&body).contains("<canvas"));
        let model = std::fs::read(data("aim-procedural.sinew")).unwrap();
        let served = raw(port, "GET", "/model.sinew").1;
        assert!(
            served == model,
            "{} bytes served, {} in the file",
            served.len(),
            model.len()
        );
        for path in [
            "/../Cargo.toml",
            "/%2e%2e/",
            "/%2E%2E/%2E%2E/etc/passwd",
            "/..",
        ] {
            let (status, _) = raw(port, "GET", path);
            assert!(status.contains(" 404 "), "{path}: {status}");
        }
        let (status, _) = raw(port, "POST", "/");
        assert!(status.contains(" 405 "), "{status}");
        stop.store(true, Ordering::SeqCst);
        thread.join().unwrap().unwrap();
        // Stopped, and then dropped: the port stops answering (within a bound, should the
        // system take a moment to close the listener).
        drop(viewer);
        let deadline = Instant::now() + Duration::from_secs(10);
        while TcpStream::connect(("127.0.0.1", port)).is_ok() {
            assert!(
                Instant::now() < deadline,
                "port {port} still answers after stopping"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    #[test]
    fn stops_at_its_deadline() {
        let viewer = Viewer::bind(site(), 0).unwrap();
        let start = Instant::now();
        viewer
            .serve(Some(start + Duration::from_millis(300)), || false)
            .unwrap();
        let took = start.elapsed();
        assert!(
            took >= Duration::from_millis(300) && took < Duration::from_secs(5),
            "{took:?}"
        );
    }
}
