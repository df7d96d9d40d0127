// Entry point: `/` shows the upload page and the job list, `/?job={id}` the map view.

import { adoptTokenFromUrl, getToken, setToken } from './api.js';
import { setupUploadPage } from './upload_page.js';
import { setupJobList } from './job_list.js';
import { openMapView } from './map_view.js';

function setupTokenField(onChange) {
  const form = document.querySelector('#token-form');
  const input = form.elements.token;
  input.value = getToken();
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    setToken(input.value.trim());
    onChange();
  });
}

adoptTokenFromUrl();
const jobId = new URLSearchParams(location.search).get('job');
const home = document.querySelector('#home');
const viewer = document.querySelector('#viewer');

if (jobId) {
  home.hidden = true;
  viewer.hidden = false;
  document.body.classList.add('map');
  setupTokenField(() => location.reload());
  openMapView(viewer, jobId);
} else {
  const jobs = setupJobList(home);
  setupTokenField(() => jobs.refresh());
  setupUploadPage(home, (job) => {
    if (document.querySelector('#open-after-upload').checked) {
      location.href = `?job=${encodeURIComponent(job.id)}`;
    } else {
      jobs.refresh();
    }
  });
  jobs.start();
}
