// luxbake viewer page: UI, input, render loop; the bake runs in worker.js.
// Test hooks live on `window.luxbake` (used by `cargo xtask web --check`).
import init, { Viewer, bundledLamps, sceneNames, defaultRequest, presetRequest, checkLampFile } from './pkg/luxbake_viewer.js';

const $ = (id) => document.getElementById(id);
const canvas = $('canvas');
const overlay = $('overlay');
const errorsList = $('errors');
const errors = [];

function showError(message) {
  errors.push(message);
  const li = document.createElement('li');
  li.textContent = message;
  errorsList.append(li);
  while (errorsList.children.length > 5) errorsList.firstChild.remove();
}

function fatal(message) {
  overlay.textContent = message;
  overlay.hidden = false;
  $('status').textContent = message;
}

const hooks = {
  errors,
  bakeCount: 0,
  lastBake: null,
  // The last bake's direct light: `{ bake, wall }` (its bake number, seconds to it).
  direct: null,
  state: 'starting',
  request: null,
  waiters: [],
  // Bakes with the given request fields; resolves with the report (rejects on error).
  bake(fields) {
    Object.assign(hooks.request, fields || {});
    syncControls();
    return new Promise((resolve, reject) => {
      hooks.waiters.push({ resolve, reject });
      requestBake(0);
    });
  },
  readback() {
    const b = hooks.lastBake;
    if (!b) return null;
    return JSON.stringify({
      request: b.request,
      report: b.report,
      maps: b.maps.map((m) => ({
        object: m.object, name: m.name, width: m.width, height: m.height,
        illuminance: Array.from(m.illuminance), direct: Array.from(m.direct),
        exitance: Array.from(m.exitance),
      })),
    });
  },
  // Device pixels in the page of world point (x, y, z), or null behind the camera.
  screenPoint(x, y, z) {
    const r = canvas.getBoundingClientRect();
    const p = viewer && viewer.project(x, y, z, r.width, r.height);
    if (!p) return null;
    const dpr = window.devicePixelRatio || 1;
    return [(r.left + p[0]) * dpr, (r.top + p[1]) * dpr];
  },
  frames: 0,
};
window.luxbake = hooks;

let viewer = null;
let worker = null;
let workerReady = false;
let bakeId = 0;
let baking = false;
let pending = false;
let retried = false;
let lampFile = null; // Uint8Array of the file from disk, once it parsed
let timer = 0;

function passRows(report) {
  const body = $('passes').tBodies[0];
  body.replaceChildren();
  const rows = [...report.setup.map((s) => [s.step, s.seconds]), ...report.passes.map((p) => [p.label, p.seconds])];
  for (const [label, s] of rows) {
    const tr = document.createElement('tr');
    tr.innerHTML = '<td></td><td></td>';
    tr.cells[0].textContent = label;
    tr.cells[1].textContent = (s * 1000).toFixed(1);
    body.append(tr);
  }
}

function requestBake(delay = 300) {
  clearTimeout(timer);
  timer = setTimeout(() => {
    if (baking) { pending = true; return; }
    startBake();
  }, delay);
}

function startBake() {
  if (!workerReady) { pending = true; return; }
  baking = true;
  pending = false;
  bakeId += 1;
  hooks.state = 'baking';
  $('progress').value = 0;
  $('status').textContent = `baking ${hooks.request.scene}…`;
  const request = JSON.stringify(hooks.request);
  const file = hooks.request.lamp.source === 'file' && lampFile ? lampFile.slice() : undefined;
  worker.postMessage({ type: 'bake', id: bakeId, request, lampFile: file });
}

function finish(ok, value) {
  const waiters = hooks.waiters.splice(0);
  for (const w of waiters) (ok ? w.resolve : w.reject)(value);
}

