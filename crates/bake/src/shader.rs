//! The shader sources of every [`Program`], GLSL ES 3.00 and WGSL side by side, and the
//! generated prefix that declares what the program's [`Signature`] says.
//!
//! `src/passes/<program>/<program>.glsl` and `.wgsl` hold a pass's two twins (they mirror
//! [`crate::cpu`] operation for operation); `shaders/lib/` holds the shared [`Library`] files.
//! A pass file declares nothing it gets from outside: the generated prefix holds
//!
//! - the BVH texel-layout constants (`luxbake_bvh::layout`), the traversal ids and choice, the
//!   blur constants ([`BLUR_NORMAL_COS`], [`MAX_BLUR_RADIUS`]) and the sampler ids
//!   ([`Sampler::id`], `LUX_SAMPLER_HASH`, `LUX_SAMPLER_SOBOL`) and the lamp paths' RNG pass
//!   (`LUX_CONNECT_PASS`);
//! - one declaration per read slot: `uniform highp sampler2DArray u_<slot>;` (GLSL, bound by
//!   name) or `@group(0) @binding(i) var lux_<slot>: texture_2d_array<f32>;` (WGSL, `i` = slot
//!   index);
//! - the parameter block: one `uniform <type> u_<field>;` per field (GLSL; padding omitted), or
//!   the struct `Lux…Params` bound as `lux_pass` at [`wgsl::PARAMS_BINDING`] (WGSL);
//! - WGSL only: the output `lux_out` and the tile `lux_tile` ([`TileParams`]). GLSL draws into
//!   the bound layer (`u_layer`, `common.glsl`) and restricts rows with the viewport.
//!
//! and the generated entry point after it ([`GLSL_ENTRY`], [`WGSL_ENTRY`]): a pass file only
//! defines the value of one texel, `vec4 luxRun(ivec3 c)` / `fn lux_run(c: vec2<i32>) ->
//! vec4<f32>`; the entry finds the texel of the invocation, skips those outside the tile and
//! writes the value.
//!
//! The `#version`/precision header of GLSL is the GL backend's (it differs between WebGL2 and
//! desktop contexts).

use luxbake_bvh::layout;

use crate::kept::Variant;
use crate::program::{
    BLUR_NORMAL_COS, Field, Library, MAX_BLUR_RADIUS, ParamBlock, Program, Scalar, Signature,
    TileParams,
};
use crate::rng::Sampler;
use crate::scene::BvhMode;

/// WGSL binding numbers (group 0: the pass; group 1: the scene).
pub mod wgsl {
    /// Group 0: the output storage texture.
    pub const OUT_BINDING: u32 = 8;
    /// Group 0: the tile ([`TileParams`](crate::program::TileParams)).
    pub const TILE_BINDING: u32 = 9;
    /// Group 0: the program's parameter block.
    pub const PARAMS_BINDING: u32 = 10;
    /// Group 1: BVH node bounds.
    pub const BOUNDS_BINDING: u32 = 0;
    /// Group 1: BVH links (MTBVH or TBVH).
    pub const LINKS_BINDING: u32 = 1;
    /// Group 1: triangle data.
    pub const TRIANGLES_BINDING: u32 = 2;
    /// Group 1: intensity tables.
    pub const IES_BINDING: u32 = 3;
    /// Group 1: object regions.
    pub const REGIONS_BINDING: u32 = 4;
    /// Group 1: the scene uniform block (`LuxScene`).
    pub const SCENE_BINDING: u32 = 5;
    /// Group 1: the lamps.
    pub const LAMPS_BINDING: u32 = 6;
    /// Group 1: the lamp paths' points.
    pub const LAMP_PATHS_BINDING: u32 = 7;
    /// Group 0: the kept gather hits a trace pass writes and a replaying gather reads
    /// ([`crate::kept`]; [`super::wgsl_gather_trace_source`], [`super::wgsl_gather_replay_source`]).
    pub const HITS_BINDING: u32 = 11;
}

