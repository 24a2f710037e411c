// Types of sinew.mjs, Sinew's face models in JavaScript. Reference: docs/WASM.md.
//
// Every failure is thrown: an `Error` whose message is sinew-core's (e.g. "header says the file
// is 81008 bytes, but it is 1000 bytes (truncated or padded)"), an `InputError` for a value the
// core refuses (e.g. "head[3] is NaN or infinite"), a `TypeError` for an argument of the wrong
// type, a `RangeError` for a frame index that is not a non-negative integer.

/** Bytes of a `.sinew` file: an ArrayBuffer or any typed array (node's Buffer included). */
export type Bytes = ArrayBuffer | ArrayBufferView;
/** `f32` values; an array of numbers is converted. */
export type Floats = Float32Array | ArrayLike<number>;

/**
 * Instantiates the WebAssembly module once; every other call needs it. `source`: the module's
 * URL (default: `sinew_wasm.wasm` beside sinew.mjs; `file:` URLs are read with node:fs), a
 * Response, its bytes, or a compiled WebAssembly.Module.
 */
export function init(source?: string | URL | Response | Bytes | WebAssembly.Module): Promise<void>;

/**
 * A value the core refuses instead of guessing: NaN, infinite, outside its range (a 6D
 * rotation's values ±1e6, translations and coordinates ±1e5, coefficients and decoder inputs
 * ±1e3), or degenerate (a rotation's column shorter than 1e-6 or parallel to the other,
 * landmarks that all coincide). Nothing is computed then.
 */
export class InputError extends Error {
  readonly name: "InputError";
  /** The parameter's name in this API: `head`, `jaw`, `coefficients`, `positions`, `input`, `neutral`, `neutralLandmarks`, `landmarks`, `pixels`, `camera`, `filter`, `time`. */
  readonly argument: string;
  /** The value's index in it; for a degenerate 6D rotation its column's first index (0 or 3). */
  readonly index: number;
}

