// Browser test of `sinew view --webcam` (docs/VIEW.md, "A webcam"): a synthetic performance of
// the golden ICT actor (`sinew data performance`, a second at rest, then expressions and head
// motion), rendered by `sinew render --stamp` as a y4m video, is the camera of Debian's headless
// chromium (its fake capture device); the page runs the real MediaPipe Face Mesh (npm
// @mediapipe/face_mesh, served by `sinew view` from node_modules) on every frame, calibrates on
// the first second, drives the actor through tests/data/driver-ict-mediapipe.sinew in the core
// compiled to WebAssembly, and this test compares every driven face with the performance's truth
// at the frame the page read from the frame's code. Prints the frame rate, the tracker's and
// Sinew's time and the latency for docs/BENCHMARKS.md.
//
// Usage: node host/tests/view/webcam.mjs
//   (after `cargo build -p sinew-host` and `npm ci` in this folder; needs ICT-FaceKit)
// Environment: SINEW_BIN, CHROMIUM as for e2e.mjs; SINEW_DATA (default ../shared/data);
// SINEW_REQUIRE_DATA=1 fails instead of skipping without the data.

import { execFileSync, spawn } from "node:child_process";
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";

const here = dirname(fileURLToPath(import.meta.url));
const root = resolve(here, "../../..");
const data = join(root, "tests/data");
const bin =
  process.env.SINEW_BIN ??
  join(process.env.CARGO_TARGET_DIR ?? join(root, "target"), "debug/sinew");
const browserPath = process.env.CHROMIUM ?? "/usr/bin/chromium";
const kit = join(process.env.SINEW_DATA ?? resolve(root, "../shared/data"), "ict-facekit");
const tracker = join(here, "node_modules/@mediapipe/face_mesh");

/** The performance: frames at rest (2 s of video), then 2 s of expressions and head motion. */
const FRAMES = 40;
const REST_FRAMES = 20;
/** The video's rate: slower than real time, as a 2-core machine tracks about 7 frames a second. */
const VIDEO_FPS = 10;
/** Seconds of camera the test watches: two passes of the looping video. */
const WATCH_SECONDS = 9;
/**
 * Bounds on the driven faces against the truth, mean per-vertex distance in mm (measured
 * 2026-12-02: docs/VIEW.md, "A webcam"): over every driven frame, and the worst frame.
 */
const MEAN_BOUND_MM = 12;
const WORST_BOUND_MM = 22;

let passed = 0;
function check(condition, what) {
  if (!condition) throw new Error(`failed: ${what}`);
  passed++;
  console.log(`ok ${passed} - ${what}`);
}

if (!existsSync(kit)) {
  if (process.env.SINEW_REQUIRE_DATA === "1") {
    console.error(`webcam: no ICT-FaceKit at ${kit} (SINEW_REQUIRE_DATA=1)`);
    process.exit(1);
  }
  console.log(`webcam: skipped, no ICT-FaceKit at ${kit}`);
  process.exit(0);
}
for (const [path, hint] of [
  [bin, "build it with `cargo build -p sinew-host` or set SINEW_BIN"],
  [browserPath, "install Debian's `chromium` or set CHROMIUM"],
  [tracker, "run `npm ci` in host/tests/view"],
]) {
  if (!existsSync(path)) {
    console.error(`webcam: ${path} is missing: ${hint}`);
    process.exit(1);
  }
}

const work = mkdtempSync(join(tmpdir(), "sinew-webcam-"));
let server = null;
let browser = null;
const guard = setTimeout(() => {
  console.error("webcam: timed out after 150 s");
  server?.kill("SIGKILL");
  process.exit(1);
}, 150_000);

/** The `v` lines of an OBJ, x y z each. */
function objPositions(path) {
  const out = [];
  for (const line of readFileSync(path, "utf8").split("\n")) {
    if (line.startsWith("v ")) out.push(...line.split(/\s+/).slice(1, 4).map(Number));
  }
  return out;
}

/** Mean distance between two x y z lists, in their units. */
function meanDistance(a, b) {
  let sum = 0;
  for (let i = 0; i < a.length; i += 3) sum += Math.hypot(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2]);
  return sum / (a.length / 3);
}

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const mean = (xs) => xs.reduce((a, b) => a + b, 0) / xs.length;