/// How WGSL reads the encoded BVH and triangle data: both hold exactly the texels of
/// `luxbake_bvh::EncodedScene` and differ only in how a shader fetches them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BvhStorage {
    /// `array<vec4<f32>>` storage buffers indexed `(layer · h + y) · w + x`.
    #[default]
    Buffers,
    /// RGBA32F texture arrays read with `textureLoad`, as the paper (and GLSL) does.
    Textures,
}

/// The traversal id a program is compiled for: 0 MTBVH (also for [`BvhMode::Wide`]), 1 TBVH,
/// 2 brute force.
pub fn traversal_id(bvh: BvhMode) -> i32 {
    match bvh.encoded() {
        BvhMode::Wide | BvhMode::Mtbvh => 0,
        BvhMode::Tbvh => 1,
        BvhMode::None => 2,
    }
}

/// The traversal a program is compiled for: the pass's encoded traversal
/// ([`BvhMode::encoded`]), or brute force (none) for programs that cast no rays.
pub fn program_traversal(program: Program, bvh: BvhMode) -> BvhMode {
    if program.traces_rays() {
        bvh.encoded()
    } else {
        BvhMode::None
    }
}

/// The GLSL text of a library file.
pub fn glsl_library(lib: Library) -> &'static str {
    match lib {
        Library::Common => include_str!("../shaders/lib/common.glsl"),
        Library::Rng => include_str!("../shaders/lib/rng.glsl"),
        Library::Scene => include_str!("../shaders/lib/scene.glsl"),
        Library::Bvh => include_str!("../shaders/lib/bvh.glsl"),
        Library::Ies => include_str!("../shaders/lib/ies.glsl"),
        Library::Lamp => include_str!("../shaders/lib/lamp.glsl"),
        Library::Opening => include_str!("../shaders/lib/opening.glsl"),
        Library::Guide => include_str!("../shaders/lib/guide.glsl"),
        Library::Gather => include_str!("../shaders/lib/gather.glsl"),
        Library::Coarse => include_str!("../shaders/lib/coarse.glsl"),
    }
}

/// The WGSL files of a library (the BVH library's storage declarations first).
pub fn wgsl_library(lib: Library, storage: BvhStorage) -> Vec<&'static str> {
    match lib {
        Library::Common => vec![include_str!("../shaders/lib/common.wgsl")],
        Library::Rng => vec![include_str!("../shaders/lib/rng.wgsl")],
        Library::Scene => vec![include_str!("../shaders/lib/scene.wgsl")],
        Library::Bvh => vec![
            match storage {
                BvhStorage::Buffers => include_str!("../shaders/lib/bvh_buffers.wgsl"),
                BvhStorage::Textures => include_str!("../shaders/lib/bvh_textures.wgsl"),
            },
            include_str!("../shaders/lib/bvh.wgsl"),
        ],
        Library::Ies => vec![include_str!("../shaders/lib/ies.wgsl")],
        Library::Lamp => vec![include_str!("../shaders/lib/lamp.wgsl")],
        Library::Opening => vec![include_str!("../shaders/lib/opening.wgsl")],
        Library::Guide => vec![include_str!("../shaders/lib/guide.wgsl")],
        Library::Gather => vec![
            include_str!("../shaders/lib/gather.wgsl"),
            include_str!("../shaders/lib/gather_hit.wgsl"),
        ],
        Library::Coarse => vec![include_str!("../shaders/lib/coarse.wgsl")],
    }
}

/// The sampler uniform of read slot `slot` in GLSL.
pub fn glsl_slot(slot: &str) -> String {
    format!("u_{slot}")
}

/// The uniform of parameter field `field` in GLSL.
pub fn glsl_param(field: &Field) -> String {
    format!("u_{}", field.name)
}

