// Browser end-to-end test of `sinew view` (docs/VIEW.md): starts the viewer on the ICT actor, its
// golden f32 replay, a pose file made here, the golden fitted performance and the golden landmark
// driver with its OpenFace track, loads the page in Debian's headless chromium (WebGL2 on
// SwiftShader, no GPU needed) through playwright-core, plays all four and requires every frame's
// hash computed in the page to equal tests/data/aim-ict.hashes (f32), the host's hashes of the
// pose file, tests/data/fit-ict.hashes and the frames of tests/data/driver-ict.hashes; then the golden S2D decoder with its replay as landmark track,
// every decoded frame's hash equal to tests/data/s2d-ict.hashes and the landmarks drawn; moves the sliders and the camera, checks a screenshot is not blank, checks the
// server's refusals, then stops the server with Ctrl-C (SIGINT).
//
// Usage: node host/tests/view/e2e.mjs [--screenshot PATH]
//   (after `cargo build -p sinew-host` and `npm ci` in this folder)
// Environment: SINEW_BIN (default $CARGO_TARGET_DIR/debug/sinew, the target folder being
// target/ unless CARGO_TARGET_DIR says otherwise), CHROMIUM (default /usr/bin/chromium).
// Prints the per-frame time (pose + normals through WebAssembly) for docs/BENCHMARKS.md.

