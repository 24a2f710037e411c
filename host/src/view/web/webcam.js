// `sinew view --webcam` (docs/VIEW.md, "A webcam"): the browser's camera, MediaPipe Face Mesh
// run in the page (its web files served by `sinew view` from a local folder, as /mediapipe/…),
// and every frame driven, filtered and posed through sinew-core compiled to WebAssembly: the
// live calibration on the first second of found frames, the lost-frame rules, the One Euro
// filter, the pose and its normals. The frame rate, the tracker's and Sinew's time and the
// latency from camera frame to posed mesh are shown.
//
// For tests, the page's URL query `?stamp` reads each camera frame's number from the code that
// `sinew render --stamp` draws in its top-left corner, so a test feeding a rendered video as a
// fake camera knows which frame of the performance each pose is of.

import { Driver } from "./sinew.mjs";

const $ = (id) => document.getElementById(id);

/** The calibration takes the found frames of this first stretch of time, in seconds. */
const CALIBRATION_SECONDS = 1;
/** The One Euro filter on the driven poses: cutoff at rest (Hz) and speed coefficient. */
const FILTER = { minCutoff: 1, beta: 0.1 };
/** Frames kept for the figures (and the tests). */
const KEEP = 600;
/** Frames the shown means are over. */
const WINDOW = 30;
/** The frame-number code of `sinew render --stamp`: 16 cells of 8 px along the top edge. */
const STAMP = { bits: 16, cell: 8 };

/** Loads MediaPipe Face Mesh's script (a classic script that defines `window.FaceMesh`). */
function loadTracker() {
  return new Promise((resolve, reject) => {
    const script = document.createElement("script");
    script.src = "mediapipe/face_mesh.js";
    script.onload = () =>
      window.FaceMesh ? resolve(window.FaceMesh) : reject(new Error("mediapipe/face_mesh.js defines no FaceMesh"));
    script.onerror = () => reject(new Error("mediapipe/face_mesh.js could not be loaded"));
    document.head.append(script);
  });
}

/** The frame number `sinew render --stamp` drew into the picture on `context`'s canvas. */
function readStamp(context) {
  const { bits, cell } = STAMP;
  const row = context.getImageData(0, cell / 2, bits * cell, 1).data;
  let code = 0;
  for (let k = 0; k < bits; k++) {
    const i = 4 * (k * cell + cell / 2);
    const luma = 0.299 * row[i] + 0.587 * row[i + 1] + 0.114 * row[i + 2];
    if (luma > 127) code |= 1 << k;
  }
  return code;
}

const mean = (xs) => (xs.length ? xs.reduce((a, b) => a + b, 0) / xs.length : 0);

/**
 * Starts the webcam: `driver` a MediaPipe driver of `model`, `show(positions, normals,
 * coefficients)` draws a posed frame. Returns the test hooks.
 */
