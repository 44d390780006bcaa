//! The static scene data on the GPU (bind group 1 of the ray-casting passes): the encoded BVH
//! (storage buffers or texture arrays, [`BvhStorage`]), the intensity tables, the light-map
//! regions, the scene constants and the lamps, packed by `luxbake::pack` (as for the glow
//! backend) at the bindings of `luxbake::shader::wgsl`.

use luxbake::backend::SceneData;
use luxbake::pack;
use luxbake::shader::wgsl;
use luxbake_bvh::{EncodedScene, layout};
use wgpu::util::DeviceExt;

use crate::device::Gpu;
use crate::error::{Result, WgpuError};
use crate::shaders::BvhStorage;

/// Bytes of the `LuxScene` uniform block (`scene.wgsl`).
pub(crate) const SCENE_UNIFORM_BYTES: u64 = 48;
/// Bytes of one `LuxLamp` (`scene.wgsl`): six vec4.
const LAMP_BYTES: usize = 16 * pack::LAMP_ROWS;

/// Everything `upload_scene` put on the GPU.
#[derive(Debug)]
pub(crate) struct GpuScene {
    /// Bind group 1 with the MTBVH links.
    pub(crate) mtbvh: wgpu::BindGroup,
    /// Bind group 1 with the TBVH links (also used by brute force, which reads no links).
    pub(crate) tbvh: wgpu::BindGroup,
    pub(crate) layer_size: [u32; 2],
}

/// f32 words as bytes (little-endian, as every wgpu target is).
pub(crate) fn bytes_of(words: &[f32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

pub(crate) fn u32_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// A read-only storage buffer holding `data` (at least 16 bytes: empty arrays are padded).
fn storage(gpu: &Gpu, label: &str, mut data: Vec<u8>) -> Result<wgpu::Buffer> {
    if data.len() < 16 {
        data.resize(16, 0);
    }
    let max = gpu.limits.max_storage_buffer_binding_size;
    if data.len() as u64 > max {
        return Err(WgpuError::Limit {
            what: "storage buffer binding size, bytes",
            requested: data.len() as u64,
            allowed: max,
        });
    }
    gpu.scoped(label, || {
        gpu.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: &data,
                usage: wgpu::BufferUsages::STORAGE,
            })
    })
}

/// One encoded BVH array as `layers` layers of a `size` texture array.
fn data_texture(
    gpu: &Gpu,
    label: &str,
    size: [u32; 2],
    layers: u32,
    data: &[f32],
) -> Result<wgpu::TextureView> {
    let max = gpu.limits.max_texture_dimension_2d;
    if size[0].max(size[1]) > max {
        return Err(WgpuError::Limit {
            what: "BVH data texture size",
            requested: size[0].max(size[1]).into(),
            allowed: max.into(),
        });
    }
    let expected = 4 * size[0] as usize * size[1] as usize * layers as usize;
    if data.len() != expected {
        return Err(WgpuError::InvalidInput(format!(
            "{label}: {} floats for a {size:?} × {layers} texture",
            data.len()
        )));
    }
    gpu.scoped(label, || {
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: layers,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        gpu.queue.write_texture(
            texture.as_image_copy(),
            &bytes_of(data),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(16 * size[0]),
                rows_per_image: Some(size[1]),
            },
            texture.size(),
        );
        texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    })
}

/// The three BVH bindings (bounds, links, triangles) in one of the two storages.
enum BvhData {
    Buffers {
        bounds: wgpu::Buffer,
        links: wgpu::Buffer,
        tbvh_links: wgpu::Buffer,
        triangles: wgpu::Buffer,
    },
    /// Bounds, MTBVH links, TBVH links, triangles.
    Textures(Box<[wgpu::TextureView; 4]>),
}

impl BvhData {
    fn upload(gpu: &Gpu, bvh: &EncodedScene, storage_kind: BvhStorage) -> Result<BvhData> {
        Ok(match storage_kind {
            BvhStorage::Buffers => BvhData::Buffers {
                bounds: storage(gpu, "bvh_bounds", bytes_of(&bvh.bounds))?,
                links: storage(gpu, "bvh_links", bytes_of(&bvh.links))?,
                tbvh_links: storage(gpu, "bvh_tbvh_links", bytes_of(&bvh.tbvh_links))?,
                triangles: storage(gpu, "bvh_triangles", bytes_of(&bvh.triangles))?,
            },
            BvhStorage::Textures => BvhData::Textures(Box::new([
                data_texture(
                    gpu,
                    "bvh_bounds",
                    bvh.node_size,
                    layout::BOUNDS_LAYERS,
                    &bvh.bounds,
                )?,
                data_texture(
                    gpu,
                    "bvh_links",
                    bvh.node_size,
                    layout::LINK_LAYERS,
                    &bvh.links,
                )?,
                data_texture(
                    gpu,
                    "bvh_tbvh_links",
                    bvh.node_size,
                    layout::TBVH_LINK_LAYERS,
                    &bvh.tbvh_links,
                )?,
                data_texture(
                    gpu,
                    "bvh_triangles",
                    bvh.tri_size,
                    layout::TRIANGLE_LAYERS,
                    &bvh.triangles,
                )?,
            ])),
        })
    }

