// Validate glTF/GLB files with the Khronos glTF validator and print one JSON array of
// reports (in argument order) on stdout. Usage: node validate.js FILE [FILE ...]
// CommonJS on purpose: it runs whether or not this folder's package.json ships beside it.
'use strict';

const fs = require('fs');
const path = require('path');

let validator;
try {
  validator = require('gltf-validator');
} catch (e) {
  process.stderr.write(
    'gltf-validator is not installed: run `npm ci` in ' + __dirname + '\n');
  process.exit(3);
}

async function validateFile(file) {
  const full = path.resolve(file);
  const bytes = new Uint8Array(fs.readFileSync(full));
  return validator.validateBytes(bytes, {
    uri: path.basename(full),
    maxIssues: 0, // unlimited
    writeTimestamp: false,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        const resource = path.resolve(path.dirname(full), decodeURIComponent(uri));
        fs.readFile(resource, (err, data) => (err ? reject(err.toString()) : resolve(data)));
      }),
  });
}

async function main() {
  const files = process.argv.slice(2);
  if (files.length === 0) {
    process.stderr.write('usage: node validate.js FILE [FILE ...]\n');
    process.exit(2);
  }
  const reports = [];
  for (const file of files) {
    try {
      reports.push(await validateFile(file));
    } catch (e) {
      // The validator rejects input it cannot even classify as glTF or GLB.
      reports.push({ uri: file, fatal: String(e) });
    }
  }
  process.stdout.write(JSON.stringify(reports) + '\n');
}

main();
