//! Thin, checked wrappers over the GL calls the backend makes: programs, RGBA32F texture arrays,
//! render targets, read-back. Every wrapper checks `glGetError` and names the pass it worked for.

use std::collections::HashMap;

use glow::HasContext;

use crate::context::webgl2;
use crate::error::{GlowError, Result, gl_error_name};

/// Returns the first pending GL error as [`GlowError::Gl`].
pub(crate) fn check(gl: &glow::Context, pass: &str, operation: &'static str) -> Result<()> {
    // SAFETY: glGetError has no preconditions.
    let code = unsafe { gl.get_error() };
    if code == glow::NO_ERROR {
        return Ok(());
    }
    // Drain further flags so that the next check reports the next operation's errors only.
    // SAFETY: as above.
    while unsafe { gl.get_error() } != glow::NO_ERROR {}
    Err(GlowError::Gl {
        pass: pass.to_owned(),
        operation,
        code,
        name: gl_error_name(code),
    })
}

/// The header every shader starts with: GLSL ES 3.00 and high precision everywhere (the bake
/// compares against f32 CPU maths).
pub(crate) const SHADER_HEADER: &str = "#version 300 es\n\
precision highp float;\n\
precision highp int;\n\
precision highp sampler2DArray;\n";

/// Full-screen triangle from `gl_VertexID` (no vertex buffers); draws are clipped to the tile by
/// the viewport and scissor.
const FULLSCREEN_VS: &str = "void main() {\n\
    vec2 p = vec2(float((gl_VertexID & 1) << 2), float((gl_VertexID & 2) << 1)) - 1.0;\n\
    gl_Position = vec4(p, 0.0, 1.0);\n\
}\n";

/// A linked fragment-shader pass with its uniform locations.
#[derive(Debug)]
pub(crate) struct Program {
    pub(crate) raw: glow::Program,
    uniforms: HashMap<String, glow::UniformLocation>,
}

fn compile(
    gl: &glow::Context,
    label: &str,
    kind: u32,
    stage: &'static str,
    source: &str,
) -> Result<glow::Shader> {
    // SAFETY: plain object creation and compilation on a current context.
    unsafe {
        let shader = gl.create_shader(kind).map_err(|log| GlowError::Compile {
            pass: label.to_owned(),
            stage,
            log,
        })?;
        gl.shader_source(shader, source);
        gl.compile_shader(shader);
        if !gl.get_shader_compile_status(shader) {
            let log = gl.get_shader_info_log(shader);
            gl.delete_shader(shader);
            return Err(GlowError::Compile {
                pass: label.to_owned(),
                stage,
                log: numbered_log(&log, source),
            });
        }
        Ok(shader)
    }
}

/// The driver log followed by the numbered source, so that "0:123(4): error" can be found.
fn numbered_log(log: &str, source: &str) -> String {
    let mut out = format!("{}\n--- source ---\n", log.trim_end());
    for (i, line) in source.lines().enumerate() {
        out.push_str(&format!("{:4} {line}\n", i + 1));
    }
    out
}

impl Program {
    /// Compiles [`SHADER_HEADER`] + `defines` + `fragment` against the full-screen vertex shader.
    pub(crate) fn new(
        gl: &glow::Context,
        label: &str,
        defines: &str,
        fragment: &[&str],
    ) -> Result<Self> {
        let vs_source = format!("{SHADER_HEADER}{FULLSCREEN_VS}");
        let mut fs_source = format!("{SHADER_HEADER}{defines}");
        for part in fragment {
            fs_source.push_str(part);
            fs_source.push('\n');
        }
        let vs = compile(gl, label, glow::VERTEX_SHADER, "vertex", &vs_source)?;
        let fs = match compile(gl, label, glow::FRAGMENT_SHADER, "fragment", &fs_source) {
            Ok(fs) => fs,
            Err(e) => {
                // SAFETY: deleting the shader object created above.
                unsafe { gl.delete_shader(vs) };
                return Err(e);
            }
        };
        // SAFETY: linking the two shaders compiled above; they are deleted once attached.
        unsafe {
            let raw = gl.create_program().map_err(|log| GlowError::Link {
                pass: label.to_owned(),
                log,
            })?;
            gl.attach_shader(raw, vs);
            gl.attach_shader(raw, fs);
            gl.link_program(raw);
            gl.detach_shader(raw, vs);
            gl.detach_shader(raw, fs);
            gl.delete_shader(vs);
            gl.delete_shader(fs);
            if !gl.get_program_link_status(raw) {
                let log = gl.get_program_info_log(raw);
                gl.delete_program(raw);
                return Err(GlowError::Link {
                    pass: label.to_owned(),
                    log: numbered_log(&log, &fs_source),
                });
            }
            let mut uniforms = HashMap::new();
            for i in 0..gl.get_active_uniforms(raw) {
                if let Some(u) = gl.get_active_uniform(raw, i) {
                    let name = u.name.trim_end_matches("[0]").to_owned();
                    if let Some(loc) = gl.get_uniform_location(raw, &name) {
                        uniforms.insert(name, loc);
                    }
                }
            }
            check(gl, label, "linking the program")?;
            Ok(Self { raw, uniforms })
        }
    }

