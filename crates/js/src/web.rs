//! The wasm-bindgen interface the package's worker (`package/worker.js`) calls (wasm32 only).
//!
//! [`Baker`] owns one WebGL2 context on an `OffscreenCanvas`, the rooms the page loaded
//! ([`Baker::load`]: the glTF file read and the room's host work done once, for every bake of
//! it) and one [`GlowBackend`] for all of them: the pass programs compile once, and the
//! backend frees each bake's textures and scene when its maps are read back
//! ([`GpuBackend::release`]); after a failure that was not the request's, the context and the
//! backend are replaced. Errors
//! become JS `Error`s with `name` `LuxbakeError` and a `kind` ([`JsBakeError::kind`]). A Rust panic
//! aborts the module (wasm32 has no unwinding): the panic hook keeps its message for
//! [`take_panic`], and the worker reports it and replaces the module instead of hanging.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

use luxbake::backend::GpuBackend;
use luxbake::bake::ObjectMaps;
use luxbake::layers::{LampLayers, LampState, LayerError, bake_layers};
use luxbake::map::MapImage;
use luxbake::scene::{Scene, Settings};
use luxbake::{BakeOutput, DirectStage, Progress, ReadBack, Room};
use luxbake_backend_glow::{GlContext, GlowBackend};
use serde::Deserialize;
use serde_json::json;
use wasm_bindgen::prelude::*;
use web_sys::{OffscreenCanvas, WebGl2RenderingContext};

use crate::JsBakeError;
use crate::request::{BakeOptions, Imported, build_lamps, build_scene, import_room, measure};

thread_local! {
    static PANIC: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Keeps a panic's message for [`take_panic`] and logs it (once per module instance).
fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        std::panic::set_hook(Box::new(|info| {
            let message = format!("luxbake panicked: {info}");
            web_sys::console::error_1(&message.as_str().into());
            PANIC.with(|p| *p.borrow_mut() = Some(message));
        }));
    });
}

/// The message of the panic that aborted the module, if any (read by the worker after the
/// module trapped).
#[wasm_bindgen(js_name = takePanic)]
pub fn take_panic() -> Option<String> {
    PANIC.with(|p| p.borrow_mut().take())
}

/// A JS `Error` named `LuxbakeError` with the error's `kind`.
fn js_error(e: &JsBakeError) -> JsValue {
    let err = js_sys::Error::new(&e.to_string());
    err.set_name("LuxbakeError");
    let _ = js_sys::Reflect::set(&err, &"kind".into(), &e.kind().into());
    err.into()
}

/// The presets' names and their settings as JSON (for the page's quality picker and docs).
#[wasm_bindgen(js_name = presets)]
pub fn presets() -> String {
    use luxbake::scene::{Method, Quality, Settings};
    let describe = |s: Settings| {
        json!({"method": s.method.name(), "quality": s.quality.name(), "rays": s.rays,
               "bounces": s.bounces, "texelsPerMetre": s.texels_per_metre})
    };
    json!({
        "draft": describe(Settings::of(Method::Converged, Quality::Draft)),
        "default": describe(Settings::of(Method::Converged, Quality::Default)),
        "final": describe(Settings::of(Method::Converged, Quality::Final)),
        "paper": describe(Settings::of(Method::Paper, Quality::Default)),
    })
    .to_string()
}

/// What a finished bake keeps for `measure`.
struct Kept {
    imported: Rc<Imported>,
    maps: Vec<(usize, MapImage)>,
    /// A layered bake's layers: `measure` recombines them in the page's lamp states.
    layers: Option<LampLayers>,
    tolerance: f64,
}

/// A room the page loaded: its file (read again for another texel density or blur), the file
/// as read, and the room's host work for that import.
struct LoadedRoom {
    gltf: Vec<u8>,
    imported: Rc<Imported>,
    room: Room,
}

/// The worker's baker: a WebGL2 context on an `OffscreenCanvas`, the loaded rooms, and the
/// bakes whose results the page still holds (for `measure`).
#[wasm_bindgen]
pub struct Baker {
    canvas: OffscreenCanvas,
    renderer: String,
    kept: HashMap<u32, Kept>,
    next_id: u32,
    rooms: HashMap<u32, LoadedRoom>,
    next_room: u32,
    /// The backend of every bake on the context (taken out while a bake runs: a bake that
    /// fails drops it).
    backend: Option<GlowBackend>,
    /// For tests: lose the context (`WEBGL_lose_context`) when this pass of the next bake
    /// starts.
    lose_at_pass: Option<usize>,
}