function onWorker(e) {
  const m = e.data;
  if (m.type === 'ready') {
    $('gpu').textContent = `bake GPU: ${m.renderer}`;
    workerReady = true;
    startBake();
    return;
  }
  if (m.type === 'fatal') {
    fatal(`This page cannot bake here: ${m.message}`);
    hooks.state = 'fatal';
    finish(false, m.message);
    return;
  }
  if (m.id !== bakeId) return;
  if (m.type === 'progress') {
    const ev = m.event;
    if (ev.kind === 'setup') $('status').textContent = `${ev.step}…`;
    if (ev.kind === 'pass') $('status').textContent = `pass ${ev.index + 1}/${ev.count}: ${ev.label}`;
    // The share of the expected work done (bounces left out are not counted as to come).
    if (ev.kind === 'work') $('progress').value = Math.min(1, ev.fraction);
    return;
  }
  if (m.type === 'direct') {
    // The direct light first; the converged maps replace it when the bake is done.
    try {
      viewer.showBake(JSON.stringify(hooks.request), m.maps);
      hooks.direct = { bake: bakeId, wall: m.wall };
      $('status').textContent = m.stage === 'preview'
        ? 'direct light (preview, the lamps as points) shown; baking the luminous opening…'
        : 'direct light shown; baking the bounces…';
    } catch (err) {
      showError(`display: ${err.message || err}`);
    }
    return;
  }
  baking = false;
  if (m.type === 'done') {
    retried = false;
    const request = JSON.parse(JSON.stringify(hooks.request));
    try {
      viewer.showBake(JSON.stringify(request), m.maps);
    } catch (err) {
      showError(`display: ${err.message || err}`);
    }
    const direct = hooks.direct?.bake === bakeId ? hooks.direct.wall : null;
    hooks.lastBake = { request, report: m.report, maps: m.maps, wall: m.wall, direct };
    hooks.bakeCount += 1;
    hooks.state = 'baked';
    $('progress').value = 1;
    $('status').textContent =
      `${m.report.scene}: ${m.report.texels.toLocaleString()} texels, ${m.report.triangles} triangles, ` +
      `baked in ${m.report.total_seconds.toFixed(2)} s (${m.report.bvh}, ${m.report.bounces_run} bounce(s))`;
    passRows(m.report);
    finish(true, m.report);
  } else if (m.type === 'error') {
    hooks.state = 'error';
    showError(`bake failed: ${m.message} (the previous bake is kept)`);
    $('status').textContent = 'bake failed';
    // The worker replaced its context after the failure: a lost context gets one retry.
    if (!retried && /lost|CONTEXT_LOST/i.test(m.message)) {
      retried = true;
      pending = true;
    } else {
      finish(false, m.message);
    }
  }
  if (pending) startBake();
}

function fillSelect(el, items) {
  el.replaceChildren(...items.map(([value, label]) => new Option(label, value)));
}

function syncControls() {
  const r = hooks.request;
  const l = r.lamp;
  const pos = l.position || [0, 2.55, 0];
  $('scene').value = r.scene;
  $('lamp').value = l.source;
  const set = (id, v) => { $(id).value = v; $(id).nextElementSibling.value = Number(v).toFixed(2); };
  set('lamp-x', pos[0]); set('lamp-y', pos[1]); set('lamp-z', pos[2]);
  set('lamp-tilt', l.tilt_deg); set('lamp-azimuth', l.azimuth_deg);
  set('lamp-rotation', l.rotation_deg); set('lamp-multiplier', l.multiplier);
  $('lamp-model').value = l.lamp_model;
  set('blur', r.blur_sigma);
  $('method').value = r.method;
  $('quality').value = r.quality;
  $('tail').checked = r.tail;
  for (const [id, v] of [['rays', r.rays], ['bounces', r.bounces], ['density', r.texels_per_metre]]) {
    const el = $(id);
    if (![...el.options].some((o) => Number(o.value) === v)) el.append(new Option(String(v)));
    el.value = String(v);
  }
  $('exposure').nextElementSibling.value = $('exposure').value;
  if (viewer) viewer.setLampMarker(pos[0], pos[1], pos[2]);
}