/// The generated GLSL prefix of `program` compiled for traversal `bvh` (see the module docs):
/// constants, slot samplers and parameter uniforms. It follows the `#version` header.
pub fn glsl_prefix(program: Program, bvh: BvhMode) -> String {
    let sig = program.signature();
    let mut s = glsl_constants(program_traversal(program, bvh));
    for slot in sig.reads {
        s.push_str(&format!(
            "uniform highp sampler2DArray {};\n",
            glsl_slot(slot)
        ));
    }
    for f in sig.params.iter().filter(|f| !f.is_padding()) {
        s.push_str(&format!("uniform {} {};\n", f.ty.glsl(), glsl_param(f)));
    }
    s
}

/// The generated constants after the BVH layout's, in order: the traversal ids and the choice
/// `bvh`, the blur constants, the sampler ids, the RNG passes, the lattice step, the opening's
/// control variate's bounds and fewest probes, the narrow
/// texels' position w and the cells per side of the density proxy's grid; each a name, its
/// type and its value as both languages write it.
fn constants(bvh: BvhMode) -> Vec<(String, Scalar, String)> {
    let int = |name: &str, v: i32| (name.to_string(), Scalar::I32, v.to_string());
    let uint = |name: String, v: u32| (name, Scalar::U32, format!("{v}u"));
    let mut c = vec![
        int("LUX_TRAVERSAL_MTBVH", 0),
        int("LUX_TRAVERSAL_TBVH", 1),
        int("LUX_TRAVERSAL_NONE", 2),
        int("LUX_TRAVERSAL", traversal_id(bvh)),
        (
            "LUX_BLUR_NORMAL_COS".to_string(),
            Scalar::F32,
            format!("{BLUR_NORMAL_COS:?}"),
        ),
        int("LUX_MAX_BLUR_RADIUS", MAX_BLUR_RADIUS),
    ];
    for sampler in Sampler::ALL {
        let name = sampler.name().to_ascii_uppercase();
        c.push(uint(format!("LUX_SAMPLER_{name}"), sampler.id()));
    }
    c.push(uint("LUX_SOBOL_BLOCK".into(), crate::rng::SOBOL_BLOCK));
    c.push(uint(
        "LUX_CONNECT_PASS".into(),
        crate::lightpaths::CONNECT_PASS,
    ));
    c.push(uint(
        "LUX_OPENING_PASS".into(),
        crate::opening::OPENING_PASS,
    ));
    c.push(uint("LUX_PHI".into(), crate::opening::PHI));
    c.push((
        "LUX_CONTROL_MAX_ERROR".to_string(),
        Scalar::F32,
        format!("{:?}", crate::opening::CONTROL_MAX_ERROR),
    ));
    c.push(uint(
        "LUX_CONTROL_MIN_PROBES".into(),
        crate::opening::CONTROL_MIN_PROBES,
    ));
    c.push((
        "LUX_CONTROL_MAX_CANCELLATION".to_string(),
        Scalar::F32,
        format!("{:?}", crate::opening::CONTROL_MAX_CANCELLATION),
    ));

    c.push((
        "LUX_NARROW".to_string(),
        Scalar::F32,
        format!("{:?}", crate::validity::NARROW),
    ));
    c.push((
        "LUX_NARROW_GAP".to_string(),
        Scalar::F32,
        format!("{:?}", crate::validity::NARROW_GAP),
    ));
    c.push(int(
        "LUX_PROXY_CELLS",
        crate::lightpaths::PROXY_CELLS as i32,
    ));
    // 1 in the idle programs of the refine and connect passes (`Variant::Idle`, `idle`).
    c.push(uint("LUX_IDLE".into(), 0));
    c
}

/// The idle program ([`Variant::Idle`]) from the source of the plain one: `LUX_IDLE` 1 instead
/// of 0 (its `#define` in GLSL, its `const` in WGSL), so that the compilers drop the code
/// behind `LUX_IDLE != 0u`.
fn idle(source: String) -> String {
    let (glsl, wgsl) = ("#define LUX_IDLE 0u\n", "const LUX_IDLE: u32 = 0u;\n");
    let plain = if source.contains(glsl) { glsl } else { wgsl };
    source.replacen(plain, &plain.replace("0u", "1u"), 1)
}

