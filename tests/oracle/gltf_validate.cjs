#!/usr/bin/env node
// Oracle for the 3D Tiles writer: Khronos' glTF Validator (npm `gltf-validator`,
// its validateBytes API) on every .glb under DIR, recursively.
//
//   NODE_PATH=/path/to/node_modules node tests/oracle/gltf_validate.cjs DIR
//
// Prints one JSON object to stdout:
//   {"files": N, "errors": total, "warnings": total, "infos": total,
//    "validator": version, "unsupported_extensions": [...],
//    "by_file": {relpath: {errors, warnings, infos, messages: [...]}}}
// where messages are the first 5 errors/warnings ({code, severity, message, pointer}).
// Exits 0 whatever the validator found (the Rust test asserts); 2 on bad usage.
//
// The validator does not know EXT_mesh_features / EXT_structural_metadata: it reports
// each as UNSUPPORTED_EXTENSION at severity Information (not a warning), and the
// property table buffer views, which only those extensions reference, as
// UNUSED_OBJECT (Information). Core glTF rules still apply to the feature id
// attribute: e.g. a tightly packed UNSIGNED_SHORT _FEATURE_ID_0 is an error
// (MESH_PRIMITIVE_ACCESSOR_UNALIGNED); FLOAT, or u8/u16 with a byteStride of 4, is fine.
'use strict';

const fs = require('fs');
const path = require('path');
const validator = require('gltf-validator');

const SEVERITY = ['error', 'warning', 'info', 'hint'];

function glbFiles(dir) {
  const out = [];
  for (const entry of fs.readdirSync(dir, { withFileTypes: true })) {
    const p = path.join(dir, entry.name);
    if (entry.isDirectory()) out.push(...glbFiles(p));
    else if (entry.isFile() && entry.name.toLowerCase().endsWith('.glb')) out.push(p);
  }
  return out.sort();
}

async function validateFile(file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  try {
    return await validator.validateBytes(bytes, {
      uri: path.basename(file),
      format: 'glb',
      maxIssues: 0,
      writeTimestamp: false,
      externalResourceFunction: (uri) =>
        new Promise((resolve, reject) => {
          fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, data) =>
            err ? reject(err.toString()) : resolve(new Uint8Array(data)),
          );
        }),
    });
  } catch (err) {
    // The validator rejects input it cannot even parse as GLB: count it as one error.
    return {
      issues: {
        numErrors: 1, numWarnings: 0, numInfos: 0,
        messages: [{ code: 'VALIDATOR_REJECTED', severity: 0, message: String(err), pointer: '' }],
      },
    };
  }
}

async function main() {
  const dir = process.argv[2];
  if (!dir || !fs.existsSync(dir) || !fs.statSync(dir).isDirectory()) {
    process.stderr.write('usage: gltf_validate.cjs DIR\n');
    process.exit(2);
  }
  const result = {
    files: 0, errors: 0, warnings: 0, infos: 0,
    validator: validator.version(), unsupported_extensions: [], by_file: {},
  };
  const unsupported = new Set();
  for (const file of glbFiles(dir)) {
    const issues = (await validateFile(file)).issues;
    const messages = issues.messages || [];
    for (const m of messages) {
      const name = m.code === 'UNSUPPORTED_EXTENSION' && /'([^']+)'/.exec(m.message);
      if (name) unsupported.add(`${name[1]} (${SEVERITY[m.severity] || m.severity})`);
    }
    result.files += 1;
    result.errors += issues.numErrors;
    result.warnings += issues.numWarnings;
    result.infos += issues.numInfos;
    result.by_file[path.relative(dir, file).split(path.sep).join('/')] = {
      errors: issues.numErrors,
      warnings: issues.numWarnings,
      infos: issues.numInfos,
      messages: messages
        .filter((m) => m.severity <= 1)
        .slice(0, 5)
        .map((m) => ({ code: m.code, severity: SEVERITY[m.severity], message: m.message, pointer: m.pointer ?? null })),
    };
  }
  result.unsupported_extensions = [...unsupported].sort();
  process.stdout.write(JSON.stringify(result) + '\n');
}

main().catch((err) => {
  process.stderr.write(`gltf_validate.cjs: ${err && err.stack ? err.stack : err}\n`);
  process.exit(2);
});
