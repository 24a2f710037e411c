//! The refusals of the performance, sequence and pose-mode calls: NULL pointers, handles of the
//! wrong kind, frames and labels out of range, non-finite inputs and wrong lengths, each with
//! its status and a message naming the argument, the value or the index at fault.
#![allow(unsafe_code)] // Calling the C API is `unsafe` by nature; each call site says why it holds.

use std::ptr::{null, null_mut};

use sinew::*;

mod common;
use common::{Model, data, message, new_error};

/// Opens a performance from `bytes`: the status, the message and the handle (NULL on failure).
fn open_perf(bytes: &[u8]) -> (SinewStatus, String, *mut SinewPerformance) {
    let mut handle = null_mut();
    let mut err = new_error();
    // Safety: `bytes` has the length passed; on success the caller frees the handle before the
    // bytes.
    let status =
        unsafe { sinew_performance_open(bytes.as_ptr(), bytes.len(), &mut handle, &mut err) };
    (status, message(&err), handle)
}

#[test]
fn performance_calls_refuse_what_they_cannot_play() {
    // Not a performance, truncated, NULL.
    let actor = data("aim-ict.sinew");
    let (status, msg, h) = open_perf(&actor);
    assert_eq!(
        (status, msg.as_str(), h),
        (
            SinewStatus::WrongKind,
            "the artefact is an AIM actor, not a fitted performance",
            null_mut()
        )
    );
    let bytes = data("fit-ict.sinew");
    let (status, msg, _) = open_perf(&bytes[..200]);
    assert_eq!(status, SinewStatus::InvalidFormat);
    assert_eq!(
        msg,
        format!(
            "performance: header says the file is {} bytes, but it is 200 bytes (truncated or \
             padded)",
            bytes.len()
        )
    );
    let mut handle = null_mut();
    let mut err = new_error();
    // Safety: NULL bytes are refused before any access.
    let status = unsafe { sinew_performance_open(null(), 10, &mut handle, &mut err) };
    assert_eq!(
        (status, message(&err)),
        (SinewStatus::NullPointer, "bytes is NULL".into())
    );

    let (status, _, perf) = open_perf(&bytes);
    assert_eq!(status, SinewStatus::Ok);
    let model = Model::open("aim-ict.sinew");
    let other = Model::open("aim-procedural.sinew");
    let s2d = Model::open("s2d-ict.sinew");
    let check = |m: &Model| {
        let mut err = new_error();
        // Safety: live handles.
        let status = unsafe { sinew_performance_check_model(perf, m.handle, &mut err) };
        (status, message(&err))
    };
    let mut want = 0u64;
    let mut found = 0u64;
    // Safety: live handles, writable hashes.
    unsafe {
        sinew_model_content_hash(model.handle, &mut want, null_mut());
        sinew_model_content_hash(other.handle, &mut found, null_mut());
    }
    assert_eq!(
        check(&other),
        (
            SinewStatus::ModelMismatch,
            format!(
                "the performance was fitted to the actor {want:016x}, this model is {found:016x}"
            )
        )
    );
    assert_eq!(
        check(&s2d),
        (
            SinewStatus::WrongKind,
            "the model is an S2D decoder, not an AIM actor".into()
        )
    );
    assert_eq!(check(&model), (SinewStatus::Ok, String::new()));

    let mut info = std::mem::MaybeUninit::uninit();
    // Safety: a live handle and a writable info.
    unsafe { sinew_performance_info(perf, info.as_mut_ptr(), null_mut()) };
    // Safety: written above.
    let info = unsafe { info.assume_init() };
    let v3 = 3 * model.info().vertex_count;
    let pose = |m: &Model, f: usize, scratch: usize, positions: usize, normals: bool| {
        let mut s = vec![0.0f32; scratch];
        let mut p = vec![0.0f32; positions];
        let mut n = vec![0.0f32; v3];
        let mut hash = 0;
        let mut err = new_error();
        let n_ptr = if normals { n.as_mut_ptr() } else { null_mut() };
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_performance_pose(
                perf,
                m.handle,
                f,
                s.as_mut_ptr(),
                s.len(),
                p.as_mut_ptr(),
                p.len(),
                n_ptr,
                n.len(),
                &mut hash,
                &mut err,
            )
        };
        (status, message(&err))
    };
    let n = info.frame_count;
    let s = info.scratch_floats;
    assert_eq!(
        pose(&model, n, s, v3, true),
        (
            SinewStatus::OutOfRange,
            format!("frame {n} is past the performance's {n} frames")
        )
    );
    assert_eq!(pose(&other, 0, s, v3, true).0, SinewStatus::ModelMismatch);
    assert_eq!(
        pose(&model, 0, s - 1, v3, true),
        (
            SinewStatus::BufferLength,
            format!("scratch has {} floats, the model needs at least {s}", s - 1)
        )
    );
    assert_eq!(
        pose(&model, 0, s, v3 - 3, true),
        (
            SinewStatus::BufferLength,
            format!("positions has {} elements, {v3} expected", v3 - 3)
        )
    );
    assert_eq!(
        pose(&model, 0, s, v3, false),
        (
            SinewStatus::NullPointer,
            "normals (the frame hash covers the normals) is NULL".into()
        )
    );
    assert_eq!(pose(&model, 0, s, v3, true).0, SinewStatus::Ok);
    let (mut head, mut jaw) = ([0.0f32; 9], [0.0f32; 9]);
    let mut err = new_error();
    // Safety: a NULL performance is refused before any access.
    let status = unsafe {
        sinew_performance_frame(
            null(),
            0,
            head.as_mut_ptr(),
            jaw.as_mut_ptr(),
            null_mut(),
            0,
            &mut err,
        )
    };
    assert_eq!(
        (status, message(&err)),
        (SinewStatus::NullPointer, "perf is NULL".into())
    );
    // Safety: a live handle; head and jaw hold 9 floats.
    let status = unsafe {
        sinew_performance_frame(
            perf,
            n + 5,
            head.as_mut_ptr(),
            jaw.as_mut_ptr(),
            null_mut(),
            0,
            &mut err,
        )
    };
    assert_eq!(
        (status, message(&err)),
        (
            SinewStatus::OutOfRange,
            format!("frame {} is past the performance's {n} frames", n + 5)
        )
    );
    // Safety: opened above, freed once; NULL is ignored.
    unsafe {
        sinew_performance_free(perf);
        sinew_performance_free(null_mut());
    }
}

