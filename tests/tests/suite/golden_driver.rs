//! Golden live driver: a small 2D landmark driver of the golden ICT actor (`driver-ict.sinew`,
//! 1,500 steps, hidden 64; committed, the commands in docs/FIT.md, "The golden driver") driven by
//! a 20-frame OpenFace 2.0 track (`driver-ict.csv`, the 2D track of a synthetic performance of
//! the actor, with 1 px of landmark noise). Per frame the driven pose's hash and the posed
//! frame's hash (positions then normals), without and with the One Euro filter at the track's
//! time stamps, are pinned in `driver-ict.hashes`, whose `track` and `filter` lines tell the C
//! example, the wasm tests and the firmware targets the intrinsics and the filter's settings; the
//! same hashes are checked on every one of them.
//!
//! Live driving (`sinew_core::live`) is pinned the same way on a second track,
//! `driver-ict-live.csv`: a performance that rests for its first frames, carries a tracker's
//! convention and four tracker failures; per frame what became of it (calibrating, driven,
//! lost, missing) and the hashes of the pose played and of the posed frame, in
//! `driver-ict-live.hashes`, whose `live` line gives the settings.

use std::fmt::Write;
use std::path::Path;

use sinew_core::aim::AimActor;
use sinew_core::driver::{Driver, Intrinsics, LANDMARKS, filter_pose, normalise_pixels, pose_hash};
use sinew_core::filter::OneEuro;
use sinew_core::hash::frame_hash;
use sinew_core::live::{Live, Lost, Outcome, Settings};
use sinew_host::driver::drive::{self, bind, poses};
use sinew_host::driver::track;
use sinew_tests::{check, check_bytes, golden_dir};

const ACTOR: &str = "aim-ict.sinew";
const DRIVER: &str = "driver-ict.sinew";
const TRACK: &str = "driver-ict.csv";
const HASHES: &str = "driver-ict.hashes";
const LIVE_TRACK: &str = "driver-ict-live.csv";
const LIVE_HASHES: &str = "driver-ict-live.hashes";
/// The live settings: the calibration's frames, then the lost-frame rules (residual, speed,
/// turn, reacquire): the core's defaults.
const LIVE: Settings = Settings::defaults(6);
/// How the live track was made (docs/FIT.md, "Live driving").
const LIVE_SEED: u64 = 6;
const LIVE_FRAMES: usize = 60;
const LIVE_CONVENTION: u64 = 11;
const LIVE_FAILURES: usize = 4;
/// The synthetic performance's camera (`sinew data performance`'s defaults): fx, fy, cx, cy.
const CAMERA: Intrinsics = Intrinsics {
    fx: 1200.0,
    fy: 1200.0,
    cx: 320.0,
    cy: 240.0,
};
/// The One Euro filter's minimum cutoff (Hz), speed coefficient and derivative cutoff (Hz).
const FILTER: [f32; 3] = [1.0, 0.5, 1.0];
/// How the track was made (docs/FIT.md, "The golden driver").
const PERFORMANCE_SEED: u64 = 4;
const FRAMES: usize = 20;
const LANDMARK_NOISE_PX: f32 = 1.0;

fn read(name: &str) -> Vec<u8> {
    let path = golden_dir().join(name);
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: golden file missing ({e})", path.display()))
}

/// The live track's frames: the time stamp, and the `[68, 2]` pixels where the tracker found a
/// face, through the host's OpenFace reader.
fn live_frames() -> Vec<(f32, Option<Vec<f32>>)> {
    let rows = sinew_host::io::openface::read(&golden_dir().join(LIVE_TRACK)).unwrap();
    rows.into_iter()
        .map(|r| (r.timestamp.unwrap(), r.success.then_some(r.pixels)))
        .collect()
}

