#include "server/http_index.h"

namespace glam::server {

const std::string& BuiltInIndexHtml() {
  static const std::string html = R"html(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>GLAM server</title>
<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}
td,th{border:1px solid #ccc;padding:4px 8px}</style></head>
<body><h1>GLAM server</h1>
<p>The 3D viewer is not installed (build it with <code>bash scripts/setup-node.sh</code>, see docs/viewer.md); this page lists jobs. API: <a href="/api/v1/openapi.yaml">openapi.yaml</a></p>
<form id="up"><input type="file" name="video" accept="video/*"> <button>Upload</button></form>
<table><thead><tr><th>name</th><th>state</th><th>frames</th><th>submaps</th><th>results</th></tr></thead>
<tbody id="jobs"></tbody></table>
<script>
const token = new URLSearchParams(location.search).get('token');
const auth = token ? {Authorization: 'Bearer ' + token} : {};
function esc(s) { return String(s).replace(/[&<>"]/g, c => ({'&':'&amp;','<':'&lt;','>':'&gt;','"':'&quot;'}[c])); }
async function refresh() {
  const r = await fetch('/api/v1/jobs?limit=50', {headers: auth});
  if (!r.ok) { document.getElementById('jobs').innerHTML = '<tr><td colspan=5>' + r.status + '</td></tr>'; return; }
  const page = await r.json();
  document.getElementById('jobs').innerHTML = page.jobs.map(j =>
    '<tr><td>' + esc(j.name) + '</td><td>' + esc(j.state) + (j.error ? ': ' + esc(j.error) : '') +
    '</td><td>' + j.progress.frames_done + '/' + j.progress.frames_total + '</td><td>' +
    j.progress.submaps_completed + '</td><td>' + (j.state === 'completed' ?
      '<a href="' + j.urls.trajectory + '">trajectory</a> <a href="' + j.urls.points + '">points</a> ' +
      '<a href="' + j.urls.report + '">report</a>' : '') + '</td></tr>').join('');
}
document.getElementById('up').onsubmit = async e => {
  e.preventDefault();
  await fetch('/api/v1/jobs', {method: 'POST', body: new FormData(e.target), headers: auth});
  refresh();
};
refresh(); setInterval(refresh, 2000);
</script></body></html>
)html";
  return html;
}

}  // namespace glam::server
