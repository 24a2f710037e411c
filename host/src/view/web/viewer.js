// The page of `sinew view` (docs/VIEW.md): a baked AIM actor posed through sinew-core compiled
// to WebAssembly (sinew.mjs, docs/WASM.md), drawn with plain WebGL2. Every vertex position and
// normal on screen comes from the core, so a frame's hash here is the one the host, the C API
// and the firmware compute.
//
// For tests, `window.sinewTest` exposes the hashes of the frames played, the hash of what is
// shown and the per-frame times (host/tests/view/e2e.mjs).

import { init, Model, Replay, frameHash } from "./sinew.mjs";

const $ = (id) => document.getElementById(id);
const status = $("status");

/** Replay playback speed: a replay records no frame rate, so 30 frames per second. */
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
  if (model.kind !== "aim") throw new Error(`${config.model} is not an AIM actor`);
  $("title").textContent = config.model;
  document.title = `${config.model} · Sinew view`;

  // Frame sources: the replay's frames and the pose file's, each as {head, jaw, coefficients}.
  const sources = [];
  let replay = null;
  if (config.replay) {
    replay = Replay.load(await bytes("replay.sinew"));
    replay.check(model);
    sources.push({
      name: `replay ${config.replay.name} (${replay.mode})`,
      count: replay.frameCount,
      frame: (f) => replay.frame(f),
      expected: replay.mode === "f32" ? (f) => replay.expected(f) : null,
    });
  }
  if (config.poses) {
    const file = await (await fetch("poses.json")).json();
    sources.push({
      name: `poses ${config.poses.name}`,
      count: file.frames.length,
      frame: (f) => ({
        head: file.frames[f].head ?? IDENTITY_9D,
        jaw: file.frames[f].jaw ?? IDENTITY_9D,
        coefficients: file.frames[f].weights,
      }),
      expected: null,
    });
  }

  const view = new FaceView($("face"), model);
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
  const rig = new Rig(model.shapeCount, () => show(rig.pose(), null));
  const times = [];
  /** Hashes of the frames played, by source and frame index. */
  const played = sources.map(() => new Map());
  let positions = null;

  /** Poses, draws and hashes; `playedFrame` ([source, frame]) records the hash as played. */
  function show(pose, playedFrame) {
    const t0 = performance.now();
    positions = model.pose(pose.head, pose.jaw, pose.coefficients);
    const normals = model.normals(positions);
    const ms = performance.now() - t0;
    times.push(ms);
    const recent = times.slice(-TIME_WINDOW);
    const mean = recent.reduce((a, b) => a + b, 0) / recent.length;
    $("time").textContent = `${ms.toFixed(2)} ms (mean of ${recent.length}: ${mean.toFixed(2)} ms)`;
    view.draw(positions, normals);
    const hash = frameHash(positions, normals);
    if (playedFrame) played[playedFrame[0]].set(playedFrame[1], hash);
    return hash;
  }

  const player = new Player(sources, (s, f) => {
    const source = sources[s];
    const pose = source.frame(f);
    rig.setCoefficients(pose.coefficients);
    const hash = show(pose, [s, f]);
    const expected = source.expected?.(f);
    const shown = played[s];
    let note = `frame ${f}: ${hash}`;
    if (expected) {
      const same = [...shown].filter(([g, h]) => h === source.expected(g)).length;
      note += hash === expected ? " = recorded" : ` ≠ recorded ${expected}`;
      note += ` · ${same}/${source.count} frames match the recording`;
    }
    $("check").textContent = note;
  });

  show(rig.pose(), null);
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
        const p = sources[s].frame(f);
        const x = model.pose(p.head, p.jaw, p.coefficients);
        return frameHash(x, model.normals(x));
      }),
    /** The hash of the positions on screen. */
    positionsChecksum: () => frameHash(positions),
    /** Milliseconds of pose + normals, for every frame computed since the page loaded. */
    frameTimes: () => times.slice(),
    playing: () => player.playing,
    /** The thickness heatmap's range as shown, e.g. "0 – 28.6 mm". */
    thicknessRange: () => heat.label,
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

