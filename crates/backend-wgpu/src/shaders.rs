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
    use luxbake::program::{
        BLUR_NORMAL_COS, BlurParams, DirectParams, Field, GatherParams, Library, MAX_BLUR_RADIUS,
        ParamBlock, Program, TileParams,
    };
    use luxbake::rng::Sampler;
    use luxbake::scene::BvhMode;
    use luxbake::shader::{BvhStorage, wgsl_constants, wgsl_library, wgsl_source};
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
        for program in Program::ALL {
            for storage in [BvhStorage::Buffers, BvhStorage::Textures] {
                for traversal in TRAVERSALS {
                    let label = format!("{} {traversal:?} {storage:?}", program.label());
                    let module = validate(&label, &wgsl_source(program, traversal, storage));
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
    /// bits, and both samplers' uniforms through `lux_sample2` with their generated ids (as
    /// bits), 10 words.
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
    let o = 10u * (gid.y * size.x * size.y + gid.x);
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
}
";

    /// Runs [`RNG_CS`] on the device for `cases` (sample, pass, seed, layer) and reads back
    /// its words.
    fn rng_words(gpu: &crate::device::Gpu, cases: &[[u32; 4]], texels: u32) -> Vec<u32> {
        use wgpu::util::DeviceExt;
        let source = format!(
            "{}{}\n{RNG_CS}",
            wgsl_constants(BvhMode::None),
            wgsl_library(Library::Rng, BvhStorage::Buffers).concat()
        );
        validate("debug rng", &source);
        let bytes = 4 * 10 * u64::from(texels) * cases.len() as u64;
        let d = &gpu.device;
        let read = gpu
            .scoped("debug rng", || {
                let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some("debug rng"),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("debug rng"),
                    layout: None,
                    module: &module,
                    entry_point: Some("main"),
                    compilation_options: Default::default(),
                    cache: None,
                });
                let input: Vec<u8> = cases
                    .iter()
                    .flatten()
                    .flat_map(|w| w.to_le_bytes())
                    .collect();
                let cases_buf = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("cases"),
                    contents: &input,
                    usage: wgpu::BufferUsages::STORAGE,
                });
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
                let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("debug rng"),
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: cases_buf.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: out.as_entire_binding(),
                        },
                    ],
                });
                let mut encoder = d.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &group, &[]);
                    pass.dispatch_workgroups(texels.div_ceil(64), cases.len() as u32, 1);
                }
                encoder.copy_buffer_to_buffer(&out, 0, &read, 0, bytes);
                gpu.queue.submit([encoder.finish()]);
                read
            })
            .expect("debug rng dispatch");
        read.slice(..)
            .map_async(wgpu::MapMode::Read, |r| r.expect("map"));
        gpu.wait("debug rng").expect("wait");
        let view = read.slice(..).get_mapped_range().expect("mapped range");
        view.chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    }

    #[test]
    fn rng_is_bit_exact() {
        use luxbake::rng::{Draw, hash, sobol2, sobol2_bits, texel_index, uniform2};
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
                    ];
                    let o = 10 * (k * texels as usize + (y * size[0] + x) as usize);
                    assert_eq!(
                        words[o..o + 10],
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
