// Type declarations of the luxbake package (ES module).

/** What a LuxbakeError is about. */
export type LuxbakeErrorKind =
  | 'options'      // malformed options, unknown key, wrong type
  | 'setting'      // a setting out of range (same limits as the CLI); the message names it
  | 'lamp'         // a lamp out of range, or its IES/EULUMDAT file does not parse (the message names the line)
  | 'scene'        // the glTF/GLB file is rejected (the message names the accessor, node or part)
  | 'webgl'        // no WebGL2, a missing extension, or a GPU failure
  | 'contextLost'  // the WebGL2 context was lost during the bake
  | 'aborted'      // the AbortSignal fired
  | 'measure'      // malformed points, or the result's maps are gone
  | 'worker'       // the worker could not start
  | 'internal'     // a bug (the worker is replaced; please report it)
  | 'disposed';    // the baker or the room was disposed

/** The error every promise of this package rejects with. */
export class LuxbakeError extends Error {
  readonly name: 'LuxbakeError';
  readonly kind: LuxbakeErrorKind;
  constructor(kind: LuxbakeErrorKind, message: string);
}

export type Quality = 'draft' | 'default' | 'final';
export type Method = 'converged' | 'paper';
export declare const QUALITIES: readonly Quality[];
export declare const METHODS: readonly Method[];

/** A lamp: its photometric file and where it hangs (metres, in the glTF file's frame, +Y up). */
export interface Lamp {
  /** The IES LM-63 or EULUMDAT file (text or bytes). */
  photometry: string | ArrayBuffer | ArrayBufferView;
  /** Photometric centre, metres. */
  position: [number, number, number];
  /** Direction of the photometric nadir; default straight down [0, -1, 0]. */
  aim?: [number, number, number];
  /** Turn of the C0 plane about the aim axis, degrees. */
  rotation?: number;
  /** Dimmer: scalar on every intensity (default 1, >= 0). */
  multiplier?: number;
  /** Linear RGB tint (default [1, 1, 1]). */
  color?: [number, number, number];
  /** Name for reports and errors (default `lamp_<index>`). */
  name?: string;
  /** How it emits: 'auto' (its file's luminous opening where a surface is near enough for the point model to be off by more than 1 %), 'point' or 'area' (default: the options' `lampModel`, else 'auto'). */
  lampModel?: LampModel;
}

/** How a lamp emits: from a point, from its file's luminous opening, or whichever the scene needs. */
export type LampModel = 'auto' | 'point' | 'area';

/** Progress of a bake; `fraction` never decreases and the last event has fraction 1. */
export interface ProgressEvent {
  phase: 'setup' | 'pass' | 'work' | 'done';
  fraction: number;
  step?: string;
  label?: string;
  index?: number;
  count?: number;
  bounce?: number;
}

/** What to bake. Settings not given take the preset's values (the CLI's). */
export interface BakeOptions {
  /** The glTF (data-URI buffers) or GLB file. Light-map UVs (TEXCOORD_1) are generated when missing. */
  scene: ArrayBuffer | ArrayBufferView;
  lamps: Lamp[];
  /** The converged method's preset (default 'default'). */
  quality?: Quality;
  /** 'converged' (default) or 'paper' (the paper's pipeline). */
  method?: Method;
  rays?: number;
  /** Indirect bounces; 0 = direct light only. Converged: exactly this many unless `tail` is true. */
  bounces?: number;
  /** Converged: after the bounces, add the extrapolated rest of the inter-reflection series (then `bounces` is a cap). Default: the preset's (true), false when `bounces` is given. */
  tail?: boolean;
  /** Blur sigma in texels, 0 = none. */
  blurSigma?: number;
  texelsPerMetre?: number;
  seed?: number;
  /** Converged: lamp paths per texel of the first bounce (default: the preset's; 0 = none). */
  lampPaths?: number;
  /** Converged: rays per texel in a narrow gap (a bookcase's back near a wall) in the first two bounces, half as many in each after, whatever its noise; a bounce that gathers fewer there adds the rest (default: the preset's, 64 at 'default', 256 at 'final', 0 = none at 'draft'). */
  narrowRays?: number;
  /** Converged: the denoiser's bias correction (default: the preset's, true at 'default' and 'final'): its residual filtered once more and added back. */
  denoiseCorrection?: boolean;
  /** Converged: the first bounce evaluates the lamps' direct light at each gather ray's hit instead of reading the direct light map there (default: the preset's, true at 'final'). */
  directAtHits?: boolean;
  /** Points of a lamp's luminous opening per texel near it (default: the preset's, 48 at 'default'). */
  openingSamples?: number;
  /** Opening points per visibility probe: a texel first casts the shadow rays of every Nth point and,
   * when all of them reach the opening, takes the others as seen (default 4; 0 or 1: every point casts its ray). */
  openingProbeStride?: number;
  /** The lamp model of every lamp without its own `lampModel` (default 'auto'). */
  lampModel?: LampModel;
  /** Largest distance of a measure() point from a baked surface, metres (default 0.01). */
  measureTolerance?: number;
  onProgress?: (event: ProgressEvent) => void;
  signal?: AbortSignal;
}

