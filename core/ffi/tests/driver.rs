//! The live driver through the C API: the golden driver (`driver-ict`) drives the golden actor
//! from the golden OpenFace track, every frame's pose and posed frame hashing as
//! `tests/data/driver-ict.hashes` lists them, without and with the One Euro filter; and what the
//! driver calls refuse: another actor, another kind, NaN landmarks and pixels, bad intrinsics,
//! filter settings and time stamps, buffers of the wrong length. Expected hashes come from the
//! hash list, never from this file.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::collections::HashMap;
use std::ptr::{null, null_mut};

use sinew::*;

mod common;
use common::{Model, data, message, new_error};

/// `driver-ict.hashes`: the track's file and intrinsics, the filter's settings, and every
/// `KIND FRAME HASH` line.
struct List {
    track: String,
    camera: SinewIntrinsics,
    filter: SinewFilter,
    hashes: HashMap<(String, usize), u64>,
}

fn list() -> List {
    let text = String::from_utf8(data("driver-ict.hashes")).unwrap();
    let (mut track, mut camera, mut filter) = (None, None, None);
    let mut hashes = HashMap::new();
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
            "filter" => {
                filter = Some(SinewFilter {
                    min_cutoff: num(1),
                    beta: num(2),
                    d_cutoff: num(3),
                });
            }
            kind => {
                let frame = words[1].parse().unwrap();
                let hash = u64::from_str_radix(words[2], 16).unwrap();
                hashes.insert((kind.to_owned(), frame), hash);
            }
        }
    }
    List {
        track: track.expect("a track line"),
        camera: camera.unwrap(),
        filter: filter.expect("a filter line"),
        hashes,
    }
}

/// The OpenFace CSV's frames: each frame's `timestamp` and its 68 `[u, v]` pixels.
fn track(name: &str) -> Vec<(f32, Vec<f32>)> {
    let text = String::from_utf8(data(name)).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').map(str::trim).collect();
    let at = |name: &str| header.iter().position(|c| *c == name).unwrap();
    let (time, x, y) = (at("timestamp"), at("x_0"), at("y_0"));
    lines
        .map(|line| {
            let cells: Vec<f32> = line.split(',').map(|c| c.trim().parse().unwrap()).collect();
            let pixels = (0..68).flat_map(|l| [cells[x + l], cells[y + l]]).collect();
            (cells[time], pixels)
        })
        .collect()
}

/// An open driver over bytes the struct keeps alive.
struct Drv {
    handle: *mut SinewDriver,
    _bytes: Vec<u8>,
}

impl Drv {
    fn open(bytes: Vec<u8>, model: &Model) -> Result<Self, (SinewStatus, String)> {
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: `bytes` outlives the handle (both in `Drv`, freed in `drop` first).
        let status = unsafe {
            sinew_driver_open(
                bytes.as_ptr(),
                bytes.len(),
                model.handle,
                &mut handle,
                &mut err,
            )
        };
        if status != SinewStatus::Ok {
            assert!(handle.is_null(), "a failed open leaves NULL");
            return Err((status, message(&err)));
        }
        Ok(Self {
            handle,
            _bytes: bytes,
        })
    }