/// Loses `canvas`'s WebGL2 context through `WEBGL_lose_context` (as a GPU reset would);
/// whether the extension was there.
fn lose_context(canvas: &OffscreenCanvas) -> bool {
    let Some(gl) = canvas
        .get_context("webgl2")
        .ok()
        .flatten()
        .and_then(|c| c.dyn_into::<WebGl2RenderingContext>().ok())
    else {
        return false;
    };
    let Ok(Some(ext)) = gl.get_extension("WEBGL_lose_context") else {
        return false;
    };
    js_sys::Reflect::get(&ext, &"loseContext".into())
        .ok()
        .and_then(|f| f.dyn_into::<js_sys::Function>().ok())
        .is_some_and(|f| f.call0(&ext).is_ok())
}

fn new_context() -> Result<(OffscreenCanvas, GlContext), JsBakeError> {
    let canvas = OffscreenCanvas::new(1, 1)
        .map_err(|e| JsBakeError::Gpu(format!("OffscreenCanvas unavailable: {e:?}")))?;
    let ctx =
        GlContext::from_offscreen_canvas(&canvas).map_err(|e| JsBakeError::Gpu(e.to_string()))?;
    Ok((canvas, ctx))
}

/// Sends a bake's progress to the page: one JSON event per set-up step and pass, `fraction`
/// of the whole bake, never decreasing.
struct Reporter<'a> {
    progress: &'a js_sys::Function,
    canvas: &'a OffscreenCanvas,
    last: f64,
    /// For tests: lose the context when this pass starts.
    lose_at: Option<usize>,
    /// A layered bake bakes `layers` times; each ends with its read-back, which counts `layer`.
    layers: usize,
    layer: usize,
}

impl Reporter<'_> {
    fn send(&mut self, mut event: serde_json::Value, fraction: f64) {
        self.last = self.last.max(fraction);
        event["fraction"] = json!(self.last);
        // A throwing progress callback must not stop the bake.
        let _ = self
            .progress
            .call1(&JsValue::NULL, &JsValue::from_str(&event.to_string()));
    }

    fn on(&mut self, p: &Progress<'_>) {
        // The passes' work is 2 % to 98 % of the whole (Progress::Work: the bounces left out
        // are never counted as work to come); a layered bake's layers share it equally.
        let layers = self.layers.max(1) as f64;
        let share = |layer: usize, f: f64| 0.02 + 0.96 * (layer as f64 + f) / layers;
        match p {
            Progress::Setup(step) => {
                self.send(json!({"phase": "setup", "step": step}), 0.0);
                if *step == "read back" {
                    self.layer += 1;
                }
            }
            Progress::PassStart {
                index,
                count,
                label,
                bounce,
            } => {
                if self.lose_at == Some(*index) {
                    lose_context(self.canvas);
                }
                self.send(
                    json!({"phase": "pass", "index": index, "count": count, "label": label,
                           "bounce": bounce}),
                    share(self.layer, 0.0),
                );
            }
            Progress::Work(f) => {
                let fraction = share(self.layer, f64::from(*f));
                self.send(json!({"phase": "work"}), fraction);
            }
            Progress::PassProgress { .. } | Progress::PassDone { .. } => {}
        }
    }
}

/// Sets `o[k] = v`.
fn set(o: &js_sys::Object, k: &str, v: JsValue) -> Result<(), JsBakeError> {
    js_sys::Reflect::set(o, &k.into(), &v)
        .map(|_| ())
        .map_err(|_| JsBakeError::Gpu("building the result object".into()))
}

/// A map as the page gets it: RGBA `Float32Array`, dilated into the chart padding.
fn f32s(img: &MapImage, passes: u32) -> JsValue {
    js_sys::Float32Array::from(img.dilated(passes).texels.as_slice()).into()
}