    /// The location of an active uniform (`None` if the compiler removed it as unused).
    pub(crate) fn uniform(&self, name: &str) -> Option<&glow::UniformLocation> {
        self.uniforms.get(name)
    }

    /// Binds the program and its sampler uniforms: texture unit `i` gets `samplers[i]`.
    /// Asserts WebGL2's guarantee of [`webgl2::TEXTURE_UNITS`] units per pass.
    pub(crate) fn use_with(
        &self,
        gl: &glow::Context,
        pass: &str,
        samplers: &[(&str, &TextureArray)],
    ) -> Result<()> {
        if samplers.len() > webgl2::TEXTURE_UNITS as usize {
            return Err(GlowError::Limit {
                what: "texture units per pass (WebGL2 guarantees 16)",
                requested: samplers.len() as u64,
                allowed: webgl2::TEXTURE_UNITS.into(),
            });
        }
        // SAFETY: binding our program and existing textures to units below the limit.
        unsafe {
            gl.use_program(Some(self.raw));
            for (unit, (name, tex)) in samplers.iter().enumerate() {
                gl.active_texture(glow::TEXTURE0 + unit as u32);
                gl.bind_texture(glow::TEXTURE_2D_ARRAY, Some(tex.raw));
                gl.uniform_1_i32(self.uniform(name), unit as i32);
            }
            gl.active_texture(glow::TEXTURE0);
        }
        check(gl, pass, "binding the program and its textures")
    }

    /// Sets an `int` uniform of the bound program (ignored if the compiler removed it).
    pub(crate) fn set_i32(&self, gl: &glow::Context, name: &str, v: i32) {
        // SAFETY: setting a uniform of the bound program; a missing location is a no-op.
        unsafe { gl.uniform_1_i32(self.uniform(name), v) };
    }

    /// Sets a `uint` uniform of the bound program.
    pub(crate) fn set_u32(&self, gl: &glow::Context, name: &str, v: u32) {
        // SAFETY: as set_i32.
        unsafe { gl.uniform_1_u32(self.uniform(name), v) };
    }

    /// Sets an `ivec2` uniform of the bound program.
    pub(crate) fn set_ivec2(&self, gl: &glow::Context, name: &str, v: [i32; 2]) {
        // SAFETY: as set_i32.
        unsafe { gl.uniform_2_i32(self.uniform(name), v[0], v[1]) };
    }

    /// Sets a `float` uniform of the bound program.
    pub(crate) fn set_f32(&self, gl: &glow::Context, name: &str, v: f32) {
        // SAFETY: as set_i32.
        unsafe { gl.uniform_1_f32(self.uniform(name), v) };
    }

    /// Deletes the program.
    pub(crate) fn delete(&self, gl: &glow::Context) {
        // SAFETY: the program belongs to this context and is not used again.
        unsafe { gl.delete_program(self.raw) };
    }
}

/// An RGBA32F 2D texture array, sampled only with `texelFetch` (no filtering, no wrapping: edges
/// are handled in the shaders).
#[derive(Debug)]
pub(crate) struct TextureArray {
    pub(crate) raw: glow::Texture,
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) layers: u32,
}

fn to_i32(v: u32, what: &str) -> Result<i32> {
    i32::try_from(v).map_err(|_| GlowError::InvalidInput(format!("{what} {v} exceeds i32")))
}

