// Bundles the report's 3D view (src/viewer.js with three.js) into dist/viewer.js, the one
// minified script the C++ build embeds into every report (src/fringe/io/CMakeLists.txt).
//
//   node build.mjs            rebuild dist/viewer.js (commit it with its sources)
//   node build.mjs --check    exit 1 unless dist/viewer.js is what its sources give, byte for
//                             byte; exit 77 (skipped) when node_modules is absent, unless
//                             FRINGE_REQUIRE_SHARED_DATA=1 (CI), where that fails too
//
// The versions are pinned in package-lock.json (`npm ci`); the output depends on nothing else.
import { readFileSync, writeFileSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const check = process.argv.includes('--check');
const dist = join(here, 'dist', 'viewer.js');

let esbuild;
try {
  esbuild = await import('esbuild');
} catch (e) {
  const why = `web/viewer/node_modules is absent (run npm ci in web/viewer, or ` +
              `scripts/install-deps.sh): ${e.code || e.message}`;
  if (process.env.FRINGE_REQUIRE_SHARED_DATA === '1') {
    console.error(`FAIL: ${why}; FRINGE_REQUIRE_SHARED_DATA=1 needs it`);
    process.exit(1);
  }
  console.log(`SKIP: ${why}`);
  process.exit(77);
}

const result = await esbuild.build({
  absWorkingDir: here,
  entryPoints: ['src/viewer.js'],
  bundle: true,
  minify: true,
  format: 'iife',
  target: ['es2020'],
  charset: 'ascii',        // the C++ side embeds it as bytes; ASCII keeps it plain
  legalComments: 'eof',    // three.js' MIT licence notice stays in the bundle
  write: false,
  logLevel: 'warning',
});
const bundle = Buffer.from(result.outputFiles[0].contents);

if (!check) {
  writeFileSync(dist, bundle);
  console.log(`wrote ${dist} (${bundle.length} bytes)`);
  process.exit(0);
}
let committed;
try {
  committed = readFileSync(dist);
} catch (e) {
  console.error(`FAIL: ${dist} is missing (node build.mjs writes it)`);
  process.exit(1);
}
if (!committed.equals(bundle)) {
  console.error(`FAIL: ${dist} (${committed.length} bytes) is not what its sources give ` +
                `(${bundle.length} bytes): run node build.mjs in web/viewer and commit dist/viewer.js`);
  process.exit(1);
}
console.log(`ok: ${dist} matches its sources (${bundle.length} bytes)`);