/// Per baked object of `maps`: `{object, name, width, height, illuminance, direct, gltf,
/// generatedUvs, uv1, indices, sourceVertex}` ([`Baker::bake`]).
fn objects_of(
    imported: &Imported,
    maps: &[ObjectMaps],
    settings: &Settings,
) -> Result<Vec<js_sys::Object>, JsBakeError> {
    let passes = luxbake_output::dilation_passes(settings);
    let mut objects = Vec::with_capacity(maps.len());
    for m in maps {
        let info = imported
            .objects
            .get(m.object)
            .ok_or_else(|| JsBakeError::Gpu(format!("object {} is not in the room", m.object)))?;
        let mesh = &imported.scene.objects[m.object].mesh;
        let o = js_sys::Object::new();
        set(&o, "object", (m.object as u32).into())?;
        set(&o, "name", m.name.as_str().into())?;
        set(&o, "width", m.region.size[0].into())?;
        set(&o, "height", m.region.size[1].into())?;
        set(&o, "illuminance", f32s(m.illuminance(), passes))?;
        set(&o, "direct", f32s(m.direct(), passes))?;
        let source = match info.gltf {
            Some(g) => {
                let s = js_sys::Object::new();
                set(&s, "node", (g.node as u32).into())?;
                set(&s, "mesh", (g.mesh as u32).into())?;
                set(&s, "primitive", (g.primitive as u32).into())?;
                s.into()
            }
            None => JsValue::NULL,
        };
        set(&o, "gltf", source)?;
        set(&o, "generatedUvs", info.generated_uvs.into())?;
        let uv1: Vec<f32> = mesh.lightmap_uvs.iter().flatten().copied().collect();
        set(&o, "uv1", js_sys::Float32Array::from(uv1.as_slice()).into())?;
        let (indices, source_vertex) = match &info.source_vertex {
            Some(sv) => {
                let idx: Vec<u32> = mesh.indices.iter().flatten().copied().collect();
                (
                    js_sys::Uint32Array::from(idx.as_slice()).into(),
                    js_sys::Uint32Array::from(sv.as_slice()).into(),
                )
            }
            None => (JsValue::NULL, JsValue::NULL),
        };
        set(&o, "indices", indices)?;
        set(&o, "sourceVertex", source_vertex)?;
        objects.push(o);
    }
    Ok(objects)
}

/// The objects as a JS array.
fn array_of(objects: Vec<js_sys::Object>) -> js_sys::Array {
    objects.into_iter().collect()
}

/// The report of a bake as JSON.
fn report_of(
    out: &BakeOutput,
    objects: usize,
    settings: &Settings,
    renderer: &str,
) -> serde_json::Value {
    let r = &out.report;
    json!({
        "backend": r.backend,
        "renderer": renderer,
        "texels": r.texels,
        "regionTexels": r.region_texels,
        "triangles": r.triangles,
        "objects": objects,
        "settings": {"method": settings.method.name(), "quality": settings.quality.name(),
                     "rays": settings.rays, "bounces": settings.bounces,
                     "texelsPerMetre": settings.texels_per_metre, "seed": settings.seed},
        "bouncesRun": r.bounces_run,
        "setup": r.setup.iter().map(|(n, s)| json!({"step": n, "seconds": s})).collect::<Vec<_>>(),
        "passes": r.passes.iter().map(|p| json!({"label": p.label, "bounce": p.bounce, "seconds": p.seconds})).collect::<Vec<_>>(),
        "skipped": r.skipped.iter().map(ToString::to_string).collect::<Vec<_>>(),
        "totalSeconds": r.total_seconds,
    })
}

/// A lamp's state as the page sends it for `measure` (`result.setLamp`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StateJson {
    multiplier: f32,
    color: [f32; 3],
    on: bool,
}

/// Lamp states from JSON (`[{multiplier, color, on}]`), checked by the layers.
fn lamp_states(json: &str) -> Result<Vec<LampState>, JsBakeError> {
    let states: Vec<StateJson> = serde_json::from_str(json)
        .map_err(|e| JsBakeError::Options(format!("lamp states: {e}")))?;
    Ok(states
        .into_iter()
        .map(|s| LampState {
            multiplier: s.multiplier,
            color: s.color,
            on: s.on,
        })
        .collect())
}