export async function startWebcam({ config, model, driver, show }) {
  const panel = $("webcam");
  panel.hidden = false;
  const say = (text) => ($("webcam-status").textContent = text);
  const stamped = new URLSearchParams(location.search).has("stamp");
  const points = config.webcam.points;
  const rest = Float32Array.from([1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, ...new Array(model.shapeCount).fill(0)]);
  const records = [];
  const state = { error: null, started: false };

  say(`loading ${config.webcam.tracker}…`);
  const FaceMesh = await loadTracker();
  const tracker = new FaceMesh({ locateFile: (file) => `mediapipe/${file}` });
  tracker.setOptions({
    maxNumFaces: 1,
    refineLandmarks: true,
    minDetectionConfidence: 0.5,
    minTrackingConfidence: 0.5,
  });
  let results = null;
  tracker.onResults((r) => (results = r));
  // The first frame loads the model and builds the graph (seconds): done on a blank picture
  // before the camera starts, so the calibration's second is spent on the face.
  const grab = document.createElement("canvas");
  grab.width = 640;
  grab.height = 480;
  const context = grab.getContext("2d", { willReadFrequently: true });
  context.fillStyle = "#3a3c42";
  context.fillRect(0, 0, grab.width, grab.height);
  await tracker.send({ image: grab });

  say("asking for the camera…");
  const video = $("camera");
  video.srcObject = await navigator.mediaDevices.getUserMedia({
    video: { width: { ideal: 640 }, height: { ideal: 480 } },
    audio: false,
  });
  await video.play();
  const [w, h] = [video.videoWidth, video.videoHeight];
  grab.width = w;
  grab.height = h;
  const [fx, fy, cx, cy] = config.webcam.intrinsics ?? [w, w, w / 2, h / 2];
  const camera = { fx, fy, cx, cy };

  let live = null;
  let calibration = [];
  const filter = driver.filter(FILTER);
  $("recalibrate").addEventListener("click", () => {
    live = null;
    calibration = [];
    filter.reset();
  });

  /** One camera frame: tracked, driven and posed. `arrived`: when it reached the page (ms). */
  async function frame(arrived) {
    context.drawImage(video, 0, 0, w, h);
    const stamp = stamped ? readStamp(context) : null;
    const t0 = performance.now();
    results = null;
    await tracker.send({ image: grab });
    const t1 = performance.now();
    const face = results?.multiFaceLandmarks?.[0];
    const time = arrived / 1000;

    const s0 = performance.now();
    let input = null;
    let landmarks = null;
    if (face) {
      landmarks = face.map((p) => [p.x, p.y, p.z]);
      const pixels = new Float32Array(2 * points.length);
      points.forEach((p, i) => {
        pixels[2 * i] = face[p].x * w;
        pixels[2 * i + 1] = face[p].y * h;
      });
      input = Driver.pixels(pixels, camera);
    }
    let step;
    if (!live) {
      // The first second of frames, from the first with a face, is the face at rest.
      if (input || calibration.length) calibration.push([input, time]);
      const found = calibration.filter(([x]) => x).length;
      step = { outcome: "calibrating", pose: rest };
      if (found && time - calibration[0][1] >= CALIBRATION_SECONDS) {
        live = driver.live(model, { calibrateFrames: found });
        for (const [x, t] of calibration) step = live.step(x, t);
      }
    } else {
      step = live.step(input, time);
    }
    const raw = step.pose;
    const pose = step.outcome === "calibrating" ? raw : filter.step(raw, time);
    const positions = driver.play(model, pose);
    const normals = model.normals(positions);
    const s1 = performance.now();
    show(positions, normals, pose.slice(18));
    const posed = performance.now();

    records.push({
      stamp,
      outcome: step.outcome,
      residual: step.residual,
      landmarks,
      found: Boolean(face),
      trackerMs: t1 - t0,
      sinewMs: s1 - s0,
      latencyMs: posed - arrived,
      time,
      raw: Array.from(raw),
      pose: Array.from(pose),
    });
    if (records.length > KEEP) records.shift();
    const recent = records.slice(-WINDOW);
    const span = recent.length > 1 ? recent.at(-1).time - recent[0].time : 0;
    const fps = span > 0 ? (recent.length - 1) / span : 0;
    const lost = records.filter((r) => r.outcome.startsWith("lost")).length;
    say(
      live?.calibrated
        ? `driving · calibrated on ${live.calibratedFrames} frames · ${lost} lost frames`
        : `calibrating: look at the camera with a neutral face (${calibration.length} frames)`,
    );
    $("webcam-time").textContent =
      `${fps.toFixed(1)} frames/s · tracker ${mean(recent.map((r) => r.trackerMs)).toFixed(1)} ms · ` +
      `Sinew ${mean(recent.map((r) => r.sinewMs)).toFixed(2)} ms · ` +
      `latency ${mean(recent.map((r) => r.latencyMs)).toFixed(0)} ms`;
  }

  // One frame at a time, always the newest: a frame that arrives while the tracker works on
  // the last is skipped.
  const next = () => {
    const run = (arrived) =>
      frame(arrived).then(next, (e) => {
        state.error = String(e);
        say(`stopped: ${e}`);
      });
    if (video.requestVideoFrameCallback) video.requestVideoFrameCallback((now) => run(now));
    else requestAnimationFrame((now) => run(now));
  };
  state.started = true;
  next();

  return {
    started: () => state.started,
    error: () => state.error,
    size: [w, h],
    /**
     * Every frame seen (the last KEEP): its code (`?stamp`), MediaPipe's points (null: no face),
     * the outcome and residual, the times, the driven pose and the one shown (filtered).
     */
    frames: () => records.slice(),
    /** The actor's positions for a pose, x y z each. */
    positions: (pose) => Array.from(driver.play(model, Float32Array.from(pose))),
    /** Found frames the calibration took, once it is complete (null before). */
    calibratedFrames: () => (live?.calibrated ? live.calibratedFrames : null),
  };
}
