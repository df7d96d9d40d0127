// Resumable uploads (docs/api.md, "Resumable uploads"), so a dropped link or a server restart
// costs a retry, not the whole upload:
//  * a video (and its .SRT track): POST /uploads, then PATCH chunks from the offset the server
//    has, retrying a chunk that failed after asking the server where it is;
//  * photos: one image set (POST /uploads {kind: "images"}), one PUT per photo, skipping the
//    photos the set already holds; a photo whose request failed is sent again whole.
// The upload's id is remembered in localStorage under the files' names, sizes and dates, so
// choosing the same files again (after a page reload, or after giving up) goes on from what
// the server kept instead of from the start.
import { ApiError, apiFetch, apiUrl, authHeaders } from './api.js';
import { cleanImageName } from './image_names.js';

const DEFAULT_CHUNK_BYTES = 16 << 20;
// Chunk size override (bytes), for tests that want several chunks from a small clip.
const CHUNK_KEY = 'glam.uploadChunkBytes';
const MAX_ATTEMPTS = 8;           // consecutive failures of one chunk or photo before giving up
const MAX_BACKOFF_MS = 30_000;

function chunkBytes() {
  const n = Number(localStorage.getItem(CHUNK_KEY));
  return Number.isInteger(n) && n >= 1024 ? n : DEFAULT_CHUNK_BYTES;
}

function sessionKey(file) {
  return `glam.upload.${file.name}|${file.size}|${file.lastModified}`;
}

// 32-bit FNV-1a of a string, as 8 hex digits (a short localStorage key for a set of photos).
function fnv1a(text) {
  let h = 0x811c9dc5;
  for (let i = 0; i < text.length; i += 1) {
    h ^= text.charCodeAt(i);
    h = Math.imul(h, 0x01000193) >>> 0;
  }
  return h.toString(16).padStart(8, '0');
}

function photoSetKey(photos) {
  const list = photos.map((f) => `${f.name}|${f.size}|${f.lastModified}`).join('\n');
  return `glam.imageset.${photos.length}.${fnv1a(list)}`;
}

const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

// Errors after which retrying cannot help: the request itself is refused.
function permanent(err) {
  return err instanceof ApiError && err.status >= 400 && err.status < 500 &&
    !['offset_mismatch', 'upload_busy'].includes(err.code);
}

async function getUpload(id) {
  return (await apiFetch(apiUrl(`uploads/${encodeURIComponent(id)}`), { cache: 'no-store' })).json();
}

// The upload remembered under `key` when the server still has it and `fits` it, else a new one
// from `request` ({size, filename, kind}).
async function openUpload(key, request, fits) {
  const known = localStorage.getItem(key);
  if (known) {
    try {
      const upload = await getUpload(known);
      if (fits(upload)) return upload;
    } catch (err) {
      if (!(err instanceof ApiError && err.status === 404)) throw err;  // expired or used: a new one
    }
  }
  const response = await apiFetch(apiUrl('uploads'), {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(request),
  });
  const upload = await response.json();
  localStorage.setItem(key, upload.id);
  return upload;
}

// One request with a body through XHR (fetch has no upload progress); resolves with the JSON
// answer of a 200. onBytes(bytes of this body sent).
function sendBody(method, url, headers, blob, onBytes) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open(method, url);
    for (const [k, v] of Object.entries({ ...authHeaders(), ...headers })) xhr.setRequestHeader(k, v);
    xhr.responseType = 'json';
    xhr.upload.onprogress = (e) => onBytes(e.loaded);
    xhr.onload = () => {
      if (xhr.status === 200) {
        resolve(xhr.response);
      } else {
        const err = xhr.response && xhr.response.error ? xhr.response.error : { code: 'error', message: `HTTP ${xhr.status}` };
        reject(new ApiError(xhr.status, err.code, err.message));
      }
    };
    xhr.onerror = () => reject(new ApiError(0, 'network', 'network error during upload'));
    xhr.send(blob);
  });
}

// Runs `attempt` until it succeeds: a refusal is thrown at once, other failures are retried
// with backoff (the note says so) after `recover` (which asks the server where it is), up to
// MAX_ATTEMPTS in a row; then `giveUp(err)` is thrown.
async function withRetries(attempt, recover, onNote, giveUp) {
  for (let failures = 0; ;) {
    try {
      return await attempt();
    } catch (err) {
      if (permanent(err)) throw err;
      if (++failures >= MAX_ATTEMPTS) throw giveUp(err);
      const wait = Math.min(MAX_BACKOFF_MS, 500 * 2 ** failures);
      onNote(`${err.message}; retrying in ${Math.round(wait / 1000)} s`);
      await sleep(wait);
      try {
        await recover();
      } catch (e) {
        if (permanent(e)) throw e;  // gone (expired, deleted): nothing to resume
      }
    }
  }
}

