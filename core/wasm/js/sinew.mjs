// Sinew's face models in JavaScript: the ES module over sinew_wasm.wasm (sinew-core compiled to
// WebAssembly). API reference: docs/WASM.md; types: sinew.d.ts.
//
// The module's exports speak in numbers only (core/wasm/src/exports.rs): inputs are copied
// into the module's I/O area, an operation returns the length of its result there (or -1, and
// `sinew_error` gives the message), and models and replays are handles. This file turns that
// into classes, typed arrays and Error exceptions (an InputError, with the argument and the
// index, when the core refuses a value). WebAssembly memory is little-endian, as are
// the typed arrays of every platform a browser or node runs on.

let wasm = null;

/**
 * A value the core refuses instead of guessing: NaN, infinite, outside its range, or degenerate
 * (a 6D rotation's column too short or parallel to the other, landmarks that all coincide).
 * `argument` is the parameter's name in this API (`head`, `coefficients`, `neutralLandmarks`),
 * `index` the value's position in it (for a degenerate rotation, its column's first index).
 */
export class InputError extends Error {
  constructor(message, argument, index) {
    super(message);
    this.name = "InputError";
    this.argument = argument;
    this.index = index;
  }
}

/**
 * Instantiates the WebAssembly module once. `source` is the module's URL (default: the
 * `sinew_wasm.wasm` beside this file), a Response, its bytes, or a compiled WebAssembly.Module.
 */
export async function init(source) {
  if (wasm) return;
  source ??= new URL("./sinew_wasm.wasm", import.meta.url);
  if (typeof source === "string") source = new URL(source, import.meta.url);
  let instance;
  if (source instanceof WebAssembly.Module) {
    instance = await WebAssembly.instantiate(source, {});
  } else if (source instanceof URL && source.protocol === "file:") {
    // node: fetch() does not read files.
    const { readFile } = await import("node:fs/promises");
    ({ instance } = await WebAssembly.instantiate(await readFile(source), {}));
  } else if (source instanceof URL || (typeof Response !== "undefined" && source instanceof Response)) {
    const response = source instanceof URL ? await fetch(source) : source;
    if (!response.ok) throw new Error(`sinew: cannot fetch ${response.url}: ${response.status}`);
    ({ instance } = await WebAssembly.instantiate(await response.arrayBuffer(), {}));
  } else {
    ({ instance } = await WebAssembly.instantiate(bytesOf(source, "the module"), {}));
  }
  wasm = instance.exports;
}

function exports() {
  if (!wasm) throw new Error("sinew: call `await init()` before using the module");
  return wasm;
}

/** The bytes of an ArrayBuffer or a typed array (node's Buffer included), without a copy. */
function bytesOf(data, what) {
  if (data instanceof ArrayBuffer) return new Uint8Array(data);
  if (ArrayBuffer.isView(data)) return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  throw new TypeError(`sinew: ${what} must be an ArrayBuffer or a typed array`);
}

/** `values` as a Float32Array (an array of numbers is converted). */
function floats(values, what) {
  if (values instanceof Float32Array) return values;
  if (Array.isArray(values) || ArrayBuffer.isView(values)) return Float32Array.from(values);
  throw new TypeError(`sinew: ${what} must be a Float32Array or an array of numbers`);
}

const f32Bytes = (a) => new Uint8Array(a.buffer, a.byteOffset, a.byteLength);

/** Copies `parts` (Uint8Arrays) one after the other into the I/O area. */
function put(...parts) {
  const w = exports();
  const total = parts.reduce((n, p) => n + p.length, 0);
  const ptr = w.sinew_io_reserve(total) >>> 0;
  const memory = new Uint8Array(w.memory.buffer);
  let at = ptr;
  for (const p of parts) {
    memory.set(p, at);
    at += p.length;
  }
}

/** The result of an operation that returned `status`: a copy of its bytes, or an Error thrown. */
function take(status) {
  const w = exports();
  if (status < 0) throw failure();
  const ptr = w.sinew_io_ptr() >>> 0;
  // A copy: the memory may grow (and its buffer be replaced) at the next call.
  return new Uint8Array(w.memory.buffer).slice(ptr, ptr + status);
}

