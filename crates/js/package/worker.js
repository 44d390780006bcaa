// luxbake's bake worker: one WebGL2 context on an OffscreenCanvas, one bake at a time, so that
// the page's thread keeps drawing while the GPU bakes. Messages: see index.js.
import init, { Baker, takePanic } from './wasm/luxbake_js.js';

let baker = null;

function describe(err) {
  if (err && err.name === 'LuxbakeError') return { kind: err.kind, message: err.message, fatal: false };
  // Anything else is a trap (a Rust panic aborts the module) or a JS failure: the module may be
  // in any state, so the page replaces this worker.
  const panic = (() => { try { return takePanic(); } catch { return undefined; } })();
  return { kind: 'internal', message: panic || `internal error: ${err && err.message ? err.message : err}`, fatal: true };
}

const ready = init().then(() => {
  baker = new Baker();
  postMessage({ type: 'ready', renderer: baker.renderer() });
}).catch((err) => {
  const d = describe(err);
  postMessage({ type: 'fatal', kind: err && err.kind ? err.kind : 'webgl', message: d.message });
});

onmessage = async (e) => {
  await ready;
  const m = e.data;
  if (!baker) return;
  if (m.type === 'release') {
    baker.release(m.bakeId);
    return;
  }
  if (m.type === 'test:loseContext') {
    baker.loseContextDuringNextBake(m.pass);
    postMessage({ type: 'done', id: m.id });
    return;
  }
  try {
    if (m.type === 'bake') {
      const result = baker.bake(new Uint8Array(m.gltf.buffer ?? m.gltf), m.options, m.photometry, (event) => {
        postMessage({ type: 'progress', id: m.id, event: JSON.parse(event) });
      });
      const transfer = [];
      for (const o of result.objects) {
        for (const k of ['illuminance', 'direct', 'uv1', 'indices', 'sourceVertex']) if (o[k]) transfer.push(o[k].buffer);
      }
      postMessage({ type: 'done', id: m.id, result }, transfer);
    } else if (m.type === 'measure') {
      const lux = baker.measure(m.bakeId, m.points);
      postMessage({ type: 'measured', id: m.id, lux }, [lux.buffer]);
    }
  } catch (err) {
    postMessage({ type: 'error', id: m.id, ...describe(err) });
  }
};
