// Values the core refuses instead of guessing (issue #37), through the JavaScript API: each is
// thrown as an InputError naming the argument as this API calls it and the value's index, and
// nothing is computed. A file whose checksums are valid but whose numbers are out of bounds is
// refused at load, naming the section and the value.
//
// Usage: bash core/wasm/build.sh && node --test core/wasm/test/
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";

import { init, InputError, Model, Replay } from "../pkg/sinew.mjs";

const data = (name) => readFileSync(new URL(`../../../tests/data/${name}`, import.meta.url));

await init();

const ID = [1, 0, 0, 0, 1, 0, 0, 0, 0];
const withValue = (array, i, v) => {
  const out = Array.from(array);
  out[i] = v;
  return out;
};

/** Asserts that `call` throws an InputError about `argument`'s value `index` whose message starts with `start`. */
function refuses(call, argument, index, start) {
  assert.throws(call, (e) => {
    assert.ok(e instanceof InputError, `${e}`);
    assert.ok(e instanceof Error);
    assert.equal(e.name, "InputError");
    assert.equal(e.argument, argument);
    assert.equal(e.index, index);
    assert.ok(e.message.startsWith(start), `${JSON.stringify(e.message)} should start with ${JSON.stringify(start)}`);
    return true;
  });
}

test("AIM: NaN, infinite, huge and degenerate heads, jaws and coefficients are refused by index", () => {
  const aim = Model.load(data("aim-procedural.sinew"));
  const w = new Float32Array(aim.shapeCount);
  refuses(() => aim.pose(withValue(ID, 3, NaN), ID, w), "head", 3, "head[3] is NaN or infinite");
  refuses(() => aim.pose(ID, withValue(ID, 1, Infinity), w), "jaw", 1, "jaw[1] is NaN or infinite");
  refuses(() => aim.pose(withValue(ID, 7, NaN), ID, w), "head", 7, "head[7] is NaN or infinite");
  refuses(() => aim.pose(new Array(9).fill(0), ID, w), "head", 0, "head[0..3], the 6D rotation's first column, is shorter than 1e-6");
  refuses(() => aim.pose(ID, [1, 2, 3, 2, 4, 6, 0, 0, 0], w), "jaw", 3, "jaw[3..6], the 6D rotation's second column");
  refuses(() => aim.pose(ID.map((x) => x * 1e20), ID, w), "head", 0, "head[0] is outside ±1e6");
  refuses(() => aim.pose(ID, withValue(ID, 6, 2e5), w), "jaw", 6, "jaw[6] is outside ±1e5");
  refuses(() => aim.pose(ID, ID, withValue(w, 2, NaN)), "coefficients", 2, "coefficients[2] is NaN or infinite");
  refuses(() => aim.pose(ID, ID, withValue(w, 0, -5e3)), "coefficients", 0, "coefficients[0] is outside ±1e3");
  const positions = aim.pose(ID, ID, w);
  refuses(() => aim.normals(withValue(positions, 10, NaN)), "positions", 10, "positions[10] is NaN or infinite");
  // After a refusal, other failures are plain Errors again, and valid calls work.
  assert.throws(() => aim.normals(new Float32Array(5)), (e) => !(e instanceof InputError) && e instanceof Error);
  assert.ok(aim.normals(positions).every(Number.isFinite));
});

