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

const SETTING_KEYS = ['method', 'quality', 'rays', 'bounces', 'tail', 'blurSigma', 'texelsPerMetre', 'seed', 'lampPaths', 'narrowRays', 'denoiseCorrection', 'directAtHits', 'openingSamples', 'openingProbeStride', 'lampModel', 'measureTolerance'];
const LAMP_KEYS = ['name', 'position', 'aim', 'rotation', 'multiplier', 'color', 'lampModel'];

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

/** The glTF/GLB file of `options.scene` as a copy of its bytes. */
function sceneBytes(scene) {
  if (!(scene instanceof ArrayBuffer) && !ArrayBuffer.isView(scene)) {
    throw new LuxbakeError('options', '`scene` must be the glTF or GLB file as an ArrayBuffer');
  }
  return toBytes(scene, '`scene`');
}

/** The settings of `options` (every key but `other`), checked for unknown keys. */
function settingsOf(options, other) {
  const settings = {};
  for (const [k, v] of Object.entries(options)) {
    if (other.includes(k) || v === undefined) continue;
    if (!SETTING_KEYS.includes(k)) {
      throw new LuxbakeError('options', `unknown option \`${k}\` (expected ${other.join(', ')}, ${SETTING_KEYS.join(', ')})`);
    }
    settings[k] = v;
  }
  return settings;
}