function wireControls() {
  const r = hooks.request;
  $('scene').onchange = (e) => { r.scene = e.target.value; requestBake(); };
  $('lamp').onchange = (e) => {
    if (e.target.value === 'file' && !lampFile) { syncControls(); return; }
    r.lamp.source = e.target.value; requestBake();
  };
  const lampInput = (id, apply) => {
    $(id).oninput = (e) => { apply(Number(e.target.value)); syncControls(); requestBake(); };
  };
  const pos = () => (r.lamp.position ||= [0, 2.55, 0]);
  lampInput('lamp-x', (v) => { pos()[0] = v; });
  lampInput('lamp-y', (v) => { pos()[1] = v; });
  lampInput('lamp-z', (v) => { pos()[2] = v; });
  lampInput('lamp-tilt', (v) => { r.lamp.tilt_deg = v; });
  lampInput('lamp-azimuth', (v) => { r.lamp.azimuth_deg = v; });
  lampInput('lamp-rotation', (v) => { r.lamp.rotation_deg = v; });
  lampInput('lamp-multiplier', (v) => { r.lamp.multiplier = v; });
  $('lamp-model').onchange = (e) => { r.lamp.lamp_model = e.target.value; requestBake(); };
  lampInput('blur', (v) => { r.blur_sigma = v; });
  const preset = () => {
    const p = JSON.parse(presetRequest($('method').value, $('quality').value));
    for (const key of ['method', 'quality', 'rays', 'bounces', 'tail', 'blur_sigma']) r[key] = p[key];
    syncControls();
    requestBake();
  };
  $('method').onchange = preset;
  $('quality').onchange = preset;
  $('rays').onchange = (e) => { r.rays = Number(e.target.value); requestBake(); };
  // A chosen bounce count is exact (as `bounces` without `tail` in a scene file); tick the
  // tail to make it a cap again.
  $('bounces').onchange = (e) => { r.bounces = Number(e.target.value); r.tail = false; syncControls(); requestBake(); };
  $('tail').onchange = (e) => { r.tail = e.target.checked; requestBake(); };
  $('density').onchange = (e) => { r.texels_per_metre = Number(e.target.value); requestBake(); };
  $('rebake').onclick = () => requestBake(0);
  $('lamp-file').onchange = async (e) => {
    const f = e.target.files[0];
    if (!f) return;
    const bytes = new Uint8Array(await f.arrayBuffer());
    try {
      const summary = checkLampFile(f.name, bytes);
      lampFile = bytes;
      let opt = [...$('lamp').options].find((o) => o.value === 'file');
      if (!opt) { opt = new Option('', 'file'); $('lamp').append(opt); }
      opt.textContent = `file: ${f.name}`;
      r.lamp.source = 'file';
      $('status').textContent = summary;
      syncControls();
      requestBake(0);
    } catch (err) {
      showError(`${err.message || err} — the lamp and the bake are unchanged`);
    }
    e.target.value = '';
  };
  $('exposure').oninput = (e) => { viewer.setExposure(Number(e.target.value)); e.target.nextElementSibling.value = e.target.value; };
  $('falsecolour').onchange = (e) => { viewer.setFalseColour(e.target.checked); $('legend').hidden = !e.target.checked; };
  $('walk').onchange = (e) => { viewer.setWalk(e.target.checked); canvas.focus(); };
  $('resetview').onclick = () => { viewer.resetCamera(); $('walk').checked = false; };
}

