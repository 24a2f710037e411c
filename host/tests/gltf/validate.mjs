// Validates .glb files with the Khronos glTF validator (npm gltf-validator), printing every
// issue, and exits non-zero when any file has an error. Usage: node validate.mjs FILE.glb...
import { readFile } from 'node:fs/promises';
import validator from 'gltf-validator';

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate.mjs FILE.glb...');
  process.exit(2);
}
let failed = false;
for (const file of files) {
  let bytes;
  try {
    bytes = new Uint8Array(await readFile(file));
  } catch (e) {
    console.error(`${file}: cannot read: ${e.message}`);
    failed = true;
    continue;
  }
  const report = await validator.validateBytes(bytes, {
    uri: file,
    maxIssues: 0, // report every issue
    // A .glb from sinew carries everything in its BIN chunk: an external reference is an error.
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
  });
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  for (const m of messages) {
    const level = ['error', 'warning', 'info', 'hint'][m.severity] ?? m.severity;
    console.error(`${file}: ${level} ${m.code} at ${m.pointer ?? m.offset ?? ''}: ${m.message}`);
  }
  console.log(
    `${file}: glTF validator ${report.validatorVersion}: ${numErrors} errors, ` +
      `${numWarnings} warnings, ${numInfos} infos, ${numHints} hints`,
  );
  failed ||= numErrors !== 0;
}
process.exit(failed ? 1 : 0);