impl TextureArray {
    /// Allocates `width × height × layers` RGBA32F texels (contents undefined until written).
    pub(crate) fn new(
        gl: &glow::Context,
        label: &str,
        width: u32,
        height: u32,
        layers: u32,
    ) -> Result<Self> {
        if width == 0 || height == 0 || layers == 0 {
            return Err(GlowError::InvalidInput(format!(
                "texture `{label}`: empty size {width}×{height}×{layers}"
            )));
        }
        // SAFETY: allocation with immutable storage on a current context; sizes checked above
        // and against the limits by the caller.
        let raw = unsafe {
            let raw = gl.create_texture().map_err(|log| GlowError::NoContext {
                reason: format!("glCreateTexture for `{label}`: {log}"),
            })?;
            gl.bind_texture(glow::TEXTURE_2D_ARRAY, Some(raw));
            for (p, v) in [
                (glow::TEXTURE_MIN_FILTER, glow::NEAREST),
                (glow::TEXTURE_MAG_FILTER, glow::NEAREST),
                (glow::TEXTURE_WRAP_S, glow::CLAMP_TO_EDGE),
                (glow::TEXTURE_WRAP_T, glow::CLAMP_TO_EDGE),
            ] {
                gl.tex_parameter_i32(glow::TEXTURE_2D_ARRAY, p, v as i32);
            }
            gl.tex_storage_3d(
                glow::TEXTURE_2D_ARRAY,
                1,
                glow::RGBA32F,
                to_i32(width, "width")?,
                to_i32(height, "height")?,
                to_i32(layers, "layers")?,
            );
            gl.bind_texture(glow::TEXTURE_2D_ARRAY, None);
            raw
        };
        check(gl, label, "allocating an RGBA32F texture array")?;
        Ok(Self {
            raw,
            width,
            height,
            layers,
        })
    }

    fn check_layer(&self, layer: u32) -> Result<()> {
        if layer >= self.layers {
            return Err(GlowError::InvalidInput(format!(
                "layer {layer} of a {}-layer texture",
                self.layers
            )));
        }
        Ok(())
    }

    /// Uploads whole layers from `first_layer` on: a multiple of `width * height * 4` floats,
    /// layer after layer, row 0 first.
    pub(crate) fn upload(
        &self,
        gl: &glow::Context,
        label: &str,
        first_layer: u32,
        texels: &[f32],
    ) -> Result<()> {
        let per_layer = self.width as usize * self.height as usize * 4;
        let count = texels.len() / per_layer;
        let fits = u32::try_from(count)
            .ok()
            .and_then(|c| c.checked_add(first_layer))
            .is_some_and(|end| end <= self.layers);
        if !texels.len().is_multiple_of(per_layer) || count == 0 || !fits {
            return Err(GlowError::InvalidInput(format!(
                "upload to `{label}` from layer {first_layer}: {} floats is not 1..={} layers of \
                 {per_layer}",
                texels.len(),
                self.layers.saturating_sub(first_layer)
            )));
        }
        let bytes: Vec<u8> = texels.iter().flat_map(|v| v.to_ne_bytes()).collect();
        // SAFETY: the byte slice holds exactly `count` layers that fit the texture (checked
        // above); unpack alignment 4 matches f32 rows.
        unsafe {
            gl.bind_texture(glow::TEXTURE_2D_ARRAY, Some(self.raw));
            gl.pixel_store_i32(glow::UNPACK_ALIGNMENT, 4);
            gl.tex_sub_image_3d(
                glow::TEXTURE_2D_ARRAY,
                0,
                0,
                0,
                to_i32(first_layer, "layer")?,
                to_i32(self.width, "width")?,
                to_i32(self.height, "height")?,
                to_i32(count as u32, "layers")?,
                glow::RGBA,
                glow::FLOAT,
                glow::PixelUnpackData::Slice(Some(&bytes)),
            );
            gl.bind_texture(glow::TEXTURE_2D_ARRAY, None);
        }
        check(gl, label, "uploading texture layers")
    }

    /// Deletes the texture.
    pub(crate) fn delete(&self, gl: &glow::Context) {
        // SAFETY: the texture belongs to this context and is not used again.
        unsafe { gl.delete_texture(self.raw) };
    }
}

/// One framebuffer object, re-pointed at whichever texture layer a pass renders into.
/// Most colour attachments a draw writes (WebGL2 guarantees 4 colour attachments and draw
/// buffers).
pub(crate) const MAX_ATTACHMENTS: usize = 4;

