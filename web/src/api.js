// REST client of the viewer. Every URL is relative to the page (the server may be reached
// under any host name or behind a path prefix). The API token comes from `?token=` in the page
// URL or from the token field, is kept in localStorage, and is sent as a Bearer header on
// fetch/XHR; EventSource and plain download links cannot set headers, so they get `?token=`.

const TOKEN_KEY = 'glam.apiToken';

export function apiUrl(path) {
  return new URL(`api/v1/${path}`, document.baseURI).toString();
}

export function getToken() {
  return localStorage.getItem(TOKEN_KEY) || '';
}

export function setToken(token) {
  if (token) localStorage.setItem(TOKEN_KEY, token);
  else localStorage.removeItem(TOKEN_KEY);
}

// Moves `?token=` from the address bar into localStorage so that it is not left in the
// history or in shared links.
export function adoptTokenFromUrl() {
  const url = new URL(location.href);
  const token = url.searchParams.get('token');
  if (token === null) return;
  setToken(token);
  url.searchParams.delete('token');
  history.replaceState(null, '', url.toString());
}

export function authHeaders() {
  const token = getToken();
  return token ? { Authorization: `Bearer ${token}` } : {};
}

// For URLs that the browser fetches by itself (EventSource, <a download>).
export function withToken(url) {
  const token = getToken();
  if (!token) return url;
  const u = new URL(url, document.baseURI);
  u.searchParams.set('token', token);
  return u.toString();
}

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;
    this.code = code;
  }
}

// The server's JSON error body ({"error": {"code", "message"}}), or the status line when the
// body is not one.
function apiError(status, body) {
  const err = body && body.error ? body.error : { code: 'error', message: `HTTP ${status}` };
  return new ApiError(status, err.code, err.message);
}

async function errorFrom(response) {
  let body = null;
  try {
    body = await response.json();
  } catch {
    // not JSON: the status line is the message
  }
  return apiError(response.status, body);
}

export async function apiFetch(url, init = {}) {
  const response = await fetch(url, { ...init, headers: { ...authHeaders(), ...(init.headers || {}) } });
  if (!response.ok) throw await errorFrom(response);
  return response;
}

export async function getJson(path) {
  return (await apiFetch(apiUrl(path), { cache: 'no-cache' })).json();
}

export const listJobs = (limit = 50) => getJson(`jobs?limit=${limit}`);
export const getJob = (id) => getJson(`jobs/${encodeURIComponent(id)}`);

export async function cancelJob(id) {
  return (await apiFetch(apiUrl(`jobs/${encodeURIComponent(id)}/cancel`), { method: 'POST' })).json();
}

// Ends a running live-stream job's input; the job completes with the map of what arrived.
export async function finishJob(id) {
  return (await apiFetch(apiUrl(`jobs/${encodeURIComponent(id)}/finish`), { method: 'POST' })).json();
}

// A live-stream job (servers started with --allow-streams): the URL and the job options.
export async function createStreamJob(streamUrl, options) {
  const response = await apiFetch(apiUrl('jobs'), {
    method: 'POST',
    headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ stream_url: streamUrl, options }),
  });
  return response.json();
}

export async function deleteJob(id) {
  await apiFetch(apiUrl(`jobs/${encodeURIComponent(id)}`), { method: 'DELETE' });
}
