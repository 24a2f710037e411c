// The page of `sinew view` (docs/VIEW.md): a baked AIM actor posed, or an S2D decoder decoding
// a landmark track, through sinew-core compiled to WebAssembly (sinew.mjs, docs/WASM.md), drawn
// with plain WebGL2 (face.js). Every vertex position (and an actor's normals) on screen comes
// from the core, so a frame's hash here is the one the host, the C API and the firmware compute.
//
// For tests, `window.sinewTest` exposes the hashes of the frames played, the hash of what is
// shown and the per-frame times (host/tests/view/e2e.mjs).

import { init, Driver, Model, Performance, Replay, frameHash } from "./sinew.mjs";
import { FaceView, vertexNormals } from "./face.js";
import { startWebcam } from "./webcam.js";

const $ = (id) => document.getElementById(id);
const status = $("status");

/** Playback speed: a replay or a performance records no frame rate, so 30 frames per second. */
const FPS = 30;
/** The 9D identity: 6D rotation columns (1,0,0), (0,1,0), then a zero translation. */
const IDENTITY_9D = [1, 0, 0, 0, 1, 0, 0, 0, 0];
/** How many recent per-frame times the mean shown is over. */
const TIME_WINDOW = 30;
/** The skin's colour (linear RGB). */
const SKIN = [0.82, 0.66, 0.58];
/** Heat-map stops (position, sRGB 0–255), low to high, as the host's figures draw them. */
const RAMP = [
  [0.0, [15, 25, 110]],
  [0.2, [30, 90, 220]],
  [0.45, [20, 210, 230]],
  [0.72, [250, 225, 40]],
  [1.0, [205, 20, 20]],
];
/** Millimetres per unit of the `units` metadata. */
const MM = { mm: 1, cm: 10, m: 1000 };

/** The heat-map colour at t in [0, 1] (clamped), in linear RGB for the shader. */
function ramp(t) {
  t = Math.min(1, Math.max(0, t));
  let i = 0;
  while (i + 2 < RAMP.length && t > RAMP[i + 1][0]) i++;
  const [[t0, c0], [t1, c1]] = [RAMP[i], RAMP[i + 1]];
  const f = (t - t0) / (t1 - t0);
  return c0.map((c, k) => Math.pow((c + (c1[k] - c) * f) / 255, 2.2));
}

/**
 * Per-vertex colours: the skin, or the actor's soft-tissue thickness d0 (from the core) on the
 * heat-map scale from 0 to its largest value, with that range in mm.
 */
function thicknessColours(model) {
  const d = model.thickness();
  const mm = MM[model.metadata.units] ?? 1;
  const hi = d.reduce((m, x) => Math.max(m, x), 0) * mm || 1;
  const colours = new Float32Array(d.length * 3);
  d.forEach((x, v) => colours.set(ramp((x * mm) / hi), v * 3));
  const unit = model.metadata.units in MM ? "mm" : model.metadata.units ?? "units";
  return { colours, label: `0 – ${hi.toFixed(1)} ${unit}` };
}

