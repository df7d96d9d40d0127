// Upload form: a video chosen or dropped, optional name / focal length / intrinsics.json and
// the advanced job options, sent with a progress bar. Options follow docs/api.md "Creating a job": `focal` (pixels at
// the original resolution) or `intrinsics` (an intrinsics.json object); not both.

import { uploadVideo } from './api.js';

function readIntrinsics(file) {
  return file.text().then((text) => {
    let value;
    try {
      value = JSON.parse(text);
    } catch (e) {
      throw new Error(`${file.name} is not JSON: ${e.message}`);
    }
    if (typeof value !== 'object' || value === null || Array.isArray(value)) {
      throw new Error(`${file.name} must hold one intrinsics object`);
    }
    return value;
  });
}

async function collectOptions(form) {
  const options = {};
  const name = form.elements.name.value.trim();
  if (name) options.name = name;
  const focal = form.elements.focal.value.trim();
  const intrinsicsFile = form.elements.intrinsics.files[0];
  if (focal && intrinsicsFile) throw new Error('give either a focal length or an intrinsics file, not both');
  if (focal) {
    const f = Number(focal);
    if (!(f > 0)) throw new Error('the focal length must be a positive number of pixels');
    options.focal = f;
  }
  if (intrinsicsFile) options.intrinsics = await readIntrinsics(intrinsicsFile);
  for (const [key, min] of [['stride', 1], ['keyframes_per_submap', 3], ['max_image_size', 0], ['detect_every', 0]]) {
    const text = form.elements[key].value.trim();
    if (!text) continue;
    const n = Number(text);
    if (!Number.isInteger(n) || n < min) throw new Error(`${key.replaceAll('_', ' ')} must be an integer ≥ ${min}`);
    options[key] = n;
  }
  const smooth = form.elements.smooth_window_s.value.trim();
  if (smooth) {
    const s = Number(smooth);
    if (!(s >= 0 && s <= 5)) throw new Error('path smoothing must be between 0 and 5 seconds');
    options.smooth_window_s = s;
  }
  return options;
}

// onCreated(job): called with the created job (201).
export function setupUploadPage(root, onCreated) {
  const form = root.querySelector('#upload-form');
  const fileInput = form.elements.video;
  const drop = root.querySelector('#drop-zone');
  const bar = root.querySelector('#upload-progress');
  const status = root.querySelector('#upload-status');
  const button = form.querySelector('button[type=submit]');
  let dropped = null;

  const chosen = () => dropped || fileInput.files[0] || null;
  const showChosen = () => {
    const f = chosen();
    drop.querySelector('.file-name').textContent = f ? f.name : 'no video chosen';
  };
  fileInput.addEventListener('change', () => {
    dropped = null;
    showChosen();
  });
  drop.addEventListener('dragover', (e) => {
    e.preventDefault();
    drop.classList.add('over');
  });
  drop.addEventListener('dragleave', () => drop.classList.remove('over'));
  drop.addEventListener('drop', (e) => {
    e.preventDefault();
    drop.classList.remove('over');
    if (e.dataTransfer.files.length > 0) dropped = e.dataTransfer.files[0];
    showChosen();
  });

  form.addEventListener('submit', async (e) => {
    e.preventDefault();
    const file = chosen();
    if (!file) {
      status.textContent = 'Choose or drop a video first.';
      return;
    }
    button.disabled = true;
    bar.hidden = false;
    bar.value = 0;
    try {
      const options = await collectOptions(form);
      status.textContent = `Uploading ${file.name}…`;
      const job = await uploadVideo(file, options, (fraction) => {
        bar.value = fraction;
        status.textContent = `Uploading ${file.name}: ${Math.round(fraction * 100)} %`;
      }, form.elements.telemetry.files[0] || null);
      bar.value = 1;
      status.textContent = `Job ${job.id} created (${job.state}).`;
      form.reset();
      dropped = null;
      showChosen();
      onCreated(job);
    } catch (err) {
      status.textContent = `Upload failed: ${err.message}`;
    } finally {
      button.disabled = false;
    }
  });
}
