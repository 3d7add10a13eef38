// Validates glTF/GLB files with Khronos' glTF-Validator (the npm package `gltf-validator`, installed
// by scripts/validate_gltf.sh, never a dependency of derma). Fails on any error or warning;
// infos (e.g. texture coordinates no material uses yet) are listed but allowed.
// Usage: node scripts/validate_gltf.js VALIDATOR_DIR FILE.glb... (a FILE ending in `#static` is
// a mesh without morph targets; every other file must carry them).
const path = require('path');
const fs = require('fs');
const validator = require(path.join(process.argv[2], 'node_modules', 'gltf-validator'));
(async () => {
  let bad = 0;
  for (const arg of process.argv.slice(3)) {
    const isStatic = arg.endsWith('#static');
    const f = isStatic ? arg.slice(0, -'#static'.length) : arg;
    const r = await validator.validateBytes(new Uint8Array(fs.readFileSync(f)), { maxIssues: 100 });
    const i = r.issues;
    console.log(`${f}: ${i.numErrors} errors, ${i.numWarnings} warnings, ${i.numInfos} infos; ` +
      `${r.info.totalVertexCount} vertices, ${r.info.drawCallCount} draw calls, morph targets: ${r.info.hasMorphTargets}`);
    for (const m of i.messages.filter((m) => m.severity <= 1)) console.log(`  ${m.code} ${m.pointer}: ${m.message}`);
    if (i.numErrors + i.numWarnings > 0 || (!isStatic && !r.info.hasMorphTargets)) bad += 1;
  }
  process.exit(bad ? 1 : 0);
})();
