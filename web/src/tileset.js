// Reads a job's tileset.json (3D Tiles 1.1, docs/file-formats.md) into what the viewer needs:
// the revision, where a georeferenced map is on the earth (the origin of its east-north-up
// world, from the root transform) and, per submap, the tile URL, world_from_submap and the
// disconnected flag.

import * as THREE from 'three';
import { apiFetch, apiUrl } from './api.js';
import { geodeticFromEcef } from './geodesy.js';

// glTF content is y-up; 3D Tiles clients rotate it +90 deg about X to the tileset's z-up
// frame (the GLB stores submap (x, y, z) as (x, z, -y); this rotation maps it back).
export const Z_UP_FROM_Y_UP = new THREE.Matrix4().makeRotationX(Math.PI / 2);

export function tilesetUrl(jobId) {
  return apiUrl(`jobs/${encodeURIComponent(jobId)}/tileset.json`);
}

// Returns null while the job has no tileset yet (404 not_available / 409).
export async function fetchTileset(jobId) {
  const url = tilesetUrl(jobId);
  let response;
  try {
    response = await apiFetch(url, { cache: 'no-cache' });
  } catch (err) {
    if (err.status === 404 || err.status === 409) return null;
    throw err;
  }
  return parseTileset(await response.json(), url);
}

export function parseTileset(json, baseUrl) {
  const revision = json.extras && Number.isFinite(json.extras.revision)
    ? json.extras.revision : Number(json.asset && json.asset.tilesetVersion) || 0;
  const tiles = [];
  for (const child of (json.root && json.root.children) || []) {
    if (!child.content || !child.content.uri) continue;
    const extras = child.extras || {};
    // `transform` is column-major, as Matrix4.fromArray expects.
    const worldFromSubmap = new THREE.Matrix4();
    if (Array.isArray(child.transform) && child.transform.length === 16) worldFromSubmap.fromArray(child.transform);
    tiles.push({
      submap: Number.isInteger(extras.submap) ? extras.submap : tiles.length,
      url: new URL(child.content.uri, baseUrl).toString(),
      worldFromSubmap,
      disconnected: Boolean(extras.disconnected),
      // The submap being built (a provisional tile, replaced by the submap's own once placed).
      open: Boolean(extras.open),
      keyframes: Number.isInteger(extras.keyframes) ? extras.keyframes : null,
      box: child.boundingVolume && child.boundingVolume.box,
    });
  }
  // ECEF from ENU: its translation (column-major 12..14) is the ENU origin.
  const t = json.root && json.root.transform;
  const origin = Array.isArray(t) && t.length === 16 ? geodeticFromEcef(t[12], t[13], t[14]) : null;
  return { revision, tiles, origin };
}