/** The lamps' specs (JSON for the worker) and their photometric files. */
function lampsOf(lamps) {
  if (!Array.isArray(lamps)) throw new LuxbakeError('options', '`lamps` must be an array of lamps');
  const photometry = [];
  const specs = lamps.map((lamp, i) => {
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
  return { specs, photometry };
}

/**
 * Sets `renderer` up for light maps in lux: ACES filmic tone mapping (three.js's default,
 * `NoToneMapping`, ignores the exposure) with the exposure that shows a surface of albedo
 * `albedo` lit by `lux` (e.g. `result.measure` on the floor under the lamp) at `key` before
 * tone mapping. Returns the exposure.
 */
export function setExposure(renderer, THREE, lux, { albedo = 0.5, key = 0.8 } = {}) {
  if (!THREE || THREE.ACESFilmicToneMapping === undefined) throw new LuxbakeError('options', 'setExposure needs the three.js module as its second argument');
  if (!(lux > 0) || !Number.isFinite(lux)) throw new LuxbakeError('options', `setExposure needs an illuminance > 0 lux, got ${lux}`);
  renderer.toneMapping = THREE.ACESFilmicToneMapping;
  // Radiance ρE/π of the surface, brought to `key`.
  renderer.toneMappingExposure = key * Math.PI / (albedo * lux);
  return renderer.toneMappingExposure;
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
    if (m.type === 'direct') {
      p.direct?.(m.result);
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

  #request(message, transfer = [], progress = null, direct = null) {
    const id = this.#nextId++;
    return new Promise((resolve, reject) => {
      this.#pending.set(id, { resolve, reject, progress, direct });
      this.#worker.postMessage({ ...message, id }, transfer);
    });
  }

  /**
   * Bakes `scene` (glTF/GLB bytes) lit by `lamps`. Options: `quality`, `method` and the
   * settings' overrides (`rays`, `bounces`, `tail`, `blurSigma`, `texelsPerMetre`, `seed`, `lampPaths`, `narrowRays`, `denoiseCorrection`, `directAtHits`), checked by
   * the same code as the CLI; `onProgress(event)` with `event.fraction` from 0 to 1;
   * `signal` an AbortSignal. Resolves to a BakeResult.
   */
  bake(options) {
    return this.#enqueue(() => this.#bake(options), options?.signal);
  }

  /**
   * Reads `scene` (glTF/GLB bytes) as a room and does its host work (light-map layout,
   * G-buffer, BVH) once: resolves to a Room whose `bake({ lamps, ... })` runs only the lamps'
   * work and the GPU passes. Options: the settings of `bake` (the room's bakes start from
   * them), `onProgress`, `signal`.
   */
  load(options) {
    return this.#enqueue(() => this.#load(options), options?.signal);
  }

  /** Runs `run` after the bakes before it; a fired `signal` rejects at once. */
  #enqueue(run, signal) {
    const result = this.#queue.then(run, run);
    this.#queue = result.catch(() => {});
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
    const bytes = sceneBytes(scene);
    const settings = settingsOf(options, ['scene', 'lamps', 'onProgress', 'signal']);
    const { specs, photometry } = lampsOf(lamps);
    settings.lamps = specs;
    await this.#ensureWorker();
    return this.#run(
      { type: 'bake', gltf: bytes, options: JSON.stringify(settings), photometry },
      [bytes.buffer, ...photometry.map((p) => p.buffer)],
      { onProgress, signal },
      (m, seconds) => new BakeResult(this, m.result, seconds, { lamps: specs }),
    );
  }

  async #load(options = {}) {
    const { scene, onProgress, signal } = options;
    if (signal?.aborted) throw aborted(signal);
    const bytes = sceneBytes(scene);
    const settings = settingsOf(options, ['scene', 'onProgress', 'signal']);
    const room = new Room(this, bytes, settings);
    await this._loadInWorker(room, { onProgress, signal });
    return room;
  }

  /** @internal Loads `room` in the current worker (again after the worker was replaced). */
  async _loadInWorker(room, { onProgress, signal } = {}) {
    await this.#ensureWorker();
    const generation = this.#generation;
    const bytes = room._bytes.slice();
    await this.#run(
      { type: 'load', gltf: bytes, options: JSON.stringify(room._settings) },
      [bytes.buffer],
      { onProgress, signal },
      (m) => room._loaded(m.result, generation),
    );
  }

  /** @internal The worker's generation: rooms loaded in another one are gone. */
  get _generation() {
    return this.#worker ? this.#generation : -1;
  }

  /** @internal Bakes a loaded room (queued like `bake`). */
  _bakeRoom(room, options) {
    return this.#enqueue(() => this.#bakeRoom(room, options), options?.signal);
  }

  async #bakeRoom(room, options = {}) {
    const { lamps, onProgress, onDirect, signal, layers = false } = options;
    if (signal?.aborted) throw aborted(signal);
    const keys = ['lamps', 'onProgress', 'onDirect', 'signal', 'layers'];
    const settings = { ...room._settings, ...settingsOf(options, keys) };
    if (typeof layers !== 'boolean') throw new LuxbakeError('options', '`layers` must be true or false');
    if (onDirect !== undefined && typeof onDirect !== 'function') throw new LuxbakeError('options', '`onDirect` must be a function');
    if (onDirect && layers) throw new LuxbakeError('options', '`onDirect` is for bakes without `layers` (a layered bake bakes each lamp alone)');
    const { specs, photometry } = lampsOf(lamps);
    settings.lamps = specs;
    room._check();
    if (room._generation !== this._generation) await this._loadInWorker(room, { signal });
    const started = performance.now();
    const direct = onDirect ? (m) => {
      const result = new BakeResult(null, { id: 0, report: '{}', warnings: [], objects: m.objects }, (performance.now() - started) / 1000, { stage: m.stage === 'preview' ? 'preview' : 'direct' });
      try { onDirect(result); } catch (err) { console.error(err); }
    } : null;
    return this.#run(
      { type: 'bakeRoom', room: room._id, options: JSON.stringify(settings), photometry, direct: !!onDirect, layers },
      photometry.map((p) => p.buffer),
      { onProgress, signal, direct },
      (m, seconds) => new BakeResult(this, m.result, seconds, { lamps: specs }),
    );
  }

  /** Sends a request, reports its progress, rejects at once on `signal`; `make` builds the result. */
  async #run(message, transfer, { onProgress, signal, direct = null }, make) {
    const started = performance.now();
    let last = 0;
    const progress = (event) => {
      last = Math.max(last, event.fraction);
      if (onProgress) {
        try { onProgress({ ...event, fraction: last }); } catch (err) { console.error(err); }
      }
    };
    const work = this.#request(message, transfer, progress, direct);
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
      const result = make(m, (performance.now() - started) / 1000);
      if (result instanceof BakeResult) this.#results.add(result);
      if (onProgress) {
        try { onProgress({ phase: 'done', fraction: 1 }); } catch (err) { console.error(err); }
      }
      return result;
    } finally {
      if (onAbort) signal.removeEventListener('abort', onAbort);
    }
  }

  /** @internal */
  _disposeRoom(id) {
    if (this.#worker) this.#worker.postMessage({ type: 'disposeRoom', room: id });
  }

  /** @internal */
  async _measure(bakeId, points, states) {
    if (!this.#worker) throw new LuxbakeError('measure', 'the baker that made this result was disposed or aborted');
    const m = await this.#request({ type: 'measure', bakeId, points, states: states ? JSON.stringify(states) : undefined });
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

/**
 * A room read once (`baker.load`): its file, its light-map layout, G-buffer and BVH stay in
 * the worker, and `bake` runs only the lamps' work and the GPU passes.
 */
export class Room {
  #baker;
  #id = 0;
  #generation = -1;
  #disposed = false;

  constructor(baker, bytes, settings) {
    this.#baker = baker;
    /** @internal The file, kept to load the room again in a new worker. */
    this._bytes = bytes;
    /** @internal The load's settings: every bake starts from them. */
    this._settings = settings;
    /** What the glTF reader ignored or converted. */
    this.warnings = [];
    /** Objects read from the file, and light-map texels of the room. */
    this.objects = 0;
    this.texels = 0;
    /** Seconds the room's host work took in the worker. */
    this.seconds = 0;
  }

  /** @internal */
  _loaded(raw, generation) {
    this.#id = raw.room;
    this.#generation = generation;
    this.warnings = raw.warnings;
    this.objects = raw.objects;
    this.texels = raw.texels;
    this.seconds = raw.seconds;
  }

  /** @internal */
  get _id() {
    return this.#id;
  }

  /** @internal */
  get _generation() {
    return this.#generation;
  }

  /** @internal Throws `disposed` for a disposed room. */
  _check() {
    if (this.#disposed) throw new LuxbakeError('disposed', 'the room was disposed: load it again with baker.load');
  }

  /**
   * Bakes the room lit by `lamps`. Options: those of `baker.bake` but `scene` (the settings
   * start from the load's; another `texelsPerMetre` or `blurSigma` reads the room again),
   * `onDirect(result)` called with the direct light (a BakeResult for `applyToThree`) before
   * the bounces run (twice when a lamp bakes its luminous opening: first a preview, every
   * lamp a point, `result.stage` 'preview', then the direct light, 'direct'), and `layers: true` to bake each lamp alone so that `result.setLamp`
   * dims, tints or switches it without a ray. Resolves to a BakeResult.
   */
  bake(options) {
    if (this.#disposed) return Promise.reject(new LuxbakeError('disposed', 'the room was disposed: load it again with baker.load'));
    return this.#baker._bakeRoom(this, options);
  }

  /** Frees the room in the worker; later bakes reject with `disposed`. */
  dispose() {
    if (this.#disposed) return;
    this.#disposed = true;
    if (this.#baker._generation === this.#generation) this.#baker._disposeRoom(this.#id);
    this._bytes = null;
  }
}

/** Largest finite half float. */
const HALF_MAX = 65504;

/** Most lamps whose layers `applyToThree` sums in the shader (one texture unit each). */
const MAX_SHADER_LAYERS = 8;

/** The read of the light map in three.js's `lights_fragment_maps` chunk, replaced by the layers' sum. */
const LIGHTMAP_READ = 'vec4 lightMapTexel = texture2D( lightMap, vLightMapUv );';

/** A lamp's state in a layered result: `{ multiplier, color, on }`. */
function lampState(spec) {
  return { multiplier: spec.multiplier ?? 1, color: [...(spec.color ?? [1, 1, 1])], on: true };
}

/** The light maps of one bake. */
export class BakeResult {
  #baker;
  #textures = [];
  /** Layered: `{ colors, states, weights (three.js uniform), dirty, maps }`. */
  #layers = null;

  constructor(baker, raw, wallSeconds, { lamps = [], stage = 'converged' } = {}) {
    this.#baker = baker;
    const report = JSON.parse(raw.report);
    /** Bake id inside the worker (for `measure`). */
    this.id = raw.id;
    /**
     * `converged`; `direct` for the direct light handed to `onDirect` before the bounces;
     * `preview` for the direct light with every lamp a point, handed to `onDirect` before
     * that when a lamp bakes its luminous opening.
     */
    this.stage = stage;
    /** Per baked object: name, glTF origin, light maps (RGBA Float32Array, lux). */
    this.objects = raw.objects;
    /** What the glTF reader ignored or converted. */
    this.warnings = raw.warnings;
    /** The bake's report: texels, triangles, settings, per-pass seconds. */
    this.report = report;
    /** Seconds: `bake` as the bake measured itself, `total` with the transfer to and from the worker (for `direct`: until the direct light arrived). */
    this.timings = {
      bake: report.totalSeconds,
      total: wallSeconds,
      setup: report.setup,
      passes: report.passes,
    };
    if (raw.layerColors) {
      this.#layers = {
        colors: raw.layerColors.map((c) => Array.from(c)),
        states: lamps.map(lampState),
        weights: null,
        dirty: false,
        maps: raw.objects.map((o) => ({ illuminance: o.illuminance, direct: o.direct })),
      };
      /** Layered results: what the worker keeps per lamp, bytes (the page keeps 32 and the GPU 8 more per region texel). */
      this.bytesPerLamp = raw.bytesPerLamp;
      const layers = this.#layers;
      raw.objects.forEach((o, k) => {
        for (const stage of ['illuminance', 'direct']) {
          Object.defineProperty(o, stage, {
            enumerable: true,
            get: () => {
              if (layers.dirty) this.#recombine();
              return layers.maps[k][stage];
            },
          });
        }
      });
    }
  }

  /** @internal */
  _forget() {
    this.#baker = null;
  }

  /** The lamps of a layered result, in their current states (copies). */
  get lamps() {
    return this.#layers ? this.#layers.states.map((s) => ({ ...s, color: [...s.color] })) : [];
  }

  /**
   * Layered results (`room.bake({ layers: true })`): sets lamp `index`'s `multiplier` (>= 0),
   * `color` (linear RGB, each >= 0) and `on`, without a ray. The light maps `applyToThree`
   * applied follow at once (their layers are summed in the shader); `objects[k].illuminance`
   * and `direct` and `measure` follow the new state.
   */
  setLamp(index, state = {}) {
    const layers = this.#layers;
    if (!layers) throw new LuxbakeError('options', 'setLamp needs a result of room.bake({ layers: true })');
    if (!Number.isInteger(index) || index < 0 || index >= layers.states.length) {
      throw new LuxbakeError('lamp', `setLamp: lamp ${index} is not one of the ${layers.states.length} lamps of the bake`);
    }
    if (state === null || typeof state !== 'object') throw new LuxbakeError('options', 'setLamp: the state must be an object { multiplier, color, on }');
    const next = { ...layers.states[index], color: [...layers.states[index].color] };
    for (const [k, v] of Object.entries(state)) {
      if (v === undefined) continue;
      if (k === 'multiplier') {
        if (typeof v !== 'number' || !Number.isFinite(v) || v < 0) throw new LuxbakeError('lamp', `lamp ${index}: \`multiplier\` must be a finite number >= 0, got ${v}`);
        next.multiplier = v;
      } else if (k === 'color') {
        if (!(Array.isArray(v) || ArrayBuffer.isView(v)) || v.length !== 3 || !Array.from(v).every((c) => typeof c === 'number' && Number.isFinite(c) && c >= 0)) {
          throw new LuxbakeError('lamp', `lamp ${index}: \`color\` must be three finite numbers >= 0`);
        }
        next.color = Array.from(v);
      } else if (k === 'on') {
        if (typeof v !== 'boolean') throw new LuxbakeError('options', `lamp ${index}: \`on\` must be true or false`);
        next.on = v;
      } else {
        throw new LuxbakeError('options', `setLamp: unknown key \`${k}\` (expected multiplier, color, on)`);
      }
    }
    layers.states[index] = next;
    layers.dirty = true;
    if (layers.weights) layers.weights.value[index].fromArray(this.#weight(index));
  }

  /** Lamp `i`'s weight on its layer, per channel: its state over the colour it was baked in. */
  #weight(i) {
    const { states, colors } = this.#layers;
    const s = states[i];
    return s.on ? [0, 1, 2].map((c) => s.multiplier * s.color[c] / colors[i][c]) : [0, 0, 0];
  }

  /** The objects' maps from the layers in the current states. */
  #recombine() {
    const layers = this.#layers;
    const weights = layers.states.map((_, i) => this.#weight(i));
    this.objects.forEach((o, k) => {
      for (const stage of ['illuminance', 'direct']) {
        const sources = o.layers[stage];
        const out = new Float32Array(sources[0].length);
        for (let t = 0; t < out.length; t += 4) {
          let r = 0, g = 0, b = 0;
          for (let i = 0; i < sources.length; i++) {
            const w = weights[i], m = sources[i];
            r += w[0] * m[t]; g += w[1] * m[t + 1]; b += w[2] * m[t + 2];
          }
          out[t] = r; out[t + 1] = g; out[t + 2] = b; out[t + 3] = sources[0][t + 3];
        }
        layers.maps[k][stage] = out;
      }
    });
    layers.dirty = false;
  }

  /**
   * Illuminance in lux at world points (an array of [x, y, z] or a flat array of 3n numbers,
   * metres, in the glTF file's frame): a Promise of a Float64Array, NaN for a point on no baked
   * surface.
   */
  async measure(points) {
    const flat = Float64Array.from(Array.isArray(points) && Array.isArray(points[0]) ? points.flat() : points);
    if (this.stage !== 'converged') throw new LuxbakeError('measure', 'the direct light handed to onDirect has no measure: measure the bake\'s result');
    if (!this.#baker) throw new LuxbakeError('measure', 'this result was disposed, or its baker aborted a bake or was disposed');
    return this.#baker._measure(this.id, flat, this.#layers?.states);
  }

  /**
   * Puts the light maps on a three.js scene loaded from the same file: `root` is the object
   * GLTFLoader returned (`gltf`, exact matching through `gltf.parser.associations`) or an
   * Object3D (matching by name). Each matched mesh gets a clone of its material with
   * `lightMap` (half-float RGBA, lux, `channel` 1) and `lightMapIntensity` (default 1: the
   * map is illuminance E, so three.js shows radiance ρE/π); its geometry gets `uv1` (and is
   * rebuilt where the UVs were generated). The file's own punctual lights (KHR_lights_punctual)
   * under `root` are removed (`lights: 'remove'`, the default: the maps hold all of the
   * lamps' light) or kept (`lights: 'keep'`). A layered result puts one map per lamp on the
   * material and sums them in the shader, weighted as `setLamp` says. Returns
   * `{ applied, unmatched, removedLights }`.
   */
  applyToThree(root, THREE, { intensity = 1, lights = 'remove' } = {}) {
    if (!THREE || !THREE.DataTexture) throw new LuxbakeError('options', 'applyToThree needs the three.js module as its second argument');
    if (lights !== 'remove' && lights !== 'keep') throw new LuxbakeError('options', `applyToThree: \`lights\` must be 'remove' or 'keep', got ${lights}`);
    const associations = root?.parser?.associations;
    const sceneRoot = root?.scene ?? root;
    if (!sceneRoot || typeof sceneRoot.traverse !== 'function') {
      throw new LuxbakeError('options', 'applyToThree needs the GLTFLoader result or a three.js Object3D');
    }
    const layered = this.#layers;
    if (layered) {
      if (layered.states.length > MAX_SHADER_LAYERS) {
        throw new LuxbakeError('options', `applyToThree sums at most ${MAX_SHADER_LAYERS} lamps' layers in the shader; this bake has ${layered.states.length}`);
      }
      if (!THREE.ShaderChunk?.lights_fragment_maps?.includes(LIGHTMAP_READ)) {
        throw new LuxbakeError('options', 'applyToThree: this three.js version reads the light map differently from the one luxbake sums layers in (three r151 or later)');
      }
      layered.weights ??= { value: layered.states.map((_, i) => new THREE.Vector3().fromArray(this.#weight(i))) };
    }
    const meshes = [];
    const punctual = [];
    sceneRoot.traverse((o) => {
      if (o.isMesh) meshes.push(o);
      if (o.isLight && !o.isAmbientLight && !o.isHemisphereLight) punctual.push(o);
    });
    if (lights === 'remove') for (const l of punctual) l.removeFromParent();
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
      const textures = layered
        ? obj.layers.illuminance.map((map, i) => this.#texture(obj, map, `${obj.name}_lux_${i}`, THREE))
        : [this.#texture(obj, obj.illuminance, `${obj.name}_lux`, THREE)];
      const source = ud.luxbakeMaterial;
      const material = Array.isArray(source) ? source.map((m) => m.clone()) : source.clone();
      for (const m of Array.isArray(material) ? material : [material]) {
        m.lightMap = textures[0];
        m.lightMapIntensity = intensity;
        if (layered) this.#sumLayers(m, textures, layered.weights, THREE.ShaderChunk.lights_fragment_maps);
        m.needsUpdate = true;
      }
      if (mesh.material !== source) for (const m of [mesh.material].flat()) m.dispose();
      mesh.material = material;
      applied++;
    }
    return { applied, unmatched, removedLights: lights === 'remove' ? punctual.length : 0 };
  }

  /**
   * Makes `material` show the sum of the lamps' layers (`textures`, one per lamp, the first as
   * its `lightMap`) weighted by the shared uniform `weights` (one RGB weight per lamp), so that
   * `setLamp` changes a uniform and no texture.
   */
  #sumLayers(material, textures, weights, chunk) {
    const extra = textures.slice(1).map((t) => ({ value: t }));
    const sum = `vec4 lightMapTexel = vec4( luxbakeWeights[ 0 ] * texture2D( lightMap, vLightMapUv ).rgb${
      extra.map((_, i) => ` + luxbakeWeights[ ${i + 1} ] * texture2D( luxbakeLayer${i + 1}, vLightMapUv ).rgb`).join('')}, 1.0 );`;
    const declarations = [`uniform vec3 luxbakeWeights[ ${textures.length} ];`,
      ...extra.map((_, i) => `uniform sampler2D luxbakeLayer${i + 1};`)].join('\n');
    const patched = chunk.replace(LIGHTMAP_READ, sum);
    material.onBeforeCompile = (shader) => {
      shader.uniforms.luxbakeWeights = weights;
      extra.forEach((u, i) => { shader.uniforms[`luxbakeLayer${i + 1}`] = u; });
      shader.fragmentShader = `${declarations}\n${shader.fragmentShader.replace('#include <lights_fragment_maps>', patched)}`;
    };
    material.customProgramCacheKey = () => `luxbake-layers-${textures.length}`;
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

  #texture(obj, src, name, THREE) {
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
    t.name = name;
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

// ------------------------------------------------------------ the catalogue's web GLB

/** Reads an 8-bit RGBA PNG (not interlaced) into its bytes, exactly (no colour management). */
async function readPngRgba(bytes) {
  const fail = (why) => { throw new LuxbakeError('scene', `a LogLuv light map: ${why}`); };
  const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const signature = [137, 80, 78, 71, 13, 10, 26, 10];
  if (bytes.length < 8 || signature.some((b, i) => bytes[i] !== b)) fail('not a PNG');
  let width = 0, height = 0;
  const idat = [];
  for (let at = 8; at + 8 <= bytes.length;) {
    const length = view.getUint32(at);
    const type = String.fromCharCode(...bytes.subarray(at + 4, at + 8));
    if (at + 12 + length > bytes.length) fail('truncated');
    const data = bytes.subarray(at + 8, at + 8 + length);
    if (type === 'IHDR') {
      width = view.getUint32(at + 8); height = view.getUint32(at + 12);
      if (data[8] !== 8 || data[9] !== 6 || data[12] !== 0) fail('not 8-bit RGBA without interlacing');
    } else if (type === 'IDAT') {
      idat.push(data);
    } else if (type === 'IEND') {
      break;
    }
    at += 12 + length;
  }
  if (!width || !height || idat.length === 0) fail('no image data');
  const stream = new Blob(idat).stream().pipeThrough(new DecompressionStream('deflate'));
  const raw = new Uint8Array(await new Response(stream).arrayBuffer());
  const stride = 4 * width;
  if (raw.length < (stride + 1) * height) fail('truncated image data');
  const out = new Uint8Array(stride * height);
  for (let y = 0; y < height; y++) {
    const filter = raw[y * (stride + 1)];
    const line = raw.subarray(y * (stride + 1) + 1, (y + 1) * (stride + 1));
    const row = y * stride, up = row - stride;
    for (let x = 0; x < stride; x++) {
      const a = x >= 4 ? out[row + x - 4] : 0;
      const b = y > 0 ? out[up + x] : 0;
      const c = x >= 4 && y > 0 ? out[up + x - 4] : 0;
      let predicted;
      switch (filter) {
        case 0: predicted = 0; break;
        case 1: predicted = a; break;
        case 2: predicted = b; break;
        case 3: predicted = (a + b) >> 1; break;
        case 4: {
          const p = a + b - c, pa = Math.abs(p - a), pb = Math.abs(p - b), pc = Math.abs(p - c);
          predicted = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
          break;
        }
        default: fail(`unknown row filter ${filter}`);
      }
      out[row + x] = (line[x] + predicted) & 0xff;
    }
  }
  return { width, height, data: out };
}

/** CIE XYZ to linear Rec. 709 RGB: `luxbake_output::logluv::XYZ_TO_RGB`. */
const XYZ_TO_RGB = [
  [3.2406254773, -1.5372079722, -0.4986285987],
  [-0.9689307147, 1.8757560609, 0.0415175238],
  [0.0557101204, -0.2040210506, 1.0569959423],
];

/**
 * Decodes 32-bit LogLuv bytes (R, G: 256 · (log2 Y + 64) big-endian; B, A: 410 · u′, 410 · v′)
 * into linear RGB floats, alpha 1 — the rule of `luxbake_output::logluv`.
 */
function decodeLogLuv(bytes) {
  const rgba = new Float32Array(bytes.length);
  for (let i = 0; i < bytes.length; i += 4) {
    const le = (bytes[i] << 8) | bytes[i + 1];
    rgba[i + 3] = 1;
    if (le === 0 || bytes[i + 3] === 0) continue;
    const Y = 2 ** (le / 256 - 64);
    const u = bytes[i + 2] / 410, v = bytes[i + 3] / 410;
    const X = (Y * 9 * u) / (4 * v), Z = (Y * (12 - 3 * u - 20 * v)) / (4 * v);
    for (let c = 0; c < 3; c++) {
      const m = XYZ_TO_RGB[c];
      rgba[i + c] = Math.max(0, m[0] * X + m[1] * Y + m[2] * Z);
    }
  }
  return rgba;
}

/**
 * `LUXBAKE_texture_logluv`: a texture whose image is a LogLuv PNG, decoded here into a linear
 * float texture (half floats unless `type` is `THREE.FloatType`).
 */
class TextureLogLuvPlugin {
  constructor(parser, THREE, type) {
    this.name = 'LUXBAKE_texture_logluv';
    this.parser = parser;
    this.THREE = THREE;
    this.type = type;
  }

  loadTexture(textureIndex) {
    const parser = this.parser;
    const def = parser.json.textures[textureIndex];
    const ext = def.extensions?.[this.name];
    if (!ext) return null;
    const image = parser.json.images?.[ext.source];
    if (!image || image.bufferView === undefined) {
      return Promise.reject(new LuxbakeError('scene', `texture ${textureIndex}: LUXBAKE_texture_logluv needs an image in a bufferView`));
    }
    return parser.getDependency('bufferView', image.bufferView).then(async (buffer) => {
      const T = this.THREE;
      const png = await readPngRgba(new Uint8Array(buffer));
      const rgba = decodeLogLuv(png.data);
      const half = this.type !== T.FloatType;
      const data = half ? Uint16Array.from(rgba, (v) => T.DataUtils.toHalfFloat(Math.min(v, 65504))) : rgba;
      const texture = new T.DataTexture(data, png.width, png.height, T.RGBAFormat, half ? T.HalfFloatType : T.FloatType);
      texture.colorSpace = T.LinearSRGBColorSpace;
      texture.flipY = false;
      texture.magFilter = T.LinearFilter;
      texture.minFilter = T.LinearFilter;
      texture.generateMipmaps = false;
      texture.wrapS = texture.wrapT = T.ClampToEdgeWrapping;
      texture.name = def.name ?? image.name ?? '';
      texture.needsUpdate = true;
      parser.associations.set(texture, { textures: textureIndex });
      return texture;
    });
  }
}

/**
 * `MOZ_lightmap` (Mozilla Hubs): the material's light map, on the UV set `texCoord` (1, i.e.
 * `TEXCOORD_1`), scaled by `intensity`. With luxbake's maps a texel is illuminance in lux, and
 * a `MeshStandardMaterial` shades it as luminance `E · intensity · albedo / π` (cd/m²).
 */
class LightmapPlugin {
  constructor(parser) {
    this.name = 'MOZ_lightmap';
    this.parser = parser;
  }

  async extendMaterialParams(materialIndex, params) {
    const def = this.parser.json.materials[materialIndex];
    const ext = def.extensions?.[this.name];
    if (!ext) return;
    const texture = await this.parser.getDependency('texture', ext.index);
    if (!texture) {
      throw new LuxbakeError('scene', `material ${materialIndex} (${def.name ?? ''}): its MOZ_lightmap texture ${ext.index} did not load`);
    }
    texture.channel = ext.texCoord ?? 1;
    params.lightMap = texture;
    params.lightMapIntensity = ext.intensity ?? 1;
  }
}

/**
 * `EXT_lights_ies`: each lamp node gets `userData.ies = { name, text, multiplier, color }`, its
 * profile as IES LM-63 text (for three.js's `IESLoader`); no light is added, since the light
 * maps already hold the lamps' light.
 */
class LightsIesPlugin {
  constructor(parser) {
    this.name = 'EXT_lights_ies';
    this.parser = parser;
  }

  async afterRoot(gltf) {
    const json = this.parser.json;
    const lights = json.extensions?.[this.name]?.lights;
    if (!lights) return;
    const profiles = await Promise.all(lights.map(async (light) => {
      if (light.bufferView === undefined) return { name: light.name ?? '', uri: light.uri };
      const bytes = await this.parser.getDependency('bufferView', light.bufferView);
      return { name: light.name ?? '', text: new TextDecoder().decode(bytes) };
    }));
    for (const scene of gltf.scenes) {
      scene.traverse((object) => {
        const node = this.parser.associations.get(object)?.nodes;
        const ext = node === undefined ? undefined : json.nodes[node].extensions?.[this.name];
        if (!ext) return;
        const profile = profiles[ext.light];
        if (!profile) throw new LuxbakeError('scene', `node ${node}: EXT_lights_ies light ${ext.light} does not exist`);
        object.userData.ies = { ...profile, multiplier: ext.multiplier ?? 1, color: ext.color ?? [1, 1, 1] };
      });
    }
  }
}

/**
 * Registers on three.js's `GLTFLoader` what reads a catalogue row's `web.glb`: its light maps
 * (`MOZ_lightmap` naming `LUXBAKE_texture_logluv` textures, decoded into linear float
 * textures in lux) and its lamps' IES profiles (`EXT_lights_ies`). `THREE` is the three.js
 * module; `options.type` `THREE.FloatType` keeps 32-bit floats (default `THREE.HalfFloatType`,
 * filterable everywhere, up to 65504 lx). Returns the loader.
 *
 *   const loader = registerWebGLB(new GLTFLoader(), THREE);
 *   const gltf = await loader.loadAsync('out/<key>/web.glb');
 */
export function registerWebGLB(loader, THREE, { type } = {}) {
  if (!loader || typeof loader.register !== 'function') {
    throw new LuxbakeError('options', 'registerWebGLB: the first argument must be a three.js GLTFLoader');
  }
  if (!THREE || typeof THREE.DataTexture !== 'function' || !THREE.DataUtils) {
    throw new LuxbakeError('options', 'registerWebGLB: the second argument must be the three.js module');
  }
  loader.register((parser) => new TextureLogLuvPlugin(parser, THREE, type ?? THREE.HalfFloatType));
  loader.register((parser) => new LightmapPlugin(parser));
  loader.register((parser) => new LightsIesPlugin(parser));
  return loader;
}
