// The console page: the live scene from the console's event stream, a time slider over the
// cached frames, the box behind a drawn rectangle, status and recording. Every query while
// paused names the frame shown, so what is drawn always belongs to the image it is drawn on.

import { getJson, postJson, previewImage, segmentsImage } from './api.js';
import { boxSizeCm, formatSize, nsToSeconds } from './geometry.js';
import { RecordPanel } from './record_panel.js';
import { SceneState } from './scene_state.js';
import { StatusPanel } from './status_panel.js';
import { View2D } from './view2d.js';
import { View3D } from './view3d.js';

const $ = (id) => document.getElementById(id);
const LIVE_RATE_HZ = 10;

const live = new SceneState();         // the daemon's scene, kept up to date from the stream
const status = new StatusPanel();
const record = new RecordPanel();
const view2d = new View2D($('view2d'), (rectangle) => estimateBox(rectangle));
const view3d = new View3D($('view3d'));

let mode = 'live';             // 'live' or 'paused'
let cachedFrames = [];         // processed cached frames (FrameInfo) the slider walks, oldest first
let framesShown = 0;
let updatesApplied = 0;
let lastBox = null;            // {request, response} or {request, error}
let pendingPreview = null;     // the newest preview not decoded yet: {update, scene}
let decoding = false;
let newestPausedQuery = 0;     // drops answers to slider moves the operator has moved past
let events = null;

// ---- the live stream

function previewQuery() {
  return `preview=${$('preview-kind').value}&width=${$('preview-width').value}&quality=70`;
}

function openEvents() {
  if (events) events.close();
  events = new EventSource(`/api/events?${previewQuery()}&rate=${LIVE_RATE_HZ}`);
  events.addEventListener('scene', (e) => onSceneUpdate(JSON.parse(e.data)));
  events.addEventListener('status', (e) => onStatus(JSON.parse(e.data)));
  events.addEventListener('link', (e) => onLink(JSON.parse(e.data)));
  events.addEventListener('record', (e) => record.update(JSON.parse(e.data)));
  events.onerror = () => status.setLink('unreachable', 'the console itself (retrying)');
}

function sceneLabel(scene) {
  const taught = scene.taughtObjects.length;
  return `${scene.planes.length} planes, ${scene.objects.length} things` +
         (taught ? `, ${taught} taught (${scene.taughtObjects.map((t) => t.name).join(', ')})` : '');
}

function onSceneUpdate(update) {
  if (live.apply(update)) onDaemonRestarted();
  ++updatesApplied;
  if (mode !== 'live') return;
  const scene = live.snapshot();
  view3d.show(scene);
  $('scene-label').textContent = sceneLabel(scene);
  if (!update.preview_jpeg) return;  // the image stays that of its own frame, with its overlays
  pendingPreview = { update, scene };
  if (!decoding) showPreviews();
}

/// Decodes and shows previews one at a time; one that arrives meanwhile replaces the one still
/// waiting, so the view keeps up with the newest frame however fast updates come.
async function showPreviews() {
  decoding = true;
  try {
    while (pendingPreview) {
      const { update, scene } = pendingPreview;
      pendingPreview = null;
      const image = await previewImage(update);
      if (mode === 'live') showFrame(image, scene); else image.close();
    }
  } finally {
    decoding = false;
  }
}

function showFrame(image, scene) {
  view2d.show(image, scene);
  ++framesShown;
  const info = scene.info;
  $('frame-label').textContent = `t ${nsToSeconds(info.timestamp_ns)} s · #${info.sequence}`;
  if ($('ov-segments').checked) loadSegments(info.timestamp_ns);
}

let segmentsLoading = false;
async function loadSegments(timestampNs) {
  if (segmentsLoading) return;  // the next frame asks again; an overlay never lands on another frame
  segmentsLoading = true;
  try {
    const image = await segmentsImage(timestampNs);
    if (image) view2d.setSegments(timestampNs, image);
  } finally {
    segmentsLoading = false;
  }
}

function onStatus(event) {
  status.update(event);
  const session = event.status?.session_id;
  if (session && live.sessionId && session !== live.sessionId) {
    live.reset(session);
    onDaemonRestarted();
  }
}

function onLink(event) {
  if (event.state === 'connected') status.setLink('connected');
  else if (event.state === 'connecting') status.setLink('connecting');
  else {
    const words = event.message ? `${event.code}: ${event.message}` : event.code;
    status.setLink('reconnecting', `${words} (retry in ${event.retry_in_s} s)`);
  }
}

/// A new daemon session: its track ids and cached frames are new, so what the page held goes.
function onDaemonRestarted() {
  lastBox = null;
  view2d.setUserBox(null);
  view3d.setUserBox(null);
  setBoxText('the daemon restarted: draw again', 'muted');
  if (mode === 'paused') goLive();
}

// ---- pause, step, slider