/** A validated AIM actor or S2D decoder. */
export class Model {
  private constructor();
  /** Validates a `.sinew` model (AIM actor or S2D decoder). */
  static load(bytes: Bytes): Model;
  readonly kind: "aim" | "s2d";
  /** Vertices of the output mesh. */
  readonly vertexCount: number;
  /** Coefficients per pose (corrective shapes) of an AIM actor; 0 for an S2D decoder. */
  readonly shapeCount: number;
  /** Values of an S2D decoder's input (3 per landmark); 0 for an AIM actor. */
  readonly inputLength: number;
  /** Landmarks of an S2D decoder's input; 0 for an AIM actor. */
  readonly landmarkCount: number;
  /** Triangles of an AIM actor's template; 0 for an S2D decoder (its file has no faces). */
  readonly triangleCount: number;
  /** Content hash of the model's bytes, 16 hex digits; a replay names it. */
  readonly hash: string;
  /** Metadata (`units`, `axes`, provenance). */
  readonly metadata: Record<string, string>;
  /** The length unit of positions (`cm` for the ICT actors), or null if the file records none. */
  readonly units: string | null;
  /** The axes' directions (e.g. `x-left-of-actor,y-up,z-forward`), or null if the file records none. */
  readonly axes: string | null;
  /**
   * AIM: `[shapeCount]` the corrective shapes' names in coefficient order (sliders, morph
   * targets): the recorded training shapes without the neutral, or `shape_1` … when the file
   * records none. Empty for an S2D decoder.
   */
  shapeNames(): string[];
  /** `[triangleCount * 3]` vertex indices, counter-clockwise (empty for an S2D decoder). */
  triangles(): Uint32Array;
  /** `[landmarkCount]` the vertex of each input landmark (empty for an AIM actor). */
  landmarkVertices(): Uint32Array;
  /** `[vertexCount * 3]` an AIM actor's neutral skin, an S2D decoder's template. */
  neutral(): Float32Array;
  /** AIM: `[vertexCount]` the soft-tissue thickness at each vertex, in the actor's unit. */
  thickness(): Float32Array;
  /**
   * AIM: `[vertexCount * 3]` posed positions. `head`, `jaw`: 9 values each (6D rotation, then
   * translation; the jaw about the actor's pivot); `coefficients`: `[shapeCount]`.
   */
  pose(head: Floats, jaw: Floats, coefficients: Floats): Float32Array;
  /** The jaw of a pose given by coefficients alone: the shapes' learned jaws blended, within their range (9 values). */
  jawFromWeights(coefficients: Floats): Float32Array;
  /**
   * AIM: `[vertexCount * 3]` posed positions in Q16.16 fixed point, as raw values (value × 65536):
   * the Q16 replays' mode (needs the actor's Q16.16 cache). `frameHashQ16` of them is the frame's
   * Q16 hash.
   */
  poseQ16(head: Floats, jaw: Floats, coefficients: Floats): Int32Array;
  /**
   * AIM: the fast mode's frame: `pose`'s positions and normals normalised with micromath's
   * approximate inverse square root, `[vertexCount * 3]` each. `frameHash(positions, normals)` is
   * the frame's fast hash.
   */
  poseFast(head: Floats, jaw: Floats, coefficients: Floats): { positions: Float32Array; normals: Float32Array };
  /** AIM: `[vertexCount * 3]` area-weighted unit normals of posed positions. */
  normals(positions: Floats): Float32Array;
  /** S2D: the decoder's `[inputLength]` input from `[landmarkCount * 3]` neutral and expressive landmarks. */
  landmarkInput(neutralLandmarks: Floats, landmarks: Floats): Float32Array;
  /** S2D: `[vertexCount * 3]` vertices, decoded onto `neutral` (same topology) or the template. */
  decode(input: Floats, neutral?: Floats | null): Float32Array;
  /** S2D: `decode(landmarkInput(neutralLandmarks, landmarks), neutral)`. */
  decodeLandmarks(neutralLandmarks: Floats, landmarks: Floats, neutral?: Floats | null): Float32Array;
  /** Frees the model's memory in the module now (otherwise when it is garbage-collected). */
  free(): void;
}

/** One frame of an AIM replay. */
export interface AimFrame {
  head: Float32Array;
  jaw: Float32Array;
  coefficients: Float32Array;
}

/** One frame of an S2D replay: the decoder's input. */
export interface S2dFrame {
  input: Float32Array;
}

/** A validated replay: per-frame inputs and the hash recorded for each frame. */
export class Replay {
  private constructor();
  /** Validates a `.sinew` replay. */
  static load(bytes: Bytes): Replay;
  readonly kind: "aim" | "s2d";
  /** The numeric mode it was recorded in (S2D replays are all "f32"); play "q16" frames with `poseQ16`, "fast" with `poseFast`. */
  readonly mode: "f32" | "q16" | "fast";
  readonly frameCount: number;
  /** Content hash of the model it was recorded with, 16 hex digits. */
  readonly modelHash: string;
  /** `[vertexCount * 3]` the neutral an S2D replay decodes onto, or null (the template). */
  readonly neutral: Float32Array | null;
  /** Frame `f`'s inputs (`0 <= f < frameCount`). */
  frame(f: number): AimFrame | S2dFrame;
  /** The hash recorded for frame `f`, 16 hex digits. */
  expected(f: number): string;
  /** Throws unless this replay was recorded with `model` (content hash and sizes). */
  check(model: Model): void;
  free(): void;
}

/** One frame of a fitted performance. */
export interface PerformanceFrame {
  head: Float32Array;
  jaw: Float32Array;
  /** `[shapeCount]` for a global fit; null for a local fit (its coefficients vary per vertex). */
  coefficients: Float32Array | null;
}

