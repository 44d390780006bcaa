//! Gather hits kept across the bakes of one room by the GPU backends: a lamp swap's bounces as
//! look-ups (the CPU backend keeps its own per row, [`crate::cpu::hits`]).
//!
//! A gather ray depends only on the room and the random numbers — its origin and frame on the
//! texel's G-buffer position and normal, its direction on the sampler's draw for (texel, ray,
//! bounce, seed), its hit on the BVH — never on the lamps. With hits kept, a GPU backend runs a
//! gather dispatch ([`Program::Gather`]) as two programs:
//!
//! 1. a **trace pass** (`passes/gather/trace.glsl`, `trace.wgsl`): the dispatch's rays of every
//!    texel of the tile, each closest hit `(t, triangle, u, v)` written to the backend's hit
//!    storage at the texel's place in the tile, one tile-sized plane per ray (triangle −1: no
//!    such ray, or a miss);
//! 2. the gather compiled to **replay** ([`crate::shader::GLSL_GATHER_REPLAY`],
//!    [`crate::shader::wgsl_gather_replay_source`]), which reads each ray's hit there where it
//!    would have traversed the BVH and does everything after the hit (the shading normal, the
//!    light-map look-up, the lamp paths' weight, the sums) as before.
//!
//! A later bake of the same room whose dispatch has the same [`HitKey`] runs only the second.
//! The hit is the one the traversal returned, stored as 32-bit floats without rounding (a
//! triangle index is exact in f32 below 2²⁴), and both programs compute the ray with the
//! gather's operations, so the maps equal a bake that traces (`tests/tests/gather_hits.rs` in
//! the workspace's harness). [`KeptHits`] is the bookkeeping every GPU backend shares: the keys,
//! the budget, which rooms still exist; the storage `T` is the backend's.
//!
//! # What makes a dispatch's hits valid
//! [`HitKey`]: the BVH object the rays were cast in (held weakly, so its address is not reused
//! while the hits exist), the ray offset's size, the traversal, the gather parameters that
//! place the rays (rays, orphans' rays, stride, reach, bounce, seed, sampler, the chunk) and the
//! tile, and 64-bit hashes of the position and normal maps as they were uploaded
//! ([`hash_floats`]). Another room,
//! another texel density or G-buffer, or a map written by a pass instead of uploaded, traces
//! again. Hits of a BVH that no longer exists (its room was dropped) are freed at the next
//! scene upload.
//!
//! # What it costs
//! [`HIT_BYTES`] per texel of the tile and ray of the dispatch (the storage spans the tile's
//! whole rows, texels outside the charts and off the coarse grid included); a dispatch whose
//! hits would pass the budget is gathered as without kept hits. The first bake pays the hits'
//! writes and reads, not another traversal. The driver cuts a gather's tiles around long runs
//! of rows without a valid texel, whose dispatches are idle and keep nothing
//! ([`crate::backend::Dispatch::idle`]; glow clears them), and a strided gather's also around
//! those without a narrow texel ([`crate::program::TilePlan::tiles_by_kind`]). A backend that
//! gathers a strided gather's grid texels on their compact grid (glow and wgpu,
//! [`crate::program::coarse::grid_tile`]) keeps two parts ([`Part`]): the grid's, `1/stride²`
//! of the tile, and the rest of the tile's, as many planes as a grid texel's rays where the
//! tile may hold a narrow texel ([`crate::backend::Dispatch::narrow`]) and the orphans' rays'
//! elsewhere.

use std::collections::HashMap;
use std::sync::{Arc, Weak};

use luxbake_bvh::EncodedScene;

use crate::contract::ParamBlock;
use crate::program::{GatherParams, Program, TileParams};
use crate::scene::BvhMode;

/// Bytes of one kept hit: four 32-bit floats `(t, triangle, u, v)`.
pub const HIT_BYTES: u64 = 16;

/// Which program a GPU backend runs for a pass: the pass's own, for a gather with kept hits
/// (module docs) the trace pass that writes them or the gather that replays them, or for a
/// refinement's dispatch in which no texel does the pass's work its idle program
/// ([`crate::shader::glsl_variant`], [`crate::shader::wgsl_variant`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// The pass's own program.
    Plain,
    /// The gather's trace pass: writes each ray's hit.
    Trace,
    /// The gather replaying kept hits.
    Replay,
    /// The refine or connect pass's program with `LUX_IDLE` 1: each texel writes what it
    /// writes where it refines nothing, the rays' code compiled out. The driver runs it on the
    /// dispatches that it knows have no texel to refine ([`crate::backend::Dispatch::idle`]:
    /// the refinements in narrow gaps alone, over rows without a gap). llvmpipe and lavapipe
    /// run a branch in SIMD lanes with a mask, so the refinement's code around its loops ran
    /// for every texel that skipped it (docs/performance.md, "Refinements in gaps: an idle
    /// program").
    Idle,
}

