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
//!   over the rectangle. Row 0 of every texture is the first row in memory. A point at light-map
//!   UV `(u, v)` of an object lies in texel `region.offset + floor((u, v) * region.size)` of its
//!   [`Region`](crate::layout::Region).
//! - Object transforms: `world = T · Rz · Ry · Rx · S · p` ([`Transform::from_trs`]): scale
//!   first, then rotations about the fixed world X, Y and Z axes in that order, then translation.
//!
//! # The lamp frame, precisely
//! `luxbake-ies` answers intensities in its photometric frame: nadir (γ = 0°) along −Z, the
//! C0 half-plane toward +X, C90 toward +Y. [`Lamp::world_to_photometric_matrix`] maps a world
//! direction into that frame. It is built in three steps:
//! 1. **Default frame** (`aim = [0, -1, 0]`, `rotation_deg = 0`): photometric +X (C0) is world
//!    +X, photometric +Y (C90) is world −Z, photometric +Z (zenith) is world +Y. So world −Y is
//!    the nadir and, seen from above, C angles grow counter-clockwise from +X toward −Z.
//! 2. **Aim**: the default frame is turned by the *smallest* rotation that takes world −Y onto
//!    the normalised `aim` (rotation axis `(−Y) × aim`). When `aim` points straight up (+Y) that
//!    axis is undefined and the turn is 180° about world +X (C0 stays +X, C90 becomes +Z). An
//!    `aim` of zero length or with non-finite components counts as the default `[0, -1, 0]`.
//! 3. **Rotation**: the aimed frame is then turned by `rotation_deg` about the photometric
//!    zenith axis (−aim), right-handed. Positive angles move the C0 plane toward where C90 was:
//!    with the default aim, `rotation_deg = 90` puts C0 at world −Z and C90 at world −X, i.e.
//!    counter-clockwise seen from above (from behind the lamp, looking along `aim`).

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;

use luxbake_bvh::TriangleAttributes;
use luxbake_ies::Photometry;

/// Errors of scene construction, scene files and mesh validation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// `Scene::builtin` was given a name it does not know.
    #[error("unknown built-in scene `{name}` (known: {known})")]
    UnknownBuiltin {
        /// The name asked for.
        name: String,
        /// Comma-separated list of the known names.
        known: String,
    },
    /// A file could not be read.
    #[error("cannot read `{path}`: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The scene file is not valid TOML or a key has a value of the wrong type; `message`
    /// carries the line, column and key as the TOML parser reports them.
    #[error("scene file{}: {message}", fmt_path(.path))]
    Toml {
        /// The scene file, if the text came from one.
        path: Option<PathBuf>,
        /// The parser's message.
        message: String,
    },
    /// A key of the scene file has a value that is out of range or inconsistent.
    #[error("scene file{}: `{key}`: {message}", fmt_path(.path))]
    Invalid {
        /// The scene file, if the text came from one.
        path: Option<PathBuf>,
        /// Full key path, e.g. `object[2].size` or `settings.rays`.
        key: String,
        /// What is wrong and what was expected.
        message: String,
    },
    /// A photometric file named by a scene file could not be parsed.
    #[error("`{key}`: cannot parse photometric file `{file}`: {source}")]
    Photometry {
        /// Key path of the `ies` entry, e.g. `lamp[0].ies`.
        key: String,
        /// The photometric file.
        file: PathBuf,
        /// The parser's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// An object's mesh is malformed (see [`Mesh::validate`]).
    #[error("object `{object}`: invalid mesh: {message}")]
    Mesh {
        /// The object's name.
        object: String,
        /// What is wrong.
        message: String,
    },
    /// Two objects have the same name.
    #[error("two objects are named `{0}` (names must be unique: they name the output files)")]
    DuplicateName(String),
}