/** The last failed operation's exception: an InputError when the core refused a value. */
function failure() {
  const w = exports();
  // The argument's name first: `sinew_error` replaces the I/O area and forgets the refusal.
  const len = w.sinew_error_argument();
  if (len >= 0) {
    const argument = text(len);
    const index = w.sinew_error_index();
    return new InputError(text(w.sinew_error()), argument, index);
  }
  return new Error(text(w.sinew_error()));
}

function text(len) {
  const w = exports();
  const ptr = w.sinew_io_ptr() >>> 0;
  return new TextDecoder().decode(new Uint8Array(w.memory.buffer, ptr, len));
}

const takeF32 = (status) => new Float32Array(take(status).buffer);
const takeI32 = (status) => new Int32Array(take(status).buffer);
const takeU32 = (status) => new Uint32Array(take(status).buffer);
const takeText = (status) => new TextDecoder().decode(take(status));

/** `key=value` lines as an object. */
function keyValues(lines) {
  const out = {};
  for (const line of lines.split("\n")) {
    const eq = line.indexOf("=");
    if (eq > 0) out[line.slice(0, eq)] = line.slice(eq + 1);
  }
  return out;
}

// Frees the module's side of a model or replay that was garbage-collected without `free()`.
const finalizer = new FinalizationRegistry((handle) => wasm?.sinew_free(handle));
const token = Symbol("sinew handle");

class Handle {
  #handle;

  constructor(key, handle) {
    if (key !== token) throw new TypeError("sinew: use Model.load, Replay.load, Performance.load, Motion.load or Driver.load");
    this.#handle = handle;
    finalizer.register(this, handle, this);
  }

  /** The handle; 0 (never live) once freed, so a freed object's calls throw. */
  get _h() {
    return this.#handle;
  }

  /** Frees the model, replay or performance now (its memory in the module). Further calls throw. */
  free() {
    if (this.#handle !== 0) {
      finalizer.unregister(this);
      exports().sinew_free(this.#handle);
      this.#handle = 0;
    }
  }
}

function load(bytes, loader) {
  const w = exports();
  put(bytesOf(bytes, "the file"));
  const handle = loader(w);
  if (handle < 0) throw failure();
  return handle;
}

function frameIndex(f) {
  if (!Number.isInteger(f) || f < 0 || f > 0xffff_ffff) {
    throw new RangeError(`sinew: a frame index is a non-negative integer, got ${f}`);
  }
  return f;
}

/** A validated AIM actor or S2D decoder. */
export class Model extends Handle {
  #info;

  /** Validates a `.sinew` model (AIM actor or S2D decoder); throws an Error saying what is wrong. */
  static load(bytes) {
    return new Model(token, load(bytes, (w) => w.sinew_model_load()));
  }

  constructor(key, handle) {
    super(key, handle);
    this.#info = keyValues(takeText(exports().sinew_info(handle)));
  }