impl Variant {
    /// The variants of `pass`: the gather has the first three, the refine and connect passes
    /// their own and the idle one, every other pass its own program.
    pub fn of(pass: Program) -> &'static [Variant] {
        match pass {
            Program::Gather => &[Variant::Plain, Variant::Trace, Variant::Replay],
            Program::Refine | Program::Connect => &[Variant::Plain, Variant::Idle],
            _ => &[Variant::Plain],
        }
    }

    /// The variant a backend runs for a dispatch of `pass` that is `idle`
    /// ([`crate::backend::Dispatch::idle`]) and keeps no gather hits: [`Variant::Idle`] where
    /// `pass` has one, else [`Variant::Plain`].
    pub fn plain_or_idle(pass: Program, idle: bool) -> Variant {
        if idle && Variant::of(pass).contains(&Variant::Idle) {
            Variant::Idle
        } else {
            Variant::Plain
        }
    }

    /// The program's label: the pass's, with ` (trace)`, ` (replay)` or ` (idle)`.
    pub fn label(self, pass: Program) -> String {
        match self {
            Variant::Plain => pass.label().to_owned(),
            Variant::Trace => format!("{} (trace)", pass.label()),
            Variant::Replay => format!("{} (replay)", pass.label()),
            Variant::Idle => format!("{} (idle)", pass.label()),
        }
    }
}

/// Whether a gather dispatch with `words` (its [`GatherParams`]) can keep and replay its hits:
/// not one that evaluates the direct light at its hits
/// ([`GatherParams::direct_at_hits`]), whose shadow rays depend on the lamps (the replay
/// programs leave that code out, so that a swap's gather stays a look-up).
pub fn replayable(words: &[u32]) -> bool {
    GatherParams::from_words(words).direct_at_hits == 0
}

/// Which of a dispatch's texels a kept hit texture holds: all of them, or for a strided gather
/// drawn on its compact grid ([`crate::program::coarse::grid_tile`]) the grid's texels or the
/// rest of the tile.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Part {
    /// Every texel of the tile, each with all its rays.
    Whole,
    /// The grid texels of the tile, the key's tile the compact one.
    Grid,
    /// The tile's texels off the grid (the grid texels' hits are misses): the orphans and a
    /// narrow gap's texels, which cast as many rays as a grid texel. Keeping only the orphans'
    /// rays and tracing a narrow gap's others in the swap took the strided gathers of a
    /// `chairs_05` swap at 24 texels/m from 0.037 to 0.087 s a bounce under llvmpipe.
    Rest,
    /// [`Part::Rest`] of a tile without a narrow texel
    /// ([`crate::backend::Dispatch::narrow`] `false`): its texels off the grid that cast rays
    /// are orphans, each with the orphans' rays, and so many planes are kept (a quarter of a
    /// grid texel's at the `default`'s stride 4). A `chairs_05` bake's kept hits: 287 → 202 MB
    /// at 24 texels/m, 1 073 MB (the 1 GiB budget full, a bounce traced again in every swap)
    /// → 549 MB at 64; with the empty rows' dispatches idle too, 144 and 456 MB
    /// (docs/performance.md, "Kept hits: the orphans' rays alone").
    Orphans,
}

/// What places a gather dispatch's rays (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct HitKey {
    /// The BVH object's address (valid while the [`KeptHits`] holds a weak pointer to it).
    scene: usize,
    /// The ray offset's size term, bits.
    epsilon: u32,
    /// The traversal compiled into the programs.
    traversal: BvhMode,
    /// `[rays, orphan_rays, stride, reach (bits), bounce, seed, sampler, first_ray,
    /// chunk_rays]`.
    rays: [u32; 9],
    /// `[layer, x0, y0, width, height]`.
    tile: [u32; 5],
    /// Hashes of the position and normal maps' uploads.
    gbuffer: [u64; 2],
    /// The texels whose hits are kept.
    part: Part,
    /// Width and height of the hits' planes: the tile's, or for [`Part::Grid`] its compact
    /// grid's.
    extent: [u32; 2],
}

