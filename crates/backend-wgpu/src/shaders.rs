//! WGSL sources (one file per pass in `shaders/`, side by side) and the generated prefix.
//!
//! Every module is [`prefix`] + library files + the pass file. The prefix holds the texel-layout
//! constants of the BVH encoding (`luxbake_bvh::layout::wgsl_constants`), the traversal choice
//! and the blur constants of the CPU reference, so shaders and Rust cannot drift.
//!
//! | pass (paper Figure 4 box) | file | library files |
//! |---|---|---|
//! | direct (2) | `direct.wgsl` | `common`, `scene`, `bvh_*`, `bvh`, `ies` |
//! | copy (2 → 3, 6 → 7) | `copy.wgsl` | `common` |
//! | blur (3, 7) | `blur.wgsl` | `common` |
//! | albedo multiply (4, 8) | `albedo_mul.wgsl` | `common` |
//! | gather (5) | `gather.wgsl` | `common`, `rng`, `scene`, `bvh_*`, `bvh` |
//! | combine (6) | `combine.wgsl` | `common` |
//!
//! `bvh_*` is `bvh_buffers.wgsl` (storage buffers, the default) or `bvh_textures.wgsl` (the
//! paper's texture arrays), see [`BvhStorage`].

pub(crate) use luxbake::graph::Program as Pass;
use luxbake::scene::BvhMode;
use luxbake_bvh::layout;

const COMMON: &str = include_str!("../shaders/common.wgsl");
const RNG: &str = include_str!("../shaders/rng.wgsl");
const SCENE: &str = include_str!("../shaders/scene.wgsl");
const BVH_BUFFERS: &str = include_str!("../shaders/bvh_buffers.wgsl");
const BVH_TEXTURES: &str = include_str!("../shaders/bvh_textures.wgsl");
const BVH: &str = include_str!("../shaders/bvh.wgsl");
const IES: &str = include_str!("../shaders/ies.wgsl");
const DIRECT: &str = include_str!("../shaders/direct.wgsl");
const COPY: &str = include_str!("../shaders/copy.wgsl");
const BLUR: &str = include_str!("../shaders/blur.wgsl");
const ALBEDO_MUL: &str = include_str!("../shaders/albedo_mul.wgsl");
const GATHER: &str = include_str!("../shaders/gather.wgsl");
const COMBINE: &str = include_str!("../shaders/combine.wgsl");

/// Where the ray-casting passes read the encoded BVH and triangle data from.
///
/// Both hold exactly the texels of [`luxbake_bvh::EncodedScene`]; they differ only in how a
/// shader fetches them. Measured on lavapipe (see the crate docs): storage buffers are faster,
/// so they are the default.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BvhStorage {
    /// `array<vec4<f32>>` storage buffers indexed `(layer · h + y) · w + x`.
    #[default]
    Buffers,
    /// RGBA32F texture arrays read with `textureLoad`, as the paper (and the glow backend) does.
    Textures,
}

/// Which traversal a ray-casting module is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) enum Traversal {
    /// Six link orders; the layer is picked from the ray's dominant direction.
    Mtbvh,
    /// One threaded link order.
    Tbvh,
    /// Every triangle tested.
    None,
}

impl Traversal {
    pub(crate) fn of(mode: BvhMode) -> Traversal {
        match mode {
            BvhMode::Mtbvh => Traversal::Mtbvh,
            BvhMode::Tbvh => Traversal::Tbvh,
            BvhMode::None => Traversal::None,
        }
    }

    fn value(self) -> i32 {
        match self {
            Traversal::Mtbvh => 0,
            Traversal::Tbvh => 1,
            Traversal::None => 2,
        }
    }
}

/// The WGSL module and bindings of each [`Pass`] (the core's shader program enum).
pub(crate) trait PassShaders {
    /// Number of graph textures the pass reads (bindings 0 .. n of group 0).
    fn reads(self) -> usize;
    /// The full WGSL source of the pass for `traversal` and `storage`.
    fn source(self, traversal: Traversal, storage: BvhStorage) -> String;
}

impl PassShaders for Pass {
    fn reads(self) -> usize {
        match self {
            Pass::Copy => 1,
            Pass::Direct | Pass::Blur | Pass::AlbedoMul | Pass::Combine => 2,
            Pass::Gather => 3,
        }
    }

