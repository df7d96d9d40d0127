// Browser test of the web viewer (issue 7): headless Debian chromium driven by playwright-core.
//
//   node browser_test.mjs --glam GLAM_BIN --clip VIDEO --source-dir SRC --out DIR
//
// Starts `glam serve` (temporary data dir, free port, API token) with its default web root
// (the build's web/dist), uploads VIDEO through the page's file input, waits until the job is
// complete and the viewer has decoded every tile, then checks against the server:
//   * points decoded in the page (connected submaps) == the job's progress.points and
//     report.json points; one decoded tile per tileset child, each fetched exactly once;
//   * every tile sits at the final tileset's transform, its decoded points inside its bounding
//     volume in the world frame (axis convention); tiles whose transform changed during the
//     run were moved by the SSE `revision` path without being fetched again; every revision
//     event's tileset.json already had that revision; a further (injected) revision moves
//     every tile without reloading it;
//   * the canvas is not blank (non-background pixels); the screenshot is saved in DIR;
//   * a second, standard client (3DTilesRendererJS) loads `tileset.json?format=quantized`:
//     every child tile, with the same number of points.
// Prints the time from each submap's `submap` event to its tile being visible (benchmark).
// Exits 0 on success, 1 on a failed check (chromium missing is a failure, not a skip).
import { spawn } from 'node:child_process';
import { existsSync, mkdirSync, mkdtempSync, readFileSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { dirname, join, resolve } from 'node:path';
import { createInterface } from 'node:readline';
import { fileURLToPath } from 'node:url';
import { deflateSync } from 'node:zlib';

const here = dirname(fileURLToPath(import.meta.url));
const TOKEN = 'browser-test-token';
const CHROMIUM = process.env.GLAM_CHROMIUM || '/usr/bin/chromium';
const JOB_TIMEOUT_MS = 180_000;
const KEYFRAMES_PER_SUBMAP = 4;
// A path smoothing other than the default, entered in the form, must reach the job options.
const SMOOTH_WINDOW_S = 0.3;
const DETECT_MAX_SECONDS = 0.2;
// A preview interval other than the default (1 s), entered in the form, must reach the job.
const PREVIEW_INTERVAL_S = 0.5;
// The product's default budget, sent explicitly: checks that the form's field reaches the job.
const MAX_FEATURES = 2000;

// A DJI-style GPS track (.SRT) for the clip, from its ground truth (x east, y north, z up,
// metres) around a made-up origin (small-area spherical conversion; GPS noise is larger).
function srtFromTruth(truthPath) {
  const R = 6378137;
  const lat0 = 46.5, lon0 = 7.5, alt0 = 1200;
  const lines = readFileSync(truthPath, 'utf8').split('\n').filter((l) => l && !l.startsWith('#'));
  const stamp = (s) => {
    const ms = Math.round(s * 1000);
    const pad = (n, w) => String(n).padStart(w, '0');
    return `00:${pad(Math.floor(ms / 60000), 2)}:${pad(Math.floor(ms / 1000) % 60, 2)},${pad(ms % 1000, 3)}`;
  };
  return lines.map((line, i) => {
    const [t, x, y, z] = line.trim().split(/\s+/).map(Number);
    const lat = lat0 + (y / R) * 180 / Math.PI;
    const lon = lon0 + (x / (R * Math.cos(lat0 * Math.PI / 180))) * 180 / Math.PI;
    return `${i + 1}\n${stamp(t)} --> ${stamp(t + 0.03)}\n[latitude: ${lat.toFixed(8)}] [longitude: ${lon.toFixed(8)}] ` +
      `[rel_alt: ${z.toFixed(3)} abs_alt: ${(alt0 + z).toFixed(3)}]\n`;
  }).join('\n');
}

// A small RGB PNG of pseudo-random pixels (what the server's upload probe decodes).
function tinyPng(width, height, seed) {
  const crcTable = Array.from({ length: 256 }, (_, n) => {
    let c = n;
    for (let k = 0; k < 8; k += 1) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
    return c >>> 0;
  });
  const crc32 = (buf) => {
    let c = 0xffffffff;
    for (const b of buf) c = crcTable[(c ^ b) & 0xff] ^ (c >>> 8);
    return (c ^ 0xffffffff) >>> 0;
  };
  const chunk = (type, data) => {
    const body = Buffer.concat([Buffer.from(type, 'ascii'), data]);
    const out = Buffer.alloc(12 + data.length);
    out.writeUInt32BE(data.length, 0);
    body.copy(out, 4);
    out.writeUInt32BE(crc32(body), 8 + data.length);
    return out;
  };
  const header = Buffer.alloc(13);
  header.writeUInt32BE(width, 0);
  header.writeUInt32BE(height, 4);
  header[8] = 8;  // bit depth
  header[9] = 2;  // RGB
  const rows = Buffer.alloc(height * (1 + 3 * width));
  let state = seed * 2654435761 >>> 0;
  for (let y = 0; y < height; y += 1) {
    for (let i = 1; i <= 3 * width; i += 1) {
      state = (state * 1664525 + 1013904223) >>> 0;
      rows[y * (1 + 3 * width) + i] = state >>> 24;
    }
  }
  return Buffer.concat([Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]), chunk('IHDR', header),
    chunk('IDAT', deflateSync(rows)), chunk('IEND', Buffer.alloc(0))]);
}

