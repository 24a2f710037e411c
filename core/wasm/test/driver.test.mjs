// The golden live driver through the JavaScript API: tests/data/driver-ict.sinew drives
// aim-ict.sinew in WebAssembly from the OpenFace track its hash list names
// (tests/data/driver-ict.csv, through the list's camera), and every frame's pose and posed frame
// must hash as tests/data/driver-ict.hashes lists them (the x86_64 host's sinew-core), without
// and with the One Euro filter at the track's time stamps. Then the refusals a page can meet.
//
// Usage: bash core/wasm/build.sh && node --test core/wasm/test/
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";

import { init, Driver, InputError, Model, frameHash } from "../pkg/sinew.mjs";

const data = (name) => readFileSync(new URL(`../../../tests/data/${name}`, import.meta.url));

await init();

/** driver-ict.hashes: the `track FILE FX FY CX CY` and `filter MIN_CUTOFF BETA D_CUTOFF` lines and `KIND FRAME HASH` lines. */
function hashList() {
  const list = { hashes: new Map() };
  for (const line of data("driver-ict.hashes").toString("utf8").split("\n")) {
    if (line.startsWith("#") || line === "") continue;
    const w = line.split(" ");
    if (w[0] === "track") {
      list.track = w[1];
      list.camera = { fx: Number(w[2]), fy: Number(w[3]), cx: Number(w[4]), cy: Number(w[5]) };
    } else if (w[0] === "filter") {
      list.filter = { minCutoff: Number(w[1]), beta: Number(w[2]), dCutoff: Number(w[3]) };
    } else {
      list.hashes.set(`${w[0]} ${w[1]}`, w[2]);
    }
  }
  assert.ok(list.track && list.filter, "driver-ict.hashes names its track and filter");
  return list;
}

/** An OpenFace 2.0 CSV's rows: the timestamp and the 68 [u, v] pixels (columns found by name). */
function track(name) {
  const [header, ...rows] = data(name).toString("utf8").trim().split("\n");
  const names = header.split(",").map((c) => c.trim());
  const [t, x, y] = ["timestamp", "x_0", "y_0"].map((c) => names.indexOf(c));
  assert.ok(t >= 0 && x >= 0 && y >= 0, `${name}: no timestamp, x_0 or y_0 column`);
  return rows.map((row) => {
    const cells = row.split(",").map((c) => Number(c.trim()));
    const pixels = new Float32Array(136);
    for (let l = 0; l < 68; l++) {
      pixels[2 * l] = cells[x + l];
      pixels[2 * l + 1] = cells[y + l];
    }
    return { time: cells[t], pixels };
  });
}

test("driver-ict drives aim-ict: every pose and frame hashes as driver-ict.hashes lists", () => {
  const list = hashList();
  const model = Model.load(data("aim-ict.sinew"));
  const driver = Driver.load(data("driver-ict.sinew"), model);
  assert.equal(driver.space, "2d");
  assert.equal(driver.inputLength, 136);
  assert.equal(driver.poseLength, 18 + model.shapeCount);
  assert.equal(driver.modelHash, model.hash);
  const rows = track(list.track);
  assert.equal(4 * rows.length, list.hashes.size);
  const filter = driver.filter(list.filter);
  rows.forEach(({ time, pixels }, f) => {
    const pose = driver.pose(Driver.pixels(pixels, list.camera));
    assert.equal(pose.length, driver.poseLength);
    assert.equal(frameHash(pose), list.hashes.get(`pose ${f}`), `pose ${f}`);
    assert.equal(driver.frameHash(model, pose), list.hashes.get(`frame ${f}`), `frame ${f}`);
    assert.equal(driver.play(model, pose).length, 3 * model.vertexCount);
    const smooth = filter.step(pose, time);
    assert.equal(frameHash(smooth), list.hashes.get(`filtered-pose ${f}`), `filtered-pose ${f}`);
    assert.equal(driver.frameHash(model, smooth), list.hashes.get(`filtered-frame ${f}`), `filtered-frame ${f}`);
  });
  // After a reset the filter passes its first frame through again.
  filter.reset();
  const first = driver.pose(Driver.pixels(rows[0].pixels, list.camera));
  assert.equal(driver.frameHash(model, filter.step(first, rows[0].time)), list.hashes.get("filtered-frame 0"));
  driver.free();
  model.free();
});

test("the driver refuses NaN landmarks, bad pixels, late time stamps and another actor", () => {
  const list = hashList();
  const model = Model.load(data("aim-ict.sinew"));
  const driver = Driver.load(data("driver-ict.sinew"), model);
  const { time, pixels } = track(list.track)[0];
  const landmarks = Driver.pixels(pixels, list.camera);
  landmarks[17] = NaN;
  assert.throws(() => driver.pose(landmarks), (e) => e instanceof InputError && e.argument === "landmarks" && e.index === 17 && e.message === "landmarks[17] is NaN or infinite");
  const bad = pixels.slice();
  bad[5] = Infinity;
  assert.throws(() => Driver.pixels(bad, list.camera), (e) => e instanceof InputError && e.argument === "pixels" && e.index === 5);
  assert.throws(() => Driver.pixels(pixels, { ...list.camera, fx: 0 }), (e) => e instanceof InputError && e.argument === "camera" && e.index === 0);
  const pose = driver.pose(Driver.pixels(pixels, list.camera));
  const filter = driver.filter(list.filter);
  filter.step(pose, time);
  assert.throws(() => filter.step(pose, time), (e) => e instanceof InputError && e.argument === "time" && /1e-3 s after/.test(e.message));
  assert.throws(() => driver.filter({ minCutoff: 0, beta: 0 }).step(pose, 0), (e) => e instanceof InputError && e.argument === "filter" && e.index === 0);
  assert.throws(() => driver.pose(new Float32Array(10)), /landmarks has 10 values, expected 136/);
  const other = Model.load(data("aim-procedural.sinew"));
  assert.throws(() => Driver.load(data("driver-ict.sinew"), other), /driver does not fit this actor/);
  assert.throws(() => driver.play(other, pose), /driver was trained for the actor/);
  const decoder = Model.load(data("s2d-ict.sinew"));
  assert.throws(() => Driver.load(data("driver-ict.sinew"), decoder), /a driver drives an AIM actor/);
  assert.throws(() => Driver.load(data("fit-ict.sinew"), model), /not a landmark driver/);
  for (const m of [driver, model, other, decoder]) m.free();
});

