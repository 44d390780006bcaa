//! The static scene data on the GPU: the paper's BVH and geometry data textures.

use luxbake_bvh::{EncodedScene, layout};

use crate::error::{GlowError, Result};
use crate::gl::{Program, TextureArray};
use crate::shaders::Traversal;

/// The encoded BVH as RGBA32F texture arrays, exactly the texels of [`EncodedScene`]: node
/// links (6-layer MTBVH array and 1-layer TBVH array), node bounds (2 layers), triangle data
/// (8 layers).
#[derive(Debug)]
pub(crate) struct BvhTextures {
    links: TextureArray,
    tbvh_links: TextureArray,
    bounds: TextureArray,
    triangles: TextureArray,
    node_count: i32,
    triangle_count: i32,
}

fn count(v: u32, what: &str) -> Result<i32> {
    i32::try_from(v).map_err(|_| GlowError::InvalidInput(format!("{what} {v} exceeds i32")))
}

impl BvhTextures {
    /// Uploads `scene`'s textures.
    pub(crate) fn upload(gl: &glow::Context, scene: &EncodedScene) -> Result<Self> {
        let [nw, nh] = scene.node_size;
        let [tw, th] = scene.tri_size;
        let make = |label: &str, w, h, layers, data: &[f32]| -> Result<TextureArray> {
            let t = TextureArray::new(gl, label, w, h, layers)?;
            t.upload(gl, label, 0, data)?;
            Ok(t)
        };
        Ok(Self {
            links: make("bvh_links", nw, nh, layout::LINK_LAYERS, &scene.links)?,
            tbvh_links: make(
                "bvh_tbvh_links",
                nw,
                nh,
                layout::TBVH_LINK_LAYERS,
                &scene.tbvh_links,
            )?,
            bounds: make("bvh_bounds", nw, nh, layout::BOUNDS_LAYERS, &scene.bounds)?,
            triangles: make(
                "bvh_triangles",
                tw,
                th,
                layout::TRIANGLE_LAYERS,
                &scene.triangles,
            )?,
            node_count: count(scene.node_count, "node count")?,
            triangle_count: count(scene.triangle_count, "triangle count")?,
        })
    }

    /// The sampler bindings `bvh.glsl` declares for `traversal`.
    pub(crate) fn samplers(&self, traversal: Traversal) -> Vec<(&'static str, &TextureArray)> {
        let links = match traversal {
            Traversal::Mtbvh => &self.links,
            Traversal::Tbvh => &self.tbvh_links,
            Traversal::None => return vec![("u_triangles", &self.triangles)],
        };
        vec![
            ("u_triangles", &self.triangles),
            ("u_bounds", &self.bounds),
            ("u_links", links),
        ]
    }

    /// Sets the counts `bvh.glsl` declares (the program must be bound).
    pub(crate) fn set_uniforms(&self, gl: &glow::Context, program: &Program) {
        program.set_i32(gl, "u_node_count", self.node_count);
        program.set_i32(gl, "u_triangle_count", self.triangle_count);
    }

    /// Deletes the textures.
    pub(crate) fn delete(&self, gl: &glow::Context) {
        for t in [&self.links, &self.tbvh_links, &self.bounds, &self.triangles] {
            t.delete(gl);
        }
    }
}
