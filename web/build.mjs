// `npm run build`: bundles src/main.js with esbuild and writes the static viewer to dist/
// (index.html, style.css, app.js and three's Draco decoder files, served by `glam serve`).
import { build } from 'esbuild';
import { copyFile, mkdir, rm } from 'node:fs/promises';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

const here = dirname(fileURLToPath(import.meta.url));
const dist = join(here, 'dist');
const draco = join(here, 'node_modules/three/examples/jsm/libs/draco');

await rm(dist, { recursive: true, force: true });
await mkdir(join(dist, 'draco'), { recursive: true });
await build({
  entryPoints: [join(here, 'src/main.js')],
  bundle: true,
  format: 'esm',
  minify: true,
  sourcemap: true,
  target: ['es2020'],
  outfile: join(dist, 'app.js'),
  logLevel: 'warning',
});
for (const f of ['index.html', 'style.css']) await copyFile(join(here, f), join(dist, f));
for (const f of ['draco_decoder.wasm', 'draco_wasm_wrapper.js', 'draco_decoder.js']) {
  await copyFile(join(draco, f), join(dist, 'draco', f));
}
console.log(`web: wrote ${dist}`);
