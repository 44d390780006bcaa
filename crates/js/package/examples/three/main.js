// luxbake + three.js: load a glTF room, pick a lamp (bundled photometry or a file), bake its
// light maps in the browser, orbit around the result. The room is read once (`baker.load`):
// another lamp re-bakes only the lamp's part, and shows its direct light first.
//
// URL parameters (all optional): scene (a .glb URL), lamp (a photometry URL), x, y, z (lamp
// position, metres), quality, and rays, bounces, blurSigma, texelsPerMetre, seed (settings'
// overrides); autobake=1 bakes on load.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { Luxbake, setExposure } from 'luxbake';

const LAMPS = [
  ['lamps/luxbake_downlight.ies', 'luxbake downlight (1500 lm)'],
  ['lamps/synthetic_cosine_typeC.ies', 'synthetic I = 1000 cd·cos θ'],
  ['lamps/synthetic_asym_typeC.ies', 'synthetic asymmetric'],
];
const params = new URLSearchParams(location.search);
const $ = (id) => document.getElementById(id);

// State the end-to-end test reads (cargo xtask npm --check).
const example = {
  state: 'loading', errors: [], progress: [], bakes: 0, timings: null, result: null,
  THREE, Luxbake, GLTFLoader, setExposure,
};
window.luxbakeExample = example;
function fail(err) {
  example.errors.push(String(err.message || err));
  $('errors').textContent = example.errors.at(-1);
}

const canvas = $('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
const scene3 = new THREE.Scene();
scene3.background = new THREE.Color(0x101010);
const camera = new THREE.PerspectiveCamera(60, 1, 0.05, 100);
const controls = new OrbitControls(camera, canvas);
controls.addEventListener('change', draw);

function exposureChanged() {
  // ACES filmic: three.js's default (NoToneMapping) ignores the exposure.
  renderer.toneMapping = THREE.ACESFilmicToneMapping;
  renderer.toneMappingExposure = 2 ** Number($('exposure').value);
  draw();
}
function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
function draw() {
  resize();
  renderer.render(scene3, camera);
}
window.addEventListener('resize', draw);
$('exposure').addEventListener('input', exposureChanged);

/** Pixel position of world point (x, y, z) in the canvas, or null behind the camera. */
example.screenPoint = (x, y, z) => {
  const p = new THREE.Vector3(x, y, z).project(camera);
  if (p.z > 1 || p.z < -1) return null;
  return [(p.x + 1) / 2 * canvas.clientWidth, (1 - p.y) / 2 * canvas.clientHeight];
};

async function fetchBytes(url) {
  const r = await fetch(url);
  if (!r.ok) throw new Error(`${url}: HTTP ${r.status}`);
  return r.arrayBuffer();
}

let gltf = null;
let sceneBytes = null;
let lampFile = null; // { name, bytes } of an uploaded file
let bounds = null;

async function loadRoom(url) {
  sceneBytes = await fetchBytes(url);
  gltf = await new GLTFLoader().parseAsync(sceneBytes.slice(0), '');
  scene3.add(gltf.scene);
  bounds = new THREE.Box3().setFromObject(gltf.scene);
  const c = bounds.getCenter(new THREE.Vector3());
  const size = bounds.getSize(new THREE.Vector3());
  $('x').value = params.get('x') ?? c.x.toFixed(2);
  $('y').value = params.get('y') ?? (bounds.max.y - 0.05).toFixed(2);
  $('z').value = params.get('z') ?? c.z.toFixed(2);
  camera.position.set(c.x + size.x * 0.35, bounds.min.y + size.y * 0.8, c.z + size.z * 0.45);
  controls.target.set(c.x, bounds.min.y, c.z);
  controls.update();
  example.sceneBytes = sceneBytes;
}

let baker = null;
let room = null;
let running = null;
let lastResult = null;

/** The settings' overrides of the URL. */
function urlSettings() {
  const settings = {};
  for (const k of ['rays', 'bounces', 'blurSigma', 'texelsPerMetre', 'seed']) {
    if (params.has(k)) settings[k] = Number(params.get(k));
  }
  return settings;
}

async function bake() {
  if (running) running.abort();
  const abort = new AbortController();
  running = abort;
  $('cancel').disabled = false;
  example.state = 'baking';
  example.progress = [];
  const photometry = lampFile ? lampFile.bytes : await fetchBytes($('lamp').value);
  const settings = urlSettings();
  const position = ['x', 'y', 'z'].map((k) => Number($(k).value));
  example.request = { position, ...settings };
  $('status').textContent = 'baking…';
  try {
    const t0 = performance.now();
    let direct = null;
    let directSeconds = null;
    const result = await room.bake({
      lamps: [{ photometry, position, name: lampFile ? lampFile.name : $('lamp').selectedOptions[0].text }],
      quality: $('quality').value,
      ...settings,
      signal: abort.signal,
      onProgress: (e) => {
        example.progress.push(e.fraction);
        $('progress').value = e.fraction;
      },
      // The direct light first, while the bounces run (a lamp that bakes its luminous
      // opening sends a preview, every lamp a point, before it).
      onDirect: (d) => {
        directSeconds ??= (performance.now() - t0) / 1000;
        d.applyToThree(gltf, THREE);
        direct?.dispose();
        direct = d;
        draw();
        $('status').textContent = d.stage === 'preview'
          ? 'direct light (preview) shown; baking the luminous opening…'
          : 'direct light shown; baking the bounces…';
      },
    });
    const t1 = performance.now();
    if (lastResult) lastResult.dispose();
    lastResult = result;
    const { applied, unmatched } = result.applyToThree(gltf, THREE);
    direct?.dispose();
    draw();
    await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
    const t2 = performance.now();
    example.timings = { bake: result.timings.bake, call: (t1 - t0) / 1000, firstFrame: (t2 - t1) / 1000, direct: directSeconds };
    // Exposure from the illuminance on the floor under the lamp (a measure() look-up): its
    // radiance ρE/π at ρ = 0.5 maps to 0.8 before tone mapping.
    const [floorLux] = await result.measure([[position[0], bounds.min.y, position[2]]]);
    example.floorLux = floorLux;
    if (!params.has('exposure') && floorLux > 0) {
      $('exposure').value = Math.log2(setExposure(renderer, THREE, floorLux)).toFixed(2);
      exposureChanged();
    }
    await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r)));
    example.result = result;
    example.bakes++;
    example.state = 'baked';
    $('status').textContent = `baked ${applied} objects in ${result.timings.bake.toFixed(2)} s on ${baker.renderer}` +
      (unmatched.length ? `; not found in the scene: ${unmatched.join(', ')}` : '') +
      (result.warnings.length ? `; ${result.warnings.join('; ')}` : '');
  } catch (err) {
    example.state = err.kind === 'aborted' ? 'aborted' : 'error';
    $('status').textContent = err.kind === 'aborted' ? 'cancelled' : 'bake failed';
    if (err.kind !== 'aborted') fail(err);
  } finally {
    if (running === abort) {
      running = null;
      $('cancel').disabled = true;
    }
  }
}

