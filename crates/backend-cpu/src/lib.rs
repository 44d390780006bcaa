//! # luxbake-backend-cpu
//!
//! The CPU reference backend of [luxbake](https://example.invalid/luxbake): a [`GpuBackend`]
//! whose textures are `Vec<f32>`s in memory and whose dispatch runs each pass's CPU reference
//! ([`luxbake::cpu::run`]: plain Rust, rayon over texel rows, `f32` computed as a shader would).
//! It is the oracle every GPU backend (`luxbake-backend-glow`, `luxbake-backend-wgpu`) is diffed
//! against, and the backend of `cargo xtask bake` by default. What each pass computes is
//! specified in [`luxbake::cpu`], next to the references.
//!
//! It was `luxbake::cpu::CpuBackend`; the core names no backend now.
//!
//! ```no_run
//! use luxbake::scene::Scene;
//!
//! let scene = Scene::builtin("chairs_01")?;
//! let out = luxbake_backend_cpu::bake(&scene)?;
//! println!("{} maps", out.maps.len());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

use luxbake::backend::{DEFAULT_TILE_WORK, Dispatch, GpuBackend, Limits, SceneData};
use luxbake::bake::{BakeError, BakeOutput};
use std::sync::Arc;

use luxbake::cpu::{CpuScene, GatherHitStats, GatherHits, GuideCache, View};
use luxbake::graph::TexDesc;
use luxbake::program::{GatherParams, ParamBlock, Program};
use luxbake::scene::Scene;

/// `scene` baked on a new [`CpuBackend`] at its own settings, without progress reports.
///
/// # Errors
/// As [`luxbake::bake()`].
pub fn bake(scene: &Scene) -> Result<BakeOutput, BakeError<CpuError>> {
    luxbake::bake(&mut CpuBackend::new(), scene, &scene.settings, &mut |_| {})
}

/// Errors of the CPU backend (all are misuse of the [`GpuBackend`] contract).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CpuError {
    /// A texture handle that this backend did not create.
    #[error("unknown texture {0}")]
    UnknownTexture(usize),
    /// An upload with the wrong number of floats.
    #[error("upload of {got} floats into a layer of {expected}")]
    WrongSize {
        /// Floats per layer.
        expected: usize,
        /// Floats given.
        got: usize,
    },
    /// A layer index beyond the texture's layers.
    #[error("layer {layer} of a texture with {layers} layers")]
    LayerOutOfRange {
        /// The layer asked for.
        layer: u32,
        /// Layers of the texture.
        layers: u32,
    },
    /// A pass was given the wrong number of textures or textures of different sizes.
    #[error("pass `{pass}`: {reason}")]
    BadBindings {
        /// The pass label.
        pass: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A lamp refers to a table that was not uploaded.
    #[error("lamp {lamp} refers to intensity table {table}, but {tables} were uploaded")]
    MissingTable {
        /// Lamp index.
        lamp: usize,
        /// Table index.
        table: u32,
        /// Number of tables.
        tables: usize,
    },
    /// A texture too large to address.
    #[error("texture {size:?} × {layers} layers is too large")]
    TooLarge {
        /// Layer size.
        size: [u32; 2],
        /// Layers.
        layers: u32,
    },
}

/// Handle of a CPU texture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CpuTexture(usize);

/// The CPU reference backend.
#[derive(Debug, Default)]
pub struct CpuBackend {
    textures: Vec<(TexDesc, Vec<f32>)>,
    /// Per texture, what identifies its texels ([`luxbake::cpu::texels_id`]) once a
    /// denoiser, gather or upsampling pass asked, until it is written again.
    ids: Vec<Option<u64>>,
    /// The denoiser's chart tests and the grid corners of the later bounces, kept from pass
    /// to pass and bake to bake ([`luxbake::cpu::GuideMasks`], 4 bytes per texel each, and
    /// [`luxbake::cpu::CoarseMasks`], 1 byte; at most [`GuideCache::KEEP`] of each).
    guides: GuideCache,
    /// Gather hits kept across bakes ([`CpuBackend::keep_gather_hits`]).
    hits: Option<Arc<GatherHits>>,
}

/// The budget [`CpuBackend::keep_gather_hits`] is usually given: 1 GiB of hits, 67 M gather
/// rays (`chairs_05` at the default preset and 64 texels/m records 4.7 M, 75 MB).
pub const GATHER_HITS_BUDGET: usize = 1 << 30;

impl CpuBackend {
    /// A backend with no textures.
    pub fn new() -> CpuBackend {
        CpuBackend::default()
    }

    /// Keeps the gather rays' hits from bake to bake, up to `budget` bytes
    /// ([`luxbake::cpu::hits`]): a later bake of the same prepared room (another lamp, a
    /// swap) replays them instead of traversing the BVH, with the same maps bit for bit. For
    /// a backend that bakes one room several times. A room's hits are kept while the room
    /// (its BVH) exists and the backend lives; a new call starts an empty cache.
    pub fn keep_gather_hits(&mut self, budget: usize) {
        self.hits = Some(Arc::new(GatherHits::new(budget)));
    }

    /// What the kept gather hits served so far ([`CpuBackend::keep_gather_hits`]; `None`
    /// without).
    pub fn gather_hit_stats(&self) -> Option<GatherHitStats> {
        self.hits.as_ref().map(|h| h.stats())
    }

    /// Bytes this backend keeps from bake to bake besides its textures: the gather hits
    /// ([`CpuBackend::keep_gather_hits`]) and the denoiser's chart tests.
    pub fn kept_bytes(&self) -> usize {
        self.gather_hit_stats().map_or(0, |h| h.bytes) + self.guides.bytes()
    }

