#!/usr/bin/env node
// Validate glTF files with the Khronos glTF validator (npm package gltf-validator) and print
// one JSON object {path: report} on stdout. The report is the validator's own (issues.numErrors,
// issues.messages, info...). Usage: node tests/tools/validate_gltf.js FILE.glb [FILE.glb ...]
// The package is found in GLTF_VALIDATOR_DIR, else in .ci/node/node_modules/gltf-validator
// (installed by .ci/setup.d/gltf-validator.sh, or by the test fixture).
"use strict";
const fs = require("fs");
const path = require("path");

const moduleDir = process.env.GLTF_VALIDATOR_DIR ||
    path.resolve(__dirname, "..", "..", ".ci", "node", "node_modules", "gltf-validator");
const validator = require(moduleDir);

async function main(files) {
    if (files.length === 0) {
        console.error("usage: node validate_gltf.js FILE.glb [FILE.glb ...]");
        return 2;
    }
    const reports = {};
    for (const file of files) {
        const bytes = new Uint8Array(fs.readFileSync(file));
        reports[file] = await validator.validateBytes(bytes, {
            uri: path.basename(file),
            maxIssues: 0,          // report every issue
            writeTimestamp: false,
        });
    }
    process.stdout.write(JSON.stringify({validatorVersion: validator.version(), reports: reports}, null, 1) + "\n");
    return 0;
}

main(process.argv.slice(2)).then(
    (code) => { process.exitCode = code; },
    (err) => { console.error(String(err)); process.exitCode = 1; });
