//! The generated shader constants compile: WGSL through naga's WGSL front end and validator,
//! the GLSL `#define`s through naga's GLSL front end (GLSL 4.50 core, whose literal and
//! preprocessor grammar GLSL ES 3.00 shares) — every constant is used, so a malformed literal
//! fails here rather than in a browser.

use luxbake_bvh::layout::{self, CONSTANTS, Constant};

fn validate(module: &naga::Module) {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(module)
    .expect("valid module");
}

/// Every constant in one float expression: their sum, the integers converted by `cast`.
fn sum_of_constants(cast: &str) -> String {
    let uses: Vec<String> = CONSTANTS
        .iter()
        .map(|(name, c)| match c {
            Constant::Int(_) => format!("{cast}({name})"),
            Constant::Float(_) => name.to_string(),
        })
        .collect();
    uses.join(" + ")
}

#[test]
fn wgsl_constants_parse_and_validate() {
    let source = format!(
        "{}\n@fragment\nfn main() -> @location(0) vec4<f32> {{\n    let s = {};\n    return vec4<f32>(s);\n}}\n",
        layout::wgsl_constants(),
        sum_of_constants("f32")
    );
    let module = naga::front::wgsl::parse_str(&source)
        .unwrap_or_else(|e| panic!("{}\n{source}", e.emit_to_string(&source)));
    validate(&module);
}

#[test]
fn glsl_defines_parse_and_validate() {
    let source = format!(
        "#version 450 core\n{}\nlayout(location = 0) out vec4 o;\nvoid main() {{\n    float s = {};\n    o = vec4(s);\n}}\n",
        layout::glsl_defines(),
        sum_of_constants("float")
    );
    let mut frontend = naga::front::glsl::Frontend::default();
    let options = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
    let module = frontend
        .parse(&options, &source)
        .unwrap_or_else(|e| panic!("{e:?}\n{source}"));
    validate(&module);
}