#[derive(Debug)]
pub(crate) struct Target {
    fbo: glow::Framebuffer,
    vao: glow::VertexArray,
}

impl Target {
    /// Creates the framebuffer and the empty vertex array the full-screen triangle needs.
    pub(crate) fn new(gl: &glow::Context) -> Result<Self> {
        // SAFETY: object creation on a current context.
        unsafe {
            let fbo = gl
                .create_framebuffer()
                .map_err(|log| GlowError::NoContext {
                    reason: format!("glCreateFramebuffer: {log}"),
                })?;
            let vao = gl
                .create_vertex_array()
                .map_err(|log| GlowError::NoContext {
                    reason: format!("glCreateVertexArray: {log}"),
                })?;
            Ok(Self { fbo, vao })
        }
    }

    /// Attaches `layer` of `tex` as colour attachment 0 and checks completeness.
    pub(crate) fn bind(
        &self,
        gl: &glow::Context,
        pass: &str,
        tex: &TextureArray,
        layer: u32,
    ) -> Result<()> {
        self.bind_layers(gl, pass, tex, &[layer])
    }

    /// Attaches `layers` of `tex` (at most [`MAX_ATTACHMENTS`]) as colour attachments 0, 1, …
    /// (fragment outputs at locations 0, 1, …), detaches the others, and checks completeness.
    pub(crate) fn bind_layers(
        &self,
        gl: &glow::Context,
        pass: &str,
        tex: &TextureArray,
        layers: &[u32],
    ) -> Result<()> {
        if layers.is_empty() || layers.len() > MAX_ATTACHMENTS {
            return Err(GlowError::InvalidInput(format!(
                "pass `{pass}`: {} colour attachments (1 to {MAX_ATTACHMENTS})",
                layers.len()
            )));
        }
        for &layer in layers {
            tex.check_layer(layer)?;
        }
        let attachments: Vec<u32> = (0..layers.len() as u32)
            .map(|i| glow::COLOR_ATTACHMENT0 + i)
            .collect();
        // SAFETY: attaching existing texture layers to our framebuffer, detaching the rest.
        unsafe {
            gl.bind_framebuffer(glow::FRAMEBUFFER, Some(self.fbo));
            for i in 0..MAX_ATTACHMENTS {
                let (texture, layer) = match layers.get(i) {
                    Some(&l) => (Some(tex.raw), to_i32(l, "layer")?),
                    None => (None, 0),
                };
                gl.framebuffer_texture_layer(
                    glow::FRAMEBUFFER,
                    glow::COLOR_ATTACHMENT0 + i as u32,
                    texture,
                    0,
                    layer,
                );
            }
            gl.draw_buffers(&attachments);
            let status = gl.check_framebuffer_status(glow::FRAMEBUFFER);
            if status != glow::FRAMEBUFFER_COMPLETE {
                return Err(GlowError::Framebuffer {
                    pass: pass.to_owned(),
                    status,
                });
            }
        }
        check(gl, pass, "attaching texture layers")
    }

    /// Draws the full-screen triangle with `program` (already bound, uniforms set) into the
    /// bound layer, restricted to the rectangle `[x, y, w, h]` in texels.
    pub(crate) fn draw(&self, gl: &glow::Context, pass: &str, rect: [u32; 4]) -> Result<()> {
        let [x, y, w, h] = rect;
        // SAFETY: a draw of three vertices with no attributes into the bound framebuffer.
        unsafe {
            gl.bind_vertex_array(Some(self.vao));
            gl.disable(glow::BLEND);
            gl.disable(glow::DEPTH_TEST);
            gl.enable(glow::SCISSOR_TEST);
            gl.viewport(0, 0, to_i32(x + w, "x")?, to_i32(y + h, "y")?);
            gl.scissor(
                to_i32(x, "x")?,
                to_i32(y, "y")?,
                to_i32(w, "w")?,
                to_i32(h, "h")?,
            );
            gl.draw_arrays(glow::TRIANGLES, 0, 3);
            gl.disable(glow::SCISSOR_TEST);
            gl.bind_vertex_array(None);
        }
        check(gl, pass, "drawing")
    }