async function bytes(url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: ${response.status} ${response.statusText}`);
  return response.arrayBuffer();
}

async function main() {
  await init();
  const config = await (await fetch("config.json")).json();
  const model = Model.load(await bytes("model.sinew"));
  $("title").textContent = config.model;
  document.title = `${config.model} · Sinew view`;
  if (model.kind === "s2d") return mainS2d(model, config);

  // Frame sources: the replay's frames, the pose file's and the performance's. Each gives a
  // frame's {head, jaw, coefficients} (coefficients null where they vary per vertex), its
  // positions posed by the core, and the hash recorded for it where there is one to compare.
  const sources = [];
  const posed = (p) => model.pose(p.head, p.jaw, p.coefficients);
  let replay = null;
  if (config.replay) {
    replay = Replay.load(await bytes("replay.sinew"));
    replay.check(model);
    sources.push({
      name: `replay ${config.replay.name} (${replay.mode})`,
      count: replay.frameCount,
      frame: (f) => replay.frame(f),
      positions: (f) => posed(replay.frame(f)),
      expected: replay.mode === "f32" ? (f) => replay.expected(f) : null,
    });
  }
  if (config.poses) {
    const file = await (await fetch("poses.json")).json();
    const frame = (f) => ({
      head: file.frames[f].head ?? IDENTITY_9D,
      jaw: file.frames[f].jaw ?? IDENTITY_9D,
      coefficients: file.frames[f].weights,
    });
    sources.push({
      name: `poses ${config.poses.name}`,
      count: file.frames.length,
      frame,
      positions: (f) => posed(frame(f)),
      expected: null,
    });
  }
  if (config.performance) {
    const perf = Performance.load(await bytes("performance.sinew"));
    perf.check(model);
    sources.push({
      name: `performance ${config.performance.name} (${perf.form})`,
      count: perf.frameCount,
      frame: (f) => perf.frame(f),
      // The core's Performance::pose: a global frame's coefficients, or F_W per vertex.
      positions: (f) => perf.pose(model, f),
      expected: perf.hasHashes ? (f) => perf.expected(f) : null,
    });
  }

  if (config.driver) {
    // Every frame's landmarks through the driver once, as `sinew drive` does: a lost frame
    // (null) holds the last pose, the rest pose before the first found one.
    const driver = Driver.load(await bytes("driver.sinew"), model);
    const track = await (await fetch("landmarks.json")).json();
    let last = Float32Array.from([...IDENTITY_9D, ...IDENTITY_9D, ...new Array(model.shapeCount).fill(0)]);
    const poses = track.frames.map((landmarks) => {
      if (landmarks) last = driver.pose(Float32Array.from(landmarks));
      return last;
    });
    sources.push({
      name: `driver ${config.driver.name} on ${config.driver.landmarks} (${config.driver.space})`,
      count: poses.length,
      frame: (f) => ({
        head: poses[f].slice(0, 9),
        jaw: poses[f].slice(9, 18),
        coefficients: poses[f].slice(18),
      }),
      positions: (f) => driver.play(model, poses[f]),
      expected: null,
    });
  }

  const view = new FaceView($("face"), model.triangles(), model.neutral());
  const skin = new Float32Array(model.vertexCount * 3);
  for (let v = 0; v < model.vertexCount; v++) skin.set(SKIN, v * 3);
  const heat = thicknessColours(model);
  const toggle = $("thickness");
  const showThickness = () => {
    view.setColours(toggle.checked ? heat.colours : skin);
    $("thickness-scale").hidden = !toggle.checked;
    $("thickness-range").textContent = heat.label;
  };
  toggle.addEventListener("change", showThickness);
  showThickness();
  const rig = new Rig(model.shapeCount, shapeNames(model), (w) => model.jawFromWeights(w), () => show(() => posed(rig.pose()), null));
  const times = [];
  /** Hashes of the frames played, by source and frame index. */
  const played = sources.map(() => new Map());
  let positions = null;

  /**
   * Poses (`compute` returns the positions), draws and hashes; `playedFrame` ([source, frame])
   * records the hash as played.
   */
  function show(compute, playedFrame) {
    const t0 = performance.now();
    positions = compute();
    const normals = model.normals(positions);
    recordTime(times, performance.now() - t0);
    view.draw(positions, normals);
    const hash = frameHash(positions, normals);
    if (playedFrame) played[playedFrame[0]].set(playedFrame[1], hash);
    return hash;
  }

  const player = new Player(sources, (s, f) => {
    const source = sources[s];
    const { coefficients } = source.frame(f);
    if (coefficients) rig.setCoefficients(coefficients);
    const hash = show(() => source.positions(f), [s, f]);
    $("check").textContent = checkNote(source, played[s], f, hash);
  });

  show(() => posed(rig.pose()), null);

  // The webcam starts in the background (the tracker loads, the browser asks for the camera);
  // its test hooks appear when it runs, its failure is shown in its panel.
  let webcam = null;
  if (config.webcam) {
    const driver = Driver.load(await bytes("driver.sinew"), model);
    startWebcam({
      config,
      model,
      driver,
      show: (p, normals, coefficients) => {
        positions = p;
        view.draw(p, normals);
        rig.setCoefficients(coefficients);
      },
    }).then(
      (hooks) => (webcam = hooks),
      (e) => {
        $("webcam-status").textContent = `webcam: ${e.message ?? e}`;
        $("webcam-status").classList.add("error");
        webcam = { error: () => String(e.message ?? e), frames: () => [], started: () => false };
      },
    );
  }
  const frames = sources.reduce((n, s) => n + s.count, 0);
  status.textContent =
    `${model.vertexCount} vertices, ${model.triangleCount} triangles, ${model.shapeCount} ` +
    `correctives` + (sources.length ? `, ${frames} frames to play` : "");

  window.sinewTest = {
    ready: true,
    vertexCount: model.vertexCount,
    shapeCount: model.shapeCount,
    sources: sources.map((s) => ({ name: s.name, count: s.count })),
    /** Hashes of the frames of source `s` played so far, by frame index (null: not played). */
    playedHashes: (s = 0) => Array.from({ length: sources[s].count }, (_, f) => played[s].get(f) ?? null),
    /** Every frame of source `s` posed, its normals computed and hashed now, in order. */
    frameHashes: (s = 0) =>
      Array.from({ length: sources[s].count }, (_, f) => {
        const x = sources[s].positions(f);
        return frameHash(x, model.normals(x));
      }),
    /** The hash of the positions on screen. */
    positionsChecksum: () => frameHash(positions),
    /** Milliseconds of pose + normals, for every frame computed since the page loaded. */
    frameTimes: () => times.slice(),
    playing: () => player.playing,
    /** The thickness heatmap's range as shown, e.g. "0 – 28.6 mm". */
    thicknessRange: () => heat.label,
    /** The webcam's hooks (webcam.js) once it runs or has failed; null before. */
    webcam: () => webcam,
  };
}

/** Shows a frame's time (`ms`) and the mean of the last TIME_WINDOW, and keeps it in `times`. */
function recordTime(times, ms) {
  times.push(ms);
  const recent = times.slice(-TIME_WINDOW);
  const mean = recent.reduce((a, b) => a + b, 0) / recent.length;
  $("time").textContent = `${ms.toFixed(2)} ms (mean of ${recent.length}: ${mean.toFixed(2)} ms)`;
}

/**
 * What the page says of frame `f` of `source` with hash `hash`: the hash, and where the source
 * has recorded ones, whether it equals its own and how many of the frames shown (`shown`, frame
 * to hash) match.
 */
function checkNote(source, shown, f, hash) {
  const expected = source.expected?.(f);
  let note = `frame ${f}: ${hash}`;
  if (expected) {
    const same = [...shown].filter(([g, h]) => h === source.expected(g)).length;
    note += hash === expected ? " = recorded" : ` ≠ recorded ${expected}`;
    note += ` · ${same}/${source.count} frames match the recording`;
  }
  return note;
}

/**
 * The landmarks a frame's decoder input describes, placed at the neutral's landmarks:
 * `neutral + ‖centred(neutral)‖ · input`, x y z per landmark. Under both of the decoder's input
 * normalisations (docs/FORMAT.md, `s2d.input`) the input is the landmarks' motion, less its
 * mean, in units of the neutral's centred size (Frobenius: the difference of the two unit-size
 * sets, the expressive one taken at the neutral's size), so this inverts it: exactly (up to
 * rounding) for an input measured against this neutral, and up to the renormalisation of the
 * moved set for one measured against another face's (a transferred track, Frobenius).
 */
function trackLandmarks(neutral, input) {
  const k = neutral.length / 3;
  const mean = [0, 1, 2].map((c) => {
    let sum = 0;
    for (let i = 0; i < k; i++) sum += neutral[3 * i + c];
    return sum / k;
  });
  let size = 0;
  for (let i = 0; i < neutral.length; i++) size += (neutral[i] - mean[i % 3]) ** 2;
  size = Math.sqrt(size) || 1;
  return neutral.map((n, i) => n + size * input[i]);
}

/**
 * The page for an S2D decoder: its landmark track (an S2D replay) decoded frame by frame onto
 * the `--neutral` face, else the track's neutral, else the decoder's template; the face drawn
 * with the neutral's polygons, or as points when there are none; the landmarks over it.
 */
async function mainS2d(model, config) {
  for (const id of ["head-jaw", "correctives", "display"]) $(id).hidden = true;
  $("time-what").textContent = "Decode";
  const face = config.neutral ? await (await fetch("neutral.json")).json() : null;
  const track = config.track ? Replay.load(await bytes("track.sinew")) : null;
  if (track) {
    if (track.kind !== "s2d") throw new Error(`${config.track.name} is not an S2D replay`);
    track.check(model);
  }
  const neutral = face ? Float32Array.from(face.positions) : (track?.neutral ?? model.neutral());
  const triangles = face ? Uint32Array.from(face.triangles) : new Uint32Array(0);
  const landmarkVertices = model.landmarkVertices();
  const neutralLandmarks = new Float32Array(3 * landmarkVertices.length);
  landmarkVertices.forEach((v, i) => neutralLandmarks.set(neutral.subarray(3 * v, 3 * v + 3), 3 * i));

  const view = new FaceView($("face"), triangles, neutral);
  view.setColours(new Float32Array(neutral.length).map((_, i) => SKIN[i % 3]));
  const sources = track
    ? [
        {
          name: `track ${config.track.name}`,
          count: track.frameCount,
          input: (f) => track.frame(f).input,
          expected: config.track.compare ? (f) => track.expected(f) : null,
        },
      ]
    : [];
  const times = [];
  const played = sources.map(() => new Map());
  let positions = neutral;
  let landmarks = neutralLandmarks;
  const draw = () => view.draw(positions, triangles.length ? vertexNormals(positions, triangles) : positions);

  const player = new Player(sources, (s, f) => {
    const input = sources[s].input(f);
    const t0 = performance.now();
    positions = model.decode(input, neutral);
    recordTime(times, performance.now() - t0);
    landmarks = trackLandmarks(neutralLandmarks, input);
    view.setLandmarks(landmarks);
    draw();
    const hash = frameHash(positions);
    played[s].set(f, hash);
    $("check").textContent = checkNote(sources[s], played[s], f, hash);
  });
  if (!track) {
    view.setLandmarks(landmarks);
    draw();
  }
  status.textContent =
    `S2D decoder: ${model.vertexCount} vertices, ${model.landmarkCount} landmarks` +
    (face ? `, ${triangles.length / 3} triangles of ${config.neutral.name}` : ", drawn as points") +
    (track ? `, ${track.frameCount} frames to play` : "");

  window.sinewTest = {
    ready: true,
    kind: "s2d",
    vertexCount: model.vertexCount,
    landmarkCount: model.landmarkCount,
    sources: sources.map((s) => ({ name: s.name, count: s.count })),
    playedHashes: (s = 0) => Array.from({ length: sources[s].count }, (_, f) => played[s].get(f) ?? null),
    /** Every frame of source `s` decoded and hashed now, in order. */
    frameHashes: (s = 0) =>
      Array.from({ length: sources[s].count }, (_, f) => frameHash(model.decode(sources[s].input(f), neutral))),
    positionsChecksum: () => frameHash(positions),
    /** The landmarks drawn, x y z each. */
    landmarks: () => Array.from(landmarks),
    /**
     * How faithfully the points show frame `f`: the largest difference between its input and
     * the decoder's input from the neutral's landmarks and the landmarks drawn for it, and the
     * input's largest value.
     */
    landmarkRoundTrip: (f, s = 0) => {
      const input = sources[s].input(f);
      const again = model.landmarkInput(neutralLandmarks, trackLandmarks(neutralLandmarks, input));
      return {
        difference: again.reduce((m, x, i) => Math.max(m, Math.abs(x - input[i])), 0),
        largest: input.reduce((m, x) => Math.max(m, Math.abs(x)), 0),
      };
    },
    frameTimes: () => times.slice(),
    playing: () => player.playing,
  };
}

/** Plays one source's frames at FPS, never skipping one (a slow machine plays slower). */
class Player {
  constructor(sources, showFrame) {
    this.sources = sources;
    this.showFrame = showFrame;
    this.source = 0;
    this.frame = 0;
    this.playing = false;
    if (!sources.length) return;
    $("playback").hidden = false;
    const select = $("source");
    sources.forEach((s, i) => select.add(new Option(s.name, String(i))));
    select.addEventListener("change", () => {
      this.source = Number(select.value);
      this.seek(0);
    });
    $("play").addEventListener("click", () => (this.playing ? this.pause() : this.play()));
    $("frame").addEventListener("input", (e) => {
      this.pause();
      this.seek(Number(e.target.value));
    });
    this.seek(0);
  }

  seek(f) {
    const count = this.sources[this.source].count;
    this.frame = f;
    $("frame").max = String(count - 1);
    $("frame").value = String(f);
    $("frame-label").textContent = `${f + 1}/${count}`;
    this.showFrame(this.source, f);
  }

  play() {
    this.playing = true;
    $("play").textContent = "Pause";
    let due = performance.now() + 1000 / FPS;
    const tick = (now) => {
      if (!this.playing) return;
      if (now >= due) {
        // Never more than one frame per tick: a replay is for checking every frame.
        due = Math.max(due + 1000 / FPS, now);
        this.seek((this.frame + 1) % this.sources[this.source].count);
      }
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }

  pause() {
    this.playing = false;
    $("play").textContent = "Play";
  }
}

/**
 * The actor's corrective shapes' names, from its metadata `shapes` (neutral first, then one per
 * corrective); `corrective N` where the actor records none or too few.
 */
function shapeNames(model) {
  const recorded = (model.metadata.shapes ?? "").split(",").slice(1);
  return Array.from({ length: model.shapeCount }, (_, i) =>
    recorded.length === model.shapeCount && recorded[i] ? recorded[i] : `corrective ${i + 1}`,
  );
}

/**
 * The sliders: head yaw and pitch, one per corrective coefficient, named, and a jaw opening
 * beyond what the coefficients open. `learnedJaw(coefficients)` is the core's jaw of a pose given
 * by coefficients alone (the shapes' learned jaws blended, `jawFromWeights`).
 */
class Rig {
  constructor(shapeCount, names, learnedJaw, onInput) {
    this.onInput = onInput;
    this.learnedJaw = learnedJaw;
    this.head = { yaw: 0, pitch: 0 };
    this.jaw = 0;
    this.coefficients = new Float32Array(shapeCount);
    const rig = $("rig");
    this.slider(rig, "head-yaw", "head yaw", -45, 45, 1, "°", (v) => (this.head.yaw = v));
    this.slider(rig, "head-pitch", "head pitch", -30, 30, 1, "°", (v) => (this.head.pitch = v));
    this.slider(rig, "jaw", "jaw open +", -2, 20, 0.5, "°", (v) => (this.jaw = v));
    this.shapeInputs = [];
    for (let i = 0; i < shapeCount; i++) {
      const input = this.slider($("shapes"), `shape-${i}`, names[i], 0, 1, 0.01, "", (v) => {
        this.coefficients[i] = v;
      });
      this.shapeInputs.push(input);
    }
    $("reset").addEventListener("click", () => {
      for (const input of document.querySelectorAll("#rig input, #shapes input")) {
        input.value = "0";
        input.dispatchEvent(new Event("input"));
      }
    });
  }

  slider(parent, id, text, min, max, step, unit, set) {
    const label = document.createElement("label");
    const input = Object.assign(document.createElement("input"), { type: "range", id, min, max, step, value: 0 });
    const out = document.createElement("output");
    const update = () => (out.textContent = `${Number(input.value)}${unit}`);
    label.append(text, input, out);
    parent.append(label);
    update();
    input.addEventListener("input", () => {
      set(Number(input.value));
      update();
      this.onInput();
    });
    return input;
  }

  /** Shows a played frame's coefficients on the sliders (without posing again). */
  setCoefficients(values) {
    values.forEach((v, i) => {
      this.coefficients[i] = v;
      this.shapeInputs[i].value = String(v);
      this.shapeInputs[i].nextElementSibling.textContent = Number(v).toFixed(2);
    });
  }

  /** The pose the sliders describe, in the core's 9D form (6D rotation columns, translation). */
  pose() {
    const rad = Math.PI / 180;
    const [cy, sy] = [Math.cos(this.head.yaw * rad), Math.sin(this.head.yaw * rad)];
    const [cp, sp] = [Math.cos(this.head.pitch * rad), Math.sin(this.head.pitch * rad)];
    // R = Ry(yaw) · Rx(pitch); its first two columns.
    const head = [cy, 0, -sy, sy * sp, cp, cy * sp, 0, 0, 0];
    // The coefficients' own jaw (each shape's learned jaw, as sinew play --arkit and engines
    // driving shapes by name take it), then the slider's opening about the x axis through the
    // pivot on top: R' = Rx · R, t' = Rx · t. At 0° the jaw is the core's to the bit.
    const learned = this.learnedJaw(this.coefficients);
    if (this.jaw === 0) return { head, jaw: Array.from(learned), coefficients: this.coefficients };
    const [cj, sj] = [Math.cos(this.jaw * rad), Math.sin(this.jaw * rad)];
    const rx = (v) => [v[0], cj * v[1] - sj * v[2], sj * v[1] + cj * v[2]];
    const jaw = [...rx(learned.slice(0, 3)), ...rx(learned.slice(3, 6)), ...rx(learned.slice(6, 9))];
    return { head, jaw, coefficients: this.coefficients };
  }
}

// Last, once every class above is defined.
try {
  await main();
} catch (e) {
  status.textContent = `Error: ${e.message}`;
  status.classList.add("error");
  window.sinewTest = { ready: false, error: String(e.message) };
  throw e;
}
