//! Every artefact the core plays, played through the C API: the golden fitted performance
//! (`fit-ict`, local coefficients) and a global one, the golden generated sequence
//! (`motion-ict` through `s2d-ict`), and an AIM frame's Q16.16 and fast outputs from the pose
//! calls. Expected hashes come from `tests/data/*.hashes` and the replays, never from this file.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::ptr::{null, null_mut};

use sinew::*;
use sinew_core::aim::AimActor;
use sinew_core::motion::MotionGenerator;
use sinew_core::performance::{self as perf, Performance};
use sinew_core::s2d::S2dDecoder;
use sinew_core::sequence::{Sequence, SequenceBuffers};

mod common;
use common::{Model, Section, container, data, message, new_error};

/// An open performance over bytes the struct keeps alive.
struct Perf {
    handle: *mut SinewPerformance,
    _bytes: Vec<u8>,
}

impl Perf {
    fn open(bytes: Vec<u8>) -> Self {
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: `bytes` outlives the handle (both in `Perf`, freed in `drop` first).
        let status =
            unsafe { sinew_performance_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
        assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
        Self {
            handle,
            _bytes: bytes,
        }
    }

    fn info(&self) -> SinewPerformanceInfo {
        let mut info = std::mem::MaybeUninit::uninit();
        // Safety: a live handle and a writable info.
        let status = unsafe { sinew_performance_info(self.handle, info.as_mut_ptr(), null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        unsafe { info.assume_init() }
    }

    /// Frame `f` posed on `model` with its normals and hash.
    fn pose(&self, model: &Model, f: usize) -> (Vec<f32>, Vec<f32>, u64) {
        let v3 = 3 * model.info().vertex_count;
        let mut scratch = vec![0.0f32; self.info().scratch_floats];
        let (mut p, mut n, mut hash) = (vec![0.0f32; v3], vec![0.0f32; v3], 0u64);
        let mut err = new_error();
        // Safety: live handles; every buffer has the length passed.
        let status = unsafe {
            sinew_performance_pose(
                self.handle,
                model.handle,
                f,
                scratch.as_mut_ptr(),
                scratch.len(),
                p.as_mut_ptr(),
                p.len(),
                n.as_mut_ptr(),
                n.len(),
                &mut hash,
                &mut err,
            )
        };
        assert_eq!(status, SinewStatus::Ok, "frame {f}: {}", message(&err));
        (p, n, hash)
    }

    /// Frame `f`'s head, jaw and (when `weights` is given) coefficients, and the status.
    fn frame(&self, f: usize, weights: Option<&mut [f32]>) -> ([f32; 9], [f32; 9], SinewStatus) {
        let (mut head, mut jaw) = ([0.0f32; 9], [0.0f32; 9]);
        let (w, len) = weights.map_or((null_mut(), 0), |w| (w.as_mut_ptr(), w.len()));
        // Safety: a live handle; head and jaw hold 9 floats, `w` `len` or is NULL.
        let status = unsafe {
            sinew_performance_frame(
                self.handle,
                f,
                head.as_mut_ptr(),
                jaw.as_mut_ptr(),
                w,
                len,
                null_mut(),
            )
        };
        (head, jaw, status)
    }
}

impl Drop for Perf {
    fn drop(&mut self) {
        // Safety: opened by `Perf::open`, freed once.
        unsafe { sinew_performance_free(self.handle) };
    }
}

/// The hashes of `fit-ict.hashes`: "frame hash" lines after a comment.
fn fit_hashes() -> Vec<u64> {
    let text = String::from_utf8(data("fit-ict.hashes")).unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
        .enumerate()
        .map(|(i, l)| {
            let (f, h) = l.split_once(' ').unwrap();
            assert_eq!(f.parse::<usize>().unwrap(), i);
            u64::from_str_radix(h, 16).unwrap()
        })
        .collect()
}

fn hash_frame(first: &[f32], second: &[f32]) -> u64 {
    let mut hash = 0;
    // Safety: both slices have the lengths passed.
    let status = unsafe {
        sinew_hash_frame(
            first.as_ptr(),
            first.len(),
            second.as_ptr(),
            second.len(),
            &mut hash,
            null_mut(),
        )
    };
    assert_eq!(status, SinewStatus::Ok);
    hash
}

#[test]
fn the_golden_fitted_performance_plays_its_hashes_through_the_c_api() {
    let model = Model::open("aim-ict.sinew");
    let p = Perf::open(data("fit-ict.sinew"));
    let info = p.info();
    let listed = fit_hashes();
    assert_eq!(info.frame_count, listed.len());
    assert!(info.is_local && info.has_hashes);
    assert_eq!(info.shape_count, model.info().shape_count);
    let mut content = 0u64;
    // Safety: live handles, writable hash.
    unsafe {
        assert_eq!(
            sinew_model_content_hash(model.handle, &mut content, null_mut()),
            SinewStatus::Ok
        );
        assert_eq!(
            sinew_performance_check_model(p.handle, model.handle, null_mut()),
            SinewStatus::Ok
        );
    }
    assert_eq!(info.model_hash, content);
    for (f, want) in listed.iter().enumerate() {
        let (positions, normals, hash) = p.pose(&model, f);
        assert_eq!(hash, *want, "frame {f} in fit-ict.hashes");
        assert_eq!(hash_frame(&positions, &normals), hash, "frame {f}");
        let mut baked = 0;
        // Safety: a live handle, a writable hash.
        let status = unsafe { sinew_performance_expected(p.handle, f, &mut baked, null_mut()) };
        assert_eq!(
            (status, baked),
            (SinewStatus::Ok, hash),
            "frame {f} as baked"
        );
        // A local fit has head and jaw per frame, but no coefficients to give.
        let (head, jaw, status) = p.frame(f, None);
        assert_eq!(status, SinewStatus::Ok);
        let bytes = data("fit-ict.sinew");
        let core = Performance::from_bytes(&bytes).unwrap();
        assert_eq!(Some((head, jaw)), core.head_jaw(f));
        let mut w = vec![0.0; info.shape_count];
        assert_eq!(p.frame(f, Some(&mut w)).2, SinewStatus::Unsupported);
    }
}

/// A global fit of the ICT actor, made from the golden local one: its heads and jaws, and per
/// frame a coefficient vector, so that a global performance is played from C too.
fn global_fit(frames: usize, shapes: usize) -> Vec<u8> {
    let bytes = data("fit-ict.sinew");
    let local = Performance::from_bytes(&bytes).unwrap();
    let h = local.model_hash();
    let mut poses = Vec::new();
    for f in 0..frames {
        let (head, jaw) = local.head_jaw(f % local.frames()).unwrap();
        poses.extend(head.into_iter().chain(jaw));
    }
    let weights: Vec<f32> = (0..frames * shapes)
        .map(|i| ((i * 37 % 17) as f32 / 17.0 - 0.5) * 0.8)
        .collect();
    let (frames, shapes) = (frames as u32, shapes as u32);
    container(
        sinew_core::format::ArtifactKind::Performance.code(),
        &[
            Section::u32s(perf::MODEL_HASH, &[2], &[h as u32, (h >> 32) as u32]),
            Section::f32s(perf::POSES, &[frames, 18], &poses),
            Section::f32s(perf::WEIGHTS, &[frames, shapes], &weights),
        ],
    )
}

#[test]
fn a_global_performance_plays_as_the_core_plays_it() {
    let model = Model::open("aim-ict.sinew");
    let m = model.info().shape_count;
    let bytes = global_fit(3, m);
    let p = Perf::open(bytes.clone());
    let info = p.info();
    assert!(!info.is_local && !info.has_hashes);
    assert_eq!((info.frame_count, info.shape_count), (3, m));
    let actor_bytes = data("aim-ict.sinew");
    let actor = AimActor::from_bytes(&actor_bytes).unwrap();
    let core = Performance::from_bytes(&bytes).unwrap();
    let v3 = 3 * actor.vertex_count();
    let mut scratch = vec![0.0; core.scratch_len()];
    let (mut cp, mut cn) = (vec![0.0; v3], vec![0.0; v3]);
    for f in 0..info.frame_count {
        let (positions, normals, hash) = p.pose(&model, f);
        let core_hash =
            perf::play_frame_hash(&core, &actor, f, &mut scratch, &mut cp, &mut cn).unwrap();
        assert_eq!(hash, core_hash, "frame {f}: the core's play_frame_hash");
        assert_eq!((positions.clone(), normals), (cp.clone(), cn.clone()));
        // A global frame is the actor posed with the frame's coefficients.
        let mut w = vec![0.0; m];
        let (head, jaw, status) = p.frame(f, Some(&mut w));
        assert_eq!(status, SinewStatus::Ok);
        let mut posed = vec![0.0f32; v3];
        // Safety: every buffer has the length passed; normals are not asked for.
        let status = unsafe {
            sinew_aim_pose(
                model.handle,
                head.as_ptr(),
                jaw.as_ptr(),
                w.as_ptr(),
                w.len(),
                posed.as_mut_ptr(),
                posed.len(),
                null_mut(),
                0,
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        assert_eq!(posed, positions, "frame {f}");
    }
    // The file carries no hashes to compare with.
    let mut err = new_error();
    let mut h = 0;
    // Safety: a live handle, a writable hash and error record.
    let status = unsafe { sinew_performance_expected(p.handle, 0, &mut h, &mut err) };
    assert_eq!(status, SinewStatus::Unsupported);
    assert_eq!(message(&err), "the performance carries no frame hashes");
}

/// An open sequence over the generator's bytes, with the decoder it plays on.
struct Seq {
    handle: *mut SinewSequence,
    _bytes: Vec<u8>,
    decoder: Model,
}

impl Seq {
    fn open() -> Self {
        let decoder = Model::open("s2d-ict.sinew");
        let bytes = data("motion-ict.sinew");
        let mut handle = null_mut();
        let mut err = new_error();
        // Safety: the generator's bytes and the decoder (with its bytes) outlive the handle.
        let status = unsafe {
            sinew_sequence_open(
                bytes.as_ptr(),
                bytes.len(),
                decoder.handle,
                &mut handle,
                &mut err,
            )
        };
        assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
        Self {
            handle,
            _bytes: bytes,
            decoder,
        }
    }

    fn info(&self) -> SinewSequenceInfo {
        let mut info = std::mem::MaybeUninit::uninit();
        // Safety: a live handle and a writable info.
        let status = unsafe { sinew_sequence_info(self.handle, info.as_mut_ptr(), null_mut()) };
        assert_eq!(status, SinewStatus::Ok);
        // Safety: written on success.
        unsafe { info.assume_init() }
    }

    /// The curve of `label` from `seed`, on `neutral` (empty: the template).
    fn curve(&self, label: usize, seed: u64, intensity: f32, neutral: &[f32]) -> Vec<f32> {
        let info = self.info();
        let mut curve = vec![0.0f32; info.curve_floats];
        let mut scratch = vec![0.0f32; info.scratch_floats];
        let n = if neutral.is_empty() {
            null()
        } else {
            neutral.as_ptr()
        };
        let mut err = new_error();
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_sequence_curve(
                self.handle,
                label,
                seed,
                intensity,
                n,
                neutral.len(),
                curve.as_mut_ptr(),
                curve.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                &mut err,
            )
        };
        assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
        curve
    }

    /// Frame `t` of `curve` decoded onto `neutral` (empty: the template), and its hash.
    fn frame(&self, t: usize, curve: &[f32], neutral: &[f32]) -> (Vec<f32>, u64) {
        let info = self.info();
        let mut scratch = vec![0.0f32; info.scratch_floats];
        let mut vertices = vec![0.0f32; 3 * info.vertex_count];
        let n = if neutral.is_empty() {
            null()
        } else {
            neutral.as_ptr()
        };
        let mut hash = 0;
        let mut err = new_error();
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_sequence_frame(
                self.handle,
                t,
                curve.as_ptr(),
                curve.len(),
                n,
                neutral.len(),
                scratch.as_mut_ptr(),
                scratch.len(),
                vertices.as_mut_ptr(),
                vertices.len(),
                &mut hash,
                &mut err,
            )
        };
        assert_eq!(status, SinewStatus::Ok, "frame {t}: {}", message(&err));
        (vertices, hash)
    }

    fn label_name(&self, label: usize) -> String {
        let mut needed = 0;
        // Safety: a size query: NULL buffer of length 0 and a writable `needed`.
        let status = unsafe {
            sinew_sequence_label_name(self.handle, label, null_mut(), 0, &mut needed, null_mut())
        };
        assert_eq!(status, SinewStatus::Ok);
        let mut buf = vec![0u8; needed];
        // Safety: `buf` has `needed` bytes.
        let status = unsafe {
            sinew_sequence_label_name(
                self.handle,
                label,
                buf.as_mut_ptr().cast(),
                buf.len(),
                null_mut(),
                null_mut(),
            )
        };
        assert_eq!(status, SinewStatus::Ok);
        assert_eq!(buf.pop(), Some(0));
        String::from_utf8(buf).unwrap()
    }
}

impl Drop for Seq {
    fn drop(&mut self) {
        // Safety: opened by `Seq::open`, freed once (the decoder is freed after it).
        unsafe { sinew_sequence_free(self.handle) };
    }
}

/// A hash list's sequence: the label's name and index, the seed and the intensity.
type Named = (String, usize, u64, f32);

/// `motion-ict.hashes`: the `sequence NAME LABEL SEED INTENSITY` line and the `motion T HASH`
/// lines.
fn motion_hashes() -> (Named, Vec<(usize, u64)>) {
    let text = String::from_utf8(data("motion-ict.hashes")).unwrap();
    let mut sequence = None;
    let mut frames = Vec::new();
    for line in text.lines() {
        let f: Vec<&str> = line.split_ascii_whitespace().collect();
        match f.as_slice() {
            ["sequence", name, label, seed, intensity] => {
                sequence = Some((
                    name.to_string(),
                    label.parse().unwrap(),
                    seed.parse().unwrap(),
                    intensity.parse().unwrap(),
                ));
            }
            ["motion", t, h] => {
                frames.push((t.parse().unwrap(), u64::from_str_radix(h, 16).unwrap()))
            }
            _ => {}
        }
    }
    (
        sequence.expect("motion-ict.hashes names its sequence"),
        frames,
    )
}

#[test]
fn the_golden_generated_sequence_plays_its_hashes_through_the_c_api() {
    let seq = Seq::open();
    let info = seq.info();
    let ((name, label, seed, intensity), listed) = motion_hashes();
    assert_eq!(listed.len(), info.frame_count);
    assert_eq!(info.frame_count, SINEW_SEQUENCE_FRAMES);
    assert_eq!(info.landmark_count, seq.decoder.info().landmark_count);
    assert_eq!(info.vertex_count, seq.decoder.info().vertex_count);
    assert_eq!(seq.label_name(label), name);
    let curve = seq.curve(label, seed, intensity, &[]);
    for (t, want) in &listed {
        let (vertices, hash) = seq.frame(*t, &curve, &[]);
        assert_eq!(hash, *want, "frame {t} in motion-ict.hashes");
        assert_eq!(sinew_core::hash::frame_hash(&vertices), hash);
    }
    // Frame 0 is the neutral: no displacement from the template's landmarks.
    let (first, _) = seq.frame(0, &curve, &[]);
    let last = seq.frame(info.frame_count, &curve, &[]).0;
    assert_ne!(first, last, "the sequence moves");
}

#[test]
fn a_sequence_on_another_neutral_plays_as_the_core_plays_it() {
    let seq = Seq::open();
    let info = seq.info();
    // The S2D replay's neutral: another face in the decoder's topology.
    let replay = data("s2d-ict.replay.sinew");
    let neutral: Vec<f32> = sinew_core::replay::S2dReplay::from_bytes(&replay)
        .unwrap()
        .neutral()
        .unwrap()
        .iter()
        .collect();
    let curve = seq.curve(3, 11, 0.5, &neutral);
    let generator = data("motion-ict.sinew");
    let decoder = data("s2d-ict.sinew");
    let core = Sequence::new(
        MotionGenerator::from_bytes(&generator).unwrap(),
        S2dDecoder::from_bytes(&decoder).unwrap(),
    )
    .unwrap();
    let mut c = vec![0.0; core.curve_len()];
    let mut input = vec![0.0; core.input_len()];
    let mut scratch = vec![0.0; core.scratch_len()];
    let mut vertices = vec![0.0; core.vertex_len()];
    let mut buf = SequenceBuffers {
        curve: &mut c,
        input: &mut input,
        neutral: &neutral,
        scratch: &mut scratch,
        vertices: &mut vertices,
    };
    core.curve(3, 11, 0.5, &mut buf).unwrap();
    assert_eq!(buf.curve, &curve[..]);
    for t in [1, info.frame_count / 2, info.frame_count] {
        let want = core.decode_frame_hash(t, &mut buf).unwrap();
        let (v, hash) = seq.frame(t, &curve, &neutral);
        assert_eq!((hash, &v[..]), (want, &buf.vertices[..]), "frame {t}");
    }
}

/// Every frame of an AIM golden's Q16 and fast replays, posed by the pose calls and hashed by
/// the hash calls, has the replay's hash.
#[test]
fn q16_and_fast_pose_outputs_hash_as_the_replays() {
    for name in ["aim-procedural", "aim-ict"] {
        let model = Model::open(&format!("{name}.sinew"));
        let info = model.info();
        let v3 = 3 * info.vertex_count;
        for mode in ["q16", "fast"] {
            let bytes = data(&format!("{name}.{mode}.replay.sinew"));
            let replay = sinew_core::replay::AimReplay::from_bytes(&bytes).unwrap();
            let mut w = vec![0.0f32; info.shape_count];
            for f in 0..replay.frames() {
                let (head, jaw) = replay.frame(f, &mut w).unwrap();
                let mut hash = 0;
                let mut err = new_error();
                // Safety: every buffer has the length passed.
                let status = unsafe {
                    if mode == "q16" {
                        let mut q = vec![0i32; v3];
                        let s = sinew_aim_pose_q16(
                            model.handle,
                            head.as_ptr(),
                            jaw.as_ptr(),
                            w.as_ptr(),
                            w.len(),
                            q.as_mut_ptr(),
                            q.len(),
                            &mut err,
                        );
                        assert_eq!(s, SinewStatus::Ok, "{}", message(&err));
                        sinew_hash_q16(q.as_ptr(), q.len(), &mut hash, &mut err)
                    } else {
                        let (mut p, mut n) = (vec![0.0f32; v3], vec![0.0f32; v3]);
                        let s = sinew_aim_pose_fast(
                            model.handle,
                            head.as_ptr(),
                            jaw.as_ptr(),
                            w.as_ptr(),
                            w.len(),
                            p.as_mut_ptr(),
                            p.len(),
                            n.as_mut_ptr(),
                            n.len(),
                            &mut err,
                        );
                        assert_eq!(s, SinewStatus::Ok, "{}", message(&err));
                        hash = hash_frame(&p, &n);
                        s
                    }
                };
                assert_eq!(status, SinewStatus::Ok, "{}", message(&err));
                assert_eq!(Some(hash), replay.expected(f), "{name} {mode} frame {f}");
            }
        }
    }
}
