//! The wasm-bindgen interface the page's JavaScript calls (wasm32 only).
//!
//! - [`Baker`] lives in the bake worker (`web/worker.js`): one WebGL2 context on an
//!   `OffscreenCanvas` and one [`GlowBackend`] on it (a bake frees its textures when its maps
//!   are read back; the programs stay compiled), the room of the last bake kept: a bake that
//!   changes only the lamp, the rays or the bounces reuses its layout, G-buffer, BVH and
//!   unocclusion, and the gather rays' hits the backend kept (`luxbake::kept`) instead of
//!   casting them again. Progress is reported through a JS callback, the direct light handed
//!   over through another before the bounces run.
//! - [`Viewer`] lives on the page's thread: the display renderer, the camera, the light maps
//!   of the last successful bake.

mod render;

use luxbake::bake::ObjectMaps;
use luxbake::scene::Object;
use luxbake::sources::builtin::ROOM_SIZE;
use luxbake::{GpuBackend, Progress, Room};
use luxbake_backend_glow::{GlContext, GlowBackend};
use serde_json::json;
use wasm_bindgen::prelude::*;
use web_sys::{HtmlCanvasElement, OffscreenCanvas};

use crate::camera::{Camera, Mode};
use crate::mesh::display_meshes;
use crate::request::{BakeRequest, FILE_SOURCE, build_scene, parse_lamp_file};
use crate::{ViewerError, request};
use render::{Frame, Renderer};

fn js_err(e: impl std::fmt::Display) -> JsError {
    JsError::new(&e.to_string())
}

/// Sends Rust panics to the browser console (once per instance).
fn install_panic_hook() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        std::panic::set_hook(Box::new(|info| {
            web_sys::console::error_1(&format!("luxbake-viewer panicked: {info}").into());
        }));
    });
}

/// The bundled lamps as JSON `[[id, label], ...]`.
#[wasm_bindgen(js_name = bundledLamps)]
pub fn bundled_lamps() -> String {
    json!(request::BUNDLED_LAMPS).to_string()
}

/// The built-in scene names as JSON.
#[wasm_bindgen(js_name = sceneNames)]
pub fn scene_names() -> String {
    json!(luxbake::scene::Scene::builtin_names()).to_string()
}

/// The default request as JSON.
#[wasm_bindgen(js_name = defaultRequest)]
pub fn default_request() -> String {
    serde_json::to_string(&BakeRequest::default()).unwrap_or_default()
}

/// The default request with the rays, bounces and blur of a method's preset, as JSON; an
/// unknown method or quality gives the default request.
#[wasm_bindgen(js_name = presetRequest)]
pub fn preset_request(method: &str, quality: &str) -> String {
    let request = match (method.parse(), quality.parse()) {
        (Ok(m), Ok(q)) => BakeRequest::with_preset(m, q),
        _ => BakeRequest::default(),
    };
    serde_json::to_string(&request).unwrap_or_default()
}

/// Parses a photometric file from disk; returns a one-line summary or the parser's error.
///
/// # Errors
/// The `luxbake-ies` message (line and what was expected).
#[wasm_bindgen(js_name = checkLampFile)]
pub fn check_lamp_file(name: &str, bytes: &[u8]) -> Result<String, JsError> {
    let p = parse_lamp_file(name, bytes).map_err(js_err)?;
    let lumens = p
        .lumens_per_lamp()
        .map_or_else(|| "absolute".to_owned(), |l| format!("{l:.0} lm"));
    Ok(format!(
        "{name}: {:?}, {} × {} angles, {lumens}, peak {:.0} cd",
        p.photometric_type(),
        p.vertical_angles().len(),
        p.horizontal_angles().len(),
        (0..p.horizontal_angles().len())
            .filter_map(|h| p.candela_row(h))
            .flatten()
            .fold(0.0f64, |m, &c| m.max(c))
    ))
}