    fn get(&self, t: &CpuTexture) -> Result<&(TexDesc, Vec<f32>), CpuError> {
        self.textures.get(t.0).ok_or(CpuError::UnknownTexture(t.0))
    }
}

impl GpuBackend for CpuBackend {
    type Texture = CpuTexture;
    type Scene = CpuScene;
    type Error = CpuError;

    fn name(&self) -> &'static str {
        "cpu"
    }

    fn tile_work(&self) -> u64 {
        DEFAULT_TILE_WORK
    }

    fn limits(&self) -> Limits {
        Limits {
            max_texture_size: 16_384,
            max_array_layers: 2048,
            max_texture_units: 16,
            loop_iterations: None,
        }
    }

    fn create_texture(&mut self, desc: &TexDesc) -> Result<CpuTexture, CpuError> {
        let n = (desc.size[0] as usize)
            .checked_mul(desc.size[1] as usize)
            .and_then(|n| n.checked_mul(desc.layers as usize))
            .and_then(|n| n.checked_mul(4))
            .filter(|&n| n <= isize::MAX as usize / 4)
            .ok_or(CpuError::TooLarge {
                size: desc.size,
                layers: desc.layers,
            })?;
        self.textures.push((desc.clone(), vec![0.0; n]));
        self.ids.push(None);
        Ok(CpuTexture(self.textures.len() - 1))
    }

    fn upload(&mut self, texture: &CpuTexture, layer: u32, texels: &[f32]) -> Result<(), CpuError> {
        let (desc, data) = self
            .textures
            .get_mut(texture.0)
            .ok_or(CpuError::UnknownTexture(texture.0))?;
        if layer >= desc.layers {
            return Err(CpuError::LayerOutOfRange {
                layer,
                layers: desc.layers,
            });
        }
        let per_layer = 4 * desc.size[0] as usize * desc.size[1] as usize;
        if texels.len() != per_layer {
            return Err(CpuError::WrongSize {
                expected: per_layer,
                got: texels.len(),
            });
        }
        let start = layer as usize * per_layer;
        data[start..start + per_layer].copy_from_slice(texels);
        self.ids[texture.0] = None;
        Ok(())
    }

    fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<CpuScene, CpuError> {
        for (i, l) in scene.lamps.iter().enumerate() {
            if l.table as usize >= scene.ies_tables.len() {
                return Err(CpuError::MissingTable {
                    lamp: i,
                    table: l.table,
                    tables: scene.ies_tables.len(),
                });
            }
        }
        let mut uploaded = CpuScene::new(scene);
        if let Some(hits) = &self.hits {
            uploaded.keep_gather_hits(Arc::clone(hits));
        }
        Ok(uploaded)
    }

    fn release(&mut self) -> Result<(), CpuError> {
        self.textures.clear();
        self.ids.clear();
        Ok(())
    }

    fn dispatch(&mut self, call: &Dispatch<'_, CpuTexture, CpuScene>) -> Result<(), CpuError> {
        let out_index = call.write.0;
        let (desc, mut out) = {
            let (d, data) = self
                .textures
                .get_mut(out_index)
                .ok_or(CpuError::UnknownTexture(out_index))?;
            (d.clone(), std::mem::take(data))
        };
        // The denoiser's passes read their taps' chart tests from the kept masks of the
        // position map, the gather and the upsampling on a grid its grid corners from those
        // of the position and normal maps: what identifies their texels is hashed once after
        // each upload.
        let kept: &[&str] = match call.program {
            Program::Variance | Program::Atrous => &["position"],
            Program::Gather if GatherParams::from_words(call.params).stride > 1 => {
                &["position", "normal"]
            }
            Program::Upsample => &["position", "normal"],
            _ => &[],
        };
        if !kept.is_empty() {
            let names = call.program.signature().reads;
            for (slot, r) in call.reads.iter().enumerate() {
                if names.get(slot).is_some_and(|n| kept.contains(n)) && r.0 != out_index {
                    let (d, data) = self.get(r)?;
                    if self.ids[r.0].is_none() {
                        self.ids[r.0] = Some(luxbake::cpu::texels_id(d.size, d.layers, data));
                    }
                }
            }
        }
        let result = (|| {
            let mut views = Vec::with_capacity(call.reads.len());
            let mut ids = Vec::with_capacity(call.reads.len());
            for r in call.reads {
                let (d, data) = self.get(r)?;
                views.push(View::new(data, d.size, d.layers));
                ids.push(self.ids.get(r.0).copied().flatten());
            }
            luxbake::cpu::run_with(call, &views, &desc, &mut out, Some((&self.guides, &ids)))
                .map_err(|reason| CpuError::BadBindings {
                    pass: call.label,
                    reason,
                })
        })();
        if let Some((_, data)) = self.textures.get_mut(out_index) {
            *data = out;
        }
        if let Some(id) = self.ids.get_mut(out_index) {
            *id = None;
        }
        result
    }

    fn read_back(&mut self, texture: &CpuTexture, layer: u32) -> Result<Vec<f32>, CpuError> {
        let (desc, data) = self.get(texture)?;
        if layer >= desc.layers {
            return Err(CpuError::LayerOutOfRange {
                layer,
                layers: desc.layers,
            });
        }
        let per_layer = 4 * desc.size[0] as usize * desc.size[1] as usize;
        let start = layer as usize * per_layer;
        Ok(data[start..start + per_layer].to_vec())
    }
}
