//! [`WgpuBackend`]: the device, its texture arrays, its pipelines, and the [`GpuBackend`]
//! implementation that runs each pass of the graph as tiled compute dispatches.

use std::collections::HashMap;

use luxbake::backend::{DEFAULT_TILE_WORK, Dispatch, GpuBackend, Limits, SceneData};
use luxbake::graph::TexDesc;
use luxbake::kept::{self, HitKey, KeptHitStats, KeptHits, Part, Uploads, Variant};
use luxbake::program::{GatherParams, ParamBlock, Program, SceneNeeds, TileParams, coarse};
use luxbake::scene::BvhMode;
use luxbake::shader::{program_traversal, wgsl, wgsl_variant};

use crate::device::Gpu;
use crate::error::{Result, WgpuError};
use crate::scene::{GpuScene, SCENE_UNIFORM_BYTES, u32_bytes};
use crate::shaders::BvhStorage;

/// Compute workgroup edge (`@workgroup_size(8, 8, 1)` in every pass).
const WORKGROUP: u32 = 8;
/// Bytes of the tile block (`LuxTile`).
const TILE_BYTES: u64 = std::mem::size_of::<TileParams>() as u64;

/// Bytes of `program`'s parameter block (0 without one).
fn params_bytes(program: Program) -> u64 {
    4 * program.signature().params.len() as u64
}

/// A texture array owned by a [`WgpuBackend`] (a handle; the backend owns the GPU object).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct WgpuTexture(usize);

/// The static scene data of a bake on the GPU (a handle; the buffers belong to the backend).
#[derive(Debug)]
pub struct WgpuScene(usize);

/// Options of [`WgpuBackend::with_options`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WgpuOptions {
    /// Backends to pick an adapter from; `None` = `WGPU_BACKEND` if set, else every backend
    /// compiled in (Vulkan in this build).
    pub backends: Option<wgpu::Backends>,
    /// Where the BVH lives on the GPU.
    pub bvh_storage: BvhStorage,
    /// Work per dispatch (see [`DEFAULT_TILE_WORK`]), at least 1.
    pub tile_work: u64,
}

impl Default for WgpuOptions {
    fn default() -> Self {
        WgpuOptions {
            backends: None,
            bvh_storage: BvhStorage::default(),
            tile_work: DEFAULT_TILE_WORK,
        }
    }
}

#[derive(Debug)]
struct Texture {
    label: String,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    size: [u32; 2],
    layers: u32,
}

/// The wgpu backend: a device, the RGBA32F texture arrays of a bake, the uploaded scene data and
/// one compute pipeline per pass kind (and traversal), created on first use.
#[derive(Debug)]
pub struct WgpuBackend {
    gpu: Gpu,
    options: WgpuOptions,
    textures: Vec<Texture>,
    scenes: Vec<GpuScene>,
    /// Per uploaded scene: the address of its BVH object and its ray offset (what kept hits
    /// are keyed by).
    scene_keys: Vec<(usize, f32)>,
    pass_layouts: HashMap<(Program, Variant), wgpu::BindGroupLayout>,
    scene_layout: wgpu::BindGroupLayout,
    pipelines: HashMap<(Program, BvhMode, Variant), wgpu::ComputePipeline>,
    tile: wgpu::Buffer,
    params: wgpu::Buffer,
    /// With kept gather hits: per texture, the hash of each layer's upload (`None` until
    /// uploaded, or once a pass writes the texture).
    uploads: Uploads,
    /// The gather hits kept from bake to bake ([`WgpuBackend::keep_gather_hits`]).
    kept: Option<KeptHits<wgpu::Buffer>>,
}

fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}

/// A buffer binding; uniform blocks state their size so wgpu checks it against the shader.
fn buffer_entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
    size: u64,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: std::num::NonZeroU64::new(size),
        },
        count: None,
    }
}

const STORAGE_RO: wgpu::BufferBindingType = wgpu::BufferBindingType::Storage { read_only: true };

/// Group 0 of `variant` of `program`: its read slots, the output, the tile, its parameter block,
/// and for the gather's trace pass and replay the kept hits' buffer.
fn variant_layout_entries(program: Program, variant: Variant) -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut entries = pass_layout_entries(program);
    let read_only = match variant {
        Variant::Plain | Variant::Idle => return entries,
        Variant::Trace => false,
        Variant::Replay => true,
    };
    entries.push(buffer_entry(
        wgsl::HITS_BINDING,
        wgpu::BufferBindingType::Storage { read_only },
        0,
    ));
    entries
}