/** A validated fitted performance (`sinew fit --out FIT.sinew`), played on its AIM actor. */
export class Performance {
  private constructor();
  /** Validates a `.sinew` fitted performance. */
  static load(bytes: Bytes): Performance;
  /** "global": one coefficient vector per frame; "local": coefficients per vertex (AIM eq. 19). */
  readonly form: "global" | "local";
  readonly frameCount: number;
  /** Coefficients per frame (per vertex for a local fit): the actor's corrective count. */
  readonly shapeCount: number;
  /** Content hash of the actor it was fitted to, 16 hex digits. */
  readonly modelHash: string;
  /** Whether the file carries each frame's hash as baked. */
  readonly hasHashes: boolean;
  /** Throws unless this performance was fitted to `model` (content hash and coefficient count). */
  check(model: Model): void;
  /** Frame `f`'s head, jaw and (global fit) coefficients (`0 <= f < frameCount`). */
  frame(f: number): PerformanceFrame;
  /** `[vertexCount * 3]` `model` posed for frame `f`; throws unless fitted to `model`. */
  pose(model: Model, f: number): Float32Array;
  /** Frame `f` posed, normals and hash computed in the module: sinew-core's `performance::play_frame_hash`. */
  frameHash(model: Model, f: number): string;
  /** The hash baked for frame `f`, 16 hex digits, or null when the file carries none. */
  expected(f: number): string | null;
  free(): void;
}

/** A pinhole camera's intrinsics in pixels. */
export interface Intrinsics {
  fx: number;
  fy: number;
  cx: number;
  cy: number;
}

/** The One Euro filter's settings (Casiez et al. 2012). */
export interface FilterSettings {
  /** The cutoff of a still signal, Hz (above 0): lower smooths more. */
  minCutoff: number;
  /** How fast the cutoff rises with the speed (0 or more): higher lags less. */
  beta: number;
  /** The cutoff of the speed's low-pass, Hz (above 0); 1 by default. */
  dCutoff?: number;
}

/** The One Euro filter's state over one driver's poses. */
export interface DriverFilter {
  /**
   * `pose` smoothed at `time` seconds (a new array; each step's rate is 1 / the time since the
   * last step; the first step after a reset passes through). Throws an `InputError` naming
   * `time` for a stamp less than 1 ms after the last, `filter` for a bad setting.
   */
  step(pose: Floats, time: number): Float32Array;
  /** Forgets every frame seen. */
  reset(): void;
}

/** Live driving's settings (sinew-core's `live::Settings`); a limit of 0 turns its rule off. */
export interface LiveSettings {
  /** Found frames taken as the face at rest looking at the camera (0: no calibration; at most 1000). */
  calibrateFrames?: number;
  /** The largest residual of a found frame, in face sizes in the image (default 0.2). */
  maxResidual?: number;
  /** The fastest the face's centre moves, face sizes a second (default 40). */
  maxSpeed?: number;
  /** The fastest the head turns, radians a second (default 8). */
  maxTurn?: number;
  /** Seconds after which a run of jumps is the head's real motion (default 0.5). */
  reacquire?: number;
}

/** What became of a frame of live driving. */
export type LiveOutcome = "driven" | "calibrating" | "missing" | "lost-residual" | "lost-jump";

/** Live driving's state over one driver and its actor (`Driver.live`). */
export interface DriverLive {
  /**
   * One frame: its landmarks (or `null`: no face) at `time` seconds. `pose` is the pose to play
   * (the rest pose while calibrating, the last accepted one when lost or missing); `residual` the
   * last found frame's, in face sizes. Throws an `InputError` naming `settings`, `time` or
   * `landmarks`; nothing changes then.
   */
  step(landmarks: Floats | null, time: number): { outcome: LiveOutcome; pose: Float32Array; residual: number };
  /** Found frames the calibration has taken. */
  readonly calibratedFrames: number;
  /** Whether the calibration is complete. */
  readonly calibrated: boolean;
  /** The calibration's deviation in face sizes once complete, else `null`. */
  readonly deviation: number | null;
  /** Forgets every frame seen: the calibration starts again. */
  reset(): void;
}

/**
 * A validated landmark driver (`sinew train driver`) bound to the AIM actor it was trained for:
 * one frame of a tracker's 68 landmarks to the actor's pose, sinew-core's `Driver::drive`.
 */