    fn info(&self) -> SinewDriverInfo {
        let mut info = std::mem::MaybeUninit::uninit();
        // Safety: a live handle and a writable info.
        let status = unsafe { sinew_driver_info(self.handle, info.as_mut_ptr(), null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        unsafe { info.assume_init() }
    }

    /// `landmarks` to a pose, or the refusal.
    fn pose(&self, landmarks: &[f32], pose: &mut [f32]) -> Result<(), (SinewStatus, String)> {
        let mut scratch = vec![0.0f32; self.info().scratch_floats];
        let mut err = new_error();
        // Safety: a live handle; every buffer has the length passed.
        let status = unsafe {
            sinew_driver_pose(
                self.handle,
                landmarks.as_ptr(),
                landmarks.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                pose.as_mut_ptr(),
                pose.len(),
                &mut err,
            )
        };
        check(status, &err)
    }

    fn filter(
        &self,
        filter: &SinewFilter,
        time: f32,
        state: &mut [f32],
        pose: &mut [f32],
    ) -> Result<(), (SinewStatus, String)> {
        let mut err = new_error();
        // Safety: a live handle; every buffer has the length passed.
        let status = unsafe {
            sinew_driver_filter(
                self.handle,
                filter,
                time,
                state.as_mut_ptr(),
                state.len(),
                pose.as_mut_ptr(),
                pose.len(),
                &mut err,
            )
        };
        check(status, &err)
    }

    /// The pose played on `model`: the frame hash (positions then normals).
    fn play(&self, model: &Model, pose: &[f32]) -> Result<u64, (SinewStatus, String)> {
        let v3 = 3 * self.info().vertex_count;
        let (mut p, mut n, mut hash) = (vec![0.0f32; v3], vec![0.0f32; v3], 0u64);
        let mut err = new_error();
        // Safety: live handles; every buffer has the length passed.
        let status = unsafe {
            sinew_driver_play(
                self.handle,
                model.handle,
                pose.as_ptr(),
                pose.len(),
                p.as_mut_ptr(),
                p.len(),
                n.as_mut_ptr(),
                n.len(),
                &mut hash,
                &mut err,
            )
        };
        check(status, &err).map(|()| hash)
    }
}

impl Drop for Drv {
    fn drop(&mut self) {
        // Safety: opened by `Drv::open`, freed once.
        unsafe { sinew_driver_free(self.handle) };
    }
}

fn check(status: SinewStatus, err: &SinewError) -> Result<(), (SinewStatus, String)> {
    assert_eq!(err.status, status);
    if status == SinewStatus::Ok {
        Ok(())
    } else {
        Err((status, message(err)))
    }
}

fn pixels(pixels: &[f32], camera: &SinewIntrinsics) -> Result<Vec<f32>, (SinewStatus, String)> {
    let mut out = vec![0.0f32; 136];
    let mut err = new_error();
    // Safety: every buffer has the length passed.
    let status = unsafe {
        sinew_driver_pixels(
            pixels.as_ptr(),
            pixels.len(),
            camera,
            out.as_mut_ptr(),
            out.len(),
            &mut err,
        )
    };
    check(status, &err).map(|()| out)
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

#[test]
fn the_golden_track_drives_the_listed_hashes() {
    let list = list();
    let model = Model::open("aim-ict.sinew");
    let driver = Drv::open(data("driver-ict.sinew"), &model).unwrap();
    let info = driver.info();
    assert_eq!((info.landmark_count, info.landmark_dims), (68, 2));
    assert_eq!(info.input_len, 136);
    assert_eq!(info.pose_len, 18 + model.info().shape_count);
    assert_eq!(info.vertex_count, model.info().vertex_count);
    assert_eq!(info.filter_state_floats, 2 + 2 * info.pose_len);
    let frames = track(&list.track);
    assert_eq!(4 * frames.len(), list.hashes.len());
    let mut state = vec![1.0f32; info.filter_state_floats];
    // Safety: `state` has the length passed.
    let status = unsafe { sinew_driver_filter_reset(state.as_mut_ptr(), state.len(), null_mut()) };
    assert_eq!(status, SinewStatus::Ok);
    for (f, (time, px)) in frames.iter().enumerate() {
        let want = |kind: &str| list.hashes[&(kind.to_owned(), f)];
        let landmarks = pixels(px, &list.camera).unwrap();
        let mut pose = vec![0.0f32; info.pose_len];
        driver.pose(&landmarks, &mut pose).unwrap();
        assert_eq!(hash_of(&pose), want("pose"), "frame {f}: pose");
        assert_eq!(driver.play(&model, &pose), Ok(want("frame")), "frame {f}");
        driver
            .filter(&list.filter, *time, &mut state, &mut pose)
            .unwrap();
        assert_eq!(hash_of(&pose), want("filtered-pose"), "frame {f}");
        assert_eq!(
            driver.play(&model, &pose),
            Ok(want("filtered-frame")),
            "frame {f}"
        );
    }
}

#[test]
fn driver_calls_refuse_what_they_cannot_use() {
    let list = list();
    let model = Model::open("aim-ict.sinew");
    let bytes = data("driver-ict.sinew");
    // Another actor, a decoder, another kind of artefact.
    let other = Model::open("aim-procedural.sinew");
    let (status, text) = Drv::open(bytes.clone(), &other).err().unwrap();
    assert_eq!(status, SinewStatus::ModelMismatch, "{text}");
    assert!(text.contains("trained for the actor"), "{text}");
    let decoder = Model::open("s2d-ict.sinew");
    let (status, _) = Drv::open(bytes.clone(), &decoder).err().unwrap();
    assert_eq!(status, SinewStatus::WrongKind);
    let (status, text) = Drv::open(data("fit-ict.sinew"), &model).err().unwrap();
    assert_eq!(status, SinewStatus::WrongKind, "{text}");

    let driver = Drv::open(bytes, &model).unwrap();
    let info = driver.info();
    let (time, px) = track(&list.track).remove(0);
    let mut landmarks = pixels(&px, &list.camera).unwrap();
    // A NaN landmark is named with its index; nothing is written.
    landmarks[17] = f32::NAN;
    let mut pose = vec![7.0f32; info.pose_len];
    assert_eq!(
        driver.pose(&landmarks, &mut pose),
        Err((
            SinewStatus::InvalidInput,
            "landmarks[17] is NaN or infinite".into()
        ))
    );
    assert!(pose.iter().all(|&v| v == 7.0));
    landmarks[17] = 1e9;
    let (status, text) = driver.pose(&landmarks, &mut pose).unwrap_err();
    assert_eq!(
        (status, text.as_str()),
        (SinewStatus::InvalidInput, "landmarks[17] is outside ±1e5")
    );
    let (status, text) = driver.pose(&landmarks[..100], &mut pose).unwrap_err();
    assert_eq!(status, SinewStatus::BufferLength, "{text}");
    // Pixels and intrinsics are named as the C parameters.
    let mut bad = px.clone();
    bad[5] = f32::INFINITY;
    assert_eq!(
        pixels(&bad, &list.camera),
        Err((
            SinewStatus::InvalidInput,
            "pixels[5] is NaN or infinite".into()
        ))
    );
    let zero = SinewIntrinsics {
        fx: 0.0,
        ..list.camera
    };
    let (status, text) = pixels(&px, &zero).unwrap_err();
    assert_eq!(status, SinewStatus::InvalidInput);
    assert!(text.starts_with("intrinsics.fx "), "{text}");
    // The filter: bad settings, a time stamp that does not move on, a state of another length.
    let good = pixels(&px, &list.camera).unwrap();
    driver.pose(&good, &mut pose).unwrap();
    let mut state = vec![0.0f32; info.filter_state_floats];
    driver
        .filter(&list.filter, time, &mut state, &mut pose)
        .unwrap();
    let before = (state.clone(), pose.clone());
    let (status, text) = driver
        .filter(&list.filter, time, &mut state, &mut pose)
        .unwrap_err();
    assert_eq!(
        (status, text.as_str()),
        (
            SinewStatus::InvalidInput,
            "time[0] is not at least 1e-3 s after the last frame's time stamp"
        )
    );
    let negative = SinewFilter {
        beta: -1.0,
        ..list.filter
    };
    let (status, text) = driver
        .filter(&negative, time + 1.0, &mut state, &mut pose)
        .unwrap_err();
    assert_eq!(
        (status, text.as_str()),
        (SinewStatus::InvalidInput, "filter[1] is outside [0, 1e3]")
    );
    let mut nan_pose = pose.clone();
    nan_pose[20] = f32::NAN;
    let (status, text) = driver
        .filter(&list.filter, time + 1.0, &mut state, &mut nan_pose)
        .unwrap_err();
    assert_eq!(
        (status, text.as_str()),
        (SinewStatus::InvalidInput, "weights[2] is NaN or infinite")
    );
    assert_eq!(
        (state.clone(), pose.clone()),
        before,
        "refusals change nothing"
    );
    let (status, _) = driver
        .filter(&list.filter, time + 1.0, &mut state[1..], &mut pose)
        .unwrap_err();
    assert_eq!(status, SinewStatus::BufferLength);
    // Playing: another actor, a hash without normals.
    let (status, _) = driver.play(&other, &pose).unwrap_err();
    assert_eq!(status, SinewStatus::ModelMismatch);
    let v3 = 3 * info.vertex_count;
    let mut p = vec![0.0f32; v3];
    let mut hash = 0u64;
    let mut err = new_error();
    // Safety: live handles; `p` has the length passed; no normals.
    let status = unsafe {
        sinew_driver_play(
            driver.handle,
            model.handle,
            pose.as_ptr(),
            pose.len(),
            p.as_mut_ptr(),
            p.len(),
            null_mut(),
            0,
            &mut hash,
            &mut err,
        )
    };
    assert_eq!(status, SinewStatus::NullPointer, "{}", message(&err));
}