fn layer_error(e: &LayerError) -> JsBakeError {
    match e {
        LayerError::Count { .. } => JsBakeError::Options(e.to_string()),
        LayerError::State { lamp, field } => JsBakeError::Lamp {
            index: *lamp,
            name: format!("lamp_{lamp}"),
            message: format!("`{field}` must be finite and >= 0"),
        },
    }
}

/// Whether a failure was the request's (the context is fine) rather than the GPU's.
fn is_input_error(e: &JsBakeError) -> bool {
    matches!(
        e,
        JsBakeError::Options(_)
            | JsBakeError::Setting { .. }
            | JsBakeError::Lamp { .. }
            | JsBakeError::Scene(_)
            | JsBakeError::Disposed(_)
    )
}

#[wasm_bindgen]
impl Baker {
    /// Creates the context and checks it (WebGL2, `EXT_color_buffer_float`, WebGL2 limits).
    ///
    /// # Errors
    /// A `webgl` error naming what is missing.
    #[wasm_bindgen(constructor)]
    pub fn new() -> Result<Baker, JsValue> {
        install_panic_hook();
        let (canvas, ctx) = new_context().map_err(|e| js_error(&e))?;
        let caps = ctx.capabilities();
        let renderer = format!("{} ({})", caps.renderer, caps.version);
        Ok(Baker {
            canvas,
            renderer,
            kept: HashMap::new(),
            next_id: 1,
            rooms: HashMap::new(),
            backend: None,
            next_room: 1,
            lose_at_pass: None,
        })
    }

    /// The GPU's renderer and version strings.
    pub fn renderer(&self) -> String {
        self.renderer.clone()
    }

    /// Whether the baker's WebGL2 context is lost.
    #[wasm_bindgen(js_name = isContextLost)]
    pub fn is_context_lost(&self) -> bool {
        self.canvas
            .get_context("webgl2")
            .ok()
            .flatten()
            .and_then(|c| c.dyn_into::<WebGl2RenderingContext>().ok())
            .is_none_or(|gl| gl.is_context_lost())
    }

    /// For tests: the next bake loses its WebGL2 context (`WEBGL_lose_context`) when pass
    /// `pass` starts, as a GPU reset would; that bake then fails with `contextLost`.
    #[wasm_bindgen(js_name = loseContextDuringNextBake)]
    pub fn lose_context_during_next_bake(&mut self, pass: usize) {
        self.lose_at_pass = Some(pass);
    }

    /// Bakes `gltf` (GLB or glTF JSON bytes) with `options_json` ([`BakeOptions`]) and one
    /// photometric file (`Uint8Array`) per lamp in `photometry`. `progress` is called with one
    /// JSON event per set-up step and pass (`fraction` of the whole bake, non-decreasing).
    /// Returns `{id, report, warnings, objects}`: `report` a JSON string (texels, passes with
    /// seconds, total), `objects` per baked object `{object, name, width, height, illuminance,
    /// direct, gltf, generatedUvs, uv1, indices, sourceVertex}` (illuminance and direct: RGBA
    /// Float32Arrays in lux, row 0 first, alpha 1 on baked texels, dilated into the chart
    /// padding; `uv1` the light-map UVs per vertex; `indices` and `sourceVertex` only for
    /// generated UVs). `id` names the bake for [`Baker::measure`] until [`Baker::release`].
    ///
    /// After a failure the context is replaced, so that a lost context does not stop the next
    /// bake.
    ///
    /// # Errors
    /// A `LuxbakeError` ([`JsBakeError`]).
    pub fn bake(
        &mut self,
        gltf: &[u8],
        options_json: &str,
        photometry: &js_sys::Array,
        progress: &js_sys::Function,
    ) -> Result<JsValue, JsValue> {
        let result = self.bake_inner(gltf, options_json, photometry, progress);
        self.settle(result)
    }