/// The bake worker's baker: a WebGL2 context on an `OffscreenCanvas`, its backend, and the
/// room of the last bake with the objects it was prepared from.
#[wasm_bindgen]
pub struct Baker {
    canvas: OffscreenCanvas,
    renderer: String,
    backend: Option<GlowBackend>,
    room: Option<(Vec<Object>, Room)>,
}

fn new_context() -> Result<(OffscreenCanvas, GlContext), JsError> {
    let canvas = OffscreenCanvas::new(1, 1)
        .map_err(|e| js_err(format!("OffscreenCanvas unavailable: {e:?}")))?;
    let ctx = GlContext::from_offscreen_canvas(&canvas).map_err(js_err)?;
    Ok((canvas, ctx))
}

#[wasm_bindgen]
impl Baker {
    /// Creates the context and checks it (WebGL2, `EXT_color_buffer_float`, WebGL2 limits).
    ///
    /// # Errors
    /// A message naming what is missing.
    #[wasm_bindgen(constructor)]
    pub fn new() -> Result<Baker, JsError> {
        install_panic_hook();
        let (canvas, ctx) = new_context()?;
        let caps = ctx.capabilities();
        let renderer = format!("{} ({})", caps.renderer, caps.version);
        Ok(Baker {
            canvas,
            renderer,
            backend: None,
            room: None,
        })
    }

    /// The GPU's renderer and version strings.
    pub fn renderer(&self) -> String {
        self.renderer.clone()
    }

    /// Bakes `request_json` ([`BakeRequest`]); `lamp_file` holds the bytes of a file from disk
    /// for lamp source `file`. `progress` is called with one JSON event per set-up step, pass
    /// start, finished tile and finished pass; `direct` with the blurred direct light, as
    /// `maps` entries `{object, name, width, height, illuminance}` ([`Viewer::show_bake`]
    /// shows them) and the stage (`"direct"`, or `"preview"`), before the bounces run
    /// ([`luxbake::bake_room_direct_first`]): once, or twice when a lamp bakes its opening
    /// (first its preview, every lamp a point). Returns
    /// `{report, maps}`: `report` a JSON string (texels, passes with seconds, total), `maps`
    /// one entry per receiver `{object, name, width, height, illuminance, direct, exitance}`
    /// (Float32Arrays, RGBA, row 0 first; stages 7, 3 and 8 of Figure 5).
    ///
    /// After a failure the context is replaced, so a lost context does not stop the next bake.
    ///
    /// # Errors
    /// Invalid request or lamp file, or a backend failure (the message names the pass).
    pub fn bake(
        &mut self,
        request_json: &str,
        lamp_file: Option<Vec<u8>>,
        progress: &js_sys::Function,
        direct: &js_sys::Function,
    ) -> Result<JsValue, JsError> {
        let result = self.bake_inner(request_json, lamp_file.as_deref(), progress, direct);
        if result.is_err() {
            // A failed bake may have lost the context: start again on a new one.
            self.backend = None;
            self.room = None;
            if let Ok((canvas, _)) = new_context() {
                self.canvas = canvas;
            }
        }
        result
    }

