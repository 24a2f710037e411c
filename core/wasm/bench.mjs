// Per-frame time of the WebAssembly package under node: the ICT actor's pose + normals and the
// S2D decoder's decode, over the golden replays' frames (tests/data), through the JavaScript API
// (copies in and out of the module included). Figures: docs/BENCHMARKS.md.
//
// Usage: bash core/wasm/build.sh && node core/wasm/bench.mjs [rounds]
// Each round plays every frame of the replay once; the median round is reported after one
// round of warm-up.
import { readFileSync } from "node:fs";
import { performance } from "node:perf_hooks";

import { init, Model, Replay, frameHash } from "./pkg/sinew.mjs";

const rounds = Number(process.argv[2] ?? 20);
if (!Number.isInteger(rounds) || rounds < 1) {
  console.error(`bench.mjs: rounds must be a positive integer, got ${process.argv[2]}`);
  process.exit(2);
}
const data = (name) => readFileSync(new URL(`../../tests/data/${name}`, import.meta.url));
await init();

/** Median milliseconds per frame of `run(frame)` over `frames` frames, `rounds` rounds. */
function measure(frames, run) {
  const times = [];
  for (let r = 0; r <= rounds; r++) {
    const t0 = performance.now();
    for (const f of frames) run(f);
    if (r > 0) times.push((performance.now() - t0) / frames.length);
  }
  times.sort((a, b) => a - b);
  return times[Math.floor(times.length / 2)];
}

const report = (what, ms) => console.log(`${what.padEnd(44)} ${ms.toFixed(3)} ms/frame`);

const aim = Model.load(data("aim-ict.sinew"));
const aimReplay = Replay.load(data("aim-ict.f32.replay.sinew"));
const aimFrames = Array.from({ length: aimReplay.frameCount }, (_, f) => aimReplay.frame(f));
report(`aim-ict pose (${aim.vertexCount} vertices, ${aim.shapeCount} shapes)`, measure(aimFrames, (f) => aim.pose(f.head, f.jaw, f.coefficients)));
report("aim-ict pose + normals", measure(aimFrames, (f) => aim.normals(aim.pose(f.head, f.jaw, f.coefficients))));
report(
  "aim-ict pose + normals + frameHash",
  measure(aimFrames, (f) => {
    const p = aim.pose(f.head, f.jaw, f.coefficients);
    frameHash(p, aim.normals(p));
  }),
);

const s2d = Model.load(data("s2d-ict.sinew"));
const s2dReplay = Replay.load(data("s2d-ict.replay.sinew"));
const neutral = s2dReplay.neutral;
const s2dFrames = Array.from({ length: s2dReplay.frameCount }, (_, f) => s2dReplay.frame(f));
report(`s2d-ict decode (${s2d.vertexCount} vertices, ${s2d.landmarkCount} landmarks)`, measure(s2dFrames, (f) => s2d.decode(f.input, neutral)));
console.log(`node ${process.version}, ${rounds} rounds of ${aimFrames.length} and ${s2dFrames.length} frames, median round`);
