//! Live driving through the C API: the golden driver (`driver-ict`) drives the golden actor
//! through `sinew_live_step` from the golden live track (`driver-ict-live.csv`: a rest, a
//! tracker's convention, four tracker failures), every frame's outcome, played pose and posed
//! frame as `tests/data/driver-ict-live.hashes` lists them; and what the live calls refuse.
//! Expected values come from the hash list, never from this file.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::collections::HashMap;
use std::mem::MaybeUninit;
use std::ptr::{null, null_mut};

use sinew::*;

mod common;
use common::{Model, data, message, new_error};

/// `driver-ict-live.hashes`: the track and its intrinsics, the settings, and every
/// `KIND FRAME VALUE` line.
struct List {
    track: String,
    camera: SinewIntrinsics,
    settings: SinewLive,
    lines: HashMap<(String, usize), String>,
}

fn list() -> List {
    let text = String::from_utf8(data("driver-ict-live.hashes")).unwrap();
    let (mut track, mut camera, mut settings) = (None, None, None);
    let mut lines = HashMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let words: Vec<&str> = line.split_whitespace().collect();
        let num = |i: usize| words[i].parse::<f32>().unwrap();
        match words[0] {
            "track" => {
                track = Some(words[1].to_owned());
                camera = Some(SinewIntrinsics {
                    fx: num(2),
                    fy: num(3),
                    cx: num(4),
                    cy: num(5),
                });
            }
            "live" => {
                settings = Some(SinewLive {
                    calibrate_frames: words[1].parse().unwrap(),
                    max_residual: num(2),
                    max_speed: num(3),
                    max_turn: num(4),
                    reacquire: num(5),
                });
            }
            kind => {
                lines.insert(
                    (kind.to_owned(), words[1].parse().unwrap()),
                    words[2].to_owned(),
                );
            }
        }
    }
    List {
        track: track.expect("a track line"),
        camera: camera.unwrap(),
        settings: settings.expect("a live line"),
        lines,
    }
}