  /** "aim" or "s2d". */
  get kind() {
    return this.#info.kind;
  }
  /** Vertices of the output mesh. */
  get vertexCount() {
    return Number(this.#info.vertices);
  }
  /** Coefficients per pose (corrective shapes) of an AIM actor; 0 for an S2D decoder. */
  get shapeCount() {
    return Number(this.#info.shapes);
  }
  /** Values of an S2D decoder's input (3 per landmark); 0 for an AIM actor. */
  get inputLength() {
    return Number(this.#info.inputs);
  }
  /** Landmarks of an S2D decoder's input; 0 for an AIM actor. */
  get landmarkCount() {
    return Number(this.#info.inputs) / 3;
  }
  /** Triangles of an AIM actor's template; 0 for an S2D decoder (its file has no faces). */
  get triangleCount() {
    return Number(this.#info.triangles);
  }
  /** The content hash of the model's bytes (16 hex digits), which a replay names. */
  get hash() {
    return this.#info.hash;
  }
  /** The metadata (`units`, `axes`, provenance) as an object of strings. */
  get metadata() {
    return keyValues(takeText(exports().sinew_metadata(this._h)));
  }
  /** The length unit of positions (`cm` for the ICT actors), or null if the file records none. */
  get units() {
    return this.metadata.units ?? null;
  }
  /** The axes' directions (`x-left-of-actor,y-up,z-forward`), or null if the file records none. */
  get axes() {
    return this.metadata.axes ?? null;
  }
  /**
   * An AIM actor's corrective shapes' names in coefficient order (the sliders or morph targets):
   * the recorded training shapes without the neutral, or `shape_1` … when the file records none.
   * Empty for an S2D decoder.
   */
  shapeNames() {
    const text = takeText(exports().sinew_names(this._h));
    return text === "" ? [] : text.split("\n");
  }
  /** Triangle vertex indices, 3 per triangle (empty for an S2D decoder). */
  triangles() {
    return takeU32(exports().sinew_array(this._h, 0));
  }
  /** The vertex of each input landmark of an S2D decoder (empty for an AIM actor). */
  landmarkVertices() {
    return takeU32(exports().sinew_array(this._h, 1));
  }
  /** The neutral mesh, x y z per vertex: an AIM actor's neutral skin, an S2D decoder's template. */
  neutral() {
    return takeF32(exports().sinew_array(this._h, 2));
  }
  /** An AIM actor's soft-tissue thickness at each vertex, in the actor's unit. */
  thickness() {
    return takeF32(exports().sinew_array(this._h, 4));
  }

  /** Poses an AIM actor: head and jaw as 9 values (6D rotation, translation), the coefficients. */
  pose(head, jaw, coefficients) {
    const h = floats(head, "head");
    const j = floats(jaw, "jaw");
    put(f32Bytes(h), f32Bytes(j), f32Bytes(floats(coefficients, "coefficients")));
    return takeF32(exports().sinew_pose(this._h, h.length, j.length));
  }

  /**
   * The jaw of a pose given by coefficients alone (an ARKit capture, sliders, shapes driven by
   * name): every training shape's learned jaw blended by its coefficient and held within the
   * range the shapes span; 9 values for `pose`'s `jaw`.
   */
  jawFromWeights(coefficients) {
    put(f32Bytes(floats(coefficients, "coefficients")));
    return takeF32(exports().sinew_jaw_from_weights(this._h));
  }

  /**
   * Poses an AIM actor in Q16.16 fixed point (the Q16 replays' mode): the positions' raw values
   * (value × 65536), x y z per vertex. `frameHashQ16(poseQ16(...))` is the frame's Q16 hash.
   */
  poseQ16(head, jaw, coefficients) {
    const h = floats(head, "head");
    const j = floats(jaw, "jaw");
    put(f32Bytes(h), f32Bytes(j), f32Bytes(floats(coefficients, "coefficients")));
    return takeI32(exports().sinew_pose_q16(this._h, h.length, j.length));
  }

  /**
   * Poses an AIM actor in the fast mode: `{ positions, normals }`, the positions of `pose` and
   * the normals normalised with micromath's approximate inverse square root.
   * `frameHash(positions, normals)` is the frame's fast hash.
   */
  poseFast(head, jaw, coefficients) {
    const h = floats(head, "head");
    const j = floats(jaw, "jaw");
    put(f32Bytes(h), f32Bytes(j), f32Bytes(floats(coefficients, "coefficients")));
    const v = takeF32(exports().sinew_pose_fast(this._h, h.length, j.length));
    const n = v.length / 2;
    return { positions: v.subarray(0, n), normals: v.subarray(n) };
  }

  /** Area-weighted vertex normals of an AIM actor's posed positions. */
  normals(positions) {
    put(f32Bytes(floats(positions, "positions")));
    return takeF32(exports().sinew_normals(this._h));
  }

  /** An S2D decoder's input from a neutral and an expressive landmark set (x y z each). */
  landmarkInput(neutralLandmarks, landmarks) {
    const n = floats(neutralLandmarks, "neutral landmarks");
    put(f32Bytes(n), f32Bytes(floats(landmarks, "landmarks")));
    return takeF32(exports().sinew_landmark_input(this._h, n.length));
  }

  /** Decodes an S2D input onto `neutral` (same topology), or onto the decoder's template. */
  decode(input, neutral) {
    const i = floats(input, "input");
    const parts = [f32Bytes(i)];
    if (neutral !== undefined && neutral !== null) parts.push(f32Bytes(floats(neutral, "neutral")));
    put(...parts);
    return takeF32(exports().sinew_decode(this._h, i.length));
  }

  /** `decode(landmarkInput(neutralLandmarks, landmarks), neutral)`. */
  decodeLandmarks(neutralLandmarks, landmarks, neutral) {
    return this.decode(this.landmarkInput(neutralLandmarks, landmarks), neutral);
  }
}

/** A validated replay: per-frame inputs and the hash recorded for each frame. */
export class Replay extends Handle {
  #info;
  #neutral;

  /** Validates a `.sinew` replay; throws an Error saying what is wrong. */
  static load(bytes) {
    return new Replay(token, load(bytes, (w) => w.sinew_replay_load()));
  }

  constructor(key, handle) {
    super(key, handle);
    this.#info = keyValues(takeText(exports().sinew_info(handle)));
  }

  /** "aim" or "s2d": the kind of model it plays. */
  get kind() {
    return this.#info.kind;
  }
  /** The numeric mode it was recorded in: "f32", "q16" or "fast" (S2D: "f32"). */
  get mode() {
    return this.#info.mode;
  }
  /** Number of frames. */
  get frameCount() {
    return Number(this.#info.frames);
  }
  /** The content hash of the model it was recorded with (16 hex digits). */
  get modelHash() {
    return this.#info.model;
  }
  /** The neutral an S2D replay's frames decode onto, or null (decode onto the template). */
  get neutral() {
    if (this.#info.neutral !== "1") return null;
    this.#neutral ??= takeF32(exports().sinew_array(this._h, 3));
    return this.#neutral;
  }

  /** Frame `f`'s inputs: `{ head, jaw, coefficients }` (AIM) or `{ input }` (S2D). */
  frame(f) {
    const v = takeF32(exports().sinew_replay_frame(this._h, frameIndex(f)));
    if (this.kind === "s2d") return { input: v };
    return { head: v.subarray(0, 9), jaw: v.subarray(9, 18), coefficients: v.subarray(18) };
  }

  /** The hash recorded for frame `f` (16 hex digits). */
  expected(f) {
    return takeText(exports().sinew_replay_expected(this._h, frameIndex(f)));
  }

  /** Throws unless this replay was recorded with `model` (content hash and sizes). */
  check(model) {
    if (!(model instanceof Model)) throw new TypeError("sinew: check takes a Model");
    take(exports().sinew_replay_check(this._h, model._h));
  }
}

/**
 * A validated fitted performance (`sinew fit --out FIT.sinew`): per frame the head, the jaw and
 * the coefficients (one vector per frame for a global fit, a network of the vertex for a local
 * one), played on the AIM actor it was fitted to.
 */
export class Performance extends Handle {
  #info;

  /** Validates a `.sinew` fitted performance; throws an Error saying what is wrong. */
  static load(bytes) {
    return new Performance(token, load(bytes, (w) => w.sinew_performance_load()));
  }

  constructor(key, handle) {
    super(key, handle);
    this.#info = keyValues(takeText(exports().sinew_info(handle)));
  }

  /** "global" (one coefficient vector per frame) or "local" (coefficients per vertex, AIM eq. 19). */
  get form() {
    return this.#info.form;
  }
  /** Number of frames. */
  get frameCount() {
    return Number(this.#info.frames);
  }
  /** Coefficients per frame (per vertex for a local fit): the actor's corrective count. */
  get shapeCount() {
    return Number(this.#info.shapes);
  }
  /** The content hash of the actor it was fitted to (16 hex digits). */
  get modelHash() {
    return this.#info.model;
  }
  /** Whether the file carries each frame's hash as baked. */
  get hasHashes() {
    return this.#info.hashes === "1";
  }

  /** Throws unless this performance was fitted to `model` (content hash and coefficient count). */
  check(model) {
    take(exports().sinew_performance_check(this._h, modelHandle(model)));
  }

  /** Frame `f`'s `{ head, jaw, coefficients }`; `coefficients` is null for a local fit. */
  frame(f) {
    const v = takeF32(exports().sinew_performance_frame(this._h, frameIndex(f)));
    return { head: v.subarray(0, 9), jaw: v.subarray(9, 18), coefficients: this.form === "local" ? null : v.subarray(18) };
  }

  /** Poses `model` (the actor it was fitted to) for frame `f`: positions, x y z per vertex. */
  pose(model, f) {
    return takeF32(exports().sinew_performance_pose(this._h, modelHandle(model), frameIndex(f)));
  }

  /** Frame `f` posed, its normals and its hash computed in the module (16 hex digits). */
  frameHash(model, f) {
    return takeText(exports().sinew_performance_hash(this._h, modelHandle(model), frameIndex(f)));
  }

  /** The hash baked for frame `f` (16 hex digits), or null when the file carries none. */
  expected(f) {
    return takeText(exports().sinew_performance_expected(this._h, frameIndex(f))) || null;
  }
}

/**
 * A validated Motion3DGAN generator (`sinew train motion`): a label and a seed become a landmark
 * curve, each of whose frames an S2D decoder turns into a dense face.
 */
export class Motion extends Handle {
  #info;
  #labels;

  /** Validates a `.sinew` motion generator; throws an Error saying what is wrong. */
  static load(bytes) {
    return new Motion(token, load(bytes, (w) => w.sinew_motion_load()));
  }

  constructor(key, handle) {
    super(key, handle);
    this.#info = keyValues(takeText(exports().sinew_info(handle)));
    this.#labels = takeText(exports().sinew_names(handle)).split("\n");
  }

  /** The labels' names in index order (`mouth_open`, …; `label_0` … when the file records none). */
  get labels() {
    return [...this.#labels];
  }
  /** Number of labels. */
  get labelCount() {
    return Number(this.#info.labels);
  }
  /** Frames of a motion after its neutral frame 0. */
  get frameCount() {
    return Number(this.#info.frames);
  }
  /** Landmarks it moves (the decoder's). */
  get landmarkCount() {
    return Number(this.#info.landmarks);
  }

  /**
   * The landmark curve of `label` (an index or a name) from `seed` (a non-negative integer or
   * BigInt below 2⁶⁴) on the S2D decoder `decoder`: `(frameCount + 1) · 3K` values, frame 0 the
   * neutral's landmarks. `intensity` (default 1) scales how far the motion goes; `neutral` is the
   * face to play on (default: the decoder's template).
   */
  curve(decoder, label, seed, { intensity = 1, neutral } = {}) {
    const index = this.#label(label);
    const s = seedOf(seed);
    const parts = [];
    if (neutral !== undefined && neutral !== null) parts.push(f32Bytes(floats(neutral, "neutral")));
    put(...parts);
    const low = Number(s & 0xffff_ffffn);
    const high = Number(s >> 32n);
    return takeF32(exports().sinew_motion_curve(this._h, modelHandle(decoder), index, low, high, intensity));
  }

  /** Frame `t` (0 to frameCount) of `curve` decoded onto `neutral` (default: the template). */
  frame(decoder, curve, t, neutral) {
    const c = floats(curve, "curve");
    const parts = [f32Bytes(c)];
    if (neutral !== undefined && neutral !== null) parts.push(f32Bytes(floats(neutral, "neutral")));
    put(...parts);
    return takeF32(exports().sinew_motion_frame(this._h, modelHandle(decoder), frameIndex(t), c.length));
  }

  /** Every frame 1 to frameCount of the sequence of `label` and `seed`, as `curve` and `frame`. */
  frames(decoder, label, seed, options = {}) {
    const c = this.curve(decoder, label, seed, options);
    const out = [];
    for (let t = 1; t <= this.frameCount; t++) out.push(this.frame(decoder, c, t, options.neutral));
    return out;
  }

  #label(label) {
    if (typeof label === "string") {
      const i = this.#labels.indexOf(label);
      if (i < 0) throw new RangeError(`sinew: unknown label "${label}" (labels: ${this.#labels.join(", ")})`);
      return i;
    }
    if (!Number.isInteger(label) || label < 0 || label > 0xffff_ffff) {
      throw new RangeError(`sinew: a label is a name or a non-negative integer, got ${label}`);
    }
    return label;
  }
}

/** A seed as a BigInt in [0, 2⁶⁴). */
function seedOf(seed) {
  if (typeof seed === "bigint" && seed >= 0n && seed < 1n << 64n) return seed;
  if (Number.isSafeInteger(seed) && seed >= 0) return BigInt(seed);
  throw new RangeError(`sinew: a seed is an integer from 0 below 2^64 (a BigInt above 2^53), got ${seed}`);
}

/**
 * A validated landmark driver (`sinew train driver`) bound to the AIM actor it was trained for:
 * one frame of a tracker's 68 landmarks becomes the actor's pose (head 9, jaw 9, coefficients),
 * the same bits as sinew-core computes on every target.
 */
export class Driver extends Handle {
  #info;

  /** Validates a `.sinew` landmark driver for `model`, the actor it was trained for; throws otherwise. */
  static load(bytes, model) {
    const m = modelHandle(model);
    return new Driver(token, load(bytes, (w) => w.sinew_driver_load(m)));
  }

  constructor(key, handle) {
    super(key, handle);
    this.#info = keyValues(takeText(exports().sinew_info(handle)));
  }

  /** "2d" (pixels through `Driver.pixels`) or "3d" (landmarks in the actor's unit and frame). */
  get space() {
    return this.#info.space;
  }
  /** Values of one frame's landmarks: 68 × 2 or 68 × 3. */
  get inputLength() {
    return Number(this.#info.inputs);
  }
  /** Values of a pose: head (9), jaw (9), then `shapeCount` coefficients. */
  get poseLength() {
    return Number(this.#info.pose);
  }
  /** The actor's coefficients. */
  get shapeCount() {
    return Number(this.#info.shapes);
  }
  /** The content hash of the actor it was trained for (16 hex digits). */
  get modelHash() {
    return this.#info.model;
  }

  /**
   * A tracker's 68 `[u, v]` pixels (136 values, v down) through the camera's intrinsics
   * `{ fx, fy, cx, cy }` (pixels): the landmarks a 2D driver reads.
   */
  static pixels(pixels, camera) {
    const k = Float32Array.of(camera.fx, camera.fy, camera.cx, camera.cy);
    const p = floats(pixels, "pixels");
    put(f32Bytes(p), f32Bytes(k));
    return takeF32(exports().sinew_driver_pixels(p.length));
  }

  /** One frame's landmarks (`inputLength` values) to the pose (`poseLength` values). */
  pose(landmarks) {
    put(f32Bytes(floats(landmarks, "landmarks")));
    return takeF32(exports().sinew_driver_pose(this._h));
  }

  /**
   * A One Euro filter over this driver's poses, `{ minCutoff, beta, dCutoff }` (Hz, a speed
   * coefficient, Hz; dCutoff 1 by default): `step(pose, time)` gives the pose smoothed at `time`
   * seconds, `reset()` starts again (the next step passes its frame through).
   */
  filter({ minCutoff, beta, dCutoff = 1 }) {
    return new DriverFilter(this, Float32Array.of(minCutoff, beta, dCutoff), Number(this.#info.state));
  }

  /**
   * Live driving from a real tracker on `model` (the driver's actor): the calibration on the
   * first found frames and the lost-frame rules (docs/FIT.md "Live driving"), its state kept
   * here. `settings`: `{ calibrateFrames, maxResidual, maxSpeed, maxTurn, reacquire }`, each
   * missing one the core's default (`Driver.liveDefaults`); a limit of 0 turns its rule off.
   */
  live(model, settings = {}) {
    modelHandle(model);
    const d = Driver.liveDefaults(0);
    const values = Float32Array.of(
      settings.calibrateFrames ?? d.calibrateFrames,
      settings.maxResidual ?? d.maxResidual,
      settings.maxSpeed ?? d.maxSpeed,
      settings.maxTurn ?? d.maxTurn,
      settings.reacquire ?? d.reacquire,
    );
    return new DriverLive(this, model, values, Number(this.#info.live));
  }

  /** The core's default live settings, calibrating on `calibrateFrames` frames. */
  static liveDefaults(calibrateFrames = 0) {
    if (!Number.isInteger(calibrateFrames) || calibrateFrames < 0) {
      throw new RangeError(`sinew: calibrateFrames is a whole number, got ${calibrateFrames}`);
    }
    const v = takeF32(exports().sinew_live_defaults(calibrateFrames));
    return { calibrateFrames: v[0], maxResidual: v[1], maxSpeed: v[2], maxTurn: v[3], reacquire: v[4] };
  }

  /** `model` (the driver's actor) posed by `pose`: positions, x y z per vertex. */
  play(model, pose) {
    const m = modelHandle(model);
    put(f32Bytes(floats(pose, "pose")));
    return takeF32(exports().sinew_driver_play(this._h, m));
  }

  /** The frame hash of `model` posed by `pose` (positions then normals), computed in the module. */
  frameHash(model, pose) {
    const m = modelHandle(model);
    put(f32Bytes(floats(pose, "pose")));
    return takeText(exports().sinew_driver_hash(this._h, m));
  }
}

/** What became of a frame of live driving, by the core's code. */
const OUTCOMES = ["driven", "calibrating", "missing", "lost-residual", "lost-jump"];

/** Live driving's state over one driver and its actor (`Driver.live`). */
class DriverLive {
  #driver;
  #model;
  #settings;
  #state;
  #calibrated = 0;
  #deviation = null;

  constructor(driver, model, settings, stateLength) {
    this.#driver = driver;
    this.#model = model;
    this.#settings = settings;
    this.#state = new Float32Array(stateLength);
  }

  /**
   * One frame: its landmarks (`inputLength` values, or `null` when the tracker found no face)
   * taken at `time` seconds. Returns `{ outcome, pose, residual }`: `outcome` is "calibrating"
   * (the pose is the rest pose), "driven", "missing", "lost-residual" or "lost-jump" (the last
   * pose held); `residual` the last found frame's, in face sizes.
   */
  step(landmarks, time) {
    const found = landmarks !== null && landmarks !== undefined;
    const l = found ? floats(landmarks, "landmarks") : new Float32Array(0);
    put(f32Bytes(this.#settings), f32Bytes(l), f32Bytes(this.#state));
    const out = takeF32(
      exports().sinew_driver_live(this.#driver._h, modelHandle(this.#model), time, found ? 1 : 0, l.length),
    );
    const p = this.#driver.poseLength;
    this.#calibrated = out[1];
    this.#deviation = out[2] < 0 ? null : out[2];
    this.#state = out.slice(4 + p);
    return { outcome: OUTCOMES[out[0]], pose: out.slice(4, 4 + p), residual: out[3] };
  }

  /** Found frames the calibration has taken. */
  get calibratedFrames() {
    return this.#calibrated;
  }
  /** Whether the calibration is complete (always, without one). */
  get calibrated() {
    return this.#calibrated >= this.#settings[0];
  }
  /** The calibration's deviation in face sizes once complete (`null` before or without one). */
  get deviation() {
    return this.#deviation;
  }

  /** Forgets every frame seen: the calibration starts again. */
  reset() {
    this.#state.fill(0);
    this.#calibrated = 0;
    this.#deviation = null;
  }
}

/** The One Euro filter's state over one driver's poses (`Driver.filter`). */
class DriverFilter {
  #driver;
  #settings;
  #state;

  constructor(driver, settings, stateLength) {
    this.#driver = driver;
    this.#settings = settings;
    this.#state = new Float32Array(stateLength);
  }

  /** `pose` smoothed at `time` seconds (each step's rate from the time stamps); a new array. */
  step(pose, time) {
    const p = floats(pose, "pose");
    put(f32Bytes(this.#settings), f32Bytes(p), f32Bytes(this.#state));
    const out = takeF32(exports().sinew_driver_filter(this.#driver._h, time, p.length));
    this.#state = out.slice(p.length);
    return out.slice(0, p.length);
  }

  /** Forgets every frame seen: the next step passes its frame through. */
  reset() {
    this.#state.fill(0);
  }
}

function modelHandle(model) {
  if (!(model instanceof Model)) throw new TypeError("sinew: a performance, a motion or a driver plays on a Model");
  return model._h;
}

/**
 * The hash of a frame (16 hex digits): the values of every array in order. `frameHash(positions,
 * normals)` is an AIM frame's hash in the f32 mode, `frameHash(vertices)` an S2D frame's.
 */
export function frameHash(...arrays) {
  put(...arrays.map((a, i) => f32Bytes(floats(a, `array ${i}`))));
  return takeText(exports().sinew_frame_hash());
}

/** The hash of a Q16 frame (16 hex digits): each raw Q16.16 value's 32 bits, as `poseQ16` gives them. */
export function frameHashQ16(values) {
  if (!(values instanceof Int32Array)) throw new TypeError("sinew: frameHashQ16 takes an Int32Array");
  put(new Uint8Array(values.buffer, values.byteOffset, values.byteLength));
  return takeText(exports().sinew_frame_hash_q16());
}
