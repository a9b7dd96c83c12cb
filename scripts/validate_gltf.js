#!/usr/bin/env node
// Validates .glb/.gltf files with the Khronos glTF validator (npm package
// `gltf-validator`, installed globally by scripts/setup.sh) and prints one
// line per file: "<path>: E errors, W warnings, I infos, H hints" and then
// every error and warning. Exit status: 0 when every file has no error and no
// warning, 1 otherwise, 77 when the validator module is not installed (the
// tests treat 77 as "skip", the automake convention).
'use strict';
const fs = require('fs');
const path = require('path');
const { execSync } = require('child_process');

function loadValidator() {
  try { return require('gltf-validator'); } catch (e) { /* try the global root */ }
  try {
    const root = execSync('npm root -g', { encoding: 'utf8', stdio: ['ignore', 'pipe', 'ignore'] }).trim();
    return require(path.join(root, 'gltf-validator'));
  } catch (e) { return null; }
}

async function main() {
  const validator = loadValidator();
  if (!validator) {
    console.log('gltf-validator is not installed (npm install -g gltf-validator)');
    process.exit(77);
  }
  let bad = 0;
  for (const file of process.argv.slice(2)) {
    const bytes = new Uint8Array(fs.readFileSync(file));
    const report = await validator.validateBytes(bytes, { maxIssues: 50 });
    const i = report.issues;
    console.log(`${file}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos, ${i.numHints} hints`);
    for (const m of i.messages)
      if (m.severity <= 1) console.log(`  ${m.severity === 0 ? 'error' : 'warning'} ${m.code} ${m.pointer || ''}: ${m.message}`);
    if (i.numErrors > 0 || i.numWarnings > 0) ++bad;
  }
  process.exit(bad > 0 ? 1 : 0);
}
main().catch((e) => { console.error(String(e)); process.exit(1); });
