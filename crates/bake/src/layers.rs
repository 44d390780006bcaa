//! Per-lamp layers: each lamp's light baked apart, recombined without a ray.
//!
//! Every light map of a bake except the albedo is linear in each lamp's intensity: the direct
//! light is `I·multiplier·colour·cos θ/d²`, and every later stage (blur, × albedo, gather,
//! combine, the tail, the denoiser) is linear in it or, where it decides something (where the
//! bounces stop, the tail's weight, the denoiser's noise estimate), decides on ratios that a
//! scale does not change. [`bake_layers`] therefore bakes each lamp alone, at multiplier 1 in
//! its own colour, on one prepared [`Room`]; [`LampLayers::combine`] sums the layers weighted
//! by each lamp's [`LampState`] (its multiplier, its colour over the baked one, or nothing when
//! it is off). Dimming, tinting or switching a lamp casts no ray.
//!
//! Dimming and switching give exactly what a fresh bake gives (up to rounding). A new colour
//! is exact for the direct light and every bounce; only the converged method's tail (one
//! weight from the RGB sum of the bounce series, [`crate::series`]) was estimated for the
//! baked colour, so a strong change of tint differs from a fresh bake by a small part of the
//! tail (a test bounds it).
//!
//! A layered bake of two lamps is not the same Monte Carlo estimate as one bake of both (each
//! layer has its own lamp paths and bounce decisions); both converge to the same light. A
//! layered bake of one lamp at multiplier `m` equals `m` × its layer up to rounding (a test
//! checks 1e-5 relative).
//!
//! Memory: each extra lamp keeps its own [`ObjectMaps`], seven linear stages of
//! `4 × f32` per texel of every receiver's region: 112 bytes per region texel
//! ([`LampLayers::bytes_per_lamp`]).

use rayon::prelude::*;
use web_time::Instant;

use crate::backend::GpuBackend;
use crate::bake::{BakeError, BakeOutput, Progress, bake_room};
use crate::map::MapImage;
use crate::prepare::Room;
use crate::report::{LampModelChoice, ObjectMaps};
use crate::scene::{Lamp, Settings};

/// How a lamp lights a recombination ([`LampLayers::combine`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LampState {
    /// Dimmer: scalar on every intensity (≥ 0).
    pub multiplier: f32,
    /// Linear RGB tint (each ≥ 0).
    pub color: [f32; 3],
    /// Whether the lamp is switched on.
    pub on: bool,
}

impl LampState {
    /// The state `lamp` is baked with: its multiplier and colour, on.
    pub fn of(lamp: &Lamp) -> LampState {
        LampState {
            multiplier: lamp.multiplier,
            color: lamp.color,
            on: true,
        }
    }

    /// Per-channel weight of the lamp's layer: `multiplier × colour`, 0 when off.
    pub fn weight(&self) -> [f32; 3] {
        if self.on {
            self.color.map(|c| self.multiplier * c)
        } else {
            [0.0; 3]
        }
    }

    /// Checks that the multiplier and colour are finite and ≥ 0.
    ///
    /// # Errors
    /// [`LayerError::State`] naming the field.
    fn validate(&self, lamp: usize) -> Result<(), LayerError> {
        let bad = |v: f32| !(v.is_finite() && v >= 0.0);
        if bad(self.multiplier) {
            return Err(LayerError::State {
                lamp,
                field: "multiplier",
            });
        }
        if self.color.into_iter().any(bad) {
            return Err(LayerError::State {
                lamp,
                field: "color",
            });
        }
        Ok(())
    }
}

/// A recombination that cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LayerError {
    /// Not one state per lamp.
    #[error("{given} lamp states for {lamps} lamps")]
    Count {
        /// States given.
        given: usize,
        /// Lamps baked.
        lamps: usize,
    },
    /// A state's multiplier or colour is negative, NaN or infinite.
    #[error("lamp {lamp}: `{field}` must be finite and >= 0")]
    State {
        /// The lamp.
        lamp: usize,
        /// `multiplier` or `color`.
        field: &'static str,
    },
}

/// A bake kept per lamp: each lamp's maps at multiplier 1 in its own colour.
#[derive(Debug, Clone)]
pub struct LampLayers {
    /// One bake per lamp of the scene, in order, lit by that lamp alone at multiplier 1.
    pub layers: Vec<BakeOutput>,
    /// The colour each layer was baked in: the lamp's, or white where the lamp's has a
    /// channel at 0 (which a layer could not bring back).
    pub colors: Vec<[f32; 3]>,
    /// Seconds the whole layered bake took.
    pub total_seconds: f64,
}

