//! The WGSL modules: the core's shader sources (`luxbake::shader`, one file per pass under
//! `crates/bake/src/passes/<pass>/`, side by side with its GLSL twin) after the generated prefix of
//! the program's signature; `luxbake::shader::wgsl_source` assembles them. The bindings are
//! `luxbake::shader::wgsl`'s.
//!
//! The BVH library is read from storage buffers (the default) or texture arrays, see
//! [`BvhStorage`]: measured on lavapipe (see the crate docs), storage buffers are faster.

pub use luxbake::shader::BvhStorage;

#[cfg(test)]
mod tests {
    use luxbake::kept::Variant;
    use luxbake::program::{
        BLUR_NORMAL_COS, BlurParams, DirectParams, Field, GatherParams, Library, MAX_BLUR_RADIUS,
        ParamBlock, Program, TileParams,
    };
    use luxbake::rng::Sampler;
    use luxbake::scene::BvhMode;
    use luxbake::shader::{BvhStorage, wgsl_constants, wgsl_library, wgsl_source, wgsl_variant};
    use luxbake_bvh::layout;
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

    const TRAVERSALS: [BvhMode; 3] = [BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None];

    #[test]
    fn every_program_validates_with_naga_for_every_traversal_and_storage() {
        // Every pass, and the gather's trace pass and replay (kept hits, `luxbake::kept`).
        let mut checked = 0;
        for (pass, &variant) in Program::ALL
            .into_iter()
            .flat_map(|p| Variant::of(p).iter().map(move |v| (p, v)))
        {
            let name = variant.label(pass);
            checked += 1;
            for storage in [BvhStorage::Buffers, BvhStorage::Textures] {
                for traversal in TRAVERSALS {
                    let label = format!("{name} {traversal:?} {storage:?}");
                    let source = wgsl_variant(pass, traversal, storage, variant);
                    let module = validate(&label, &source);
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
        assert_eq!(
            checked,
            Program::ALL.len() + 4,
            "the gather's trace and replay, the refine and connect passes' idle programs"
        );
    }

    /// The members of WGSL struct `name` in `module`: (name, offset).
    fn members(module: &naga::Module, name: &str) -> Vec<(String, u32)> {
        let (_, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("struct {name} missing"));
        match &ty.inner {
            naga::TypeInner::Struct { members, .. } => members
                .iter()
                .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                .collect(),
            other => panic!("{name} is not a struct: {other:?}"),
        }
    }

    fn expected(fields: &[Field]) -> Vec<(String, u32)> {
        fields
            .iter()
            .map(|f| (f.name.to_owned(), f.offset as u32))
            .collect()
    }

    #[test]
    fn parameter_structs_match_the_rust_blocks_field_by_field() {
        let cases = [
            ("gather", Program::Gather, BvhMode::Mtbvh),
            ("direct", Program::Direct, BvhMode::Tbvh),
            ("blur", Program::Blur, BvhMode::None),
        ];
        let [gather, direct, module] = cases.map(|(label, program, mode)| {
            validate(label, &wgsl_source(program, mode, BvhStorage::Buffers))
        });
        for (module, name, fields) in [
            (&gather, TileParams::WGSL_NAME, TileParams::FIELDS),
            (&gather, GatherParams::WGSL_NAME, GatherParams::FIELDS),
            (&direct, DirectParams::WGSL_NAME, DirectParams::FIELDS),
            (&module, BlurParams::WGSL_NAME, BlurParams::FIELDS),
        ] {
            assert_eq!(members(module, name), expected(fields), "{name}");
        }
        // The uniform blocks have their Rust sizes.
        for (name, size) in [
            (TileParams::WGSL_NAME, std::mem::size_of::<TileParams>()),
            (BlurParams::WGSL_NAME, std::mem::size_of::<BlurParams>()),
        ] {
            let (_, ty) = module
                .types
                .iter()
                .find(|(_, t)| t.name.as_deref() == Some(name))
                .expect("struct");
            assert_eq!(ty.inner.size(module.to_ctx()) as usize, size, "{name}");
        }
    }

    /// Per (case, texel): the hash, both uniforms of the hash sampler, the Sobol sampler's
    /// bits, both samplers' uniforms through `lux_sample2` with their generated ids (as
    /// bits), then the streams (`rng::Stream`): the Sobol sampler's gather (stride `pass - 1`,
    /// `sample` rays) and refinement (`seed` rays, then `sample` more), and the hash
    /// sampler's gather: 16 words.
    const RNG_CS: &str = "@group(0) @binding(0) var<storage, read> cases: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> words: array<u32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let size = vec2<u32>(97u, 61u);
    if (gid.x >= size.x * size.y) {
        return;
    }
    let c = cases[gid.y];
    let t = lux_texel_index(size, c.w, gid.x % size.x, gid.x / size.x);
    let h = lux_uniform2(t, c.x, c.y, c.z);
    let b = lux_sobol2_bits(t, c.x, c.y, c.z);
    let sh = lux_sample2(LUX_SAMPLER_HASH, t, c.x, c.y, c.z);
    let ss = lux_sample2(LUX_SAMPLER_SOBOL, t, c.x, c.y, c.z);
    let o = 16u * (gid.y * size.x * size.y + gid.x);
    words[o] = lux_hash(t, c.x, c.y, c.z);
    words[o + 1u] = bitcast<u32>(h.x);
    words[o + 2u] = bitcast<u32>(h.y);
    words[o + 3u] = b.x;
    words[o + 4u] = b.y;
    words[o + 5u] = bitcast<u32>(lux_sobol2(t, c.x, c.y, c.z).x);
    words[o + 6u] = bitcast<u32>(sh.x);
    words[o + 7u] = bitcast<u32>(sh.y);
    words[o + 8u] = bitcast<u32>(ss.x);
    words[o + 9u] = bitcast<u32>(ss.y);
    let x = gid.x % size.x;
    let y = gid.x / size.x;
    let g = lux_gather_stream(LUX_SAMPLER_SOBOL, size, c.w, x, y, c.y - 1u, c.x);
    let r = lux_refine_stream(LUX_SAMPLER_SOBOL, size, c.w, x, y, c.z, c.x);
    let gh = lux_gather_stream(LUX_SAMPLER_HASH, size, c.w, x, y, c.y - 1u, c.x);
    words[o + 10u] = g.x;
    words[o + 11u] = g.y;
    words[o + 12u] = r.x;
    words[o + 13u] = r.y;
    words[o + 14u] = gh.x;
    words[o + 15u] = gh.y;
}
";

    /// Runs [`RNG_CS`] on the device for `cases` (sample, pass, seed, layer) and reads back
    /// its words.
    fn rng_words(gpu: &crate::device::Gpu, cases: &[[u32; 4]], texels: u32) -> Vec<u32> {
        let source = format!(
            "{}{}\n{RNG_CS}",
            wgsl_constants(BvhMode::None),
            wgsl_library(Library::Rng, BvhStorage::Buffers).concat()
        );
        let input: Vec<u8> = cases
            .iter()
            .flatten()
            .flat_map(|w| w.to_le_bytes())
            .collect();
        compute_words(
            gpu,
            "debug rng",
            &source,
            &[&input],
            16 * u64::from(texels) * cases.len() as u64,
            [texels.div_ceil(64), cases.len() as u32],
        )
    }

    /// Runs the compute shader `source` (entry `main`) on the device: its bindings 0, 1, …
    /// of group 0 are read-only storage buffers holding `inputs`, the next one `words` words
    /// it writes, read back after `groups` workgroups (x, y).
    fn compute_words(
        gpu: &crate::device::Gpu,
        label: &str,
        source: &str,
        inputs: &[&[u8]],
        words: u64,
        groups: [u32; 2],
    ) -> Vec<u32> {
        use wgpu::util::DeviceExt;
        validate(label, source);
        let bytes = 4 * words;
        let d = &gpu.device;
        let read = gpu
            .scoped(label, || {
                let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(label),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(label),
                    layout: None,
                    module: &module,
                    entry_point: Some("main"),
                    compilation_options: Default::default(),
                    cache: None,
                });
                let buffers: Vec<wgpu::Buffer> = inputs
                    .iter()
                    .map(|contents| {
                        d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                            label: Some(label),
                            contents,
                            usage: wgpu::BufferUsages::STORAGE,
                        })
                    })
                    .collect();
                let out = d.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("words"),
                    size: bytes,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                });
                let read = d.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("read"),
                    size: bytes,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
                    .iter()
                    .chain(std::iter::once(&out))
                    .enumerate()
                    .map(|(i, b)| wgpu::BindGroupEntry {
                        binding: i as u32,
                        resource: b.as_entire_binding(),
                    })
                    .collect();
                let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(label),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &entries,
                });
                let mut encoder = d.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &group, &[]);
                    pass.dispatch_workgroups(groups[0], groups[1], 1);
                }
                encoder.copy_buffer_to_buffer(&out, 0, &read, 0, bytes);
                gpu.queue.submit([encoder.finish()]);
                read
            })
            .unwrap_or_else(|e| panic!("{label} dispatch: {e}"));
        read.slice(..)
            .map_async(wgpu::MapMode::Read, |r| r.expect("map"));
        gpu.wait(label).expect("wait");
        let view = read.slice(..).get_mapped_range().expect("mapped range");
        view.chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    /// Per direction: the table's sample and its density proxy's, through `lux_ies_sample`
    /// and `lux_proxy_sample` (`lux_ies` as `pack::ies_values` lays it out: the table of
    /// `size` values, then its proxy).
    const IES_CS: &str = "@group(0) @binding(0) var<storage, read> lux_ies: array<f32>;
