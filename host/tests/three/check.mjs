// Poses a .glb from `sinew export gltf` the way three.js does and compares it with `sinew play`'s
// OBJ frames of the same poses. three.js (npm `three`, pinned in package-lock.json) loads the file
// with GLTFLoader from its bytes (no browser), plays its animation with an AnimationMixer, and
// each vertex is morphed and skinned on the CPU by three's own SkinnedMesh.getVertexPosition.
//
// With --original RIG.glb (the character an export with --rig carried meshes from), each mesh
// of the original that the export carries (by name) must stand where it stood, vertex by vertex
// in the scene, with the export's skeleton in its bind pose: the export drops into a scene in
// place of the original.
//
// Usage: node check.mjs --glb FILE.glb --frames DIR --obj-unit METRES [--tolerance-mm MM]
//                       [--original RIG.glb]
//   DIR holds frame_00000.obj, … from `sinew play` of the frames the .glb was exported with;
//   --obj-unit is the OBJ's unit in metres (0.01 for the kit's centimetres). A looping export
//   (--loop) has one keyframe more than there are frames: it is compared with frame 0.
// Exported vertex and OBJ vertex are matched by triangle corner: the export keeps the triangle
// order of the actor (or of the rig) and only splits vertices at texture seams.
// Positions are compared in the mesh's own frame: three's world positions with the transform
// above the skeleton (a rig's node transform) taken off. Exits non-zero when any vertex of any
// keyframe is further than the tolerance (default 0.5 mm, docs/ENGINES.md) from sinew play's.
import { readFile, readdir } from 'node:fs/promises';
import { join } from 'node:path';
import { parseArgs } from 'node:util';
import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
// three.js's own meshopt decoder, for exports written with --compress (EXT_meshopt_compression).
import { MeshoptDecoder } from 'three/examples/jsm/libs/meshopt_decoder.module.js';

const { values: args } = parseArgs({
  options: {
    glb: { type: 'string' },
    frames: { type: 'string' },
    'obj-unit': { type: 'string' },
    'tolerance-mm': { type: 'string', default: '0.5' },
    original: { type: 'string' },
  },
});
function fail(message) {
  console.error(message);
  process.exit(1);
}
if (!args.glb || !args.frames || !args['obj-unit']) {
  fail('usage: node check.mjs --glb FILE.glb --frames DIR --obj-unit METRES [--tolerance-mm MM]');
}
const objUnit = Number(args['obj-unit']);
const toleranceMm = Number(args['tolerance-mm']);
if (!(objUnit > 0) || !(toleranceMm > 0)) {
  fail(`--obj-unit ${args['obj-unit']} and --tolerance-mm ${args['tolerance-mm']} must be positive numbers`);
}

/** One OBJ frame: positions and the corners of its polygons, fan-triangulated as Sinew does. */
async function readObj(path) {
  const positions = [];
  const corners = [];
  for (const line of (await readFile(path, 'utf8')).split('\n')) {
    const f = line.trim().split(/\s+/);
    if (f[0] === 'v') {
      positions.push([Number(f[1]), Number(f[2]), Number(f[3])]);
    } else if (f[0] === 'f') {
      const poly = f.slice(1).map((c) => Number(c.split('/')[0]) - 1);
      for (let k = 1; k + 1 < poly.length; k++) corners.push(poly[0], poly[k], poly[k + 1]);
    }
  }
  return { positions, corners };
}

// three.js's loader reaches for the browser's global `self` when a file has textures (a
// character carried with --rig); in node the textures then fail to load, which this check,
// about geometry, does not need.
globalThis.self ??= globalThis;
async function load(path) {
  try {
    const bytes = await readFile(path);
    const buffer = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
    return await new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).parseAsync(buffer, '');
  } catch (e) {
    fail(`${path}: three.js cannot load it: ${e.message ?? e}`);
  }
}
const gltf = await load(args.glb);
let face;
gltf.scene.traverse((o) => {
  if (o.isSkinnedMesh && o.name === 'face') face = o;
});
if (!face) fail(`${args.glb}: no skinned mesh "face"`);
if (gltf.animations.length !== 1) fail(`${args.glb}: ${gltf.animations.length} animations, expected 1`);
const clip = gltf.animations[0];
const times = clip.tracks[0].times;
// Every keyed morph weight lies in [0, 1], where a DCC's sliders clamp (Blender's shape keys).
for (const track of clip.tracks) {
  if (!track.name.endsWith('.morphTargetInfluences')) continue;
  const bad = track.values.findIndex((w) => !(w >= 0 && w <= 1));
  if (bad >= 0) {
    fail(`${args.glb}: ${track.name} keys weight ${track.values[bad]} (value ${bad}), outside [0, 1]`);
  }
}

