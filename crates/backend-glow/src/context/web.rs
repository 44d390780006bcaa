//! WebGL2 context from a canvas (wasm32 only).

use wasm_bindgen::{JsCast, JsValue};
use web_sys::{HtmlCanvasElement, OffscreenCanvas, WebGl2RenderingContext};

use crate::error::{GlowError, Result};

/// Asks `canvas` for a `webgl2` context and wraps it in `glow`.
pub(crate) fn from_canvas(canvas: &HtmlCanvasElement) -> Result<glow::Context> {
    webgl2("canvas", canvas.get_context("webgl2"))
}

/// Asks an `OffscreenCanvas` (usable in a Web Worker) for a `webgl2` context.
pub(crate) fn from_offscreen_canvas(canvas: &OffscreenCanvas) -> Result<glow::Context> {
    webgl2("OffscreenCanvas", canvas.get_context("webgl2"))
}

/// Wraps what `<canvas>.getContext("webgl2")` gave in `glow`; `canvas` names the caller in
/// errors.
fn webgl2(
    canvas: &str,
    got: std::result::Result<Option<web_sys::js_sys::Object>, JsValue>,
) -> Result<glow::Context> {
    let no_context = |what: String| GlowError::NoContext {
        reason: format!("{canvas}.getContext(\"webgl2\") {what}"),
    };
    let context = got
        .map_err(|e| no_context(format!("threw: {e:?}")))?
        .ok_or_else(|| no_context("returned null (WebGL2 unavailable)".into()))?
        .dyn_into::<WebGl2RenderingContext>()
        .map_err(|_| no_context("did not return a WebGL2RenderingContext".into()))?;
    Ok(glow::Context::from_webgl2_context(context))
}
