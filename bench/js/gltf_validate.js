// Usage: node gltf_validate.js FILE.gltf|glb ...  (run by bench/lod_validate.sh). Prints, per file, the
// Khronos validator's error, warning and info counts and every error and warning.
const validator = require('gltf-validator');
const fs = require('fs');
const path = require('path');
(async () => {
  let bad = 0;
  for (const f of process.argv.slice(2)) {
    const data = new Uint8Array(fs.readFileSync(f));
    const report = await validator.validateBytes(data, {
      uri: f,
      externalResourceFunction: (uri) => new Promise((ok, no) => {
        fs.readFile(path.join(path.dirname(f), decodeURIComponent(uri)), (e, d) => e ? no(e.toString()) : ok(new Uint8Array(d)));
      }),
    });
    const i = report.issues;
    console.log(`${f}: errors ${i.numErrors} warnings ${i.numWarnings} infos ${i.numInfos}`);
    for (const m of i.messages) if (m.severity <= 1) console.log(`  [${m.severity}] ${m.code} ${m.pointer || ''} ${m.message}`);
    if (i.numErrors > 0) bad++;
  }
  process.exit(bad ? 1 : 0);
})();