// Uploads `file` completely; returns the upload's id. onProgress(fraction in 0..1, note): note
// is a message while a chunk is being retried, else ''.
export async function uploadResumable(file, onProgress = () => {}) {
  let upload = await openUpload(sessionKey(file), { size: file.size, filename: file.name },
    (u) => u.kind !== 'images' && u.size === file.size);
  let offset = upload.offset;
  const chunk = chunkBytes();
  onProgress(offset / file.size, offset > 0 ? 'resuming' : '');
  const url = apiUrl(`uploads/${encodeURIComponent(upload.id)}`);
  while (offset < file.size) {
    const end = Math.min(file.size, offset + chunk);
    upload = await withRetries(
      // After a failure the server may hold the whole chunk already (only its answer was lost).
      () => (offset >= end ? getUpload(upload.id)
        : sendBody('PATCH', url, { 'Upload-Offset': String(offset), 'Content-Type': 'application/offset+octet-stream' },
          file.slice(offset, end), (sent) => onProgress((offset + sent) / file.size, ''))),
      async () => { offset = (await getUpload(upload.id)).offset; },  // it keeps a broken chunk's bytes
      (note) => onProgress(offset / file.size, note),
      (err) => new Error(`${err.message}; ${Math.round((100 * offset) / file.size)} % are kept on the server, ` +
        'choose the same file again to go on'));
    offset = upload.offset;
  }
  return upload.id;
}

async function createJob(body, options) {
  if (options && Object.keys(options).length > 0) body.options = options;
  const response = await apiFetch(apiUrl('jobs'), {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  return response.json();
}

// The video and its GPS track (a DJI .SRT File or null) as resumable uploads, then the job.
export async function createJobFromUploads(video, telemetry, options, onProgress) {
  const total = video.size + (telemetry ? telemetry.size : 0);
  const uploadId = await uploadResumable(video, (f, note) => onProgress((f * video.size) / total, note));
  let telemetryId = null;
  if (telemetry) {
    telemetryId = await uploadResumable(telemetry,
      (f, note) => onProgress((video.size + f * telemetry.size) / total, note));
  }
  const body = { upload_id: uploadId };
  if (telemetryId) body.telemetry_upload_id = telemetryId;
  const job = await createJob(body, options);
  // The uploads are the job's now.
  localStorage.removeItem(sessionKey(video));
  if (telemetry) localStorage.removeItem(sessionKey(telemetry));
  return job;
}

// Photos as one image set, each photo sent whole unless the set has it already, then the
// photo job. onProgress(fraction in 0..1, note).
export async function createJobFromPhotos(photos, options, onProgress) {
  const names = photos.map((f) => cleanImageName(f.name));
  const seen = new Map();
  names.forEach((name, i) => {
    if (seen.has(name)) throw new Error(`${photos[seen.get(name)].name} and ${photos[i].name} would both be sent as ${name}`);
    seen.set(name, i);
  });
  const total = photos.reduce((sum, f) => sum + f.size, 0);
  const key = photoSetKey(photos);
  let set = await openUpload(key, { kind: 'images', size: total },
    (u) => u.kind === 'images' && u.size === total);
  // The set's photos: from the set's list (GET), then kept up to date as photos are stored
  // (a PUT's answer leaves the list out).
  const stored = () => new Map((set.images || []).map((image) => [image.name, image.size]));
  let have = stored();
  let done = photos.reduce((sum, f, i) => sum + (have.get(names[i]) === f.size ? f.size : 0), 0);
  onProgress(done / total, done > 0 ? 'resuming' : '');
  for (let i = 0; i < photos.length; i += 1) {
    if (have.get(names[i]) === photos[i].size) continue;
    const url = apiUrl(`uploads/${encodeURIComponent(set.id)}/images/${encodeURIComponent(names[i])}`);
    const type = photos[i].type && photos[i].type.startsWith('image/') ? photos[i].type : 'application/octet-stream';
    await withRetries(
      () => (have.get(names[i]) === photos[i].size ? null  // stored; only the answer was lost
        : sendBody('PUT', url, { 'Content-Type': type }, photos[i], (sent) => onProgress((done + sent) / total, ''))),
      async () => { set = await getUpload(set.id); have = stored(); },
      (note) => onProgress(done / total, `${photos[i].name}: ${note}`),
      (err) => new Error(`${photos[i].name}: ${err.message}; ${i} of ${photos.length} photos are kept on the server, ` +
        'choose the same photos again to go on'));
    have.set(names[i], photos[i].size);
    done += photos[i].size;
  }
  const job = await createJob({ upload_id: set.id }, options);
  localStorage.removeItem(key);  // the set is the job's now
  return job;
}
