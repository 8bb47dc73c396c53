// Runs the Khronos glTF-Validator (npm gltf-validator) on glTF files:
//   node tests/js/validate.mjs FILE.glb|FILE.gltf...
// Prints one JSON line per file: {"file", "errors", "warnings", "infos",
// "hints", "messages": [the first errors and warnings]}. Exit status: 0 when
// no file has an error, 1 when one has, 77 when the validator is not
// installed (npm ci --prefix tests/js), 2 for a usage error.
import { readFile } from 'node:fs/promises';
import path from 'node:path';

let validator;
try {
  validator = await import('gltf-validator');
} catch (e) {
  console.error(`validate.mjs: the gltf-validator npm package is not installed (npm ci --prefix tests/js): ${e.message}`);
  process.exit(77);
}
const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node tests/js/validate.mjs FILE.glb|FILE.gltf...');
  process.exit(2);
}
let failed = false;
for (const file of files) {
  const bytes = new Uint8Array(await readFile(file));
  const report = await validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0,
    // prt's files are self-contained (GLB chunk or data: URI): any other
    // resource asked for is an error of the file.
    externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
  });
  const i = report.issues;
  const messages = i.messages.filter((m) => m.severity <= 1).slice(0, 20)
    .map((m) => `${['error', 'warning'][m.severity]} ${m.code}: ${m.message} (${m.pointer ?? ''})`);
  console.log(JSON.stringify({ file, errors: i.numErrors, warnings: i.numWarnings, infos: i.numInfos,
                               hints: i.numHints, messages }));
  if (i.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
