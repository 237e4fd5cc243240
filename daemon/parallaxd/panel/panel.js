// The control panel's script. Every action is one control request (POST api/request, the same
// JSON as a line on parallaxd's control socket); pictures come from the `view` and `frame`
// requests (api/view.png, api/frame.png). The token arrives in the page's URL and goes with
// every request as a header.
'use strict';

const token = new URLSearchParams(location.search).get('token') || '';
const $ = (id) => document.getElementById(id);

async function ask(request) {
  const response = await fetch('api/request', {
    method: 'POST',
    headers: {'Content-Type': 'application/json', 'X-Parallax-Token': token},
    body: JSON.stringify(request),
  });
  return response.json();
}

async function picture(path) {
  const response = await fetch(path, {headers: {'X-Parallax-Token': token}});
  if (!response.ok) {
    let why = 'HTTP ' + response.status;
    try { why = (await response.json()).error || why; } catch (e) { /* not JSON */ }
    throw new Error(why);
  }
  return URL.createObjectURL(await response.blob());
}

function showReply(what, reply) {
  $('reply').textContent = what + ': ' + (reply.ok ? (reply.message || 'done') : reply.error);
  $('reply').classList.toggle('error', !reply.ok);
}

async function act(what, request) {
  const reply = await ask(request);
  showReply(what, reply);
  await refreshStatus();
  requestPreview();
  refreshThumbnails();
  return reply;
}

// ---- status: state, stage and its progress, the scene's parameters -------------------------

let status = null;
let parametersOf = '';  // the scene (and its declared parameters) the sliders were made for

function progressOf(stage) {
  // Stages count what they do: "pictures: 3 of 96", "decoding: picture set 2 of 4".
  const m = /(\d+) of (\d+)/.exec(stage || '');
  return m ? {done: Number(m[1]), total: Number(m[2])} : null;
}

async function refreshStatus() {
  try {
    status = await ask({request: 'status'});
  } catch (e) {
    $('state').textContent = 'unreachable';
    $('state').className = 'state error';
    return;
  }
  $('state').textContent = status.state + (status.showing ? ' (' + status.showing + ')' : '');
  $('state').className = 'state ' + status.state;
  $('stage').textContent = status.stage || '';
  const p = progressOf(status.stage);
  $('progress').hidden = !p;
  if (p) { $('progress').max = p.total; $('progress').value = p.done; }
  $('link').textContent = 'link ' + status.link.health;
  const error = status.last_error ? status.last_error.stage + ': ' + status.last_error.error
                                  : (status.scene_error || '');
  $('error').hidden = !error;
  $('error').textContent = error;
  $('calibration').textContent = status.calibration.source + ' (' + status.calibration.hash + ')';
  const calibrating = status.state === 'calibrating';
  $('btn-cancel').disabled = !calibrating;
  $('btn-calibrate').disabled = calibrating;
  setUpObserver(status.display);
  setUpModules(status.display.modules);
  setUpParameters(status.scene);
}

let observerSetUp = false;
function setUpObserver(display) {
  if (observerSetUp) return;
  // Viewers from one screen width left of the centre to one right.
  const w = Math.round(display.screen_width * 100) / 100;
  $('observer').min = -w;
  $('observer').max = w;
  observerSetUp = true;
}

let modulesSetUp = 0;
function setUpModules(count) {
  if (modulesSetUp === count) return;
  modulesSetUp = count;
  const select = $('identify-module');
  select.length = 1;
  const grid = $('thumbnails');
  grid.textContent = '';
  for (let m = 0; m < count; ++m) {
    select.add(new Option('module ' + m, String(m)));
    const figure = document.createElement('figure');
    const img = document.createElement('img');
    img.id = 'module-' + m;
    img.alt = 'module ' + m + "'s frame";
    const caption = document.createElement('figcaption');
    caption.textContent = 'module ' + m;
    figure.append(img, caption);
    grid.append(figure);
  }
  refreshThumbnails();
}

// A parameter's `set`s go one at a time and the slider's latest value goes last: requests sent
// together (ten arrow-key presses) may reach the daemon in any order and leave the scene on an
// older value than the slider shows.
function parameterSender(name, slider) {
  let busy = false, again = false;
  return async () => {
    if (busy) { again = true; return; }
    busy = true;
    try {
      do {
        again = false;
        await act('set ' + name, {request: 'set', name: name, value: Number(slider.value)});
      } while (again);
    } finally {
      busy = false;
    }
  };
}