/** The sliders: head yaw and pitch, jaw opening, one per corrective coefficient. */
class Rig {
  constructor(shapeCount, onInput) {
    this.onInput = onInput;
    this.head = { yaw: 0, pitch: 0 };
    this.jaw = 0;
    this.coefficients = new Float32Array(shapeCount);
    const rig = $("rig");
    this.slider(rig, "head-yaw", "head yaw", -45, 45, 1, "°", (v) => (this.head.yaw = v));
    this.slider(rig, "head-pitch", "head pitch", -30, 30, 1, "°", (v) => (this.head.pitch = v));
    this.slider(rig, "jaw", "jaw open", -2, 20, 0.5, "°", (v) => (this.jaw = v));
    this.shapeInputs = [];
    for (let i = 0; i < shapeCount; i++) {
      const input = this.slider($("shapes"), `shape-${i}`, `corrective ${i + 1}`, 0, 1, 0.01, "", (v) => {
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
    // The jaw opens about the x axis through the actor's pivot.
    const [cj, sj] = [Math.cos(this.jaw * rad), Math.sin(this.jaw * rad)];
    const jaw = [1, 0, 0, 0, cj, sj, 0, 0, 0];
    return { head, jaw, coefficients: this.coefficients };
  }
}

const VERTEX_SHADER = `#version 300 es
in vec3 position;
in vec3 normal;
in vec3 tint;
uniform mat4 viewProjection;
uniform mat4 view;
out vec3 viewNormal;
out vec3 viewPosition;
out vec3 albedo;
void main() {
  albedo = tint;
  vec4 p = view * vec4(position, 1.0);
  viewPosition = p.xyz;
  viewNormal = mat3(view) * normal;
  gl_Position = viewProjection * vec4(position, 1.0);
}`;

const FRAGMENT_SHADER = `#version 300 es
precision highp float;
in vec3 viewNormal;
in vec3 viewPosition;
in vec3 albedo;
out vec4 colour;
void main() {
  vec3 n = normalize(viewNormal);
  vec3 v = normalize(-viewPosition);
  if (dot(n, v) < 0.0) n = -n;
  vec3 key = normalize(vec3(0.5, 0.6, 0.8));
  vec3 fill = normalize(vec3(-0.7, 0.1, 0.5));
  float diffuse = max(dot(n, key), 0.0) * 0.75 + max(dot(n, fill), 0.0) * 0.25;
  float sky = 0.5 + 0.5 * n.y;
  float specular = pow(max(dot(n, normalize(key + v)), 0.0), 40.0) * 0.25;
  vec3 c = albedo * (0.06 + 0.08 * sky + 0.85 * diffuse) + vec3(specular);
  colour = vec4(pow(c, vec3(1.0 / 2.2)), 1.0);
}`;

/** The face on a WebGL2 canvas, with orbit (drag) and zoom (wheel) about its centre. */
class FaceView {
  constructor(canvas, model) {
    this.canvas = canvas;
    const gl = canvas.getContext("webgl2", { antialias: true });
    if (!gl) throw new Error("this browser has no WebGL2");
    this.gl = gl;
    this.program = program(gl, VERTEX_SHADER, FRAGMENT_SHADER);
    const triangles = model.triangles();
    this.indexCount = triangles.length;
    this.vao = gl.createVertexArray();
    gl.bindVertexArray(this.vao);
    this.positionBuffer = attribute(gl, this.program, "position");
    this.normalBuffer = attribute(gl, this.program, "normal");
    this.colourBuffer = attribute(gl, this.program, "tint");
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, triangles, gl.STATIC_DRAW);

    // Orbit about the neutral's bounding box centre, at a distance that frames it.
    const neutral = model.neutral();
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    for (let i = 0; i < neutral.length; i += 3) {
      for (let k = 0; k < 3; k++) {
        lo[k] = Math.min(lo[k], neutral[i + k]);
        hi[k] = Math.max(hi[k], neutral[i + k]);
      }
    }
    this.centre = lo.map((l, k) => (l + hi[k]) / 2);
    this.radius = Math.hypot(...hi.map((h, k) => h - lo[k])) / 2 || 1;
    this.distance = this.radius * 2.8;
    this.yaw = 0;
    this.pitch = 0;
    this.listen();
  }

  listen() {
    const c = this.canvas;
    let last = null;
    c.addEventListener("pointerdown", (e) => {
      last = [e.clientX, e.clientY];
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener("pointerup", () => (last = null));
    c.addEventListener("pointermove", (e) => {
      if (!last) return;
      this.yaw -= (e.clientX - last[0]) * 0.01;
      this.pitch = Math.max(-1.5, Math.min(1.5, this.pitch - (e.clientY - last[1]) * 0.01));
      last = [e.clientX, e.clientY];
      this.redraw();
    });
    c.addEventListener(
      "wheel",
      (e) => {
        e.preventDefault();
        const factor = Math.exp(Math.sign(e.deltaY) * 0.1);
        this.distance = Math.max(this.radius * 0.5, Math.min(this.radius * 10, this.distance * factor));
        this.redraw();
      },
      { passive: false },
    );
    new ResizeObserver(() => this.redraw()).observe(c);
  }

  /** Sets the per-vertex colours (linear RGB, 3 per vertex) and redraws. */
  setColours(colours) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.colourBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, colours, gl.STATIC_DRAW);
    if (this.drawn) this.redraw();
  }

  draw(positions, normals) {
    const gl = this.gl;
    gl.bindBuffer(gl.ARRAY_BUFFER, this.positionBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, positions, gl.DYNAMIC_DRAW);
    gl.bindBuffer(gl.ARRAY_BUFFER, this.normalBuffer);
    gl.bufferData(gl.ARRAY_BUFFER, normals, gl.DYNAMIC_DRAW);
    this.drawn = true;
    this.redraw();
  }

  redraw() {
    const gl = this.gl;
    const c = this.canvas;
    const scale = window.devicePixelRatio || 1;
    const [w, h] = [Math.round(c.clientWidth * scale), Math.round(c.clientHeight * scale)];
    if (w > 0 && h > 0 && (c.width !== w || c.height !== h)) [c.width, c.height] = [w, h];
    gl.viewport(0, 0, c.width, c.height);
    gl.clearColor(0x1d / 255, 0x20 / 255, 0x26 / 255, 1);
    gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
    gl.enable(gl.DEPTH_TEST);
    gl.useProgram(this.program);
    const eye = [
      this.centre[0] + this.distance * Math.cos(this.pitch) * Math.sin(this.yaw),
      this.centre[1] + this.distance * Math.sin(this.pitch),
      this.centre[2] + this.distance * Math.cos(this.pitch) * Math.cos(this.yaw),
    ];
    const view = lookAt(eye, this.centre, [0, 1, 0]);
    const near = Math.max(this.distance - this.radius * 2, this.radius * 0.01);
    const projection = perspective(Math.PI / 5, c.width / Math.max(c.height, 1), near, this.distance + this.radius * 2);
    gl.uniformMatrix4fv(gl.getUniformLocation(this.program, "view"), false, view);
    gl.uniformMatrix4fv(gl.getUniformLocation(this.program, "viewProjection"), false, multiply(projection, view));
    gl.bindVertexArray(this.vao);
    gl.drawElements(gl.TRIANGLES, this.indexCount, gl.UNSIGNED_INT, 0);
  }
}

function program(gl, vertexSource, fragmentSource) {
  const p = gl.createProgram();
  for (const [type, source] of [
    [gl.VERTEX_SHADER, vertexSource],
    [gl.FRAGMENT_SHADER, fragmentSource],
  ]) {
    const s = gl.createShader(type);
    gl.shaderSource(s, source);
    gl.compileShader(s);
    if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) throw new Error(`shader: ${gl.getShaderInfoLog(s)}`);
    gl.attachShader(p, s);
  }
  gl.linkProgram(p);
  if (!gl.getProgramParameter(p, gl.LINK_STATUS)) throw new Error(`shader link: ${gl.getProgramInfoLog(p)}`);
  return p;
}

function attribute(gl, p, name) {
  const buffer = gl.createBuffer();
  const location = gl.getAttribLocation(p, name);
  gl.bindBuffer(gl.ARRAY_BUFFER, buffer);
  gl.enableVertexAttribArray(location);
  gl.vertexAttribPointer(location, 3, gl.FLOAT, false, 0, 0);
  return buffer;
}

// Column-major 4×4 matrices, as WebGL takes them.
function lookAt(eye, target, up) {
  const z = normalise(eye.map((e, k) => e - target[k]));
  const x = normalise(cross(up, z));
  const y = cross(z, x);
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  return new Float32Array([
    x[0], y[0], z[0], 0,
    x[1], y[1], z[1], 0,
    x[2], y[2], z[2], 0,
    -dot(x, eye), -dot(y, eye), -dot(z, eye), 1,
  ]);
}

function perspective(fovY, aspect, near, far) {
  const f = 1 / Math.tan(fovY / 2);
  return new Float32Array([
    f / aspect, 0, 0, 0,
    0, f, 0, 0,
    0, 0, (far + near) / (near - far), -1,
    0, 0, (2 * far * near) / (near - far), 0,
  ]);
}

function multiply(a, b) {
  const out = new Float32Array(16);
  for (let col = 0; col < 4; col++) {
    for (let row = 0; row < 4; row++) {
      let s = 0;
      for (let k = 0; k < 4; k++) s += a[k * 4 + row] * b[col * 4 + k];
      out[col * 4 + row] = s;
    }
  }
  return out;
}

function cross(a, b) {
  return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
}

function normalise(v) {
  const n = Math.hypot(...v) || 1;
  return v.map((x) => x / n);
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
