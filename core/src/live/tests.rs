//! Live driving on the golden actor and driver: landmarks made here by posing the actor, placing
//! a tracker's convention on its landmark vertices and projecting them through the driver's
//! camera, so that the truth of every frame is known.

use std::vec;
use std::vec::Vec;

use super::*;
use crate::driver::{self, Intrinsics, normalise_pixels};
use crate::linalg::Mat3;
use crate::rotation::to_6d;

const ACTOR: &[u8] = include_bytes!("../../../tests/data/aim-ict.sinew");
const DRIVER: &[u8] = include_bytes!("../../../tests/data/driver-ict.sinew");
/// Two rows of the golden track (`driver-ict.csv`, frames 0 and 7): real expressions to pose.
const CAMERA: Intrinsics = Intrinsics {
    fx: 1200.0,
    fy: 1200.0,
    cx: 320.0,
    cy: 240.0,
};

struct Scene {
    actor: AimActor<'static>,
    driver: Driver<'static>,
}

fn scene() -> Scene {
    let actor = AimActor::from_bytes(ACTOR).unwrap();
    let driver = Driver::from_bytes(DRIVER).unwrap();
    driver.check_actor(ACTOR, &actor).unwrap();
    Scene { actor, driver }
}

/// A head turned by `yaw` and `pitch` (radians) and moved by `t`, at rest or with `pose`'s jaw
/// and coefficients.
fn pose_with(s: &Scene, yaw: f32, pitch: f32, t: [f32; 3], expression: Option<&[f32]>) -> Vec<f32> {
    let (sy, cy) = (libm::sinf(yaw), libm::cosf(yaw));
    let (sp, cp) = (libm::sinf(pitch), libm::cosf(pitch));
    let ry = Mat3::from_cols(Vec3::new(cy, 0.0, -sy), Vec3::Y, Vec3::new(sy, 0.0, cy));
    let rx = Mat3::from_cols(Vec3::X, Vec3::new(0.0, cp, sp), Vec3::new(0.0, -sp, cp));
    let mut pose = vec![0.0; s.driver.output_len()];
    rest_pose(&mut pose);
    pose[..6].copy_from_slice(&to_6d(&ry.mul_mat(&rx)));
    pose[6..9].copy_from_slice(&t);
    if let Some(e) = expression {
        pose[9..].copy_from_slice(&e[9..]);
    }
    pose
}

/// A tracker's convention: an offset per landmark in the face's frame (cm), largest on the
/// contour (outwards and down), the brows (up) and the lips (out of the mouth).
fn convention() -> Vec<Vec3> {
    (0..LANDMARKS)
        .map(|l| {
            let side = |x: f32| if l % 2 == 0 { x } else { -x };
            match l {
                0..=16 => Vec3::new(if l < 8 { -0.35 } else { 0.35 }, -0.25, -0.1),
                17..=26 => Vec3::new(side(0.05), 0.3, 0.0),
                27..=35 => Vec3::new(0.0, -0.08, 0.0),
                36..=47 => Vec3::new(side(0.04), 0.05, 0.0),
                48..=59 => Vec3::new(side(0.1), if l < 55 { 0.2 } else { -0.25 }, 0.0),
                _ => Vec3::new(side(0.05), 0.1, 0.0),
            }
        })
        .collect()
}

/// `pose`'s 68 landmarks, each moved by `offsets` in the face's frame, as the camera sees them
/// in pixels, then normalised as a 2D driver reads them.
fn landmarks(s: &Scene, pose: &[f32], offsets: Option<&[Vec3]>) -> Vec<f32> {
    let v3 = 3 * s.actor.vertex_count();
    let mut positions = vec![0.0; v3];
    driver::play(&s.actor, pose, &mut positions).unwrap();
    let mut points = vec![0.0; 3 * LANDMARKS];
    s.driver.landmarks_of(&positions, &mut points).unwrap();
    let head = head_of(pose);
    let camera = s.driver.camera().unwrap();
    let mut pixels = vec![0.0; 2 * LANDMARKS];
    for l in 0..LANDMARKS {
        let mut p = Vec3::new(points[3 * l], points[3 * l + 1], points[3 * l + 2]);
        if let Some(o) = offsets {
            p = p + head.rot.mul_vec(o[l]);
        }
        let [x, y] = project(camera, p, 1.0);
        pixels[2 * l] = CAMERA.cx + CAMERA.fx * x;
        pixels[2 * l + 1] = CAMERA.cy + CAMERA.fy * y;
    }
    let mut out = vec![0.0; 2 * LANDMARKS];
    normalise_pixels(&pixels, &CAMERA, &mut out).unwrap();
    out
}

