//! The wasm-bindgen interface the package's worker (`package/worker.js`) calls (wasm32 only).
//!
//! [`Baker`] owns one WebGL2 context on an `OffscreenCanvas` and a fresh
//! [`GlowBackend`] per bake (dropping it frees every texture of the bake). Errors become JS
//! `Error`s with `name` `LuxbakeError` and a `kind` ([`JsBakeError::kind`]). A Rust panic
//! aborts the module (wasm32 has no unwinding): the panic hook keeps its message for
//! [`take_panic`], and the worker reports it and replaces the module instead of hanging.

use std::cell::RefCell;
use std::collections::HashMap;

use luxbake::Progress;
use luxbake::map::MapImage;
use luxbake::scene::Scene;
use luxbake_backend_glow::{GlContext, GlowBackend};
use serde_json::json;
use wasm_bindgen::prelude::*;
use web_sys::{OffscreenCanvas, WebGl2RenderingContext};

use crate::JsBakeError;
use crate::request::{BakeOptions, build_scene, measure};

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
    scene: Scene,
    maps: Vec<(usize, MapImage)>,
    tolerance: f64,
}

/// The worker's baker: a WebGL2 context on an `OffscreenCanvas`, and the bakes whose results
/// the page still holds (for `measure`).
#[wasm_bindgen]
pub struct Baker {
    canvas: OffscreenCanvas,
    renderer: String,
    kept: HashMap<u32, Kept>,
    next_id: u32,
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
        let result = match result {
            Err(e)
                if !matches!(
                    e,
                    JsBakeError::Options(_)
                        | JsBakeError::Setting { .. }
                        | JsBakeError::Lamp { .. }
                        | JsBakeError::Scene(_)
                ) =>
            {
                let lost = self.is_context_lost();
                if let Ok((canvas, _)) = new_context() {
                    self.canvas = canvas;
                }
                Err(if lost { JsBakeError::ContextLost } else { e })
            }
            other => other,
        };
        result.map_err(|e| js_error(&e))
    }

    fn bake_inner(
        &mut self,
        gltf: &[u8],
        options_json: &str,
        photometry: &js_sys::Array,
        progress: &js_sys::Function,
    ) -> Result<JsValue, JsBakeError> {
        let options = BakeOptions::from_json(options_json)?;
        let files: Vec<Vec<u8>> = photometry
            .iter()
            .map(|v| js_sys::Uint8Array::new(&v).to_vec())
            .collect();
        let refs: Vec<&[u8]> = files.iter().map(Vec::as_slice).collect();
        let built = build_scene(gltf, &options, &refs)?;
        let scene = &built.scene;
        let ctx = GlContext::from_offscreen_canvas(&self.canvas)
            .map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        let mut backend = GlowBackend::new(ctx).map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        let mut last = 0.0f64;
        let lose_at = self.lose_at_pass.take();
        let canvas = &self.canvas;
        let mut send = |mut event: serde_json::Value, fraction: f64| {
            last = last.max(fraction);
            event["fraction"] = json!(last);
            // A throwing progress callback must not stop the bake.
            let _ = progress.call1(&JsValue::NULL, &JsValue::from_str(&event.to_string()));
        };
        let mut on_progress = |p: &Progress<'_>| match p {
            // The passes' work is 2 % to 98 % of the whole (Progress::Work: the bounces
            // left out are never counted as work to come).
            Progress::Setup(step) => send(json!({"phase": "setup", "step": step}), 0.0),
            Progress::PassStart {
                index,
                count,
                label,
                bounce,
            } => {
                if lose_at == Some(*index) {
                    lose_context(canvas);
                }
                send(
                    json!({"phase": "pass", "index": index, "count": count, "label": label,
                           "bounce": bounce}),
                    0.02,
                );
            }
            Progress::Work(f) => send(json!({"phase": "work"}), 0.02 + 0.96 * f64::from(*f)),
            Progress::PassProgress { .. } | Progress::PassDone { .. } => {}
        };
        let out = luxbake::bake(&mut backend, scene, &scene.settings, &mut on_progress)
            .map_err(|e| JsBakeError::Gpu(e.to_string()))?;
        drop(backend);
        if self.is_context_lost() {
            return Err(JsBakeError::ContextLost);
        }
        let r = &out.report;
        let report = json!({
            "backend": r.backend,
            "renderer": self.renderer,
            "texels": r.texels,
            "triangles": r.triangles,
            "objects": scene.objects.len(),
            "settings": {"method": scene.settings.method.name(), "quality": scene.settings.quality.name(),
                         "rays": scene.settings.rays, "bounces": scene.settings.bounces,
                         "texelsPerMetre": scene.settings.texels_per_metre, "seed": scene.settings.seed},
            "bouncesRun": r.bounces_run,
            "setup": r.setup.iter().map(|(n, s)| json!({"step": n, "seconds": s})).collect::<Vec<_>>(),
            "passes": r.passes.iter().map(|p| json!({"label": p.label, "bounce": p.bounce, "seconds": p.seconds})).collect::<Vec<_>>(),
            "skipped": r.skipped.iter().map(ToString::to_string).collect::<Vec<_>>(),
            "totalSeconds": r.total_seconds,
        });
        let passes = luxbake_output::dilation_passes(&scene.settings);
        let objects = js_sys::Array::new();
        let set = |o: &js_sys::Object, k: &str, v: JsValue| {
            js_sys::Reflect::set(o, &k.into(), &v)
                .map(|_| ())
                .map_err(|_| JsBakeError::Gpu("building the result object".into()))
        };
        for m in &out.maps {
            let info = &built.objects[m.object];
            let mesh = &scene.objects[m.object].mesh;
            let o = js_sys::Object::new();
            let f32s = |img: &MapImage| {
                JsValue::from(js_sys::Float32Array::from(
                    img.dilated(passes).texels.as_slice(),
                ))
            };
            set(&o, "object", (m.object as u32).into())?;
            set(&o, "name", m.name.as_str().into())?;
            set(&o, "width", m.region.size[0].into())?;
            set(&o, "height", m.region.size[1].into())?;
            set(&o, "illuminance", f32s(m.illuminance()))?;
            set(&o, "direct", f32s(m.direct()))?;
            let source = info.gltf.map_or(JsValue::NULL, |g| {
                let s = js_sys::Object::new();
                let _ = set(&s, "node", (g.node as u32).into());
                let _ = set(&s, "mesh", (g.mesh as u32).into());
                let _ = set(&s, "primitive", (g.primitive as u32).into());
                s.into()
            });
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
            objects.push(&o);
        }
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1).max(1);
        let warnings = js_sys::Array::new();
        for w in &built.warnings {
            warnings.push(&w.as_str().into());
        }
        let result = js_sys::Object::new();
        set(&result, "id", id.into())?;
        set(&result, "report", report.to_string().into())?;
        set(&result, "warnings", warnings.into())?;
        set(&result, "objects", objects.into())?;
        let maps = out
            .maps
            .iter()
            .map(|m| (m.object, m.illuminance().clone()))
            .collect();
        self.kept.insert(
            id,
            Kept {
                scene: built.scene,
                maps,
                tolerance: options.measure_tolerance.unwrap_or(0.01),
            },
        );
        Ok(result.into())
    }

    /// Illuminance (lux) at world points `xyz` (`3n` numbers, metres) of bake `id`
    /// ([`crate::request::measure`]; NaN for a point on no baked surface).
    ///
    /// # Errors
    /// An unknown or released bake, or malformed points (`measure`).
    pub fn measure(&self, id: u32, xyz: &[f64]) -> Result<Vec<f64>, JsValue> {
        let kept = self.kept.get(&id).ok_or_else(|| {
            js_error(&JsBakeError::Measure(format!(
                "bake {id} was released (or aborted): its maps are gone"
            )))
        })?;
        let maps: Vec<(usize, &MapImage)> = kept.maps.iter().map(|(o, m)| (*o, m)).collect();
        measure(&kept.scene, &maps, xyz, kept.tolerance).map_err(|e| js_error(&e))
    }

    /// Frees what bake `id` kept for [`Baker::measure`].
    pub fn release(&mut self, id: u32) {
        self.kept.remove(&id);
    }
}
