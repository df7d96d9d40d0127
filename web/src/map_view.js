// The map view of one job (`/?job={id}`): the tiles as they are produced, moved on every new
// map revision, with a stats panel and display controls. While the job runs it follows the
// job's event stream; `window.glamViewer` exposes the view's state for the browser test.

import { apiUrl, getJob, getJson, withToken } from './api.js';
import { createScene } from './scene.js';
import { createMapTiles } from './map_tiles.js';
import { preloadTileDecoder } from './tile_loader.js';
import { createStatsPanel } from './stats_panel.js';
import { isTerminalState, subscribeJobEvents } from './job_events.js';

export async function openMapView(root, jobId) {
  const viewer = {
    jobId, ready: false, complete: false, state: null,
    submapEvents: 0, revisionEvents: 0, previewEvents: 0, tileLatenciesMs: [],
  };
  window.glamViewer = viewer;

  preloadTileDecoder();
  const scene = createScene(root.querySelector('#canvas-host'));
  const stats = createStatsPanel(root.querySelector('#stats'));
  const submapEventAt = new Map();  // submap id -> time its `submap` event arrived
  let autoFitDone = false;

  const tiles = createMapTiles(scene, jobId, ({ tileVisible }) => {
    const c = tiles.counters;
    if (tileVisible && !tileVisible.open && submapEventAt.has(tileVisible.submap)) {
      // Split: waiting for the map revision that places the submap (alignment), fetching and
      // decoding the tile, drawing the next frame.
      const e = tileVisible;
      const eventAt = submapEventAt.get(e.submap);
      viewer.tileLatenciesMs.push({
        submap: e.submap, ms: e.visibleAt - eventAt, revisionWaitMs: Math.max(0, e.seenAt - eventAt),
        loadMs: e.decodedAt - Math.max(e.seenAt, eventAt), drawMs: e.visibleAt - e.decodedAt,
      });
    }
    if (tileVisible && !scene.userMoved()) {
      scene.fit();
      autoFitDone = true;
    }
    stats.set({
      revision: c.revision, tilesLoaded: c.tilesLoaded, pointsLoaded: c.pointsLoaded, disconnected: c.disconnected,
      openSubmap: c.openSubmap,
    });
    // A map georeferenced while it is built: where it is, from the tileset, until report.json
    // (at the end) gives the fit's rms and the GeoJSON path too.
    const fromReport = viewer.location && viewer.location.rmsM !== null;
    if (!fromReport && (c.origin || viewer.location)) {
      viewer.location = c.origin
        ? { latitude: c.origin.latitude, longitude: c.origin.longitude, rmsM: null, geojsonUrl: null } : null;
      stats.set({ location: viewer.location });
    }
  });

  // The tile counters, live (revision, tilesLoaded, pointsLoaded, pointsConnected, ...).
  for (const key of Object.keys(tiles.counters)) {
    Object.defineProperty(viewer, key, { get: () => tiles.counters[key], enumerable: true });
  }
  viewer.tileMatrices = () => tiles.matrices();
  viewer.tilePointBoxes = () => tiles.pointBoxes();
  viewer.refresh = () => tiles.sync();  // fetch tileset.json again (what a `revision` event does)
  setupControls(root, scene, tiles);
  setInterval(() => stats.set({ renderFps: scene.renderFps() }), 1000);

  function showProgress(job) {
    const p = job.progress || {};
    stats.set({
      name: job.name || job.id, state: job.state, framesDone: p.frames_done, framesTotal: p.frames_total,
      fps: p.fps, eta: p.eta_s,
    });
  }

  // A completed, georeferenced map: where it is (report.json georeference), shown in the panel.
  async function showLocation() {
    let report;
    try {
      report = await getJson(`jobs/${encodeURIComponent(jobId)}/report.json`);
    } catch (err) {
      return;  // no report (yet): nothing to show
    }
    const g = report.georeference;
    if (!g || !g.ok || !g.origin) return;
    viewer.location = { latitude: g.origin.latitude, longitude: g.origin.longitude, rmsM: g.rms_m,
      geojsonUrl: withToken(apiUrl(`jobs/${encodeURIComponent(jobId)}/trajectory.geojson`)) };
    stats.set({ location: viewer.location });
  }

  async function finish(state) {
    viewer.state = state;
    if (state === 'completed') await showLocation();
    await tiles.settle();
    if (!scene.userMoved() || !autoFitDone) scene.fit();
    // The flag and title tell scripts (and the browser test) that nothing more will arrive.
    scene.onNextFrame(() => {
      viewer.complete = true;
      document.title = `GLAM map ${jobId}: ${state}`;
    });
  }

  let job;
  try {
    job = await getJob(jobId);
  } catch (err) {
    root.querySelector('#viewer-message').textContent = `Cannot open job ${jobId}: ${err.message}`;
    tiles.counters.errors.push(err.message);
    viewer.ready = true;
    return viewer;
  }
  showProgress(job);
  viewer.state = job.state;

  if (isTerminalState(job.state)) {
    await finish(job.state);
  } else {
    subscribeJobEvents(jobId, {
      state: async (data) => {
        viewer.state = data.state;
        stats.set({ state: data.state });
        if (isTerminalState(data.state)) {
          const final = await getJob(jobId);
          showProgress(final);
          await finish(data.state);
        }
      },
      progress: (p) => stats.set({ framesDone: p.frames_done, framesTotal: p.frames_total, fps: p.fps, eta: p.eta_s }),
      submap: (data, at) => {
        viewer.submapEvents += 1;
        // The tileset gets the submap's tile with the next map revision (its `revision` event);
        // before the first revision there is no tileset at all.
        if (tiles.has(data.submap_id)) {
          viewer.tileLatenciesMs.push({ submap: data.submap_id, ms: 0, revisionWaitMs: 0, loadMs: 0, drawMs: 0 });  // already visible
        } else {
          submapEventAt.set(data.submap_id, at);
        }
        if (tiles.counters.revision > 0) tiles.sync();
      },
      revision: (data) => {
        viewer.revisionEvents += 1;
        tiles.sync(data.revision);
      },
      // The submap being built grew: tileset.json lists its new provisional tile.
      preview: () => {
        viewer.previewEvents += 1;
        tiles.sync();
      },
    });
    // A job without a map revision yet has no tileset (404), or only the provisional tile of
    // its first submap, which the next `preview` event announces.
    if (job.progress && job.progress.revision > 0) tiles.sync();
  }
  viewer.ready = true;
  return viewer;
}

function setupControls(root, scene, tiles) {
  const colorBy = root.querySelector('#color-by');
  const pointSize = root.querySelector('#point-size');
  const navigation = root.querySelector('#navigation');
  const trajectory = root.querySelector('#show-trajectory');
  const flyHelp = root.querySelector('#fly-help');
  colorBy.addEventListener('change', () => tiles.setStyle({ colorBy: colorBy.value }));
  pointSize.addEventListener('input', () => tiles.setStyle({ pointSize: Number(pointSize.value) }));
  trajectory.addEventListener('change', () => tiles.setStyle({ showTrajectory: trajectory.checked }));
  navigation.addEventListener('change', () => {
    scene.setMode(navigation.value);
    flyHelp.hidden = navigation.value !== 'fly';
  });
  root.querySelector('#fit').addEventListener('click', () => scene.fit());
  tiles.setStyle({ colorBy: colorBy.value, pointSize: Number(pointSize.value), showTrajectory: trajectory.checked });
}
