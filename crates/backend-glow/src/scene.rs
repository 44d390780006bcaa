//! The static scene data on the GPU: the paper's BVH and geometry data textures, the lamps'
//! intensity tables and the light-map regions, all RGBA32F texture arrays read with
//! `texelFetch`.

use luxbake::backend::SceneData;
use luxbake::lightpaths::{DensityProxy, PROXY_NODES};
use luxbake::pack;
use luxbake_bvh::{EncodedScene, layout};
use luxbake_ies::GpuTable;

use crate::context::Capabilities;
use crate::error::{GlowError, Result};
use crate::gl::{Program, TextureArray};
use luxbake::scene::BvhMode;

/// Everything `upload_scene` put on the GPU.
#[derive(Debug)]
pub(crate) struct GpuScene {
    pub(crate) bvh: BvhTextures,
    /// One layer per intensity table, four table columns per texel, its density proxy's rows
    /// below (see `ies.glsl`).
    pub(crate) ies: TextureArray,
    /// One column per object id: (layer, offset.x, offset.y, receiver), (width, height, 0, 0).
    pub(crate) regions: TextureArray,
    /// One column per uploaded lamp, `pack::LAMP_ROWS` rows.
    pub(crate) lamps: TextureArray,
    /// The lamp paths' points ([`SceneData::lamp_paths`]).
    pub(crate) lamp_paths: TextureArray,
    pub(crate) layer_size: [u32; 2],
    pub(crate) ray_epsilon: f32,
}

fn checked_size(caps: &Capabilities, what: &'static str, v: usize) -> Result<u32> {
    match u32::try_from(v) {
        Ok(v) if v <= caps.max_texture_size => Ok(v.max(1)),
        _ => Err(GlowError::Limit {
            what,
            requested: v as u64,
            allowed: caps.max_texture_size.into(),
        }),
    }
}

/// The IES tables as one texture array (layer = table index): the table's rows, then in the
/// rows below them (from row `height` on) its [`DensityProxy`]'s `PROXY_NODES` rows.
pub(crate) fn ies_texture(
    gl: &glow::Context,
    caps: &Capabilities,
    tables: &[GpuTable],
) -> Result<TextureArray> {
    let nodes = PROXY_NODES as usize;
    let texels_wide = |t: &GpuTable| (t.width as usize).div_ceil(4).max(nodes.div_ceil(4));
    let w = checked_size(
        caps,
        "IES table width / 4",
        tables.iter().map(texels_wide).max().unwrap_or(1),
    )?;
    let h = checked_size(
        caps,
        "IES table height with its density proxy",
        tables
            .iter()
            .map(|t| t.height as usize + nodes)
            .max()
            .unwrap_or(1),
    )?;
    let layers = u32::try_from(tables.len().max(1))
        .ok()
        .filter(|&l| l <= caps.max_array_layers)
        .ok_or(GlowError::Limit {
            what: "intensity tables (texture array layers)",
            requested: tables.len() as u64,
            allowed: caps.max_array_layers.into(),
        })?;
    let tex = TextureArray::new(gl, "ies_tables", w, h, layers)?;
    for (layer, t) in tables.iter().enumerate() {
        let mut data = vec![0.0f32; w as usize * h as usize * 4];
        for (row, values) in t
            .values
            .chunks(t.width.max(1) as usize)
            .take(t.height as usize)
            .enumerate()
        {
            let start = row * w as usize * 4;
            data[start..start + values.len()].copy_from_slice(values);
        }
        let proxy = DensityProxy::new(t);
        for (row, values) in proxy.values.chunks(nodes).enumerate() {
            let start = (t.height as usize + row) * w as usize * 4;
            data[start..start + values.len()].copy_from_slice(values);
        }
        tex.upload(gl, "ies_tables", layer as u32, &data)?;
    }
    Ok(tex)
}