function setUpParameters(scene) {
  const ranges = scene ? scene.parameter_ranges || {} : {};
  const key = scene ? scene.name + ':' + Object.keys(ranges).join(',') : '';
  const box = $('parameters');
  if (key !== parametersOf) {
    parametersOf = key;
    box.textContent = '';
    for (const [name, r] of Object.entries(ranges)) {
      const div = document.createElement('div');
      div.className = 'parameter';
      const label = document.createElement('label');
      const value = document.createElement('output');
      value.id = 'value-' + name;
      label.append(name + (r.description ? ' — ' + r.description : '') + ': ', value);
      const slider = document.createElement('input');
      slider.type = 'range';
      slider.id = 'param-' + name;
      slider.min = r.min;
      slider.max = r.max;
      slider.step = (r.max - r.min) / 100 || 'any';
      slider.value = scene.parameters[name];
      label.htmlFor = slider.id;
      slider.addEventListener('input', () => { value.textContent = Number(slider.value).toFixed(3); });
      // One `set` when the slider is let go (or moved by the keyboard), not one per pixel.
      slider.addEventListener('change', parameterSender(name, slider));
      div.append(label, slider);
      box.append(div);
    }
    if (!Object.keys(ranges).length) box.textContent = 'This scene declares no parameters.';
  }
  // The daemon's values (a slider snaps to its steps; the label says what the scene has), unless
  // the operator is moving that slider.
  if (scene) {
    for (const [name, v] of Object.entries(scene.parameters)) {
      const slider = $('param-' + name);
      if (!slider || document.activeElement === slider) continue;
      slider.value = v;
      $('value-' + name).textContent = Number(v).toFixed(3);
    }
  }
}

// ---- the viewer's picture --------------------------------------------------------------------

let previewBusy = false, previewAgain = false;
async function requestPreview() {
  if (previewBusy) { previewAgain = true; return; }
  previewBusy = true;
  do {
    previewAgain = false;
    const x = Number($('observer').value);
    const started = performance.now();
    try {
      const url = await picture('api/view.png?x=' + x + '&width=640&height=360');
      const img = $('preview');
      const old = img.src;
      img.src = url;
      // Counted once the picture is decoded, so a load the page reports is one it can show.
      await img.decode();
      img.dataset.x = String(x);
      img.dataset.loads = String(Number(img.dataset.loads) + 1);
      if (old.startsWith('blob:')) URL.revokeObjectURL(old);
      $('preview-time').textContent =
          'x = ' + x.toFixed(2) + ' m, ' + Math.round(performance.now() - started) + ' ms';
    } catch (e) {
      $('preview-time').textContent = 'no view: ' + e.message;
    }
  } while (previewAgain);
  previewBusy = false;
}

async function refreshThumbnails() {
  for (let m = 0; m < modulesSetUp; ++m) {
    try {
      const img = $('module-' + m);
      const old = img.src;
      img.src = await picture('api/frame.png?module=' + m);
      if (old.startsWith('blob:')) URL.revokeObjectURL(old);
    } catch (e) {
      break;  // no frames yet: the next refresh tries again
    }
  }
}

// ---- stats as small live charts --------------------------------------------------------------

const history = {fps: [], dropped: [], render: [], encode: [], push: [], latency: []};
let lastStats = null;

function drawChart(name, unit) {
  const values = history[name];
  const canvas = $('chart-' + name);
  const g = canvas.getContext('2d');
  g.clearRect(0, 0, canvas.width, canvas.height);
  const max = Math.max(1e-9, ...values);
  g.strokeStyle = '#1f6feb';
  g.lineWidth = 1.5;
  g.beginPath();
  values.forEach((v, i) => {
    const x = (i / 59) * (canvas.width - 2) + 1;
    const y = canvas.height - 2 - (v / max) * (canvas.height - 12);
    if (i === 0) g.moveTo(x, y); else g.lineTo(x, y);
  });
  g.stroke();
  g.fillStyle = '#5b6570';
  g.font = '10px sans-serif';
  g.fillText('max ' + max.toFixed(1), 4, 10);
  const last = values.length ? values[values.length - 1] : 0;
  $('v-' + name).textContent = last.toFixed(1) + (unit || '');
}

