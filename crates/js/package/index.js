// luxbake: bake physically based light maps (illuminance in lux) of a glTF room lit by real
// lamps (IES LM-63 or EULUMDAT photometry), in the browser, on the visitor's GPU (WebGL2 in a
// module worker), and put them on a three.js scene. ES module, no bundler needed.

const WORKER_URL = new URL('./worker.js', import.meta.url);

/** The error every promise of this package rejects with; `kind` says what was wrong. */
export class LuxbakeError extends Error {
  constructor(kind, message) {
    super(message);
    this.name = 'LuxbakeError';
    this.kind = kind;
  }
}

/** The quality presets of the converged method (the CLI's `--quality`). */
export const QUALITIES = Object.freeze(['draft', 'default', 'final']);

/** The bake methods (the CLI's `--method`). */
export const METHODS = Object.freeze(['converged', 'paper']);

const SETTING_KEYS = ['method', 'quality', 'rays', 'bounces', 'tail', 'blurSigma', 'texelsPerMetre', 'seed', 'lampPaths', 'measureTolerance'];
const LAMP_KEYS = ['name', 'position', 'aim', 'rotation', 'multiplier', 'color'];

function toBytes(value, what) {
  if (typeof value === 'string') return new TextEncoder().encode(value);
  if (value instanceof ArrayBuffer) return new Uint8Array(value.slice(0));
  if (ArrayBuffer.isView(value)) return new Uint8Array(value.buffer.slice(value.byteOffset, value.byteOffset + value.byteLength));
  throw new LuxbakeError('options', `${what} must be a string, an ArrayBuffer or a typed array`);
}

function aborted(signal) {
  const why = signal && signal.reason !== undefined ? `: ${signal.reason?.message ?? signal.reason}` : '';
  return new LuxbakeError('aborted', `the bake was aborted${why}`);
}

/**
 * A baker: one module worker with one WebGL2 context on an OffscreenCanvas. Bakes run one at a
 * time (a second `bake()` waits for the first).
 */
export class Luxbake {
  #worker = null;
  #starting = null;
  #renderer = '';
  #pending = new Map();
  #nextId = 1;
  #queue = Promise.resolve();
  #disposed = false;
  #generation = 0;
  #results = new Set();

  /** Starts the worker and checks WebGL2; rejects with a `webgl` LuxbakeError without it. */
  static async create() {
    const baker = new Luxbake();
    await baker.#ensureWorker();
    return baker;
  }

  /** The GPU the bakes run on, as WebGL reports it. */
  get renderer() {
    return this.#renderer;
  }

