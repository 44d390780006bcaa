//! The scene model: objects, lamps and bake settings, as plain data.
//!
//! # Conventions
//! - Units: metres for lengths, candela for intensities (from the IES file), lux (lm/m²) for
//!   illuminance, lm/m² for exitance.
//! - World frame: right-handed, **+Y up**, as glTF.
//! - A lamp's photometric frame (see [`Lamp`]) maps to world with nadir along −Y, the C0 plane
//!   toward +X and the C90 plane toward −Z (horizontal angles run counter-clockwise seen from
//!   above, as LM-63 defines them); `aim` and `rotation_deg` rotate that frame.
//! - Light-map UVs: origin (0, 0) at the **top-left texel corner** of the object's light-map
//!   rectangle, u to the right (+x texel), v downward (+y texel, row index), both in [0, 1]
//!   over the rectangle. Row 0 of every texture is the first row in memory.

use std::sync::Arc;

use luxbake_ies::Photometry;

/// A triangle mesh in object space.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Mesh {
    /// Vertex positions, metres, object space.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals, object space (same length as `positions`).
    pub normals: Vec<[f32; 3]>,
    /// Light-map UVs (unique, non-overlapping, in [0, 1]²), one per vertex.
    pub lightmap_uvs: Vec<[f32; 2]>,
    /// Material UVs for the albedo texture (glTF TEXCOORD_0), one per vertex, if any.
    pub material_uvs: Option<Vec<[f32; 2]>>,
    /// Linear per-vertex albedo multiplier (RGB), if any.
    pub colors: Option<Vec<[f32; 3]>>,
    /// Triangle list, three vertex indices per triangle, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
}

/// A linear RGB texture (row 0 first), sampled with the mesh's material UVs.
#[derive(Debug, Clone, PartialEq)]
pub struct AlbedoTexture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width * height` linear RGB texels, row-major.
    pub texels: Vec<[f32; 3]>,
}

/// Diffuse reflectance: `factor` × vertex colour × texture(material UV), each in [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct Albedo {
    /// Constant linear RGB factor.
    pub factor: [f32; 3],
    /// Optional texture, sampled bilinearly at the mesh's material UVs.
    pub texture: Option<Arc<AlbedoTexture>>,
}

/// Object-to-world affine transform: `world = linear * p + translation` (column-major 3×3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Columns of the 3×3 linear part.
    pub linear: [[f32; 3]; 3],
    /// Translation, metres.
    pub translation: [f32; 3],
}

/// One object of the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// Unique name (used for output file names).
    pub name: String,
    /// Geometry in object space.
    pub mesh: Mesh,
    /// Object-to-world transform.
    pub transform: Transform,
    /// Diffuse reflectance.
    pub albedo: Albedo,
    /// Whether the object receives a light map. Non-receivers still cast shadows and reflect
    /// nothing (they get no map to read).
    pub receiver: bool,
}

/// A lamp: a photometric distribution placed in the world.
#[derive(Debug, Clone)]
pub struct Lamp {
    /// Name for reports.
    pub name: String,
    /// The luminous intensity distribution (candela), including its multipliers.
    pub photometry: Arc<Photometry>,
    /// Photometric centre, metres, world.
    pub position: [f32; 3],
    /// World direction of the photometric nadir (default `[0, -1, 0]`), need not be unit length.
    pub aim: [f32; 3],
    /// Turn of the C0 plane about the aim axis, degrees, counter-clockwise seen from the lamp
    /// looking along `aim`... see the crate docs for the exact rule.
    pub rotation_deg: f32,
    /// Scalar multiplier on every intensity.
    pub multiplier: f32,
    /// Linear RGB tint (default `[1, 1, 1]`); the light maps carry one channel per component.
    pub color: [f32; 3],
}

/// Gaussian blur setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Blur {
    /// No blur.
    None,
    /// Separable Gaussian with this standard deviation in texels.
    Sigma(f32),
}

/// Which ray-traversal structure the ray-casting passes use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BvhMode {
    /// Six link orders, one per dominant ray direction (Hachisuka 2015).
    Mtbvh,
    /// One threaded depth-first link order (Simonsen et al. 2005).
    Tbvh,
    /// Brute force over all triangles (the paper's "no BVH").
    None,
}

/// Which backend executes the pass graph (chosen at the edges: CLI, tests, scene file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BackendKind {
    /// The CPU reference backend in this crate.
    Cpu,
    /// `luxbake-backend-glow` (OpenGL ES 3.0 / WebGL2).
    Glow,
    /// `luxbake-backend-wgpu`.
    Wgpu,
}

/// Bake settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Gather rays per texel per bounce.
    pub rays: u32,
    /// Indirect bounces (0 = direct light only).
    pub bounces: u32,
    /// Blur of the direct and combined maps.
    pub blur: Blur,
    /// Light-map texel density, texels per metre.
    pub texels_per_metre: f32,
    /// Traversal structure.
    pub bvh: BvhMode,
    /// Seed of the stateless random-number hash.
    pub seed: u32,
    /// Preferred backend (the CLI flag overrides it).
    pub backend: BackendKind,
}

/// A complete scene: what a bake needs, nothing about how it runs.
#[derive(Debug, Clone)]
pub struct Scene {
    /// Objects (receivers and occluders).
    pub objects: Vec<Object>,
    /// Lamps.
    pub lamps: Vec<Lamp>,
    /// Settings.
    pub settings: Settings,
}
