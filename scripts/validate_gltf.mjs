#!/usr/bin/env node
// Validate glTF/GLB files with the Khronos glTF validator (npm package `gltf-validator`).
//
//   npm install --prefix tools gltf-validator     # once; tools/ is git-ignored
//   node scripts/validate_gltf.mjs                # validates assets/models/*.glb
//   node scripts/validate_gltf.mjs a.glb b.gltf   # or the files named
//
// Prints one line per file (errors / warnings / infos) and every error message;
// exits non-zero when any file has an error or cannot be read.
import { readFile, readdir } from 'node:fs/promises';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const root = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const require = createRequire(import.meta.url);
let validator;
for (const candidate of [path.join(root, 'tools/node_modules/gltf-validator'), 'gltf-validator']) {
  try {
    validator = require(candidate);
    break;
  } catch {
    // try the next location
  }
}
if (!validator) {
  console.error('gltf-validator is not installed: run `npm install --prefix tools gltf-validator`');
  process.exit(2);
}

let files = process.argv.slice(2);
if (files.length === 0) {
  const dir = path.join(root, 'assets/models');
  files = (await readdir(dir)).filter((f) => f.endsWith('.glb')).sort().map((f) => path.join(dir, f));
}
if (files.length === 0) {
  console.error('no files to validate');
  process.exit(2);
}

let failed = 0;
for (const file of files) {
  try {
    const bytes = new Uint8Array(await readFile(file));
    const report = await validator.validateBytes(bytes, {
      uri: path.basename(file),
      maxIssues: 100,
      externalResourceFunction: (uri) => readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))).then((b) => new Uint8Array(b)),
    });
    const { numErrors, numWarnings, numInfos, messages } = report.issues;
    console.log(`${path.relative(root, file)}: ${numErrors} errors, ${numWarnings} warnings, ${numInfos} infos`);
    for (const m of messages) {
      if (m.severity <= 1) console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer ?? ''}: ${m.message}`);
    }
    if (numErrors > 0) failed += 1;
  } catch (e) {
    console.log(`${file}: cannot validate: ${e}`);
    failed += 1;
  }
}
process.exit(failed > 0 ? 1 : 0);
