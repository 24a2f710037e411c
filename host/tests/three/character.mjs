// Makes a character of a rig: copies a .glb and adds what a character has besides its face, an
// `eyes` mesh (a textured triangle in front of the face, under a node of its own) with its
// material, texture, sampler and a PNG image in the BIN chunk, and a `teethLower` mesh (a
// triangle behind the lower lip, which the export hangs on the jaw joint), so that
// `sinew export gltf --rig` has something to carry. Usage: node character.mjs IN.glb OUT.glb
// (IN: a rig from `sinew data rig`, its skin in metres, y up, looking along +z).
import { readFile, writeFile } from 'node:fs/promises';
import { deflateSync } from 'node:zlib';

const [input, output] = process.argv.slice(2);
if (!input || !output) {
  console.error('usage: node character.mjs IN.glb OUT.glb');
  process.exit(2);
}
const file = await readFile(input);
const jsonLength = file.readUInt32LE(12);
const doc = JSON.parse(file.subarray(20, 20 + jsonLength).toString('utf8'));
const binLength = file.readUInt32LE(20 + jsonLength);
let bin = Buffer.from(file.subarray(28 + jsonLength, 28 + jsonLength + binLength));

// A 4 × 4 RGB PNG.
function crc32(bytes) {
  let c = ~0;
  for (const b of bytes) {
    c ^= b;
    for (let k = 0; k < 8; k++) c = (c >>> 1) ^ (0xedb88320 & -(c & 1));
  }
  return ~c >>> 0;
}
function chunk(type, body) {
  const head = Buffer.alloc(4);
  head.writeUInt32BE(body.length);
  const crc = Buffer.alloc(4);
  crc.writeUInt32BE(crc32(Buffer.concat([Buffer.from(type), body])));
  return Buffer.concat([head, Buffer.from(type), body, crc]);
}
const header = Buffer.alloc(13);
header.writeUInt32BE(4, 0);
header.writeUInt32BE(4, 4);
header.set([8, 2, 0, 0, 0], 8);
const rows = Buffer.concat(Array.from({ length: 4 }, () => Buffer.from([0, ...Array(4).fill([200, 150, 120]).flat()])));
const png = Buffer.concat([
  Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
  chunk('IHDR', header),
  chunk('IDAT', deflateSync(rows)),
  chunk('IEND', Buffer.alloc(0)),
]);

function view(bytes, target) {
  bin = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
  const v = { buffer: 0, byteOffset: bin.length, byteLength: bytes.length };
  if (target) v.target = target;
  doc.bufferViews.push(v);
  bin = Buffer.concat([bin, bytes]);
  return doc.bufferViews.length - 1;
}
// The triangle a few centimetres in front of the face's bounding box, in the skin's own frame.
const face = doc.accessors[doc.meshes[0].primitives[0].attributes.POSITION];
const [lo, hi] = [face.min, face.max];
const mid = [0, 1, 2].map((k) => 0.5 * (lo[k] + hi[k]));
const size = hi[0] - lo[0];
const points = [
  [mid[0] + 0.2 * size, mid[1] + 0.1 * size, hi[2]],
  [mid[0] - 0.2 * size, mid[1] + 0.1 * size, hi[2]],
  [mid[0], mid[1] + 0.25 * size, hi[2]],
];
const positions = view(Buffer.from(new Float32Array(points.flat()).buffer), 34962);
const uvs = view(Buffer.from(new Float32Array([0, 0, 1, 0, 0.5, 1]).buffer), 34962);
const indices = view(Buffer.from(new Uint16Array([0, 1, 2]).buffer), 34963);
const image = view(png);
const min = [0, 1, 2].map((k) => Math.min(...points.map((p) => Math.fround(p[k]))));
const max = [0, 1, 2].map((k) => Math.max(...points.map((p) => Math.fround(p[k]))));
doc.accessors.push(
  { bufferView: positions, componentType: 5126, count: 3, type: 'VEC3', min, max },
  { bufferView: uvs, componentType: 5126, count: 3, type: 'VEC2' },
  { bufferView: indices, componentType: 5123, count: 3, type: 'SCALAR' },
);
const n = doc.accessors.length;
doc.materials = [{ name: 'eye', pbrMetallicRoughness: { baseColorTexture: { index: 0 } } }];
doc.textures = [{ source: 0, sampler: 0 }];
doc.samplers = [{ magFilter: 9729 }];
doc.images = [{ bufferView: image, mimeType: 'image/png' }];
doc.meshes.push({
  name: 'eyes',
  primitives: [{ attributes: { POSITION: n - 3, TEXCOORD_0: n - 2 }, indices: n - 1, material: 0 }],
});