impl HitKey {
    /// The key of a gather dispatch with `words` (its [`GatherParams`]) over `tile`, in the
    /// BVH at address `scene` with ray offset `epsilon`, reading maps whose uploads hash to
    /// `gbuffer`.
    pub fn new(
        scene: usize,
        epsilon: f32,
        traversal: BvhMode,
        words: &[u32],
        tile: TileParams,
        gbuffer: [u64; 2],
    ) -> HitKey {
        let p = GatherParams::from_words(words);
        HitKey {
            scene,
            epsilon: epsilon.to_bits(),
            traversal,
            rays: [
                p.rays,
                p.orphan_rays,
                p.stride,
                p.reach.to_bits(),
                p.bounce,
                p.seed,
                p.sampler,
                p.first_ray,
                p.chunk_rays,
            ],
            tile: [tile.layer, tile.x0, tile.y0, tile.width, tile.height],
            gbuffer,
            part: Part::Whole,
            extent: [tile.width, tile.height],
        }
    }

    /// The key of `part` of the dispatch, whose hits' planes are `extent` (width, height)
    /// texels: the tile's, or for [`Part::Grid`] its compact grid's.
    pub fn part(self, part: Part, extent: [u32; 2]) -> HitKey {
        HitKey {
            part,
            extent,
            ..self
        }
    }

    /// Rays whose hits a texel keeps at most: the chunk's share (the gather pass's `first` and
    /// `count`) of the larger of the grid texels' and the orphans' rays, for [`Part::Grid`] of
    /// the grid texels', for [`Part::Orphans`] of the orphans'.
    pub fn rays(&self) -> u32 {
        let [rays, orphan, .., first, chunk] = self.rays;
        let rays = match self.part {
            Part::Whole | Part::Rest => rays.max(orphan),
            Part::Grid => rays,
            Part::Orphans => orphan,
        };
        let left = rays.saturating_sub(first);
        if chunk > 0 { left.min(chunk) } else { left }
    }

    /// Bytes of the dispatch's hits.
    pub fn bytes(&self) -> u64 {
        u64::from(self.extent[0]) * u64::from(self.extent[1]) * u64::from(self.rays()) * HIT_BYTES
    }
}

/// What a GPU backend's kept gather hits hold and served.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeptHitStats {
    /// Bytes of hits kept.
    pub bytes: u64,
    /// Gather dispatches whose hits are kept.
    pub dispatches: usize,
    /// Gather dispatches that traced their rays and kept the hits.
    pub traced: u64,
    /// Gather dispatches that read kept hits (each one that traced too).
    pub replayed: u64,
    /// Of `dispatches`, the rests of tiles without a narrow texel, which keep the orphans' rays
    /// alone ([`Part::Orphans`]).
    pub orphan_parts: usize,
}

/// The hits a GPU backend keeps (its storage `T` per dispatch key) and the budget.
#[derive(Debug)]
pub struct KeptHits<T> {
    budget: u64,
    /// The BVHs hits were cast in, weakly held.
    rooms: Vec<Weak<EncodedScene>>,
    hits: HashMap<HitKey, T>,
    bytes: u64,
    traced: u64,
    replayed: u64,
}

impl<T> KeptHits<T> {
    /// Nothing kept yet; at most `budget` bytes of hits.
    pub fn new(budget: u64) -> KeptHits<T> {
        KeptHits {
            budget,
            rooms: Vec::new(),
            hits: HashMap::new(),
            bytes: 0,
            traced: 0,
            replayed: 0,
        }
    }

    /// Remembers that hits may be cast in `scene` (so its address is not reused while they
    /// exist) and hands back the hit textures of BVHs that no longer exist, for the caller to
    /// free.
    pub fn upload(&mut self, scene: &Arc<EncodedScene>) -> Vec<T> {
        let freed = self.prune();
        if !self
            .rooms
            .iter()
            .any(|w| std::ptr::eq(w.as_ptr(), Arc::as_ptr(scene)))
        {
            self.rooms.push(Arc::downgrade(scene));
        }
        freed
    }

    /// Hands back the hits cast in BVHs that no longer exist (their rooms were dropped), for
    /// the caller to free.
    pub fn prune(&mut self) -> Vec<T> {
        let gone: Vec<usize> = self
            .rooms
            .iter()
            .filter(|w| w.strong_count() == 0)
            .map(|w| w.as_ptr() as usize)
            .collect();
        self.rooms.retain(|w| w.strong_count() > 0);
        let dropped: Vec<HitKey> = self
            .hits
            .keys()
            .filter(|k| gone.contains(&k.scene))
            .copied()
            .collect();
        dropped
            .into_iter()
            .filter_map(|k| {
                self.bytes -= k.bytes();
                self.hits.remove(&k)
            })
            .collect()
    }