    /// Reads `gltf` (GLB or glTF JSON bytes) as a room and does its host work (layout,
    /// G-buffer, BVH, unocclusion) for the settings of `options_json` ([`BakeOptions`]
    /// without lamps), once for every [`Baker::bake_room`] of it. `progress` as for
    /// [`Baker::bake`]. Returns `{room, warnings, objects, texels, seconds}`.
    ///
    /// # Errors
    /// A `LuxbakeError` ([`JsBakeError`]): `options` when `lamps` are given.
    pub fn load(
        &mut self,
        gltf: Vec<u8>,
        options_json: &str,
        progress: &js_sys::Function,
    ) -> Result<JsValue, JsValue> {
        let result = self.load_inner(gltf, options_json, progress);
        self.settle(result)
    }

    /// Bakes loaded room `room` lit by the lamps of `options_json` (one photometric file per
    /// lamp in `photometry`), with its settings ([`BakeOptions`]): only the lamps' work and
    /// the passes run, unless the settings ask for another texel density or blur, which reads
    /// the file again and redoes the room's host work. Returns what [`Baker::bake`] returns.
    ///
    /// `direct`, when given, is called once with `{objects}` ([`Baker::bake`]'s objects with
    /// the blurred direct light as both `illuminance` and `direct`) before the bounces run.
    /// With `layers` each lamp is baked alone ([`luxbake::layers::bake_layers`]): the result
    /// then also has per object `layers: {illuminance: [...], direct: [...]}` (one map per
    /// lamp, at multiplier 1 in `layerColors[i]`), `layerColors`, and `bytesPerLamp` (what the
    /// worker keeps per lamp); `objects` hold the lamps as the options set them, and
    /// [`Baker::measure`] recombines the layers in the states it is given. `direct` is not
    /// called for a layered bake.
    ///
    /// # Errors
    /// A `LuxbakeError` ([`JsBakeError`]); `disposed` for a room that is not (or no longer)
    /// loaded.
    #[wasm_bindgen(js_name = bakeRoom)]
    pub fn bake_room(
        &mut self,
        room: u32,
        options_json: &str,
        photometry: &js_sys::Array,
        progress: &js_sys::Function,
        direct: Option<js_sys::Function>,
        layers: bool,
    ) -> Result<JsValue, JsValue> {
        let result = self.bake_room_inner(
            room,
            options_json,
            photometry,
            progress,
            direct.as_ref(),
            layers,
        );
        self.settle(result)
    }

    /// Frees loaded room `room` (its results keep what `measure` needs).
    #[wasm_bindgen(js_name = disposeRoom)]
    pub fn dispose_room(&mut self, room: u32) {
        self.rooms.remove(&room);
        if let Some(backend) = &mut self.backend {
            // The room's gather hits go with it (GPU memory); a lost context frees them anyway.
            let _ = backend.free_dropped_hits();
        }
    }

    /// Illuminance (lux) at world points `xyz` (`3n` numbers, metres) of bake `id`
    /// ([`crate::request::measure`]; NaN for a point on no baked surface). For a layered bake,
    /// `states_json` (`[{multiplier, color, on}]`, one per lamp) recombines the layers first
    /// ([`LampLayers::combine`]).
    ///
    /// # Errors
    /// An unknown or released bake, or malformed points (`measure`); states for a bake
    /// without layers (`options`), of the wrong count (`options`) or out of range (`lamp`).
    pub fn measure(
        &self,
        id: u32,
        xyz: &[f64],
        states_json: Option<String>,
    ) -> Result<Vec<f64>, JsValue> {
        self.measure_inner(id, xyz, states_json.as_deref())
            .map_err(|e| js_error(&e))
    }

    /// Frees what bake `id` kept for [`Baker::measure`].
    pub fn release(&mut self, id: u32) {
        self.kept.remove(&id);
    }
}

impl Baker {
    /// After a failure that was not the request's, replaces the context, so that a lost
    /// context does not stop the next bake; turns the error into a JS `LuxbakeError`.
    fn settle(&mut self, result: Result<JsValue, JsBakeError>) -> Result<JsValue, JsValue> {
        let result = match result {
            Err(e) if !is_input_error(&e) => {
                let lost = self.is_context_lost();
                if let Ok((canvas, _)) = new_context() {
                    self.canvas = canvas;
                }
                self.backend = None;
                Err(if lost { JsBakeError::ContextLost } else { e })
            }
            other => other,
        };
        result.map_err(|e| js_error(&e))
    }

