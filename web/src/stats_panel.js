// The map view's stats panel: points, submaps, revision, processing fps, job state.

import { formatCount, formatDuration } from './format.js';

export function createStatsPanel(element) {
  const values = {};
  function set(patch) {
    Object.assign(values, patch);
    const rows = [
      ['job', values.name || ''],
      ['state', values.state || ''],
      ['frames', values.framesTotal > 0 ? `${formatCount(values.framesDone)} / ${formatCount(values.framesTotal)}` : formatCount(values.framesDone)],
      ['processing', values.fps ? `${values.fps.toFixed(1)} fps` : '–'],
      ['ETA', values.state === 'running' ? formatDuration(values.eta) : '–'],
      ['revision', String(values.revision ?? 0)],
      ['submaps', `${formatCount(values.tilesLoaded)} shown${values.disconnected ? `, ${values.disconnected} disconnected` : ''}`],
      ['points', formatCount(values.pointsLoaded)],
      ['render', values.renderFps ? `${values.renderFps.toFixed(0)} fps` : '–'],
    ];
    element.innerHTML = rows.map(([k, v]) => `<div><span>${k}</span><b>${v}</b></div>`).join('');
  }
  return { set };
}