/// The generated GLSL constants: BVH layout, then the shared constants (blur, sampler ids,
/// RNG passes, the lattice step) as `#define`s.
pub fn glsl_constants(bvh: BvhMode) -> String {
    let mut s = layout::glsl_defines();
    for (name, _, value) in constants(bvh) {
        s.push_str(&format!("#define {name} {value}\n"));
    }
    s
}

/// The generated WGSL constants: BVH layout, then the shared constants as `const`s.
pub fn wgsl_constants(bvh: BvhMode) -> String {
    let mut s = layout::wgsl_constants();
    for (name, ty, value) in constants(bvh) {
        s.push_str(&format!("const {name}: {} = {value};\n", ty.wgsl()));
    }
    s
}

/// What the gather's program ([`Program::Gather`]) gets after [`glsl_prefix`] to replay kept
/// hits instead of tracing its rays (the glow backend's kept gather hits): `LUX_REPLAY`, the
/// hits' sampler `u_hits` (layer `k` the hits of the dispatch's `k`-th ray, texel `(x, y)` the
/// tile's texel `u_hit_origin + (x, y)`) and `u_hit_origin`. `lib/gather.glsl`'s ray loop then
/// reads each ray's `(t, triangle, u, v)` where it would have called `luxTrace`.
pub const GLSL_GATHER_REPLAY: &str = "#define LUX_REPLAY 1\n\
    uniform highp sampler2DArray u_hits;\n\
    uniform ivec2 u_hit_origin;\n";

/// The GLSL files, after the gather's [`glsl_prefix`], of the glow backend's trace pass for
/// kept gather hits: the gather's libraries and `passes/gather/trace.glsl` (its own `main`),
/// which writes ray `u_first_ray`'s hit of every texel of the tile that [`GLSL_GATHER_REPLAY`]
/// reads back.
pub fn glsl_gather_trace_sources() -> Vec<&'static str> {
    let mut v: Vec<&'static str> = Program::Gather
        .signature()
        .libraries
        .iter()
        .map(|&l| glsl_library(l))
        .collect();
    v.push(include_str!("passes/gather/trace.glsl"));
    v
}

/// The GLSL prefix and files of `variant` of `pass` for traversal `bvh`: the pass's own
/// ([`glsl_prefix`], [`glsl_sources`]); the gather's trace pass, the gather's prefix with
/// [`glsl_gather_trace_sources`]; its replay, the gather after [`GLSL_GATHER_REPLAY`]; the idle
/// program, the pass's own with `LUX_IDLE` 1.
pub fn glsl_variant(pass: Program, bvh: BvhMode, variant: Variant) -> (String, Vec<&'static str>) {
    let mut prefix = glsl_prefix(pass, bvh);
    match variant {
        Variant::Plain => (prefix, glsl_sources(pass)),
        Variant::Idle => (idle(prefix), glsl_sources(pass)),
        Variant::Trace => (prefix, glsl_gather_trace_sources()),
        Variant::Replay => {
            prefix.push_str(GLSL_GATHER_REPLAY);
            (prefix, glsl_sources(pass))
        }
    }
}

/// The GLSL files of `program` after the prefix: its libraries, then the pass file.
pub fn glsl_sources(program: Program) -> Vec<&'static str> {
    let sig = program.signature();
    let mut v: Vec<&'static str> = sig.libraries.iter().map(|&l| glsl_library(l)).collect();
    v.push(program.signature().glsl);
    v.push(GLSL_ENTRY);
    v
}

