//! The display: the scene's meshes drawn with their light maps on the page's WebGL2 canvas.

use glam::{Mat4, Vec3};
use glow::HasContext;
use wasm_bindgen::JsCast;
use web_sys::{HtmlCanvasElement, WebGl2RenderingContext};

use crate::ViewerError;
use crate::mesh::{DisplayMesh, FLOATS_PER_VERTEX};

const VERTEX: &str = r"#version 300 es
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_nrm;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec3 a_alb;
uniform mat4 u_vp;
out vec2 v_uv;
out vec3 v_alb;
void main() {
    v_uv = a_uv;
    v_alb = a_alb;
    gl_Position = u_vp * vec4(a_pos, 1.0);
}
";

const FRAGMENT: &str = r"#version 300 es
precision highp float;
precision highp sampler2D;
uniform sampler2D u_map;
uniform int u_has_map;
uniform int u_mode;      // 0 exitance, 1 false-colour lux, 2 lamp marker
uniform float u_exposure;
in vec2 v_uv;
in vec3 v_alb;
out vec4 o_color;

// Masked bilinear look-up (luxbake::map): texels weighted by their mask, renormalised.
vec3 illuminance(vec2 uv) {
    ivec2 size = textureSize(u_map, 0);
    vec2 c = clamp(uv * vec2(size) - 0.5, vec2(0.0), vec2(size - 1));
    ivec2 i0 = ivec2(floor(c));
    ivec2 i1 = min(i0 + 1, size - 1);
    vec2 f = c - vec2(i0);
    vec4 t00 = texelFetch(u_map, i0, 0);
    vec4 t10 = texelFetch(u_map, ivec2(i1.x, i0.y), 0);
    vec4 t01 = texelFetch(u_map, ivec2(i0.x, i1.y), 0);
    vec4 t11 = texelFetch(u_map, i1, 0);
    float w00 = (1.0 - f.x) * (1.0 - f.y) * step(0.5, t00.a);
    float w10 = f.x * (1.0 - f.y) * step(0.5, t10.a);
    float w01 = (1.0 - f.x) * f.y * step(0.5, t01.a);
    float w11 = f.x * f.y * step(0.5, t11.a);
    float w = w00 + w10 + w01 + w11;
    if (w <= 0.0) return vec3(0.0);
    return (t00.rgb * w00 + t10.rgb * w10 + t01.rgb * w01 + t11.rgb * w11) / w;
}

// Blue - cyan - green - yellow - red - white over t in 0..1.
vec3 ramp(float t) {
    vec3 c0 = vec3(0.05, 0.05, 0.45), c1 = vec3(0.0, 0.6, 0.9), c2 = vec3(0.1, 0.8, 0.2);
    vec3 c3 = vec3(0.95, 0.9, 0.1), c4 = vec3(0.9, 0.15, 0.1), c5 = vec3(1.0, 1.0, 1.0);
    float s = clamp(t, 0.0, 1.0) * 5.0;
    if (s < 1.0) return mix(c0, c1, s);
    if (s < 2.0) return mix(c1, c2, s - 1.0);
    if (s < 3.0) return mix(c2, c3, s - 2.0);
    if (s < 4.0) return mix(c3, c4, s - 3.0);
    return mix(c4, c5, s - 4.0);
}

void main() {
    if (u_mode == 2) { o_color = vec4(1.0, 0.92, 0.6, 1.0); return; }
    vec3 e = u_has_map == 1 ? illuminance(v_uv) : vec3(0.0);
    if (u_mode == 1) {
        float lux = dot(e, vec3(0.2126, 0.7152, 0.0722));
        o_color = vec4(ramp(log(max(lux, 1e-3)) / log(10.0) / 4.0), 1.0);
        return;
    }
    vec3 luminance = e * v_alb / 3.14159265;
    vec3 mapped = 1.0 - exp(-luminance * u_exposure);
    o_color = vec4(pow(mapped, vec3(1.0 / 2.2)), 1.0);
}
";

/// An object on the GPU.
struct GpuMesh {
    vao: glow::VertexArray,
    vbo: glow::Buffer,
    ibo: glow::Buffer,
    count: i32,
    map: Option<glow::Texture>,
}