// Input: pointer drag (mouse, pen, one finger), two-finger pinch, wheel, keys.
const pointers = new Map();
const keys = new Set();
function wireInput() {
  canvas.addEventListener('pointerdown', (e) => { canvas.setPointerCapture(e.pointerId); pointers.set(e.pointerId, [e.clientX, e.clientY]); canvas.focus(); });
  canvas.addEventListener('pointermove', (e) => {
    const prev = pointers.get(e.pointerId);
    if (!prev) return;
    if (pointers.size === 1) viewer.drag(e.clientX - prev[0], e.clientY - prev[1]);
    else if (pointers.size === 2) {
      const [a, b] = [...pointers.values()];
      const other = a === prev ? b : a;
      const before = Math.hypot(prev[0] - other[0], prev[1] - other[1]);
      const after = Math.hypot(e.clientX - other[0], e.clientY - other[1]);
      if (before > 0 && after > 0) viewer.zoom(before / after);
    }
    pointers.set(e.pointerId, [e.clientX, e.clientY]);
  });
  const up = (e) => pointers.delete(e.pointerId);
  canvas.addEventListener('pointerup', up);
  canvas.addEventListener('pointercancel', up);
  canvas.addEventListener('wheel', (e) => { e.preventDefault(); viewer.zoom(Math.exp(e.deltaY * 0.001)); }, { passive: false });
  canvas.addEventListener('keydown', (e) => { keys.add(e.code); if (e.code.startsWith('Arrow')) e.preventDefault(); });
  canvas.addEventListener('keyup', (e) => keys.delete(e.code));
  canvas.addEventListener('blur', () => keys.clear());
  canvas.addEventListener('webglcontextlost', (e) => {
    e.preventDefault();
    fatal('The display lost its WebGL context; waiting for the browser to restore it…');
  });
  canvas.addEventListener('webglcontextrestored', () => {
    try {
      viewer.restore(canvas);
      overlay.hidden = true;
    } catch (err) {
      fatal(`The WebGL context could not be restored: ${err.message || err}. Reload the page.`);
    }
  });
}

let last = performance.now();
function frame(now) {
  const dt = Math.min(0.1, (now - last) / 1000);
  last = now;
  const speed = 1.5 * dt;
  const k = (a, b) => (keys.has(a) || keys.has(b) ? 1 : 0);
  const fwd = k('KeyW', 'ArrowUp') - k('KeyS', 'ArrowDown');
  const right = k('KeyD', 'ArrowRight') - k('KeyA', 'ArrowLeft');
  const lift = k('KeyE', 'PageUp') - k('KeyQ', 'PageDown');
  if (fwd || right || lift) viewer.walk(fwd * speed, right * speed, lift * speed);
  const dpr = window.devicePixelRatio || 1;
  const w = Math.max(1, Math.round(canvas.clientWidth * dpr));
  const h = Math.max(1, Math.round(canvas.clientHeight * dpr));
  if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
  try {
    viewer.render(w, h);
    hooks.frames += 1;
  } catch (err) {
    showError(`display: ${err.message || err}`);
    return; // stop drawing after a GL error rather than flooding the page
  }
  requestAnimationFrame(frame);
}

async function main() {
  await init();
  const request = JSON.parse(defaultRequest());
  // URL overrides, e.g. ?scene=chairs_01&texels_per_metre=12&rays=16&bounces=2 (`bounces`
  // without `tail=true` is an exact count)
  const params = new URLSearchParams(location.search);
  for (const key of ['scene', 'method', 'quality', 'rays', 'bounces', 'blur_sigma', 'texels_per_metre', 'seed']) {
    if (params.has(key)) request[key] = ['scene', 'method', 'quality'].includes(key) ? params.get(key) : Number(params.get(key));
  }
  if (params.has('bounces') || params.has('tail')) request.tail = params.get('tail') === 'true';
  hooks.request = request;
  fillSelect($('scene'), JSON.parse(sceneNames()).map((n) => [n, n]));
  fillSelect($('lamp'), JSON.parse(bundledLamps()));
  try {
    viewer = new Viewer(canvas);
  } catch (err) {
    fatal(`This page needs WebGL2: ${err.message || err}`);
    hooks.state = 'fatal';
    return;
  }
  syncControls();
  wireControls();
  wireInput();
  requestAnimationFrame(frame);
  worker = new Worker(new URL('./worker.js', import.meta.url), { type: 'module' });
  worker.onmessage = onWorker;
  worker.onerror = (e) => fatal(`The bake worker failed to start: ${e.message || 'module workers unsupported?'}`);
  hooks.state = 'ready';
}

main().catch((err) => fatal(`The viewer failed to start: ${err.message || err}`));
