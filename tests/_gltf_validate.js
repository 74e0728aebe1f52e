// Validate glTF files with the Khronos glTF-Validator (npm package `gltf-validator`, whose
// folder is the first argument): prints one JSON line per file, {file, errors, warnings,
// messages}, external buffers and images read from beside the file.
"use strict";
const fs = require("fs");
const path = require("path");
const validator = require(process.argv[2]);

async function check(file) {
  const data = new Uint8Array(fs.readFileSync(file));
  const report = await validator.validateBytes(data, {
    uri: path.basename(file),
    maxIssues: 0,
    writeTimestamp: false,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(path.dirname(file), decodeURIComponent(uri)), (err, buf) =>
          err ? reject(err.toString()) : resolve(new Uint8Array(buf)));
      }),
  });
  const issues = report.issues;
  return {
    file,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    messages: issues.messages.map((m) => `${m.severity} ${m.code} ${m.pointer || ""}: ${m.message}`),
  };
}

(async () => {
  for (const file of process.argv.slice(3)) {
    console.log(JSON.stringify(await check(file)));
  }
})().catch((e) => {
  console.error(String(e));
  process.exit(1);
});