fn fmt_path(path: &Option<PathBuf>) -> String {
    match path {
        Some(p) => format!(" `{}`", p.display()),
        None => String::new(),
    }
}

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

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Checks the structural invariants every consumer relies on: per-vertex arrays of equal
    /// length, indices in range, finite positions, normals and UVs. It does not reject
    /// degenerate (zero-area) triangles: the rasteriser and the BVH handle those.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.positions.len();
        if self.normals.len() != n {
            return Err(format!("{} normals for {n} positions", self.normals.len()));
        }
        if self.lightmap_uvs.len() != n {
            return Err(format!(
                "{} light-map UVs for {n} positions",
                self.lightmap_uvs.len()
            ));
        }
        if let Some(uvs) = &self.material_uvs
            && uvs.len() != n
        {
            return Err(format!("{} material UVs for {n} positions", uvs.len()));
        }
        if let Some(colors) = &self.colors
            && colors.len() != n
        {
            return Err(format!("{} colours for {n} positions", colors.len()));
        }
        let finite3 = |v: &[f32; 3]| v.iter().all(|c| c.is_finite());
        if let Some(i) = self.positions.iter().position(|p| !finite3(p)) {
            return Err(format!("position {i} is not finite"));
        }
        if let Some(i) = self.normals.iter().position(|p| !finite3(p)) {
            return Err(format!("normal {i} is not finite"));
        }
        if let Some(i) = self
            .lightmap_uvs
            .iter()
            .position(|uv| !uv.iter().all(|c| c.is_finite()))
        {
            return Err(format!("light-map UV {i} is not finite"));
        }
        if let Some(t) = self
            .indices
            .iter()
            .position(|tri| tri.iter().any(|&i| i as usize >= n))
        {
            return Err(format!("triangle {t} indexes past the {n} vertices"));
        }
        Ok(())
    }
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

impl AlbedoTexture {
    /// Bilinear sample with repeat wrapping at material UV `uv` (texel centres at
    /// `(i + 0.5) / width`). Returns white for an empty or inconsistent texture.
    pub fn sample(&self, uv: [f32; 2]) -> [f32; 3] {
        let (w, h) = (self.width as usize, self.height as usize);
        if w == 0 || h == 0 || self.texels.len() != w * h || !uv.iter().all(|c| c.is_finite()) {
            return [1.0; 3];
        }
        let x = uv[0] as f64 * w as f64 - 0.5;
        let y = uv[1] as f64 * h as f64 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        let wrap = |i: f64, n: usize| i.rem_euclid(n as f64) as usize % n;
        let (x0i, x1i) = (wrap(x0, w), wrap(x0 + 1.0, w));
        let (y0i, y1i) = (wrap(y0, h), wrap(y0 + 1.0, h));
        let t = |x: usize, y: usize| self.texels[y * w + x];
        let (a, b, c, d) = (t(x0i, y0i), t(x1i, y0i), t(x0i, y1i), t(x1i, y1i));
        std::array::from_fn(|k| {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            top + (bottom - top) * fy
        })
    }
}

/// Diffuse reflectance: `factor` × vertex colour × texture(material UV), each in [0, 1].
#[derive(Debug, Clone, PartialEq)]
pub struct Albedo {
    /// Constant linear RGB factor.
    pub factor: [f32; 3],
    /// Optional texture, sampled bilinearly at the mesh's material UVs.
    pub texture: Option<Arc<AlbedoTexture>>,
}

impl Albedo {
    /// A constant grey albedo.
    pub fn grey(value: f32) -> Albedo {
        Albedo {
            factor: [value; 3],
            texture: None,
        }
    }
}

/// Object-to-world affine transform: `world = linear * p + translation` (column-major 3×3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    /// Columns of the 3×3 linear part.
    pub linear: [[f32; 3]; 3],
    /// Translation, metres.
    pub translation: [f32; 3],
}