/** What a room is read with (`baker.load`): the settings its bakes start from. */
export type LoadOptions = Omit<BakeOptions, 'lamps'>;

/** What a room is baked with (`room.bake`): the lamps and settings over the load's. */
export interface RoomBakeOptions extends Omit<BakeOptions, 'scene'> {
  /** Called with the blurred direct light (a BakeResult with `stage` 'direct', for applyToThree; no measure) before the bounces run; when a lamp bakes its luminous opening, first with a preview (`stage` 'preview': every lamp a point, one shadow ray a texel). Not with `layers`. */
  onDirect?: (direct: BakeResult) => void;
  /** Bake each lamp alone, so that `result.setLamp` dims, tints or switches it without a ray (costs one bake per lamp, and memory per lamp: see `bytesPerLamp`). */
  layers?: boolean;
}

/** A lamp's state in a layered result. */
export interface LampState {
  /** Dimmer (>= 0). */
  multiplier: number;
  /** Linear RGB tint (each >= 0). */
  color: [number, number, number];
  /** Switched on. */
  on: boolean;
}

/** One baked object's light maps. */
export interface BakedObject {
  /** Index of the object in the bake. */
  object: number;
  /** Part name from the file (node name, `.i` for the i-th primitive of a multi-primitive mesh). */
  name: string;
  width: number;
  height: number;
  /** Illuminance (direct + indirect), lux, RGBA, row 0 first (v = 0), alpha 1 on baked texels; dilated into the chart padding. */
  illuminance: Float32Array;
  /** Direct illuminance, lux, same layout. */
  direct: Float32Array;
  /** Where in the glTF file the object came from (null for none). */
  gltf: { node: number; mesh: number; primitive: number } | null;
  /** Whether the light-map UVs were generated (the file had no usable TEXCOORD_1). */
  generatedUvs: boolean;
  /** Light-map UVs, two per vertex. */
  uv1: Float32Array;
  /** For generated UVs: triangle indices of the new vertices, and the file vertex each one copies. */
  indices: Uint32Array | null;
  sourceVertex: Uint32Array | null;
  /** Layered results: per lamp, its maps alone at multiplier 1 (in `BakeResult.layerColors`). */
  layers?: { illuminance: Float32Array[]; direct: Float32Array[] };
}

export interface BakeTimings {
  /** Seconds the bake took in the worker. */
  bake: number;
  /** Seconds from bake() to the result, with the transfers. */
  total: number;
  setup: { step: string; seconds: number }[];
  passes: { label: string; bounce: number; seconds: number }[];
}