/// How to draw a frame.
pub(crate) struct Frame {
    /// `projection · view`, column-major.
    pub view_projection: Mat4,
    /// Linear factor on luminance before tone mapping.
    pub exposure: f32,
    /// False-colour lux view.
    pub false_colour: bool,
    /// The lamp marker's world position.
    pub lamp: [f32; 3],
    /// Drawing-buffer size, pixels.
    pub size: [i32; 2],
}

/// The display renderer on one canvas.
pub(crate) struct Renderer {
    gl: glow::Context,
    webgl: WebGl2RenderingContext,
    program: glow::Program,
    meshes: Vec<GpuMesh>,
    marker: Option<GpuMesh>,
    /// Set when the context was lost since these objects were made: they are gone with it, and
    /// deleting them on the restored context would be a GL error.
    stale: bool,
}

fn gpu(what: &str, e: impl std::fmt::Display) -> ViewerError {
    ViewerError::Gpu(format!("{what}: {e}"))
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_ne_bytes()).collect()
}

fn u32_bytes(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_ne_bytes()).collect()
}

impl Renderer {
    /// A renderer on `canvas` (WebGL2, antialiased, drawing buffer preserved so that
    /// screenshots see the last frame).
    pub(crate) fn new(canvas: &HtmlCanvasElement) -> Result<Renderer, ViewerError> {
        let options = js_sys::Object::new();
        for (k, v) in [("antialias", true), ("preserveDrawingBuffer", true)] {
            js_sys::Reflect::set(&options, &k.into(), &v.into())
                .map_err(|e| gpu("context options", format!("{e:?}")))?;
        }
        let webgl = canvas
            .get_context_with_context_options("webgl2", &options)
            .map_err(|e| gpu("canvas.getContext(\"webgl2\")", format!("{e:?}")))?
            .ok_or_else(|| {
                ViewerError::Gpu(
                    "this browser offers no WebGL2 (canvas.getContext(\"webgl2\") returned null)"
                        .into(),
                )
            })?
            .dyn_into::<WebGl2RenderingContext>()
            .map_err(|_| ViewerError::Gpu("getContext(\"webgl2\") is not WebGL2".into()))?;
        let gl = glow::Context::from_webgl2_context(webgl.clone());
        // SAFETY: plain GL calls on a live context; every object is checked.
        let program = unsafe {
            let program = gl.create_program().map_err(|e| gpu("createProgram", e))?;
            let mut shaders = Vec::new();
            for (kind, src) in [
                (glow::VERTEX_SHADER, VERTEX),
                (glow::FRAGMENT_SHADER, FRAGMENT),
            ] {
                let s = gl.create_shader(kind).map_err(|e| gpu("createShader", e))?;
                gl.shader_source(s, src);
                gl.compile_shader(s);
                if !gl.get_shader_compile_status(s) && !webgl.is_context_lost() {
                    return Err(gpu("display shader", gl.get_shader_info_log(s)));
                }
                gl.attach_shader(program, s);
                shaders.push(s);
            }
            gl.link_program(program);
            if !gl.get_program_link_status(program) && !webgl.is_context_lost() {
                return Err(gpu("display program", gl.get_program_info_log(program)));
            }
            for s in shaders {
                gl.detach_shader(program, s);
                gl.delete_shader(s);
            }
            program
        };
        Ok(Renderer {
            gl,
            webgl,
            program,
            meshes: Vec::new(),
            marker: None,
            stale: false,
        })
    }

    /// Marks every object as gone with a lost context (dropping then deletes nothing).
    pub(crate) fn abandon(&mut self) {
        self.stale = true;
    }

    /// Whether the browser took the context away.
    pub(crate) fn is_lost(&self) -> bool {
        self.webgl.is_context_lost()
    }