async function main() {
  for (const [url, label] of LAMPS) $('lamp').add(new Option(label, url));
  if (params.get('lamp')) $('lamp').add(new Option(params.get('lamp').split('/').pop(), params.get('lamp')), 0);
  $('lamp').selectedIndex = 0;
  if (params.get('quality')) $('quality').value = params.get('quality');
  if (params.get('exposure')) $('exposure').value = params.get('exposure');
  $('lamp').addEventListener('change', () => { lampFile = null; $('lamp-file').value = ''; bake(); });
  $('lamp-file').addEventListener('change', async () => {
    const f = $('lamp-file').files[0];
    if (!f) return;
    lampFile = { name: f.name, bytes: await f.arrayBuffer() };
    bake();
  });
  $('bake').addEventListener('click', bake);
  $('cancel').addEventListener('click', () => running?.abort(new Error('cancelled')));
  exposureChanged();
  await loadRoom(params.get('scene') || 'chairs_01.glb');
  draw();
  baker = await Luxbake.create();
  example.baker = baker;
  // The room's layout, G-buffer and BVH, once for every lamp.
  room = await baker.load({ scene: sceneBytes, ...urlSettings() });
  example.room = room;
  example.state = 'ready';
  $('status').textContent = `ready: ${baker.renderer}`;
  if (params.get('autobake') === '1') await bake();
}

main().catch((err) => {
  example.state = 'fatal';
  $('status').textContent = 'cannot bake here';
  fail(err);
});