impl Transform {
    /// The identity transform.
    pub const IDENTITY: Transform = Transform {
        linear: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0; 3],
    };

    /// Translation, rotation and scale: `world = T · Rz · Ry · Rx · S · p`, i.e. scale per axis
    /// first, then rotate about the fixed world X, then Y, then Z axis by the given degrees
    /// (right-handed: positive angles turn counter-clockwise looking down the axis toward the
    /// origin), then translate.
    pub fn from_trs(
        translation: [f32; 3],
        rotation_deg_xyz: [f32; 3],
        scale: [f32; 3],
    ) -> Transform {
        let r = rotation_xyz(rotation_deg_xyz.map(f64::from));
        let linear = std::array::from_fn(|col| {
            std::array::from_fn(|row| (r[row][col] * f64::from(scale[col])) as f32)
        });
        Transform {
            linear,
            translation,
        }
    }

    /// Maps an object-space point to world space.
    pub fn point(&self, p: [f32; 3]) -> [f32; 3] {
        let w = self.point_f64(p.map(f64::from));
        w.map(|c| c as f32)
    }

    /// [`Transform::point`] in double precision.
    pub fn point_f64(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.linear;
        std::array::from_fn(|r| {
            f64::from(m[0][r]) * p[0]
                + f64::from(m[1][r]) * p[1]
                + f64::from(m[2][r]) * p[2]
                + f64::from(self.translation[r])
        })
    }

    /// Maps an object-space normal to a world-space unit normal with the inverse transpose of
    /// the linear part (so non-uniform scales keep normals perpendicular to surfaces; mirrors
    /// keep them on the same side of the surface). Returns the input unchanged when the
    /// transform is singular or the result cannot be normalised.
    pub fn normal(&self, n: [f32; 3]) -> [f32; 3] {
        match self.normal_f64(n.map(f64::from)) {
            Some(v) => v.map(|c| c as f32),
            None => n,
        }
    }

    /// [`Transform::normal`] in double precision; `None` when it cannot be normalised.
    pub fn normal_f64(&self, n: [f64; 3]) -> Option<[f64; 3]> {
        let m: [[f64; 3]; 3] = self.linear.map(|c| c.map(f64::from));
        // Columns a, b, c; the inverse transpose is [b×c, c×a, a×b] / det (as columns).
        let (a, b, c) = (m[0], m[1], m[2]);
        let cof = [cross(b, c), cross(c, a), cross(a, b)];
        let det = dot(a, cof[0]);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let v: [f64; 3] = std::array::from_fn(|r| {
            (cof[0][r] * n[0] + cof[1][r] * n[1] + cof[2][r] * n[2]) * det.signum()
        });
        normalize(v)
    }

    /// Determinant of the linear part (negative for mirroring transforms).
    pub fn determinant(&self) -> f64 {
        let m: [[f64; 3]; 3] = self.linear.map(|c| c.map(f64::from));
        dot(m[0], cross(m[1], m[2]))
    }
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
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
    /// Multiplier on [`Settings::texels_per_metre`] for this object's light map (default 1;
    /// Unity calls it "scale in lightmap"). Density stays uniform over the object's surface.
    /// The built-in furniture uses [`crate::builtin::FURNITURE_TEXEL_SCALE`] to reproduce the
    /// paper's per-object map budgets.
    pub texel_scale: f32,
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
    /// Turn of the C0 plane about the aim axis, degrees: right-handed about the photometric
    /// zenith (−aim), i.e. counter-clockwise seen from behind the lamp looking along `aim`, so
    /// positive angles move C0 toward where C90 was. See the module docs for the exact rule.
    pub rotation_deg: f32,
    /// Scalar multiplier on every intensity.
    pub multiplier: f32,
    /// Linear RGB tint (default `[1, 1, 1]`); the light maps carry one channel per component.
    pub color: [f32; 3],
}

impl Lamp {
    /// A lamp with the default frame (aim straight down, no rotation), multiplier 1, white.
    pub fn new(name: impl Into<String>, photometry: Arc<Photometry>, position: [f32; 3]) -> Lamp {
        Lamp {
            name: name.into(),
            photometry,
            position,
            aim: [0.0, -1.0, 0.0],
            rotation_deg: 0.0,
            multiplier: 1.0,
            color: [1.0; 3],
        }
    }

    /// The rotation from world directions to the `luxbake-ies` photometric frame (nadir −Z,
    /// C0 +X, C90 +Y), **row-major**: `photometric[r] = Σ_c m[r][c] · world[c]`. Row 0 is the
    /// world direction of C0 (photometric +X), row 1 of C90 (+Y), row 2 of the zenith (+Z,
    /// = −aim). Orthonormal and right-handed; its transpose maps back to world. The rule is
    /// in the module docs.
    pub fn world_to_photometric_matrix(&self) -> [[f32; 3]; 3] {
        self.frame_f64().map(|row| row.map(|c| c as f32))
    }

    /// [`Lamp::world_to_photometric_matrix`] in double precision.
    pub fn frame_f64(&self) -> [[f64; 3]; 3] {
        let default_aim = [0.0, -1.0, 0.0];
        let aim = normalize(self.aim.map(f64::from)).unwrap_or(default_aim);
        let basis = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]];
        // Step 2: the smallest rotation taking −Y onto `aim` (Rodrigues).
        let c = dot(default_aim, aim);
        let aimed = if c < -1.0 + 1e-12 {
            // Straight up: 180° about +X.
            basis.map(|v| [v[0], -v[1], -v[2]])
        } else {
            let k = cross(default_aim, aim);
            basis.map(|v| {
                let kxv = cross(k, v);
                let kxkxv = cross(k, kxv);
                std::array::from_fn(|i| v[i] + kxv[i] + kxkxv[i] / (1.0 + c))
            })
        };
        // Step 3: turn about the zenith axis by rotation_deg (right-handed).
        let theta = f64::from(self.rotation_deg).to_radians();
        let theta = if theta.is_finite() { theta } else { 0.0 };
        let (s, co) = theta.sin_cos();
        let zenith = aimed[2];
        let rot = |v: [f64; 3]| -> [f64; 3] {
            let kxv = cross(zenith, v);
            let kdv = dot(zenith, v);
            std::array::from_fn(|i| v[i] * co + kxv[i] * s + zenith[i] * kdv * (1.0 - co))
        };
        [rot(aimed[0]), rot(aimed[1]), zenith]
    }

    /// Maps a world direction (any length) to the photometric frame; the result has the same
    /// length. Intensity toward a texel at `p` is `photometry` evaluated at
    /// `to_photometric(p − position)`.
    pub fn to_photometric(&self, world_dir: [f32; 3]) -> [f32; 3] {
        let m = self.frame_f64();
        let d = world_dir.map(f64::from);
        m.map(|row| dot(row, d) as f32)
    }
}