    /// Whether a dispatch with `key` may keep its hits within the budget.
    pub fn fits(&self, key: &HitKey) -> bool {
        key.rays() > 0
            && self
                .bytes
                .checked_add(key.bytes())
                .is_some_and(|b| b <= self.budget)
    }

    /// Whether a dispatch with `key` reads kept hits: they are kept, or they fit the budget.
    pub fn usable(&self, key: &HitKey) -> bool {
        self.get(key).is_some() || self.fits(key)
    }

    /// Keeps the hits a dispatch with `key` traced; hands back the texture they replace, if
    /// any, for the caller to free.
    pub fn insert(&mut self, key: HitKey, hits: T) -> Option<T> {
        self.bytes += key.bytes();
        self.traced += 1;
        let old = self.hits.insert(key, hits);
        if old.is_some() {
            self.bytes -= key.bytes();
        }
        old
    }

    /// The hits kept for `key`.
    pub fn get(&self, key: &HitKey) -> Option<&T> {
        self.hits.get(key)
    }

    /// Counts a dispatch that read kept hits.
    pub fn replayed(&mut self) {
        self.replayed += 1;
    }

    /// What the cache holds and served.
    pub fn stats(&self) -> KeptHitStats {
        KeptHitStats {
            bytes: self.bytes,
            dispatches: self.hits.len(),
            traced: self.traced,
            replayed: self.replayed,
            orphan_parts: self.hits.keys().filter(|k| k.part == Part::Orphans).count(),
        }
    }

    /// Every kept texture, for the caller to free.
    pub fn drain(&mut self) -> Vec<T> {
        self.bytes = 0;
        self.rooms.clear();
        self.hits.drain().map(|(_, t)| t).collect()
    }
}

/// The hashes of a backend's texture uploads, per texture (its index) and layer — what tells
/// one room's G-buffer from another's in a [`HitKey`]. A texture a pass writes is forgotten.
#[derive(Debug, Default)]
pub struct Uploads(HashMap<usize, Vec<Option<u64>>>);

impl Uploads {
    /// Records the upload of `texels` to `layer` of `texture` (of `layers` layers).
    pub fn record(&mut self, texture: usize, layers: u32, layer: u32, texels: &[f32]) {
        let hashes = self
            .0
            .entry(texture)
            .or_insert_with(|| vec![None; layers as usize]);
        if let Some(h) = hashes.get_mut(layer as usize) {
            *h = Some(hash_floats(texels));
        }
    }

    /// Forgets `texture` (a pass writes it).
    pub fn forget(&mut self, texture: usize) {
        self.0.remove(&texture);
    }

    /// Forgets every texture (the backend freed them).
    pub fn clear(&mut self) {
        self.0.clear();
    }

    /// A hash of every layer of `texture`; `None` unless each was uploaded.
    pub fn hash(&self, texture: usize) -> Option<u64> {
        let mut h = 0u64;
        for l in self.0.get(&texture)? {
            h = h.rotate_left(29) ^ (*l)?;
        }
        Some(h)
    }
}

