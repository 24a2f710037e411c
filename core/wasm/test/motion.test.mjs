// The golden generated sequence through the JavaScript API: tests/data/motion-ict.sinew (a
// Motion3DGAN generator) with the S2D decoder s2d-ict.sinew, the label, seed and intensity that
// tests/data/motion-ict.hashes names, must decode in WebAssembly to frames hashing as that list
// says (the x86_64 host's sinew_core::sequence). Then the refusals a page can meet.
//
// Usage: bash core/wasm/build.sh && node --test core/wasm/test/
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";

import { init, InputError, Model, Motion, Replay, frameHash } from "../pkg/sinew.mjs";

const data = (name) => readFileSync(new URL(`../../../tests/data/${name}`, import.meta.url));

await init();

/** motion-ict.hashes: the `sequence NAME LABEL SEED INTENSITY` line and `motion T HASH` lines. */
function hashList() {
  let sequence = null;
  const frames = new Map();
  for (const line of data("motion-ict.hashes").toString("utf8").split("\n")) {
    const f = line.split(" ");
    if (f[0] === "sequence") {
      sequence = { name: f[1], label: Number(f[2]), seed: BigInt(f[3]), intensity: Number(f[4]) };
    } else if (f[0] === "motion") {
      frames.set(Number(f[1]), f[2]);
    }
  }
  assert.ok(sequence, "motion-ict.hashes names its sequence");
  return { sequence, frames };
}

test("motion-ict through s2d-ict: every frame hashes as motion-ict.hashes lists", () => {
  const decoder = Model.load(data("s2d-ict.sinew"));
  const motion = Motion.load(data("motion-ict.sinew"));
  const { sequence, frames } = hashList();
  assert.equal(motion.frameCount, frames.size);
  assert.equal(motion.landmarkCount, decoder.landmarkCount);
  assert.equal(motion.labels.length, motion.labelCount);
  assert.equal(motion.labels[sequence.label], sequence.name);
  const curve = motion.curve(decoder, sequence.label, sequence.seed, { intensity: sequence.intensity });
  assert.equal(curve.length, (motion.frameCount + 1) * 3 * motion.landmarkCount);
  for (const [t, want] of frames) {
    const vertices = motion.frame(decoder, curve, t);
    assert.equal(vertices.length, 3 * decoder.vertexCount);
    assert.equal(frameHash(vertices), want, `frame ${t} in motion-ict.hashes`);
  }
  // The same sequence by the label's name, a Number seed and all frames at once.
  const all = motion.frames(decoder, sequence.name, Number(sequence.seed), { intensity: sequence.intensity });
  assert.deepEqual(all.map((v) => frameHash(v)), [...frames.values()]);
  // Frame 0 is the neutral's landmarks; a curve frame decoded through the decoder's own path
  // (landmarkInput from frames 0 and t, then decode) is the same frame.
  const k3 = 3 * motion.landmarkCount;
  const t = 9;
  const direct = decoder.decodeLandmarks(curve.subarray(0, k3), curve.subarray(t * k3, (t + 1) * k3));
  assert.deepEqual(direct, motion.frame(decoder, curve, t));
  motion.free();
  decoder.free();
});

test("a sequence on another neutral moves that face", () => {
  const decoder = Model.load(data("s2d-ict.sinew"));
  const motion = Motion.load(data("motion-ict.sinew"));
  const neutral = Replay.load(data("s2d-ict.replay.sinew")).neutral;
  const onTemplate = motion.frames(decoder, 3, 11, { intensity: 0.5 });
  const onNeutral = motion.frames(decoder, 3, 11, { intensity: 0.5, neutral });
  assert.equal(onNeutral.length, motion.frameCount);
  assert.notDeepEqual(onNeutral[0], onTemplate[0]);
  // Frame 0 is no motion: the decoder's output for no displacement, decoded onto the neutral.
  const curve = motion.curve(decoder, 3, 11, { intensity: 0.5, neutral });
  const k3 = 3 * motion.landmarkCount;
  const still = decoder.decodeLandmarks(curve.subarray(0, k3), curve.subarray(0, k3), neutral);
  assert.deepEqual(motion.frame(decoder, curve, 0, neutral), still);
  // The curve starts at the neutral's own landmarks.
  const vertices = decoder.landmarkVertices();
  for (let i = 0; i < vertices.length; i++) {
    for (let c = 0; c < 3; c++) assert.equal(curve[3 * i + c], neutral[3 * vertices[i] + c]);
  }
});

test("generators, labels, seeds and frames are checked", () => {
  const decoder = Model.load(data("s2d-ict.sinew"));
  const actor = Model.load(data("aim-procedural.sinew"));
  const motion = Motion.load(data("motion-ict.sinew"));
  assert.throws(() => Motion.load(data("s2d-ict.sinew")), {
    message: "the artefact is of another kind than expected (an S2D decoder, not a motion generator)",
  });
  assert.throws(() => Model.load(data("motion-ict.sinew")), { message: /\(a motion generator; a model is/ });
  assert.throws(() => motion.curve(actor, 0, 1), {
    message: "a motion plays on an S2D decoder, this model is an AIM actor",
  });
  assert.throws(() => motion.curve(decoder, motion.labelCount, 1), {
    message: `label ${motion.labelCount} is past the generator's ${motion.labelCount} labels`,
  });
  assert.throws(() => motion.curve(decoder, "yawn", 1), RangeError);
  assert.throws(() => motion.curve(decoder, 0, -1), RangeError);
  assert.throws(() => motion.curve(decoder, 0, 2 ** 60), RangeError);
  assert.throws(() => motion.curve(decoder, 0, 1, { intensity: NaN }), (e) => {
    assert.ok(e instanceof InputError);
    assert.equal(e.message, "intensity[0] is NaN or infinite");
    assert.equal(e.argument, "intensity");
    return true;
  });
  const neutral = new Float32Array(3 * decoder.vertexCount);
  neutral[7] = 3e5;
  assert.throws(() => motion.curve(decoder, 0, 1, { neutral }), {
    name: "InputError",
    message: "neutral[7] is outside ±1e5",
  });
  assert.throws(() => motion.curve(decoder, 0, 1, { neutral: neutral.subarray(3) }), {
    message: `neutral has ${neutral.length - 3} values, expected ${neutral.length}`,
  });
  // A seed above 2^53 as a BigInt is a seed like any other.
  assert.equal(motion.curve(decoder, 0, (1n << 64n) - 1n).length, (motion.frameCount + 1) * 3 * motion.landmarkCount);
  const curve = motion.curve(decoder, 0, 1);
  const past = motion.frameCount + 1;
  assert.throws(() => motion.frame(decoder, curve, past), {
    message: `frame ${past} is past the motion's ${motion.frameCount} frames`,
  });
  assert.throws(() => motion.frame(decoder, curve.subarray(1), 1), { message: /^curve has \d+ values, expected \d+$/ });
  const bad = Float32Array.from(curve);
  const at = 3 * motion.landmarkCount + 4;
  bad[at] = Infinity;
  assert.throws(() => motion.frame(decoder, bad, 1), {
    name: "InputError",
    message: `curve[${at}] is NaN or infinite`,
  });
  assert.throws(() => motion.frame(decoder, curve, 1.5), RangeError);
  assert.throws(() => motion.frame("s2d-ict.sinew", curve, 1), TypeError);
  motion.free();
  assert.throws(() => motion.curve(decoder, 0, 1), {
    message: "handle 0 is not a live model, replay, performance, motion generator or driver",
  });
});
