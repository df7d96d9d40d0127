// Fetches one GLB tile with the API token and decodes it with GLTFLoader + DRACOLoader. The
// Draco decoder files are copied into dist/draco/ at build time and served by our own server
// (no CDN). Returns the decoded point clouds and camera paths of the tile.

import * as THREE from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { DRACOLoader } from 'three/examples/jsm/loaders/DRACOLoader.js';
import { apiFetch } from './api.js';

let loader = null;

function gltfLoader() {
  if (loader) return loader;
  const draco = new DRACOLoader();
  draco.setDecoderPath(new URL('draco/', document.baseURI).toString());
  draco.preload();
  loader = new GLTFLoader();
  loader.setDRACOLoader(draco);
  return loader;
}

// Starts fetching and compiling the Draco decoder (~0.5 s in software) before the first tile.
export function preloadTileDecoder() {
  gltfLoader();
}

export async function loadTile(url) {
  const buffer = await (await apiFetch(url)).arrayBuffer();
  const gltf = await gltfLoader().parseAsync(buffer, '');
  const points = [];
  const lines = [];
  gltf.scene.traverse((o) => {
    if (o.isPoints) points.push(o);
    else if (o.isLine) lines.push(o);
  });
  let pointCount = 0;
  for (const p of points) pointCount += p.geometry.getAttribute('position').count;
  return { scene: gltf.scene, points, lines, pointCount, bytes: buffer.byteLength };
}

// COLOR_0 holds the video's colours as stored bytes; with a linear output colour space they
// reach the screen unchanged (three.js would otherwise treat them as linear and brighten them
// when converting to sRGB; see stack-notes).
export const OUTPUT_COLOR_SPACE = THREE.LinearSRGBColorSpace;
