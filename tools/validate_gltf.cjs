// SPDX-License-Identifier: Apache-2.0
// Validates glTF 2.0 files with the Khronos glTF validator (npm package gltf-validator, found
// through NODE_PATH or node_modules). Prints one JSON line per file: {"file", "errors",
// "warnings", "infos", "messages": the first ten errors and warnings}. Exit status 1 when a
// file has errors, 2 when a file cannot be read or the validator is missing.
// Usage: NODE_PATH=build/npm/node_modules node tools/validate_gltf.cjs FILE.glb ...
'use strict';
const fs = require('fs');
let validator;
try {
  validator = require('gltf-validator');
} catch (e) {
  console.error('validate_gltf: the gltf-validator package is not installed (tools/install_deps.sh validator)');
  process.exit(2);
}
(async () => {
  let failed = false;
  for (const file of process.argv.slice(2)) {
    let bytes;
    try {
      bytes = new Uint8Array(fs.readFileSync(file));
    } catch (e) {
      console.error(`validate_gltf: ${file}: ${e.message}`);
      process.exit(2);
    }
    const report = await validator.validateBytes(bytes, { maxIssues: 100 });
    const issues = report.issues;
    const messages = issues.messages.filter((m) => m.severity <= 1).slice(0, 10)
      .map((m) => `${m.code} ${m.pointer || ''}: ${m.message}`);
    console.log(JSON.stringify({ file, errors: issues.numErrors, warnings: issues.numWarnings, infos: issues.numInfos, messages }));
    if (issues.numErrors > 0) failed = true;
  }
  process.exit(failed ? 1 : 0);
})();