async function pause() {
  if (mode === 'paused') return;
  mode = 'paused';
  setTimelineButtons();
  try {
    cachedFrames = (await getJson('/api/frames')).frames.filter((f) => f.processed);
  } catch (error) {
    $('time-label').textContent = error.message;
    return;
  }
  const slider = $('time-slider');
  slider.max = Math.max(cachedFrames.length - 1, 0);
  const shown = view2d.shownTimestampNs();
  const index = cachedFrames.findIndex((f) => f.timestamp_ns === shown);
  slider.value = index >= 0 ? index : cachedFrames.length - 1;
  updateTimeLabel();
}

async function showCachedFrame(index) {
  const frame = cachedFrames[index];
  if (!frame) return;
  $('time-slider').value = index;
  const ticket = ++newestPausedQuery;
  try {
    const update = await getJson(`/api/scene?at_ns=${frame.timestamp_ns}&${previewQuery()}`);
    const image = await previewImage(update);
    if (ticket !== newestPausedQuery || mode !== 'paused') return image?.close();
    const scene = SceneState.fromFullUpdate(update).snapshot();
    view3d.show(scene);
    $('scene-label').textContent = sceneLabel(scene);
    if (image) showFrame(image, scene);
    updateTimeLabel();
  } catch (error) {
    $('time-label').textContent = error.message;
  }
}

function goLive() {
  mode = 'live';
  setTimelineButtons();
  view3d.show(live.snapshot());
  $('time-label').textContent = 'live';
}

function sliderIndex() {
  return Number($('time-slider').value);
}

function updateTimeLabel() {
  const shown = view2d.shownTimestampNs();
  const newest = cachedFrames.at(-1)?.timestamp_ns;
  const behind = shown && newest ? (Number(BigInt(newest) - BigInt(shown)) / 1e9).toFixed(2) : '?';
  $('time-label').textContent =
      `paused at ${shown ? nsToSeconds(shown) : '?'} s, ${behind} s before the newest cached ` +
      `(${cachedFrames.length} frames)`;
}

function setTimelineButtons() {
  const paused = mode === 'paused';
  $('btn-pause').disabled = paused;
  for (const id of ['btn-back', 'btn-forward', 'btn-live', 'time-slider']) $(id).disabled = !paused;
}

$('btn-pause').addEventListener('click', () => pause());
$('btn-live').addEventListener('click', () => goLive());
$('btn-back').addEventListener('click', () => showCachedFrame(Math.max(sliderIndex() - 1, 0)));
$('btn-forward').addEventListener('click', () =>
  showCachedFrame(Math.min(sliderIndex() + 1, cachedFrames.length - 1)));
$('time-slider').addEventListener('input', () => showCachedFrame(sliderIndex()));

// ---- the box behind a rectangle

// Drawing starts on the frame shown and stays on it: the box is that frame's.
$('view2d').addEventListener('pointerdown', () => { if (view2d.shownTimestampNs()) pause(); });

async function estimateBox({ p1, p2 }) {
  const request = { at_ns: view2d.shownTimestampNs(), p1, p2, mode: $('box-mode').value };
  setBoxText('estimating…', 'muted');
  try {
    const response = await postJson('/api/box', request);
    const size = formatSize(boxSizeCm(response.corners));
    lastBox = { request, response };
    view2d.setUserBox({ timestampNs: response.frame_timestamp_ns, corners: response.corners,
                        p1, p2, label: size });
    view3d.setUserBox(response.corners, size);
    const s = response.stats;
    setBoxText(`${size}\n${s.range_from_origin ? 'distance' : 'depth'} ` +
               `${s.near_m.toFixed(3)}–${s.far_m.toFixed(3)} m, ${s.used_pixels} of ` +
               `${s.valid_pixels} pixels\nframe ${nsToSeconds(response.frame_timestamp_ns)} s, ` +
               `ROI ${p1.x},${p1.y} – ${p2.x},${p2.y}`, 'box');
  } catch (error) {
    lastBox = { request, error: { code: error.code, message: error.daemonMessage } };
    setBoxText(error.message, 'error');
  }
}

function setBoxText(text, kind) {
  $('box-result').textContent = text;
  $('box-result').className = 'result ' + kind;
}

// ---- overlays and preview settings

for (const name of ['planes', 'segments', 'boxes', 'bowls']) {
  $('ov-' + name).addEventListener('change', (e) => {
    view2d.setOverlay(name, e.target.checked);
    const shown = view2d.shownTimestampNs();
    if (name === 'segments' && e.target.checked && shown) loadSegments(shown);
  });
}
for (const id of ['preview-kind', 'preview-width']) {
  $(id).addEventListener('change', () => {
    openEvents();
    if (mode === 'paused') showCachedFrame(sliderIndex());
  });
}

// Read-only hooks for the browser test (tests/clients/console_browser_test.py).
window.shapesenseConsole = {
  planeCount3d: () => view3d.planeCount(),
  taughtCount3d: () => view3d.taughtCount(),
  shownTimestampNs: () => view2d.shownTimestampNs(),
  lastBox: () => lastBox,
  frameCount: () => framesShown,
  updateCount: () => updatesApplied,
  mode: () => mode,
};

setTimelineButtons();
openEvents();