/// The CSV's rows: the time stamp, and the pixels where `success` is 1.
fn track(name: &str) -> Vec<(f32, Option<Vec<f32>>)> {
    let text = String::from_utf8(data(name)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').map(str::trim).collect();
    let at = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (time, success, x, y) = (at("timestamp"), at("success"), at("x_0"), at("y_0"));
    lines
        .map(|line| {
            let cells: Vec<f32> = line.split(',').map(|c| c.trim().parse().unwrap()).collect();
            let pixels = (0..68).flat_map(|l| [cells[x + l], cells[y + l]]).collect();
            (cells[time], (cells[success] != 0.0).then_some(pixels))
        })
        .collect()
}

fn check(status: SinewStatus, err: &SinewError) -> Result<(), (SinewStatus, String)> {
    assert_eq!(err.status, status);
    if status == SinewStatus::Ok {
        Ok(())
    } else {
        Err((status, message(err)))
    }
}

/// The golden driver open on the golden actor, over bytes it keeps.
struct Session {
    model: Model,
    driver: *mut SinewDriver,
    _bytes: Vec<u8>,
    info: SinewDriverInfo,
    live: SinewLiveInfo,
}

impl Session {
    fn open() -> Self {
        let model = Model::open("aim-ict.sinew");
        let bytes = data("driver-ict.sinew");
        let mut driver = null_mut();
        // Safety: `bytes` outlives the handle (both here, the handle freed first in `drop`).
        let status = unsafe {
            sinew_driver_open(
                bytes.as_ptr(),
                bytes.len(),
                model.handle,
                &mut driver,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        let mut info = MaybeUninit::uninit();
        let mut live = MaybeUninit::uninit();
        // Safety: live handles and writable records.
        unsafe {
            assert_eq!(
                sinew_driver_info(driver, info.as_mut_ptr(), null_mut()),
                SinewStatus::Ok
            );
            assert_eq!(
                sinew_live_info(driver, model.handle, live.as_mut_ptr(), null_mut()),
                SinewStatus::Ok
            );
        }
        Self {
            model,
            driver,
            _bytes: bytes,
            // Safety: both written on success.
            info: unsafe { info.assume_init() },
            live: unsafe { live.assume_init() },
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        settings: &SinewLive,
        landmarks: Option<&[f32]>,
        time: f32,
        state: &mut [f32],
        scratch: &mut [f32],
        pose: &mut [f32],
    ) -> Result<SinewLiveOutcome, (SinewStatus, String)> {
        let mut outcome = SinewLiveOutcome::Driven;
        let mut err = new_error();
        let (ptr, len) = landmarks.map_or((null(), 0), |l| (l.as_ptr(), l.len()));
        // Safety: live handles; every buffer has the length passed.
        let status = unsafe {
            sinew_live_step(
                self.driver,
                self.model.handle,
                settings,
                ptr,
                len,
                time,
                state.as_mut_ptr(),
                state.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                pose.as_mut_ptr(),
                pose.len(),
                &mut outcome,
                &mut err,
            )
        };
        check(status, &err).map(|()| outcome)
    }

    fn play(&self, pose: &[f32]) -> u64 {
        let v3 = 3 * self.info.vertex_count;
        let (mut p, mut n, mut hash) = (vec![0.0f32; v3], vec![0.0f32; v3], 0u64);
        // Safety: live handles; every buffer has the length passed.
        let status = unsafe {
            sinew_driver_play(
                self.driver,
                self.model.handle,
                pose.as_ptr(),
                pose.len(),
                p.as_mut_ptr(),
                p.len(),
                n.as_mut_ptr(),
                n.len(),
                &mut hash,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        hash
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        // Safety: opened in `open`, freed once.
        unsafe { sinew_driver_free(self.driver) };
    }
}

fn pixels(pixels: &[f32], camera: &SinewIntrinsics) -> Vec<f32> {
    let mut out = vec![0.0f32; 136];
    // Safety: every buffer has the length passed.
    let status = unsafe {
        sinew_driver_pixels(
            pixels.as_ptr(),
            pixels.len(),
            camera,
            out.as_mut_ptr(),
            out.len(),
            null_mut(),
        )
    };
    assert_eq!(status, SinewStatus::Ok);
    out
}

fn hash_of(values: &[f32]) -> u64 {
    let mut hash = 0u64;
    // Safety: `values` has the length passed; no second buffer.
    let status = unsafe {
        sinew_hash_frame(
            values.as_ptr(),
            values.len(),
            null(),
            0,
            &mut hash,
            null_mut(),
        )
    };
    assert_eq!(status, SinewStatus::Ok);
    hash
}

fn name(o: SinewLiveOutcome) -> &'static str {
    match o {
        SinewLiveOutcome::Driven => "driven",
        SinewLiveOutcome::Calibrating => "calibrating",
        SinewLiveOutcome::Missing => "missing",
        SinewLiveOutcome::LostResidual => "lost-residual",
        SinewLiveOutcome::LostJump => "lost-jump",
    }
}

#[test]
fn the_golden_live_track_drives_the_listed_outcomes_and_hashes() {
    let list = list();
    let s = Session::open();
    // The settings the list names are the core's defaults, as `sinew_live_defaults` gives them.
    let mut defaults = MaybeUninit::uninit();
    // Safety: a writable record.
    let status = unsafe {
        sinew_live_defaults(
            list.settings.calibrate_frames,
            defaults.as_mut_ptr(),
            null_mut(),
        )
    };
    assert_eq!(status, SinewStatus::Ok);
    // Safety: written on success.
    assert_eq!(unsafe { defaults.assume_init() }, list.settings);
    assert_eq!(
        s.live.state_floats,
        20 + 3 * 68 + s.info.pose_len,
        "{:?}",
        s.live
    );
    let mut state = vec![0.0f32; s.live.state_floats];
    let mut scratch = vec![0.0f32; s.live.scratch_floats];
    let mut pose = vec![0.0f32; s.info.pose_len];
    let frames = track(&list.track);
    assert_eq!(3 * frames.len(), list.lines.len());
    for (f, (time, px)) in frames.iter().enumerate() {
        let landmarks = px.as_ref().map(|p| pixels(p, &list.camera));
        let outcome = s
            .step(
                &list.settings,
                landmarks.as_deref(),
                *time,
                &mut state,
                &mut scratch,
                &mut pose,
            )
            .unwrap();
        let line = |kind: &str| list.lines[&(kind.to_owned(), f)].clone();
        assert_eq!(name(outcome), line("outcome"), "frame {f}");
        assert_eq!(
            format!("{:016x}", hash_of(&pose)),
            line("pose"),
            "frame {f}"
        );
        assert_eq!(
            format!("{:016x}", s.play(&pose)),
            line("frame"),
            "frame {f}"
        );
        let mut c = MaybeUninit::uninit();
        // Safety: live handles, the state's length passed, a writable record.
        let status = unsafe {
            sinew_live_calibration(
                s.driver,
                s.model.handle,
                &list.settings,
                state.as_ptr(),
                state.len(),
                c.as_mut_ptr(),
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        let c = unsafe { c.assume_init() };
        let n = list.settings.calibrate_frames;
        assert_eq!(c.frames, n.min(f as u32 + 1));
        assert_eq!(c.complete, f as u32 + 1 >= n);
        assert!(c.complete == (c.deviation > 0.0));
    }
}

#[test]
fn the_live_calls_refuse_bad_settings_time_stamps_and_buffers() {
    let list = list();
    let s = Session::open();
    let mut state = vec![0.0f32; s.live.state_floats];
    let mut scratch = vec![0.0f32; s.live.scratch_floats];
    let mut pose = vec![0.0f32; s.info.pose_len];
    let frames = track(&list.track);
    let first = pixels(frames[0].1.as_ref().unwrap(), &list.camera);
    let bad = |settings: SinewLive| {
        let (mut st, mut sc, mut po) = (state.clone(), scratch.clone(), pose.clone());
        s.step(&settings, Some(&first), 0.0, &mut st, &mut sc, &mut po)
            .unwrap_err()
    };
    let ok = list.settings;
    for (settings, expected) in [
        (
            SinewLive {
                max_speed: -1.0,
                ..ok
            },
            "settings.max_speed is outside [0, 1e3]",
        ),
        (
            SinewLive {
                max_residual: f32::NAN,
                ..ok
            },
            "settings.max_residual is NaN or infinite",
        ),
        (
            SinewLive {
                calibrate_frames: 5000,
                ..ok
            },
            "settings.calibrate_frames is outside [0, 1000]",
        ),
    ] {
        assert_eq!(
            bad(settings),
            (SinewStatus::InvalidInput, expected.to_owned())
        );
    }
    s.step(&ok, Some(&first), 0.0, &mut state, &mut scratch, &mut pose)
        .unwrap();
    let before = (state.clone(), pose.clone());
    let e = s
        .step(&ok, None, 0.0005, &mut state, &mut scratch, &mut pose)
        .unwrap_err();
    assert_eq!(e.0, SinewStatus::InvalidInput);
    assert!(e.1.starts_with("time[0] is not at least 1e-3 s"), "{}", e.1);
    let mut nan = first.clone();
    nan[3] = f32::NAN;
    assert_eq!(
        s.step(&ok, Some(&nan), 1.0, &mut state, &mut scratch, &mut pose),
        Err((
            SinewStatus::InvalidInput,
            "landmarks[3] is NaN or infinite".to_owned()
        ))
    );
    assert_eq!((state.clone(), pose.clone()), before, "nothing changed");
    let e = s
        .step(&ok, None, 1.0, &mut state[1..], &mut scratch, &mut pose)
        .unwrap_err();
    assert_eq!(e.0, SinewStatus::BufferLength, "{}", e.1);
    assert!(e.1.starts_with("state has"), "{}", e.1);
    let e = s
        .step(
            &ok,
            Some(&first[1..]),
            1.0,
            &mut state,
            &mut scratch,
            &mut pose,
        )
        .unwrap_err();
    assert_eq!(e.0, SinewStatus::BufferLength, "{}", e.1);
    let mut err = new_error();
    // Safety: NULL settings are checked before anything is read.
    let status = unsafe {
        sinew_live_step(
            s.driver,
            s.model.handle,
            null(),
            null(),
            0,
            1.0,
            state.as_mut_ptr(),
            state.len(),
            scratch.as_mut_ptr(),
            scratch.len(),
            pose.as_mut_ptr(),
            pose.len(),
            null_mut(),
            &mut err,
        )
    };
    assert_eq!(status, SinewStatus::NullPointer);
    assert_eq!(message(&err), "settings is NULL");
    // Another actor than the driver's.
    let other = Model::open("aim-procedural.sinew");
    let mut info = MaybeUninit::uninit();
    // Safety: live handles and a writable record.
    let status = unsafe { sinew_live_info(s.driver, other.handle, info.as_mut_ptr(), &mut err) };
    assert_eq!(status, SinewStatus::ModelMismatch, "{}", message(&err));
}
