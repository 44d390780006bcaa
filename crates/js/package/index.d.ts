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
  | 'disposed';    // the baker was disposed

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
}

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
  /** Largest distance of a measure() point from a baked surface, metres (default 0.01). */
  measureTolerance?: number;
  onProgress?: (event: ProgressEvent) => void;
  signal?: AbortSignal;
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
  /** Illuminance (lux) at world points; NaN where a point is on no baked surface. */
  measure(points: ArrayLike<number> | [number, number, number][]): Promise<Float64Array>;
  /**
   * Puts the light maps on the meshes of a three.js scene loaded from the same file (pass the
   * GLTFLoader result for exact matching, or an Object3D to match by name): `lightMap` on
   * channel 1 (uv1), `lightMapIntensity` = `intensity` (default 1).
   */
  applyToThree(root: object, THREE: object, options?: { intensity?: number }): { applied: number; unmatched: string[] };
  /** Frees the textures made by applyToThree and the maps kept for measure. */
  dispose(): void;
}

export class Luxbake {
  /** Starts the worker and its WebGL2 context; rejects with kind 'webgl' without WebGL2. */
  static create(): Promise<Luxbake>;
  /** The GPU, as WebGL reports it. */
  readonly renderer: string;
  /** Bakes; one bake at a time (a second call waits for the first). */
  bake(options: BakeOptions): Promise<BakeResult>;
  /** Frees the worker and its WebGL2 context. */
  dispose(): void;
}