    fn bake_inner(
        &mut self,
        request_json: &str,
        lamp_file: Option<&[u8]>,
        progress: &js_sys::Function,
        direct: &js_sys::Function,
    ) -> Result<JsValue, JsError> {
        let request = BakeRequest::from_json(request_json).map_err(js_err)?;
        let scene = build_scene(&request, lamp_file).map_err(js_err)?;
        let mut backend = match self.backend.take() {
            Some(backend) => backend,
            None => {
                let ctx = GlContext::from_offscreen_canvas(&self.canvas).map_err(js_err)?;
                let mut backend = GlowBackend::new(ctx).map_err(js_err)?;
                backend
                    .keep_gather_hits(luxbake_backend_glow::WEB_GATHER_HITS_BUDGET)
                    .map_err(js_err)?;
                backend
            }
        };
        let send = |event: serde_json::Value| {
            // A throwing progress callback must not stop the bake.
            let _ = progress.call1(&JsValue::NULL, &JsValue::from_str(&event.to_string()));
        };
        let mut on_progress = |p: &Progress<'_>| match p {
            Progress::Setup(step) => send(json!({"kind": "setup", "step": step})),
            Progress::PassStart {
                index,
                count,
                label,
                bounce,
            } => send(json!({"kind": "pass", "index": index, "count": count,
                                "label": label, "bounce": bounce})),
            Progress::PassProgress { index, fraction } => {
                send(json!({"kind": "tile", "index": index, "fraction": fraction}));
            }
            Progress::PassDone { index, seconds } => {
                send(json!({"kind": "done", "index": index, "seconds": seconds}));
            }
            Progress::Work(fraction) => send(json!({"kind": "work", "fraction": fraction})),
        };
        // luxbake::bake, the direct light handed over first; the last bake's room again when
        // only what does not depend on it changed (the lamp, the rays, the bounces, the blur).
        let settings = &scene.settings;
        let kept = self.room.take().filter(|(objects, room)| {
            *objects == scene.objects && room.check(settings, backend.limits()).is_ok()
        });
        let reused = kept.is_some();
        let (objects, room) = match kept {
            Some(kept) => kept,
            None => (
                scene.objects.clone(),
                Room::prepare(&scene, settings, backend.limits(), &mut on_progress)
                    .map_err(js_err)?,
            ),
        };
        let mut sent = Ok(());
        let mut out = luxbake::bake_room_direct_first(
            &mut backend,
            &room,
            &scene.lamps,
            settings,
            &mut on_progress,
            &mut |stage, maps: &[ObjectMaps]| {
                // A preview that could not be sent keeps its error (and nothing follows).
                if sent.is_ok() {
                    sent = maps_of(maps, false).map(|maps| {
                        // A throwing callback must not stop the bake.
                        let _ =
                            direct.call2(&JsValue::NULL, &maps, &JsValue::from_str(stage.name()));
                    });
                }
            },
        )
        .map_err(js_err)?;
        sent?;
        if !reused {
            out.report.setup.splice(0..0, room.timings.iter().copied());
            out.report.total_seconds += room.timings.iter().map(|(_, s)| s).sum::<f64>();
        }
        self.backend = Some(backend);
        self.room = Some((objects, room));
        let r = &out.report;
        let report = json!({
            "backend": r.backend,
            "renderer": self.renderer,
            "scene": request.scene,
            "texels": r.texels,
            "triangles": r.triangles,
            "shadow_rays": r.shadow_rays,
            "gather_rays": r.gather_rays,
            "bvh": r.bvh.name(),
            "bounces_run": r.bounces_run,
            "room_reused": reused,
            "setup": r.setup.iter().map(|(n, s)| json!({"step": n, "seconds": s})).collect::<Vec<_>>(),
            "passes": r.passes.iter().map(|p| json!({"label": p.label, "bounce": p.bounce, "seconds": p.seconds})).collect::<Vec<_>>(),
            "skipped": r.skipped.iter().map(ToString::to_string).collect::<Vec<_>>(),
            "total_seconds": r.total_seconds,
        });
        let maps = maps_of(&out.maps, true)?;
        let result = js_sys::Object::new();
        js_sys::Reflect::set(&result, &"report".into(), &report.to_string().into())
            .and_then(|_| js_sys::Reflect::set(&result, &"maps".into(), &maps))
            .map_err(|_| js_err("building the result object"))?;
        Ok(result.into())
    }
}

