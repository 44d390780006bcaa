//! The WGSL modules: the core's shader sources (`luxbake::shader`, one file per pass under
//! `crates/bake/shaders/<pass>/`, side by side with its GLSL twin) after the generated prefix of
//! the program's signature; `luxbake::shader::wgsl_source` assembles them. The bindings are
//! `luxbake::shader::wgsl`'s.
//!
//! The BVH library is read from storage buffers (the default) or texture arrays, see
//! [`BvhStorage`]: measured on lavapipe (see the crate docs), storage buffers are faster.

pub use luxbake::shader::BvhStorage;

#[cfg(test)]
mod tests {
    use luxbake::program::{
        BLUR_NORMAL_COS, BlurParams, DirectParams, Field, GatherParams, MAX_BLUR_RADIUS,
        ParamBlock, Program, TileParams,
    };
    use luxbake::scene::BvhMode;
    use luxbake::shader::{BvhStorage, wgsl_constants, wgsl_source};
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
        let module = validate(
            "gather",
            &wgsl_source(Program::Gather, BvhMode::Mtbvh, BvhStorage::Buffers),
        );
        assert_eq!(
            members(&module, TileParams::WGSL_NAME),
            expected(TileParams::FIELDS)
        );
        assert_eq!(
            members(&module, GatherParams::WGSL_NAME),
            expected(GatherParams::FIELDS)
        );
        let module = validate(
            "direct",
            &wgsl_source(Program::Direct, BvhMode::Tbvh, BvhStorage::Buffers),
        );
        assert_eq!(
            members(&module, DirectParams::WGSL_NAME),
            expected(DirectParams::FIELDS)
        );
        let module = validate(
            "blur",
            &wgsl_source(Program::Blur, BvhMode::None, BvhStorage::Buffers),
        );
        assert_eq!(
            members(&module, BlurParams::WGSL_NAME),
            expected(BlurParams::FIELDS)
        );
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
    }
}