/// Group 0 of `program`: its read slots, the output, the tile and its parameter block.
fn pass_layout_entries(program: Program) -> Vec<wgpu::BindGroupLayoutEntry> {
    let sig = program.signature();
    let mut entries: Vec<_> = (0..sig.reads.len() as u32).map(texture_entry).collect();
    entries.push(wgpu::BindGroupLayoutEntry {
        binding: wgsl::OUT_BINDING,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: wgpu::TextureFormat::Rgba32Float,
            view_dimension: wgpu::TextureViewDimension::D2Array,
        },
        count: None,
    });
    entries.push(buffer_entry(
        wgsl::TILE_BINDING,
        wgpu::BufferBindingType::Uniform,
        TILE_BYTES,
    ));
    if !sig.params.is_empty() {
        entries.push(buffer_entry(
            wgsl::PARAMS_BINDING,
            wgpu::BufferBindingType::Uniform,
            params_bytes(program),
        ));
    }
    entries
}

/// Group 1 (the scene) for `storage`.
fn scene_layout_entries(storage: BvhStorage) -> Vec<wgpu::BindGroupLayoutEntry> {
    let mut entries: Vec<_> = [
        wgsl::BOUNDS_BINDING,
        wgsl::LINKS_BINDING,
        wgsl::TRIANGLES_BINDING,
    ]
    .into_iter()
    .map(|b| match storage {
        BvhStorage::Buffers => buffer_entry(b, STORAGE_RO, 0),
        BvhStorage::Textures => texture_entry(b),
    })
    .collect();
    entries.push(buffer_entry(wgsl::IES_BINDING, STORAGE_RO, 0));
    entries.push(buffer_entry(wgsl::REGIONS_BINDING, STORAGE_RO, 0));
    entries.push(buffer_entry(
        wgsl::SCENE_BINDING,
        wgpu::BufferBindingType::Uniform,
        SCENE_UNIFORM_BYTES,
    ));
    entries.push(buffer_entry(wgsl::LAMPS_BINDING, STORAGE_RO, 0));
    entries.push(buffer_entry(wgsl::LAMP_PATHS_BINDING, STORAGE_RO, 0));
    entries
}

/// Whether `program` binds the scene (group 1).
fn uses_scene(program: Program) -> bool {
    program.signature().scene != SceneNeeds::default()
}

impl WgpuBackend {
    /// A backend on the first adapter `WGPU_BACKEND` selects (every compiled-in backend, i.e.
    /// Vulkan, when unset), with default options.
    ///
    /// # Errors
    /// [`WgpuError::NoAdapter`] without a driver, [`WgpuError::RequestDevice`] if the adapter
    /// refuses a device.
    pub fn new() -> Result<Self> {
        Self::with_options(WgpuOptions::default())
    }