/// Opens a sequence from the generator bytes `bytes` on `decoder`.
fn open_seq(bytes: &[u8], decoder: &Model) -> (SinewStatus, String, *mut SinewSequence) {
    let mut handle = null_mut();
    let mut err = new_error();
    // Safety: `bytes` and the decoder's bytes outlive the handle (freed by each test).
    let status = unsafe {
        sinew_sequence_open(
            bytes.as_ptr(),
            bytes.len(),
            decoder.handle,
            &mut handle,
            &mut err,
        )
    };
    (status, message(&err), handle)
}

#[test]
fn sequence_calls_refuse_what_they_cannot_generate() {
    let generator = data("motion-ict.sinew");
    let aim = Model::open("aim-procedural.sinew");
    let decoder = Model::open("s2d-ict.sinew");
    let (status, msg, h) = open_seq(&generator, &aim);
    assert_eq!(
        (status, msg.as_str(), h),
        (
            SinewStatus::WrongKind,
            "the model is an AIM actor, not an S2D decoder",
            null_mut()
        )
    );
    let s2d_bytes = data("s2d-ict.sinew");
    let (status, msg, _) = open_seq(&s2d_bytes, &decoder);
    assert_eq!(
        (status, msg.as_str()),
        (
            SinewStatus::WrongKind,
            "the artefact is an S2D decoder, not a motion generator"
        )
    );
    let (status, _, seq) = open_seq(&generator, &decoder);
    assert_eq!(status, SinewStatus::Ok);
    let mut info = std::mem::MaybeUninit::uninit();
    // Safety: a live handle and a writable info.
    unsafe { sinew_sequence_info(seq, info.as_mut_ptr(), null_mut()) };
    // Safety: written above.
    let info = unsafe { info.assume_init() };
    let v3 = 3 * info.vertex_count;
    let curve = |label: usize, intensity: f32, neutral: Option<&[f32]>, len: usize| {
        let mut c = vec![0.0f32; len];
        let mut s = vec![0.0f32; info.scratch_floats];
        let (n, nl) = neutral.map_or((null(), 0), |n| (n.as_ptr(), n.len()));
        let mut err = new_error();
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_sequence_curve(
                seq,
                label,
                7,
                intensity,
                n,
                nl,
                c.as_mut_ptr(),
                c.len(),
                s.as_mut_ptr(),
                s.len(),
                &mut err,
            )
        };
        (status, message(&err), c)
    };
    let cf = info.curve_floats;
    let labels = info.label_count;
    let (status, msg, _) = curve(labels, 1.0, None, cf);
    assert_eq!(
        (status, msg),
        (
            SinewStatus::OutOfRange,
            format!("label {labels} is past the generator's {labels} labels")
        )
    );
    let (status, msg, _) = curve(0, f32::NAN, None, cf);
    assert_eq!(
        (status, msg.as_str()),
        (SinewStatus::InvalidInput, "intensity[0] is NaN or infinite")
    );
    let (status, msg, _) = curve(0, 1e9, None, cf);
    assert_eq!(
        (status, msg.as_str()),
        (SinewStatus::InvalidInput, "intensity[0] is outside ±1e3")
    );
    let (status, msg, _) = curve(0, 1.0, None, cf - 1);
    assert_eq!(
        (status, msg),
        (
            SinewStatus::BufferLength,
            format!("curve has {} elements, {cf} expected", cf - 1)
        )
    );
    let (status, msg, _) = curve(0, 1.0, Some(&vec![0.0; v3 - 1]), cf);
    assert_eq!(
        (status, msg),
        (
            SinewStatus::BufferLength,
            format!("neutral has {} elements, {v3} expected", v3 - 1)
        )
    );
    let (status, _, good) = curve(0, 1.0, None, cf);
    assert_eq!(status, SinewStatus::Ok);
    let frame = |t: usize, curve: &[f32], vertices: usize| {
        let mut s = vec![0.0f32; info.scratch_floats];
        let mut v = vec![0.0f32; vertices];
        let mut err = new_error();
        // Safety: every buffer has the length passed.
        let status = unsafe {
            sinew_sequence_frame(
                seq,
                t,
                curve.as_ptr(),
                curve.len(),
                null(),
                0,
                s.as_mut_ptr(),
                s.len(),
                v.as_mut_ptr(),
                v.len(),
                null_mut(),
                &mut err,
            )
        };
        (status, message(&err))
    };
    let past = info.frame_count + 1;
    assert_eq!(
        frame(past, &good, v3),
        (
            SinewStatus::OutOfRange,
            format!(
                "frame {past} is past the sequence's {} frames",
                info.frame_count
            )
        )
    );
    assert_eq!(frame(1, &good, v3 + 3).0, SinewStatus::BufferLength);
    // A curve value, named by its index in the curve.
    let mut bad = good.clone();
    let at = 3 * info.landmark_count + 5;
    bad[at] = f32::INFINITY;
    assert_eq!(
        frame(1, &bad, v3),
        (
            SinewStatus::InvalidInput,
            format!("curve[{at}] is NaN or infinite")
        )
    );
    // A neutral face coordinate, named by its index in the face.
    let mut neutral = vec![0.0f32; v3];
    neutral[v3 - 1] = 2e5;
    let (status, msg, _) = curve(0, 1.0, Some(&neutral), cf);
    assert_eq!(
        (status, msg),
        (
            SinewStatus::InvalidInput,
            format!("neutral[{}] is outside ±1e5", v3 - 1)
        )
    );
    assert_eq!(frame(1, &good, v3), (SinewStatus::Ok, String::new()));
    let mut needed = 0;
    let mut err = new_error();
    // Safety: a size query on a live handle.
    let status =
        unsafe { sinew_sequence_label_name(seq, labels, null_mut(), 0, &mut needed, &mut err) };
    assert_eq!(status, SinewStatus::OutOfRange);
    // Safety: opened above, freed once; NULL is ignored.
    unsafe {
        sinew_sequence_free(seq);
        sinew_sequence_free(null_mut());
    }
}

