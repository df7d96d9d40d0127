// Usage: node validate.mjs FILE.glb
// Prints the Khronos glTF Validator's report as JSON on stdout; exits 0 when the report has
// no errors, 1 when it has errors, 2 on bad usage or an unreadable file.
import { readFile } from 'node:fs/promises';
import validator from 'gltf-validator';

const file = process.argv[2];
if (!file) {
  console.error('usage: node validate.mjs FILE.glb');
  process.exit(2);
}
let data;
try {
  data = new Uint8Array(await readFile(file));
} catch (e) {
  console.error(`cannot read ${file}: ${e.message}`);
  process.exit(2);
}
// Tiles are self-contained GLBs: any external resource request is itself a failure.
const report = await validator.validateBytes(data, {
  uri: file,
  maxIssues: 100,
  externalResourceFunction: (uri) => Promise.reject(new Error(`external resource ${uri}`)),
});
console.log(JSON.stringify(report, null, 1));
process.exit(report.issues.numErrors === 0 ? 0 : 1);