import { execFileSync, spawn } from "node:child_process";
import { existsSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { request } from "node:http";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";
import { PNG } from "pngjs";

const root = resolve(dirname(fileURLToPath(import.meta.url)), "../../..");
const data = join(root, "tests/data");
const bin =
  process.env.SINEW_BIN ??
  join(process.env.CARGO_TARGET_DIR ?? join(root, "target"), "debug/sinew");
const browserPath = process.env.CHROMIUM ?? "/usr/bin/chromium";
const work = mkdtempSync(join(tmpdir(), "sinew-view-"));
const screenshotArg = process.argv.indexOf("--screenshot");
const screenshotPath = screenshotArg > 0 ? resolve(process.argv[screenshotArg + 1]) : join(work, "view.png");
/** The page's background (style.css, viewer.js clear colour). */
const BACKGROUND = [0x1d, 0x20, 0x26];
/** Frames of pose + normals timed before the figures are printed. */
const TIMED_FRAMES = 120;

let passed = 0;
function check(condition, what) {
  if (!condition) throw new Error(`failed: ${what}`);
  passed++;
  console.log(`ok ${passed} - ${what}`);
}

for (const [path, hint] of [
  [bin, "build it with `cargo build -p sinew-host` or set SINEW_BIN"],
  [browserPath, "install Debian's `chromium` or set CHROMIUM"],
]) {
  if (!existsSync(path)) {
    console.error(`e2e: ${path} is missing: ${hint}`);
    process.exit(1);
  }
}

// Nothing here may hang a CI run: the whole test ends within two minutes either way.
const guard = setTimeout(() => {
  console.error("e2e: timed out after 120 s");
  server?.kill("SIGKILL");
  s2dServer?.kill("SIGKILL");
  process.exit(1);
}, 120_000);

let server = null;
let s2dServer = null;
let browser = null;
try {
  // A pose file of three frames (neutral, jaw open 10°, head turned 15° with correctives), and
  // its frame hashes as the host computes them (`sinew replay record`, then `verify`).
  const rad = Math.PI / 180;
  const poses = join(work, "poses.json");
  writeFileSync(
    poses,
    JSON.stringify({
      frames: [
        { weights: Array(19).fill(0) },
        { jaw: [1, 0, 0, 0, Math.cos(10 * rad), Math.sin(10 * rad), 0, 0, 0], weights: Array(19).fill(0) },
        {
          head: [Math.cos(15 * rad), 0, -Math.sin(15 * rad), 0, 1, 0, 0, 0, 0],
          weights: Array.from({ length: 19 }, (_, i) => (i % 4) / 4),
        },
      ],
    }),
  );
  const recorded = join(work, "poses.replay.sinew");
  const model = join(data, "aim-ict.sinew");
  execFileSync(bin, ["replay", "record", "--model", model, "--poses", poses, "--out", recorded, "--mode", "f32"]);
  const hostHashes = execFileSync(bin, ["replay", "verify", "--model", model, "--replay", recorded], { encoding: "utf8" })
    .split("\n")
    .map((l) => /^frame (\d+) ([0-9a-f]{16}) ok$/.exec(l))
    .filter(Boolean)
    .map((m) => m[2]);
  check(hostHashes.length === 3, "the host hashes the pose file's 3 frames");

  // The golden driver's track and camera, and the frames it drives (tests/data/driver-ict.hashes).
  const driverList = readFileSync(join(data, "driver-ict.hashes"), "utf8").split("\n");
  const driverCamera = driverList.find((l) => l.startsWith("track ")).split(" ").slice(2);
  const driverHashes = driverList
    .map((l) => /^frame (\d+) ([0-9a-f]{16})$/.exec(l))
    .filter(Boolean)
    .map((m) => m[2]);
  check(driverCamera.length === 4 && driverHashes.length > 0, `the golden driver's list names its camera and ${driverHashes.length} frames`);

  server = spawn(
    bin,
    [
      "view",
      join(data, "aim-ict.sinew"),
      "--replay",
      join(data, "aim-ict.f32.replay.sinew"),
      "--poses",
      poses,
      "--performance",
      join(data, "fit-ict.sinew"),
      "--driver",
      join(data, "driver-ict.sinew"),
      "--landmarks",
      join(data, "driver-ict.csv"),
      "--intrinsics",
      driverCamera.join(","),
      "--port",
      "0",
      // A safety net only: the test stops it with SIGINT below.
      "--exit-after-seconds",
      "150",
    ],
    { stdio: ["ignore", "pipe", "inherit"] },
  );
  const url = await firstLine(server);
  check(/^http:\/\/127\.0\.0\.1:\d+\/$/.test(url), `the server prints its address first (${url})`);
  const port = Number(new URL(url).port);

  // The server's refusals, with paths sent exactly as written.
  check((await raw(port, "/../Cargo.toml")) === 404, "/../Cargo.toml is 404");
  check((await raw(port, "/%2e%2e/")) === 404, "/%2e%2e/ is 404");
  check((await raw(port, "/%2e%2e/%2e%2e/etc/passwd")) === 404, "/%2e%2e/%2e%2e/etc/passwd is 404");
  check((await raw(port, "/", "evil.example")) === 421, "a foreign Host header is refused (421)");
  check((await raw(port, "/model.sinew")) === 200, "/model.sinew is served");

  browser = await chromium.launch({
    executablePath: browserPath,
    headless: true,
    args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist"],
  });
  const page = await browser.newPage({ viewport: { width: 1200, height: 800 } });
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await page.goto(url);
  await page.waitForFunction(() => window.sinewTest !== undefined, null, { timeout: 30_000 });
  const ready = await page.evaluate(() => window.sinewTest);
  check(ready.ready === true, `the page loaded the actor (${ready.error ?? `${ready.vertexCount} vertices`})`);
  check(ready.vertexCount === 4705 && ready.shapeCount === 19, "4,705 vertices and 19 correctives");

  // Play the replay through the page's own play button until every frame has been shown.
  const expected = readFileSync(join(data, "aim-ict.hashes"), "utf8")
    .split("\n")
    .filter((l) => l.startsWith("f32 "))
    .map((l) => l.split(" ")[2]);
  check(expected.length === 16, "16 f32 frames in tests/data/aim-ict.hashes");
  await page.click("#play");
  await page.waitForFunction(() => window.sinewTest.playedHashes(0).every((h) => h !== null), null, {
    timeout: 30_000,
  });
  const played = await page.evaluate(() => window.sinewTest.playedHashes(0));
  check(JSON.stringify(played) === JSON.stringify(expected), "every played frame's hash equals aim-ict.hashes (f32)");
  const recomputed = await page.evaluate(() => window.sinewTest.frameHashes(0));
  check(JSON.stringify(recomputed) === JSON.stringify(expected), "frameHashes() equals aim-ict.hashes (f32)");
  await page.waitForFunction((n) => window.sinewTest.frameTimes().length >= n, TIMED_FRAMES, { timeout: 30_000 });
  await page.click("#play");
  check(!(await page.evaluate(() => window.sinewTest.playing())), "Pause stops playback");
  const status = await page.textContent("#check");
  check(/16\/16 frames match the recording/.test(status), `the page reports the match (${status})`);

  // The pose file, chosen in the source menu and played: the host's hashes, frame for frame.
  check(ready.sources.length === 4 && ready.sources[1].count === 3, "the pose file is the second source");
  await page.selectOption("#source", "1");
  await page.click("#play");
  await page.waitForFunction(() => window.sinewTest.playedHashes(1).every((h) => h !== null), null, {
    timeout: 30_000,
  });
  await page.click("#play");
  const posesPlayed = await page.evaluate(() => window.sinewTest.playedHashes(1));
  check(JSON.stringify(posesPlayed) === JSON.stringify(hostHashes), "the pose file's frames hash as on the host");

  // The fitted performance, the third source, played through the core's Performance::pose: the
  // hashes of tests/data/fit-ict.hashes, and the page says they match the ones baked in the file.
  const fitHashes = readFileSync(join(data, "fit-ict.hashes"), "utf8")
    .split("\n")
    .filter((l) => /^\d+ [0-9a-f]{16}$/.test(l))
    .map((l) => l.split(" ")[1]);
  check(ready.sources[2].count === fitHashes.length && fitHashes.length > 0, `the performance is the third source (${fitHashes.length} frames)`);
  await page.selectOption("#source", "2");
  await page.click("#play");
  await page.waitForFunction(() => window.sinewTest.playedHashes(2).every((h) => h !== null), null, {
    timeout: 30_000,
  });
  await page.click("#play");
  const fitPlayed = await page.evaluate(() => window.sinewTest.playedHashes(2));
  check(JSON.stringify(fitPlayed) === JSON.stringify(fitHashes), "every performance frame's hash equals fit-ict.hashes");
  const fitStatus = await page.textContent("#check");
  check(
    new RegExp(`${fitHashes.length}/${fitHashes.length} frames match the recording`).test(fitStatus),
    `the page reports the performance's match with its baked hashes (${fitStatus})`,
  );

  // The golden driver on its track, the fourth source: landmarks through the driver in the core
  // compiled to WebAssembly, every frame's hash as tests/data/driver-ict.hashes records it.
  check(ready.sources[3].count === driverHashes.length, `the driver is the fourth source (${ready.sources[3].count} frames)`);
  await page.selectOption("#source", "3");
  await page.click("#play");
  await page.waitForFunction(() => window.sinewTest.playedHashes(3).every((h) => h !== null), null, {
    timeout: 30_000,
  });
  await page.click("#play");
  const drivenPlayed = await page.evaluate(() => window.sinewTest.playedHashes(3));
  check(JSON.stringify(drivenPlayed) === JSON.stringify(driverHashes), "every driven frame's hash equals driver-ict.hashes");
  await page.selectOption("#source", "0");

  // The sliders move the geometry, and moving back restores it bit for bit.
  const setSlider = (id, value) =>
    page.evaluate(
      ([id, value]) => {
        const input = document.getElementById(id);
        input.value = String(value);
        input.dispatchEvent(new Event("input"));
        return window.sinewTest.positionsChecksum();
      },
      [id, value],
    );
  await page.click("#reset");
  const neutral = await page.evaluate(() => window.sinewTest.positionsChecksum());
  const names = await page.evaluate(() =>
    [0, 18].map((i) => document.getElementById(`shape-${i}`).parentElement.firstChild.textContent),
  );
  check(
    names[0] === "jawOpen" && names[1] === "noseSneer_R",
    `the sliders carry the actor's shape names (${names.join(", ")})`,
  );
  const smiled = await setSlider("shape-0", 1);
  check(smiled !== neutral, "corrective 1 at 1 changes the positions");
  check((await setSlider("shape-0", 0)) === neutral, "corrective 1 back at 0 restores them exactly");
  check((await setSlider("jaw", 12)) !== neutral, "the jaw slider changes the positions");
  check((await setSlider("head-yaw", 20)) !== neutral, "the head yaw slider changes the positions");
  await setSlider("head-yaw", 0);

  // Orbit (drag) and zoom (wheel) move the camera, not the face.
  const nextPaint = () => page.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  await setSlider("frame", 9);
  await nextPaint();
  const canvas = page.locator("#face");
  const head = await page.evaluate(() => window.sinewTest.positionsChecksum());
  const front = await canvas.screenshot();
  const box = await canvas.boundingBox();
  const [cx, cy] = [box.x + box.width / 2, box.y + box.height / 2];
  await page.mouse.move(cx, cy);
  await page.mouse.down();
  await page.mouse.move(cx - 50, cy - 15, { steps: 5 });
  await page.mouse.up();
  await page.mouse.wheel(0, -100);
  await nextPaint();
  const turned = await canvas.screenshot();
  check(!front.equals(turned), "dragging and the wheel change the view");
  check((await page.evaluate(() => window.sinewTest.positionsChecksum())) === head, "…and not the positions");

  // A screenshot of a posed frame; the face must cover a fair share of the canvas.
  const canvasPng = PNG.sync.read(turned);
  let face = 0;
  for (let i = 0; i < canvasPng.data.length; i += 4) {
    const d = [0, 1, 2].some((k) => Math.abs(canvasPng.data[i + k] - BACKGROUND[k]) > 8);
    if (d) face++;
  }
  const share = face / (canvasPng.width * canvasPng.height);
  check(share >= 0.1, `the face covers ${(100 * share).toFixed(1)} % of the canvas (at least 10 %)`);

  // The thickness heatmap: the toggle recolours the face from the skin to the heat-map scale
  // (blue where the tissue is thin), shows its range in mm, and back again restores the skin.
  await page.check("#thickness");
  await nextPaint();
  const heat = await canvas.screenshot();
  check(!heat.equals(turned), "the thickness toggle recolours the face");
  const heatPng = PNG.sync.read(heat);
  let blue = 0;
  for (let i = 0; i < heatPng.data.length; i += 4) {
    const [r, g, b] = [heatPng.data[i], heatPng.data[i + 1], heatPng.data[i + 2]];
    if (b > r + 40 && b > 60) blue++;
  }
  check(blue / (heatPng.width * heatPng.height) > 0.02, `the heatmap is blue where thin (${blue} pixels)`);
  const range = await page.locator("#thickness-range").textContent();
  check(
    (await page.locator("#thickness-scale").isVisible()) && /^0 – \d+\.\d mm$/.test(range),
    `the heatmap's range is shown in mm (${range})`,
  );
  await page.uncheck("#thickness");
  await nextPaint();
  check((await canvas.screenshot()).equals(turned), "turning it off restores the skin");
  writeFileSync(screenshotPath, await page.screenshot());
  console.log(`e2e: screenshot ${screenshotPath}`);
  check(errors.length === 0, `no errors in the page${errors.length ? `: ${errors.join("; ")}` : ""}`);

  // An S2D decoder and its landmark track (the golden S2D replay), on a second server: every
  // decoded frame's hash equals tests/data/s2d-ict.hashes, and the landmarks drawn give the
  // frame's decoder input back.
  s2dServer = spawn(
    bin,
    ["view", join(data, "s2d-ict.sinew"), "--track", join(data, "s2d-ict.replay.sinew"), "--port", "0", "--exit-after-seconds", "150"],
    { stdio: ["ignore", "pipe", "inherit"] },
  );
  const s2dUrl = await firstLine(s2dServer);
  const s2dPage = await browser.newPage({ viewport: { width: 1200, height: 800 } });
  s2dPage.on("pageerror", (e) => errors.push(e.message));
  s2dPage.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await s2dPage.goto(s2dUrl);
  await s2dPage.waitForFunction(() => window.sinewTest !== undefined, null, { timeout: 30_000 });
  const s2dReady = await s2dPage.evaluate(() => window.sinewTest);
  check(
    s2dReady.ready === true && s2dReady.kind === "s2d" && s2dReady.vertexCount === 1177 && s2dReady.landmarkCount === 68,
    `the page loaded the S2D decoder (${s2dReady.error ?? `${s2dReady.vertexCount} vertices, ${s2dReady.landmarkCount} landmarks`})`,
  );
  const s2dExpected = readFileSync(join(data, "s2d-ict.hashes"), "utf8")
    .split("\n")
    .filter((l) => l.startsWith("s2d "))
    .map((l) => l.split(" ")[2]);
  check(s2dExpected.length === 16 && s2dReady.sources[0].count === 16, "16 frames in the track and in s2d-ict.hashes");
  await s2dPage.click("#play");
  await s2dPage.waitForFunction(() => window.sinewTest.playedHashes(0).every((h) => h !== null), null, {
    timeout: 30_000,
  });
  await s2dPage.click("#play");
  const s2dPlayed = await s2dPage.evaluate(() => window.sinewTest.playedHashes(0));
  check(JSON.stringify(s2dPlayed) === JSON.stringify(s2dExpected), "every decoded frame's hash equals s2d-ict.hashes");
  const s2dRecomputed = await s2dPage.evaluate(() => window.sinewTest.frameHashes(0));
  check(JSON.stringify(s2dRecomputed) === JSON.stringify(s2dExpected), "frameHashes() equals s2d-ict.hashes");
  const s2dStatus = await s2dPage.textContent("#check");
  check(/16\/16 frames match the recording/.test(s2dStatus), `the page reports the track's match (${s2dStatus})`);
  // The track was measured on one identity and decodes onto another's neutral (a transfer), and
  // the decoder normalises each set to unit size: the points give its input back up to that
  // renormalisation, 2.1 % of the frame's largest input value at worst on this track (docs/VIEW.md).
  const trips = await s2dPage.evaluate(() => Array.from({ length: 16 }, (_, f) => window.sinewTest.landmarkRoundTrip(f)));
  check(trips[0].largest === 0 && trips[0].difference === 0, "frame 0 (no motion): the landmarks drawn are the neutral's");
  const worst = Math.max(...trips.map((t) => (t.largest > 0 ? t.difference / t.largest : 0)));
  check(worst < 0.03, `the landmarks drawn give each frame's decoder input back within 3 % (worst ${(100 * worst).toFixed(2)} %)`);
  check((await s2dPage.evaluate(() => window.sinewTest.landmarks().length)) === 3 * 68, "68 landmarks drawn");
  // The last frame shown: the face as points with the landmarks (green) over it.
  await s2dPage.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
  const s2dPng = PNG.sync.read(await s2dPage.locator("#face").screenshot());
  let [cloud, green] = [0, 0];
  for (let i = 0; i < s2dPng.data.length; i += 4) {
    const [r, g, b] = [s2dPng.data[i], s2dPng.data[i + 1], s2dPng.data[i + 2]];
    if ([r, g, b].some((c, k) => Math.abs(c - BACKGROUND[k]) > 8)) cloud++;
    if (g > 150 && g > r + 60 && g > b + 60) green++;
  }
  const pixels = s2dPng.width * s2dPng.height;
  check(cloud / pixels > 0.01 && green > 68 * 10, `the decoded face and its landmarks are drawn (${cloud} and ${green} pixels)`);
  check(errors.length === 0, `no errors in the S2D page${errors.length ? `: ${errors.join("; ")}` : ""}`);
  await s2dPage.close();
  const s2dExited = new Promise((r) => s2dServer.once("exit", (code) => r(code)));
  s2dServer.kill("SIGINT");
  check((await Promise.race([s2dExited, sleep(5000).then(() => "still running")])) === 0, "SIGINT stops the S2D server");
  s2dServer = null;

  const times = (await page.evaluate(() => window.sinewTest.frameTimes())).slice(1); // skip the first, cold
  times.sort((a, b) => a - b);
  const median = times[Math.floor(times.length / 2)];
  const mean = times.reduce((a, b) => a + b, 0) / times.length;
  console.log(
    `e2e: aim-ict pose + normals in ${browser.version()} (headless, WebAssembly): median ${median.toFixed(3)} ms, ` +
      `mean ${mean.toFixed(3)} ms, min ${times[0].toFixed(3)} ms, max ${times[times.length - 1].toFixed(3)} ms ` +
      `over ${times.length} frames`,
  );
  await browser.close();
  browser = null;

  // Ctrl-C stops the server cleanly.
  const exited = new Promise((r) => server.once("exit", (code, signal) => r({ code, signal })));
  server.kill("SIGINT");
  const { code, signal } = await Promise.race([exited, sleep(5000).then(() => ({ code: "still running" }))]);
  check(code === 0, `SIGINT stops the server with status 0 (${code ?? signal})`);
  server = null;
  console.log(`e2e: ${passed} passed, 0 failed`);
} catch (e) {
  console.error(`e2e: ${e.message}`);
  console.log(`e2e: ${passed} passed, 1 failed`);
  process.exitCode = 1;
} finally {
  await browser?.close().catch(() => {});
  server?.kill("SIGKILL");
  s2dServer?.kill("SIGKILL");
  clearTimeout(guard);
  for (const file of ["poses.json", "poses.replay.sinew"]) rmSync(join(work, file), { force: true });
}

function sleep(ms) {
  return new Promise((r) => setTimeout(r, ms));
}

/** The first line the server prints on stdout (its address). */
function firstLine(child) {
  return new Promise((resolveLine, reject) => {
    let text = "";
    child.stdout.setEncoding("utf8");
    child.stdout.on("data", (chunk) => {
      text += chunk;
      const end = text.indexOf("\n");
      if (end >= 0) resolveLine(text.slice(0, end).trim());
    });
    child.once("exit", (code) => reject(new Error(`sinew view exited (${code}) before printing its address`)));
    child.once("error", reject);
  });
}

/** The status of a GET of `path` sent as written (no normalisation), with a Host header. */
function raw(port, path, host = `127.0.0.1:${port}`) {
  return new Promise((resolveStatus, reject) => {
    const req = request({ host: "127.0.0.1", port, path, headers: { Host: host } }, (res) => {
      res.resume();
      resolveStatus(res.statusCode);
    });
    req.once("error", reject);
    req.end();
  });
}
