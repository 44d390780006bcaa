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
  if (m.type === 'disposeRoom') {
    baker.disposeRoom(m.room);
    return;
  }
  const progress = (event) => {
    postMessage({ type: 'progress', id: m.id, event: JSON.parse(event) });
  };
  try {
    if (m.type === 'bake') {
      const result = baker.bake(new Uint8Array(m.gltf.buffer ?? m.gltf), m.options, m.photometry, progress);
      postMessage({ type: 'done', id: m.id, result }, transferOf(result));
    } else if (m.type === 'load') {
      const result = baker.load(new Uint8Array(m.gltf.buffer ?? m.gltf), m.options, progress);
      postMessage({ type: 'done', id: m.id, result });
    } else if (m.type === 'bakeRoom') {
      // The direct light goes to the page while the bounces still run.
      const direct = m.direct ? (result) => postMessage({ type: 'direct', id: m.id, result }, transferOf(result)) : undefined;
      const result = baker.bakeRoom(m.room, m.options, m.photometry, progress, direct, m.layers);
      postMessage({ type: 'done', id: m.id, result }, transferOf(result));
    } else if (m.type === 'measure') {
      const lux = baker.measure(m.bakeId, m.points, m.states);
      postMessage({ type: 'measured', id: m.id, lux }, [lux.buffer]);
    }
  } catch (err) {
    postMessage({ type: 'error', id: m.id, ...describe(err) });
  }
};

/** The buffers of a result's maps and geometry, moved to the page rather than copied. */
function transferOf(result) {
  const transfer = [];
  for (const o of result.objects) {
    for (const k of ['illuminance', 'direct', 'uv1', 'indices', 'sourceVertex']) if (o[k]) transfer.push(o[k].buffer);
    if (o.layers) for (const maps of [o.layers.illuminance, o.layers.direct]) for (const map of maps) transfer.push(map.buffer);
  }
  return transfer;
}