    fn source(self, traversal: Traversal, storage: BvhStorage) -> String {
        let bvh_access = match storage {
            BvhStorage::Buffers => BVH_BUFFERS,
            BvhStorage::Textures => BVH_TEXTURES,
        };
        let files: &[&str] = match self {
            Pass::Direct => &[COMMON, SCENE, bvh_access, BVH, IES, DIRECT],
            Pass::Copy => &[COMMON, COPY],
            Pass::Blur => &[COMMON, BLUR],
            Pass::AlbedoMul => &[COMMON, ALBEDO_MUL],
            Pass::Gather => &[COMMON, RNG, SCENE, bvh_access, BVH, GATHER],
            Pass::Combine => &[COMMON, COMBINE],
        };
        let mut s = prefix(traversal);
        for f in files {
            s.push_str(f);
            s.push('\n');
        }
        s
    }
}

/// The generated constants of every module: the BVH layout, the traversal choice and the blur
/// constants of the CPU reference.
pub(crate) fn prefix(traversal: Traversal) -> String {
    format!(
        "{}const LUX_TRAVERSAL_MTBVH: i32 = 0;\nconst LUX_TRAVERSAL_TBVH: i32 = 1;\n\
         const LUX_TRAVERSAL_NONE: i32 = 2;\nconst LUX_TRAVERSAL: i32 = {};\n\
         const LUX_BLUR_NORMAL_COS: f32 = {:?};\nconst LUX_MAX_BLUR_RADIUS: i32 = {};\n",
        layout::wgsl_constants(),
        traversal.value(),
        luxbake::cpu::BLUR_NORMAL_COS,
        luxbake::cpu::MAX_BLUR_RADIUS,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use wgpu::naga;

    /// Parses and validates `source` with naga (the validator wgpu itself runs).
    fn validate(label: &str, source: &str) -> naga::Module {
        let module = naga::front::wgsl::parse_str(source)
            .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(source)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{label}: {}", e.emit_to_string(source)));
        module
    }

    #[test]
    fn every_pass_validates_with_naga_for_every_traversal_and_storage() {
        for pass in Pass::ALL {
            for storage in [BvhStorage::Buffers, BvhStorage::Textures] {
                for traversal in [Traversal::Mtbvh, Traversal::Tbvh, Traversal::None] {
                    let label = format!("{} {traversal:?} {storage:?}", pass.label());
                    let module = validate(&label, &pass.source(traversal, storage));
                    let entry: Vec<_> = module.entry_points.iter().map(|e| &e.name).collect();
                    assert_eq!(entry, ["main"], "{label}");
                    assert_eq!(
                        module.entry_points[0].stage,
                        naga::ShaderStage::Compute,
                        "{label}"
                    );
                }
            }
        }
    }

    #[test]
    fn generated_constants_match_the_rust_side() {
        let p = prefix(Traversal::Tbvh);
        assert!(p.contains(&layout::wgsl_constants()));
        assert!(p.contains("const LUX_TRAVERSAL: i32 = 1;"));
        // The prefix parses to the same values as the Rust constants.
        let module = validate(
            "prefix",
            &format!("{p}\n@compute @workgroup_size(1) fn main() {{}}"),
        );
        let find = |name: &str| {
            module
                .constants
                .iter()
                .find(|(_, c)| c.name.as_deref() == Some(name))
                .map(|(_, c)| module.global_expressions[c.init].clone())
                .unwrap_or_else(|| panic!("constant {name} missing"))
        };
        use naga::{Expression, Literal};
        assert!(matches!(
            find("LUX_TRIANGLE_LAYERS"),
            Expression::Literal(Literal::I32(v)) if v == layout::TRIANGLE_LAYERS as i32
        ));
        assert!(matches!(
            find("LUX_BOX_SLACK"),
            Expression::Literal(Literal::F32(v)) if v == layout::BOX_SLACK
        ));
        assert!(matches!(
            find("LUX_BLUR_NORMAL_COS"),
            Expression::Literal(Literal::F32(v)) if v == luxbake::cpu::BLUR_NORMAL_COS
        ));
        assert!(matches!(
            find("LUX_MAX_BLUR_RADIUS"),
            Expression::Literal(Literal::I32(v)) if v == luxbake::cpu::MAX_BLUR_RADIUS
        ));
    }

    #[test]
    fn the_pass_parameter_block_is_sixty_four_bytes() {
        // backend::Params writes 16 words; the WGSL struct must have the same size.
        let module = validate(
            "common",
            &format!(
                "{}{COMMON}\n@compute @workgroup_size(1) fn main() {{}}",
                prefix(Traversal::None)
            ),
        );
        let (_, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some("LuxParams"))
            .expect("LuxParams");
        assert_eq!(ty.inner.size(module.to_ctx()), 64);
    }
}
