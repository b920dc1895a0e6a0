// Runs the Khronos glTF validator on each file given; prints one JSON line per file
// ({file, errors, warnings, infos, messages}) and exits 1 when any has an error.
import fs from "node:fs";
import validator from "gltf-validator";

let failed = false;
for (const file of process.argv.slice(2)) {
  const report = await validator.validateBytes(new Uint8Array(fs.readFileSync(file)), { maxIssues: 100 });
  const i = report.issues;
  const messages = i.messages.filter((m) => m.severity === 0).slice(0, 10).map((m) => `${m.code} ${m.pointer || ""}: ${m.message}`);
  console.log(JSON.stringify({ file, errors: i.numErrors, warnings: i.numWarnings, infos: i.numInfos, messages }));
  if (i.numErrors > 0) failed = true;
}
process.exit(failed ? 1 : 0);
