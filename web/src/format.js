// Small text formatters shared by the job list and the stats panel.

export function formatDuration(seconds) {
  if (seconds === undefined || seconds === null || seconds < 0) return '–';
  const s = Math.round(seconds);
  if (s < 60) return `${s} s`;
  if (s < 3600) return `${Math.floor(s / 60)} min ${s % 60} s`;
  return `${Math.floor(s / 3600)} h ${Math.floor((s % 3600) / 60)} min`;
}

export function formatCount(n) {
  return Number(n || 0).toLocaleString('en-US');
}

export function formatBytes(n) {
  if (!n) return '–';
  const units = ['B', 'KB', 'MB', 'GB', 'TB'];
  let i = 0;
  let v = n;
  while (v >= 1024 && i < units.length - 1) {
    v /= 1024;
    i += 1;
  }
  return `${v.toFixed(i === 0 ? 0 : 1)} ${units[i]}`;
}

export function escapeHtml(s) {
  return String(s).replace(/[&<>"']/g, (c) => ({ '&': '&amp;', '<': '&lt;', '>': '&gt;', '"': '&quot;', "'": '&#39;' })[c]);
}

// Fraction of the job done, 0..1, or null while the frame count is unknown.
export function jobFraction(job) {
  const p = job.progress || {};
  if (job.state === 'completed') return 1;
  if (!(p.frames_total > 0)) return null;
  return Math.min(1, p.frames_done / p.frames_total);
}
