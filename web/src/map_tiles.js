// The tiles of one job in the scene. Each submap is a group whose matrix is world_from_submap
// (from tileset.json) times the +90 deg X rotation of glTF content; a new map revision only
// changes these matrices, the decoded points stay (tiles are immutable, docs/architecture.md).
// The submap being built comes as a provisional tile (extras.open) under a new URL whenever it
// grew; it is drawn slightly transparent and replaced like any tile whose URL changed.

import * as THREE from 'three';
import { Z_UP_FROM_Y_UP, fetchTileset } from './tileset.js';
import { loadTile } from './tile_loader.js';

const TRAJECTORY_COLOR = new THREE.Color(1.0, 0.67, 0.0);
const DISCONNECTED_COLOR = new THREE.Color(1.0, 0.15, 0.15);

export function submapColor(submap) {
  return new THREE.Color().setHSL((submap * 0.618034) % 1, 0.75, 0.55);
}

// scene: from createScene. onChange(): stats changed. Counters are kept for the stats panel
// and the browser test (window.glamViewer).
export function createMapTiles(scene, jobId, onChange) {
  const tiles = new Map();  // submap -> entry
  const style = { colorBy: 'rgb', pointSize: 2, showTrajectory: true };
  const counters = {
    revision: -1, tilesLoaded: 0, pointsLoaded: 0, pointsConnected: 0, disconnected: 0, expectedTiles: 0,
    // The provisional tile of the submap being built, once loaded: {submap, keyframes, points};
    // not counted in tilesLoaded / pointsLoaded. previewsLoaded: such tiles decoded so far.
    openSubmap: null, previewsLoaded: 0, previewFetches: {},
    tileFetches: {}, transformUpdates: 0, staleTilesets: 0, revisionsApplied: [], bytesLoaded: 0, errors: [],
    // Where the map is on the earth ({latitude, longitude, altitude} of its ENU origin) once a
    // revision was georeferenced, and the first revision that was.
    origin: null, firstGeoreferencedRevision: null,
  };
  let syncing = null;
  let dirty = false;
  const pending = new Set();  // tile loads in flight

  function applyStyle(entry) {
    if (!entry.content) return;
    const color = submapColor(entry.submap);
    for (const p of entry.points) {
      p.material.size = style.pointSize;
      p.material.transparent = entry.open;
      p.material.opacity = entry.open ? 0.6 : 1.0;
      p.material.vertexColors = style.colorBy === 'rgb' && p.geometry.hasAttribute('color');
      p.material.color.copy(style.colorBy === 'rgb' ? new THREE.Color(1, 1, 1) : color);
      p.material.needsUpdate = true;
    }
    for (const l of entry.lines) {
      l.visible = style.showTrajectory;
      l.material.color.copy(style.colorBy === 'rgb' ? TRAJECTORY_COLOR : color);
    }
    if (entry.marker) entry.marker.visible = entry.disconnected;
  }

  function setTransform(entry, worldFromSubmap) {
    entry.group.matrix.copy(worldFromSubmap).multiply(Z_UP_FROM_Y_UP);
    entry.group.matrixWorldNeedsUpdate = true;
    entry.worldFromSubmap = worldFromSubmap.clone();
  }

  async function load(entry) {
    const fetches = entry.open ? counters.previewFetches : counters.tileFetches;
    fetches[entry.submap] = (fetches[entry.submap] || 0) + 1;
    const tile = await loadTile(entry.url);
    if (tiles.get(entry.submap) !== entry) return;  // replaced meanwhile
    entry.decodedAt = performance.now();
    entry.points = tile.points.map((p) => {
      p.material = new THREE.PointsMaterial({ sizeAttenuation: false });
      return p;
    });
    entry.lines = tile.lines.map((l) => {
      l.material = new THREE.LineBasicMaterial();
      return l;
    });
    const box = new THREE.Box3().setFromObject(tile.scene);
    entry.marker = new THREE.Box3Helper(box, DISCONNECTED_COLOR);
    tile.scene.add(entry.marker);
    entry.content = tile.scene;
    entry.pointCount = tile.pointCount;
    applyStyle(entry);
    entry.group.add(tile.scene);
    if (entry.open) counters.previewsLoaded += 1;
    counters.bytesLoaded += tile.bytes;
    recount();
    scene.onNextFrame((t) => {
      entry.visibleAt = t;
      onChange({ tileVisible: entry });
    });
  }

  function recount() {
    let connected = 0;
    let disconnected = 0;
    let loaded = 0;
    let points = 0;
    counters.openSubmap = null;
    for (const e of tiles.values()) {
      if (e.open) {
        if (e.content) counters.openSubmap = { submap: e.submap, keyframes: e.keyframes, points: e.pointCount };
        continue;
      }
      if (e.disconnected) disconnected += 1;
      if (e.content && !e.disconnected) connected += e.pointCount;
      if (e.content) {
        loaded += 1;
        points += e.pointCount;
      }
    }
    counters.pointsConnected = connected;
    counters.disconnected = disconnected;
    counters.tilesLoaded = loaded;
    counters.pointsLoaded = points;
  }

  function remove(entry) {
    scene.mapRoot.remove(entry.group);
    tiles.delete(entry.submap);
    if (entry.content) entry.content.traverse((o) => { if (o.geometry) o.geometry.dispose(); });
    recount();
  }

  async function syncOnce() {
    const tileset = await fetchTileset(jobId);
    if (!tileset || tileset.revision < counters.revision) return;
    const seen = new Set();
    for (const t of tileset.tiles) {
      seen.add(t.submap);
      let entry = tiles.get(t.submap);
      // A different tile: the job was mapped again, the submap being built grew, or its own
      // tile replaces the provisional one.
      if (entry && entry.url !== t.url) {
        remove(entry);
        entry = undefined;
      }
      if (!entry) {
        entry = {
          submap: t.submap, url: t.url, open: t.open, keyframes: t.keyframes, group: new THREE.Group(), content: null,
          points: [], lines: [],
        };
        entry.group.matrixAutoUpdate = false;
        entry.group.name = `submap ${t.submap}`;
        tiles.set(t.submap, entry);
        scene.mapRoot.add(entry.group);
        setTransform(entry, t.worldFromSubmap);
        entry.firstWorldFromSubmap = t.worldFromSubmap.clone();
        entry.seenAt = performance.now();  // the first tileset that lists this tile arrived
        const loading = load(entry).catch((err) => {
          counters.errors.push(`tile ${t.submap}: ${err.message}`);
          if (tiles.get(t.submap) === entry) tiles.delete(t.submap);
          scene.mapRoot.remove(entry.group);
        }).finally(() => pending.delete(loading));
        pending.add(loading);
      } else if (!entry.worldFromSubmap.equals(t.worldFromSubmap)) {
        setTransform(entry, t.worldFromSubmap);
        if (entry.content) counters.transformUpdates += 1;
      }
      entry.disconnected = t.disconnected;
      applyStyle(entry);
    }
    for (const entry of [...tiles.values()]) if (!seen.has(entry.submap)) remove(entry);
    if (tileset.revision !== counters.revision) counters.revisionsApplied.push(tileset.revision);
    counters.revision = tileset.revision;
    counters.origin = tileset.origin;
    if (tileset.origin && counters.firstGeoreferencedRevision === null) {
      counters.firstGeoreferencedRevision = tileset.revision;
    }
    recount();
    scene.invalidate();
    counters.expectedTiles = tileset.tiles.length;
    onChange({});
  }

  // Coalesces bursts of events: one fetch at a time, one more if something arrived meanwhile.
  // wanted: the revision an event announced; if tileset.json is still older, it is fetched
  // again shortly (counted as stale: the server should write the tileset before the event).
  let wanted = 0;
  let retry = null;
  function sync(wantedRevision = 0) {
    if (wantedRevision > wanted) wanted = wantedRevision;
    if (syncing) {
      dirty = true;
      return syncing;
    }
    syncing = (async () => {
      do {
        dirty = false;
        try {
          await syncOnce();
        } catch (err) {
          counters.errors.push(`tileset: ${err.message}`);
        }
      } while (dirty);
      if (counters.revision < wanted) {
        counters.staleTilesets += 1;
        if (retry === null) retry = setTimeout(() => { retry = null; sync(); }, 500);
      }
    })().finally(() => { syncing = null; });
    return syncing;
  }

  // Resolves once the latest tileset is applied and every tile in it is decoded.
  async function settle() {
    await sync();
    while (pending.size > 0) await Promise.all([...pending]);
  }

  function setStyle(patch) {
    Object.assign(style, patch);
    for (const e of tiles.values()) applyStyle(e);
    scene.invalidate();
  }

  return {
    sync,
    settle,
    setStyle,
    counters,
    // The submap's own tile is loaded (not only its provisional one).
    has: (submap) => tiles.has(submap) && tiles.get(submap).content !== null && !tiles.get(submap).open,
    // submap -> {first, current}: world_from_submap (column-major) when the tile appeared and now.
    matrices: () => Object.fromEntries([...tiles.values()].map((e) => [e.submap, {
      first: [...e.firstWorldFromSubmap.elements], current: [...e.worldFromSubmap.elements],
    }])),
    // submap -> world-frame axis-aligned box [min, max] of the tile's decoded points.
    pointBoxes: () => {
      scene.mapRoot.updateMatrixWorld(true);
      const out = {};
      for (const e of tiles.values()) {
        const box = new THREE.Box3();
        for (const p of e.points) box.expandByObject(p, true);
        if (!box.isEmpty()) out[e.submap] = [box.min.toArray(), box.max.toArray()];
      }
      return out;
    },
    allLoaded: () => [...tiles.values()].every((e) => e.content !== null),
  };
}