/// Mean per-vertex distance (cm) between the actor posed by `a` and by `b`.
fn distance(s: &Scene, a: &[f32], b: &[f32]) -> f32 {
    let v3 = 3 * s.actor.vertex_count();
    let (mut pa, mut pb) = (vec![0.0; v3], vec![0.0; v3]);
    driver::play(&s.actor, a, &mut pa).unwrap();
    driver::play(&s.actor, b, &mut pb).unwrap();
    let total: f32 = pa
        .chunks_exact(3)
        .zip(pb.chunks_exact(3))
        .map(|(p, q)| {
            let d = Vec3::new(p[0] - q[0], p[1] - q[1], p[2] - q[2]);
            d.norm()
        })
        .sum();
    total / s.actor.vertex_count() as f32
}

/// The driver's pose of `landmarks` as they are.
fn raw(s: &Scene, landmarks: &[f32]) -> Vec<f32> {
    let mut scratch = vec![0.0; s.driver.scratch_len()];
    let mut pose = vec![0.0; s.driver.output_len()];
    s.driver.drive(landmarks, &mut scratch, &mut pose).unwrap();
    pose
}

/// Expressions the driver reads well: its own answers to two frames of the golden track.
fn expressions(s: &Scene) -> Vec<Vec<f32>> {
    let clean = |yaw, pitch, t| landmarks(s, &pose_with(s, yaw, pitch, t, None), None);
    let open = raw(s, &clean(0.1, 0.05, [0.5, -0.3, 2.0]));
    let mut smile = open.clone();
    for (i, w) in smile[18..].iter_mut().enumerate() {
        *w = if i % 3 == 0 { 0.6 } else { 0.0 };
    }
    smile[9..18].copy_from_slice(&REST_9);
    vec![open, smile]
}

struct Session<'s> {
    live: Live<'s, 'static>,
    state: Vec<f32>,
    scratch: Vec<f32>,
    pose: Vec<f32>,
    time: f32,
}

impl<'s> Session<'s> {
    fn new(s: &'s Scene, settings: Settings) -> Self {
        let live = Live::new(&s.driver, &s.actor, settings).unwrap();
        Self {
            state: vec![0.0; live.state_len()],
            scratch: vec![0.0; live.scratch_len()],
            pose: vec![0.0; s.driver.output_len()],
            live,
            time: 0.0,
        }
    }

    fn step(&mut self, landmarks: Option<&[f32]>) -> Outcome {
        self.time += 1.0 / 32.0;
        self.live
            .step(
                &mut self.state,
                landmarks,
                self.time,
                &mut self.scratch,
                &mut self.pose,
            )
            .unwrap()
    }
}

/// Calibration frames at rest looking at the camera, the head a little off the axis, with the
/// convention.
fn calibration(s: &Scene, offsets: Option<&[Vec3]>) -> Vec<Vec<f32>> {
    (0..6)
        .map(|k| {
            let wobble = 0.01 * (k as f32 - 2.5);
            let pose = pose_with(s, wobble, -wobble, [1.0 + wobble, -0.5, 3.0], None);
            landmarks(s, &pose, offsets)
        })
        .collect()
}

#[test]
fn a_calibration_takes_the_trackers_convention_off() {
    let s = scene();
    let offsets = convention();
    // Frames far apart (the rules would take them for jumps): the calibration alone.
    let mut live = Session::new(
        &s,
        Settings {
            calibrate_frames: 6,
            ..Settings::OFF
        },
    );
    let mut rest = vec![0.0; s.driver.output_len()];
    rest_pose(&mut rest);
    for (k, frame) in calibration(&s, Some(&offsets)).iter().enumerate() {
        assert_eq!(live.step(Some(frame)), Outcome::Calibrating, "frame {k}");
        assert_eq!(live.pose, rest, "frame {k} is written at rest");
        assert_eq!(live.live.calibrated_frames(&live.state), k as u32 + 1);
    }
    // The offsets found are the convention's across the image (its depth the camera cannot
    // see), within the head's error on the steady landmarks.
    let (mut err, mut size) = (0.0f32, 0.0f32);
    for (l, o) in offsets.iter().enumerate() {
        let found = live.live.offset(&live.state, l).unwrap();
        err += libm::hypotf(found[0] - o.x, found[1] - o.y);
        size += libm::hypotf(o.x, o.y);
    }
    assert!(err < 0.4 * size, "offsets off by {err} against {size}");
    let deviation = live.live.calibration_deviation(&live.state).unwrap();
    assert!(deviation < 0.05, "{deviation}");
    // Expressions under other heads: the calibrated pose is far nearer the truth than the raw
    // one, and near the driver's on clean landmarks.
    let heads = [(0.15, 0.0, [0.0, 0.0, 0.0]), (-0.2, 0.1, [-1.5, 1.0, -6.0])];
    for (e, truth) in expressions(&s).iter().enumerate() {
        for (h, &(yaw, pitch, t)) in heads.iter().enumerate() {
            let truth = pose_with(&s, yaw, pitch, t, Some(truth));
            let seen = landmarks(&s, &truth, Some(&offsets));
            assert_eq!(live.step(Some(&seen)), Outcome::Driven, "{e} {h}");
            let calibrated = distance(&s, &live.pose, &truth);
            let conventional = distance(&s, &raw(&s, &seen), &truth);
            let clean = distance(&s, &raw(&s, &landmarks(&s, &truth, None)), &truth);
            assert!(
                calibrated < 0.6 * conventional,
                "{e} {h}: {calibrated} {conventional}"
            );
            assert!(
                calibrated < 1.5 * clean + 0.05,
                "{e} {h}: {calibrated} {clean}"
            );
        }
    }
}