    /// Clears the rectangle `[x, y, w, h]` (texels) of the bound layer to zero.
    pub(crate) fn clear(&self, gl: &glow::Context, pass: &str, rect: [u32; 4]) -> Result<()> {
        let [x, y, w, h] = rect;
        // SAFETY: a scissored clear of colour attachment 0 of the bound, complete framebuffer.
        unsafe {
            gl.enable(glow::SCISSOR_TEST);
            gl.scissor(
                to_i32(x, "x")?,
                to_i32(y, "y")?,
                to_i32(w, "w")?,
                to_i32(h, "h")?,
            );
            gl.clear_buffer_f32_slice(glow::COLOR, 0, &[0.0; 4]);
            gl.disable(glow::SCISSOR_TEST);
        }
        check(gl, pass, "clearing")
    }

    /// Reads one whole layer back: `width * height * 4` floats, row 0 first.
    pub(crate) fn read(
        &self,
        gl: &glow::Context,
        label: &str,
        tex: &TextureArray,
        layer: u32,
    ) -> Result<Vec<f32>> {
        self.bind(gl, label, tex, layer)?;
        let n = tex.width as usize * tex.height as usize * 4;
        let mut bytes = vec![0u8; n * 4];
        // SAFETY: the buffer holds exactly width × height RGBA f32 texels; RGBA/FLOAT is always a
        // valid read format for an RGBA32F attachment (EXT_color_buffer_float).
        unsafe {
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            gl.read_buffer(glow::COLOR_ATTACHMENT0);
            gl.read_pixels(
                0,
                0,
                to_i32(tex.width, "width")?,
                to_i32(tex.height, "height")?,
                glow::RGBA,
                glow::FLOAT,
                glow::PixelPackData::Slice(Some(&mut bytes)),
            );
        }
        check(gl, label, "reading a texture layer back")?;
        Ok(bytes
            .chunks_exact(4)
            .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }

    /// Reads texel `at` of the bound target back: the caller waits until the GPU has drawn it
    /// (WebGL's `finish` need not wait).
    #[cfg(target_arch = "wasm32")]
    pub(crate) fn wait(&self, gl: &glow::Context, label: &str, at: [u32; 2]) -> Result<()> {
        let mut bytes = [0u8; 16];
        // SAFETY: the buffer holds one RGBA f32 texel; RGBA/FLOAT is a valid read format for
        // an RGBA32F attachment (EXT_color_buffer_float).
        unsafe {
            gl.pixel_store_i32(glow::PACK_ALIGNMENT, 4);
            gl.read_buffer(glow::COLOR_ATTACHMENT0);
            gl.read_pixels(
                to_i32(at[0], "x")?,
                to_i32(at[1], "y")?,
                1,
                1,
                glow::RGBA,
                glow::FLOAT,
                glow::PixelPackData::Slice(Some(&mut bytes)),
            );
        }
        check(gl, label, "waiting for a tile")
    }

    /// Deletes the framebuffer and vertex array.
    pub(crate) fn delete(&self, gl: &glow::Context) {
        // SAFETY: both objects belong to this context and are not used again.
        unsafe {
            gl.delete_framebuffer(self.fbo);
            gl.delete_vertex_array(self.vao);
        }
    }
}

#[cfg(test)]
mod tests {
    use glow::HasContext;

    use super::{Program, Target, TextureArray};
    use crate::GlowError;
    use crate::testutil::{context_or_skip, with_gl};

    const PATTERN_FS: &str = "uniform int u_layer;\n\
        out vec4 o;\n\
        void main() {\n\
            vec2 p = floor(gl_FragCoord.xy);\n\
            o = vec4(p.x * 1.5 + 0.25, -p.y / 3.0, float(u_layer) + 0.125, 1.0e-30 * (p.x + 1.0));\n\
        }\n";

    fn pattern(x: u32, y: u32, layer: u32) -> [f32; 4] {
        let (px, py) = (x as f32, y as f32);
        [
            px * 1.5 + 0.25,
            -py / 3.0,
            layer as f32 + 0.125,
            1.0e-30 * (px + 1.0),
        ]
    }