/// Per frame of the live track: the outcome, the played pose's hash and the posed frame's.
fn drive_live(actor_bytes: &[u8], driver_bytes: &[u8]) -> Vec<(Outcome, u64, u64)> {
    let actor = AimActor::from_bytes(actor_bytes).unwrap();
    let driver = Driver::from_bytes(driver_bytes).unwrap();
    driver.check_actor(actor_bytes, &actor).unwrap();
    let live = Live::new(&driver, &actor, LIVE).unwrap();
    let v3 = 3 * actor.vertex_count();
    let (mut positions, mut normals) = (vec![0.0; v3], vec![0.0; v3]);
    let mut state = vec![0.0; live.state_len()];
    let mut scratch = vec![0.0; live.scratch_len()];
    let mut pose = vec![0.0; driver.output_len()];
    let mut landmarks = vec![0.0; 2 * LANDMARKS];
    live_frames()
        .into_iter()
        .map(|(time, pixels)| {
            let found = pixels.map(|p| {
                normalise_pixels(&p, &CAMERA, &mut landmarks).unwrap();
                landmarks.clone()
            });
            let outcome = live
                .step(&mut state, found.as_deref(), time, &mut scratch, &mut pose)
                .unwrap();
            (
                outcome,
                frame_hash(&pose),
                pose_hash(&actor, &pose, &mut positions, &mut normals).unwrap(),
            )
        })
        .collect()
}