/// `maps` as the page gets them: per receiver `{object, name, width, height, illuminance}`
/// and, with `all`, `direct` and `exitance` (Float32Arrays, RGBA, row 0 first).
fn maps_of(maps: &[ObjectMaps], all: bool) -> Result<js_sys::Array, JsError> {
    let out = js_sys::Array::new();
    for m in maps {
        let o = js_sys::Object::new();
        let set = |k: &str, v: JsValue| js_sys::Reflect::set(&o, &k.into(), &v);
        let f32s = |img: &luxbake::map::MapImage| {
            JsValue::from(js_sys::Float32Array::from(img.texels.as_slice()))
        };
        let ok = set("object", (m.object as u32).into()).is_ok()
            && set("name", m.name.as_str().into()).is_ok()
            && set("width", m.region.size[0].into()).is_ok()
            && set("height", m.region.size[1].into()).is_ok()
            && set("illuminance", f32s(m.illuminance())).is_ok()
            && (!all
                || set("direct", f32s(m.direct())).is_ok()
                    && set("exitance", f32s(m.exitance())).is_ok());
        if !ok {
            return Err(js_err("building the result object"));
        }
        out.push(&o);
    }
    Ok(out)
}

/// The page's display: renderer, camera, the light maps of the last bake.
#[wasm_bindgen]
pub struct Viewer {
    renderer: Renderer,
    camera: Camera,
    meshes: Vec<crate::mesh::DisplayMesh>,
    /// Per object: `(width, height, illuminance texels)` of the last bake.
    maps: Vec<Option<(u32, u32, Vec<f32>)>>,
    lamp: [f32; 3],
    exposure_ev: f32,
    false_colour: bool,
}

#[wasm_bindgen]
impl Viewer {
    /// A viewer on `canvas`.
    ///
    /// # Errors
    /// No WebGL2, or the display shaders fail.
    #[wasm_bindgen(constructor)]
    pub fn new(canvas: &HtmlCanvasElement) -> Result<Viewer, JsError> {
        install_panic_hook();
        Ok(Viewer {
            renderer: Renderer::new(canvas).map_err(js_err)?,
            camera: Camera::for_room(ROOM_SIZE),
            meshes: Vec::new(),
            maps: Vec::new(),
            lamp: [0.0, ROOM_SIZE[1] - 0.05, 0.0],
            exposure_ev: -3.0,
            false_colour: false,
        })
    }

    /// Whether the display context is lost (the page then waits for `webglcontextrestored`
    /// and calls [`Viewer::restore`]).
    #[wasm_bindgen(js_name = isContextLost)]
    pub fn is_context_lost(&self) -> bool {
        self.renderer.is_lost()
    }

    /// Recreates every GPU object on `canvas` after a context loss, from the meshes and maps
    /// kept on the CPU.
    ///
    /// # Errors
    /// As [`Viewer::new`].
    pub fn restore(&mut self, canvas: &HtmlCanvasElement) -> Result<(), JsError> {
        self.renderer.abandon();
        self.renderer = Renderer::new(canvas).map_err(js_err)?;
        self.upload().map_err(js_err)
    }

    fn upload(&mut self) -> Result<(), ViewerError> {
        self.renderer.set_meshes(&self.meshes)?;
        for (i, m) in self.maps.iter().enumerate() {
            let map = m.as_ref().map(|(w, h, t)| (*w, *h, t.as_slice()));
            self.renderer.set_map(i, map)?;
        }
        Ok(())
    }

    /// Shows a finished bake: the scene of `request_json` with `maps` (the `maps` array a
    /// [`Baker::bake`] returned). On error the previous bake stays on display.
    ///
    /// # Errors
    /// A request that does not build, or maps that do not fit the scene's objects.
    #[wasm_bindgen(js_name = showBake)]
    pub fn show_bake(&mut self, request_json: &str, maps: &js_sys::Array) -> Result<(), JsError> {
        let mut request = BakeRequest::from_json(request_json).map_err(js_err)?;
        if request.lamp.source == FILE_SOURCE {
            // The display needs the lamp's position only, not its photometry.
            request.lamp.source = "downlight".into();
        }
        let scene = build_scene(&request, None).map_err(js_err)?;
        let meshes = display_meshes(&scene);
        let mut new_maps = vec![None; meshes.len()];
        for entry in maps.iter() {
            let get = |k: &str| js_sys::Reflect::get(&entry, &k.into()).ok();
            let num = |k: &str| get(k).and_then(|v| v.as_f64()).unwrap_or(-1.0);
            let (object, w, h) = (num("object"), num("width"), num("height"));
            let texels = get("illuminance")
                .and_then(|v| v.dyn_into::<js_sys::Float32Array>().ok())
                .map(|a| a.to_vec())
                .unwrap_or_default();
            let fits = object >= 0.0
                && (object as usize) < meshes.len()
                && w >= 1.0
                && h >= 1.0
                && texels.len() as f64 == 4.0 * w * h;
            if !fits {
                return Err(js_err(ViewerError::Maps(format!(
                    "entry for object {object} ({w}×{h}, {} floats) does not fit `{}`",
                    texels.len(),
                    request.scene
                ))));
            }
            new_maps[object as usize] = Some((w as u32, h as u32, texels));
        }
        self.meshes = meshes;
        self.maps = new_maps;
        self.lamp = scene
            .lamps
            .first()
            .map_or(self.lamp, |l| l.position.map(|c| c as f32));
        self.upload().map_err(js_err)
    }