/// The generated GLSL entry point: a pass file defines `vec4 luxRun(ivec3 c)`, the value of
/// texel `c` (x, y, layer); the fragment shader writes it.
pub const GLSL_ENTRY: &str = "\nvoid main() {\n    o_color = luxRun(luxTexel());\n}\n";

/// The generated WGSL entry point: a pass file defines `fn lux_run(c: vec2<i32>) -> vec4<f32>`,
/// the value of texel `c` of the tile's layer; the compute shader skips invocations outside
/// the tile and stores it.
pub const WGSL_ENTRY: &str = "
@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = lux_texel(gid);
    if (c.x < 0) {
        return;
    }
    lux_store(c, lux_run(c));
}
";

/// The WGSL declaration of a parameter struct named `name` with `fields`.
pub fn wgsl_struct(name: &str, fields: &[Field]) -> String {
    let mut s = format!("struct {name} {{\n");
    for f in fields {
        s.push_str(&format!("    {}: {},\n", f.name, f.ty.wgsl()));
    }
    s.push_str("}\n");
    s
}

/// The generated WGSL prefix of `program` compiled for traversal `bvh` (see the module docs).
pub fn wgsl_prefix(program: Program, bvh: BvhMode) -> String {
    let sig: &Signature = program.signature();
    let mut s = wgsl_constants(program_traversal(program, bvh));
    for (i, slot) in sig.reads.iter().enumerate() {
        s.push_str(&format!(
            "@group(0) @binding({i}) var lux_{slot}: texture_2d_array<f32>;\n"
        ));
    }
    s.push_str(&format!(
        "@group(0) @binding({}) var lux_out: texture_storage_2d_array<rgba32float, write>;\n",
        wgsl::OUT_BINDING
    ));
    s.push_str(&wgsl_struct(TileParams::WGSL_NAME, TileParams::FIELDS));
    s.push_str(&format!(
        "@group(0) @binding({}) var<uniform> lux_tile: {};\n",
        wgsl::TILE_BINDING,
        TileParams::WGSL_NAME
    ));
    if !sig.params.is_empty() {
        s.push_str(&wgsl_struct(sig.params_wgsl, sig.params));
        s.push_str(&format!(
            "@group(0) @binding({}) var<uniform> lux_pass: {};\n",
            wgsl::PARAMS_BINDING,
            sig.params_wgsl
        ));
    }
    s
}

/// The declaration of the kept gather hits' storage buffer ([`wgsl::HITS_BINDING`]), for the
/// trace pass (`read_write`) or the replaying gather (`read`).
fn wgsl_hits(access: &str) -> String {
    format!(
        "@group(0) @binding({}) var<storage, {access}> lux_hits: array<vec4<f32>>;\n",
        wgsl::HITS_BINDING
    )
}

/// The gather's WGSL ([`wgsl_source`] of [`Program::Gather`]) replaying kept hits
/// ([`crate::kept`]): `lux_gather_hit` reads ray `k`'s hit from plane `k` of `lux_hits` at the
/// texel's place in the tile (`passes/gather/replay.wgsl`) instead of tracing it
/// (`lib/gather_hit.wgsl`).
pub fn wgsl_gather_replay_source(bvh: BvhMode, storage: BvhStorage) -> String {
    let trace_hook = include_str!("../shaders/lib/gather_hit.wgsl");
    let replay_hook = include_str!("passes/gather/replay.wgsl");
    let source = wgsl_source(Program::Gather, bvh, storage);
    format!(
        "{}{}",
        wgsl_hits("read"),
        source.replacen(trace_hook, replay_hook, 1)
    )
}

/// The wgpu backend's trace pass for kept gather hits ([`crate::kept`]): the gather's prefix
/// and libraries, the hits' buffer and `passes/gather/trace.wgsl` (its own entry point), which
/// writes each ray of the dispatch's hit to plane `k` of `lux_hits` at the texel's place in
/// the tile.
pub fn wgsl_gather_trace_source(bvh: BvhMode, storage: BvhStorage) -> String {
    let mut s = wgsl_prefix(Program::Gather, bvh);
    s.push_str(&wgsl_hits("read_write"));
    for &lib in Program::Gather.signature().libraries {
        for f in wgsl_library(lib, storage) {
            s.push_str(f);
            s.push('\n');
        }
    }
    s.push_str(include_str!("passes/gather/trace.wgsl"));
    s
}