#[test]
fn a_calibration_over_a_moving_face_deviates_and_names_its_frames() {
    let s = scene();
    let mut still = Session::new(&s, Settings::defaults(6));
    let frames = calibration(&s, None);
    for f in &frames {
        still.step(Some(f));
    }
    let mut moving = Session::new(&s, Settings::defaults(6));
    let expression = &expressions(&s)[1];
    let mut frames = frames.clone();
    frames[4] = landmarks(
        &s,
        &pose_with(&s, 0.0, 0.0, [1.0, -0.5, 3.0], Some(expression)),
        None,
    );
    for f in &frames {
        moving.step(Some(f));
    }
    let (a, b) = (
        still.live.calibration_deviation(&still.state).unwrap(),
        moving.live.calibration_deviation(&moving.state).unwrap(),
    );
    assert!(b > 3.0 * a, "{a} {b}");
    let per_frame: Vec<f32> = frames
        .iter()
        .map(|f| {
            moving
                .live
                .deviation(&moving.state, f, &mut moving.scratch)
                .unwrap()
                .unwrap()
        })
        .collect();
    let worst = per_frame
        .iter()
        .enumerate()
        .max_by(|x, y| x.1.total_cmp(y.1))
        .unwrap()
        .0;
    assert_eq!(worst, 4, "{per_frame:?}");
    assert!(per_frame[4] > 3.0 * per_frame[0], "{per_frame:?}");
    // Before the calibration completes there is nothing to deviate from.
    let fresh = Session::new(&s, Settings::defaults(6));
    let mut scratch = fresh.scratch.clone();
    assert_eq!(
        fresh.live.deviation(&fresh.state, &frames[0], &mut scratch),
        Ok(None)
    );
    assert_eq!(fresh.live.calibration_deviation(&fresh.state), None);
}

#[test]
fn lost_and_missing_frames_hold_the_last_pose_until_the_face_is_back() {
    let s = scene();
    let mut live = Session::new(&s, Settings::defaults(0));
    let expression = &expressions(&s)[0];
    let at = |x: f32| {
        landmarks(
            &s,
            &pose_with(&s, 0.0, 0.0, [x, 0.0, 0.0], Some(expression)),
            None,
        )
    };
    // Before any frame is accepted, a missing one is written at rest.
    assert_eq!(live.step(None), Outcome::Missing);
    let mut rest = vec![0.0; s.driver.output_len()];
    rest_pose(&mut rest);
    assert_eq!(live.pose, rest);
    assert_eq!(live.step(Some(&at(0.0))), Outcome::Driven);
    assert_eq!(live.step(Some(&at(0.05))), Outcome::Driven);
    let held = live.pose.clone();
    assert_eq!(live.step(None), Outcome::Missing);
    assert_eq!(live.pose, held);
    // Landmarks that no face makes: the tracker locked on something else.
    let mut scrambled = at(0.05);
    scrambled.reverse();
    assert_eq!(live.step(Some(&scrambled)), Outcome::Lost(Lost::Residual));
    assert_eq!(live.pose, held);
    // The face read as smaller, as if 8 cm further (the head pushed away): a jump no head
    // makes in a frame, for the eight frames it lasts.
    let smaller: Vec<f32> = {
        let f = at(0.05);
        let (mut cx, mut cy) = (0.0, 0.0);
        for l in 0..LANDMARKS {
            cx += f[2 * l] / LANDMARKS as f32;
            cy += f[2 * l + 1] / LANDMARKS as f32;
        }
        (0..2 * LANDMARKS)
            .map(|i| {
                let c = if i % 2 == 0 { cx } else { cy };
                c + 0.88 * (f[i] - c)
            })
            .collect()
    };
    for k in 0..8 {
        assert_eq!(live.step(Some(&smaller)), Outcome::Lost(Lost::Jump), "{k}");
        assert_eq!(live.pose, held);
    }
    // Back: accepted at once.
    assert_eq!(live.step(Some(&at(0.05))), Outcome::Driven);
    // A head that really moved while the tracker hesitated is taken after `reacquire` seconds.
    let far = at(6.0);
    let mut outcomes = Vec::new();
    for _ in 0..20 {
        outcomes.push(live.step(Some(&far)));
    }
    let first = outcomes.iter().position(|o| *o == Outcome::Driven).unwrap();
    assert!(
        outcomes[..first]
            .iter()
            .all(|o| *o == Outcome::Lost(Lost::Jump))
    );
    // 1/32 s a frame: the first frame at least 0.5 s after the run's first.
    assert_eq!(first, 16, "{outcomes:?}");
    // Every rule off: everything found is driven.
    let mut off = Session::new(&s, Settings::OFF);
    for f in [at(0.0), scrambled.clone(), smaller.clone(), at(6.0)] {
        assert_eq!(off.step(Some(&f)), Outcome::Driven);
    }
}