try {
  const actor = join(data, "aim-ict.sinew");
  const perf = join(work, "perf");
  const video = join(work, "video");
  execFileSync(bin, ["data", "performance", "--data", kit, "--actor", actor, "--frames", String(FRAMES),
    "--rest-frames", String(REST_FRAMES), "--out", perf], { stdio: "ignore" });
  execFileSync(bin, ["render", perf, "--out", video, "--fps", String(VIDEO_FPS), "--stamp", "--no-png"], {
    stdio: "ignore",
  });
  const manifest = JSON.parse(readFileSync(join(perf, "performance.json"), "utf8"));
  const mm = { mm: 1, cm: 10, m: 1000 }[manifest.units];
  const truth = Array.from({ length: FRAMES }, (_, f) =>
    objPositions(join(perf, `frame_${String(f).padStart(5, "0")}.obj`)),
  );
  check(truth.every((t) => t.length === 3 * 4705) && mm, `the performance's ${FRAMES} frames in ${manifest.units}`);

  // The camera's intrinsics are the performance's (a webcam's default would be another lens).
  const { fx, fy, cx, cy } = manifest.camera;
  server = spawn(bin, ["view", actor, "--driver", join(data, "driver-ict-mediapipe.sinew"), "--webcam",
    "--tracker-dir", tracker, "--intrinsics", [fx, fy, cx, cy].join(","), "--port", "0",
    "--exit-after-seconds", "140"], { stdio: ["ignore", "pipe", "inherit"] });
  const url = await new Promise((resolveUrl, reject) => {
    let text = "";
    server.stdout.on("data", (d) => {
      text += d;
      if (text.includes("\n")) resolveUrl(text.split("\n")[0]);
    });
    server.on("exit", (code) => reject(new Error(`sinew view exited (${code}) before printing its address`)));
  });

  browser = await chromium.launch({
    executablePath: browserPath,
    headless: true,
    args: [
      "--no-sandbox",
      "--use-angle=swiftshader",
      "--enable-unsafe-swiftshader",
      "--ignore-gpu-blocklist",
      "--disable-background-networking",
      "--disable-component-update",
      "--use-fake-ui-for-media-stream",
      "--use-fake-device-for-media-stream",
      `--use-file-for-fake-video-capture=${join(video, "performance.y4m")}`,
    ],
  });
  const page = await browser.newPage({ viewport: { width: 1200, height: 800 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await page.goto(`${url}?stamp`);
  await page.waitForFunction(() => window.sinewTest?.webcam()?.started() || window.sinewTest?.webcam()?.error(), null, {
    timeout: 60_000,
  });
  const failed = await page.evaluate(() => window.sinewTest.webcam().error());
  check(!failed, `the webcam runs (${failed ?? "MediaPipe loaded, the camera opened"})`);
  const size = await page.evaluate(() => window.sinewTest.webcam().size);
  check(size[0] === manifest.camera.width && size[1] === manifest.camera.height, `the camera is the video (${size.join("×")})`);
  await page.waitForTimeout(WATCH_SECONDS * 1000);
  const frames = await page.evaluate(() => window.sinewTest.webcam().frames());
  check(!(await page.evaluate(() => window.sinewTest.webcam().error())), "the webcam ran throughout");

  // The calibration: the first second of found frames, all at rest.
  const calibrating = frames.filter((f) => f.outcome === "calibrating");
  check(
    calibrating.length >= 3 && calibrating.every((f) => f.stamp < REST_FRAMES),
    `calibrated on ${calibrating.length} frames, all of the rest (frames ${calibrating.map((f) => f.stamp).join(" ")})`,
  );
  const driven = frames.filter((f) => f.outcome === "driven" && f.stamp < FRAMES);
  const performing = driven.filter((f) => f.stamp >= REST_FRAMES + 5);
  check(driven.length >= 20 && performing.length >= 5, `${driven.length} frames driven, ${performing.length} of them performing`);
  const found = frames.filter((f) => f.found).length;
  check(found === frames.length, `MediaPipe found the face in ${found} of ${frames.length} frames`);

  // Every driven face against the truth of the frame it read, raw (the driver's own pose) and
  // as shown (One Euro filtered).
  const errorsMm = [];
  const shownMm = [];
  for (const f of driven) {
    const [raw, shown] = await page.evaluate((p) => [window.sinewTest.webcam().positions(p[0]), window.sinewTest.webcam().positions(p[1])], [f.raw, f.pose]);
    errorsMm.push(meanDistance(raw, truth[f.stamp]) * mm);
    shownMm.push(meanDistance(shown, truth[f.stamp]) * mm);
  }
  const worst = Math.max(...errorsMm);
  console.log(
    `# driven faces against the truth: mean ${mean(errorsMm).toFixed(2)} mm per vertex, worst frame ` +
      `${worst.toFixed(2)} mm, ${driven.length} frames; at rest ` +
      `${mean(errorsMm.filter((_, i) => driven[i].stamp < REST_FRAMES)).toFixed(2)} mm, performing ` +
      `${mean(errorsMm.filter((_, i) => driven[i].stamp >= REST_FRAMES)).toFixed(2)} mm; as shown (filtered) ` +
      `${mean(shownMm).toFixed(2)} mm`,
  );
  check(mean(errorsMm) <= MEAN_BOUND_MM, `the driven faces are ${mean(errorsMm).toFixed(2)} mm from the truth on average (bound ${MEAN_BOUND_MM} mm)`);
  check(worst <= WORST_BOUND_MM, `no driven face is more than ${WORST_BOUND_MM} mm from the truth (worst ${worst.toFixed(2)} mm)`);

  // The page drives as `sinew drive` does: its frames from the first face on, as a MediaPipe
  // track with the page's time stamps, driven by the host with the same calibration, give the
  // same faces, bit for bit.
  const first = frames.findIndex((f) => f.found);
  const seen = frames.slice(first);
  const track = join(work, "page.jsonl");
  writeFileSync(
    track,
    seen.map((f) => JSON.stringify({ timestamp: f.time, width: size[0], height: size[1], landmarks: f.landmarks ?? [] })).join("\n") + "\n",
  );
  const calibratedFrames = await page.evaluate(() => window.sinewTest.webcam().calibratedFrames());
  execFileSync(bin, ["drive", "--model", actor, "--driver", join(data, "driver-ict-mediapipe.sinew"), "--landmarks", track,
    "--intrinsics", [fx, fy, cx, cy].join(","), "--calibrate-frames", String(calibratedFrames), "--out", join(work, "drive")], { stdio: "ignore" });
  let same = 0;
  for (const [k, f] of seen.entries()) {
    const host = objPositions(join(work, "drive", `frame_${String(k).padStart(5, "0")}.obj`)).map(Math.fround);
    const shown = await page.evaluate((pose) => window.sinewTest.webcam().positions(pose), f.raw);
    if (host.length === shown.length && host.every((x, i) => x === shown[i])) same++;
  }
  check(same === seen.length, `sinew drive on the page's own landmarks gives the page's ${seen.length} faces bit for bit (${same} equal)`);

  // The figures for docs/BENCHMARKS.md.
  const timed = frames.slice(calibrating.length);
  const span = timed.at(-1).time - timed[0].time;
  console.log(
    `# webcam page, headless chromium: ${((timed.length - 1) / span).toFixed(1)} frames/s over ${timed.length} frames; ` +
      `per frame (median) tracker ${median(timed.map((f) => f.trackerMs)).toFixed(1)} ms, ` +
      `Sinew ${median(timed.map((f) => f.sinewMs)).toFixed(2)} ms (mean ${mean(timed.map((f) => f.sinewMs)).toFixed(2)}, ` +
      `max ${Math.max(...timed.map((f) => f.sinewMs)).toFixed(2)}), latency ${median(timed.map((f) => f.latencyMs)).toFixed(0)} ms`,
  );
  const shownText = await page.textContent("#webcam-time");
  check(/frames\/s · tracker [\d.]+ ms · Sinew [\d.]+ ms · latency \d+ ms/.test(shownText), `the page shows its times (${shownText})`);
  check(errors.length === 0, `no page errors${errors.length ? `: ${errors.join("; ")}` : ""}`);
  console.log(`webcam: all ${passed} checks passed`);
} finally {
  clearTimeout(guard);
  await browser?.close();
  server?.kill("SIGINT");
  rmSync(work, { recursive: true, force: true });
}
