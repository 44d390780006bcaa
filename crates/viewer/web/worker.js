// luxbake bake worker: owns a WebGL2 context on an OffscreenCanvas and bakes one request at a
// time, so that the page's thread keeps drawing while the GPU bakes.
import init, { Baker } from './pkg/luxbake_viewer.js';

let baker = null;
let failure = null;

const ready = init().then(() => {
  try {
    baker = new Baker();
    postMessage({ type: 'ready', renderer: baker.renderer() });
  } catch (err) {
    failure = String(err.message || err);
    postMessage({ type: 'fatal', message: failure });
  }
}, (err) => {
  failure = `loading the wasm module failed: ${err.message || err}`;
  postMessage({ type: 'fatal', message: failure });
});

onmessage = async (e) => {
  await ready;
  const m = e.data;
  if (m.type !== 'bake') return;
  if (!baker) {
    postMessage({ type: 'error', id: m.id, message: failure });
    return;
  }
  const t0 = performance.now();
  try {
    const result = baker.bake(m.request, m.lampFile, (event) => {
      postMessage({ type: 'progress', id: m.id, event: JSON.parse(event) });
    }, (maps, stage) => {
      // The direct light (first its preview, for a lamp that bakes its opening), shown while
      // the bounces run.
      postMessage({ type: 'direct', id: m.id, maps, stage, wall: (performance.now() - t0) / 1000 },
        maps.map((map) => map.illuminance.buffer));
    });
    const transfer = [];
    for (const map of result.maps) transfer.push(map.illuminance.buffer, map.direct.buffer, map.exitance.buffer);
    postMessage({
      type: 'done', id: m.id, report: JSON.parse(result.report), maps: result.maps,
      wall: (performance.now() - t0) / 1000,
    }, transfer);
  } catch (err) {
    postMessage({ type: 'error', id: m.id, message: String(err.message || err) });
  }
};