  #ensureWorker() {
    if (this.#disposed) return Promise.reject(new LuxbakeError('disposed', 'the baker was disposed'));
    if (this.#starting) return this.#starting;
    const worker = new Worker(WORKER_URL, { type: 'module', name: 'luxbake' });
    const generation = ++this.#generation;
    this.#worker = worker;
    this.#starting = new Promise((resolve, reject) => {
      const fail = (kind, message) => {
        this.#kill(new LuxbakeError(kind, message));
        reject(new LuxbakeError(kind, message));
      };
      worker.onmessage = (e) => {
        const m = e.data;
        if (m.type === 'ready') {
          this.#renderer = m.renderer;
          resolve();
        } else if (m.type === 'fatal') {
          fail(m.kind || 'webgl', m.message);
        } else {
          this.#onMessage(m, generation);
        }
      };
      worker.onerror = (e) => {
        e.preventDefault?.();
        fail('worker', `the luxbake worker failed: ${e.message || 'it could not be loaded'}`);
      };
    });
    return this.#starting;
  }

  /** Ends the worker (its WebGL2 context goes with it); pending requests reject with `error`. */
  #kill(error) {
    if (this.#worker) this.#worker.terminate();
    this.#worker = null;
    this.#starting = null;
    this.#generation++;
    for (const [, p] of this.#pending) p.reject(error);
    this.#pending.clear();
    for (const r of this.#results) r._forget();
    this.#results.clear();
  }

  #onMessage(m, generation) {
    if (generation !== this.#generation) return;
    const p = this.#pending.get(m.id);
    if (!p) return;
    if (m.type === 'progress') {
      p.progress?.(m.event);
      return;
    }
    this.#pending.delete(m.id);
    if (m.type === 'error') {
      const err = new LuxbakeError(m.kind, m.message);
      // A panic or a trap leaves the module unusable: start a fresh worker next time.
      if (m.fatal) this.#kill(err);
      p.reject(err);
    } else {
      p.resolve(m);
    }
  }

  #request(message, transfer = [], progress = null) {
    const id = this.#nextId++;
    return new Promise((resolve, reject) => {
      this.#pending.set(id, { resolve, reject, progress });
      this.#worker.postMessage({ ...message, id }, transfer);
    });
  }

  /**
   * Bakes `scene` (glTF/GLB bytes) lit by `lamps`. Options: `quality`, `method` and the
   * settings' overrides (`rays`, `bounces`, `tail`, `blurSigma`, `texelsPerMetre`, `seed`, `lampPaths`), checked by
   * the same code as the CLI; `onProgress(event)` with `event.fraction` from 0 to 1;
   * `signal` an AbortSignal. Resolves to a BakeResult.
   */
  bake(options) {
    const run = () => this.#bake(options);
    const result = this.#queue.then(run, run);
    this.#queue = result.catch(() => {});
    const signal = options?.signal;
    if (!signal) return result;
    // A bake still waiting for the one before it rejects at once too (it then never starts).
    return Promise.race([result, new Promise((_, reject) => {
      if (signal.aborted) reject(aborted(signal));
      else signal.addEventListener('abort', () => reject(aborted(signal)), { once: true });
    })]);
  }

  async #bake(options = {}) {
    const { scene, lamps, onProgress, signal } = options;
    if (signal?.aborted) throw aborted(signal);
    if (!(scene instanceof ArrayBuffer) && !ArrayBuffer.isView(scene)) {
      throw new LuxbakeError('options', '`scene` must be the glTF or GLB file as an ArrayBuffer');
    }
    if (!Array.isArray(lamps)) throw new LuxbakeError('options', '`lamps` must be an array of lamps');
    const settings = {};
    for (const [k, v] of Object.entries(options)) {
      if (['scene', 'lamps', 'onProgress', 'signal'].includes(k) || v === undefined) continue;
      if (!SETTING_KEYS.includes(k)) {
        throw new LuxbakeError('options', `unknown option \`${k}\` (expected scene, lamps, onProgress, signal, ${SETTING_KEYS.join(', ')})`);
      }
      settings[k] = v;
    }
    const photometry = [];
    settings.lamps = lamps.map((lamp, i) => {
      if (lamp === null || typeof lamp !== 'object') throw new LuxbakeError('lamp', `lamp ${i} is not an object`);
      if (lamp.photometry === undefined) throw new LuxbakeError('lamp', `lamp ${i}: \`photometry\` (the IES or EULUMDAT file) is missing`);
      photometry.push(toBytes(lamp.photometry, `lamp ${i}: \`photometry\``));
      const spec = {};
      for (const [k, v] of Object.entries(lamp)) {
        if (k === 'photometry' || v === undefined) continue;
        if (!LAMP_KEYS.includes(k)) throw new LuxbakeError('lamp', `lamp ${i}: unknown key \`${k}\` (expected photometry, ${LAMP_KEYS.join(', ')})`);
        spec[k] = ArrayBuffer.isView(v) ? Array.from(v) : v;
      }
      return spec;
    });
    const bytes = toBytes(scene, '`scene`');
    await this.#ensureWorker();
    if (signal?.aborted) throw aborted(signal);
    const started = performance.now();
    let last = 0;
    const progress = (event) => {
      last = Math.max(last, event.fraction);
      if (onProgress) {
        try { onProgress({ ...event, fraction: last }); } catch (err) { console.error(err); }
      }
    };
    const work = this.#request(
      { type: 'bake', gltf: bytes, options: JSON.stringify(settings), photometry },
      [bytes.buffer, ...photometry.map((p) => p.buffer)],
      progress,
    );
    let onAbort = null;
    const cancel = new Promise((_, reject) => {
      if (!signal) return;
      onAbort = () => {
        // The bake runs to its end inside the worker: end the worker (the next bake starts a
        // new one), so that the promise rejects at once and the GPU stops.
        const err = aborted(signal);
        this.#kill(err);
        reject(err);
      };
      signal.addEventListener('abort', onAbort, { once: true });
    });
    try {
      const m = await Promise.race([work, cancel]);
      const result = new BakeResult(this, m.result, (performance.now() - started) / 1000);
      this.#results.add(result);
      if (onProgress) {
        try { onProgress({ phase: 'done', fraction: 1 }); } catch (err) { console.error(err); }
      }
      return result;
    } finally {
      if (onAbort) signal.removeEventListener('abort', onAbort);
    }
  }

  /** @internal */
  async _measure(bakeId, points) {
    if (!this.#worker) throw new LuxbakeError('measure', 'the baker that made this result was disposed or aborted');
    const m = await this.#request({ type: 'measure', bakeId, points });
    return m.lux;
  }

  /** @internal For tests: the next bake loses its WebGL2 context when pass `pass` starts. */
  async _loseContextDuringNextBake(pass) {
    await this.#ensureWorker();
    await this.#request({ type: 'test:loseContext', pass });
  }

  /** @internal */
  _release(result) {
    this.#results.delete(result);
    if (this.#worker) this.#worker.postMessage({ type: 'release', bakeId: result.id });
  }

  /** Frees the worker and its WebGL2 context; later calls reject with `disposed`. */
  dispose() {
    if (this.#disposed) return;
    this.#kill(new LuxbakeError('disposed', 'the baker was disposed'));
    this.#disposed = true;
  }
}

/** Largest finite half float. */
const HALF_MAX = 65504;

/** The light maps of one bake. */
export class BakeResult {
  #baker;
  #textures = [];

  constructor(baker, raw, wallSeconds) {
    this.#baker = baker;
    const report = JSON.parse(raw.report);
    /** Bake id inside the worker (for `measure`). */
    this.id = raw.id;
    /** Per baked object: name, glTF origin, light maps (RGBA Float32Array, lux). */
    this.objects = raw.objects;
    /** What the glTF reader ignored or converted. */
    this.warnings = raw.warnings;
    /** The bake's report: texels, triangles, settings, per-pass seconds. */
    this.report = report;
    /** Seconds: `bake` as the bake measured itself, `total` with the transfer to and from the worker. */
    this.timings = {
      bake: report.totalSeconds,
      total: wallSeconds,
      setup: report.setup,
      passes: report.passes,
    };
  }

  /** @internal */
  _forget() {
    this.#baker = null;
  }

  /**
   * Illuminance in lux at world points (an array of [x, y, z] or a flat array of 3n numbers,
   * metres, in the glTF file's frame): a Promise of a Float64Array, NaN for a point on no baked
   * surface.
   */
  async measure(points) {
    const flat = Float64Array.from(Array.isArray(points) && Array.isArray(points[0]) ? points.flat() : points);
    if (!this.#baker) throw new LuxbakeError('measure', 'this result was disposed, or its baker aborted a bake or was disposed');
    return this.#baker._measure(this.id, flat);
  }

  /**
   * Puts the light maps on a three.js scene loaded from the same file: `root` is the object
   * GLTFLoader returned (`gltf`, exact matching through `gltf.parser.associations`) or an
   * Object3D (matching by name). Each matched mesh gets a clone of its material with
   * `lightMap` (half-float RGBA, lux, `channel` 1) and `lightMapIntensity` (default 1: the
   * map is illuminance E, so three.js shows radiance ρE/π); its geometry gets `uv1` (and is
   * rebuilt where the UVs were generated). Returns `{ applied, unmatched }`.
   */
  applyToThree(root, THREE, { intensity = 1 } = {}) {
    if (!THREE || !THREE.DataTexture) throw new LuxbakeError('options', 'applyToThree needs the three.js module as its second argument');
    const associations = root?.parser?.associations;
    const sceneRoot = root?.scene ?? root;
    if (!sceneRoot || typeof sceneRoot.traverse !== 'function') {
      throw new LuxbakeError('options', 'applyToThree needs the GLTFLoader result or a three.js Object3D');
    }
    const meshes = [];
    sceneRoot.traverse((o) => { if (o.isMesh) meshes.push(o); });
    const sanitize = (s) => String(s).replace(/\s/g, '_').replace(/[\[\]\.:\/]/g, '');
    const find = (obj) => {
      if (associations && obj.gltf) {
        return meshes.find((o) => {
          const a = associations.get(o);
          if (!a || a.meshes !== obj.gltf.mesh || (a.primitives ?? 0) !== obj.gltf.primitive) return false;
          for (let p = o; p; p = p.parent) {
            const n = associations.get(p);
            if (n && n.nodes !== undefined) return n.nodes === obj.gltf.node;
          }
          return false;
        });
      }
      return meshes.find((o) => sanitize(o.name) === sanitize(obj.name));
    };
    let applied = 0;
    const unmatched = [];
    for (const obj of this.objects) {
      const mesh = find(obj);
      if (!mesh) {
        unmatched.push(obj.name);
        continue;
      }
      // The file's own geometry and material, kept on the first application, are the source
      // of every later one (a re-bake may have generated different UVs).
      const ud = mesh.userData;
      ud.luxbakeGeometry ??= mesh.geometry;
      ud.luxbakeMaterial ??= mesh.material;
      const geometry = this.#geometry(ud.luxbakeGeometry, obj, THREE);
      if (!geometry) {
        unmatched.push(obj.name);
        continue;
      }
      if (mesh.geometry !== ud.luxbakeGeometry) mesh.geometry.dispose();
      mesh.geometry = geometry;
      const texture = this.#texture(obj, THREE);
      const source = ud.luxbakeMaterial;
      const material = Array.isArray(source) ? source.map((m) => m.clone()) : source.clone();
      for (const m of Array.isArray(material) ? material : [material]) {
        m.lightMap = texture;
        m.lightMapIntensity = intensity;
        m.needsUpdate = true;
      }
      if (mesh.material !== source) for (const m of [mesh.material].flat()) m.dispose();
      mesh.material = material;
      applied++;
    }
    return { applied, unmatched };
  }

  /** The geometry with the light-map UVs as `uv1`, or null when `old` does not fit. */
  #geometry(old, obj, THREE) {
    const uv1 = new THREE.BufferAttribute(new Float32Array(obj.uv1), 2);
    const count = old.attributes.position.count;
    if (!obj.sourceVertex) {
      if (count !== obj.uv1.length / 2) return null;
      const geometry = old.clone();
      geometry.setAttribute('uv1', uv1);
      return geometry;
    }
    // Generated UVs: the unwrapper split vertices at chart seams; gather every attribute of
    // the file's vertices into the new vertex order.
    const src = obj.sourceVertex;
    if (src.some((v) => v >= count)) return null;
    const geometry = new THREE.BufferGeometry();
    for (const [name, attr] of Object.entries(old.attributes)) {
      if (name === 'uv1') continue;
      const size = attr.itemSize;
      // Raw components (normalized integers stay as they are); interleaved attributes read
      // from their shared buffer.
      const array = attr.isInterleavedBufferAttribute ? attr.data.array : attr.array;
      const stride = attr.isInterleavedBufferAttribute ? attr.data.stride : size;
      const offset = attr.isInterleavedBufferAttribute ? attr.offset : 0;
      const out = new array.constructor(src.length * size);
      for (let i = 0; i < src.length; i++) {
        for (let c = 0; c < size; c++) out[i * size + c] = array[src[i] * stride + offset + c];
      }
      geometry.setAttribute(name, new THREE.BufferAttribute(out, size, attr.normalized));
    }
    geometry.setAttribute('uv1', uv1);
    geometry.setIndex(new THREE.BufferAttribute(new Uint32Array(obj.indices), 1));
    return geometry;
  }

  #texture(obj, THREE) {
    const src = obj.illuminance;
    const half = new Uint16Array(src.length);
    for (let i = 0; i < src.length; i++) {
      const v = i % 4 === 3 ? 1 : Math.min(Math.max(src[i], 0), HALF_MAX);
      half[i] = THREE.DataUtils.toHalfFloat(v);
    }
    const t = new THREE.DataTexture(half, obj.width, obj.height, THREE.RGBAFormat, THREE.HalfFloatType);
    t.channel = 1;
    t.flipY = false;
    t.colorSpace = THREE.NoColorSpace ?? '';
    t.magFilter = THREE.LinearFilter;
    t.minFilter = THREE.LinearFilter;
    t.generateMipmaps = false;
    t.name = `${obj.name}_lux`;
    t.needsUpdate = true;
    this.#textures.push(t);
    return t;
  }

  /** Frees the textures made by applyToThree and the maps kept in the worker for measure. */
  dispose() {
    for (const t of this.#textures) t.dispose();
    this.#textures = [];
    if (this.#baker) this.#baker._release(this);
    this.#baker = null;
  }
}
