// The map view's stats panel: points, submaps, revision, processing fps, job state and, for a
// georeferenced map, where it is on the earth (with links to a web map and the GeoJSON path).

import { escapeHtml, formatCount, formatDuration } from './format.js';

// values.location: { latitude, longitude, rmsM, geojsonUrl } of a georeferenced map; rmsM and
// geojsonUrl are null while the job runs (the location then comes from tileset.json).
function locationCell(location) {
  if (!location) return '–';
  const { latitude: lat, longitude: lon } = location;
  const text = `${Math.abs(lat).toFixed(5)}° ${lat >= 0 ? 'N' : 'S'}, ${Math.abs(lon).toFixed(5)}° ${lon >= 0 ? 'E' : 'W'}`;
  const osm = `https://www.openstreetmap.org/?mlat=${lat.toFixed(6)}&mlon=${lon.toFixed(6)}#map=17/${lat.toFixed(6)}/${lon.toFixed(6)}`;
  const title = location.rmsM === null ? 'GPS fit of the map so far' : `GPS fit rms ${location.rmsM.toFixed(2)} m`;
  const path = location.geojsonUrl === null ? ''
    : ` <a href="${escapeHtml(location.geojsonUrl)}" download="trajectory.geojson">path</a>`;
  return `<span id="map-location" title="${title}">${text}</span> ` +
    `<a href="${escapeHtml(osm)}" target="_blank" rel="noopener">map</a>${path}`;
}

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
      // The submap being built, shown provisionally (slightly transparent) until it completes.
      ['building', values.openSubmap
        ? `submap ${values.openSubmap.submap}, ${values.openSubmap.keyframes ?? '?'} keyframes, ${formatCount(values.openSubmap.points)} points`
        : '–'],
      ['render', values.renderFps ? `${values.renderFps.toFixed(0)} fps` : '–'],
    ];
    if (values.location) rows.push(['location', locationCell(values.location)]);
    element.innerHTML = rows.map(([k, v]) => `<div><span>${k}</span><b>${v}</b></div>`).join('');
  }
  return { set };
}