function args() {
  const out = {};
  const a = process.argv.slice(2);
  for (let i = 0; i < a.length; i += 2) out[a[i].replace(/^--/, '')] = a[i + 1];
  for (const k of ['glam', 'clip', 'source-dir', 'out']) {
    if (!out[k]) throw new Error(`missing --${k}`);
  }
  return out;
}

let failures = 0;
function check(ok, message) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${message}`);
  if (!ok) failures += 1;
}

function startServer(glam, dataDir) {
  const env = { ...process.env };
  delete env.GLAM_WEB_ROOT;  // exercise the compiled-in default web root (the build's web/dist)
  delete env.GLAM_API_TOKEN;
  const child = spawn(glam, ['--log-level', 'warn', 'serve', '--data', dataDir, '--port', '0', '--token', TOKEN],
    { env, stdio: ['ignore', 'pipe', 'inherit'] });
  return new Promise((resolvePort, reject) => {
    const timer = setTimeout(() => reject(new Error('glam serve did not report its port within 30 s')), 30_000);
    child.once('exit', (code) => reject(new Error(`glam serve exited with ${code}`)));
    createInterface({ input: child.stdout }).on('line', (line) => {
      try {
        const j = JSON.parse(line);
        if (j.port) {
          clearTimeout(timer);
          resolvePort({ child, port: j.port });
        }
      } catch {
        // not the JSON line
      }
    });
  });
}

async function api(base, path) {
  const r = await fetch(`${base}/api/v1/${path}`, { headers: { Authorization: `Bearer ${TOKEN}` } });
  if (!r.ok) throw new Error(`GET ${path}: HTTP ${r.status}`);
  return r.json();
}

// Share of canvas pixels that differ from the clear colour, computed in the page.
function nonBackgroundShare(page) {
  return page.evaluate(() => {
    const src = document.querySelector('#canvas-host canvas');
    const c = document.createElement('canvas');
    c.width = src.width;
    c.height = src.height;
    const ctx = c.getContext('2d');
    ctx.drawImage(src, 0, 0);
    const { data } = ctx.getImageData(0, 0, c.width, c.height);
    let n = 0;
    for (let i = 0; i < data.length; i += 4) {
      if (Math.abs(data[i] - 0x10) + Math.abs(data[i + 1] - 0x14) + Math.abs(data[i + 2] - 0x18) > 24) n += 1;
    }
    return n / (data.length / 4);
  });
}

// World-frame axis-aligned box of a tileset child's boundingVolume.box under its transform
// (column-major 4x4).
function worldBoxOfChild(child) {
  const b = child.boundingVolume.box;
  const m = child.transform;
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (const sx of [-1, 1]) for (const sy of [-1, 1]) for (const sz of [-1, 1]) {
    const p = [0, 1, 2].map((k) => b[k] + sx * b[3 + k] + sy * b[6 + k] + sz * b[9 + k]);
    const w = [0, 1, 2].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
    for (let k = 0; k < 3; k += 1) {
      lo[k] = Math.min(lo[k], w[k]);
      hi[k] = Math.max(hi[k], w[k]);
    }
  }
  return [lo, hi];
}

function stats(values) {
  const v = [...values].sort((a, b) => a - b);
  if (v.length === 0) return 'none';
  const q = (p) => v[Math.min(v.length - 1, Math.floor(p * v.length))];
  return `n=${v.length} min=${v[0].toFixed(0)} median=${q(0.5).toFixed(0)} max=${v[v.length - 1].toFixed(0)} ms`;
}

async function main() {
  const opt = args();
  if (!existsSync(CHROMIUM)) {
    throw new Error(`${CHROMIUM} not found: the browser test needs Debian's chromium ` +
      '(`bash scripts/setup-deps.sh --with-test`, which `make test` runs)');
  }
  const dist = join(opt['source-dir'], 'web/dist/index.html');
  if (!existsSync(dist)) throw new Error(`${dist} missing: build the viewer (bash scripts/setup-node.sh)`);
  if (!existsSync(opt.clip)) throw new Error(`clip ${opt.clip} missing (CTest fixture fixture.synth_web)`);
  mkdirSync(opt.out, { recursive: true });
  let build;
  let chromium;
  try {
    ({ build } = await import('esbuild'));
    ({ chromium } = await import('playwright-core'));
    await import('3d-tiles-renderer');
  } catch (err) {
    throw new Error(`${err.message}: install the test's npm packages with bash scripts/setup-node.sh`);
  }

  // The second client's page: 3DTilesRendererJS bundled for the browser.
  const bundle = await build({
    entryPoints: [join(here, 'tiles_client.js')], bundle: true, format: 'iife', write: false,
    logLevel: 'warning', nodePaths: [join(here, 'node_modules')],
  });

  const dataDir = mkdtempSync(join(tmpdir(), 'glam-browser-test-'));
  const { child, port } = await startServer(resolve(opt.glam), dataDir);
  const base = `http://127.0.0.1:${port}`;
  const browser = await chromium.launch({
    executablePath: CHROMIUM,
    args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader'],
  });
  try {
    const page = await browser.newPage({ viewport: { width: 1280, height: 720 } });
    page.on('pageerror', (e) => console.log(`page error: ${e.message}`));
    page.on('console', (m) => { if (m.type() === 'error') console.log(`page console: ${m.text()}`); });

    // 1. Upload through the page (the token arrives as ?token= and is kept by the page).
    await page.goto(`${base}/?token=${TOKEN}`);
    // The video goes as a resumable upload: in 64 KiB chunks here (so the clip takes several),
    // and the link "drops" once, on the second chunk: the page must ask the server where it is
    // and go on, and the job must get exactly the clip's bytes.
    await page.evaluate(() => localStorage.setItem('glam.uploadChunkBytes', String(64 * 1024)));
    const patches = { sent: 0, aborted: 0 };
    await page.route(/\/api\/v1\/uploads\/[0-9a-f]{16}$/, (route) => {
      if (route.request().method() !== 'PATCH') return route.continue();
      if (++patches.sent === 2) {
        ++patches.aborted;
        return route.abort('connectionreset');
      }
      return route.continue();
    });
    // A live stream URL goes to the API as a stream job; this server was started without
    // --allow-streams, so the page shows the server's refusal and no job is created.
    await page.fill('#upload-form input[name=stream_url]', 'rtsp://127.0.0.1:9/live');
    await page.click('#upload-form button[type=submit]');
    await page.waitForFunction(() => /does not map live streams/.test(document.querySelector('#upload-status').textContent),
      null, { timeout: 10_000 });
    check(!/[?&]job=/.test(page.url()), 'a stream job on a server without --allow-streams was refused (403 shown in the form)');
    await page.fill('#upload-form input[name=stream_url]', '');
    await page.setInputFiles('#video-file', opt.clip);
    // Its GPS track, so that the map comes out georeferenced (metres, east-north-up).
    await page.setInputFiles('#upload-form input[name=telemetry]', {
      name: 'clip.SRT', mimeType: 'application/x-subrip',
      buffer: Buffer.from(srtFromTruth(join(dirname(opt.clip), 'gt_trajectory.tum'))),
    });
    // Short submaps, so that the small clip gives several submaps and map revisions.
    await page.click('#upload-form summary');
    await page.fill('#upload-form input[name=keyframes_per_submap]', String(KEYFRAMES_PER_SUBMAP));
    await page.fill('#upload-form input[name=smooth_window_s]', String(SMOOTH_WINDOW_S));
    // The adaptive schedule's longest gap, at the automatic interval (so the map is as without).
    await page.fill('#upload-form input[name=detect_max_seconds]', String(DETECT_MAX_SECONDS));
    await page.fill('#upload-form input[name=preview_interval_s]', String(PREVIEW_INTERVAL_S));
    // The form refuses an option that cannot apply before uploading anything: refining the
    // focal of intrinsics that were not given.
    await page.check('#upload-form input[name=refine_focal]');
    await page.click('#upload-form button[type=submit]');
    await page.waitForFunction(() => /intrinsics/.test(document.querySelector('#upload-status').textContent),
      null, { timeout: 10_000 });
    check(!/[?&]job=/.test(page.url()), 'refine_focal without intrinsics was refused by the form, no job created');
    await page.uncheck('#upload-form input[name=refine_focal]');
    await page.fill('#upload-form input[name=max_features]', String(MAX_FEATURES));
    // The default (400), so the job maps as it would without it.
    await page.fill('#upload-form input[name=global_refinement_keyframes]', '400');
    // A global shutter said explicitly (the demo clip's), so the job maps as it would without.
    await page.fill('#upload-form input[name=rolling_shutter_ms]', '0');
    const t0 = Date.now();
    await page.click('#upload-form button[type=submit]');
    await page.waitForURL(/[?&]job=[0-9a-f]{16}/, { timeout: 60_000 });
    const jobId = new URL(page.url()).searchParams.get('job');
    console.log(`job ${jobId} created through the page; following it in the map view`);

    // 2. Wait for the job and the viewer.
    await page.waitForFunction(() => window.glamViewer && window.glamViewer.complete, null,
      { timeout: JOB_TIMEOUT_MS, polling: 500 });
    console.log(`job finished and all tiles decoded after ${((Date.now() - t0) / 1000).toFixed(1)} s`);
    const viewer = await page.evaluate(() => {
      const v = window.glamViewer;
      return { ...v, matrices: v.tileMatrices(), pointBoxes: v.tilePointBoxes() };
    });
    const job = await api(base, `jobs/${jobId}`);
    const clipBytes = readFileSync(opt.clip).length;
    check(patches.aborted === 1 && patches.sent >= Math.ceil(clipBytes / (64 * 1024)) + 1 &&
      job.input.size_bytes === clipBytes,
      `the video went up in ${patches.sent} resumable chunks, one broken and resent, and the job got all ` +
      `${job.input.size_bytes} of its ${clipBytes} bytes`);
    const report = await api(base, `jobs/${jobId}/report.json`);
    const tileset = await api(base, `jobs/${jobId}/tileset.json`);
    const children = tileset.root.children || [];
    check(job.state === 'completed', `job state ${job.state}`);
    check(viewer.errors.length === 0, `viewer errors: ${JSON.stringify(viewer.errors)}`);
    check(children.length >= 2, `tileset has ${children.length} child tiles (several submaps expected)`);
    check(viewer.tilesLoaded === children.length, `viewer decoded ${viewer.tilesLoaded} tiles of ${children.length}`);
    check(viewer.pointsConnected === job.progress.points && viewer.pointsConnected > 0,
      `points decoded in the page (connected submaps) ${viewer.pointsConnected} == job progress.points ${job.progress.points}`);
    check(report.points === job.progress.points, `report.json points ${report.points} == progress.points ${job.progress.points}`);
    check(report.georeference && report.georeference.ok === true && report.georeference.frame === 'ENU',
      `the GPS track uploaded with the video georeferenced the map: ${JSON.stringify(report.georeference)}`);
    const shownLocation = await page.textContent('#map-location').catch(() => null);
    check(viewer.location && Math.abs(viewer.location.latitude - report.georeference.origin.latitude) < 1e-9 &&
      Math.abs(viewer.location.longitude - report.georeference.origin.longitude) < 1e-9 && shownLocation !== null,
      `the stats panel shows where the map is: ${shownLocation}`);
    const geojson = await (await fetch(`${base}${new URL(viewer.location.geojsonUrl, base).pathname}${new URL(viewer.location.geojsonUrl, base).search}`)).json();
    const path = geojson.features[0].geometry.coordinates;
    check(geojson.type === 'FeatureCollection' && path.length === report.frames_posed &&
      Math.abs(path[0][1] - report.georeference.origin.latitude) < 1e-4 && Math.abs(path[0][0] - report.georeference.origin.longitude) < 1e-4,
      `the panel's GeoJSON path link serves ${path.length} positions (frames posed ${report.frames_posed}) starting at the origin`);
    // The viewer reads the same place from the tileset's root transform (ECEF of the ENU
    // origin), which it has from the first georeferenced revision on, while the job runs.
    check(viewer.origin && Math.abs(viewer.origin.latitude - report.georeference.origin.latitude) < 1e-7 &&
      Math.abs(viewer.origin.longitude - report.georeference.origin.longitude) < 1e-7 &&
      Math.abs(viewer.origin.altitude - report.georeference.origin.altitude) < 0.01,
      `the tileset's root transform puts the map's origin at ${JSON.stringify(viewer.origin)} (report.json: ` +
      `${JSON.stringify(report.georeference.origin)})`);
    check(viewer.firstGeoreferencedRevision !== null && viewer.firstGeoreferencedRevision <= viewer.revision,
      `first georeferenced revision the viewer saw: ${viewer.firstGeoreferencedRevision}`);
    check(Array.isArray(tileset.root.transform) && tileset.root.transform.length === 16 &&
      Math.hypot(tileset.root.transform[12], tileset.root.transform[13], tileset.root.transform[14]) > 6.3e6,
      'the georeferenced tileset has a root transform to earth-centred coordinates (the viewer ignores it)');
    check(viewer.revision === tileset.extras.revision, `viewer revision ${viewer.revision} == tileset revision ${tileset.extras.revision}`);
    // Once per tile version: the end-of-run global refinement rewrites the main map's tiles
    // under new URIs (report.json global_refinement.applied), so a viewer that watched the run
    // fetches those twice; moving a tile on a revision never fetches it (step 4).
    const fetches = Object.values(viewer.tileFetches);
    const maxFetches = report.global_refinement && report.global_refinement.applied ? 2 : 1;
    check(fetches.length === children.length && fetches.every((n) => n >= 1 && n <= maxFetches),
      `each tile fetched once per version (at most ${maxFetches}): ${JSON.stringify(viewer.tileFetches)}`);

    // 3. Tiles at the final transforms; moved on revision without reloading points.
    let placed = true;
    let moved = 0;
    for (const c of children) {
      const m = viewer.matrices[c.extras.submap];
      if (!m) { placed = false; continue; }
      if (m.current.some((x, i) => Math.abs(x - c.transform[i]) > 1e-9 * (1 + Math.abs(x)))) placed = false;
      if (m.first.some((x, i) => x !== m.current[i])) moved += 1;
    }
    check(placed, 'every tile sits at its transform of the final tileset');
    // Axis convention: the decoded points, rotated from glTF y-up and placed by the transform,
    // must fall inside the child's bounding volume (a box in the submap's z-up frame) mapped
    // to the world by the same transform.
    const outside = children.filter((c) => {
      const [lo, hi] = worldBoxOfChild(c);
      const got = viewer.pointBoxes[c.extras.submap];
      if (!got) return true;
      const tol = 1e-3 * Math.max(...hi.map((h, i) => h - lo[i]));
      return got[0].some((x, i) => x < lo[i] - tol) || got[1].some((x, i) => x > hi[i] + tol);
    }).map((c) => c.extras.submap);
    check(outside.length === 0, `decoded points inside their tiles' bounding volumes in the world frame (outside: ${JSON.stringify(outside)})`);
    console.log(`revisions applied by the viewer: ${JSON.stringify(viewer.revisionsApplied)}; ` +
      `submap events ${viewer.submapEvents}, revision events ${viewer.revisionEvents}; ` +
      `tiles moved after loading: ${moved}, transform updates ${viewer.transformUpdates}`);
    // Contract: a `revision` event is sent after that revision's tileset.json is written.
    check(viewer.staleTilesets === 0,
      `tileset.json fetched after a revision event had that revision (${viewer.staleTilesets} stale fetches; ` +
      'a stale tileset means the engine announced a revision before writing its tileset)');
    if (report.revision > 1) {
      check(viewer.revisionEvents > 1 && viewer.revisionsApplied.length > 1,
        `several revisions followed over SSE (${viewer.revisionEvents} events, ${viewer.revisionsApplied.length} applied)`);
    }
    if (moved > 0) check(viewer.transformUpdates >= moved, `${moved} tiles moved by revisions without reloading`);
    // The submap being built was shown before it completed (a provisional tile per `preview`
    // event; one that arrives while the submap completes may be skipped), and none is left.
    console.log(`preview events ${viewer.previewEvents}, provisional tiles decoded ${viewer.previewsLoaded}: ` +
      `${JSON.stringify(viewer.previewFetches)}`);
    check(viewer.previewEvents > 0, `the server announced provisional tiles of the submaps being built (${viewer.previewEvents} preview events)`);
    check(viewer.previewsLoaded > 0, `the viewer showed ${viewer.previewsLoaded} provisional tiles while submaps were built`);
    check(viewer.openSubmap === null && children.every((c) => !c.extras.open),
      'no provisional tile is left in the final tileset or the view');


    // 4. Screenshot: not blank; saved as the test's artifact.
    const share = await nonBackgroundShare(page);
    check(share > 0.005, `non-background pixels: ${(share * 100).toFixed(2)} % of the canvas`);
    const shot = join(opt.out, 'viewer.png');
    writeFileSync(shot, await page.screenshot());
    console.log(`screenshot: ${shot}`);

    // A chain of submaps without loops may keep its transforms from one revision to the next,
    // so the move path is also driven directly: a next revision that shifts every tile by
    // 10 m east, as the SSE `revision` handler would fetch it.
    const shifted = JSON.parse(JSON.stringify(tileset));
    shifted.extras.revision += 1;
    shifted.asset.tilesetVersion = String(shifted.extras.revision);
    for (const c of shifted.root.children) c.transform[12] += 10;
    await page.route(/\/tileset\.json(\?|$)/, (route) => route.fulfill({ contentType: 'application/json', body: JSON.stringify(shifted) }));
    await page.evaluate(() => window.glamViewer.refresh());
    await page.unroute(/\/tileset\.json(\?|$)/);
    const after = await page.evaluate(() => {
      const v = window.glamViewer;
      return { matrices: v.tileMatrices(), tileFetches: v.tileFetches, pointsLoaded: v.pointsLoaded, revision: v.revision };
    });
    const movedAll = shifted.root.children.every((c) => {
      const m = after.matrices[c.extras.submap];
      return m && m.current.every((x, i) => Math.abs(x - c.transform[i]) <= 1e-9 * (1 + Math.abs(x)));
    });
    check(movedAll && after.revision === shifted.extras.revision,
      `revision ${shifted.extras.revision}: every tile moved to its new transform`);
    check(JSON.stringify(after.tileFetches) === JSON.stringify(viewer.tileFetches) && after.pointsLoaded === viewer.pointsLoaded,
      'tiles moved without being fetched or decoded again');

    // 5. Benchmark: submap event -> tile visible.
    const latencies = viewer.tileLatenciesMs.map((l) => l.ms);
    console.log(`BENCH submap event -> tile visible: ${stats(latencies)}`);
    console.log(`BENCH   waiting for the map revision: ${stats(viewer.tileLatenciesMs.map((l) => l.revisionWaitMs))}`);
    console.log(`BENCH   fetch + Draco decode: ${stats(viewer.tileLatenciesMs.map((l) => l.loadMs))}`);
    console.log(`BENCH   next frame drawn: ${stats(viewer.tileLatenciesMs.map((l) => l.drawMs))}`);
    let dracoBytes = 0;
    let quantizedBytes = 0;
    for (const c of children) {
      const uri = new URL(c.content.uri, `${base}/api/v1/jobs/${jobId}/tileset.json`);
      const size = async (u) => (await (await fetch(u, { headers: { Authorization: `Bearer ${TOKEN}` } })).arrayBuffer()).byteLength;
      dracoBytes += await size(uri);
      uri.pathname = uri.pathname.replace(/\.glb$/, '.quantized.glb');
      quantizedBytes += await size(uri);
    }
    const perPoint = (b) => (b / viewer.pointsLoaded).toFixed(2);
    console.log(`BENCH tile bytes per point (whole GLB incl. camera path; raw float xyz + uint8 rgb = 15): ` +
      `Draco ${perPoint(dracoBytes)}, quantized ${perPoint(quantizedBytes)} (${viewer.pointsLoaded} points, ${children.length} tiles)`);
    const align = (report.alignment && report.alignment.per_submap) || [];
    console.log(`BENCH   server alignment per submap (report.json total_s): ${stats(align.map((a) => a.total_s * 1000))}`);

    // 6. The start page's job table shows the job with its warnings (the job JSON's; on this
    // clip usually the undetermined focal length of a short nadir flight).
    await page.goto(`${base}/?token=${TOKEN}`);
    await page.waitForSelector(`#jobs tr[data-id="${jobId}"]`, { timeout: 30_000 });
    const shownWarnings = await page.$$eval(`#jobs tr[data-id="${jobId}"] .warning`, (els) => els.map((e) => e.textContent));
    check(JSON.stringify(shownWarnings) === JSON.stringify(job.warnings || []),
      `job table warnings ${JSON.stringify(shownWarnings)} == job JSON warnings ${JSON.stringify(job.warnings)}`);
    console.log(`job table: ${shownWarnings.length} warning(s) shown`);
    check(job.options && job.options.detect_max_seconds === DETECT_MAX_SECONDS,
      `the form's longest detection gap reached the job: options.detect_max_seconds ${job.options && job.options.detect_max_seconds} == ${DETECT_MAX_SECONDS}`);
    check(job.options && job.options.smooth_window_s === SMOOTH_WINDOW_S,
      `the form's path smoothing reached the job: options.smooth_window_s ${job.options && job.options.smooth_window_s} == ${SMOOTH_WINDOW_S}`);
    check(job.options && job.options.preview_interval_s === PREVIEW_INTERVAL_S,
      `the form's preview interval reached the job: options.preview_interval_s ${job.options && job.options.preview_interval_s} == ${PREVIEW_INTERVAL_S}`);
    check(job.options && job.options.max_features === MAX_FEATURES && !('refine_focal' in job.options),
      `the form's feature budget reached the job, the unticked boxes did not: options ${JSON.stringify(job.options)}`);
    check(job.options && job.options.global_refinement_keyframes === 400,
      `the form's refinement limit reached the job: options.global_refinement_keyframes ${job.options && job.options.global_refinement_keyframes}`);
    check(job.options && job.options.rolling_shutter_ms === 0,
      `the form's rolling-shutter readout reached the job: options.rolling_shutter_ms ${job.options && job.options.rolling_shutter_ms}`);
    // Disconnected parts (usually none on this clip) are linked with the job JSON's URLs.
    const shownParts = await page.$$eval(`#jobs tr[data-id="${jobId}"] .part a`, (els) => els.map((e) => new URL(e.href).pathname));
    const expectedParts = (job.parts || []).flatMap((p) => [p.urls.trajectory, p.urls.points]);
    check(shownParts.length === expectedParts.length && shownParts.every((path, i) => path === expectedParts[i]),
      `job table part links ${JSON.stringify(shownParts)} match the job JSON's parts ${JSON.stringify(expectedParts)}`);
    // The COLMAP model is linked with the job JSON's URLs, and the links serve it.
    const shownColmap = await page.$$eval(`#jobs tr[data-id="${jobId}"] .colmap a`, (els) => els.map((e) => e.href));
    const expectedColmap = [job.urls.colmap_cameras, job.urls.colmap_images, job.urls.colmap_points3D];
    const colmapHeads = await Promise.all(shownColmap.map(async (href) => (await (await fetch(href)).text()).split('\n')[0]));
    check(shownColmap.length === 3 && shownColmap.every((href, i) => new URL(href).pathname === expectedColmap[i]) &&
      colmapHeads[0].startsWith('# Camera list') && colmapHeads[1].startsWith('# Image list') &&
      colmapHeads[2].startsWith('# 3D point list'),
      `job table COLMAP links ${JSON.stringify(shownColmap.map((h) => new URL(h).pathname))} serve the model (${JSON.stringify(colmapHeads)})`);

    // 6b. Photos through the same form: several images chosen at once become one photo job,
    // sent as a resumable image set, one PUT per photo under its clean name ("DJI 0003.png"
    // goes as DJI_0003.png). The link "drops" on the second photo: it is sent again whole.
    const photoFiles = [1, 2, 3].map((i) => ({
      name: i === 3 ? 'DJI 0003.png' : `DJI_000${i}.png`, mimeType: 'image/png', buffer: tinyPng(64, 48, i),
    }));
    const puts = [];
    await page.route(/\/api\/v1\/uploads\/[0-9a-f]{16}\/images\/[^/?]+/, (route) => {
      const name = decodeURIComponent(new URL(route.request().url()).pathname.split('/').pop());
      puts.push(name);
      if (name === 'DJI_0002.png' && puts.filter((n) => n === name).length === 1) return route.abort('connectionreset');
      return route.continue();
    });
    await page.setInputFiles('#video-file', photoFiles);
    check((await page.textContent('#drop-zone .file-name')) === '3 photos', 'the form shows the chosen photos');
    await page.uncheck('#open-after-upload');
    await page.click('#upload-form button[type=submit]');
    const created = await page.waitForFunction(() => {
      const m = document.querySelector('#upload-status').textContent.match(/Job ([0-9a-f]{16}) created/);
      return m && m[1];
    }, null, { timeout: 30_000 });
    const photoJobId = await created.jsonValue();
    check(!/[?&]job=/.test(page.url()), 'with "open the map view" unticked the page stays on the job list');
    const photoJob = await api(base, `jobs/${photoJobId}`);
    check(photoJob.input && photoJob.input.images === 3 && photoJob.input.filename === '3 photos',
      `photos uploaded through the page became a photo job: ${JSON.stringify(photoJob.input)}`);
    check(JSON.stringify(puts) === JSON.stringify(['DJI_0001.png', 'DJI_0002.png', 'DJI_0002.png', 'DJI_0003.png']),
      `the photos went as an image set, one PUT each under its clean name, the broken one again: ${JSON.stringify(puts)}`);

    // 7. A standard 3D Tiles client on the quantized tileset, from a page of the same origin.
    const clientPage = await browser.newPage();
    clientPage.on('pageerror', (e) => console.log(`tiles client page error: ${e.message}`));
    await clientPage.route(`${base}/__browser_test/tiles.html`, (route) => route.fulfill({
      contentType: 'text/html',
      body: `<!doctype html><html><body><script>${bundle.outputFiles[0].text}</script></body></html>`,
    }));
    await clientPage.goto(`${base}/__browser_test/tiles.html`);
    const quantized = await clientPage.evaluate(
      ([url, token]) => window.runTilesClient(url, token, 60000),
      [`${base}/api/v1/jobs/${jobId}/tileset.json?format=quantized`, TOKEN]);
    check(quantized.childTiles === children.length && quantized.modelsLoaded === children.length,
      `3DTilesRendererJS loaded ${quantized.modelsLoaded} of ${quantized.childTiles} child tiles (tileset: ${children.length})`);
    check(quantized.points === viewer.pointsLoaded,
      `3DTilesRendererJS decoded ${quantized.points} points == viewer's ${viewer.pointsLoaded} (all tiles)`);
  } finally {
    await browser.close();
    const exited = new Promise((r) => child.once('exit', r));
    child.kill('SIGTERM');
    await exited;
    rmSync(dataDir, { recursive: true, force: true });
  }
}

main().then(() => {
  console.log(failures === 0 ? 'browser test passed' : `browser test: ${failures} check(s) failed`);
  process.exit(failures === 0 ? 0 : 1);
}, (err) => {
  console.error(`browser test failed: ${err.stack || err.message}`);
  process.exit(1);
});