export class Driver {
  private constructor();
  /** Validates a `.sinew` landmark driver for `model`, the actor it was trained for (content hash). */
  static load(bytes: Bytes, model: Model): Driver;
  /** `[136]` a tracker's 68 `[u, v]` pixels through the camera: a 2D driver's landmarks. */
  static pixels(pixels: Floats, camera: Intrinsics): Float32Array;
  readonly space: "2d" | "3d";
  /** Values of one frame's landmarks: 136 (2D) or 204 (3D). */
  readonly inputLength: number;
  /** Values of a pose: head 9 (6D rotation, translation), jaw 9, then shapeCount coefficients. */
  readonly poseLength: number;
  readonly shapeCount: number;
  /** Content hash of the actor it was trained for, 16 hex digits. */
  readonly modelHash: string;
  /** `[poseLength]` the pose of one frame's landmarks; an `InputError` naming `landmarks` for a NaN. */
  pose(landmarks: Floats): Float32Array;
  /** A One Euro filter over this driver's poses. */
  filter(settings: FilterSettings): DriverFilter;
  /** Live driving on `model` (the driver's actor): calibration and lost-frame rules. */
  live(model: Model, settings?: LiveSettings): DriverLive;
  /** The core's default live settings, calibrating on `calibrateFrames` frames. */
  static liveDefaults(calibrateFrames?: number): Required<LiveSettings>;
  /** `[vertexCount * 3]` `model` (the driver's actor) posed by `pose`. */
  play(model: Model, pose: Floats): Float32Array;
  /** The frame hash of `model` posed by `pose`: positions then normals (sinew-core's `driver::pose_hash`). */
  frameHash(model: Model, pose: Floats): string;
  free(): void;
}

/** Options of a generated motion. */
export interface MotionOptions {
  /** How far the motion goes, 1 (the default) as its label's training motions. */
  intensity?: number;
  /** `[vertexCount * 3]` the face to play on, in the decoder's topology (default: its template). */
  neutral?: Floats | null;
}

/**
 * A validated Motion3DGAN generator (`sinew train motion`): a label and a seed become a landmark
 * curve, each frame of which an S2D decoder (a `Model` of kind "s2d") turns into a dense face.
 */
export class Motion {
  private constructor();
  /** Validates a `.sinew` motion generator. */
  static load(bytes: Bytes): Motion;
  /** The labels' names in index order (`mouth_open`, …). */
  readonly labels: string[];
  readonly labelCount: number;
  /** Frames of a motion after its neutral frame 0. */
  readonly frameCount: number;
  /** Landmarks it moves (the decoder's landmarkCount). */
  readonly landmarkCount: number;
  /**
   * `[(frameCount + 1) * landmarkCount * 3]` the landmark curve of `label` (index or name) from
   * `seed` (an integer from 0 below 2⁶⁴; a BigInt above 2⁵³), frame 0 the neutral's landmarks.
   */
  curve(decoder: Model, label: number | string, seed: number | bigint, options?: MotionOptions): Float32Array;
  /** `[vertexCount * 3]` frame `t` (0 to frameCount) of `curve` decoded onto `neutral` or the template. */
  frame(decoder: Model, curve: Floats, t: number, neutral?: Floats | null): Float32Array;
  /** Frames 1 to frameCount of the sequence of `label` and `seed`, each `[vertexCount * 3]`. */
  frames(decoder: Model, label: number | string, seed: number | bigint, options?: MotionOptions): Float32Array[];
  free(): void;
}

/** The hash of a Q16 frame, 16 hex digits: each raw Q16.16 value's 32 bits (`poseQ16`'s output). */
export function frameHashQ16(values: Int32Array): string;

/**
 * A frame's hash, 16 hex digits: the values of every array in order. `frameHash(positions,
 * normals)` equals sinew-core's `hash::posed_frame_hash` (an f32 frame's), `frameHash(vertices)`
 * its `hash::frame_hash` (an S2D frame's).
 */
export function frameHash(...arrays: Floats[]): string;