    fn upload_mesh(&self, vertices: &[f32], indices: &[u32]) -> Result<GpuMesh, ViewerError> {
        let gl = &self.gl;
        // SAFETY: buffers sized from the slices; attribute layout matches FLOATS_PER_VERTEX.
        unsafe {
            let vao = gl
                .create_vertex_array()
                .map_err(|e| gpu("createVertexArray", e))?;
            let vbo = gl.create_buffer().map_err(|e| gpu("createBuffer", e))?;
            let ibo = gl.create_buffer().map_err(|e| gpu("createBuffer", e))?;
            gl.bind_vertex_array(Some(vao));
            gl.bind_buffer(glow::ARRAY_BUFFER, Some(vbo));
            gl.buffer_data_u8_slice(glow::ARRAY_BUFFER, &f32_bytes(vertices), glow::STATIC_DRAW);
            gl.bind_buffer(glow::ELEMENT_ARRAY_BUFFER, Some(ibo));
            gl.buffer_data_u8_slice(
                glow::ELEMENT_ARRAY_BUFFER,
                &u32_bytes(indices),
                glow::STATIC_DRAW,
            );
            let stride = (FLOATS_PER_VERTEX * 4) as i32;
            for (loc, size, offset) in [(0u32, 3, 0), (1, 3, 3), (2, 2, 6), (3, 3, 8)] {
                gl.enable_vertex_attrib_array(loc);
                gl.vertex_attrib_pointer_f32(loc, size, glow::FLOAT, false, stride, offset * 4);
            }
            gl.bind_vertex_array(None);
            Ok(GpuMesh {
                vao,
                vbo,
                ibo,
                count: i32::try_from(indices.len()).unwrap_or(i32::MAX),
                map: None,
            })
        }
    }

    fn delete_mesh(&self, m: GpuMesh) {
        // SAFETY: objects created by this context.
        unsafe {
            self.gl.delete_vertex_array(m.vao);
            self.gl.delete_buffer(m.vbo);
            self.gl.delete_buffer(m.ibo);
            if let Some(t) = m.map {
                self.gl.delete_texture(t);
            }
        }
    }

    /// Replaces the meshes (their maps go with them).
    pub(crate) fn set_meshes(&mut self, meshes: &[DisplayMesh]) -> Result<(), ViewerError> {
        for m in std::mem::take(&mut self.meshes) {
            self.delete_mesh(m);
        }
        for m in meshes {
            let g = self.upload_mesh(&m.vertices, &m.indices)?;
            self.meshes.push(g);
        }
        if self.marker.is_none() {
            let (v, i) = marker_cube(0.06);
            self.marker = Some(self.upload_mesh(&v, &i)?);
        }
        Ok(())
    }

    /// Sets object `object`'s light map (`4 × width × height` floats of illuminance, alpha =
    /// mask), or removes it with `None`.
    pub(crate) fn set_map(
        &mut self,
        object: usize,
        map: Option<(u32, u32, &[f32])>,
    ) -> Result<(), ViewerError> {
        let gl = &self.gl;
        let Some(mesh) = self.meshes.get_mut(object) else {
            return Err(ViewerError::Maps(format!("no object {object}")));
        };
        if let Some(t) = mesh.map.take() {
            // SAFETY: our texture.
            unsafe { gl.delete_texture(t) };
        }
        let Some((w, h, texels)) = map else {
            return Ok(());
        };
        if w == 0 || h == 0 || texels.len() != 4 * w as usize * h as usize {
            return Err(ViewerError::Maps(format!(
                "object {object}: {} floats for {w}×{h} texels",
                texels.len()
            )));
        }
        // SAFETY: a complete RGBA32F texture (NEAREST, read with texelFetch only).
        unsafe {
            let t = gl.create_texture().map_err(|e| gpu("createTexture", e))?;
            gl.bind_texture(glow::TEXTURE_2D, Some(t));
            gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
            gl.tex_image_2d(
                glow::TEXTURE_2D,
                0,
                glow::RGBA32F as i32,
                w as i32,
                h as i32,
                0,
                glow::RGBA,
                glow::FLOAT,
                glow::PixelUnpackData::Slice(Some(&f32_bytes(texels))),
            );
            for p in [glow::TEXTURE_MIN_FILTER, glow::TEXTURE_MAG_FILTER] {
                gl.tex_parameter_i32(glow::TEXTURE_2D, p, glow::NEAREST as i32);
            }
            for p in [glow::TEXTURE_WRAP_S, glow::TEXTURE_WRAP_T] {
                gl.tex_parameter_i32(glow::TEXTURE_2D, p, glow::CLAMP_TO_EDGE as i32);
            }
            gl.bind_texture(glow::TEXTURE_2D, None);
            mesh.map = Some(t);
        }
        Ok(())
    }

