// Runs the golden AIM and S2D replays, the golden fitted performance, the golden generated
// sequence, the golden driver's track and the live track compiled to wasm32-unknown-unknown
// under node.
//
// Usage: node run.mjs [path/to/sinew_firmware_wasm.wasm]
// Without a path it looks in ../target (run.sh's shared target directory), then ./target.
// Prints every frame's hash, and exits 0 only when every frame matched the host's.
import { existsSync, readFileSync } from "node:fs";
import { fileURLToPath } from "node:url";

const rel = "wasm32-unknown-unknown/release/sinew_firmware_wasm.wasm";
const candidates = process.argv[2]
  ? [process.argv[2]]
  : ["../target/", "./target/"].map((d) => fileURLToPath(new URL(d + rel, import.meta.url)));
const path = candidates.find((p) => existsSync(p));
if (!path) {
  console.error(`sinew-firmware-wasm: no module at ${candidates.join(" or ")}; build it first`);
  process.exit(2);
}

const LOAD_ERROR = 0xffff_ffff;
// wasm i64 arrives as a signed BigInt; print it as the unsigned 16-digit hex of the hash list.
const hex = (v) => BigInt.asUintN(64, v).toString(16).padStart(16, "0");
const frames = [];
const imports = {
  sinew: {
    report(frame, hash, expected) {
      const ok = hash === expected;
      frames.push({ frame, ok });
      // frame = replay index * 1000 + frame number (see src/lib.rs).
      const f = `${Math.floor(frame / 1000)}:${String(frame % 1000).padStart(2)}`;
      console.log(
        ok ? `frame ${f} ${hex(hash)} ok` : `frame ${f} ${hex(hash)} MISMATCH (expected ${hex(expected)})`,
      );
    },
  },
};

const { instance } = await WebAssembly.instantiate(readFileSync(path), imports);
console.log(`sinew-firmware-wasm: ${path}`);
// The kernel suite first (reported as frames 9:0…), then the replays.
const kernels = instance.exports.sinew_kernels() >>> 0;
if (kernels !== 0) {
  console.error(`sinew-firmware-wasm: kernel suite: ${kernels === LOAD_ERROR ? "could not run" : `${kernels} cases differ`}`);
  process.exit(1);
}
console.log("sinew-firmware-wasm: 7 kernels bit-identical to the host");
// An i32 result comes back signed: `>>> 0` reads it as the u32 it is.
const result = instance.exports.sinew_replay() >>> 0;
if (result === LOAD_ERROR) {
  console.error("sinew-firmware-wasm: the replay could not load the model or the hash list");
  process.exit(1);
}
const bad = frames.filter((f) => !f.ok).length;
console.log(`sinew-firmware-wasm: ${frames.length - bad}/${frames.length} frames bit-identical to the host`);
// Cross-check the module's count with what it reported, and refuse a run that checked nothing.
if (result !== 0 || bad !== 0 || frames.length === 0) {
  process.exit(1);
}
// The S2D decoder (reported as frames 8:0…).
const aimFrames = frames.length;
const s2d = instance.exports.sinew_replay_s2d() >>> 0;
if (s2d === LOAD_ERROR) {
  console.error("sinew-firmware-wasm: the S2D replay could not load the decoder or the replay");
  process.exit(1);
}
const s2dFrames = frames.slice(aimFrames);
const s2dBad = s2dFrames.filter((f) => !f.ok).length;
console.log(`sinew-firmware-wasm: ${s2dFrames.length - s2dBad}/${s2dFrames.length} S2D frames bit-identical to the host`);
if (s2d !== 0 || s2dBad !== 0 || s2dFrames.length === 0) {
  process.exit(1);
}
// The fitted performance (reported as frames 7:0…).
const before = frames.length;
const fitted = instance.exports.sinew_replay_performance() >>> 0;
if (fitted === LOAD_ERROR) {
  console.error("sinew-firmware-wasm: the fitted performance could not load the actor or the performance");
  process.exit(1);
}
const fittedFrames = frames.slice(before);
const fittedBad = fittedFrames.filter((f) => !f.ok).length;
console.log(
  `sinew-firmware-wasm: ${fittedFrames.length - fittedBad}/${fittedFrames.length} fitted-performance frames bit-identical to the host`,
);
if (fitted !== 0 || fittedBad !== 0 || fittedFrames.length === 0) {
  process.exit(1);
}
// The generated sequence (reported as frames 6:1…).
const motionStart = frames.length;
const motion = instance.exports.sinew_replay_motion() >>> 0;
if (motion === LOAD_ERROR) {
  console.error("sinew-firmware-wasm: the generated sequence could not load the generator, the decoder or the hash list");
  process.exit(1);
}
const motionFrames = frames.slice(motionStart);
const motionBad = motionFrames.filter((f) => !f.ok).length;
console.log(
  `sinew-firmware-wasm: ${motionFrames.length - motionBad}/${motionFrames.length} generated-sequence frames bit-identical to the host`,
);
if (motion !== 0 || motionBad !== 0 || motionFrames.length === 0) {
  process.exit(1);
}
// The driven track: four checks a row (reported as frames 5:0…).
const driverStart = frames.length;
const driver = instance.exports.sinew_replay_driver() >>> 0;
if (driver === LOAD_ERROR) {
  console.error("sinew-firmware-wasm: the driven track could not load the driver, the actor, the track or the hash list");
  process.exit(1);
}
const driverChecks = frames.slice(driverStart);
const driverBad = driverChecks.filter((f) => !f.ok).length;
console.log(
  `sinew-firmware-wasm: ${driverChecks.length - driverBad}/${driverChecks.length} driven-track checks bit-identical to the host`,
);
if (driver !== 0 || driverBad !== 0 || driverChecks.length === 0) {
  process.exit(1);
}
// The live track: three checks a row, the outcome, the pose and the frame (reported as 4:0…).
const liveStart = frames.length;
const live = instance.exports.sinew_replay_live() >>> 0;
if (live === LOAD_ERROR) {
  console.error("sinew-firmware-wasm: the live track could not load the driver, the actor, the track or the hash list");
  process.exit(1);
}
const liveChecks = frames.slice(liveStart);
const liveBad = liveChecks.filter((f) => !f.ok).length;
console.log(
  `sinew-firmware-wasm: ${liveChecks.length - liveBad}/${liveChecks.length} live-track checks bit-identical to the host`,
);
if (live !== 0 || liveBad !== 0 || liveChecks.length === 0) {
  process.exit(1);
}