    /// A backend with explicit options.
    ///
    /// # Errors
    /// As [`WgpuBackend::new`].
    pub fn with_options(options: WgpuOptions) -> Result<Self> {
        let backends = options
            .backends
            .or_else(wgpu::Backends::from_env)
            .unwrap_or(wgpu::Backends::all());
        let gpu = Gpu::open(backends)?;
        let mut pass_layouts = HashMap::new();
        let variants = Program::ALL
            .into_iter()
            .flat_map(|p| Variant::of(p).iter().map(move |&v| (p, v)));
        for (pass, variant) in variants {
            let layout = gpu.scoped("bind group layouts", || {
                gpu.device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                        label: Some(pass.label()),
                        entries: &variant_layout_entries(pass, variant),
                    })
            })?;
            pass_layouts.insert((pass, variant), layout);
        }
        let scene_layout = gpu.scoped("bind group layouts", || {
            gpu.device
                .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some("scene"),
                    entries: &scene_layout_entries(options.bvh_storage),
                })
        })?;
        let uniform = |label: &'static str, size: u64| {
            gpu.scoped(label, || {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
        };
        let tile = uniform("tile", TILE_BYTES)?;
        let largest_block = Program::ALL.map(params_bytes).into_iter().max();
        let params = uniform("pass parameters", largest_block.unwrap_or(0).max(16))?;
        Ok(WgpuBackend {
            gpu,
            options: WgpuOptions {
                tile_work: options.tile_work.max(1),
                ..options
            },
            textures: Vec::new(),
            scenes: Vec::new(),
            scene_keys: Vec::new(),
            pass_layouts,
            scene_layout,
            pipelines: HashMap::new(),
            tile,
            params,
            uploads: Uploads::default(),
            kept: None,
        })
    }

    /// Keeps the gather rays' hits from bake to bake, up to `budget` bytes ([`luxbake::kept`]):
    /// a later bake of the same prepared room (another lamp, a swap) reads them instead of
    /// traversing the BVH, with the same maps. For a backend that bakes one room several times
    /// (`--lamp` repeated, a lamp swap); a single bake would pay the hits' memory and writes
    /// for nothing. A room's hits stay while the room (its BVH) exists and the backend lives,
    /// [`GpuBackend::release`] keeps them; a new call frees them and starts empty.
    pub fn keep_gather_hits(&mut self, budget: u64) {
        self.kept = Some(KeptHits::new(budget));
    }

    /// What the kept gather hits hold and served ([`WgpuBackend::keep_gather_hits`]; `None`
    /// without).
    pub fn gather_hit_stats(&self) -> Option<KeptHitStats> {
        self.kept.as_ref().map(KeptHits::stats)
    }

    /// The key of `part` of a gather dispatch's hits, over `tile` (the call's, or for
    /// [`Part::Grid`] its compact grid's), where they can be kept: with kept hits on, a gather
    /// that is not idle ([`Dispatch::idle`]) reading uploaded position and normal maps, its hits
    /// within one storage binding.
    fn hit_key(
        &self,
        call: &Dispatch<'_, WgpuTexture, WgpuScene>,
        traversal: BvhMode,
        tile: TileParams,
        part: Part,
    ) -> Option<HitKey> {
        // An idle gather (rows without a valid texel) casts no ray.
        if call.program != Program::Gather
            || call.idle
            || self.kept.is_none()
            || !kept::replayable(call.params)
        {
            return None;
        }
        // Read slots 0 and 1 are the position and normal maps.
        let gbuffer = [
            self.uploads.hash(call.reads.first()?.0)?,
            self.uploads.hash(call.reads.get(1)?.0)?,
        ];
        let &(bvh, epsilon) = self.scene_keys.get(call.scene.0)?;
        let key = HitKey::new(bvh, epsilon, traversal, call.params, call.tile, gbuffer)
            .part(part, [tile.width, tile.height]);
        let limits = &self.gpu.limits;
        let most = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        (key.bytes() > 0 && key.bytes() <= most).then_some(key)
    }

    /// The adapter in use (name, driver, backend, device type).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.gpu.info
    }

    /// The options in use.
    pub fn options(&self) -> &WgpuOptions {
        &self.options
    }

    fn scene(&self, scene: &WgpuScene) -> Result<&GpuScene> {
        self.scenes
            .get(scene.0)
            .ok_or_else(|| WgpuError::InvalidInput(format!("unknown scene {scene:?}")))
    }

    fn texture(&self, tex: &WgpuTexture) -> Result<&Texture> {
        self.textures
            .get(tex.0)
            .ok_or_else(|| WgpuError::InvalidInput(format!("unknown texture {tex:?}")))
    }

    /// Creates (once) the pipeline of `variant` of `pass` for `traversal`.
    fn pipeline(&mut self, pass: Program, traversal: BvhMode, variant: Variant) -> Result<()> {
        let key = (pass, traversal, variant);
        if self.pipelines.contains_key(&key) {
            return Ok(());
        }
        let gpu = &self.gpu;
        let source = wgsl_variant(pass, traversal, self.options.bvh_storage, variant);
        let pass_layout = self
            .pass_layouts
            .get(&(pass, variant))
            .ok_or_else(|| WgpuError::InvalidInput("bind group layout cache".into()))?;
        let mut groups = vec![Some(pass_layout)];
        if uses_scene(pass) {
            groups.push(Some(&self.scene_layout));
        }
        let label = variant.label(pass);
        let during = format!("compiling the `{label}` pipeline");
        let pipeline = gpu.scoped(&during, || {
            let module = gpu
                .device
                .create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(&label),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
            let layout = gpu
                .device
                .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(&label),
                    bind_group_layouts: &groups,
                    immediate_size: 0,
                });
            gpu.device
                .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(&label),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some("main"),
                    compilation_options: Default::default(),
                    cache: None,
                })
        })?;
        self.pipelines.insert(key, pipeline);
        Ok(())
    }

    /// Runs `variant` of the call's program over `t` (its tile, or a strided gather's part of
    /// it, [`TileParams::grid`]) with `params` (`hits`: the buffer the trace pass writes or the
    /// replay reads) and waits for it.
    fn run(
        &self,
        call: &Dispatch<'_, WgpuTexture, WgpuScene>,
        traversal: BvhMode,
        variant: Variant,
        hits: Option<&wgpu::Buffer>,
        t: TileParams,
    ) -> Result<()> {
        let label = call.label;
        let gpu_scene = self.scene(call.scene)?;
        let out = self.texture(call.write)?;
        let inputs = call
            .reads
            .iter()
            .map(|r| self.texture(r))
            .collect::<Result<Vec<_>>>()?;
        let pipeline = self
            .pipelines
            .get(&(call.program, traversal, variant))
            .ok_or_else(|| WgpuError::InvalidInput("pipeline cache".into()))?;
        let pass_layout = self
            .pass_layouts
            .get(&(call.program, variant))
            .ok_or_else(|| WgpuError::InvalidInput("bind group layout cache".into()))?;
        let mut entries: Vec<wgpu::BindGroupEntry<'_>> = inputs
            .iter()
            .enumerate()
            .map(|(i, t)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: wgpu::BindingResource::TextureView(&t.view),
            })
            .collect();
        entries.push(wgpu::BindGroupEntry {
            binding: wgsl::OUT_BINDING,
            resource: wgpu::BindingResource::TextureView(&out.view),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: wgsl::TILE_BINDING,
            resource: self.tile.as_entire_binding(),
        });
        let block = params_bytes(call.program);
        if block > 0 {
            entries.push(wgpu::BindGroupEntry {
                binding: wgsl::PARAMS_BINDING,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &self.params,
                    offset: 0,
                    size: std::num::NonZeroU64::new(block),
                }),
            });
        }
        if let Some(h) = hits {
            entries.push(wgpu::BindGroupEntry {
                binding: wgsl::HITS_BINDING,
                resource: h.as_entire_binding(),
            });
        }
        let gpu = &self.gpu;
        let during = format!("pass `{label}`");
        let group = gpu.scoped(&during, || {
            gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: pass_layout,
                entries: &entries,
            })
        })?;
        let scene_group = match call.bvh.encoded() {
            BvhMode::Mtbvh => &gpu_scene.mtbvh,
            _ => &gpu_scene.tbvh,
        };
        gpu.scoped(&during, || {
            gpu.queue
                .write_buffer(&self.tile, 0, &u32_bytes(&t.words()));
            if block > 0 {
                gpu.queue
                    .write_buffer(&self.params, 0, &u32_bytes(call.params));
            }
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) });
            {
                let mut cpass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some(label),
                    timestamp_writes: None,
                });
                cpass.set_pipeline(pipeline);
                cpass.set_bind_group(0, &group, &[]);
                if uses_scene(call.program) {
                    cpass.set_bind_group(1, scene_group, &[]);
                }
                cpass.dispatch_workgroups(
                    t.width.div_ceil(WORKGROUP),
                    t.height.div_ceil(WORKGROUP),
                    1,
                );
            }
            gpu.queue.submit([encoder.finish()]);
        })?;
        // Wait for the tile: honest progress, no unbounded queue of GPU work and no dispatch
        // long enough for a watchdog.
        gpu.wait(&during)
    }

    /// Runs the call over `tile` (`part` of it), its program, or for a gather whose hits are
    /// kept, their trace (once) and replay.
    fn gather_or_run(
        &mut self,
        call: &Dispatch<'_, WgpuTexture, WgpuScene>,
        traversal: BvhMode,
        tile: TileParams,
        part: Part,
    ) -> Result<()> {
        let label = call.label;
        let key = self
            .hit_key(call, traversal, tile, part)
            .filter(|k| self.kept.as_ref().is_some_and(|kept| kept.usable(k)));
        let Some(key) = key else {
            let variant = Variant::plain_or_idle(call.program, call.idle);
            self.pipeline(call.program, traversal, variant)?;
            return self.run(call, traversal, variant, None, tile);
        };
        self.pipeline(call.program, traversal, Variant::Replay)?;
        if self.kept.as_ref().is_some_and(|k| k.get(&key).is_none()) {
            // Trace the dispatch's rays once into a buffer of one tile-sized plane per ray.
            self.pipeline(call.program, traversal, Variant::Trace)?;
            let gpu = &self.gpu;
            let hits = gpu.scoped(&format!("pass `{label}`"), || {
                gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("gather hits"),
                    size: key.bytes(),
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                })
            })?;
            self.run(call, traversal, Variant::Trace, Some(&hits), tile)?;
            // A replaced buffer (not reached: a key is traced only when missing) is dropped.
            drop(self.kept.as_mut().and_then(|k| k.insert(key, hits)));
        }
        let hits = self.kept.as_ref().and_then(|k| k.get(&key));
        let hits = hits.ok_or_else(|| WgpuError::InvalidInput("kept hits".into()))?;
        self.run(call, traversal, Variant::Replay, Some(hits), tile)?;
        if let Some(k) = &mut self.kept {
            k.replayed();
        }
        Ok(())
    }
}

