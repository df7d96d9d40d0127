// The browser test's second, standard 3D Tiles client: 3DTilesRendererJS loads the quantized
// tileset (`tileset.json?format=quantized`) exactly as any third-party viewer would, and
// reports what it decoded. Bundled by browser_test.mjs with esbuild into an IIFE that defines
// window.runTilesClient.
import * as THREE from 'three';
import { TilesRenderer } from '3d-tiles-renderer';

// Resolves with {childTiles, modelsLoaded, points, errors} once every child tile of the root is
// loaded (or rejects after timeoutMs).
async function runTilesClient(tilesetUrl, token, timeoutMs) {
  const renderer = new THREE.WebGLRenderer({ preserveDrawingBuffer: true });
  renderer.setSize(640, 360);
  document.body.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(60, 640 / 360, 0.01, 100000);

  const tiles = new TilesRenderer(tilesetUrl);
  if (token) tiles.fetchOptions = { headers: { Authorization: `Bearer ${token}` } };
  tiles.errorTarget = 0;  // refine everything: every child tile is wanted
  tiles.setCamera(camera);
  tiles.setResolutionFromRenderer(camera, renderer);
  scene.add(tiles.group);

  const result = { childTiles: -1, modelsLoaded: 0, points: 0, pointsPerTile: {}, errors: [] };
  tiles.addEventListener('load-tileset', () => {
    const root = tiles.root;
    if (root) result.childTiles = root.children.length;
    // Look at the whole map from above so that no child is culled by the frustum.
    const sphere = new THREE.Sphere();
    tiles.getBoundingSphere(sphere);
    camera.position.copy(sphere.center).add(new THREE.Vector3(0, 0, sphere.radius * 2.5));
    camera.up.set(0, 1, 0);
    camera.lookAt(sphere.center);
    camera.far = sphere.radius * 10;
    camera.updateProjectionMatrix();
  });
  tiles.addEventListener('load-model', ({ scene: model, tile }) => {
    result.modelsLoaded += 1;
    let n = 0;
    model.traverse((o) => {
      if (o.isPoints) n += o.geometry.getAttribute('position').count;
    });
    result.points += n;
    result.pointsPerTile[tile.content ? tile.content.uri : String(result.modelsLoaded)] = n;
  });
  tiles.addEventListener('load-error', ({ error, url }) => result.errors.push(`${url}: ${error && error.message}`));

  const start = performance.now();
  await new Promise((resolve, reject) => {
    function frame() {
      camera.updateMatrixWorld();
      tiles.update();
      renderer.render(scene, camera);
      if (result.childTiles >= 0 && result.modelsLoaded >= result.childTiles) {
        resolve();
      } else if (result.errors.length > 0) {
        reject(new Error(result.errors.join('; ')));
      } else if (performance.now() - start > timeoutMs) {
        reject(new Error(`timeout: ${result.modelsLoaded} of ${result.childTiles} child tiles loaded`));
      } else {
        requestAnimationFrame(frame);
      }
    }
    frame();
  });
  return result;
}

window.runTilesClient = runTilesClient;