@group(0) @binding(1) var<storage, read> size: vec2<i32>;
@group(0) @binding(2) var<storage, read> dirs: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> words: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= arrayLength(&dirs)) {
        return;
    }
    let d = dirs[gid.x].xyz;
    words[2u * gid.x] = lux_ies_sample(0u, size, d);
    words[2u * gid.x + 1u] = lux_proxy_sample(u32(size.x * size.y), d);
}
";

    #[test]
    fn ies_sampling_and_the_density_proxy_match_the_cpu() {
        use luxbake::lightpaths::DensityProxy;
        use luxbake_ies::{GpuTable, Photometry};
        let Some(gpu) = luxbake_testkit::or_skip(
            "ies_sampling_and_the_density_proxy_match_the_cpu",
            crate::device::Gpu::open(wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all())),
            crate::WgpuError::is_driver_missing,
        ) else {
            return;
        };
        let downlight =
            Photometry::parse(include_bytes!("../../scene/lamps/luxbake_downlight.ies"))
                .expect("downlight")
                .gpu_table();
        let mut rng = luxbake_testkit::SplitMix64::new(11);
        let random = GpuTable {
            width: 24,
            height: 13,
            values: (0..24 * 13).map(|_| rng.range(0.0, 1000.0)).collect(),
        };
        let dirs = luxbake_testkit::photometric_test_directions(&mut rng, 4096);
        let dir_bytes: Vec<u8> = dirs
            .iter()
            .flat_map(|d| [d[0], d[1], d[2], 0.0])
            .flat_map(f32::to_le_bytes)
            .collect();
        // The common library's tile helpers name the output and the tile of a pass: declared
        // (in a group the entry point does not use, so not bound).
        let source = format!(
            "{}{}@group(1) @binding(0) var lux_out: texture_storage_2d_array<rgba32float, write>;\n\
             @group(1) @binding(1) var<uniform> lux_tile: {};\n{}{}\n{IES_CS}",
            wgsl_constants(BvhMode::None),
            luxbake::shader::wgsl_struct(TileParams::WGSL_NAME, TileParams::FIELDS),
            TileParams::WGSL_NAME,
            wgsl_library(Library::Common, BvhStorage::Buffers).concat(),
            wgsl_library(Library::Ies, BvhStorage::Buffers).concat()
        );
        for (ti, table) in [downlight, random].iter().enumerate() {
            let proxy = DensityProxy::new(table);
            let values: Vec<u8> = table
                .values
                .iter()
                .chain(&proxy.values)
                .flat_map(|v| v.to_le_bytes())
                .collect();
            let size: Vec<u8> = [table.width as i32, table.height as i32]
                .iter()
                .flat_map(|v| v.to_le_bytes())
                .collect();
            let out = compute_words(
                &gpu,
                "debug ies",
                &source,
                &[&values, &size, &dir_bytes],
                2 * dirs.len() as u64,
                [(dirs.len() as u32).div_ceil(64), 1],
            );
            let max = table.values.iter().fold(0.0f32, |m, &v| m.max(v));
            let (mut worst, mut worst_proxy, mut read) = (0.0f32, 0.0f32, 0);
            for (i, d) in dirs.iter().enumerate() {
                let (gpu_table, gpu_proxy) =
                    (f32::from_bits(out[2 * i]), f32::from_bits(out[2 * i + 1]));
                let (cpu_table, cpu_proxy) = (table.sample(*d), proxy.sample(*d));
                worst = worst.max((gpu_table - cpu_table).abs() / max);
                worst_proxy = worst_proxy.max((gpu_proxy - cpu_proxy).abs() / max);
                assert!(
                    (gpu_table - cpu_table).abs() <= 1e-5 * max
                        && (gpu_proxy - cpu_proxy).abs() <= 1e-5 * max,
                    "table {ti}, dir {d:?}: gpu {gpu_table} / proxy {gpu_proxy}, \
                     cpu {cpu_table} / {cpu_proxy}"
                );
                read += usize::from(gpu_proxy > 0.1 * max);
            }
            assert!(read > dirs.len() / 10, "table {ti}: the proxy read nothing");
            eprintln!(
                "table {ti} ({}x{}): worst error {worst:e} of the maximum, its density proxy \
                 {worst_proxy:e}",
                table.width, table.height
            );
        }
    }

    #[test]
    fn rng_is_bit_exact() {
        use luxbake::rng::{Draw, Stream, hash, sobol2, sobol2_bits, texel_index, uniform2};
        // Skipped (outside CI) only without an adapter: a driver that fails to open fails.
        let Some(gpu) = luxbake_testkit::or_skip(
            "rng_is_bit_exact",
            crate::device::Gpu::open(wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all())),
            crate::WgpuError::is_driver_missing,
        ) else {
            return;
        };
        let size = [97u32, 61];
        let texels = size[0] * size[1];
        let cases = [
            [0u32, 1, 0, 0],
            [255, 3, 0xDEAD_BEEF, 5],
            [u32::MAX - 2, 2, 7, 1],
            [1000, 1, 42, 0],
        ];
        let words = rng_words(&gpu, &cases, texels);
        for (k, &[sample, pass, seed, layer]) in cases.iter().enumerate() {
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let t = texel_index(size, layer, x, y);
                    let [h0, h1] = uniform2(t, sample, pass, seed);
                    let [b0, b1] = sobol2_bits(t, sample, pass, seed);
                    let [sh0, sh1] = Sampler::Hash.uniform2(t, sample, pass, seed);
                    let [ss0, ss1] = Sampler::Sobol.uniform2(t, sample, pass, seed);
                    let at = [layer, x, y];
                    let g = Stream::gather(Sampler::Sobol, size, at, pass - 1, sample);
                    let r = Stream::refine(Sampler::Sobol, size, at, seed, sample);
                    let gh = Stream::gather(Sampler::Hash, size, at, pass - 1, sample);
                    let expected = [
                        hash(t, sample, pass, seed),
                        h0.to_bits(),
                        h1.to_bits(),
                        b0,
                        b1,
                        sobol2(t, sample, pass, seed)[0].to_bits(),
                        sh0.to_bits(),
                        sh1.to_bits(),
                        ss0.to_bits(),
                        ss1.to_bits(),
                        g.key,
                        g.first,
                        r.key,
                        r.first,
                        gh.key,
                        gh.first,
                    ];
                    let o = 16 * (k * texels as usize + (y * size[0] + x) as usize);
                    assert_eq!(
                        words[o..o + 16],
                        expected,
                        "texel ({x}, {y}), case {:?}",
                        cases[k]
                    );
                }
            }
        }
    }

    #[test]
    fn generated_constants_match_the_rust_side() {
        let p = wgsl_constants(BvhMode::Tbvh);
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
            Expression::Literal(Literal::F32(v)) if v == BLUR_NORMAL_COS
        ));
        assert!(matches!(
            find("LUX_MAX_BLUR_RADIUS"),
            Expression::Literal(Literal::I32(v)) if v == MAX_BLUR_RADIUS
        ));
        for s in Sampler::ALL {
            let name = format!("LUX_SAMPLER_{}", s.name().to_ascii_uppercase());
            assert!(matches!(find(&name), Expression::Literal(Literal::U32(v)) if v == s.id()));
        }
    }
}
