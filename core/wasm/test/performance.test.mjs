// The golden fitted performance through the JavaScript API: tests/data/fit-ict.sinew played on
// aim-ict.sinew in WebAssembly must hash, frame by frame, as baked into the file and as listed
// in tests/data/fit-ict.hashes (the x86_64 host's sinew_core::performance::play_frame_hash). Then the
// refusals a page can meet.
//
// Usage: bash core/wasm/build.sh && node --test core/wasm/test/
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";

import { init, Model, Performance, Replay, frameHash } from "../pkg/sinew.mjs";

const data = (name) => readFileSync(new URL(`../../../tests/data/${name}`, import.meta.url));

await init();

/** fit-ict.hashes: "frame hash" lines after a comment. */
function hashList() {
  const out = [];
  for (const line of data("fit-ict.hashes").toString("utf8").split("\n")) {
    if (line.startsWith("#") || line === "") continue;
    const [f, h] = line.split(" ");
    out[Number(f)] = h;
  }
  assert.ok(out.length > 0, "fit-ict.hashes lists no frames");
  return out;
}

test("fit-ict on aim-ict: every frame hashes as baked and as fit-ict.hashes lists", () => {
  const model = Model.load(data("aim-ict.sinew"));
  const perf = Performance.load(data("fit-ict.sinew"));
  perf.check(model);
  assert.equal(perf.modelHash, model.hash);
  assert.equal(perf.shapeCount, model.shapeCount);
  assert.ok(perf.form === "global" || perf.form === "local");
  assert.equal(perf.hasHashes, true);
  const list = hashList();
  assert.equal(perf.frameCount, list.length);
  for (let f = 0; f < perf.frameCount; f++) {
    const positions = perf.pose(model, f);
    assert.equal(positions.length, 3 * model.vertexCount);
    const hash = frameHash(positions, model.normals(positions));
    assert.equal(hash, list[f], `frame ${f} in fit-ict.hashes`);
    assert.equal(hash, perf.expected(f), `frame ${f} as baked`);
    assert.equal(perf.frameHash(model, f), hash, `frame ${f} hashed in the module`);
    const { head, jaw, coefficients } = perf.frame(f);
    assert.equal(head.length, 9);
    assert.equal(jaw.length, 9);
    if (perf.form === "global") {
      // A global frame is the actor posed with the frame's row of coefficients.
      assert.equal(coefficients.length, model.shapeCount);
      assert.deepEqual(model.pose(head, jaw, coefficients), positions);
    } else {
      assert.equal(coefficients, null);
    }
  }
  perf.free();
  model.free();
});

test("a performance is refused on another actor, an S2D decoder and as another kind", () => {
  const perf = Performance.load(data("fit-ict.sinew"));
  const other = Model.load(data("aim-procedural.sinew"));
  const message = `performance was fitted to the actor ${perf.modelHash}, this model is ${other.hash}`;
  assert.throws(() => perf.check(other), { name: "Error", message });
  assert.throws(() => perf.pose(other, 0), { message });
  assert.throws(() => perf.frameHash(other, 0), { message });
  const s2d = Model.load(data("s2d-ict.sinew"));
  assert.throws(() => perf.check(s2d), { message: "a performance plays on an AIM actor, this model is an S2D decoder" });
  assert.throws(() => Performance.load(data("aim-ict.f32.replay.sinew")), {
    message: "the artefact is of another kind than expected (a replay, not a fitted performance)",
  });
  assert.throws(() => Model.load(data("fit-ict.sinew")), { message: /\(a fitted performance; a model is/ });
  assert.throws(() => Replay.load(data("fit-ict.sinew")), { message: /\(a fitted performance, not a replay\)/ });
  const bytes = data("fit-ict.sinew");
  assert.throws(() => Performance.load(bytes.subarray(0, 200)), {
    message: `header says the file is ${bytes.length} bytes, but it is 200 bytes (truncated or padded)`,
  });
});

test("frame indices, handles and argument types are checked", () => {
  const model = Model.load(data("aim-ict.sinew"));
  const perf = Performance.load(data("fit-ict.sinew"));
  const n = perf.frameCount;
  assert.throws(() => perf.pose(model, n), { message: `frame ${n} is past the end of the performance (${n} frames)` });
  assert.throws(() => perf.expected(n), { message: /past the end/ });
  assert.throws(() => perf.frame(-1), RangeError);
  assert.throws(() => perf.pose(model, 0.5), RangeError);
  assert.throws(() => perf.pose("aim-ict.sinew", 0), TypeError);
  // A replay's handle is not a model.
  const replay = Replay.load(data("aim-ict.f32.replay.sinew"));
  assert.throws(() => perf.check(replay), TypeError);
  model.free();
  assert.throws(() => perf.pose(model, 0), { message: "handle 0 is not a live model, replay, performance, motion generator or driver" });
  perf.free();
  assert.throws(() => perf.frame(0), { message: "handle 0 is not a live model, replay, performance, motion generator or driver" });
});
