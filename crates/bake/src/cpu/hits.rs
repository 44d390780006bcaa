//! Gather hits kept across the bakes of one room: a lamp swap's bounces as look-ups.
//!
//! A gather ray depends only on the room and the random numbers: its origin and frame on the
//! texel's G-buffer position and normal, its direction on the sampler's draw for (texel,
//! sample, bounce, seed), its hit on the BVH. None of it depends on the lamps. So when one room
//! is baked under several lamps (a shop's lamp swap, `--lamp` repeated, a catalogue), the
//! second bake's gather rays meet exactly the triangles at exactly the barycentrics the first
//! bake's did. [`GatherHits`] keeps them: the first bake traces each gather row's rays and
//! records their hits; a later bake with the same rays replays them instead of traversing the
//! BVH, and everything after the hit (the shading normal, the light-map look-up, the lamp
//! paths' weight, the sums) runs as before. The maps are the same bit for bit.
//!
//! # What makes a row's hits valid
//! A row is recorded under its key — the gather's ray parameters (sampler, bounce, seed,
//! stride, rays, chunk), the traversal, and the row's place in its tile — together with a
//! 64-bit hash of what its rays start from: each texel's index, ray range, origin and normal,
//! bit for bit. A later row replays only when the key is found among the rows traced in the
//! same BVH object (the cache holds a weak pointer to it, so its address is not reused while
//! the rows exist) and the hash is equal. A changed G-buffer (another room, another texel
//! density) or another BVH therefore traces again. Rows of a BVH that no longer exists (its
//! room was dropped) are forgotten at the next upload.
//!
//! # What it costs
//! 16 bytes per ray ([`HIT_BYTES`]): `chairs_05` at the default preset and 64 texels/m
//! records 4.7 M rays, 75 MB. Rows beyond the budget given to [`GatherHits::new`] are not
//! recorded (they are traced on every bake, as without the cache). Recording costs the
//! first bake the stores, not the traversal; refinement's rays (whose texels depend on the
//! lamps' noise) are never recorded. The CPU backend keeps hits only when asked
//! (`CpuBackend::keep_gather_hits`): a single bake would pay the memory for nothing.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, RwLock, Weak};

use luxbake_bvh::{EncodedScene, Hit};

/// Bytes a recorded ray takes (its [`Hit`]; a miss is stored as a hit on triangle
/// `u32::MAX`, which no scene has).
pub const HIT_BYTES: usize = std::mem::size_of::<Hit>();

/// A triangle index no scene has: a recorded miss.
const MISS: u32 = u32::MAX;

/// Gather hits kept across the bakes of one room (module docs). Shared by the CPU backend's
/// uploaded scenes; safe to use from the passes' threads.
#[derive(Debug)]
pub struct GatherHits {
    budget: usize,
    state: RwLock<State>,
    replayed: AtomicU64,
    traced: AtomicU64,
}

/// One BVH's recorded rows.
type Rows = HashMap<RowKey, Arc<Row>>;

#[derive(Debug, Default)]
struct State {
    /// Per BVH the rows were traced in (weakly held: a dropped room's rows go at the next
    /// upload, and while any weak pointer lives its address is not reused), its rows.
    rooms: Vec<(Weak<EncodedScene>, Rows)>,
    bytes: usize,
}

impl State {
    /// Where the rows traced in `bvh` are.
    fn room(&self, bvh: &Arc<EncodedScene>) -> Option<usize> {
        self.rooms
            .iter()
            .position(|(b, _)| std::ptr::eq(b.as_ptr(), Arc::as_ptr(bvh)))
    }
}

/// What places a gather row's rays: the pass's ray parameters, the traversal and the row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct RowKey {
    /// `[sampler, bounce, seed, stride, rays, orphan_rays, first_ray, chunk_rays]`.
    pub(crate) rays: [u32; 8],
    /// The traversal: 0 the wide BVH, else 1 + the encoded traversal's index.
    pub(crate) traversal: u32,
    /// `[layer, x0, y, width]` of the row in its tile.
    pub(crate) row: [u32; 4],
}

/// One recorded row: the hash of its rays' starts and its hits, in ray order.
#[derive(Debug)]
pub(crate) struct Row {
    inputs: u64,
    hits: Box<[Hit]>,
}

impl Row {
    /// Ray `i`'s hit (`None`: it missed).
    #[inline]
    pub(crate) fn hit(&self, i: usize) -> Option<Hit> {
        self.hits.get(i).copied().filter(|h| h.triangle != MISS)
    }

    /// Rays recorded.
    pub(crate) fn len(&self) -> usize {
        self.hits.len()
    }
}

/// How many rays [`GatherHits`] has served from its rows and how many were traced, and the
/// memory its rows take.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GatherHitStats {
    /// Gather rays whose hits were replayed.
    pub replayed: u64,
    /// Gather rays traced (and recorded while the budget allowed).
    pub traced: u64,
    /// Bytes of the recorded rows' hits.
    pub bytes: usize,
}

