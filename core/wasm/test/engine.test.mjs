// What an engine binds and renders, through the JavaScript API: the ICT actor's units, axes,
// content hash and corrective shapes' names against the metadata the core parses (and that
// `sinew inspect --json` prints), and every frame of the golden Q16 and fast replays posed by
// poseQ16 and poseFast hashing as recorded.
//
// Usage: bash core/wasm/build.sh && node --test core/wasm/test/
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";

import { init, InputError, Model, Replay, frameHash, frameHashQ16 } from "../pkg/sinew.mjs";

const data = (name) => readFileSync(new URL(`../../../tests/data/${name}`, import.meta.url));

await init();

test("the ICT actor's units, axes, hash and shape names", () => {
  const actor = Model.load(data("aim-ict.sinew"));
  const meta = actor.metadata;
  assert.equal(actor.units, meta.units);
  assert.equal(actor.units, "cm");
  assert.equal(actor.axes, meta.axes);
  assert.ok(actor.axes.includes("y-up"), actor.axes);
  // The replays of this actor name its content hash.
  assert.equal(actor.hash, Replay.load(data("aim-ict.f32.replay.sinew")).modelHash);
  const recorded = meta.shapes.split(",");
  assert.equal(recorded[0], "neutral");
  assert.deepEqual(actor.shapeNames(), recorded.slice(1));
  assert.equal(actor.shapeNames().length, actor.shapeCount);
  // An actor that records no names gets glTF export's; a decoder has none.
  const procedural = Model.load(data("aim-procedural.sinew"));
  assert.equal(procedural.metadata.shapes, undefined);
  assert.deepEqual(
    procedural.shapeNames(),
    Array.from({ length: procedural.shapeCount }, (_, i) => `shape_${i + 1}`),
  );
  assert.equal(procedural.axes, null);
  const decoder = Model.load(data("s2d-ict.sinew"));
  assert.deepEqual(decoder.shapeNames(), []);
  assert.equal(decoder.units, "cm");
});

for (const name of ["aim-procedural", "aim-ict"]) {
  test(`${name}: every q16 and fast replay frame posed by poseQ16 and poseFast hashes as recorded`, () => {
    const actor = Model.load(data(`${name}.sinew`));
    for (const mode of ["q16", "fast"]) {
      const replay = Replay.load(data(`${name}.${mode}.replay.sinew`));
      replay.check(actor);
      assert.equal(replay.mode, mode);
      for (let f = 0; f < replay.frameCount; f++) {
        const { head, jaw, coefficients } = replay.frame(f);
        let hash;
        if (mode === "q16") {
          const q = actor.poseQ16(head, jaw, coefficients);
          assert.ok(q instanceof Int32Array && q.length === 3 * actor.vertexCount);
          hash = frameHashQ16(q);
        } else {
          const { positions, normals } = actor.poseFast(head, jaw, coefficients);
          // The fast mode's positions are the f32 mode's; only the normals differ.
          assert.deepEqual(positions, actor.pose(head, jaw, coefficients));
          hash = frameHash(positions, normals);
        }
        assert.equal(hash, replay.expected(f), `${name} ${mode} frame ${f}`);
      }
    }
  });
}

test("poseQ16 and poseFast refuse as pose refuses", () => {
  const actor = Model.load(data("aim-procedural.sinew"));
  const identity = [1, 0, 0, 0, 1, 0, 0, 0, 0];
  const w = new Float32Array(actor.shapeCount);
  const head = [...identity];
  head[2] = NaN;
  for (const call of ["poseQ16", "poseFast"]) {
    assert.throws(() => actor[call](head, identity, w), (e) => {
      assert.ok(e instanceof InputError);
      assert.equal(e.message, "head[2] is NaN or infinite");
      assert.deepEqual([e.argument, e.index], ["head", 2]);
      return true;
    });
    assert.throws(() => actor[call](identity, identity, w.subarray(1)), {
      message: `coefficients has ${w.length - 1} values, expected ${w.length}`,
    });
  }
  const decoder = Model.load(data("s2d-ict.sinew"));
  assert.throws(() => decoder.poseQ16(identity, identity, []), {
    message: "poseQ16 needs an AIM actor, this model is an S2D decoder",
  });
  assert.throws(() => frameHashQ16(new Float32Array(3)), TypeError);
});