#[test]
fn the_same_frames_give_the_same_bits() {
    let s = scene();
    let offsets = convention();
    let run = || {
        let mut live = Session::new(&s, Settings::defaults(3));
        let mut bits = Vec::new();
        let frames = calibration(&s, Some(&offsets));
        for e in expressions(&s) {
            for f in frames
                .iter()
                .take(3)
                .chain([&landmarks(&s, &e, Some(&offsets))])
            {
                let o = live.step(Some(f));
                bits.push(o.code());
                bits.extend(live.pose.iter().map(|v| v.to_bits()));
            }
        }
        bits.extend(live.state.iter().map(|v| v.to_bits()));
        bits
    };
    assert_eq!(run(), run());
}

#[test]
fn bad_settings_buffers_and_time_stamps_are_refused_and_change_nothing() {
    let s = scene();
    let live_error = |i, kind| EvalError::Input(InputError::new(Argument::Live, i, kind));
    for (settings, i, kind) in [
        (
            Settings {
                calibrate_frames: 1001,
                ..Settings::OFF
            },
            0,
            InputErrorKind::OutOfRange,
        ),
        (
            Settings {
                max_residual: f32::NAN,
                ..Settings::OFF
            },
            1,
            InputErrorKind::NonFinite,
        ),
        (
            Settings {
                max_speed: -1.0,
                ..Settings::OFF
            },
            2,
            InputErrorKind::OutOfRange,
        ),
        (
            Settings {
                reacquire: 1e4,
                ..Settings::OFF
            },
            4,
            InputErrorKind::OutOfRange,
        ),
    ] {
        assert_eq!(
            Live::new(&s.driver, &s.actor, settings).err(),
            Some(live_error(i, kind))
        );
    }
    let mut live = Session::new(&s, Settings::defaults(2));
    let frame = &calibration(&s, None)[0];
    live.step(Some(frame));
    let (state, pose) = (live.state.clone(), live.pose.clone());
    let time = |kind| EvalError::Input(InputError::new(Argument::Time, 0, kind));
    let mut nan = frame.clone();
    nan[17] = f32::NAN;
    let landmark = EvalError::Input(InputError::new(
        Argument::Landmarks,
        17,
        InputErrorKind::NonFinite,
    ));
    let t = live.time;
    let l = &live.live;
    let (st, sc, po) = (&mut live.state, &mut live.scratch, &mut live.pose);
    assert_eq!(
        l.step(st, Some(frame), t, sc, po),
        Err(time(InputErrorKind::Degenerate))
    );
    assert_eq!(
        l.step(st, None, f32::INFINITY, sc, po),
        Err(time(InputErrorKind::NonFinite))
    );
    assert_eq!(l.step(st, Some(&nan), t + 1.0, sc, po), Err(landmark));
    assert_eq!(
        l.step(st, Some(&frame[1..]), t + 1.0, sc, po),
        Err(BufferError::Input.into())
    );
    assert_eq!(
        l.step(&mut st[1..], None, t + 1.0, sc, po),
        Err(BufferError::Scratch.into())
    );
    assert_eq!(
        l.step(st, None, t + 1.0, &mut sc[1..], po),
        Err(BufferError::Scratch.into())
    );
    assert_eq!(
        l.step(st, None, t + 1.0, sc, &mut po[1..]),
        Err(BufferError::Output.into())
    );
    assert_eq!((&live.state, &live.pose), (&state, &pose));
}