    /// Draws one frame into the canvas.
    pub(crate) fn draw(&self, frame: &Frame) -> Result<(), ViewerError> {
        let gl = &self.gl;
        // SAFETY: our program, VAOs and textures; every state used is set here.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, None);
            gl.viewport(0, 0, frame.size[0], frame.size[1]);
            gl.disable(glow::SCISSOR_TEST);
            gl.disable(glow::BLEND);
            gl.enable(glow::DEPTH_TEST);
            gl.depth_func(glow::LEQUAL);
            gl.enable(glow::CULL_FACE);
            gl.cull_face(glow::BACK);
            gl.front_face(glow::CCW);
            gl.clear_color(0.08, 0.09, 0.11, 1.0);
            gl.clear(glow::COLOR_BUFFER_BIT | glow::DEPTH_BUFFER_BIT);
            gl.use_program(Some(self.program));
            let loc = |n: &str| gl.get_uniform_location(self.program, n);
            let vp = frame.view_projection.to_cols_array();
            gl.uniform_matrix_4_f32_slice(loc("u_vp").as_ref(), false, &vp);
            gl.uniform_1_f32(loc("u_exposure").as_ref(), frame.exposure);
            gl.uniform_1_i32(loc("u_mode").as_ref(), i32::from(frame.false_colour));
            gl.uniform_1_i32(loc("u_map").as_ref(), 0);
            gl.active_texture(glow::TEXTURE0);
            let has_map = loc("u_has_map");
            for m in &self.meshes {
                gl.bind_texture(glow::TEXTURE_2D, m.map);
                gl.uniform_1_i32(has_map.as_ref(), i32::from(m.map.is_some()));
                gl.bind_vertex_array(Some(m.vao));
                gl.draw_elements(glow::TRIANGLES, m.count, glow::UNSIGNED_INT, 0);
            }
            if let Some(m) = &self.marker {
                // Translate the unit marker to the lamp: vp · T.
                let vp = frame.view_projection * Mat4::from_translation(Vec3::from(frame.lamp));
                gl.uniform_matrix_4_f32_slice(loc("u_vp").as_ref(), false, &vp.to_cols_array());
                gl.uniform_1_i32(loc("u_mode").as_ref(), 2);
                gl.disable(glow::CULL_FACE);
                gl.bind_vertex_array(Some(m.vao));
                gl.draw_elements(glow::TRIANGLES, m.count, glow::UNSIGNED_INT, 0);
            }
            gl.bind_vertex_array(None);
            gl.bind_texture(glow::TEXTURE_2D, None);
            let err = gl.get_error();
            if err != glow::NO_ERROR && !self.webgl.is_context_lost() {
                return Err(ViewerError::Gpu(format!(
                    "display draw: GL error {err:#06x}"
                )));
            }
        }
        Ok(())
    }
}

impl Drop for Renderer {
    fn drop(&mut self) {
        if self.stale {
            return;
        }
        for m in std::mem::take(&mut self.meshes) {
            self.delete_mesh(m);
        }
        if let Some(m) = self.marker.take() {
            self.delete_mesh(m);
        }
        // SAFETY: our program.
        unsafe { self.gl.delete_program(self.program) };
    }
}

/// A cube of half-size `h` around the origin in the display's vertex layout.
fn marker_cube(h: f32) -> (Vec<f32>, Vec<u32>) {
    let mut v = Vec::new();
    for i in 0..8u32 {
        let p = [i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| if b == 1 { h } else { -h });
        v.extend_from_slice(&p);
        v.extend_from_slice(&[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    }
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let i = faces
        .iter()
        .flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]])
        .collect();
    (v, i)
}