/// Gaussian blur setting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Blur {
    /// No blur.
    None,
    /// Separable Gaussian with this standard deviation in texels.
    Sigma(f32),
}

impl FromStr for Blur {
    type Err = String;
    /// `"none"` or a sigma in texels (finite, > 0).
    fn from_str(s: &str) -> Result<Blur, String> {
        let t = s.trim();
        if t.eq_ignore_ascii_case("none") {
            return Ok(Blur::None);
        }
        match t.parse::<f32>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(Blur::Sigma(v)),
            Ok(0.0) => Ok(Blur::None),
            _ => Err(format!(
                "expected \"none\" or a sigma in texels > 0, got `{s}`"
            )),
        }
    }
}

impl fmt::Display for Blur {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Blur::None => f.write_str("none"),
            Blur::Sigma(s) => write!(f, "{s}"),
        }
    }
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

impl BvhMode {
    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            BvhMode::Mtbvh => "mtbvh",
            BvhMode::Tbvh => "tbvh",
            BvhMode::None => "none",
        }
    }
}

impl FromStr for BvhMode {
    type Err = String;
    /// `mtbvh`, `tbvh` or `none` (case-insensitive).
    fn from_str(s: &str) -> Result<BvhMode, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "mtbvh" => Ok(BvhMode::Mtbvh),
            "tbvh" => Ok(BvhMode::Tbvh),
            "none" => Ok(BvhMode::None),
            _ => Err(format!(
                "expected \"mtbvh\", \"tbvh\" or \"none\", got `{s}`"
            )),
        }
    }
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

impl BackendKind {
    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Cpu => "cpu",
            BackendKind::Glow => "glow",
            BackendKind::Wgpu => "wgpu",
        }
    }
}

impl FromStr for BackendKind {
    type Err = String;
    /// `cpu`, `glow` or `wgpu` (case-insensitive).
    fn from_str(s: &str) -> Result<BackendKind, String> {
        match s.trim().to_ascii_lowercase().as_str() {
            "cpu" => Ok(BackendKind::Cpu),
            "glow" => Ok(BackendKind::Glow),
            "wgpu" => Ok(BackendKind::Wgpu),
            _ => Err(format!("expected \"cpu\", \"glow\" or \"wgpu\", got `{s}`")),
        }
    }
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

impl Settings {
    /// Default gather rays per texel per bounce.
    pub const DEFAULT_RAYS: u32 = 256;
    /// Default number of indirect bounces (the paper's one bounce).
    pub const DEFAULT_BOUNCES: u32 = 1;
    /// Default blur sigma, texels.
    pub const DEFAULT_BLUR_SIGMA: f32 = 2.0;
    /// Default texel density, texels per metre (1.5625 cm texels). With it the built-in scenes
    /// come close to the light-map texel counts of the paper's Table 1.
    pub const DEFAULT_TEXELS_PER_METRE: f32 = 64.0;
}

impl Default for Settings {
    /// `rays = 256`, `bounces = 1`, `blur = Sigma(2.0)`, `texels_per_metre = 64`,
    /// `bvh = Mtbvh`, `seed = 0`, `backend = Cpu`.
    fn default() -> Self {
        Settings {
            rays: Settings::DEFAULT_RAYS,
            bounces: Settings::DEFAULT_BOUNCES,
            blur: Blur::Sigma(Settings::DEFAULT_BLUR_SIGMA),
            texels_per_metre: Settings::DEFAULT_TEXELS_PER_METRE,
            bvh: BvhMode::Mtbvh,
            seed: 0,
            backend: BackendKind::Cpu,
        }
    }
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

impl Scene {
    /// A built-in scene by name (see [`Scene::builtin_names`] and [`crate::builtin`]), at the
    /// default texel density.
    pub fn builtin(name: &str) -> Result<Scene, SceneError> {
        crate::builtin::scene(name, Settings::default())
    }