/** driver-ict-live.hashes: the track, the `live` settings and every `KIND FRAME VALUE` line. */
function liveList() {
  const list = { lines: new Map() };
  for (const line of data("driver-ict-live.hashes").toString("utf8").split("\n")) {
    if (line.startsWith("#") || line === "") continue;
    const w = line.split(" ");
    if (w[0] === "track") {
      list.track = w[1];
      list.camera = { fx: Number(w[2]), fy: Number(w[3]), cx: Number(w[4]), cy: Number(w[5]) };
    } else if (w[0] === "live") {
      list.settings = {
        calibrateFrames: Number(w[1]),
        maxResidual: Number(w[2]),
        maxSpeed: Number(w[3]),
        maxTurn: Number(w[4]),
        reacquire: Number(w[5]),
      };
    } else {
      list.lines.set(`${w[0]} ${w[1]}`, w[2]);
    }
  }
  assert.ok(list.track && list.settings, "driver-ict-live.hashes names its track and settings");
  return list;
}

test("driver-ict drives aim-ict live: every outcome, pose and frame as driver-ict-live.hashes lists", () => {
  const list = liveList();
  const model = Model.load(data("aim-ict.sinew"));
  const driver = Driver.load(data("driver-ict.sinew"), model);
  // The list's settings are the core's defaults (as f32, which the list prints shortest).
  const f32 = Object.fromEntries(Object.entries(list.settings).map(([k, v]) => [k, Math.fround(v)]));
  assert.deepEqual(Driver.liveDefaults(list.settings.calibrateFrames), f32);
  const live = driver.live(model, { calibrateFrames: list.settings.calibrateFrames });
  const [header, ...rows] = data(list.track).toString("utf8").trim().split("\n");
  const names = header.split(",").map((c) => c.trim());
  const success = names.indexOf("success");
  const frames = track(list.track);
  assert.equal(3 * frames.length, list.lines.size);
  frames.forEach(({ time, pixels }, f) => {
    const found = Number(rows[f].split(",")[success]) !== 0;
    const { outcome, pose } = live.step(found ? Driver.pixels(pixels, list.camera) : null, time);
    assert.equal(outcome, list.lines.get(`outcome ${f}`), `frame ${f}`);
    assert.equal(frameHash(pose), list.lines.get(`pose ${f}`), `frame ${f}`);
    assert.equal(driver.frameHash(model, pose), list.lines.get(`frame ${f}`), `frame ${f}`);
    assert.equal(live.calibratedFrames, Math.min(f + 1, list.settings.calibrateFrames));
    assert.equal(live.deviation !== null, f + 1 >= list.settings.calibrateFrames);
  });
  // A reset starts the calibration again: the first frame calibrates once more.
  live.reset();
  assert.equal(live.calibratedFrames, 0);
  assert.equal(live.step(Driver.pixels(frames[0].pixels, list.camera), 0).outcome, "calibrating");
});

test("live driving refuses bad settings, stale time stamps and NaN landmarks, changing nothing", () => {
  const list = liveList();
  const model = Model.load(data("aim-ict.sinew"));
  const driver = Driver.load(data("driver-ict.sinew"), model);
  const frames = track(list.track);
  const first = Driver.pixels(frames[0].pixels, list.camera);
  const refused = (settings, message) =>
    assert.throws(
      () => driver.live(model, settings).step(first, 0),
      (e) => e instanceof InputError && e.argument === "settings" && e.message === message,
    );
  refused({ maxSpeed: -1 }, "settings[2] is outside [0, 1e3]");
  refused({ maxResidual: NaN }, "settings[1] is NaN or infinite");
  refused({ calibrateFrames: 2.5 }, "settings[0] is outside [0, 1e3]");
  refused({ calibrateFrames: 5000 }, "settings[0] is outside [0, 1e3]");
  const live = driver.live(model, { calibrateFrames: 2 });
  live.step(first, 0);
  assert.throws(
    () => live.step(null, 0.0005),
    (e) => e instanceof InputError && e.argument === "time",
  );
  const nan = Float32Array.from(first);
  nan[5] = NaN;
  assert.throws(
    () => live.step(nan, 1),
    (e) => e instanceof InputError && e.argument === "landmarks" && e.index === 5,
  );
  // Nothing changed: the next frame is still the calibration's second.
  assert.equal(live.calibratedFrames, 1);
  assert.equal(live.step(first, 1).outcome, "calibrating");
  assert.equal(live.calibrated, true);
  assert.throws(() => driver.live(Model.load(data("aim-procedural.sinew"))).step(first, 0), /driver was trained for the actor/);
});