const names = (await readdir(args.frames)).filter((n) => /^frame_\d+\.obj$/.test(n)).sort();
if (names.length === 0) fail(`${args.frames}: no frame_NNNNN.obj files`);
if (times.length !== names.length && times.length !== names.length + 1) {
  fail(`${args.glb}: ${times.length} keyframes for ${names.length} frames in ${args.frames}`);
}
const frames = await Promise.all(names.map((n) => readObj(join(args.frames, n))));

// Exported vertex → OBJ vertex, by corner.
const index = face.geometry.index.array;
const corners = frames[0].corners;
if (index.length !== corners.length) {
  fail(`${args.glb}: ${index.length / 3} triangles, the OBJ frames ${corners.length / 3}`);
}
const count = face.geometry.attributes.position.count;
const source = new Int32Array(count).fill(-1);
for (let k = 0; k < index.length; k++) {
  const i = index[k];
  if (source[i] !== -1 && source[i] !== corners[k]) {
    fail(`${args.glb}: exported vertex ${i} is OBJ vertex ${source[i]} and ${corners[k]}`);
  }
  source[i] = corners[k];
}

const mixer = new THREE.AnimationMixer(gltf.scene);
const action = mixer.clipAction(clip);
action.setLoop(THREE.LoopOnce, 1);
action.clampWhenFinished = true;
action.play();
// The skeleton's parent: the scene's root, or a rig's node with its transform.
const above = face.skeleton.bones[0].parent;
const v = new THREE.Vector3();
const toFrame = new THREE.Matrix4();
let worst = { mm: 0, key: 0, vertex: 0 };
for (let key = 0; key < times.length; key++) {
  action.time = times[key];
  mixer.update(0);
  gltf.scene.updateMatrixWorld(true);
  toFrame.copy(above.matrixWorld).invert().multiply(face.matrixWorld);
  const obj = frames[key % frames.length].positions;
  for (let i = 0; i < count; i++) {
    if (source[i] < 0) continue;
    face.getVertexPosition(i, v).applyMatrix4(toFrame);
    const o = obj[source[i]];
    const mm = Math.hypot(v.x / objUnit - o[0], v.y / objUnit - o[1], v.z / objUnit - o[2]) * objUnit * 1000;
    if (!(mm <= worst.mm)) worst = { mm, key, vertex: i };
  }
}

// The carried meshes where the original had them, the export's skeleton in its bind pose.
let carried = '';
if (args.original) {
  const original = await load(args.original);
  original.scene.updateMatrixWorld(true);
  action.stop();
  gltf.scene.traverse((o) => o.isSkinnedMesh && o.skeleton.pose());
  gltf.scene.updateMatrixWorld(true);
  const meshes = (scene) => {
    const byName = new Map();
    scene.traverse((o) => o.isMesh && byName.set(o.name, o));
    return byName;
  };
  const exported = meshes(gltf.scene);
  const names = [];
  let far = { mm: 0, name: '', vertex: 0 };
  for (const [name, mesh] of meshes(original.scene)) {
    const copy = exported.get(name);
    if (!copy || name === 'face') continue;
    const n = mesh.geometry.attributes.position.count;
    if (copy.geometry.attributes.position.count !== n) {
      fail(`${args.glb}: ${name} has ${copy.geometry.attributes.position.count} vertices, ${args.original} ${n}`);
    }
    const w = new THREE.Vector3();
    for (let i = 0; i < n; i++) {
      mesh.getVertexPosition(i, v).applyMatrix4(mesh.matrixWorld);
      copy.getVertexPosition(i, w).applyMatrix4(copy.matrixWorld);
      const mm = v.distanceTo(w) * 1000;
      if (!(mm <= far.mm)) far = { mm, name, vertex: i };
    }
    names.push(name);
  }
  if (names.length === 0) fail(`${args.glb}: carries no mesh of ${args.original}`);
  if (far.mm > worst.mm) worst = { ...far, key: 'bind pose', vertex: `${far.name} ${far.vertex}` };
  carried = `; carried ${names.join(', ')} where ${args.original} has them within ${far.mm.toExponential(2)} mm`;
}
const within = worst.mm <= toleranceMm;
console.log(
  `${args.glb}: three.js ${THREE.REVISION}, ${times.length} keyframes of ${count} vertices against ` +
    `${args.frames}: max ${worst.mm.toExponential(2)} mm (keyframe ${worst.key}, vertex ${worst.vertex}); ` +
    `tolerance ${toleranceMm} mm${carried}: ${within ? 'ok' : 'FAILED'}`,
);
process.exit(within ? 0 : 1);