/// The track's frames: each frame's time stamp and its `[68, 2]` pixels, through the host's
/// OpenFace reader (what `sinew drive` reads) and the `timestamp` column.
fn track_frames() -> Vec<(f32, Vec<f32>)> {
    let path = golden_dir().join(TRACK);
    let rows = sinew_host::io::openface::read(&path).unwrap();
    let text = String::from_utf8(read(TRACK)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').map(str::trim).collect();
    let column = header.iter().position(|c| *c == "timestamp").unwrap();
    let times: Vec<f32> = lines
        .map(|l| l.split(',').nth(column).unwrap().trim().parse().unwrap())
        .collect();
    assert_eq!(times.len(), rows.len());
    assert!(
        rows.iter().all(|r| r.success),
        "the golden track loses no frame"
    );
    times
        .into_iter()
        .zip(rows.into_iter().map(|r| r.pixels))
        .collect()
}

/// Per frame: the pose's hash and the posed frame's, unfiltered, then filtered.
struct Hashes {
    poses: Vec<Vec<f32>>,
    rows: Vec<[u64; 4]>,
}

fn drive_track(actor_bytes: &[u8], driver_bytes: &[u8]) -> Hashes {
    let actor = AimActor::from_bytes(actor_bytes).unwrap();
    let driver = Driver::from_bytes(driver_bytes).unwrap();
    driver.check_actor(actor_bytes, &actor).unwrap();
    let [min_cutoff, beta, d_cutoff] = FILTER;
    // The time-stamped step does not use the settings' frame rate.
    let filter = OneEuro::new(min_cutoff, beta, d_cutoff, 30.0).unwrap();
    let v3 = 3 * actor.vertex_count();
    let (mut positions, mut normals) = (vec![0.0; v3], vec![0.0; v3]);
    let mut landmarks = vec![0.0; 2 * LANDMARKS];
    let mut scratch = vec![0.0; driver.scratch_len()];
    let mut state = vec![0.0; OneEuro::timed_state_len(driver.output_len())];
    let mut out = Hashes {
        poses: Vec::new(),
        rows: Vec::new(),
    };
    for (time, pixels) in track_frames() {
        normalise_pixels(&pixels, &CAMERA, &mut landmarks).unwrap();
        let mut pose = vec![0.0; driver.output_len()];
        driver.drive(&landmarks, &mut scratch, &mut pose).unwrap();
        let unfiltered = [
            frame_hash(&pose),
            pose_hash(&actor, &pose, &mut positions, &mut normals).unwrap(),
        ];
        out.poses.push(pose.clone());
        filter_pose(&filter, &mut state, time, &mut pose).unwrap();
        let filtered = [
            frame_hash(&pose),
            pose_hash(&actor, &pose, &mut positions, &mut normals).unwrap(),
        ];
        out.rows
            .push([unfiltered[0], unfiltered[1], filtered[0], filtered[1]]);
    }
    out
}

#[test]
fn the_driven_track_is_pinned() {
    let actor_bytes = read(ACTOR);
    let driver_bytes = read(DRIVER);
    // Small enough for the firmware's flash beside the other goldens.
    assert!(
        driver_bytes.len() < 256 * 1024,
        "{} bytes",
        driver_bytes.len()
    );
    let driver = Driver::from_bytes(&driver_bytes).unwrap();
    let actor = AimActor::from_bytes(&actor_bytes).unwrap();
    let hashes = drive_track(&actor_bytes, &driver_bytes);
    assert_eq!(hashes.rows.len(), FRAMES);
    let mut text = String::new();
    writeln!(
        text,
        "# {DRIVER} ({} input, {} pose values) on {ACTOR} ({} vertices), driven by {TRACK} \
         through the camera of the track line (fx fy cx cy); the filter line: the One Euro \
         filter's min_cutoff beta d_cutoff, stepped at the track's time stamps; per frame: pose = \
         the driven pose's f32 bits, frame = the posed positions then normals, filtered-* the same \
         after the filter",
        driver.space().name(),
        driver.output_len(),
        actor.vertex_count()
    )
    .unwrap();
    writeln!(
        text,
        "track {TRACK} {} {} {} {}",
        CAMERA.fx, CAMERA.fy, CAMERA.cx, CAMERA.cy
    )
    .unwrap();
    writeln!(text, "filter {} {} {}", FILTER[0], FILTER[1], FILTER[2]).unwrap();
    let names = ["pose", "frame", "filtered-pose", "filtered-frame"];
    for (column, name) in names.iter().enumerate() {
        for (f, row) in hashes.rows.iter().enumerate() {
            writeln!(text, "{name} {f} {:016x}", row[column]).unwrap();
        }
    }
    check(HASHES, &text);
    // The face moves from frame to frame; the filter passes the first frame (its 6D rotations
    // made orthonormal once more, which may move their last bits but not the posed face) and
    // changes the rest.
    assert!(hashes.rows.windows(2).all(|w| w[0][1] != w[1][1]));
    assert_eq!(hashes.rows[0][1], hashes.rows[0][3]);
    assert!(hashes.rows[1..].iter().all(|r| r[..2] != r[2..]));
}

#[test]
fn live_driving_is_pinned() {
    let actor_bytes = read(ACTOR);
    let driver_bytes = read(DRIVER);
    let rows = drive_live(&actor_bytes, &driver_bytes);
    assert_eq!(rows.len(), LIVE_FRAMES);
    let mut text = String::new();
    writeln!(
        text,
        "# {DRIVER} on {ACTOR} driven live by {LIVE_TRACK} through the camera of the track line \
         (fx fy cx cy), a row whose success is 0 given as no landmarks, each row at its \
         timestamp; the live line: sinew_core::live::Settings (calibrate_frames max_residual \
         max_speed max_turn reacquire); per frame: outcome = what became of it, pose = the pose \
         played (f32 bits), frame = the posed positions then normals"
    )
    .unwrap();
    writeln!(
        text,
        "track {LIVE_TRACK} {} {} {} {}",
        CAMERA.fx, CAMERA.fy, CAMERA.cx, CAMERA.cy
    )
    .unwrap();
    let [n, r, v, t, q] = LIVE.values();
    writeln!(text, "live {n} {r} {v} {t} {q}").unwrap();
    for (f, row) in rows.iter().enumerate() {
        writeln!(text, "outcome {f} {}", row.0.name()).unwrap();
    }
    for (name, column) in [("pose", 1), ("frame", 2)] {
        for (f, row) in rows.iter().enumerate() {
            let h = if column == 1 { row.1 } else { row.2 };
            writeln!(text, "{name} {f} {h:016x}").unwrap();
        }
    }
    check(LIVE_HASHES, &text);
    // Every outcome is on the track: the calibration, the four failures caught, the frame
    // without a face, and the driven frames.
    let count = |o: Outcome| rows.iter().filter(|r| r.0 == o).count();
    assert_eq!(count(Outcome::Calibrating), LIVE.calibrate_frames as usize);
    assert!(
        count(Outcome::Lost(Lost::Jump)) >= 6,
        "{}",
        count(Outcome::Lost(Lost::Jump))
    );
    assert!(count(Outcome::Lost(Lost::Residual)) >= 1);
    assert!(count(Outcome::Missing) >= 1);
    assert!(count(Outcome::Driven) > LIVE_FRAMES / 2);
    // A lost or missing frame plays the last pose again.
    for w in rows.windows(2) {
        if matches!(w[1].0, Outcome::Lost(_) | Outcome::Missing) {
            assert_eq!(w[1].1, w[0].1);
        }
    }
}

/// `sinew drive` (the host functions behind the command) reads the CSV through the same
/// intrinsics and drives the same poses, bit for bit.
#[test]
fn sinew_drive_drives_the_pinned_poses() {
    let actor_bytes = read(ACTOR);
    let driver_bytes = read(DRIVER);
    let (actor_path, driver_path) = (golden_dir().join(ACTOR), golden_dir().join(DRIVER));
    let bound = bind(&actor_path, &actor_bytes, &driver_path, &driver_bytes).unwrap();
    let track = track::read(
        &golden_dir().join(TRACK),
        bound.driver.space(),
        Some(CAMERA),
        0.5,
        track::Placement::of(&actor_path, &bound.actor, &bound.driver).unwrap(),
    )
    .unwrap();
    let driven = poses(&bound, &driver_path, &track, Settings::OFF, None).unwrap();
    assert_eq!(driven, drive_track(&actor_bytes, &driver_bytes).poses);
}

/// `sinew drive`'s reading of the live CSV (lost rows as frames without landmarks, the
/// timestamps) drives the pinned live run: the same outcomes and poses.
#[test]
fn sinew_drive_drives_the_pinned_live_run() {
    let actor_bytes = read(ACTOR);
    let driver_bytes = read(DRIVER);
    let (actor_path, driver_path) = (golden_dir().join(ACTOR), golden_dir().join(DRIVER));
    let bound = bind(&actor_path, &actor_bytes, &driver_path, &driver_bytes).unwrap();
    let track = track::read(
        &golden_dir().join(LIVE_TRACK),
        bound.driver.space(),
        Some(CAMERA),
        0.5,
        track::Placement::of(&actor_path, &bound.actor, &bound.driver).unwrap(),
    )
    .unwrap();
    let driven = drive::drive_track(&bound, &driver_path, &track, LIVE, None).unwrap();
    let pinned = drive_live(&actor_bytes, &driver_bytes);
    assert_eq!(
        driven.outcomes,
        pinned.iter().map(|r| r.0).collect::<Vec<_>>()
    );
    let hashes: Vec<u64> = driven.poses.iter().map(|p| frame_hash(p)).collect();
    assert_eq!(hashes, pinned.iter().map(|r| r.1).collect::<Vec<_>>());
    let c = driven.calibration.unwrap();
    assert_eq!(c.frames, (0..6).collect::<Vec<_>>());
    assert!(c.unsteady.is_empty(), "{:?}", c.frame_deviation);
}

/// The track is the 2D track of `sinew data performance` on the golden actor (its
/// `openface.csv`); with the ICT-FaceKit data at hand, making it again gives the same bytes.
#[test]
fn the_track_is_the_performances_openface_csv() {
    let Some(kit) = sinew_tests::data_dir("ict-facekit") else {
        eprintln!("skipped: no ICT-FaceKit data (set SINEW_DATA)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let config = sinew_host::performance::PerformanceConfig {
        seed: PERFORMANCE_SEED,
        frames: FRAMES,
        landmark_noise_px: LANDMARK_NOISE_PX,
        ..Default::default()
    };
    let out = dir.path().join("perf");
    let actor = golden_dir().join(ACTOR);
    sinew_host::performance::generate(&kit, Some(Path::new(&actor)), &config, &out).unwrap();
    let csv = std::fs::read(out.join(sinew_host::io::performance::OPENFACE_CSV)).unwrap();
    check_bytes(TRACK, &csv);
    let config = sinew_host::performance::PerformanceConfig {
        seed: LIVE_SEED,
        frames: LIVE_FRAMES,
        landmark_noise_px: LANDMARK_NOISE_PX,
        rest_frames: LIVE.calibrate_frames as usize,
        convention: Some(LIVE_CONVENTION),
        failures: LIVE_FAILURES,
        ..Default::default()
    };
    let out = dir.path().join("live");
    sinew_host::performance::generate(&kit, Some(Path::new(&actor)), &config, &out).unwrap();
    let csv = std::fs::read(out.join(sinew_host::io::performance::OPENFACE_CSV)).unwrap();
    check_bytes(LIVE_TRACK, &csv);
}
