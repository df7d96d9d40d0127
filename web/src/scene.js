// The three.js scene of the map view: renderer, z-up camera, orbit and fly navigation,
// fit-to-map and an on-demand render loop (software WebGL on a server box is slow, so a frame
// is drawn only when something changed, or continuously while flying).

import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { FlyControls } from 'three/examples/jsm/controls/FlyControls.js';
import { OUTPUT_COLOR_SPACE } from './tile_loader.js';

export function createScene(container) {
  // Colours are shown as stored (see tile_loader.js): no colour management on the way in or out.
  THREE.ColorManagement.enabled = false;
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true });
  renderer.outputColorSpace = OUTPUT_COLOR_SPACE;
  renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
  renderer.setClearColor(0x101418, 1);
  container.appendChild(renderer.domElement);

  const scene = new THREE.Scene();
  const camera = new THREE.PerspectiveCamera(50, 1, 0.1, 10000);
  camera.up.set(0, 0, 1);  // the map's world frame is z-up
  camera.position.set(0, -50, 50);
  const mapRoot = new THREE.Group();
  scene.add(mapRoot);

  const orbit = new OrbitControls(camera, renderer.domElement);
  orbit.enableDamping = false;
  const fly = new FlyControls(camera, renderer.domElement);
  fly.dragToLook = true;
  fly.rollSpeed = 0.6;
  fly.enabled = false;
  let mode = 'orbit';
  let userMoved = false;
  let needsRender = true;
  const timer = new THREE.Timer();
  const afterRender = [];
  const frameTimes = [];

  orbit.addEventListener('change', () => { needsRender = true; });
  orbit.addEventListener('start', () => { userMoved = true; });
  renderer.domElement.addEventListener('pointerdown', () => { if (mode === 'fly') userMoved = true; });

  function resize() {
    const w = container.clientWidth || 1;
    const h = container.clientHeight || 1;
    renderer.setSize(w, h, false);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
    needsRender = true;
  }
  new ResizeObserver(resize).observe(container);
  resize();

  function mapBox() {
    mapRoot.updateMatrixWorld(true);
    return new THREE.Box3().setFromObject(mapRoot, true);
  }

  // Looks at the whole map from the south, 40 degrees above the horizon.
  function fit() {
    const box = mapBox();
    if (box.isEmpty()) return;
    const center = box.getCenter(new THREE.Vector3());
    const radius = Math.max(box.getSize(new THREE.Vector3()).length() / 2, 1e-3);
    // The bounding sphere is loose for a flat map under a flight path: 0.8 of its fitting distance.
    const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 0.8;
    const dir = new THREE.Vector3(0, -Math.cos(0.7), Math.sin(0.7));
    camera.position.copy(center).addScaledVector(dir, distance);
    camera.near = Math.max(distance / 1000, 1e-4);
    camera.far = distance * 10 + radius * 4;
    camera.updateProjectionMatrix();
    orbit.target.copy(center);
    camera.lookAt(center);
    orbit.update();
    fly.movementSpeed = radius / 4;
    needsRender = true;
  }

  function setMode(next) {
    mode = next;
    orbit.enabled = next === 'orbit';
    fly.enabled = next === 'fly';
    if (next === 'orbit') {
      // Orbit around the point the fly camera was looking at, at the same distance as before.
      const ahead = new THREE.Vector3(0, 0, -1).applyQuaternion(camera.quaternion);
      const d = Math.max(camera.position.distanceTo(orbit.target), 1e-3);
      orbit.target.copy(camera.position).addScaledVector(ahead, d);
      camera.up.set(0, 0, 1);
      orbit.update();
    }
    needsRender = true;
  }

  function loop() {
    requestAnimationFrame(loop);
    timer.update();
    const dt = timer.getDelta();
    if (mode === 'fly') {
      fly.update(dt);
      needsRender = true;
    }
    if (!needsRender) return;
    needsRender = false;
    renderer.render(scene, camera);
    const now = performance.now();
    frameTimes.push(now);
    while (frameTimes.length && frameTimes[0] < now - 1000) frameTimes.shift();
    for (const f of afterRender.splice(0)) f(now);
  }
  requestAnimationFrame(loop);

  return {
    renderer,
    mapRoot,
    fit,
    setMode,
    userMoved: () => userMoved,
    invalidate: () => { needsRender = true; },
    // Calls f(time) after the next frame that is drawn (a tile counts as visible then).
    onNextFrame: (f) => { afterRender.push(f); needsRender = true; },
    renderFps: () => frameTimes.length,
  };
}
