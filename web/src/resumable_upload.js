// Sends a video as a resumable upload (docs/api.md, "Resumable uploads"): POST /uploads, then
// PATCH chunks from the offset the server has, retrying a chunk that failed (the link dropped,
// the server restarted) after asking the server where it is. The upload's id is remembered in
// localStorage under the file's name, size and date, so choosing the same file again (after a
// page reload, or after giving up) goes on from the bytes the server kept instead of byte 0.
import { ApiError, apiFetch, apiUrl, authHeaders } from './api.js';

const DEFAULT_CHUNK_BYTES = 16 << 20;
// Chunk size override (bytes), for tests that want several chunks from a small clip.
const CHUNK_KEY = 'glam.uploadChunkBytes';
const MAX_ATTEMPTS = 8;           // consecutive failures of one chunk before giving up
const MAX_BACKOFF_MS = 30_000;

function chunkBytes() {
  const n = Number(localStorage.getItem(CHUNK_KEY));
  return Number.isInteger(n) && n >= 1024 ? n : DEFAULT_CHUNK_BYTES;
}

function sessionKey(file) {
  return `glam.upload.${file.name}|${file.size}|${file.lastModified}`;
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

async function openUpload(file) {
  const key = sessionKey(file);
  const known = localStorage.getItem(key);
  if (known) {
    try {
      const upload = await getUpload(known);
      if (upload.size === file.size) return upload;
    } catch (err) {
      if (!(err instanceof ApiError && err.status === 404)) throw err;  // expired or used: a new one
    }
  }
  const response = await apiFetch(apiUrl('uploads'), {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ size: file.size, filename: file.name }),
  });
  const upload = await response.json();
  localStorage.setItem(key, upload.id);
  return upload;
}

// One PATCH through XHR (fetch has no upload progress). onBytes(bytes of this chunk sent).
function sendChunk(id, offset, blob, onBytes) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open('PATCH', apiUrl(`uploads/${encodeURIComponent(id)}`));
    for (const [k, v] of Object.entries(authHeaders())) xhr.setRequestHeader(k, v);
    xhr.setRequestHeader('Upload-Offset', String(offset));
    xhr.setRequestHeader('Content-Type', 'application/offset+octet-stream');
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

// Uploads `file` completely; returns the upload's id. onProgress(fraction in 0..1, note): note
// is a message while a chunk is being retried, else ''.
export async function uploadResumable(file, onProgress = () => {}) {
  let upload = await openUpload(file);
  let offset = upload.offset;
  const chunk = chunkBytes();
  let failures = 0;
  onProgress(offset / file.size, offset > 0 ? 'resuming' : '');
  while (offset < file.size) {
    const end = Math.min(file.size, offset + chunk);
    try {
      upload = await sendChunk(upload.id, offset, file.slice(offset, end),
        (sent) => onProgress((offset + sent) / file.size, ''));
      offset = upload.offset;
      failures = 0;
    } catch (err) {
      if (permanent(err)) throw err;
      if (++failures >= MAX_ATTEMPTS) {
        throw new Error(`${err.message}; ${Math.round((100 * offset) / file.size)} % are kept on the server, ` +
          'choose the same file again to go on');
      }
      const wait = Math.min(MAX_BACKOFF_MS, 500 * 2 ** failures);
      onProgress(offset / file.size, `${err.message}; retrying in ${Math.round(wait / 1000)} s`);
      await sleep(wait);
      // Where the server is now (it keeps the bytes of a broken chunk).
      try {
        offset = (await getUpload(upload.id)).offset;
      } catch (e) {
        if (permanent(e)) throw e;  // gone (expired, deleted): nothing to resume
      }
    }
  }
  return upload.id;
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
  if (options && Object.keys(options).length > 0) body.options = options;
  const response = await apiFetch(apiUrl('jobs'), {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify(body),
  });
  // The uploads are the job's now.
  localStorage.removeItem(sessionKey(video));
  if (telemetry) localStorage.removeItem(sessionKey(telemetry));
  return response.json();
}
