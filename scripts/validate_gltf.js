// Runs the Khronos glTF validator (installed by scripts/setup_validator.sh into .tools/) on one
// .gltf/.glb file, loading its external buffers and images, and prints the validator's JSON
// report on stdout. Exit code 0 when the report was made (whatever it says), 2 on bad usage or
// an unreadable file. Usage: node scripts/validate_gltf.js FILE.gltf
'use strict';
const fs = require('fs');
const path = require('path');
const validator = require(path.join(__dirname, '..', '.tools', 'node_modules', 'gltf-validator'));

const file = process.argv[2];
if (!file) {
    console.error('usage: node scripts/validate_gltf.js FILE.gltf');
    process.exit(2);
}
let bytes;
try {
    bytes = new Uint8Array(fs.readFileSync(file));
} catch (err) {
    console.error(`cannot read ${file}: ${err.message}`);
    process.exit(2);
}
validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0, // every issue
    externalResourceFunction: (uri) => new Promise((resolve, reject) => {
        const full = path.resolve(path.dirname(file), decodeURIComponent(uri));
        fs.readFile(full, (err, data) => (err ? reject(err.toString()) : resolve(new Uint8Array(data))));
    }),
}).then((report) => {
    process.stdout.write(JSON.stringify(report, null, 1) + '\n');
}, (err) => {
    console.error(`validator failed: ${err}`);
    process.exit(2);
});
