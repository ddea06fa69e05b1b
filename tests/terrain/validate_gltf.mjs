// Validates glTF binaries with the Khronos glTF Validator (npm gltf-validator, pinned by the root
// package-lock.json; scripts/install-deps.sh installs it). Prints every message and exits 1 when
// any file has errors (2 on bad usage or an unreadable file).
//
//   node tests/terrain/validate_gltf.mjs tile.glb...
//   node tests/terrain/validate_gltf.mjs --expect-errors broken.glb...
//
// --expect-errors inverts the verdict (every file must have errors), so a test can prove that
// the check fails when the validator complains.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { validateBytes, version } from 'gltf-validator';

const args = process.argv.slice(2);
const expectErrors = args[0] === '--expect-errors';
const files = expectErrors ? args.slice(1) : args;
if (files.length === 0) {
  console.error('usage: validate_gltf.mjs [--expect-errors] file.glb...');
  process.exit(2);
}

const severities = ['error', 'warning', 'info', 'hint'];
let failed = false;
console.log(`glTF Validator ${version()}`);
for (const file of files) {
  let bytes;
  try {
    bytes = new Uint8Array(await readFile(file));
  } catch (e) {
    console.error(`${file}: ${e.message}`);
    process.exit(2);
  }
  let report;
  try {
    report = await validateBytes(bytes, { uri: path.basename(file), maxIssues: 0, writeTimestamp: false });
  } catch (e) {
    // The validator rejects input it cannot even recognise as glTF or GLB.
    console.log(`${file}: not validated: ${e}`);
    failed ||= !expectErrors;
    continue;
  }
  const { numErrors, numWarnings, numInfos, numHints, messages } = report.issues;
  console.log(`${file}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos, ${numHints} hints`);
  for (const m of messages) {
    console.log(`  ${severities[m.severity] ?? m.severity} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
  }
  if ((numErrors > 0) !== expectErrors) failed = true;
}
process.exit(failed ? 1 : 0);