impl GpuScene {
    /// Uploads the BVH, the intensity tables and the regions of `scene`.
    pub(crate) fn upload(
        gl: &glow::Context,
        caps: &Capabilities,
        scene: &SceneData<'_>,
    ) -> Result<Self> {
        for (i, l) in scene.lamps.iter().enumerate() {
            if l.table as usize >= scene.ies_tables.len() {
                return Err(GlowError::InvalidInput(format!(
                    "lamp {i} refers to intensity table {}, but {} were uploaded",
                    l.table,
                    scene.ies_tables.len()
                )));
            }
        }
        for (what, v) in [
            (
                "BVH node texture size",
                scene.bvh.encoded.node_size[0].max(scene.bvh.encoded.node_size[1]),
            ),
            (
                "BVH triangle texture size",
                scene.bvh.encoded.tri_size[0].max(scene.bvh.encoded.tri_size[1]),
            ),
        ] {
            checked_size(caps, what, v as usize)?;
        }
        let bvh = BvhTextures::upload(gl, &scene.bvh.encoded)?;
        let ies = ies_texture(gl, caps, scene.ies_tables)?;
        let n = checked_size(caps, "objects (region texture width)", scene.regions.len())?;
        let mut data = vec![0.0f32; n as usize * 2 * 4];
        for (i, rows) in pack::region_rows(scene.regions).iter().enumerate() {
            for (row, words) in rows.iter().enumerate() {
                let at = (row * n as usize + i) * 4;
                data[at..at + 4].copy_from_slice(&words.map(|v| v as f32));
            }
        }
        let regions = TextureArray::new(gl, "regions", n, 2, 1)?;
        regions.upload(gl, "regions", 0, &data)?;
        let lamps = lamp_texture(gl, caps, &pack::lamp_rows(scene))?;
        let lamp_paths = lamp_path_texture(gl, caps, scene.lamp_paths)?;
        Ok(Self {
            bvh,
            ies,
            regions,
            lamps,
            lamp_paths,
            layer_size: scene.layer_size,
            ray_epsilon: scene.ray_epsilon,
        })
    }

    pub(crate) fn delete(&self, gl: &glow::Context) {
        self.bvh.delete(gl);
        self.ies.delete(gl);
        self.regions.delete(gl);
        self.lamps.delete(gl);
        self.lamp_paths.delete(gl);
    }
}

/// Texels per row of the lamp paths' texture (a WebGL2 texture is at least 2048 wide).
const LAMP_PATH_WIDTH: usize = 1024;

/// The lamp paths' points ([`SceneData::lamp_paths`]) as a texture, texel `i` at
/// `(i % width, i / width)`: [`LAMP_PATH_WIDTH`] wide (or narrower for fewer texels), at
/// least one texel (zero) when there are none.
fn lamp_path_texture(
    gl: &glow::Context,
    caps: &Capabilities,
    floats: &[f32],
) -> Result<TextureArray> {
    let texels = (floats.len() / 4).max(1);
    let width = texels.min(LAMP_PATH_WIDTH);
    let height = texels.div_ceil(width);
    let (w, h) = (
        checked_size(caps, "lamp paths (texture width)", width)?,
        checked_size(caps, "lamp paths (texture height)", height)?,
    );
    let mut data = vec![0.0f32; 4 * width * height];
    data[..floats.len() / 4 * 4].copy_from_slice(&floats[..floats.len() / 4 * 4]);
    let tex = TextureArray::new(gl, "lamp paths", w, h, 1)?;
    tex.upload(gl, "lamp paths", 0, &data)?;
    Ok(tex)
}

/// The uploaded lamps as a texture: one column per lamp, its [`pack::LAMP_ROWS`] rows as
/// packed by [`pack::lamp_rows`].
fn lamp_texture(
    gl: &glow::Context,
    caps: &Capabilities,
    lamps: &[pack::LampRows],
) -> Result<TextureArray> {
    let n = lamps.len().max(1);
    let width = checked_size(caps, "lamps (lamp texture width)", n)?;
    let mut data = vec![0.0f32; n * pack::LAMP_ROWS * 4];
    for (i, l) in lamps.iter().enumerate() {
        for (row, v) in l.floats().iter().enumerate() {
            let at = (row * n + i) * 4;
            data[at..at + 4].copy_from_slice(v);
        }
    }
    let tex = TextureArray::new(gl, "lamps", width, pack::LAMP_ROWS as u32, 1)?;
    tex.upload(gl, "lamps", 0, &data)?;
    Ok(tex)
}

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

    /// The sampler bindings `bvh.glsl` declares for `traversal` (its encoded form,
    /// [`BvhMode::encoded`]).
    pub(crate) fn samplers(&self, traversal: BvhMode) -> Vec<(&'static str, &TextureArray)> {
        let links = match traversal.encoded() {
            BvhMode::Wide | BvhMode::Mtbvh => &self.links,
            BvhMode::Tbvh => &self.tbvh_links,
            BvhMode::None => return vec![("u_triangles", &self.triangles)],
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