async function refreshStats() {
  let s;
  try { s = await ask({request: 'stats'}); } catch (e) { return; }
  if (!s.ok) return;
  const now = performance.now();
  if (lastStats) {
    const seconds = (now - lastStats.at) / 1000;
    const push = (name, v) => { history[name].push(v); if (history[name].length > 60) history[name].shift(); };
    push('fps', (s.display_frames - lastStats.s.display_frames) / seconds);
    push('dropped', (s.dropped_frames - lastStats.s.dropped_frames) / seconds);
    push('render', s.timings.render.last_ms);
    push('encode', s.timings.encode.last_ms);
    push('push', s.timings.push.last_ms);
    push('latency', s.timings.end_to_end.last_ms);
    for (const name of Object.keys(history)) drawChart(name);
  }
  // A new frame of a still scene (a parameter set, a scene loaded): show what viewers see now.
  // An animated one is refreshed on a timer instead (each view is made between its frames).
  const animated = status && status.scene && status.scene.animated;
  if (lastStats && s.display_frames !== lastStats.s.display_frames && !animated) {
    requestPreview();
    refreshThumbnails();
  }
  lastStats = {s: s, at: now};
  $('summary').textContent = s.summary;
}

// ---- the latest `parallax report` (served by the panel from its reports folder) -------------

async function refreshReport() {
  let r;
  try {
    const response = await fetch('api/report', {headers: {'X-Parallax-Token': token}});
    r = await response.json();
  } catch (e) { return; }
  const span = $('report');
  span.textContent = '';
  if (r.latest) {
    const a = document.createElement('a');
    a.id = 'report-link';
    a.href = r.latest.url;
    a.target = '_blank';
    a.rel = 'noopener';
    a.textContent = r.latest.name + ' (' + r.latest.date + ')';
    span.append(a);
  } else {
    span.textContent = 'none yet (parallax report --out ' + r.folder + '/NAME)';
  }
}

// ---- wiring ----------------------------------------------------------------------------------

async function loadScenes() {
  const reply = await ask({request: 'scenes'});
  const select = $('scene');
  select.length = 0;
  for (const name of reply.scenes || []) select.add(new Option(name, name));
  if (status && status.scene) select.value = status.scene.name;
}

function wire() {
  $('observer').addEventListener('input', () => {
    $('observer-value').textContent = Number($('observer').value).toFixed(2);
    requestPreview();
  });
  $('btn-load').addEventListener('click', () => act('load', {request: 'load', scene: $('scene').value}));
  $('btn-play').addEventListener('click', () => act('play', {request: 'play'}));
  $('btn-pause').addEventListener('click', () => act('pause', {request: 'pause'}));
  $('btn-identify').addEventListener('click', () => {
    const m = $('identify-module').value;
    act('identify', m === '' ? {request: 'identify'} : {request: 'identify', module: Number(m)});
  });
  $('btn-testcard').addEventListener('click', () => act('test card', {request: 'testcard'}));
  $('btn-rollback').addEventListener('click', () => act('rollback', {request: 'rollback'}));
  $('btn-cancel').addEventListener('click', () => act('cancel', {request: 'cancel'}));
  $('btn-calibrate').addEventListener('click', () => {
    const p = $('photometric').value;
    $('reply').textContent = 'calibrating (minutes): the progress is above';
    // Answered when the calibration ends; status shows its stages meanwhile.
    act('calibrate', p === '' ? {request: 'calibrate'} : {request: 'calibrate', photometric: p});
    setTimeout(refreshStatus, 200);
  });
  $('btn-thumbnails').addEventListener('click', refreshThumbnails);
}

async function start() {
  wire();
  await refreshStatus();
  await loadScenes();
  requestPreview();
  refreshReport();
  setInterval(refreshStatus, 500);
  setInterval(refreshStats, 1000);
  // An animated scene changes under the viewer: a new picture every 2 s while playing.
  setInterval(() => {
    if (status && status.state === 'playing' && status.scene && status.scene.animated) requestPreview();
  }, 2000);
  setInterval(refreshThumbnails, 10000);
  setInterval(refreshReport, 30000);
}

start();
