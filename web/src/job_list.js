// The job table of the start page: state, progress, ETA and actions, refreshed by polling
// GET /jobs (one request every 2 s is cheaper for the server than an event stream per job,
// and event streams are a limited resource: --max-sse-clients).

import { apiUrl, cancelJob, deleteJob, finishJob, listJobs, withToken } from './api.js';
import { escapeHtml, formatCount, formatDuration, jobFraction } from './format.js';

const DOWNLOADS = [
  ['trajectory', 'trajectory.tum'],
  ['points', 'points.ply'],
  ['map_glb', 'map.glb'],
  ['report', 'report.json'],
];
// The map as a COLMAP sparse model (docs/file-formats.md), for dense reconstruction and
// Gaussian-splatting tools.
const COLMAP_FILES = ['cameras.txt', 'images.txt', 'points3D.txt'];

function colmapDownloads(job) {
  const links = COLMAP_FILES.map((file) => {
    const href = withToken(apiUrl(`jobs/${job.id}/colmap/${file}`));
    return `<a href="${escapeHtml(href)}" download="${escapeHtml(file)}">${file}</a>`;
  }).join(' ');
  return `<span class="colmap" title="the map as a COLMAP sparse model">COLMAP: ${links}</span>`;
}

// What the run could not do well (textureless frames, an undetermined focal length, ...):
// the job JSON's `warnings`, the same sentences as report.json.
function warnings(job) {
  return (job.warnings || []).map((w) => `<div class="warning">${escapeHtml(w)}</div>`).join('');
}

// Parts of the flight that could not be linked to the map (job JSON `parts`, report.json
// `parts`): each has its own trajectory and point cloud, in its own frame.
function partDownloads(job) {
  return (job.parts || []).map((part) => {
    const title = `frames ${part.first_frame}–${part.last_frame}, ${part.frames_posed} posed, ` +
      `${part.points} points; not linked to the map, in its own frame`;
    const links = [['trajectory', 'trajectory.tum'], ['points', 'points.ply']].map(([key, file]) => {
      const href = withToken(part.urls[key]);
      return `<a href="${escapeHtml(href)}" download="part${part.part}_${file}">${file}</a>`;
    }).join(' ');
    return `<span class="part" data-part="${escapeHtml(String(part.part))}" title="${escapeHtml(title)}">part ${escapeHtml(String(part.part))}: ${links}</span>`;
  }).join(' ');
}

function row(job) {
  const p = job.progress || {};
  const fraction = jobFraction(job);
  const active = job.state === 'queued' || job.state === 'running';
  const downloads = job.state === 'completed'
    ? DOWNLOADS.map(([, file]) => {
      const href = withToken(apiUrl(`jobs/${job.id}/${file}`));
      return `<a href="${escapeHtml(href)}" download>${file}</a>`;
    }).join(' ') + ` ${colmapDownloads(job)}` + (job.parts && job.parts.length ? ` ${partDownloads(job)}` : '')
    : '';
  return `<tr data-id="${escapeHtml(job.id)}" data-state="${escapeHtml(job.state)}">
    <td><a href="?job=${encodeURIComponent(job.id)}">${escapeHtml(job.name || job.id)}</a></td>
    <td class="state ${escapeHtml(job.state)}">${escapeHtml(job.state)}${job.error ? `<div class="error">${escapeHtml(job.error)}</div>` : ''}${warnings(job)}</td>
    <td><progress max="1" ${fraction === null ? '' : `value="${fraction}"`}></progress>
        <span class="small">${escapeHtml(p.stage || '')} ${formatCount(p.frames_done)}/${p.frames_total > 0 ? formatCount(p.frames_total) : '?'}</span></td>
    <td>${active ? formatDuration(p.eta_s) : '–'}</td>
    <td>${formatCount(p.submaps_completed)}</td>
    <td>${formatCount(p.points)}</td>
    <td class="actions">
      <a class="button" href="?job=${encodeURIComponent(job.id)}">view</a>
      ${job.state === 'running' && job.input && job.input.stream_url
    ? '<button data-action="finish" title="End the live stream here and finish the map">finish</button>' : ''}
      ${active ? '<button data-action="cancel">cancel</button>' : ''}
      <button data-action="delete">delete</button>
      ${downloads}
    </td></tr>`;
}

export function setupJobList(root) {
  const body = root.querySelector('#jobs tbody');
  const status = root.querySelector('#jobs-status');
  let timer = null;

  async function refresh() {
    try {
      const page = await listJobs(50);
      body.innerHTML = page.jobs.map(row).join('');
      status.textContent = page.total > page.jobs.length
        ? `${page.jobs.length} of ${page.total} jobs` : `${page.total} job${page.total === 1 ? '' : 's'}`;
    } catch (err) {
      status.textContent = err.status === 401
        ? 'The server needs an API token: enter it above.' : `Cannot list jobs: ${err.message}`;
    }
  }

  body.addEventListener('click', async (e) => {
    const button = e.target.closest('button[data-action]');
    if (!button) return;
    const id = button.closest('tr').dataset.id;
    const action = button.dataset.action;
    if (action === 'delete' && !confirm('Delete this job and all its files?')) return;
    button.disabled = true;
    try {
      if (action === 'cancel') await cancelJob(id);
      else if (action === 'finish') await finishJob(id);
      else await deleteJob(id);
    } catch (err) {
      status.textContent = `${action} failed: ${err.message}`;
    }
    refresh();
  });

  function start() {
    refresh();
    if (timer === null) timer = setInterval(refresh, 2000);
  }
  return { refresh, start };
}