// The lower teeth: a triangle behind the lower lip, placed from the nose tip (the skin's
// foremost vertex) by the face's width.
const skin = new Float32Array(
  bin.buffer.slice(
    bin.byteOffset + doc.bufferViews[face.bufferView].byteOffset + (face.byteOffset ?? 0),
    bin.byteOffset + doc.bufferViews[face.bufferView].byteOffset + (face.byteOffset ?? 0) + 12 * face.count,
  ),
);
let tip = 0;
for (let i = 1; i < face.count; i++) if (skin[3 * i + 2] > skin[3 * tip + 2]) tip = i;
const nose = [0, 1, 2].map((k) => skin[3 * tip + k]);
const teethPoints = [
  [nose[0] + 0.08 * size, nose[1] - 0.2 * size, nose[2] - 0.15 * size],
  [nose[0] - 0.08 * size, nose[1] - 0.2 * size, nose[2] - 0.15 * size],
  [nose[0], nose[1] - 0.25 * size, nose[2] - 0.15 * size],
];
const teethPositions = view(Buffer.from(new Float32Array(teethPoints.flat()).buffer), 34962);
const teethIndices = view(Buffer.from(new Uint16Array([0, 1, 2]).buffer), 34963);
doc.accessors.push(
  {
    bufferView: teethPositions,
    componentType: 5126,
    count: 3,
    type: 'VEC3',
    min: [0, 1, 2].map((k) => Math.min(...teethPoints.map((p) => Math.fround(p[k])))),
    max: [0, 1, 2].map((k) => Math.max(...teethPoints.map((p) => Math.fround(p[k])))),
  },
  { bufferView: teethIndices, componentType: 5123, count: 3, type: 'SCALAR' },
);
doc.meshes.push({
  name: 'teethLower',
  primitives: [{ attributes: { POSITION: doc.accessors.length - 2 }, indices: doc.accessors.length - 1 }],
});

// Each sits where the face's node puts the face, through a node of its own.
const faceNode = doc.nodes.find((node) => node.mesh === 0);
for (const [name, mesh] of [['eyes', doc.meshes.length - 2], ['teethLower', doc.meshes.length - 1]]) {
  const node = { name, mesh };
  for (const key of ['matrix', 'translation', 'rotation', 'scale']) {
    if (faceNode[key]) node[key] = faceNode[key];
  }
  doc.nodes.push(node);
  doc.scenes[doc.scene ?? 0].nodes.push(doc.nodes.length - 1);
}
bin = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
doc.buffers[0].byteLength = bin.length;
let json = Buffer.from(JSON.stringify(doc));
json = Buffer.concat([json, Buffer.alloc((4 - (json.length % 4)) % 4, 0x20)]);
const out = Buffer.alloc(28);
out.writeUInt32LE(0x46546c67, 0);
out.writeUInt32LE(2, 4);
out.writeUInt32LE(28 + json.length + bin.length, 8);
out.writeUInt32LE(json.length, 12);
out.writeUInt32LE(0x4e4f534a, 16);
const binHeader = Buffer.alloc(8);
binHeader.writeUInt32LE(bin.length, 0);
binHeader.writeUInt32LE(0x004e4942, 4);
await writeFile(output, Buffer.concat([out.subarray(0, 20), json, binHeader, bin]));