    /// Bindings 0–2 with the MTBVH (`mtbvh`) or TBVH links.
    fn entries(&self, mtbvh: bool) -> [wgpu::BindGroupEntry<'_>; 3] {
        let e = |binding, resource| wgpu::BindGroupEntry { binding, resource };
        match self {
            BvhData::Buffers {
                bounds,
                links,
                tbvh_links,
                triangles,
            } => [
                e(wgsl::BOUNDS_BINDING, bounds.as_entire_binding()),
                e(
                    wgsl::LINKS_BINDING,
                    if mtbvh { links } else { tbvh_links }.as_entire_binding(),
                ),
                e(wgsl::TRIANGLES_BINDING, triangles.as_entire_binding()),
            ],
            BvhData::Textures(views) => {
                let [bounds, links, tbvh_links, triangles] = views.as_ref();
                [
                    e(
                        wgsl::BOUNDS_BINDING,
                        wgpu::BindingResource::TextureView(bounds),
                    ),
                    e(
                        wgsl::LINKS_BINDING,
                        wgpu::BindingResource::TextureView(if mtbvh { links } else { tbvh_links }),
                    ),
                    e(
                        wgsl::TRIANGLES_BINDING,
                        wgpu::BindingResource::TextureView(triangles),
                    ),
                ]
            }
        }
    }
}

fn count(v: u32, what: &str) -> Result<i32> {
    i32::try_from(v).map_err(|_| WgpuError::InvalidInput(format!("{what} {v} exceeds i32")))
}

impl GpuScene {
    /// Uploads the BVH, the intensity tables, the regions and the constants of `scene`.
    pub(crate) fn upload(
        gpu: &Gpu,
        layout: &wgpu::BindGroupLayout,
        storage_kind: BvhStorage,
        scene: &SceneData<'_>,
    ) -> Result<GpuScene> {
        for (i, l) in scene.lamps.iter().enumerate() {
            if l.table as usize >= scene.ies_tables.len() {
                return Err(WgpuError::InvalidInput(format!(
                    "lamp {i} refers to intensity table {}, but {} were uploaded",
                    l.table,
                    scene.ies_tables.len()
                )));
            }
        }
        let bvh = BvhData::upload(gpu, &scene.bvh.encoded, storage_kind)?;
        let ies = storage(gpu, "ies_tables", bytes_of(&pack::ies_values(scene)))?;
        let regions: Vec<u32> = pack::region_rows(scene.regions)
            .iter()
            .flatten()
            .flatten()
            .copied()
            .collect();
        let mut lamps: Vec<u8> = pack::lamp_rows(scene)
            .iter()
            .flat_map(|l| u32_bytes(&l.words()))
            .collect();
        // An empty array still binds one (zero) lamp: a binding is never smaller than its
        // element.
        lamps.resize(lamps.len().max(LAMP_BYTES), 0);
        let lamps = storage(gpu, "lamps", lamps)?;
        // At least one (zero) point: a binding is never smaller than its element.
        let mut lamp_paths = bytes_of(scene.lamp_paths);
        lamp_paths.resize(
            lamp_paths
                .len()
                .max(4 * 4 * luxbake::backend::LAMP_PATH_TEXELS),
            0,
        );
        let lamp_paths = storage(gpu, "lamp paths", lamp_paths)?;
        let regions = storage(gpu, "regions", u32_bytes(&regions))?;
        let objects = u32::try_from(scene.regions.len())
            .map_err(|_| WgpuError::InvalidInput("too many objects".into()))?;
        let words: [u32; 12] = [
            scene.bvh.encoded.node_size[0],
            scene.bvh.encoded.node_size[1],
            scene.bvh.encoded.tri_size[0],
            scene.bvh.encoded.tri_size[1],
            count(scene.bvh.encoded.node_count, "node count")? as u32,
            count(scene.bvh.encoded.triangle_count, "triangle count")? as u32,
            count(objects, "object count")? as u32,
            0,
            scene.ray_epsilon.to_bits(),
            f32::INFINITY.to_bits(),
            0,
            0,
        ];
        let uniform = gpu.scoped("scene constants", || {
            gpu.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("scene constants"),
                    contents: &u32_bytes(&words),
                    usage: wgpu::BufferUsages::UNIFORM,
                })
        })?;
        let group = |mtbvh: bool| {
            let [b0, b1, b2] = bvh.entries(mtbvh);
            gpu.scoped("scene bind group", || {
                gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("scene"),
                    layout,
                    entries: &[
                        b0,
                        b1,
                        b2,
                        wgpu::BindGroupEntry {
                            binding: wgsl::IES_BINDING,
                            resource: ies.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: wgsl::REGIONS_BINDING,
                            resource: regions.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: wgsl::SCENE_BINDING,
                            resource: uniform.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: wgsl::LAMPS_BINDING,
                            resource: lamps.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: wgsl::LAMP_PATHS_BINDING,
                            resource: lamp_paths.as_entire_binding(),
                        },
                    ],
                })
            })
        };
        Ok(GpuScene {
            mtbvh: group(true)?,
            tbvh: group(false)?,
            layer_size: scene.layer_size,
        })
    }
}