#[test]
fn pose_modes_refuse_as_the_f32_pose_refuses() {
    let model = Model::open("aim-procedural.sinew");
    let s2d = Model::open("s2d-ict.sinew");
    let info = model.info();
    let v3 = 3 * info.vertex_count;
    let identity = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0f32];
    let mut nan_head = identity;
    nan_head[4] = f32::NAN;
    let w = vec![0.0f32; info.shape_count];
    let q16 = |m: &Model, head: &[f32; 9], positions: Option<&mut [i32]>| {
        let mut err = new_error();
        let (p, l) = positions.map_or((null_mut(), v3), |p| (p.as_mut_ptr(), p.len()));
        // Safety: every buffer has the length passed (a NULL one is refused first).
        let status = unsafe {
            sinew_aim_pose_q16(
                m.handle,
                head.as_ptr(),
                identity.as_ptr(),
                w.as_ptr(),
                w.len(),
                p,
                l,
                &mut err,
            )
        };
        (status, message(&err))
    };
    let mut q = vec![7i32; v3];
    assert_eq!(
        q16(&model, &nan_head, Some(&mut q)),
        (
            SinewStatus::InvalidInput,
            "head[4] is NaN or infinite".into()
        )
    );
    assert!(q.iter().all(|&x| x == 7), "nothing is written");
    assert_eq!(q16(&s2d, &identity, Some(&mut q)).0, SinewStatus::WrongKind);
    assert_eq!(
        q16(&model, &identity, None),
        (SinewStatus::NullPointer, "positions is NULL".into())
    );
    let fast = |head: &[f32; 9], weights: &[f32], normals: bool| {
        let (mut p, mut n) = (vec![0.0f32; v3], vec![0.0f32; v3]);
        let mut err = new_error();
        let n_ptr = if normals { n.as_mut_ptr() } else { null_mut() };
        // Safety: every buffer has the length passed (a NULL one is refused first).
        let status = unsafe {
            sinew_aim_pose_fast(
                model.handle,
                head.as_ptr(),
                identity.as_ptr(),
                weights.as_ptr(),
                weights.len(),
                p.as_mut_ptr(),
                p.len(),
                n_ptr,
                n.len(),
                &mut err,
            )
        };
        (status, message(&err))
    };
    assert_eq!(
        fast(&nan_head, &w, true),
        (
            SinewStatus::InvalidInput,
            "head[4] is NaN or infinite".into()
        )
    );
    let mut big = w.clone();
    big[1] = 5e3;
    assert_eq!(
        fast(&identity, &big, true),
        (
            SinewStatus::InvalidInput,
            "weights[1] is outside ±1e3".into()
        )
    );
    assert_eq!(
        fast(&identity, &w[1..], true),
        (
            SinewStatus::BufferLength,
            format!("weights has {} elements, {} expected", w.len() - 1, w.len())
        )
    );
    assert_eq!(
        fast(&identity, &w, false),
        (SinewStatus::NullPointer, "normals is NULL".into())
    );
    let mut hash = 0;
    let mut err = new_error();
    // Safety: NULL values are refused before any access.
    let status = unsafe { sinew_hash_q16(null(), 3, &mut hash, &mut err) };
    assert_eq!(
        (status, message(&err)),
        (SinewStatus::NullPointer, "values is NULL".into())
    );
}