test("S2D: refused inputs, neutrals and landmark sets are named as this API names them", () => {
  const s2d = Model.load(data("s2d-ict.sinew"));
  const input = new Float32Array(s2d.inputLength);
  refuses(() => s2d.decode(withValue(input, 17, NaN)), "input", 17, "input[17] is NaN or infinite");
  refuses(() => s2d.decode(withValue(input, 5, 2e3)), "input", 5, "input[5] is outside ±1e3");
  const neutral = s2d.neutral();
  refuses(() => s2d.decode(input, withValue(neutral, 30, -Infinity)), "neutral", 30, "neutral[30] is NaN or infinite");
  const landmarks = Array.from({ length: s2d.inputLength }, (_, i) => i % 5);
  const same = new Float32Array(s2d.inputLength).fill(1);
  refuses(() => s2d.landmarkInput(same, landmarks), "neutralLandmarks", 0, "neutralLandmarks: the landmarks all coincide");
  refuses(() => s2d.landmarkInput(landmarks, same), "landmarks", 0, "landmarks: the landmarks all coincide");
  refuses(() => s2d.landmarkInput(landmarks, withValue(landmarks, 4, NaN)), "landmarks", 4, "landmarks[4] is NaN or infinite");
});

/** CRC-32/ISO-HDLC, the format's checksum. */
function crc32(bytes) {
  let c = ~0;
  for (const b of bytes) {
    c ^= b;
    for (let k = 0; k < 8; k++) c = (c >>> 1) ^ (0xedb88320 & -(c & 1));
  }
  return ~c >>> 0;
}

/** A copy of a valid file with value `index` of f32 section `name` set to `value`, its checksums recomputed. */
function withF32(bytes, name, index, value) {
  return resealed(bytes, (entry, view, offset) => {
    if (entry === name) view.setFloat32(offset + 4 * index, value, true);
  });
}

/** A copy of a valid file with the text `from` replaced by `to` (as long), its checksums recomputed. */
function withText(bytes, from, to) {
  assert.equal(from.length, to.length);
  const at = Buffer.from(bytes).indexOf(from);
  assert.ok(at >= 0, `no ${from}`);
  return resealed(bytes, (entry, view) => {
    if (entry === "meta") new Uint8Array(view.buffer).set(new TextEncoder().encode(to), at);
  });
}

/** A copy of a valid file, `edit(name, view, offset)` called on each section before its checksum is recomputed. */
function resealed(bytes, edit) {
  const out = new Uint8Array(bytes);
  const view = new DataView(out.buffer);
  const count = view.getUint32(20, true);
  for (let i = 0; i < count; i++) {
    const e = 32 + 64 * i;
    const entry = new TextDecoder().decode(out.subarray(e + 4, e + 36)).replace(/\0+$/, "");
    const offset = view.getUint32(e + 52, true);
    const length = view.getUint32(e + 56, true);
    edit(entry, view, offset);
    view.setUint32(e + 60, crc32(out.subarray(offset, offset + length)), true);
  }
  const header = new Uint8Array([...out.subarray(0, 28), ...out.subarray(32, 32 + 64 * count)]);
  view.setUint32(28, crc32(header), true);
  return out;
}

test("a file whose checksums are valid but whose cache holds 3.4e38 is refused at load", () => {
  const bytes = data("aim-procedural.sinew");
  // An edit within bounds loads: the checksums are recomputed right.
  assert.ok(Model.load(withF32(bytes, "cache.e", 7, 0)));
  assert.throws(() => Model.load(withF32(bytes, "cache.e", 7, 3.4e38)), (e) => {
    assert.ok(!(e instanceof InputError));
    assert.equal(e.message, "section cache.e: value 7 is outside ±1e5, the limit of a length");
    return true;
  });
  assert.throws(() => Model.load(withF32(bytes, "cache.s0", 5, NaN)), {
    message: "section cache.s0: value 5 is NaN or infinite",
  });
});

test("a load error names the metadata line or the section at fault", () => {
  const replay = data("aim-procedural.f32.replay.sinew");
  assert.ok(Replay.load(withText(replay, "mode=f32", "mode=f32")));
  assert.throws(() => Replay.load(withText(replay, "mode=f32", "mode=f64")), {
    message: "metadata line 1: mode has a value this artefact does not take",
  });
  assert.throws(() => Replay.load(withText(replay, "frames=", "frames ")), {
    message: "metadata line 3 is not UTF-8 key=value text",
  });
});