    /// The baker's backend, taken out for one bake (put it back with
    /// `self.backend = Some(..)` when the bake succeeded), or a new one on the context.
    fn backend(&mut self) -> Result<GlowBackend, JsBakeError> {
        if let Some(backend) = self.backend.take() {
            return Ok(backend);
        }
        let ctx = GlContext::from_offscreen_canvas(&self.canvas)
            .map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        GlowBackend::new(ctx).map_err(|e| JsBakeError::Gpu(e.to_string()))
    }

    fn reporter<'a>(&'a mut self, progress: &'a js_sys::Function, layers: usize) -> Reporter<'a> {
        Reporter {
            progress,
            canvas: &self.canvas,
            last: 0.0,
            lose_at: self.lose_at_pass.take(),
            layers,
            layer: 0,
        }
    }

    /// Keeps a finished bake for `measure` and returns `{id, report, warnings, objects}`.
    fn finish(
        &mut self,
        imported: Rc<Imported>,
        out: &BakeOutput,
        objects: Vec<js_sys::Object>,
        report: &serde_json::Value,
        tolerance: f64,
        layers: Option<LampLayers>,
    ) -> Result<js_sys::Object, JsBakeError> {
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1).max(1);
        let warnings = js_sys::Array::new();
        for w in &imported.warnings {
            warnings.push(&w.as_str().into());
        }
        let result = js_sys::Object::new();
        set(&result, "id", id.into())?;
        set(&result, "report", report.to_string().into())?;
        set(&result, "warnings", warnings.into())?;
        set(&result, "objects", array_of(objects).into())?;
        let maps = out
            .maps
            .iter()
            .map(|m| (m.object, m.illuminance().clone()))
            .collect();
        self.kept.insert(
            id,
            Kept {
                imported,
                maps,
                layers,
                tolerance,
            },
        );
        Ok(result)
    }

    fn bake_inner(
        &mut self,
        gltf: &[u8],
        options_json: &str,
        photometry: &js_sys::Array,
        progress: &js_sys::Function,
    ) -> Result<JsValue, JsBakeError> {
        let options = BakeOptions::from_json(options_json)?;
        let files = bytes_of(photometry);
        let refs: Vec<&[u8]> = files.iter().map(Vec::as_slice).collect();
        let built = build_scene(gltf, &options, &refs)?;
        let mut backend = self.backend()?;
        let scene = &built.scene;
        let mut reporter = self.reporter(progress, 1);
        let out = luxbake::bake(&mut backend, scene, &scene.settings, &mut |p| {
            reporter.on(p);
        })
        .map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        self.backend = Some(backend);
        let settings = scene.settings.clone();
        let report = report_of(&out, scene.objects.len(), &settings, &self.renderer);
        let imported = Rc::new(Imported {
            scene: built.scene,
            objects: built.objects,
            warnings: built.warnings,
        });
        if self.is_context_lost() {
            return Err(JsBakeError::ContextLost);
        }
        let objects = objects_of(&imported, &out.maps, &settings)?;
        let tolerance = options.measure_tolerance.unwrap_or(0.01);
        let result = self.finish(imported, &out, objects, &report, tolerance, None)?;
        Ok(result.into())
    }

    fn load_inner(
        &mut self,
        gltf: Vec<u8>,
        options_json: &str,
        progress: &js_sys::Function,
    ) -> Result<JsValue, JsBakeError> {
        let options = BakeOptions::from_json(options_json)?;
        if !options.lamps.is_empty() {
            return Err(JsBakeError::Options(
                "`load` takes the room only: give the lamps to `room.bake`".into(),
            ));
        }
        let settings = options.settings()?;
        let imported = Rc::new(import_room(&gltf, &settings)?);
        let backend = self.backend()?;
        let limits = backend.limits();
        self.backend = Some(backend);
        let mut reporter = self.reporter(progress, 1);
        let room = Room::prepare(&imported.scene, &settings, limits, &mut |p| reporter.on(p))
            .map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        let id = self.next_room;
        self.next_room = self.next_room.wrapping_add(1).max(1);
        let result = js_sys::Object::new();
        set(&result, "room", id.into())?;
        let warnings = js_sys::Array::new();
        for w in &imported.warnings {
            warnings.push(&w.as_str().into());
        }
        set(&result, "warnings", warnings.into())?;
        set(&result, "objects", (imported.objects.len() as u32).into())?;
        set(&result, "texels", (room.valid_texels as f64).into())?;
        let seconds: f64 = room.timings.iter().map(|(_, s)| s).sum();
        set(&result, "seconds", seconds.into())?;
        self.rooms.insert(
            id,
            LoadedRoom {
                gltf,
                imported,
                room,
            },
        );
        Ok(result.into())
    }

    fn bake_room_inner(
        &mut self,
        room: u32,
        options_json: &str,
        photometry: &js_sys::Array,
        progress: &js_sys::Function,
        direct: Option<&js_sys::Function>,
        layered: bool,
    ) -> Result<JsValue, JsBakeError> {
        let options = BakeOptions::from_json(options_json)?;
        let settings = options.settings()?;
        let files = bytes_of(photometry);
        let refs: Vec<&[u8]> = files.iter().map(Vec::as_slice).collect();
        let lamps = build_lamps(&options, &refs)?;
        let mut backend = self.backend()?;
        if backend.gather_hit_stats().is_none() {
            // A room is baked again and again: its gather rays' hits are kept for the next
            // bake (a lamp swap reads them instead of tracing).
            backend
                .keep_gather_hits(luxbake_backend_glow::WEB_GATHER_HITS_BUDGET)
                .map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        }
        let limits = backend.limits();
        let Some(mut loaded) = self.rooms.remove(&room) else {
            return Err(JsBakeError::Disposed(format!(
                "room {room} was disposed (or its worker was replaced): load it again"
            )));
        };
        let renderer = self.renderer.clone();
        let mut reporter = self.reporter(progress, if layered { lamps.len() } else { 1 });
        let mut on_progress = |p: &Progress<'_>| reporter.on(p);
        // Another density or blur: read the file again and redo the room's host work.
        let mut prepared = Vec::new();
        // The file as read and its room change together, or not at all.
        let ready = (|| {
            if !loaded.imported.fits(&settings) {
                let imported = Rc::new(import_room(&loaded.gltf, &settings)?);
                let room = prepare(&imported.scene, &settings, limits, &mut on_progress)?;
                (loaded.imported, loaded.room) = (imported, room);
                prepared.clone_from(&loaded.room.timings);
            } else if loaded.room.check(&settings, limits).is_err() {
                loaded.room = prepare(&loaded.imported.scene, &settings, limits, &mut on_progress)?;
                prepared.clone_from(&loaded.room.timings);
            }
            Ok::<_, JsBakeError>(())
        })();
        let imported = Rc::clone(&loaded.imported);
        let baked = ready.and_then(|()| {
            let gpu = |e: luxbake::BakeError<_>| JsBakeError::Gpu(e.to_string());
            let (room, on_progress) = (&loaded.room, &mut on_progress);
            if layered {
                let layers =
                    bake_layers(&mut backend, room, &lamps, &settings, on_progress).map_err(gpu)?;
                let states: Vec<LampState> = lamps.iter().map(LampState::of).collect();
                let out = layers.combine(&states).map_err(|e| layer_error(&e))?;
                return Ok((out, Some(layers)));
            }
            // Without a `direct` callback the direct light is not read back early. The page
            // shows the illuminance and the direct light: only those stages come back.
            let mut sent = Ok(());
            let mut on_direct = |stage: DirectStage, maps: &[ObjectMaps]| {
                // A preview that could not be sent keeps its error (and nothing follows).
                if let Some(direct) = &direct
                    && sent.is_ok()
                {
                    sent = objects_of(&imported, maps, &settings).map(|objects| {
                        let event = js_sys::Object::new();
                        let _ = set(&event, "objects", array_of(objects).into());
                        let _ = set(&event, "stage", stage.name().into());
                        // A throwing callback must not stop the bake.
                        let _ = direct.call1(&JsValue::NULL, &event);
                    });
                }
            };
            let out = luxbake::bake_room_reading(
                &mut backend,
                room,
                &lamps,
                &settings,
                ReadBack::LIGHT,
                on_progress,
                direct
                    .is_some()
                    .then_some(&mut on_direct as &mut dyn FnMut(DirectStage, &[ObjectMaps])),
            )
            .map_err(gpu)?;
            sent?;
            Ok((out, None))
        });
        // The room stays loaded whatever the bake did; the backend serves the next bake if
        // this one succeeded.
        self.rooms.insert(room, loaded);
        if baked.is_ok() {
            self.backend = Some(backend);
        }
        let (mut out, layers) = baked?;
        // This bake prepared the room again: its host steps come first.
        let r = &mut out.report;
        r.total_seconds += prepared.iter().map(|(_, s)| s).sum::<f64>();
        r.setup.splice(0..0, prepared.iter().copied());
        let mut report = report_of(&out, imported.objects.len(), &settings, &renderer);
        report["roomPrepared"] = json!(!prepared.is_empty());
        if self.is_context_lost() {
            return Err(JsBakeError::ContextLost);
        }
        let objects = objects_of(&imported, &out.maps, &settings)?;
        let tolerance = options.measure_tolerance.unwrap_or(0.01);
        let Some(layers) = layers else {
            let result = self.finish(imported, &out, objects, &report, tolerance, None)?;
            return Ok(result.into());
        };
        // Per object, each lamp's maps alone (the page sums them as `setLamp` says).
        let passes = luxbake_output::dilation_passes(&settings);
        for (k, o) in objects.iter().enumerate() {
            let (illuminance, direct) = (js_sys::Array::new(), js_sys::Array::new());
            for layer in &layers.layers {
                let m = layer
                    .maps
                    .get(k)
                    .ok_or_else(|| JsBakeError::Gpu(format!("a layer lacks object {k}")))?;
                illuminance.push(&f32s(m.illuminance(), passes));
                direct.push(&f32s(m.direct(), passes));
            }
            let l = js_sys::Object::new();
            set(&l, "illuminance", illuminance.into())?;
            set(&l, "direct", direct.into())?;
            set(o, "layers", l.into())?;
        }
        let colors: js_sys::Array = layers
            .colors
            .iter()
            .map(|c| JsValue::from(js_sys::Float32Array::from(c.as_slice())))
            .collect();
        let bytes = layers.bytes_per_lamp();
        let result = self.finish(imported, &out, objects, &report, tolerance, Some(layers))?;
        set(&result, "layerColors", colors.into())?;
        set(&result, "bytesPerLamp", (bytes as f64).into())?;
        Ok(result.into())
    }

    fn measure_inner(
        &self,
        id: u32,
        xyz: &[f64],
        states_json: Option<&str>,
    ) -> Result<Vec<f64>, JsBakeError> {
        let kept = self.kept.get(&id).ok_or_else(|| {
            JsBakeError::Measure(format!(
                "bake {id} was released (or aborted): its maps are gone"
            ))
        })?;
        let scene: &Scene = &kept.imported.scene;
        match (states_json, &kept.layers) {
            (None, _) => {
                let maps: Vec<(usize, &MapImage)> =
                    kept.maps.iter().map(|(o, m)| (*o, m)).collect();
                measure(scene, &maps, xyz, kept.tolerance)
            }
            (Some(json), Some(layers)) => {
                let out = layers
                    .combine(&lamp_states(json)?)
                    .map_err(|e| layer_error(&e))?;
                let maps: Vec<(usize, &MapImage)> = out
                    .maps
                    .iter()
                    .map(|m| (m.object, m.illuminance()))
                    .collect();
                measure(scene, &maps, xyz, kept.tolerance)
            }
            (Some(_), None) => Err(JsBakeError::Options(
                "lamp states need a bake with `layers: true`".into(),
            )),
        }
    }
}

/// The photometric files the page sent (`Uint8Array`s).
fn bytes_of(photometry: &js_sys::Array) -> Vec<Vec<u8>> {
    photometry
        .iter()
        .map(|v| js_sys::Uint8Array::new(&v).to_vec())
        .collect()
}

/// [`Room::prepare`], its errors as the bake's.
fn prepare(
    scene: &Scene,
    settings: &Settings,
    limits: luxbake::backend::Limits,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<Room, JsBakeError> {
    Room::prepare(scene, settings, limits, progress).map_err(|e| JsBakeError::Gpu(e.to_string()))
}