    /// A built-in scene with the given settings; the procedural meshes' chart padding is
    /// sized for `settings.texels_per_metre` (use this rather than changing the density of a
    /// [`Scene::builtin`] afterwards).
    pub fn builtin_with_settings(name: &str, settings: Settings) -> Result<Scene, SceneError> {
        crate::builtin::scene(name, settings)
    }

    /// The names [`Scene::builtin`] accepts.
    pub fn builtin_names() -> &'static [&'static str] {
        crate::builtin::NAMES
    }

    /// Reads a TOML scene file (format: [`crate::scenefile`]); relative paths inside it are
    /// relative to the file's folder.
    pub fn from_toml_file(path: &Path) -> Result<Scene, SceneError> {
        crate::scenefile::from_file(path)
    }

    /// Parses a TOML scene from text; relative paths inside it are relative to `base_dir`.
    pub fn from_toml_str(text: &str, base_dir: &Path) -> Result<Scene, SceneError> {
        crate::scenefile::from_str(text, base_dir, None)
    }

    /// Checks every object's mesh ([`Mesh::validate`]) and that names are unique.
    pub fn validate(&self) -> Result<(), SceneError> {
        let mut names = std::collections::HashSet::new();
        for o in &self.objects {
            if !names.insert(o.name.as_str()) {
                return Err(SceneError::DuplicateName(o.name.clone()));
            }
            o.mesh.validate().map_err(|message| SceneError::Mesh {
                object: o.name.clone(),
                message,
            })?;
        }
        Ok(())
    }

    /// Total number of triangles over all objects.
    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| o.mesh.triangle_count()).sum()
    }

    /// The world-space triangle soup for the BVH, every object (receivers and non-receivers)
    /// in object order, each object's triangles in mesh order. Attributes carry world unit
    /// normals, light-map UVs and the object index. Triangles with an out-of-range index or a
    /// non-finite world position are left out (use [`Scene::validate`] to reject them instead);
    /// degenerate triangles are kept (a ray never hits them).
    pub fn world_triangles(&self) -> (Vec<[[f32; 3]; 3]>, Vec<TriangleAttributes>) {
        let mut tris = Vec::with_capacity(self.triangle_count());
        let mut attrs = Vec::with_capacity(self.triangle_count());
        for (oi, o) in self.objects.iter().enumerate() {
            let m = &o.mesh;
            for tri in &m.indices {
                let Some(idx) = tri_indices(tri, m) else {
                    continue;
                };
                let p = idx.map(|i| o.transform.point(m.positions[i]));
                if !p.iter().flatten().all(|c| c.is_finite()) {
                    continue;
                }
                let normals = idx.map(|i| o.transform.normal(m.normals[i]));
                let uvs = idx.map(|i| m.lightmap_uvs[i]);
                tris.push(p);
                attrs.push(TriangleAttributes {
                    normals,
                    uvs,
                    object: oi as u32,
                });
            }
        }
        (tris, attrs)
    }
}

/// The three vertex indices of a triangle as `usize`, if all are in range of every per-vertex
/// array the consumers read.
pub(crate) fn tri_indices(tri: &[u32; 3], m: &Mesh) -> Option<[usize; 3]> {
    let n = m
        .positions
        .len()
        .min(m.normals.len())
        .min(m.lightmap_uvs.len());
    let idx = tri.map(|i| i as usize);
    idx.iter().all(|&i| i < n).then_some(idx)
}

/// Rotation matrix (row-major) `Rz · Ry · Rx` for angles in degrees.
fn rotation_xyz(deg: [f64; 3]) -> [[f64; 3]; 3] {
    let [x, y, z] = deg.map(|d| if d.is_finite() { d.to_radians() } else { 0.0 });
    let (sx, cx) = x.sin_cos();
    let (sy, cy) = y.sin_cos();
    let (sz, cz) = z.sin_cos();
    let rx = [[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]];
    let ry = [[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]];
    let rz = [[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]];
    matmul(rz, matmul(ry, rx))
}

fn matmul(a: [[f64; 3]; 3], b: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..3).map(|k| a[r][k] * b[k][c]).sum()))
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Unit vector, or `None` for a zero or non-finite vector.
pub(crate) fn normalize(v: [f64; 3]) -> Option<[f64; 3]> {
    let l = dot(v, v).sqrt();
    (l > 0.0 && l.is_finite()).then(|| v.map(|c| c / l))
}

pub(crate) fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(crate) fn length(v: [f64; 3]) -> f64 {
    dot(v, v).sqrt()
}
