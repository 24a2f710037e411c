//! The C API on the golden models and replays of `tests/data/`: every frame of every replay
//! played through the extern functions must give the recorded hash, and the hash lists they print
//! must be the committed `*.hashes` files byte for byte (what `examples/replay.c` does from C).
//! Then the failures: each bad input gives its status and a message naming the problem.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::fmt::Write as _;
use std::ptr::{null, null_mut};

use sinew::*;

mod common;
use common::{Model, data, message, new_error, reseal, with_text};

struct Replay {
    handle: *mut SinewReplay,
    _bytes: Vec<u8>,
}

impl Replay {
    fn open(name: &str) -> Self {
        let bytes = data(name);
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: `bytes` outlives the handle.
        let status =
            unsafe { sinew_replay_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
        assert_eq!(status, SinewStatus::Ok, "{name}: {}", message(&err));
        Self {
            handle,
            _bytes: bytes,
        }
    }

    fn info(&self) -> SinewReplayInfo {
        let mut info = std::mem::MaybeUninit::uninit();
        // Safety: a live handle and a writable info.
        let status = unsafe { sinew_replay_info(self.handle, info.as_mut_ptr(), null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        unsafe { info.assume_init() }
    }

    fn aim_frame(&self, f: usize, weights: &mut [f32]) -> ([f32; 9], [f32; 9], u64) {
        let (mut head, mut jaw, mut expected) = ([0.0; 9], [0.0; 9], 0);
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_replay_aim_frame(
                self.handle,
                f,
                head.as_mut_ptr(),
                jaw.as_mut_ptr(),
                weights.as_mut_ptr(),
                weights.len(),
                &mut expected,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        (head, jaw, expected)
    }
}

impl Drop for Replay {
    fn drop(&mut self) {
        // Safety: opened by `Replay::open`, freed once.
        unsafe { sinew_replay_free(self.handle) };
    }
}

fn aim_hash(model: &Model, mode: u32, head: &[f32; 9], jaw: &[f32; 9], weights: &[f32]) -> u64 {
    let mut scratch = vec![0.0f32; model.info().scratch_floats];
    let mut hash = 0;
    let mut err = new_error();
    // Safety: every buffer has the length passed.
    let status = unsafe {
        sinew_aim_frame_hash(
            model.handle,
            mode,
            head.as_ptr(),
            jaw.as_ptr(),
            weights.as_ptr(),
            weights.len(),
            scratch.as_mut_ptr(),
            scratch.len(),
            &mut hash,
            &mut err,
        )
    };
    assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
    hash
}

/// Plays every mode's replay of an AIM golden model through the C API into the text of its
/// `.hashes` file, checking each frame against the replay on the way.
fn aim_hash_list(name: &str) -> String {
    let model = Model::open(&format!("{name}.sinew"));
    let info = model.info();
    assert_eq!(info.kind, SinewKind::Aim);
    assert!(info.has_q16);
    assert_eq!(info.scratch_bytes, 4 * info.scratch_floats);
    let mut text = format!(
        "# {name}.sinew: {} vertices, {} shapes; per mode and frame: f32/fast hash positions then \
         normals, q16 the positions' raw bits\n",
        info.vertex_count, info.shape_count
    );
    for (mode, label) in [
        (SinewMode::F32, "f32"),
        (SinewMode::Q16, "q16"),
        (SinewMode::Fast, "fast"),
    ] {
        let replay = Replay::open(&format!("{name}.{label}.replay.sinew"));
        let rinfo = replay.info();
        assert_eq!((rinfo.kind, rinfo.mode), (SinewKind::Aim, mode));
        assert_eq!(rinfo.shape_count, info.shape_count);
        // Safety: live handles.
        let status = unsafe { sinew_replay_check_model(replay.handle, model.handle, null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        let mut weights = vec![0.0; rinfo.shape_count];
        for f in 0..rinfo.frame_count {
            let (head, jaw, expected) = replay.aim_frame(f, &mut weights);
            let hash = aim_hash(&model, mode as u32, &head, &jaw, &weights);
            assert_eq!(hash, expected, "{name} {label} frame {f}");
            writeln!(text, "{label} {f} {hash:016x}").unwrap();
        }
    }
    // Each f32 frame's coefficients alone give the jaw (`sinew_aim_jaw_from_weights`).
    text.push_str(
        "# jaw: per frame, the hash of jaw_from_weights(coefficients), then the f32 frame hash \
         with that jaw\n",
    );
    let replay = Replay::open(&format!("{name}.f32.replay.sinew"));
    let mut weights = vec![0.0; info.shape_count];
    for f in 0..replay.info().frame_count {
        let (head, _, _) = replay.aim_frame(f, &mut weights);
        let mut jaw = [0.0f32; 9];
        let mut err = new_error();
        // Safety: a live handle, buffers of the lengths passed.
        let status = unsafe {
            sinew_aim_jaw_from_weights(
                model.handle,
                weights.as_ptr(),
                weights.len(),
                jaw.as_mut_ptr(),
                &mut err,
            )
        };
        assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
        let jaw_hash = sinew_core::hash::frame_hash(&jaw);
        let hash = aim_hash(&model, SinewMode::F32 as u32, &head, &jaw, &weights);
        writeln!(text, "jaw {f} {jaw_hash:016x} {hash:016x}").unwrap();
    }
    text
}

#[test]
fn aim_replays_give_the_golden_hashes_through_the_c_api() {
    for name in ["aim-procedural", "aim-ict"] {
        let committed = String::from_utf8(data(&format!("{name}.hashes"))).unwrap();
        assert_eq!(aim_hash_list(name), committed, "{name}.hashes");
    }
}

#[test]
fn s2d_replay_gives_the_golden_hashes_through_the_c_api() {
    let model = Model::open("s2d-ict.sinew");
    let info = model.info();
    assert_eq!(info.kind, SinewKind::S2d);
    assert_eq!(info.landmark_count, 68);
    assert_eq!(info.input_len, 3 * 68);
    let replay = Replay::open("s2d-ict.replay.sinew");
    let rinfo = replay.info();
    assert_eq!(rinfo.kind, SinewKind::S2d);
    assert_eq!(rinfo.input_len, info.input_len);
    assert_eq!(rinfo.neutral_len, 3 * info.vertex_count);
    // Safety (all calls below): live handles, buffers of the lengths passed.
    assert_eq!(
        unsafe { sinew_replay_check_model(replay.handle, model.handle, null_mut()) },
        SinewStatus::Ok
    );
    let mut neutral = vec![0.0f32; rinfo.neutral_len];
    let status = unsafe {
        sinew_replay_s2d_neutral(
            replay.handle,
            neutral.as_mut_ptr(),
            neutral.len(),
            null_mut(),
        )
    };
    assert_eq!(status, SinewStatus::Ok);
    let mut text = format!(
        "# s2d-ict.sinew: {} vertices, {} inputs, {} scratch values; per frame: the decoded \
         vertices (f32 bits), decoded onto the replay's neutral\n",
        info.vertex_count, info.input_len, info.scratch_floats
    );
    let mut input = vec![0.0f32; rinfo.input_len];
    let mut scratch = vec![0.0f32; info.scratch_floats];
    let mut vertices = vec![0.0f32; 3 * info.vertex_count];
    for f in 0..rinfo.frame_count {
        let mut expected = 0;
        let status = unsafe {
            sinew_replay_s2d_frame(
                replay.handle,
                f,
                input.as_mut_ptr(),
                input.len(),
                &mut expected,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        let mut hash = 0;
        let status = unsafe {
            sinew_s2d_decode(
                model.handle,
                input.as_ptr(),
                input.len(),
                neutral.as_ptr(),
                neutral.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                vertices.as_mut_ptr(),
                vertices.len(),
                &mut hash,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        assert_eq!(hash, expected, "frame {f}");
        // The caller-side hash of the vertices is the same hash.
        let mut again = 0;
        let status = unsafe {
            sinew_hash_frame(
                vertices.as_ptr(),
                vertices.len(),
                null(),
                0,
                &mut again,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        assert_eq!(again, hash);
        writeln!(text, "s2d {f} {hash:016x}").unwrap();
    }
    assert_eq!(text, String::from_utf8(data("s2d-ict.hashes")).unwrap());
}

/// Frame 0 of the golden S2D sequence is the neutral itself, so landmarks read off the replay's
/// neutral at the decoder's landmark vertices, given as both sets, decode to frame 0's hash.
#[test]
fn s2d_decodes_from_68_landmarks() {
    let model = Model::open("s2d-ict.sinew");
    let info = model.info();
    let replay = Replay::open("s2d-ict.replay.sinew");
    let mut neutral = vec![0.0f32; replay.info().neutral_len];
    let mut lmk = vec![0u32; info.landmark_count];
    let mut frame0 = vec![0.0f32; info.input_len];
    let mut expected = 0;
    // Safety (all calls below): live handles, buffers of the lengths passed.
    unsafe {
        assert_eq!(
            sinew_replay_s2d_neutral(
                replay.handle,
                neutral.as_mut_ptr(),
                neutral.len(),
                null_mut()
            ),
            SinewStatus::Ok
        );
        assert_eq!(
            sinew_s2d_landmarks(model.handle, lmk.as_mut_ptr(), lmk.len(), null_mut()),
            SinewStatus::Ok
        );
        assert_eq!(
            sinew_replay_s2d_frame(
                replay.handle,
                0,
                frame0.as_mut_ptr(),
                frame0.len(),
                &mut expected,
                null_mut()
            ),
            SinewStatus::Ok
        );
    }
    let landmarks: Vec<f32> = lmk
        .iter()
        .flat_map(|&v| neutral[3 * v as usize..3 * v as usize + 3].to_vec())
        .collect();
    assert_eq!(landmarks.len(), 3 * 68);
    let mut input = vec![1.0f32; info.input_len];
    let mut scratch = vec![0.0f32; info.scratch_floats];
    let mut vertices = vec![0.0f32; 3 * info.vertex_count];
    let mut hash = 0;
    unsafe {
        assert_eq!(
            sinew_s2d_landmark_input(
                model.handle,
                landmarks.as_ptr(),
                landmarks.as_ptr(),
                landmarks.len(),
                input.as_mut_ptr(),
                input.len(),
                null_mut(),
            ),
            SinewStatus::Ok
        );
        assert_eq!(input, frame0);
        assert_eq!(
            sinew_s2d_decode(
                model.handle,
                input.as_ptr(),
                input.len(),
                neutral.as_ptr(),
                neutral.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                vertices.as_mut_ptr(),
                vertices.len(),
                &mut hash,
                null_mut(),
            ),
            SinewStatus::Ok
        );
    }
    assert_eq!(hash, expected);
    // A moved landmark set gives the core's own normalisation, bit for bit.
    let moved: Vec<f32> = landmarks
        .iter()
        .enumerate()
        .map(|(i, x)| x + 0.01 * (i % 7) as f32)
        .collect();
    unsafe {
        assert_eq!(
            sinew_s2d_landmark_input(
                model.handle,
                landmarks.as_ptr(),
                moved.as_ptr(),
                moved.len(),
                input.as_mut_ptr(),
                input.len(),
                null_mut(),
            ),
            SinewStatus::Ok
        );
    }
    let bytes = data("s2d-ict.sinew");
    let decoder = sinew_core::s2d::S2dDecoder::from_bytes(&bytes).unwrap();
    let mut core_input = vec![0.0f32; info.input_len];
    decoder.input(&landmarks, &moved, &mut core_input).unwrap();
    assert_eq!(
        input.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        core_input.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
    assert!(input.iter().any(|&x| x != 0.0));
}

/// `sinew_aim_pose` writes what `sinew_aim_frame_hash` hashes: the positions and normals of the
/// f32 frame, whose caller-side hash is the recorded one; the triangles are the actor's.
#[test]
fn aim_pose_writes_the_hashed_frame() {
    let model = Model::open("aim-procedural.sinew");
    let info = model.info();
    let replay = Replay::open("aim-procedural.f32.replay.sinew");
    let mut weights = vec![0.0; info.shape_count];
    let (head, jaw, expected) = replay.aim_frame(5, &mut weights);
    let mut positions = vec![0.0f32; 3 * info.vertex_count];
    let mut normals = vec![0.0f32; 3 * info.vertex_count];
    let mut hash = 0;
    let mut triangles = vec![0u32; 3 * info.triangle_count];
    // Safety (all calls below): live handles, buffers of the lengths passed.
    unsafe {
        let status = sinew_aim_pose(
            model.handle,
            head.as_ptr(),
            jaw.as_ptr(),
            weights.as_ptr(),
            weights.len(),
            positions.as_mut_ptr(),
            positions.len(),
            normals.as_mut_ptr(),
            normals.len(),
            null_mut(),
        );
        assert_eq!(status, SinewStatus::Ok);
        let status = sinew_hash_frame(
            positions.as_ptr(),
            positions.len(),
            normals.as_ptr(),
            normals.len(),
            &mut hash,
            null_mut(),
        );
        assert_eq!(status, SinewStatus::Ok);
        let status = sinew_aim_triangles(
            model.handle,
            triangles.as_mut_ptr(),
            triangles.len(),
            null_mut(),
        );
        assert_eq!(status, SinewStatus::Ok);
        // Normals are optional.
        let status = sinew_aim_pose(
            model.handle,
            head.as_ptr(),
            jaw.as_ptr(),
            weights.as_ptr(),
            weights.len(),
            positions.as_mut_ptr(),
            positions.len(),
            null_mut(),
            0,
            null_mut(),
        );
        assert_eq!(status, SinewStatus::Ok);
    }
    assert_eq!(hash, expected);
    assert!(info.triangle_count > 0);
    assert!(triangles.iter().all(|&i| (i as usize) < info.vertex_count));
    let bytes = data("aim-procedural.sinew");
    let actor = sinew_core::aim::AimActor::from_bytes(&bytes).unwrap();
    assert_eq!(
        triangles,
        actor.triangles().indices().iter().collect::<Vec<_>>()
    );
}

/// One handle, many threads: handles are immutable, so concurrent calls with their own buffers
/// give the single-threaded hashes.
#[test]
fn one_model_serves_several_threads() {
    let model = Model::open("aim-procedural.sinew");
    let replay = Replay::open("aim-procedural.f32.replay.sinew");
    let frames = replay.info().frame_count;
    let shapes = model.info().shape_count;
    let (m, r) = (model.handle as usize, replay.handle as usize);
    std::thread::scope(|s| {
        for t in 0..4 {
            s.spawn(move || {
                let model = m as *const SinewModel;
                let replay = r as *const SinewReplay;
                let mut weights = vec![0.0f32; shapes];
                let mut scratch = vec![0.0f32; 6 * 336];
                for f in (t..frames).step_by(2) {
                    let (mut head, mut jaw, mut expected, mut hash) = ([0.0; 9], [0.0; 9], 0, 0);
                    // Safety: both handles outlive the scope; every buffer is this thread's own.
                    unsafe {
                        sinew_replay_aim_frame(
                            replay,
                            f,
                            head.as_mut_ptr(),
                            jaw.as_mut_ptr(),
                            weights.as_mut_ptr(),
                            shapes,
                            &mut expected,
                            null_mut(),
                        );
                        let status = sinew_aim_frame_hash(
                            model,
                            0,
                            head.as_ptr(),
                            jaw.as_ptr(),
                            weights.as_ptr(),
                            shapes,
                            scratch.as_mut_ptr(),
                            scratch.len(),
                            &mut hash,
                            null_mut(),
                        );
                        assert_eq!(status, SinewStatus::Ok);
                    }
                    assert_eq!(hash, expected, "thread {t} frame {f}");
                }
            });
        }
    });
}

/// Opens `bytes` as a model and returns the status and message (the handle must come back NULL).
fn open_status(bytes: *const u8, len: usize) -> (SinewStatus, String) {
    let mut handle = std::ptr::dangling_mut::<SinewModel>();
    let mut err = new_error();
    // Safety: `bytes` is NULL or points to `len` bytes that live through the call.
    let status = unsafe { sinew_model_open(bytes, len, &mut handle, &mut err) };
    assert!(handle.is_null(), "a failed open leaves *out NULL");
    assert_eq!(err.status, status);
    (status, message(&err))
}

#[test]
fn bad_model_bytes_are_named() {
    let bytes = data("aim-procedural.sinew");
    let (status, msg) = open_status(bytes.as_ptr(), bytes.len() - 100);
    assert_eq!(status, SinewStatus::InvalidFormat);
    assert!(msg.contains("truncated"), "{msg}");
    assert!(
        msg.contains(&format!("{} bytes", bytes.len() - 100)),
        "{msg}"
    );
    let (status, msg) = open_status(bytes.as_ptr(), 10);
    assert_eq!(status, SinewStatus::InvalidFormat);
    assert!(msg.contains("shorter than"), "{msg}");
    let mut corrupt = bytes.clone();
    let last = corrupt.len() - 1;
    corrupt[last] ^= 0x40;
    let (status, msg) = open_status(corrupt.as_ptr(), corrupt.len());
    assert_eq!(status, SinewStatus::InvalidFormat);
    assert!(msg.contains("CRC-32"), "{msg}");
    let (status, msg) = open_status(null(), 10);
    assert_eq!(status, SinewStatus::NullPointer);
    assert_eq!(msg, "bytes is NULL");
    // A replay is not a model.
    let replay = data("aim-procedural.f32.replay.sinew");
    let (status, msg) = open_status(replay.as_ptr(), replay.len());
    assert_eq!(status, SinewStatus::WrongKind);
    assert!(msg.contains("not an AIM actor or an S2D decoder"), "{msg}");
    // A model is not a replay.
    let mut handle = null_mut();
    let mut err = new_error();
    // Safety: `bytes` lives through the call.
    let status = unsafe { sinew_replay_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
    assert_eq!(status, SinewStatus::WrongKind);
    assert!(message(&err).contains("not a replay"), "{}", message(&err));
    // No `out`: a status, not a crash.
    // Safety: `bytes` lives through the call.
    let status = unsafe { sinew_model_open(bytes.as_ptr(), bytes.len(), null_mut(), null_mut()) };
    assert_eq!(status, SinewStatus::NullPointer);
}

/// A load error's record names the section or the metadata line at fault, after what was loaded.
#[test]
fn load_errors_name_the_section_and_line() {
    let open_replay = |bytes: &[u8]| {
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: `bytes` lives through the call; a failed open leaves no handle to free.
        let status =
            unsafe { sinew_replay_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
        assert!(handle.is_null());
        (status, message(&err))
    };
    let replay = data("aim-procedural.f32.replay.sinew");
    assert_eq!(
        open_replay(&with_text(&replay, b"mode=f32", b"mode=f64")),
        (
            SinewStatus::InvalidFormat,
            "AIM replay: metadata line 1: mode has a value this artefact does not take".into()
        )
    );
    assert_eq!(
        open_replay(&with_text(&replay, b"frames=", b"frames ")),
        (
            SinewStatus::InvalidFormat,
            "replay: metadata line 3 is not UTF-8 key=value text".into()
        )
    );
    // A decoder whose configuration claims one landmark more than its sections hold.
    let mut s2d = data("s2d-ict.sinew");
    let file = sinew_core::SinewFile::from_bytes(&s2d).unwrap();
    let at = file.section("s2d.cfg").unwrap().offset as usize;
    let inputs = u32::from_le_bytes(s2d[at..at + 4].try_into().unwrap());
    s2d[at..at + 4].copy_from_slice(&(inputs + 3).to_le_bytes());
    reseal(&mut s2d);
    assert_eq!(
        open_status(s2d.as_ptr(), s2d.len()),
        (
            SinewStatus::InvalidFormat,
            "S2D decoder: section s2d.lmk has a shape that does not fit with the others".into()
        )
    );
}

#[test]
fn bad_calls_are_named() {
    let aim = Model::open("aim-procedural.sinew");
    let s2d = Model::open("s2d-ict.sinew");
    let replay = Replay::open("aim-procedural.f32.replay.sinew");
    let info = aim.info();
    let head = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0f32];
    let weights = vec![0.0f32; info.shape_count];
    let mut scratch = vec![0.0f32; info.scratch_floats];
    let mut positions = vec![0.0f32; 3 * info.vertex_count];
    let mut hash = 0;
    let mut err = new_error();
    let mut frame_hash =
        |model: *const SinewModel, mode, weights: &[f32], scratch: &mut [f32], hash: *mut u64| {
            // Safety: every non-NULL buffer has the length passed.
            let status = unsafe {
                sinew_aim_frame_hash(
                    model,
                    mode,
                    head.as_ptr(),
                    head.as_ptr(),
                    weights.as_ptr(),
                    weights.len(),
                    scratch.as_mut_ptr(),
                    scratch.len(),
                    hash,
                    &mut err,
                )
            };
            assert_eq!(err.status, status);
            (status, message(&err))
        };
    let short = info.scratch_floats - 1;
    let cases = [
        (
            frame_hash(aim.handle, 0, &weights, &mut scratch[..short], &mut hash),
            SinewStatus::BufferLength,
            "scratch has",
        ),
        (
            frame_hash(aim.handle, 0, &weights[1..], &mut scratch, &mut hash),
            SinewStatus::BufferLength,
            "weights has 5 elements, 6 expected",
        ),
        (
            frame_hash(aim.handle, 3, &weights, &mut scratch, &mut hash),
            SinewStatus::OutOfRange,
            "mode 3 is unknown",
        ),
        (
            frame_hash(s2d.handle, 0, &weights, &mut scratch, &mut hash),
            SinewStatus::WrongKind,
            "is an S2D decoder, not an AIM actor",
        ),
        (
            frame_hash(null(), 0, &weights, &mut scratch, &mut hash),
            SinewStatus::NullPointer,
            "model is NULL",
        ),
        (
            frame_hash(aim.handle, 0, &weights, &mut scratch, null_mut()),
            SinewStatus::NullPointer,
            "hash is NULL",
        ),
    ];
    for ((status, msg), want, text) in cases {
        assert_eq!(status, want, "{msg}");
        assert!(msg.contains(text), "{msg:?} should contain {text:?}");
    }
    // Safety (all calls below): every non-NULL buffer has at least the length passed.
    unsafe {
        // Short positions.
        let status = sinew_aim_pose(
            aim.handle,
            head.as_ptr(),
            head.as_ptr(),
            weights.as_ptr(),
            weights.len(),
            positions.as_mut_ptr(),
            positions.len() - 3,
            null_mut(),
            0,
            &mut err,
        );
        assert_eq!(status, SinewStatus::BufferLength);
        assert!(
            message(&err).starts_with("positions has"),
            "{}",
            message(&err)
        );
        // A misaligned float buffer.
        let misaligned = (positions.as_mut_ptr() as *mut u8).wrapping_add(1) as *mut f32;
        let status = sinew_aim_pose(
            aim.handle,
            head.as_ptr(),
            head.as_ptr(),
            weights.as_ptr(),
            weights.len(),
            misaligned,
            positions.len() - 3,
            null_mut(),
            0,
            &mut err,
        );
        assert_eq!(status, SinewStatus::BufferLength);
        assert_eq!(message(&err), "positions is not aligned to 4 bytes");
        // NULL head.
        let status = sinew_aim_pose(
            aim.handle,
            null(),
            head.as_ptr(),
            weights.as_ptr(),
            weights.len(),
            positions.as_mut_ptr(),
            positions.len(),
            null_mut(),
            0,
            &mut err,
        );
        assert_eq!(status, SinewStatus::NullPointer);
        assert_eq!(message(&err), "head is NULL");
        // An S2D call on an actor.
        let status = sinew_s2d_decode(
            aim.handle,
            weights.as_ptr(),
            weights.len(),
            null(),
            0,
            scratch.as_mut_ptr(),
            scratch.len(),
            positions.as_mut_ptr(),
            positions.len(),
            null_mut(),
            &mut err,
        );
        assert_eq!(status, SinewStatus::WrongKind);
        assert!(message(&err).contains("not an S2D decoder"));
        // A replay against another model, and an AIM replay read as S2D.
        let status = sinew_replay_check_model(replay.handle, s2d.handle, &mut err);
        assert_eq!(status, SinewStatus::WrongKind);
        let ict = Model::open("aim-ict.sinew");
        let status = sinew_replay_check_model(replay.handle, ict.handle, &mut err);
        assert_eq!(status, SinewStatus::ModelMismatch);
        assert!(
            message(&err).contains("replay was recorded with model"),
            "{}",
            message(&err)
        );
        let mut input = [0.0f32; 4];
        let status = sinew_replay_s2d_frame(
            replay.handle,
            0,
            input.as_mut_ptr(),
            4,
            null_mut(),
            &mut err,
        );
        assert_eq!(status, SinewStatus::WrongKind);
        // A frame past the end.
        let mut w = weights.clone();
        let (mut h, mut j) = ([0.0f32; 9], [0.0f32; 9]);
        let frames = replay.info().frame_count;
        let status = sinew_replay_aim_frame(
            replay.handle,
            frames,
            h.as_mut_ptr(),
            j.as_mut_ptr(),
            w.as_mut_ptr(),
            w.len(),
            null_mut(),
            &mut err,
        );
        assert_eq!(status, SinewStatus::OutOfRange);
        assert_eq!(
            message(&err),
            format!("frame {frames} is past the replay's {frames} frames")
        );
        // NULL handles in every getter; NULL `err` still returns the status.
        assert_eq!(
            sinew_model_info(null(), null_mut(), null_mut()),
            SinewStatus::NullPointer
        );
        assert_eq!(
            sinew_replay_info(null(), null_mut(), null_mut()),
            SinewStatus::NullPointer
        );
        assert_eq!(
            sinew_model_info(aim.handle, null_mut(), &mut err),
            SinewStatus::NullPointer
        );
        assert_eq!(message(&err), "out is NULL");
        // Freeing NULL is a no-op.
        sinew_model_free(null_mut());
        sinew_replay_free(null_mut());
    }
}