/// The WGSL module of `variant` of `pass` for traversal `bvh`, the BVH read from `storage`:
/// [`wgsl_source`], [`wgsl_gather_trace_source`], [`wgsl_gather_replay_source`], or the
/// pass's own source with `LUX_IDLE` 1.
pub fn wgsl_variant(pass: Program, bvh: BvhMode, storage: BvhStorage, variant: Variant) -> String {
    match variant {
        Variant::Plain => wgsl_source(pass, bvh, storage),
        Variant::Idle => idle(wgsl_source(pass, bvh, storage)),
        Variant::Trace => wgsl_gather_trace_source(bvh, storage),
        Variant::Replay => wgsl_gather_replay_source(bvh, storage),
    }
}

/// The complete WGSL module of `program` for traversal `bvh`, the BVH read from `storage`.
pub fn wgsl_source(program: Program, bvh: BvhMode, storage: BvhStorage) -> String {
    let mut s = wgsl_prefix(program, bvh);
    for &lib in program.signature().libraries {
        for f in wgsl_library(lib, storage) {
            s.push_str(f);
            s.push('\n');
        }
    }
    s.push_str(program.signature().wgsl);
    s.push('\n');
    s.push_str(WGSL_ENTRY);
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_idle_programs_differ_from_the_plain_ones_in_lux_idle_alone() {
        for p in Program::ALL {
            let has_idle = Variant::of(p).contains(&Variant::Idle);
            let returns = "if (LUX_IDLE != 0u)";
            let sig = p.signature();
            assert_eq!(sig.glsl.contains(returns), has_idle, "{}", p.label());
            assert_eq!(sig.wgsl.contains(returns), has_idle, "{}", p.label());
            if !has_idle {
                continue;
            }
            let (plain, sources) = glsl_variant(p, BvhMode::Mtbvh, Variant::Plain);
            let (idle, idle_sources) = glsl_variant(p, BvhMode::Mtbvh, Variant::Idle);
            assert_eq!(sources, idle_sources);
            assert_ne!(plain, idle);
            assert_eq!(plain.replace("LUX_IDLE 0u", "LUX_IDLE 1u"), idle);
            for storage in [BvhStorage::Buffers, BvhStorage::Textures] {
                let plain = wgsl_variant(p, BvhMode::Mtbvh, storage, Variant::Plain);
                let idle = wgsl_variant(p, BvhMode::Mtbvh, storage, Variant::Idle);
                assert_ne!(plain, idle);
                assert_eq!(
                    plain.replace("LUX_IDLE: u32 = 0u", "LUX_IDLE: u32 = 1u"),
                    idle
                );
            }
        }
        assert_eq!(Variant::plain_or_idle(Program::Refine, true), Variant::Idle);
        assert_eq!(
            Variant::plain_or_idle(Program::Refine, false),
            Variant::Plain
        );
        assert_eq!(
            Variant::plain_or_idle(Program::Gather, true),
            Variant::Plain
        );
    }

    #[test]
    fn the_gathers_replay_and_trace_sources_swap_the_ray_for_the_kept_hit() {
        let trace_hook = include_str!("../shaders/lib/gather_hit.wgsl");
        let replay_hook = include_str!("passes/gather/replay.wgsl");
        let plain = wgsl_source(Program::Gather, BvhMode::Mtbvh, BvhStorage::Buffers);
        assert_eq!(plain.matches(trace_hook).count(), 1);
        let replay = wgsl_gather_replay_source(BvhMode::Mtbvh, BvhStorage::Buffers);
        assert!(!replay.contains(trace_hook), "the replay still traces");
        assert_eq!(replay.matches(replay_hook).count(), 1);
        assert!(replay.contains("@binding(11) var<storage, read> lux_hits"));
        assert_eq!(replay.matches("fn main(").count(), 1);
        let trace = wgsl_gather_trace_source(BvhMode::Mtbvh, BvhStorage::Buffers);
        assert!(trace.contains("@binding(11) var<storage, read_write> lux_hits"));
        assert_eq!(trace.matches("fn main(").count(), 1);
        assert!(
            !trace.contains("fn lux_run("),
            "the trace pass has no gather output"
        );
        // GLSL: the trace pass has its own main; the replay defines LUX_REPLAY before the
        // library that tests it.
        let glsl_trace = glsl_gather_trace_sources().concat();
        assert_eq!(glsl_trace.matches("void main()").count(), 1);
        assert!(GLSL_GATHER_REPLAY.contains("#define LUX_REPLAY"));
        assert!(glsl_library(Library::Gather).contains("#ifdef LUX_REPLAY"));
    }

    #[test]
    fn prefixes_declare_every_slot_and_parameter_of_the_signature() {
        for p in Program::ALL {
            let sig = p.signature();
            let glsl = glsl_prefix(p, BvhMode::Tbvh);
            let wgsl = wgsl_prefix(p, BvhMode::Tbvh);
            for (i, slot) in sig.reads.iter().enumerate() {
                assert!(
                    glsl.contains(&format!("sampler2DArray u_{slot};")),
                    "{glsl}"
                );
                assert!(
                    wgsl.contains(&format!("@binding({i}) var lux_{slot}:")),
                    "{wgsl}"
                );
            }
            for f in sig.params {
                assert_eq!(
                    glsl.contains(&format!("uniform {} u_{};", f.ty.glsl(), f.name)),
                    !f.is_padding()
                );
                assert!(wgsl.contains(&format!("    {}: {},", f.name, f.ty.wgsl())));
            }
            assert_eq!(
                wgsl.contains("var<uniform> lux_pass"),
                !sig.params.is_empty()
            );
            let id = if p.traces_rays() { 1 } else { 2 };
            assert!(glsl.contains(&format!("#define LUX_TRAVERSAL {id}\n")));
            assert!(wgsl.contains(&format!("const LUX_TRAVERSAL: i32 = {id};")));
        }
    }

    #[test]
    fn generated_sampler_ids_are_the_rust_ones() {
        let glsl = glsl_constants(BvhMode::Mtbvh);
        let wgsl = wgsl_constants(BvhMode::Mtbvh);
        for s in Sampler::ALL {
            let name = s.name().to_ascii_uppercase();
            assert!(glsl.contains(&format!("#define LUX_SAMPLER_{name} {}u\n", s.id())));
            assert!(wgsl.contains(&format!("const LUX_SAMPLER_{name}: u32 = {}u;\n", s.id())));
        }
        // Every prefix carries them (the gather's included).
        assert!(glsl_prefix(Program::Gather, BvhMode::Tbvh).contains("#define LUX_SAMPLER_SOBOL"));
        assert!(wgsl_prefix(Program::Gather, BvhMode::Tbvh).contains("const LUX_SAMPLER_SOBOL"));
    }

    #[test]
    fn pass_files_declare_none_of_the_generated_names() {
        for p in Program::ALL {
            let pass_glsl = p.signature().glsl;
            let pass_wgsl = p.signature().wgsl;
            assert!(pass_glsl.starts_with("// Pass \""), "{}", p.label());
            assert!(pass_wgsl.starts_with("// Pass \""), "{}", p.label());
            for slot in p.signature().reads {
                assert!(!pass_glsl.contains(&format!("sampler2DArray u_{slot};")));
                assert!(!pass_wgsl.contains(&format!("var lux_{slot}:")));
            }
            assert!(!pass_glsl.contains("\nuniform "), "{}", p.label());
            assert!(!pass_wgsl.contains("@binding"), "{}", p.label());
            // The entry points are generated: a pass file defines the texel's value only.
            assert!(
                pass_glsl.contains("\nvec4 luxRun(ivec3 c) {\n"),
                "{}",
                p.label()
            );
            assert!(pass_wgsl.contains("\nfn lux_run(c: vec2<i32>) -> vec4<f32> {\n"));
            for generated in ["void main()", "o_color", "@compute", "lux_store"] {
                assert!(!pass_glsl.contains(generated) && !pass_wgsl.contains(generated));
            }
        }
    }

    /// The array *values* of a WGSL module that it reads element by element: `let` arrays,
    /// array parameters, and `let`s holding what a function returns that is an array or a
    /// struct with one. Naga's SPIR-V reads an element of an array value at a variable index by
    /// first copying the whole array into a temporary, at every such read: the variance pass's
    /// two 25-tap windows, passed by value, made it take 3.5 s on lavapipe where the same pass
    /// in GLSL takes 0.5 s on llvmpipe. A variable (`var`) or a `ptr<function, …>` parameter
    /// is read in place.
    fn array_values(source: &str) -> Vec<String> {
        let code: String = source
            .lines()
            .map(|l| l.split_once("//").map_or(l, |(code, _)| code))
            .collect::<Vec<_>>()
            .join("\n");
        let word = |s: &str| -> String {
            s.trim_start()
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect()
        };
        // A keyword at the start of a word.
        let starts = |kw: &'static str| {
            code.match_indices(kw)
                .filter(|&(i, _)| {
                    i == 0 || !code[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_')
                })
                .map(|(i, _)| &code[i + kw.len()..])
                .collect::<Vec<&str>>()
        };
        let holders: Vec<String> = starts("struct ")
            .into_iter()
            .filter(|rest| rest.split('}').next().is_some_and(|b| b.contains("array<")))
            .map(word)
            .collect();
        let mut found = Vec::new();
        let mut returners = Vec::new();
        for rest in starts("fn ") {
            let header = rest.split('{').next().unwrap_or("");
            let name = word(header);
            if header.contains(": array<") {
                found.push(format!("`{name}` takes an array by value"));
            }
            let ret = header.rsplit_once("->").map_or("", |(_, r)| r.trim());
            if ret.starts_with("array<") || holders.contains(&word(ret)) {
                returners.push(name);
            }
        }
        for rest in starts("let ") {
            let Some((name, value)) = rest.split(';').next().and_then(|d| d.split_once('=')) else {
                continue;
            };
            let (name, value) = (word(name), value.trim_start());
            let call = word(value);
            if value.starts_with("array<") || returners.contains(&call) {
                found.push(format!("`let {name}` holds an array value"));
            }
        }
        found
    }

    #[test]
    fn no_wgsl_module_reads_an_array_value_element_by_element() {
        // The finder finds what it is for.
        let bad = "struct S { a: array<f32, 4>, }\n\
            fn f(x: array<f32, 4>) -> f32 { return x[0]; }\n\
            fn g() -> S { var s: S; return s; }\n\
            fn h(p: ptr<function, array<f32, 4>>) -> f32 { let w = array<f32, 2>(1.0, 2.0); \
            let s = g(); var ok = g(); return (*p)[0]; }\n";
        assert_eq!(
            array_values(bad),
            [
                "`f` takes an array by value",
                "`let w` holds an array value",
                "`let s` holds an array value",
            ]
        );
        for p in Program::ALL {
            for storage in [BvhStorage::Buffers, BvhStorage::Textures] {
                for &v in Variant::of(p) {
                    let module = wgsl_variant(p, BvhMode::Mtbvh, storage, v);
                    let found = array_values(&module);
                    assert!(found.is_empty(), "{} {v:?}: {found:?}", p.label());
                }
            }
        }
    }
}