    /// Moves the lamp marker (before the re-bake with the lamp there finishes).
    #[wasm_bindgen(js_name = setLampMarker)]
    pub fn set_lamp_marker(&mut self, x: f32, y: f32, z: f32) {
        if x.is_finite() && y.is_finite() && z.is_finite() {
            self.lamp = [x, y, z];
        }
    }

    /// Exposure in stops: luminance × 2^ev before tone mapping.
    #[wasm_bindgen(js_name = setExposure)]
    pub fn set_exposure(&mut self, ev: f32) {
        if ev.is_finite() {
            self.exposure_ev = ev.clamp(-16.0, 16.0);
        }
    }

    /// Switches the false-colour lux view.
    #[wasm_bindgen(js_name = setFalseColour)]
    pub fn set_false_colour(&mut self, on: bool) {
        self.false_colour = on;
    }

    /// Orbit (`false`) or walk (`true`).
    #[wasm_bindgen(js_name = setWalk)]
    pub fn set_walk(&mut self, walk: bool) {
        self.camera
            .set_mode(if walk { Mode::Walk } else { Mode::Orbit });
    }

    /// Mouse or touch drag of `(dx, dy)` CSS pixels.
    pub fn drag(&mut self, dx: f32, dy: f32) {
        self.camera.drag(dx, dy);
    }

    /// Wheel or pinch zoom (factor > 1 moves away).
    pub fn zoom(&mut self, factor: f32) {
        self.camera.zoom(factor);
    }

    /// Keyboard movement, metres.
    pub fn walk(&mut self, forward: f32, right: f32, up: f32) {
        self.camera.walk(forward, right, up);
    }

    /// Back to the default view.
    #[wasm_bindgen(js_name = resetCamera)]
    pub fn reset_camera(&mut self) {
        self.camera = Camera::for_room(ROOM_SIZE);
    }

    /// Pixel position of world point `(x, y, z)` in a `width × height` view (top-left origin),
    /// or `undefined` behind the camera.
    pub fn project(&self, x: f32, y: f32, z: f32, width: f32, height: f32) -> Option<Vec<f32>> {
        self.camera
            .project(glam::Vec3::new(x, y, z), width, height)
            .map(|p| p.to_array().to_vec())
    }

    /// Draws a frame into the drawing buffer of `width × height` pixels. A lost context draws
    /// nothing and reports no error.
    ///
    /// # Errors
    /// A GL error.
    pub fn render(&self, width: u32, height: u32) -> Result<(), JsError> {
        if self.renderer.is_lost() {
            return Ok(());
        }
        let (w, h) = (width.max(1), height.max(1));
        self.renderer
            .draw(&Frame {
                view_projection: self.camera.view_projection(w as f32 / h as f32),
                exposure: self.exposure_ev.exp2(),
                false_colour: self.false_colour,
                lamp: self.lamp,
                size: [
                    i32::try_from(w).unwrap_or(i32::MAX),
                    i32::try_from(h).unwrap_or(i32::MAX),
                ],
            })
            .map_err(js_err)
    }
}