/// Layer `layer` of `texture` from its origin, all aspects: where a whole-layer copy starts.
fn layer_origin(texture: &wgpu::Texture, layer: u32) -> wgpu::TexelCopyTextureInfo<'_> {
    wgpu::TexelCopyTextureInfo {
        texture,
        mip_level: 0,
        origin: wgpu::Origin3d {
            x: 0,
            y: 0,
            z: layer,
        },
        aspect: wgpu::TextureAspect::All,
    }
}

impl GpuBackend for WgpuBackend {
    type Texture = WgpuTexture;
    type Scene = WgpuScene;
    type Error = WgpuError;

    fn name(&self) -> &'static str {
        "wgpu"
    }

    fn limits(&self) -> Limits {
        let l = &self.gpu.limits;
        Limits {
            max_texture_size: l.max_texture_dimension_2d,
            max_array_layers: l.max_texture_array_layers,
            max_texture_units: l.max_sampled_textures_per_shader_stage,
            loop_iterations: Limits::loop_iterations_of(&self.adapter_info().name),
        }
    }

    fn create_texture(&mut self, desc: &TexDesc) -> Result<WgpuTexture> {
        let l = &self.gpu.limits;
        for (what, v, max) in [
            ("texture width", desc.size[0], l.max_texture_dimension_2d),
            ("texture height", desc.size[1], l.max_texture_dimension_2d),
            (
                "texture array layers",
                desc.layers,
                l.max_texture_array_layers,
            ),
        ] {
            if v > max {
                return Err(WgpuError::Limit {
                    what,
                    requested: v.into(),
                    allowed: max.into(),
                });
            }
        }
        if desc.size[0] == 0 || desc.size[1] == 0 || desc.layers == 0 {
            return Err(WgpuError::InvalidInput(format!(
                "texture `{}` of size {:?} × {} layers is empty",
                desc.label, desc.size, desc.layers
            )));
        }
        let gpu = &self.gpu;
        let (texture, view) = gpu.scoped(&format!("creating texture `{}`", desc.label), || {
            // wgpu zero-initialises new textures, as the contract requires.
            let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(desc.label),
                size: wgpu::Extent3d {
                    width: desc.size[0],
                    height: desc.size[1],
                    depth_or_array_layers: desc.layers,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            });
            (texture, view)
        })?;
        self.textures.push(Texture {
            label: desc.label.to_owned(),
            texture,
            view,
            size: desc.size,
            layers: desc.layers,
        });
        Ok(WgpuTexture(self.textures.len() - 1))
    }

    fn upload(&mut self, texture: &WgpuTexture, layer: u32, texels: &[f32]) -> Result<()> {
        let t = self.texture(texture)?;
        let per_layer = t.size[0] as usize * t.size[1] as usize * 4;
        if texels.len() != per_layer {
            return Err(WgpuError::InvalidInput(format!(
                "upload to `{}` layer {layer}: {} floats, expected {per_layer}",
                t.label,
                texels.len()
            )));
        }
        if layer >= t.layers {
            return Err(WgpuError::InvalidInput(format!(
                "upload to layer {layer} of `{}` with {} layers",
                t.label, t.layers
            )));
        }
        let gpu = &self.gpu;
        gpu.scoped(&format!("uploading `{}`", t.label), || {
            gpu.queue.write_texture(
                layer_origin(&t.texture, layer),
                &crate::scene::bytes_of(texels),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(16 * t.size[0]),
                    rows_per_image: Some(t.size[1]),
                },
                wgpu::Extent3d {
                    width: t.size[0],
                    height: t.size[1],
                    depth_or_array_layers: 1,
                },
            );
        })?;
        if self.kept.is_some() {
            // What tells one room's G-buffer from another's for the kept hits.
            self.uploads.record(texture.0, t.layers, layer, texels);
        }
        Ok(())
    }

    fn release(&mut self) -> Result<()> {
        self.textures.clear();
        self.scenes.clear();
        self.scene_keys.clear();
        self.uploads.clear();
        Ok(())
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<WgpuScene> {
        let s = GpuScene::upload(
            &self.gpu,
            &self.scene_layout,
            self.options.bvh_storage,
            scene,
        )?;
        if let Some(kept) = &mut self.kept {
            // Hits of rooms that no longer exist go (their buffers are dropped).
            drop(kept.upload(&scene.bvh.encoded));
        }
        self.scenes.push(s);
        self.scene_keys.push((
            std::sync::Arc::as_ptr(&scene.bvh.encoded) as usize,
            scene.ray_epsilon,
        ));
        Ok(WgpuScene(self.scenes.len() - 1))
    }

    fn tile_work(&self) -> u64 {
        self.options.tile_work
    }

    fn dispatch(&mut self, call: &Dispatch<'_, WgpuTexture, WgpuScene>) -> Result<()> {
        let label = call.label;
        let traversal = program_traversal(call.program, call.bvh);
        let gpu_scene = self.scene(call.scene)?;
        let out = self.texture(call.write)?;
        let sizes = call
            .reads
            .iter()
            .map(|r| self.texture(r).map(|t| (t.size, t.layers)))
            .collect::<Result<Vec<_>>>()?;
        call.check((out.size, out.layers), &sizes, gpu_scene.layer_size)
            .map_err(|reason| WgpuError::InvalidInput(format!("pass `{label}`: {reason}")))?;
        // A texture a pass writes is no upload any more.
        self.uploads.forget(call.write.0);
        let stride = if call.program == Program::Gather {
            GatherParams::from_words(call.params).stride
        } else {
            0
        };
        let Some(grid) = coarse::grid_tile(call.tile, stride) else {
            return self.gather_or_run(call, traversal, call.tile, Part::Whole);
        };
        // A strided gather: the tile but its grid texels (the orphans), then the grid texels
        // alone on their compact grid, every invocation a grid texel (`coarse::grid_tile`).
        let rest = TileParams {
            grid: 1,
            ..call.tile
        };
        let part = if call.narrow {
            Part::Rest
        } else {
            Part::Orphans
        };
        self.gather_or_run(call, traversal, rest, part)?;
        self.gather_or_run(call, traversal, grid, Part::Grid)
    }

    fn read_back(&mut self, texture: &WgpuTexture, layer: u32) -> Result<Vec<f32>> {
        let t = self.texture(texture)?;
        if layer >= t.layers {
            return Err(WgpuError::InvalidInput(format!(
                "read-back of layer {layer} of `{}` with {} layers",
                t.label, t.layers
            )));
        }
        let [w, h] = t.size;
        let row = 16 * w as usize;
        let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize;
        let gpu = &self.gpu;
        let during = format!("reading back `{}`", t.label);
        let buffer = gpu.scoped(&during, || {
            let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("read-back"),
                size: (padded * h as usize) as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let mut encoder = gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                    label: Some("read-back"),
                });
            encoder.copy_texture_to_buffer(
                layer_origin(&t.texture, layer),
                wgpu::TexelCopyBufferInfo {
                    buffer: &buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(padded as u32),
                        rows_per_image: Some(h),
                    },
                },
                wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
            );
            gpu.queue.submit([encoder.finish()]);
            buffer
        })?;
        let status = std::sync::Arc::new(std::sync::Mutex::new(None));
        let slot = std::sync::Arc::clone(&status);
        buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            if let Ok(mut g) = slot.lock() {
                *g = Some(r);
            }
        });
        gpu.wait(&during)?;
        let mapped = status.lock().ok().and_then(|mut g| g.take());
        match mapped {
            Some(Ok(())) => {}
            Some(Err(e)) => {
                return Err(WgpuError::Wait {
                    during,
                    reason: e.to_string(),
                });
            }
            None => {
                return Err(WgpuError::Wait {
                    during,
                    reason: "the buffer was not mapped after the queue went idle".into(),
                });
            }
        }
        let mut out = Vec::with_capacity(4 * w as usize * h as usize);
        {
            let data = buffer
                .slice(..)
                .get_mapped_range()
                .map_err(|e| WgpuError::Wait {
                    during: during.clone(),
                    reason: e.to_string(),
                })?;
            for y in 0..h as usize {
                let bytes = data.get(y * padded..y * padded + row).unwrap_or(&[]);
                out.extend(
                    bytes
                        .chunks_exact(4)
                        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
                );
            }
        }
        buffer.unmap();
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake::bake::{Progress, bake};
    use luxbake::graph::{PassKind, TexFormat};
    use luxbake::scene::{Blur, Scene, Settings};

    /// A backend; without a driver `None` after [`luxbake_testkit::skip_or_fail`] (which fails
    /// the test under CI).
    fn backend(test: &str, options: WgpuOptions) -> Option<WgpuBackend> {
        luxbake_testkit::or_skip(
            test,
            WgpuBackend::with_options(options),
            WgpuError::is_driver_missing,
        )
    }

    fn desc(size: [u32; 2], layers: u32) -> TexDesc {
        TexDesc {
            label: "t",
            size,
            layers,
            format: TexFormat::Rgba32F,
        }
    }

    #[test]
    fn misuse_is_an_error_not_a_panic() {
        let Some(mut b) = backend("misuse", WgpuOptions::default()) else {
            return;
        };
        let max = b.limits().max_texture_size;
        assert!(matches!(
            b.create_texture(&desc([max + 1, 1], 1)),
            Err(WgpuError::Limit { .. })
        ));
        assert!(matches!(
            b.create_texture(&desc([0, 4], 1)),
            Err(WgpuError::InvalidInput(_))
        ));
        let t = b.create_texture(&desc([4, 2], 2)).expect("texture");
        assert!(matches!(
            b.upload(&t, 0, &[0.0; 3]),
            Err(WgpuError::InvalidInput(_))
        ));
        assert!(matches!(
            b.upload(&t, 2, &[0.0; 32]),
            Err(WgpuError::InvalidInput(_))
        ));
        assert!(matches!(
            b.upload(&WgpuTexture(99), 0, &[0.0; 32]),
            Err(WgpuError::InvalidInput(_))
        ));
        assert!(matches!(
            b.read_back(&t, 5),
            Err(WgpuError::InvalidInput(_))
        ));
        // A round trip of one layer, and the other layer still zero.
        let texels: Vec<f32> = (0..32).map(|i| i as f32 * 0.5 - 3.0).collect();
        b.upload(&t, 1, &texels).expect("upload");
        assert_eq!(b.read_back(&t, 1).expect("read"), texels);
        assert_eq!(b.read_back(&t, 0).expect("read"), vec![0.0; 32]);
    }

    #[test]
    fn a_lost_device_is_an_error_not_a_panic() {
        let Some(mut b) = backend("device loss", WgpuOptions::default()) else {
            return;
        };
        let t = b.create_texture(&desc([8, 8], 1)).expect("texture");
        b.gpu.device.destroy();
        let e = b
            .read_back(&t, 0)
            .expect_err("read-back on a destroyed device");
        println!("after destroy: {e}");
        assert!(
            matches!(
                e,
                WgpuError::DeviceLost { .. } | WgpuError::Validation { .. }
            ),
            "{e:?}"
        );
        assert!(b.create_texture(&desc([8, 8], 1)).is_err());
    }

    /// `chairs_01` baked small (4 rays, one bounce, 6 texels per metre, `blur`) with
    /// `options`; `None` where [`backend`] skips.
    fn bake_chairs(
        test: &str,
        blur: Blur,
        options: WgpuOptions,
        progress: &mut dyn FnMut(&Progress<'_>),
    ) -> Option<luxbake::bake::BakeOutput> {
        let settings = Settings {
            rays: 4,
            bounces: 1,
            blur,
            texels_per_metre: 6.0,
            ..Settings::default()
        };
        let scene = Scene::builtin_with_settings("chairs_01", settings.clone()).expect("scene");
        let mut b = backend(test, options)?;
        Some(bake(&mut b, &scene, &settings, progress).expect("bake"))
    }

    #[test]
    fn tiles_split_the_work_and_report_progress_without_changing_the_result() {
        let mut maps = Vec::new();
        for tile_work in [DEFAULT_TILE_WORK, 1] {
            let mut fractions: Vec<(usize, f32)> = Vec::new();
            let options = WgpuOptions {
                tile_work,
                ..WgpuOptions::default()
            };
            let Some(out) = bake_chairs("tiles", Blur::Sigma(1.0), options, &mut |p| {
                if let Progress::PassProgress { index, fraction } = p {
                    fractions.push((*index, *fraction));
                }
            }) else {
                return;
            };
            // Every pass reports, monotonically, up to 1.
            for pass in 0..out.graph.passes.len() {
                let f: Vec<f32> = fractions
                    .iter()
                    .filter(|(i, _)| *i == pass)
                    .map(|(_, f)| *f)
                    .collect();
                assert_eq!(f.last(), Some(&1.0), "pass {pass}");
                assert!(f.windows(2).all(|w| w[0] < w[1]), "pass {pass}: {f:?}");
            }
            let direct = out
                .graph
                .passes
                .iter()
                .position(|p| p.kind == PassKind::Run(Program::Direct));
            let direct_reports = fractions.iter().filter(|(i, _)| Some(*i) == direct).count();
            let rows = out.layout.layer_size[1] * out.layout.layers;
            if tile_work == 1 {
                // One row per tile.
                assert_eq!(direct_reports as u32, rows);
            } else {
                assert!(direct_reports as u32 <= rows);
            }
            maps.push(out.maps);
        }
        assert_eq!(maps[0], maps[1], "tiling changed the result");
    }

    /// The converged default's strided gathers (the tile but its grid texels, then the grid
    /// texels on their compact grid: `coarse::grid_tile`) in tiles of a row or two, many of
    /// which hold no grid row, and with kept hits read back in a second bake: the maps of the
    /// default tiles, bit for bit.
    #[test]
    fn strided_gathers_in_small_tiles_and_from_kept_hits_do_not_change_the_result() {
        let test = "strided gathers in small tiles";
        let settings = Settings {
            texels_per_metre: 6.0,
            ..Settings::preset(luxbake::scene::Quality::Default)
        };
        assert!(settings.higher_stride > 1);
        let scene = Scene::builtin_with_settings("chairs_01", settings.clone()).expect("scene");
        let Some(mut whole) = backend(test, WgpuOptions::default()) else {
            return;
        };
        whole.keep_gather_hits(1 << 30);
        let want = bake(&mut whole, &scene, &settings, &mut |_| {}).expect("bake");
        let options = WgpuOptions {
            tile_work: 2_000,
            ..WgpuOptions::default()
        };
        let Some(mut tiled) = backend(test, options) else {
            return;
        };
        tiled.keep_gather_hits(1 << 30);
        let room = luxbake::bake::Room::prepare(&scene, &settings, tiled.limits(), &mut |_| {})
            .expect("room");
        // One tile per layer, cut around long runs of rows without a valid texel, which keep
        // no hits, and for a strided gather also around those without a narrow texel
        // (`TilePlan::tiles_by_kind`): a gather at stride 1 keeps one part a piece, a strided
        // one the rest's (the orphans' alone where it holds no narrow texel) and its compact
        // grid's where it holds grid rows.
        use luxbake::program::{RowKind, TilePlan};
        let (size, layers) = (want.layout.layer_size, want.layout.layers);
        let kinds = luxbake::validity::row_kinds(&room.gbuffer.position, size[0]);
        let plan = TilePlan::new(size, layers, 1, u64::MAX);
        let pieces = plan.gather_tiles(&kinds, 4);
        let parts: u64 = (want.graph.passes.iter())
            .filter(|p| p.bounce <= want.report.bounces_run)
            .filter_map(|p| match (p.kind, &p.params) {
                (PassKind::Run(Program::Gather), luxbake::program::Params::Gather(g)) => {
                    Some(g.stride)
                }
                _ => None,
            })
            .map(|stride| {
                (plan.gather_tiles(&kinds, stride).iter())
                    .filter(|(_, k)| *k != RowKind::Empty)
                    .map(|(t, _)| 1 + u64::from(coarse::grid_tile(*t, stride).is_some()))
                    .sum::<u64>()
            })
            .sum();
        let kept = whole.gather_hit_stats().expect("kept");
        assert!(kept.orphan_parts > 0, "{kept:?}");
        assert!(pieces.iter().any(|p| p.1 == RowKind::Narrow), "{pieces:?}");
        assert_eq!(kept.traced, parts);
        let staged = want.maps.iter().map(|m| m.stages.iter().flatten().count());
        assert!(staged.sum::<usize>() > 0, "nothing to compare");
        let lamps = &scene.lamps;
        for run in ["first", "second"] {
            let out = luxbake::bake::bake_room(&mut tiled, &room, lamps, &settings, &mut |_| {});
            assert_eq!(want.maps, out.expect("bake").maps, "the {run} bake");
        }
        // The second bake read every dispatch's hits.
        let KeptHitStats {
            traced, replayed, ..
        } = tiled.gather_hit_stats().expect("kept");
        assert_eq!((traced > 0, replayed), (true, 2 * traced));
    }

    #[test]
    fn buffers_and_textures_give_the_same_bake() {
        let mut maps = Vec::new();
        for bvh_storage in [BvhStorage::Buffers, BvhStorage::Textures] {
            let options = WgpuOptions {
                bvh_storage,
                ..WgpuOptions::default()
            };
            let blur = Settings::default().blur;
            let Some(out) = bake_chairs("storage", blur, options, &mut |_| {}) else {
                return;
            };
            maps.push(out.maps);
        }
        assert_eq!(maps[0], maps[1]);
    }
}