    #[test]
    fn renders_into_array_layers_and_reads_back_exactly() {
        with_gl("renders_into_array_layers_and_reads_back_exactly", |gl| {
            let (w, h, layers) = (37, 23, 3);
            let tex = TextureArray::new(gl, "test", w, h, layers).unwrap();
            let target = Target::new(gl).unwrap();
            let program = Program::new(gl, "pattern", "", &[PATTERN_FS]).unwrap();
            // Layer 1 stays as uploaded, layers 0 and 2 are rendered, layer 2 in two tiles.
            let uploaded: Vec<f32> = (0..w * h * 4).map(|i| i as f32 * 0.37 - 11.0).collect();
            tex.upload(gl, "test", 1, &uploaded).unwrap();
            for (layer, tiles) in [
                (0u32, vec![[0, 0, w, h]]),
                (2, vec![[0, 0, w, 10], [0, 10, w, 13]]),
            ] {
                target.bind(gl, "pattern", &tex, layer).unwrap();
                // SAFETY: binding the program just linked and setting its one uniform.
                unsafe {
                    gl.use_program(Some(program.raw));
                    gl.uniform_1_i32(program.uniform("u_layer"), layer as i32);
                }
                for rect in tiles {
                    target.draw(gl, "pattern", rect).unwrap();
                }
            }
            for layer in 0..layers {
                let back = target.read(gl, "test", &tex, layer).unwrap();
                if layer == 1 {
                    assert_eq!(back, uploaded);
                    continue;
                }
                for y in 0..h {
                    for x in 0..w {
                        let i = ((y * w + x) * 4) as usize;
                        assert_eq!(
                            back[i..i + 4],
                            pattern(x, y, layer),
                            "texel ({x}, {y}) layer {layer}"
                        );
                    }
                }
            }
            program.delete(gl);
            target.delete(gl);
            tex.delete(gl);
        });
    }

    #[test]
    fn compile_errors_name_the_pass_and_carry_the_log() {
        with_gl("compile_errors_name_the_pass_and_carry_the_log", |gl| {
            let err = Program::new(
                gl,
                "broken pass",
                "",
                &["out vec4 o; void main() { o = nope; }"],
            )
            .unwrap_err();
            assert!(
                matches!(
                    err,
                    GlowError::Compile {
                        stage: "fragment",
                        ..
                    }
                ),
                "{err}"
            );
            let msg = err.to_string();
            assert!(msg.contains("broken pass") && msg.contains("nope"), "{msg}");
        });
    }

    #[test]
    fn more_than_sixteen_textures_per_pass_is_an_error() {
        with_gl("more_than_sixteen_textures_per_pass_is_an_error", |gl| {
            let tex = TextureArray::new(gl, "t", 1, 1, 1).unwrap();
            let program = Program::new(gl, "units", "", &[PATTERN_FS]).unwrap();
            let names: Vec<String> = (0..17).map(|i| format!("u_t{i}")).collect();
            let samplers: Vec<(&str, &TextureArray)> =
                names.iter().map(|n| (n.as_str(), &tex)).collect();
            assert!(program.use_with(gl, "units", &samplers[..16]).is_ok());
            let err = program.use_with(gl, "units", &samplers).unwrap_err();
            assert!(
                matches!(
                    err,
                    GlowError::Limit {
                        requested: 17,
                        allowed: 16,
                        ..
                    }
                ),
                "{err}"
            );
            program.delete(gl);
            tex.delete(gl);
        });
    }

    #[test]
    fn gl_errors_name_the_pass_and_the_error() {
        with_gl("gl_errors_name_the_pass_and_the_error", |gl| {
            assert!(super::check(gl, "clean", "nothing").is_ok());
            // SAFETY: an invalid enum only sets the error flag.
            unsafe { gl.enable(0xFFFF) };
            let err = super::check(gl, "some pass", "enabling").unwrap_err();
            let msg = err.to_string();
            assert!(
                msg.contains("some pass") && msg.contains("GL_INVALID_ENUM"),
                "{msg}"
            );
            // The flag is drained: the next check sees no stale error.
            assert!(super::check(gl, "clean", "nothing").is_ok());
        });
    }

    #[test]
    fn capabilities_meet_webgl2_minimums() {
        let Some(ctx) = context_or_skip("capabilities_meet_webgl2_minimums") else {
            return;
        };
        let caps = ctx.capabilities();
        eprintln!("{caps:?}");
        assert!(caps.max_texture_size >= crate::webgl2::TEXTURE_SIZE);
        assert_eq!(caps.max_array_layers, crate::webgl2::ARRAY_LAYERS);
        assert_eq!(caps.texture_units, crate::webgl2::TEXTURE_UNITS);
    }
}
