// Upload form: a video (or a set of photos) chosen or dropped, or a live stream's URL; optional
// name / focal length /
// intrinsics.json and the advanced job options (numbers and ticked boxes; an empty field or an
// unticked box sends nothing, so the server's defaults apply), sent with a progress bar.
// Options follow docs/api.md "Creating a job": `focal` (pixels at the original resolution) or
// `intrinsics` (an intrinsics.json object); not both.

import { createStreamJob } from './api.js';
import { createJobFromPhotos, createJobFromUploads } from './resumable_upload.js';

const isImage = (f) => f.type.startsWith('image/') || /\.(jpe?g|png|tiff?|bmp|webp)$/i.test(f.name);

// What the chosen files are: one video, or photos (all images); throws otherwise.
function classify(files) {
  if (files.length === 0) return null;
  const images = files.filter(isImage);
  if (images.length === files.length) return { photos: images };
  if (files.length === 1) return { video: files[0] };
  throw new Error('choose one video, or photos only');
}

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
  const readout = form.elements.rolling_shutter_ms.value.trim().toLowerCase();
  if (readout === 'auto') {
    options.rolling_shutter_ms = 'auto';
  } else if (readout) {
    const ms = Number(readout);
    if (!(ms >= 0 && ms <= 100)) throw new Error('the rolling-shutter readout must be between 0 and 100 ms, or auto');
    options.rolling_shutter_ms = ms;
  }
  if (intrinsicsFile) options.intrinsics = await readIntrinsics(intrinsicsFile);
  for (const [key, min, max] of [['stride', 1], ['keyframes_per_submap', 3], ['max_image_size', 0], ['detect_every', 0],
    ['max_features', 100, 50000], ['global_refinement_keyframes', 0, 1000]]) {
    const text = form.elements[key].value.trim();
    if (!text) continue;
    const n = Number(text);
    if (!Number.isInteger(n) || n < min) throw new Error(`${key.replaceAll('_', ' ')} must be an integer ≥ ${min}`);
    if (max !== undefined && n > max) throw new Error(`${key.replaceAll('_', ' ')} must be at most ${max}`);
    options[key] = n;
  }
  if (form.elements.refine_focal.checked) {
    if (!intrinsicsFile) throw new Error('refining the focal needs an intrinsics file (without one it is estimated anyway)');
    options.refine_focal = true;
  }
  // Boxes left unticked send nothing: the server's defaults apply.
  for (const key of ['fixed_k1', 'name_order']) {
    if (form.elements[key].checked) options[key] = true;
  }
  for (const [key, label, max] of [['smooth_window_s', 'path smoothing', 5],
    ['detect_max_seconds', 'the longest gap between detections', 10],
    ['preview_interval_s', 'the preview interval', 60]]) {
    const text = form.elements[key].value.trim();
    if (!text) continue;
    const s = Number(text);
    if (!(s >= 0 && s <= max)) throw new Error(`${label} must be between 0 and ${max} seconds`);
    options[key] = s;
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

  const chosen = () => dropped || Array.from(fileInput.files);
  const showChosen = () => {
    const files = chosen();
    drop.querySelector('.file-name').textContent =
      files.length === 0 ? 'no video chosen' : files.length === 1 ? files[0].name : `${files.length} photos`;
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
    if (e.dataTransfer.files.length > 0) dropped = Array.from(e.dataTransfer.files);
    showChosen();
  });

  form.addEventListener('submit', async (e) => {
    e.preventDefault();
    const streamUrl = form.elements.stream_url.value.trim();
    let input;
    try {
      input = classify(chosen());
      if (input && streamUrl) throw new Error('choose a file or give a stream URL, not both');
    } catch (err) {
      status.textContent = `Upload failed: ${err.message}`;
      return;
    }
    if (streamUrl) {
      button.disabled = true;
      try {
        const options = await collectOptions(form);
        if (form.elements.telemetry.files[0]) throw new Error('a GPS track goes with a video file, not a stream');
        status.textContent = 'Creating the stream job…';
        const job = await createStreamJob(streamUrl, options);
        status.textContent = `Job ${job.id} created (${job.state}): mapping the stream as it arrives.`;
        onCreated(job);
        form.reset();
      } catch (err) {
        status.textContent = `Stream job failed: ${err.message}`;
      } finally {
        button.disabled = false;
      }
      return;
    }
    if (!input) {
      status.textContent = 'Choose or drop a video (or photos), or give a live stream URL, first.';
      return;
    }
    const label = input.video ? input.video.name
      : input.photos.length === 1 ? input.photos[0].name : `${input.photos.length} photos`;
    button.disabled = true;
    bar.hidden = false;
    bar.value = 0;
    try {
      const options = await collectOptions(form);
      const telemetry = form.elements.telemetry.files[0] || null;
      if (input.photos && telemetry) throw new Error('photos carry their GPS in EXIF; a GPS track goes with a video');
      status.textContent = `Uploading ${label}…`;
      const onProgress = (fraction, note = '') => {
        bar.value = fraction;
        status.textContent = `Uploading ${label}: ${Math.round(fraction * 100)} %${note ? ` (${note})` : ''}`;
      };
      // Resumable: a dropped link costs a retry of a chunk (a video) or of a photo, not the
      // whole upload.
      const job = input.video ? await createJobFromUploads(input.video, telemetry, options, onProgress)
                              : await createJobFromPhotos(input.photos, options, onProgress);
      bar.value = 1;
      status.textContent = `Job ${job.id} created (${job.state}).`;
      // Before the reset, which would tick "open the map view" again.
      onCreated(job);
      form.reset();
      dropped = null;
      showChosen();
    } catch (err) {
      status.textContent = `Upload failed: ${err.message}`;
    } finally {
      button.disabled = false;
    }
  });
}
