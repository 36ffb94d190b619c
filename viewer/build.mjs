// Bundles the player (src/player.js with three.js) into one minified script:
//   node build.mjs OUTFILE      (CMake runs it: src/view/CMakeLists.txt; default dist/player.js)
import * as esbuild from 'esbuild';
import { fileURLToPath } from 'node:url';
import path from 'node:path';

const here = path.dirname(fileURLToPath(import.meta.url));
const outfile = process.argv[2] || path.join(here, 'dist', 'player.js');
await esbuild.build({
  entryPoints: [path.join(here, 'src', 'player.js')],
  bundle: true,
  minify: true,
  format: 'iife',
  target: 'es2020',
  legalComments: 'inline',
  loader: { '.css': 'text' },
  logLevel: 'warning',
  outfile,
});
