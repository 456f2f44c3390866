#!/usr/bin/env node
// Khronos glTF-Validator wrapper (the npm package has no CLI).
// usage: node validate.js FILE [--ignore CODE,CODE]  -> prints the JSON report;
// exit 0 no errors, 1 errors, 2 unreadable.
const fs = require('fs'), path = require('path'), validator = require('gltf-validator');
const file = process.argv[2];
const ign = process.argv.indexOf('--ignore');
const ignoredIssues = ign > 0 ? process.argv[ign + 1].split(',') : [];
const full = path.resolve(file);
validator.validateBytes(new Uint8Array(fs.readFileSync(full)), {
  uri: path.basename(full), maxIssues: 0, ignoredIssues,
  externalResourceFunction: (uri) => new Promise((resolve, reject) =>
    fs.readFile(path.resolve(path.dirname(full), decodeURIComponent(uri)),
      (e, d) => e ? reject(e.toString()) : resolve(new Uint8Array(d)))),
// exitCode, not exit(): exit() would cut a large report short on a pipe.
}).then((r) => { console.log(JSON.stringify(r, null, 2)); process.exitCode = r.issues.numErrors > 0 ? 1 : 0; },
        (e) => { console.error(e); process.exitCode = 2; });