export class BakeResult {
  readonly objects: BakedObject[];
  readonly warnings: string[];
  readonly timings: BakeTimings;
  readonly report: Record<string, unknown>;
  /** 'converged'; 'direct' for the direct light handed to `onDirect`; 'preview' for the preview of it (every lamp a point) handed before when a lamp bakes its luminous opening. */
  readonly stage: 'converged' | 'direct' | 'preview';
  /** Layered results: the lamps in their current states. */
  readonly lamps: LampState[];
  /** Layered results: bytes the worker keeps per lamp (the page keeps 32 and the GPU 8 more per region texel). */
  readonly bytesPerLamp?: number;
  /** Illuminance (lux) at world points; NaN where a point is on no baked surface. Rejects ('measure') for a 'direct' result. */
  measure(points: ArrayLike<number> | [number, number, number][]): Promise<Float64Array>;
  /**
   * Layered results: sets lamp `index`'s state without a ray; what applyToThree applied, the
   * objects' maps and measure follow. Throws 'lamp' for an index out of range or a negative
   * or non-finite value, 'options' for a result without layers or an unknown key.
   */
  setLamp(index: number, state: Partial<LampState>): void;
  /**
   * Puts the light maps on the meshes of a three.js scene loaded from the same file (pass the
   * GLTFLoader result for exact matching, or an Object3D to match by name): `lightMap` on
   * channel 1 (uv1), `lightMapIntensity` = `intensity` (default 1). `lights`: the file's own
   * punctual lights under `root` are removed ('remove', the default) or kept ('keep').
   */
  applyToThree(root: object, THREE: object, options?: { intensity?: number; lights?: 'remove' | 'keep' }): { applied: number; unmatched: string[]; removedLights: number };
  /** Frees the textures made by applyToThree and the maps kept for measure. */
  dispose(): void;
}

/** A room read once: its layout, G-buffer and BVH stay in the worker for every bake of it. */
export class Room {
  /** What the glTF reader ignored or converted. */
  readonly warnings: string[];
  /** Objects read from the file. */
  readonly objects: number;
  /** Light-map texels. */
  readonly texels: number;
  /** Seconds the room's host work took. */
  readonly seconds: number;
  /** Bakes the room lit by `options.lamps`; one bake at a time per baker. */
  bake(options: RoomBakeOptions): Promise<BakeResult>;
  /** Frees the room; later bakes reject with 'disposed'. */
  dispose(): void;
}

export class Luxbake {
  /** Starts the worker and its WebGL2 context; rejects with kind 'webgl' without WebGL2. */
  static create(): Promise<Luxbake>;
  /** The GPU, as WebGL reports it. */
  readonly renderer: string;
  /** Bakes; one bake at a time (a second call waits for the first). */
  bake(options: BakeOptions): Promise<BakeResult>;
  /** Reads a room once for many bakes (a lamp swap re-bakes only the lamps' part). */
  load(options: LoadOptions): Promise<Room>;
  /** Frees the worker and its WebGL2 context. */
  dispose(): void;
}

/**
 * ACES filmic tone mapping with the exposure that shows a surface of `albedo` (default 0.5)
 * lit by `lux` at `key` (default 0.8) before tone mapping; returns the exposure.
 */
export function setExposure(renderer: object, THREE: object, lux: number, options?: { albedo?: number; key?: number }): number;

/** A lamp's `EXT_lights_ies` profile, as `registerWebGLB` puts it in the lamp node's `userData.ies`. */
export interface IesProfile {
  name: string;
  /** The profile as IES LM-63 text (a bufferView of the GLB), or... */
  text?: string;
  /** ...its URI when the file names one. */
  uri?: string;
  multiplier: number;
  /** Linear RGB in [0, 1]. */
  color: [number, number, number];
}

/**
 * Registers on three.js's `GLTFLoader` the plugins that read a catalogue row's `web.glb`:
 * `MOZ_lightmap` (light map on `TEXCOORD_1`, lux), `LUXBAKE_texture_logluv` (LogLuv PNGs,
 * decoded into linear float textures: half floats, or 32-bit with `type: THREE.FloatType`) and
 * `EXT_lights_ies` (`userData.ies` on lamp nodes). `THREE` is the three.js module. Returns the
 * loader.
 */
export function registerWebGLB<L extends { register(callback: (parser: any) => unknown): unknown }>(loader: L, THREE: object, options?: { type?: number }): L;