impl GatherHits {
    /// An empty cache that records rows while their hits take at most `budget` bytes.
    pub fn new(budget: usize) -> GatherHits {
        GatherHits {
            budget,
            state: RwLock::new(State::default()),
            replayed: AtomicU64::new(0),
            traced: AtomicU64::new(0),
        }
    }

    /// Counts since the cache was made, and the rows' memory.
    pub fn stats(&self) -> GatherHitStats {
        GatherHitStats {
            replayed: self.replayed.load(Ordering::Relaxed),
            traced: self.traced.load(Ordering::Relaxed),
            bytes: self.state.read().map_or(0, |s| s.bytes),
        }
    }

    /// Makes room for the rows of `bvh` (an uploaded scene's) and forgets those of BVHs no
    /// longer alive (rooms dropped).
    pub fn keep_for(&self, bvh: &Arc<EncodedScene>) {
        let Ok(mut s) = self.state.write() else {
            return;
        };
        let State { rooms, bytes } = &mut *s;
        rooms.retain(|(b, rows)| {
            let alive = b.strong_count() > 0;
            if !alive {
                *bytes -= rows.values().map(|r| r.len() * HIT_BYTES).sum::<usize>();
            }
            alive
        });
        if s.room(bvh).is_none() {
            s.rooms.push((Arc::downgrade(bvh), HashMap::new()));
        }
    }

    /// The recorded row `key` if its rays start from what `inputs` hashes and it holds `rays`
    /// rays, traced in `bvh`.
    pub(crate) fn row(
        &self,
        bvh: &Arc<EncodedScene>,
        key: &RowKey,
        inputs: u64,
        rays: usize,
    ) -> Option<Arc<Row>> {
        let s = self.state.read().ok()?;
        let row = s.rooms[s.room(bvh)?].1.get(key)?;
        (row.inputs == inputs && row.len() == rays).then(|| Arc::clone(row))
    }

    /// Whether `rays` more rays fit the budget (a hint: [`GatherHits::record`] checks again).
    pub(crate) fn has_room(&self, rays: usize) -> bool {
        self.state
            .read()
            .is_ok_and(|s| s.bytes + rays * HIT_BYTES <= self.budget)
    }

    /// Records row `key`'s hits (as [`recorded`] gives them), traced in `bvh`, if they fit
    /// the budget.
    pub(crate) fn record(&self, bvh: &Arc<EncodedScene>, key: RowKey, inputs: u64, hits: Vec<Hit>) {
        let bytes = hits.len() * HIT_BYTES;
        let row = Arc::new(Row {
            inputs,
            hits: hits.into_boxed_slice(),
        });
        let Ok(mut s) = self.state.write() else {
            return;
        };
        if s.bytes + bytes > self.budget {
            return;
        }
        let Some(room) = s.room(bvh) else {
            return;
        };
        if let Some(old) = s.rooms[room].1.insert(key, row) {
            s.bytes -= old.len() * HIT_BYTES;
        }
        s.bytes += bytes;
    }

    /// Counts `rays` replayed or traced.
    pub(crate) fn count(&self, rays: usize, replayed: bool) {
        let c = if replayed {
            &self.replayed
        } else {
            &self.traced
        };
        c.fetch_add(rays as u64, Ordering::Relaxed);
    }
}

/// A traced ray's hit as a row records it (a miss as a hit on a triangle no scene has).
#[inline]
pub(crate) fn recorded(hit: Option<Hit>) -> Hit {
    hit.unwrap_or(Hit {
        t: 0.0,
        triangle: MISS,
        u: 0.0,
        v: 0.0,
    })
}

/// A 64-bit hash of a stream of words (multiply, xor-shift per word; a final mix), for
/// [`Row`]'s inputs: it tells another G-buffer from the recorded one, it is not a defence
/// against crafted input.
#[derive(Debug, Clone, Copy)]
pub(crate) struct WordHash(u64);

impl WordHash {
    pub(crate) fn new() -> WordHash {
        WordHash(0x243f_6a88_85a3_08d3)
    }

    #[inline]
    pub(crate) fn add(&mut self, w: u32) {
        let h = (self.0 ^ u64::from(w)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        self.0 = h ^ (h >> 29);
    }

    pub(crate) fn finish(self) -> u64 {
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_word_changes_the_hash() {
        let hash = |words: &[u32]| {
            let mut h = WordHash::new();
            for &w in words {
                h.add(w);
            }
            h.finish()
        };
        let base = [1u32, 2, 3, 0x3f80_0000];
        let h0 = hash(&base);
        assert_eq!(h0, hash(&base));
        for i in 0..base.len() {
            for bit in [0, 1, 17, 31] {
                let mut w = base;
                w[i] ^= 1 << bit;
                assert_ne!(hash(&w), h0, "word {i} bit {bit}");
            }
        }
        // Order matters.
        assert_ne!(hash(&[1, 2]), hash(&[2, 1]));
    }
}