/// A 64-bit hash of an upload's floats, bit for bit (FNV-1a over 64-bit words, then a final
/// mix): what tells one room's G-buffer from another's.
pub fn hash_floats(texels: &[f32]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut words = texels.chunks_exact(2);
    for w in &mut words {
        let v = u64::from(w[0].to_bits()) | (u64::from(w[1].to_bits()) << 32);
        h = (h ^ v).wrapping_mul(0x0000_0100_0000_01b3);
    }
    for w in words.remainder() {
        h = (h ^ u64::from(w.to_bits())).wrapping_mul(0x0000_0100_0000_01b3);
    }
    h ^= texels.len() as u64;
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^ (h >> 33)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gather that evaluates the direct light at its hits keeps none: its replay would
    /// need the lamps' shadow rays, which the replay programs leave out.
    #[test]
    fn only_gathers_that_read_the_maps_at_their_hits_are_replayable() {
        let words = |direct_at_hits| {
            GatherParams {
                rays: 8,
                direct_at_hits,
                ..GatherParams::default()
            }
            .words()
        };
        assert!(replayable(&words(0)));
        assert!(!replayable(&words(1)));
    }

    #[test]
    fn uploads_hash_every_layer_once_uploaded() {
        let mut u = Uploads::default();
        u.record(3, 2, 0, &[1.0, 2.0]);
        assert_eq!(u.hash(3), None, "layer 1 not uploaded");
        u.record(3, 2, 1, &[3.0, 4.0]);
        let h = u.hash(3).expect("both layers");
        u.record(3, 2, 1, &[3.0, 5.0]);
        assert_ne!(u.hash(3), Some(h));
        u.forget(3);
        assert_eq!(u.hash(3), None);
    }

    #[test]
    fn the_hash_tells_every_bit_and_the_length() {
        let a = [1.0f32, 2.0, 3.0, 4.0, 5.0];
        let h = hash_floats(&a);
        assert_eq!(h, hash_floats(&a));
        let mut b = a;
        b[4] = f32::from_bits(5.0f32.to_bits() ^ 1);
        assert_ne!(h, hash_floats(&b));
        assert_ne!(hash_floats(&[0.0]), hash_floats(&[-0.0]));
        assert_ne!(
            hash_floats(&a[..4]),
            hash_floats(&[1.0, 2.0, 3.0, 4.0, 0.0])
        );
    }

    #[test]
    fn a_dispatch_keeps_its_chunks_rays_within_the_budget() {
        let tile = TileParams {
            layer: 0,
            x0: 0,
            y0: 8,
            width: 64,
            height: 16,
            layer_w: 64,
            layer_h: 64,
            grid: 0,
        };
        let words = |rays: u32, orphans: u32, first: u32, chunk: u32| {
            GatherParams {
                rays,
                orphan_rays: orphans,
                first_ray: first,
                chunk_rays: chunk,
                ..GatherParams::default()
            }
            .words()
        };
        let key = |w: Vec<u32>| HitKey::new(1, 1e-4, BvhMode::Mtbvh, &w, tile, [1, 2]);
        assert_eq!(key(words(4, 2, 0, 0)).rays(), 4);
        assert_eq!(key(words(2, 3, 0, 0)).rays(), 3);
        assert_eq!(key(words(300, 0, 256, 128)).rays(), 44);
        assert_eq!(key(words(300, 0, 128, 128)).rays(), 128);
        let k = key(words(4, 0, 0, 0));
        assert_eq!(k.bytes(), 64 * 16 * 4 * 16);
        // The lamps' words do not place rays.
        let mut lit = GatherParams::from_words(&words(4, 0, 0, 0));
        lit.lamp_paths = 12;
        lit.density_scale = 3.5;
        lit.lamp_count = 2;
        assert_eq!(key(lit.words()), k);
        let mut kept: KeptHits<()> = KeptHits::new(k.bytes());
        assert!(kept.fits(&k));
        assert!(kept.insert(k, ()).is_none());
        assert_eq!(kept.stats().bytes, k.bytes());
        assert!(!kept.fits(&key(words(4, 0, 1, 0))), "past the budget");
        assert!(
            !KeptHits::<()>::new(u64::MAX).fits(&key(words(4, 0, 4, 0))),
            "no rays"
        );
        // A strided gather on its compact grid: the grid's texels keep their rays, the rest
        // as many; each part a key of its own.
        let strided = key(words(16, 20, 0, 0));
        let (g, r) = (
            strided.part(Part::Grid, [16, 4]),
            strided.part(Part::Rest, [64, 16]),
        );
        assert_eq!((strided.rays(), g.rays(), r.rays()), (20, 16, 20));
        assert_eq!(
            (g.bytes(), r.bytes()),
            (16 * 4 * 16 * 16, 64 * 16 * 20 * 16)
        );
        assert!(g != strided && r != strided && g != r);
        assert_eq!(key(words(16, 4, 16, 0)).part(Part::Grid, [16, 4]).rays(), 0);
        // The rest of a tile without a narrow texel keeps the orphans' rays, a chunk's share
        // of them, and is a key of its own.
        let o = key(words(16, 4, 0, 0)).part(Part::Orphans, [64, 16]);
        assert_eq!((o.rays(), o.bytes()), (4, 64 * 16 * 4 * 16));
        assert_ne!(o, key(words(16, 4, 0, 0)).part(Part::Rest, [64, 16]));
        assert_eq!(
            key(words(16, 4, 2, 1)).part(Part::Orphans, [64, 16]).rays(),
            1
        );
        assert_eq!(
            key(words(16, 4, 4, 0)).part(Part::Orphans, [64, 16]).rays(),
            0
        );
        // The tile stays part of the key: two tiles' grids of one size are two keys.
        let other = HitKey::new(
            1,
            1e-4,
            BvhMode::Mtbvh,
            &words(16, 20, 0, 0),
            TileParams { y0: 24, ..tile },
            [1, 2],
        );
        assert_ne!(other.part(Part::Grid, [16, 4]), g);
    }
}