/// Bakes the prepared `room` once per lamp of `lamps`, each alone at multiplier 1 in its
/// colour (see the module docs). A scene without lamps gives no layers.
///
/// # Errors
/// What [`bake_room`] returns for the first lamp that fails.
pub fn bake_layers<B: GpuBackend>(
    backend: &mut B,
    room: &Room,
    lamps: &[Lamp],
    settings: &Settings,
    progress: &mut dyn FnMut(&Progress<'_>),
) -> Result<LampLayers, BakeError<B::Error>> {
    let start = Instant::now();
    let colors: Vec<[f32; 3]> = lamps
        .iter()
        .map(|l| {
            if l.color.iter().all(|&c| c > 0.0 && c.is_finite()) {
                l.color
            } else {
                [1.0; 3]
            }
        })
        .collect();
    let mut layers = Vec::with_capacity(lamps.len());
    for (lamp, &color) in lamps.iter().zip(&colors) {
        let unit = Lamp {
            multiplier: 1.0,
            color,
            ..lamp.clone()
        };
        layers.push(bake_room(
            backend,
            room,
            std::slice::from_ref(&unit),
            settings,
            progress,
        )?);
    }
    Ok(LampLayers {
        layers,
        colors,
        total_seconds: start.elapsed().as_secs_f64(),
    })
}

impl LampLayers {
    /// Bytes one more lamp keeps: seven `4 × f32` stages per texel of every receiver's
    /// region (the albedo is shared).
    pub fn bytes_per_lamp(&self) -> u64 {
        self.layers
            .first()
            .map_or(0, |l| 7 * 16 * l.report.region_texels)
    }

    /// The maps of every lamp lit as `states` says (one per lamp, in order): each linear stage
    /// `Σ_i (weight_i / colour_i) ⊙ layer_i` per channel ([`LampState::weight`], the layer's
    /// baked colour [`LampLayers::colors`]); the albedo and the
    /// texel mask (alpha) are the first layer's. The result is a [`BakeOutput`] like the first
    /// layer's: its report sums the rays and passes of every layer, and its `lamps_used` lists
    /// the lamps that are on and light something. No ray is cast.
    ///
    /// # Errors
    /// [`LayerError`] for a wrong number of states or a negative or non-finite one.
    pub fn combine(&self, states: &[LampState]) -> Result<BakeOutput, LayerError> {
        if states.len() != self.layers.len() {
            return Err(LayerError::Count {
                given: states.len(),
                lamps: self.layers.len(),
            });
        }
        for (i, s) in states.iter().enumerate() {
            s.validate(i)?;
        }
        let Some(first) = self.layers.first() else {
            return Err(LayerError::Count { given: 0, lamps: 0 });
        };
        let weights: Vec<[f32; 3]> = states
            .iter()
            .zip(&self.colors)
            .map(|(s, baked)| {
                let w = s.weight();
                [0, 1, 2].map(|c| w[c] / baked[c])
            })
            .collect();
        let maps = first
            .maps
            .iter()
            .enumerate()
            .map(|(o, object)| self.combine_object(o, object, &weights))
            .collect();
        let mut out = BakeOutput {
            settings: first.settings.clone(),
            layout: first.layout.clone(),
            graph: first.graph.clone(),
            maps,
            lamps_used: Vec::new(),
            report: first.report.clone(),
        };
        let r = &mut out.report;
        r.shadow_rays = 0;
        r.gather_rays = 0;
        r.passes.clear();
        r.setup.clear();
        r.skipped.clear();
        r.lamp_models.clear();
        for (i, layer) in self.layers.iter().enumerate() {
            let l = &layer.report;
            r.shadow_rays += l.shadow_rays;
            r.gather_rays += l.gather_rays;
            r.bounces_run = r.bounces_run.max(l.bounces_run);
            r.passes.extend(l.passes.iter().cloned());
            r.setup.extend(l.setup.iter().copied());
            r.skipped.extend(l.skipped.iter().cloned());
            // Each layer bakes one lamp as the scene's lamp 0: its index is the layer's.
            r.lamp_models
                .extend(l.lamp_models.iter().map(|c| LampModelChoice {
                    lamp: i,
                    ..c.clone()
                }));
            if states[i].on && !layer.lamps_used.is_empty() {
                out.lamps_used.push(i);
            }
        }
        r.total_seconds = self.total_seconds;
        Ok(out)
    }

    /// Object `o`'s maps (`object` in the first layer) recombined with `weights`.
    fn combine_object(&self, o: usize, object: &ObjectMaps, weights: &[[f32; 3]]) -> ObjectMaps {
        let stages = std::array::from_fn(|s| {
            let first = object.stages[s].as_ref()?;
            // Stage 0 is the albedo: the same in every layer, not light.
            if s == 0 {
                return Some(first.clone());
            }
            let sources: Vec<(&[f32], [f32; 3])> = self
                .layers
                .iter()
                .zip(weights)
                .filter_map(|(layer, w)| {
                    let m = layer.maps.get(o)?.stages.get(s)?.as_ref()?;
                    (m.texels.len() == first.texels.len()).then_some((m.texels.as_slice(), *w))
                })
                .collect();
            let mut texels = vec![0.0f32; first.texels.len()];
            // In parallel, in chunks of 4096 texels.
            texels
                .par_chunks_mut(4 * 4096)
                .enumerate()
                .for_each(|(chunk, out)| {
                    let base = chunk * 4 * 4096;
                    for (i, t) in out.chunks_exact_mut(4).enumerate() {
                        let k = base + 4 * i;
                        let mut sum = [0.0f32; 3];
                        for (m, w) in &sources {
                            for c in 0..3 {
                                sum[c] += w[c] * m[k + c];
                            }
                        }
                        for c in 0..3 {
                            t[c] = if sum[c].is_finite() { sum[c] } else { 0.0 };
                        }
                        t[3] = first.texels[k + 3];
                    }
                });
            Some(MapImage {
                width: first.width,
                height: first.height,
                texels,
            })
        });
        ObjectMaps {
            object: object.object,
            name: object.name.clone(),
            region: object.region,
            stages,
        }
    }
}
