//! WebGL2 context from a canvas (wasm32 only).

use wasm_bindgen::JsCast;
use web_sys::{HtmlCanvasElement, OffscreenCanvas, WebGl2RenderingContext};

use crate::error::{GlowError, Result};

/// Asks `canvas` for a `webgl2` context and wraps it in `glow`.
pub(crate) fn from_canvas(canvas: &HtmlCanvasElement) -> Result<glow::Context> {
    let object = canvas
        .get_context("webgl2")
        .map_err(|e| GlowError::NoContext {
            reason: format!("canvas.getContext(\"webgl2\") threw: {e:?}"),
        })?
        .ok_or_else(|| GlowError::NoContext {
            reason: "canvas.getContext(\"webgl2\") returned null (WebGL2 unavailable)".into(),
        })?;
    let context =
        object
            .dyn_into::<WebGl2RenderingContext>()
            .map_err(|_| GlowError::NoContext {
                reason: "canvas.getContext(\"webgl2\") did not return a WebGL2RenderingContext"
                    .into(),
            })?;
    Ok(glow::Context::from_webgl2_context(context))
}

/// Asks an `OffscreenCanvas` (usable in a Web Worker) for a `webgl2` context.
pub(crate) fn from_offscreen_canvas(canvas: &OffscreenCanvas) -> Result<glow::Context> {
    let object = canvas
        .get_context("webgl2")
        .map_err(|e| GlowError::NoContext {
            reason: format!("OffscreenCanvas.getContext(\"webgl2\") threw: {e:?}"),
        })?
        .ok_or_else(|| GlowError::NoContext {
            reason: "OffscreenCanvas.getContext(\"webgl2\") returned null (WebGL2 unavailable)"
                .into(),
        })?;
    let context =
        object
            .dyn_into::<WebGl2RenderingContext>()
            .map_err(|_| GlowError::NoContext {
                reason: "OffscreenCanvas.getContext(\"webgl2\") did not return a \
                         WebGL2RenderingContext"
                    .into(),
            })?;
    Ok(glow::Context::from_webgl2_context(context))
}
