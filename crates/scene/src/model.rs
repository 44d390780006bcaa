use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;
use std::sync::Arc;

use glam::{DMat3, DVec3, Vec3};
use luxbake_bvh::TriangleAttributes;
use luxbake_ies::Photometry;
use serde::de::IntoDeserializer;
use serde::de::value::MapDeserializer;

/// Opening samples per texel at most ([`Settings::opening_samples`]; `luxbake::opening`).
pub const MAX_OPENING_SAMPLES: u32 = 1024;

/// Largest blur radius, texels (the blur shaders' loop bound).
pub const MAX_BLUR_RADIUS: i32 = 64;

/// Taps on each side of a Gaussian of standard deviation `sigma` texels:
/// `min(⌈3σ⌉, MAX_BLUR_RADIUS)`, at least 0.
pub fn blur_radius(sigma: f32) -> i32 {
    ((3.0 * sigma).ceil() as i32).clamp(0, MAX_BLUR_RADIUS)
}

/// The least chart padding, texels: 2 for bilinear support and conservative rasterisation (a
/// chart's valid texels reach up to one texel past its edge, and a bilinear look-up reads one
/// more), doubled so the first mip level of the dilated maps still keeps a texel of gutter.
pub const MIN_CHART_PADDING_TEXELS: f32 = 4.0;

/// Chart padding for a bake with `blur`, texels at the object's density: the one rule of the
/// built-in meshes, scene-file meshes and generated UVs.
///
/// `max(`[`MIN_CHART_PADDING_TEXELS`]`, 2 + R)` with `R =`
/// [`blur_radius`]`(σ) = ⌈3σ⌉` (0 without blur). The reach that
/// matters is the method paper's Gaussian blur: it masks its taps by object and normal only,
/// so two charts of one object that face the same way would exchange light through a gap of
/// `R` texels or less. With this padding the valid texels of two charts (each up to one texel
/// wider than its chart, by conservative rasterisation) stay at least `R + 1` texels apart.
/// The converged method's filters (coarse interpolation, à-trous) test world-space distance
/// and never cross charts, so for it the blur term is conservative: σ 1 (default, final) gives 5
/// texels, σ 2 (paper) 8, no blur (draft) 4.
pub fn chart_padding_texels(blur: Blur) -> f32 {
    let reach = match blur {
        Blur::Sigma(s) => blur_radius(s),
        Blur::None => 0,
    };
    (2.0 + reach as f32).max(MIN_CHART_PADDING_TEXELS)
}

/// `v / |v|` in double precision with `|v| = √(v·v)` summed left to right, dividing (glam's
/// `DVec3::normalize`/`try_normalize` multiply by the reciprocal); `None` for a zero or
/// non-finite length.
///
/// No shader twin: the G-buffer's normals (`luxbake::gbuffer`) and the scene's transformed
/// normals and lamp aims ([`Transform::normal`]) are computed on the CPU in `f64` and rounded
/// to `f32` once, for every backend.
#[inline]
pub fn normalize_f64(v: DVec3) -> Option<DVec3> {
    let l = v.length();
    (l > 0.0 && l.is_finite()).then(|| v / l)
}

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
    /// A setting out of range once a caller's overrides are layered over a scene file's
    /// `[settings]` ([`crate::sources::scenefile::from_file_patched`]): the caller names the
    /// setting as its users wrote it (a flag, an option).
    #[error("{0}")]
    Override(SettingError),
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
    /// A mesh file named by a scene file could not be loaded.
    #[error("`{key}`: cannot load mesh file `{file}`: {source}")]
    MeshFile {
        /// Key path of the `mesh` entry, e.g. `object[3].mesh`.
        key: String,
        /// The mesh file.
        file: PathBuf,
        /// The loader's error.
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
        let t = |x: usize, y: usize| Vec3::from(self.texels[y * w + x]);
        let (a, b, c, d) = (t(x0i, y0i), t(x1i, y0i), t(x0i, y1i), t(x1i, y1i));
        let top = a + (b - a) * fx;
        let bottom = c + (d - c) * fx;
        (top + (bottom - top) * fy).to_array()
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
    /// Translation, metres, in double precision so that a room placed kilometres from the
    /// origin keeps its millimetres (f32 has a 1 mm step at 10 km): `luxbake::bake::bake`
    /// moves such a scene next to the origin before anything is rounded to f32.
    pub translation: [f64; 3],
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
        translation: [f64; 3],
        rotation_deg_xyz: [f32; 3],
        scale: [f32; 3],
    ) -> Transform {
        let r = rotation_xyz(Vec3::from(rotation_deg_xyz).as_dvec3());
        let linear =
            std::array::from_fn(|col| (r.col(col) * f64::from(scale[col])).as_vec3().to_array());
        Transform {
            linear,
            translation,
        }
    }

    /// Maps an object-space point to world space.
    pub fn point(&self, p: [f32; 3]) -> [f32; 3] {
        let w = self.point_f64(Vec3::from(p).as_dvec3().to_array());
        DVec3::from(w).as_vec3().to_array()
    }

    /// [`Transform::point`] in double precision.
    pub fn point_f64(&self, p: [f64; 3]) -> [f64; 3] {
        (self.linear_f64() * DVec3::from(p) + DVec3::from(self.translation)).to_array()
    }

    /// The linear part in double precision.
    fn linear_f64(&self) -> DMat3 {
        DMat3::from_cols_array_2d(&self.linear.map(|c| Vec3::from(c).as_dvec3().to_array()))
    }

    /// Maps an object-space normal to a world-space unit normal with the inverse transpose of
    /// the linear part (so non-uniform scales keep normals perpendicular to surfaces; mirrors
    /// keep them on the same side of the surface). Returns the input unchanged when the
    /// transform is singular or the result cannot be normalised.
    pub fn normal(&self, n: [f32; 3]) -> [f32; 3] {
        match self.normal_f64(Vec3::from(n).as_dvec3().to_array()) {
            Some(v) => DVec3::from(v).as_vec3().to_array(),
            None => n,
        }
    }

    /// [`Transform::normal`] in double precision; `None` when it cannot be normalised.
    pub fn normal_f64(&self, n: [f64; 3]) -> Option<[f64; 3]> {
        let m = self.linear_f64();
        // Columns a, b, c; the inverse transpose is [b×c, c×a, a×b] / det (as columns).
        let (a, b, c) = (m.x_axis, m.y_axis, m.z_axis);
        let cof = DMat3::from_cols(b.cross(c), c.cross(a), a.cross(b));
        let det = a.dot(cof.x_axis);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        normalize_f64(cof * DVec3::from(n) * det.signum()).map(|v| v.to_array())
    }

    /// Determinant of the linear part (negative for mirroring transforms).
    pub fn determinant(&self) -> f64 {
        let m = self.linear_f64();
        // a · (b × c) as before: glam's determinant() takes c · (a × b), which rounds differently.
        m.x_axis.dot(m.y_axis.cross(m.z_axis))
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
    /// The built-in chair and sofa use [`crate::sources::builtin::CHAIR_TEXEL_SCALE`] and
    /// [`crate::sources::builtin::SOFA_TEXEL_SCALE`] to reproduce the paper's per-object map budgets.
    pub texel_scale: f32,
}

/// A lamp: a photometric distribution placed in the world.
#[derive(Debug, Clone)]
pub struct Lamp {
    /// Name for reports.
    pub name: String,
    /// The luminous intensity distribution (candela), including its multipliers.
    pub photometry: Arc<Photometry>,
    /// Photometric centre, metres, world; double precision like [`Transform::translation`].
    pub position: [f64; 3],
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
    /// How the lamp emits: from a point, from its file's luminous opening, or whichever the
    /// scene needs ([`LampModel`], default [`LampModel::Auto`]).
    pub model: LampModel,
}

/// How a lamp emits ([`Lamp::model`]; the scene file's `lamp_model`).
///
/// - [`LampModel::Point`]: from its photometric centre, the file's intensity table alone.
/// - [`LampModel::Area`]: from its file's luminous opening (`luxbake::opening`), at every
///   texel; a file without an opening (all sizes 0) stays a point.
/// - [`LampModel::Auto`]: the opening where a receiver lies nearer the lamp than
///   [`LampModel::AUTO_TOLERANCE`]'s distance ([`luxbake_ies::Emitter::point_model_distance`]),
///   else the point. With the opening chosen, texels [`LampModel::SWITCH_FACTOR`] times
///   farther take the point, which costs one shadow ray instead of
///   [`Settings::opening_samples`]. The bake's report says which model each lamp got and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum LampModel {
    /// The point, or the opening where it matters.
    #[default]
    Auto,
    /// The photometric centre only.
    Point,
    /// The luminous opening everywhere.
    Area,
}

impl LampModel {
    /// Every model.
    pub const ALL: [LampModel; 3] = [LampModel::Auto, LampModel::Point, LampModel::Area];
    /// The point model's relative error above which [`LampModel::Auto`] takes the opening:
    /// 1 %, the IES rule of thumb (five times the largest dimension of a disk).
    pub const AUTO_TOLERANCE: f64 = 0.01;
    /// How much farther than the 1 % distance the opening is still evaluated, once chosen.
    /// On the opening's axis the point model's error falls with the square of the distance
    /// (0.25 % at twice the distance), but toward a steep cut-off of the intensity table it
    /// falls more slowly: a wall 2.1 m from a 0.21 m disk downlight (`rw_2.IES`, 1 % distance
    /// 1.05 m) sees the point model 2 % off Radiance's opening (`bench nearfield`, round room).
    /// Four times: 0.06 % on the axis, and room for such directions.
    pub const SWITCH_FACTOR: f64 = 4.0;

    /// The lower-case name used by scene files, the CLI and the JavaScript package.
    pub fn name(self) -> &'static str {
        match self {
            LampModel::Auto => "auto",
            LampModel::Point => "point",
            LampModel::Area => "area",
        }
    }
}

impl Lamp {
    /// A lamp with the default frame (aim straight down, no rotation), multiplier 1, white.
    pub fn new(name: impl Into<String>, photometry: Arc<Photometry>, position: [f64; 3]) -> Lamp {
        Lamp {
            name: name.into(),
            photometry,
            position,
            aim: [0.0, -1.0, 0.0],
            rotation_deg: 0.0,
            multiplier: 1.0,
            color: [1.0; 3],
            model: LampModel::Auto,
        }
    }

    /// Checks the lamp's placement and scale as every bake input does: a finite position, a
    /// finite non-zero aim, a finite rotation, a finite multiplier ≥ 0 and finite colour
    /// components ≥ 0. The error names the field (`position`, `aim`, `rotation_deg`,
    /// `multiplier`, `color`).
    ///
    /// # Errors
    /// A [`SettingError`] naming the first field out of range.
    pub fn validate(&self) -> Result<(), SettingError> {
        let invalid = |name, reason| Err(SettingError { name, reason });
        if !self.position.iter().all(|c| c.is_finite()) {
            return invalid(
                "position",
                format!("{:?}; expected finite metres", self.position),
            );
        }
        if !self.aim.iter().all(|c| c.is_finite()) || self.aim.iter().all(|&c| c == 0.0) {
            return invalid(
                "aim",
                format!("{:?}; expected a finite, non-zero direction", self.aim),
            );
        }
        if !self.rotation_deg.is_finite() {
            return invalid(
                "rotation_deg",
                format!("{}; expected finite degrees", self.rotation_deg),
            );
        }
        if !(self.multiplier >= 0.0 && self.multiplier.is_finite()) {
            return invalid(
                "multiplier",
                format!("{}; expected a finite number >= 0", self.multiplier),
            );
        }
        if !self.color.iter().all(|&c| c >= 0.0 && c.is_finite()) {
            return invalid(
                "color",
                format!("{:?}; expected finite components >= 0", self.color),
            );
        }
        Ok(())
    }

    /// The rotation from world directions to the `luxbake-ies` photometric frame (nadir −Z,
    /// C0 +X, C90 +Y), **row-major**: `photometric[r] = Σ_c m[r][c] · world[c]`. Row 0 is the
    /// world direction of C0 (photometric +X), row 1 of C90 (+Y), row 2 of the zenith (+Z,
    /// = −aim). Orthonormal and right-handed; its transpose maps back to world. The rule is
    /// in the module docs.
    pub fn world_to_photometric_matrix(&self) -> [[f32; 3]; 3] {
        self.frame_f64()
            .map(|row| DVec3::from(row).as_vec3().to_array())
    }

    /// [`Lamp::world_to_photometric_matrix`] in double precision.
    pub fn frame_f64(&self) -> [[f64; 3]; 3] {
        let default_aim = DVec3::NEG_Y;
        let aim = normalize_f64(Vec3::from(self.aim).as_dvec3()).unwrap_or(default_aim);
        let basis = [DVec3::X, DVec3::NEG_Z, DVec3::Y];
        // Step 2: the smallest rotation taking −Y onto `aim` (Rodrigues).
        let c = default_aim.dot(aim);
        let aimed = if c < -1.0 + 1e-12 {
            // Straight up: 180° about +X.
            basis.map(|v| DVec3::new(v.x, -v.y, -v.z))
        } else {
            let k = default_aim.cross(aim);
            basis.map(|v| {
                let kxv = k.cross(v);
                let kxkxv = k.cross(kxv);
                v + kxv + kxkxv / (1.0 + c)
            })
        };
        // Step 3: turn about the zenith axis by rotation_deg (right-handed).
        let theta = f64::from(self.rotation_deg).to_radians();
        let theta = if theta.is_finite() { theta } else { 0.0 };
        let (s, co) = theta.sin_cos();
        let zenith = aimed[2];
        let rot = |v: DVec3| v * co + zenith.cross(v) * s + zenith * zenith.dot(v) * (1.0 - co);
        [rot(aimed[0]), rot(aimed[1]), zenith].map(|v| v.to_array())
    }

    /// The luminaire's tilt, degrees in [0, 180]: the angle between its photometric nadir
    /// (`aim`) and world straight down (−Y), at which the bake evaluates the photometry's tilt
    /// factors (`TILT=INCLUDE` or a tilt file; see `luxbake_ies`, *Multipliers and tilt*).
    /// `rotation_deg` turns the lamp about its nadir and leaves the tilt unchanged.
    pub fn tilt_deg(&self) -> f64 {
        // Row 2 is the zenith, −aim: its +Y component is the cosine of the tilt.
        self.frame_f64()[2][1].clamp(-1.0, 1.0).acos().to_degrees()
    }

    /// Maps a world direction (any length) to the photometric frame; the result has the same
    /// length. Intensity toward a texel at `p` is `photometry` evaluated at
    /// `to_photometric(p − position)`.
    pub fn to_photometric(&self, world_dir: [f32; 3]) -> [f32; 3] {
        let d = Vec3::from(world_dir).as_dvec3();
        self.frame_f64().map(|row| DVec3::from(row).dot(d) as f32)
    }
}

/// Which generator draws the gather directions' uniforms (the draws themselves are
/// `luxbake::rng`'s, the same in every backend).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Sampler {
    /// Independent hashes per ray (`luxbake::rng::uniform2`): the paper's sampling; RMSE falls
    /// as N^-1/2.
    #[default]
    Hash,
    /// The shuffled, Owen-scrambled Sobol (0,2)-sequence (`luxbake::rng::sobol2`), shared by
    /// blocks of 2 × 2 neighbouring texels whose directions it stratifies against one another
    /// (`luxbake::rng::Stream`).
    Sobol,
}

impl Sampler {
    /// Every sampler.
    pub const ALL: [Sampler; 2] = [Sampler::Hash, Sampler::Sobol];

    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Hash => "hash",
            Sampler::Sobol => "sobol",
        }
    }

    /// The id a shader compares `GatherParams::sampler` with (`LUX_SAMPLER_<NAME>` in the
    /// generated prefix): 0 hash, 1 Sobol.
    pub fn id(self) -> u32 {
        match self {
            Sampler::Hash => 0,
            Sampler::Sobol => 1,
        }
    }

    /// The sampler of id `id`; any id but Sobol's draws with the hash, as the shaders do.
    pub fn from_id(id: u32) -> Sampler {
        if id == Sampler::Sobol.id() {
            Sampler::Sobol
        } else {
            Sampler::Hash
        }
    }
}

impl fmt::Display for Sampler {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which pipeline a bake runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// The paper's pipeline exactly: fixed bounces (the Jacobi iteration
    /// `ind_k = gather(ρ · blur(direct + ind_{k−1}))`), Gaussian blur of the reported maps,
    /// hash sampling.
    Paper,
    /// Every bounce: explicit bounce increments until the series' tail can be estimated
    /// (`luxbake::series`), the tail added, only the noisy indirect light filtered; the direct
    /// light is reported unblurred.
    Converged,
}

impl Method {
    /// Every method.
    pub const ALL: [Method; 2] = [Method::Paper, Method::Converged];

    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            Method::Paper => "paper",
            Method::Converged => "converged",
        }
    }
}

crate::names::from_str_by_name!(Method, Quality, BvhMode, LampModel, Sampler);

/// Quality preset of the converged method ([`Settings::preset`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Quality {
    /// Fast previews.
    Draft,
    /// The default.
    Default,
    /// Lighting-engineering accuracy.
    Final,
}

impl Quality {
    /// Every preset.
    pub const ALL: [Quality; 3] = [Quality::Draft, Quality::Default, Quality::Final];

    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            Quality::Draft => "draft",
            Quality::Default => "default",
            Quality::Final => "final",
        }
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

impl Blur {
    /// A sigma in texels as a blur: 0 is [`Blur::None`], anything else [`Blur::Sigma`] (which
    /// [`Settings::validate`] checks).
    pub fn sigma(sigma: f32) -> Blur {
        if sigma == 0.0 {
            Blur::None
        } else {
            Blur::Sigma(sigma)
        }
    }
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
    /// The default: on the CPU backend an 8-wide BVH with AVX (else SSE) box tests collapsed
    /// from the same SAH tree ([`luxbake_bvh::WideBvh`]); the GPU backends, which walk the
    /// encoded textures, use the MTBVH for it ([`BvhMode::encoded`]). Same hits as the MTBVH
    /// except for ties.
    Wide,
    /// Six link orders, one per dominant ray direction (Hachisuka 2015).
    Mtbvh,
    /// One threaded depth-first link order (Simonsen et al. 2005).
    Tbvh,
    /// Brute force over all triangles (the paper's "no BVH").
    None,
}

impl BvhMode {
    /// Every mode.
    pub const ALL: [BvhMode; 4] = [BvhMode::Wide, BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None];

    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            BvhMode::Wide => "wide",
            BvhMode::Mtbvh => "mtbvh",
            BvhMode::Tbvh => "tbvh",
            BvhMode::None => "none",
        }
    }

    /// The traversal of the encoded textures that stands for this mode on a backend that only
    /// has those (the shaders): [`BvhMode::Wide`] is the MTBVH, the others are themselves.
    pub fn encoded(self) -> BvhMode {
        match self {
            BvhMode::Wide => BvhMode::Mtbvh,
            m => m,
        }
    }
}

/// Bake settings.
///
/// # Limits
/// One set, checked by [`Settings::validate`] wherever settings come in (scene files, the
/// CLI, the viewer) and again by `bake()`:
///
/// | setting            | allowed                                                   |
/// |--------------------|-----------------------------------------------------------|
/// | `rays`             | 1 ..= [`MAX_RAYS`](Settings::MAX_RAYS) (65536)            |
/// | `bounces`          | 0 ..= [`MAX_BOUNCES`](Settings::MAX_BOUNCES) (64)         |
/// | `blur`             | `None`, or a sigma in (0, [`MAX_BLUR_SIGMA`](Settings::MAX_BLUR_SIGMA)] (64) texels |
/// | `texels_per_metre` | finite, > 0; the maps it gives must fit `luxbake::layout::Layout::MAX_TEXELS`, checked when the layout is sized |
/// | `higher_rays`      | 1 ..= `MAX_RAYS`                                           |
/// | `stride`, `higher_stride` | 1 ..= [`MAX_STRIDE`](Settings::MAX_STRIDE) (16)     |
/// | `refine_rays`      | 0 ..= `MAX_RAYS`, and 0 unless `stride` is 1; `refine_error` > 0 |
/// | `narrow_rays`      | 0 ..= `MAX_RAYS`                                          |
/// | `lamp_paths`       | 0 ..= [`MAX_LAMP_PATHS`](Settings::MAX_LAMP_PATHS) (1024); used with `stride` 1 only (else reported as skipped) |
/// | `opening_samples`  | 1 ..= [`MAX_OPENING_SAMPLES`] (1024) |
/// | `opening_probe_stride` | 0 ..= [`MAX_OPENING_SAMPLES`]; 0 and 1: every point casts its ray |
/// | `tail`, `bvh`, `seed`, `backend` | any value                                     |
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// The pipeline.
    pub method: Method,
    /// The preset these settings started from (recorded in the manifest; explicit settings
    /// may have changed single values since).
    pub quality: Quality,
    /// Gather rays per texel: per bounce ([`Method::Paper`]), or of the first bounce
    /// ([`Method::Converged`]; later bounces use [`Settings::higher_rays`]).
    pub rays: u32,
    /// Indirect bounces ([`Method::Paper`]), or the explicit bounces of [`Method::Converged`]:
    /// with [`Settings::tail`] the most it runs before the tail is added (it may stop earlier
    /// at [`Settings::tail_tolerance`]), without it exactly this many; 0 = direct light only.
    pub bounces: u32,
    /// [`Method::Converged`]: after the explicit bounces, add the extrapolated rest of the
    /// inter-reflection series (`luxbake::series`). The presets set it; [`Settings::paper`]
    /// does not, and the paper's method ignores it. A [`SettingsPatch`] that sets `bounces`
    /// without `tail` turns it off: an explicit count gives exactly that many bounces.
    pub tail: bool,
    /// [`Method::Paper`]: blur of the direct and combined maps. [`Method::Converged`]: filter of
    /// the indirect increments only.
    pub blur: Blur,
    /// [`Method::Converged`]: explicit bounces stop once the estimated tail is under this
    /// fraction of the total, or (from bounce 5 on) two successive estimates of the converged
    /// total agree within it (`luxbake::series`).
    pub tail_tolerance: f32,
    /// Light-map texel density, texels per metre.
    pub texels_per_metre: f32,
    /// Traversal structure.
    pub bvh: BvhMode,
    /// Seed of the stateless random-number hash.
    pub seed: u32,
    /// Sampler of the gather directions: the paper's independent hash, or the per-texel
    /// scrambled Sobol sequence (`luxbake::rng`).
    pub sampler: Sampler,
    /// [`Method::Converged`]: the first bounce is gathered on a grid of every `stride`-th
    /// texel per axis (and on texels with no grid texel on their surface) and interpolated on
    /// each surface (`luxbake::program::coarse`); 1 = every texel.
    pub stride: u32,
    /// [`Method::Converged`]: rays per gathered texel of the bounces after the first. Higher
    /// bounces are smooth (the sum of many paths) and their noise is averaged by the next
    /// gather and the final denoiser, so few rays, on a coarser grid, keep their error under
    /// the first bounce's (measured: docs/performance.md).
    pub higher_rays: u32,
    /// [`Method::Converged`]: [`Settings::stride`] of the bounces after the first.
    pub higher_stride: u32,
    /// [`Method::Converged`]: progressive refinement of the first bounce — texels whose
    /// first gather's estimated standard error after `rays`, relative to the light known at
    /// the texel (its neighbours' first bounce and its own direct light), exceeds
    /// [`Settings::refine_error`] get this many more rays (`luxbake::program::Program::Refine`);
    /// 0 = off.
    pub refine_rays: u32,
    /// [`Method::Converged`]: the relative standard error per texel that refinement aims at
    /// (of the first bounce's noise over the direct light and the first bounce together).
    pub refine_error: f32,
    /// [`Method::Converged`]: rays per texel in a narrow gap (`luxbake::validity::NARROW_GAP`:
    /// its surface faces another within a few texels and a 64th of the room's size, in a gap
    /// closed to its sides, as the back of a bookcase near a wall is), in the first two
    /// bounces, half as many in each bounce after (as the bounces' light shrinks), whatever
    /// its noise: a bounce that gathers fewer there adds the rest as refinement adds rays
    /// (`luxbake::passes::refine`, "Narrow gaps") — the first bounce with `stride` 1 (and
    /// `lamp_paths · narrow_rays / rays` further connections; without
    /// [`Settings::direct_at_hits`] these rays read the lamps' direct light at their hits and
    /// stand for the texel's first bounce alone, with it they add to the first gather's), the
    /// later ones at any `higher_stride` — and the denoiser's first iterations narrow
    /// there with the rays (`luxbake::program::atrous_steps`). 0 (or no more than a bounce's
    /// own rays): none. [`Settings::NARROW_RAYS`] at `default`, 256 at `final` (its first
    /// bounce's rays everywhere: so its later bounces' in gaps), 0 at `draft`.
    pub narrow_rays: u32,
    /// [`Method::Converged`] with [`Settings::blur`]: the denoiser's bias correction — the
    /// à-trous filter's residual filtered once more and added back, `y + B(x − y)`, which
    /// cancels the filter's bias where the light curves within its kernel (the chairs' seat
    /// undersides and aprons; `luxbake::program::correction_steps`). One more filter
    /// iteration than [`Settings::blur`]'s, without the luminance term, and a light map of
    /// memory. On in the `default` and `final` presets ([`Settings::preset`]).
    pub denoise_correction: bool,
    /// [`Method::Converged`]: the first bounce evaluates the lamps' direct light at each of its
    /// gather ray's hits, as the direct pass does at a texel (a shadow ray per lamp), instead
    /// of reading it from the direct light map there; a hit within a lamp's luminous opening's
    /// near distance reads the map as without it. The map holds the direct light at texel
    /// centres, and a gather ray that meets it between them reads it interpolated: where a
    /// shadow's edge or the light's bend crosses a texel that read is off by a share of the
    /// texel, and a surface that sees such a patch (a seat's underside over its own shadow on
    /// the floor) gathers its error (`luxbake::passes::gather`, "Direct light at the hits").
    /// A shadow ray per gather ray and lamp. On in the `final` preset ([`Settings::preset`]).
    pub direct_at_hits: bool,
    /// [`Method::Converged`]: lamp paths per texel of the first bounce — points lit by the
    /// lamps, connected to the texel and combined with its gather by multiple importance
    /// sampling (`luxbake::lightpaths`); 0 = the gather alone ([`Method::Paper`] ignores it).
    /// Used when the first bounce is gathered at every texel (`stride` 1); otherwise the
    /// bake reports them skipped. With [`Settings::refine_rays`] a refined texel also gets
    /// `lamp_paths · refine_rays / rays` further connections (`luxbake::passes::refine`).
    pub lamp_paths: u32,
    /// Points of a lamp's luminous opening, each with its shadow ray, per texel near a lamp
    /// that has one (`luxbake::opening`, [`LampModel`]); texels farther away and lamps
    /// without an opening cast one shadow ray as before.
    pub opening_samples: u32,
    /// Opening samples per visibility probe: a texel near an opening first casts the shadow
    /// rays of every `opening_probe_stride`-th of its points (those that give it light); when
    /// all of them reach the opening, its other points are taken as seen without a ray, else
    /// every point casts its own. 0 or 1: every point casts its ray (`luxbake::opening`'s
    /// docs, "Probes", say what it saves and what it can miss).
    pub opening_probe_stride: u32,
}

impl Settings {
    /// Gather rays per texel per bounce of [`Settings::paper`]. Chosen from the measured
    /// speed/accuracy Pareto front against a 4-bounce reference (`cargo xtask bench trade`,
    /// docs/performance.md).
    pub const PAPER_RAYS: u32 = 4;
    /// Bounces of [`Settings::paper`].
    pub const PAPER_BOUNCES: u32 = 3;
    /// Blur sigma of [`Settings::paper`], texels.
    pub const PAPER_BLUR_SIGMA: f32 = 2.0;
    /// Hard cap of explicit bounces of the converged presets.
    pub const CONVERGED_MAX_BOUNCES: u32 = 32;
    /// Default texel density, texels per metre (1.5625 cm texels). With it the built-in scenes
    /// come close to the light-map texel counts of the paper's Table 1.
    pub const DEFAULT_TEXELS_PER_METRE: f32 = 64.0;

    /// The method paper's pipeline with the settings measured best for it: 4 rays, 3 bounces,
    /// blur σ 2, 64 texels/m, MTBVH, seed 0, hash sampling (no [`Settings::tail`]: the paper's
    /// method ignores it).
    pub fn paper() -> Settings {
        Settings {
            method: Method::Paper,
            quality: Quality::Default,
            rays: Settings::PAPER_RAYS,
            bounces: Settings::PAPER_BOUNCES,
            tail: false,
            blur: Blur::Sigma(Settings::PAPER_BLUR_SIGMA),
            tail_tolerance: 0.01,
            texels_per_metre: Settings::DEFAULT_TEXELS_PER_METRE,
            bvh: BvhMode::Wide,
            seed: 0,
            sampler: Sampler::Hash,
            stride: 1,
            higher_rays: 1,
            higher_stride: 1,
            refine_rays: 0,
            refine_error: 0.1,
            narrow_rays: 0,
            denoise_correction: false,
            direct_at_hits: false,
            lamp_paths: 0,
            opening_samples: 32,
            opening_probe_stride: Settings::OPENING_PROBE_STRIDE,
        }
    }

    /// The converged method at `quality`, with the tail ([`Settings::tail`]): first-bounce
    /// rays and grid stride, the later bounces' rays and stride, the cap of explicit bounces,
    /// the tail tolerance and the
    /// denoiser's size (`blur` σ: `3 + round(log2 σ)` à-trous iterations). Measured against
    /// Radiance on `chairs_05` and for grain on a box room (docs/performance.md).
    ///
    /// | preset | rays (stride) | lamp paths | later bounces: rays (stride) | most bounces | tail tolerance | σ (iterations) | bias correction | opening samples |
    /// |---|--:|--:|--:|--:|--:|--:|--:|--:|
    /// | draft | 8 (4) | — | 4 (8) | 3 | 5 % | none | — | 12 |
    /// | default | 8 (1) | 4 | 16 (4) | 32 | 1 % | 1 (3) | yes | 48 |
    /// | final | 256 (1) | 32 | 32 (1) | 32 | 0.01 % | 1 (3) | yes | 128 |
    ///
    /// `default`'s first bounce and denoiser (8 rays, 4 lamp paths, the bias correction; before
    /// 2026-12-06 4 rays, 12 lamp paths, no correction) were chosen on the furniture of three
    /// rooms held out of the tuning: against the Radiance references over sixteen seeds every
    /// surface kind within 1.0 % mean |relative error| and ±0.3 % bias (the furniture 0.90–0.99 %,
    /// −0.23 … −0.29 %, was 1.07–1.26 %, −0.41 … −0.66 %; 0.85–0.97 %, −0.07 … −0.12 % against
    /// the furniture traced at its surface), the box room's walls 0.70 % grain;
    /// a lamp swap casts a third of the connections, whose shadow rays depend on the lamp,
    /// while the gather's rays are kept per room (docs/performance.md, "The default's first
    /// bounce re-split").
    ///
    /// `final` is held to 0.3 % mean |relative error| against Radiance references with half
    /// the usual noise (`bench/references/hq`, four rooms, one of them tuned on): its own noise
    /// was 0.24 % per point at 128 and 16 rays, and the tail it extrapolates after bounce 5 or
    /// 6 lands where the last bounce did, a little more in open places than the later bounces
    /// would put it (+0.1 % at the points of `chairs_10`); twice the rays and a tolerance that
    /// lets it run to bounce 9 lower both (noise 0.24 → 0.19 %, bias +0.12 → +0.10 %; mean
    /// 0.38 → 0.28 % there), at 2.2–2.3× the time (docs/performance.md). What was left on the
    /// held-out `chairs_10` (its furniture 0.38 % at 64 texels/m, 0.26 % at 128) was the
    /// maps' resolution where the first bounce read them: since 2026-12-06 `final` evaluates
    /// the direct light at its first bounce's hits ([`Settings::direct_at_hits`]) and filters
    /// at σ 1 with the bias correction (σ 2 without it before). Chosen on the tuned rooms
    /// (`chairs_05` furniture 0.31 → 0.29 %, `sofa_01` 0.59 → 0.47 %, two seeds); on the
    /// held-out rooms the furniture reads 0.31 / 0.26 / 0.27 % (`chairs_01` / `chairs_03` /
    /// `chairs_10`; 0.26 / 0.29 / 0.38 % before) and every other kind 0.09–0.22 %; against
    /// references that trace the furniture at its surface rather than 1 mm off it (under a
    /// seat the millimetre sees more of the lit floor: `bench/references/hq/README.md`)
    /// 0.26 / 0.20 / 0.27 %, biases −0.01 … +0.10 %.
    ///
    /// Opening samples ([`Settings::opening_samples`]): at `default` the direct light on a
    /// table 0.55 m under a 0.61 m linear pendant (`rw_5.IES`) is within 0.7 % of a
    /// 1024-sample bake at every texel (32 samples: 1.0 %; `crates/bake/tests/opening.rs`).
    ///
    /// The later bounces at `default` (16 rays on every fourth texel per axis): the same rays
    /// per texel of the room as 4 on every second, at the same time, but each gathered texel's
    /// 16 directions stratified together; tuned on `chairs_05` and `sofa_01`, on the three
    /// other rooms 7–10 % less error against Radiance, the walls' 14–23 % less (stride 8 biased
    /// the floors; docs/performance.md).
    ///
    /// Lamp paths ([`Settings::lamp_paths`]) take the first bounce's grain where a lamp
    /// lights a small patch brightly (a lamp under the ceiling): on the box room's walls at
    /// `default` from 2.5–3.8 % (the gather alone) to under 1 %. `draft` gathers its first bounce on a grid, where
    /// they do not apply.
    ///
    /// Refinement ([`Settings::refine_rays`]) is off in every preset: on `chairs_05` and the
    /// box room it refined 60–77 % of the texels at targets that lowered the error, so it
    /// cost as many rays as sampling every texel more (docs/performance.md). The rays in narrow
    /// gaps ([`Settings::narrow_rays`]) are on at `default`: with [`Settings::NARROW_RAYS`] (64
    /// in the first two bounces there, half as many in each after, the first bounce's reading
    /// the lamps' direct light where they land) it holds 1 % on every surface kind of all three
    /// real rooms (the furniture behind which a bookcase or a sideboard stands 2.5–3 cm from a
    /// wall: the lounge 1.76 → 0.95 %, the dining room 0.92 → 0.65 %, the office 0.64 → 0.56 %,
    /// sixteen seeds), in 0.86–0.90× the time `default` took when issue 29 was filed and
    /// 1.02–1.23× the time without them (the built-in rooms, whose gaps are open to their
    /// sides, read as before within 0.002 %; docs/performance.md, "The default's rays in
    /// narrow gaps"). At `final` 256, so that the later bounces' 32 rays become 256, 128 and
    /// 64 in gaps: its furniture (two seeds) lounge 0.58 → 0.46 %, dining 0.28 → 0.25 %,
    /// office 0.21 → 0.22 %.
    pub fn preset(quality: Quality) -> Settings {
        let base = Settings {
            method: Method::Converged,
            quality,
            bounces: Settings::CONVERGED_MAX_BOUNCES,
            tail: true,
            sampler: Sampler::Sobol,
            ..Settings::paper()
        };
        match quality {
            Quality::Draft => Settings {
                rays: 8,
                stride: 4,
                higher_rays: 4,
                higher_stride: 8,
                bounces: 3,
                tail_tolerance: 0.05,
                blur: Blur::None,
                opening_samples: 12,
                ..base
            },
            Quality::Default => Settings {
                rays: 8,
                lamp_paths: 4,
                denoise_correction: true,
                opening_samples: 48,
                higher_rays: 16,
                higher_stride: 4,
                narrow_rays: Settings::NARROW_RAYS,
                tail_tolerance: 0.01,
                blur: Blur::Sigma(1.0),
                ..base
            },
            Quality::Final => Settings {
                rays: 256,
                lamp_paths: 32,
                higher_rays: 32,
                tail_tolerance: 0.0001,
                blur: Blur::Sigma(1.0),
                denoise_correction: true,
                direct_at_hits: true,
                narrow_rays: 256,
                opening_samples: 128,
                ..base
            },
        }
    }

    /// The starting settings of `method`: [`Settings::paper`], or the converged method's
    /// [`Settings::preset`] at `quality` (which the paper's method ignores).
    pub fn of(method: Method, quality: Quality) -> Settings {
        match method {
            Method::Paper => Settings::paper(),
            Method::Converged => Settings::preset(quality),
        }
    }

    /// Most gather rays per texel per bounce.
    pub const MAX_RAYS: u32 = 65_536;
    /// Most indirect bounces.
    pub const MAX_BOUNCES: u32 = 64;
    /// Largest blur sigma, texels.
    pub const MAX_BLUR_SIGMA: f32 = 64.0;
    /// Largest [`Settings::stride`] and [`Settings::higher_stride`].
    pub const MAX_STRIDE: u32 = 16;
    /// Largest [`Settings::lamp_paths`].
    pub const MAX_LAMP_PATHS: u32 = 1024;
    /// [`Settings::narrow_rays`] of the `default` preset (see [`Settings::preset`]): 64 rays in
    /// narrow gaps in the first two bounces, half as many in each bounce after.
    pub const NARROW_RAYS: u32 = 64;
    /// [`Settings::opening_probe_stride`] of every preset: 12 probes of the `default` preset's
    /// 48 points (24 of 96 near an opening).
    pub const OPENING_PROBE_STRIDE: u32 = 4;

    /// Checks every setting against the limits in the type's docs; the error names the first
    /// setting out of range (`rays`, `bounces`, `blur`, `tail_tolerance`, `stride`,
    /// `higher_stride`, `higher_rays`, `refine_rays`, `narrow_rays`, `lamp_paths`, `opening_samples`,
    /// `opening_probe_stride`, `refine_error` or `texels_per_metre`).
    pub fn validate(&self) -> Result<(), SettingError> {
        let invalid = |name, reason| Err(SettingError { name, reason });
        if !(1..=Settings::MAX_RAYS).contains(&self.rays) {
            let max = Settings::MAX_RAYS;
            return invalid("rays", format!("{}; expected 1..={max}", self.rays));
        }
        if self.bounces > Settings::MAX_BOUNCES {
            let max = Settings::MAX_BOUNCES;
            return invalid("bounces", format!("{}; expected 0..={max}", self.bounces));
        }
        if let Blur::Sigma(sigma) = self.blur
            && !(sigma > 0.0 && sigma <= Settings::MAX_BLUR_SIGMA)
        {
            let max = Settings::MAX_BLUR_SIGMA;
            return invalid(
                "blur",
                format!("{sigma}; expected a sigma in texels, 0 < sigma <= {max}, or \"none\""),
            );
        }
        let t = self.tail_tolerance;
        if !(t > 0.0 && t < 1.0) {
            return invalid(
                "tail_tolerance",
                format!("{t}; expected a fraction, 0 < tail_tolerance < 1"),
            );
        }
        for (name, stride) in [
            ("stride", self.stride),
            ("higher_stride", self.higher_stride),
        ] {
            if !(1..=Settings::MAX_STRIDE).contains(&stride) {
                let max = Settings::MAX_STRIDE;
                return invalid(name, format!("{stride}; expected 1..={max}"));
            }
        }
        if !(1..=Settings::MAX_RAYS).contains(&self.higher_rays) {
            let max = Settings::MAX_RAYS;
            return invalid(
                "higher_rays",
                format!("{}; expected 1..={max}", self.higher_rays),
            );
        }
        if self.refine_rays > Settings::MAX_RAYS {
            let max = Settings::MAX_RAYS;
            return invalid(
                "refine_rays",
                format!("{}; expected 0..={max}", self.refine_rays),
            );
        }
        if self.refine_rays > 0 && self.stride > 1 {
            return invalid(
                "refine_rays",
                format!(
                    "{}; refinement needs a first bounce gathered at every texel (stride 1, \
                     not {}); set refine_rays = 0 or stride = 1",
                    self.refine_rays, self.stride
                ),
            );
        }
        if self.narrow_rays > Settings::MAX_RAYS {
            let max = Settings::MAX_RAYS;
            return invalid(
                "narrow_rays",
                format!("{}; expected 0..={max}", self.narrow_rays),
            );
        }
        if self.lamp_paths > Settings::MAX_LAMP_PATHS {
            let max = Settings::MAX_LAMP_PATHS;
            return invalid(
                "lamp_paths",
                format!("{}; expected 0..={max}", self.lamp_paths),
            );
        }
        if !(1..=MAX_OPENING_SAMPLES).contains(&self.opening_samples) {
            let max = MAX_OPENING_SAMPLES;
            return invalid(
                "opening_samples",
                format!("{}; expected 1..={max}", self.opening_samples),
            );
        }
        if self.opening_probe_stride > MAX_OPENING_SAMPLES {
            let max = MAX_OPENING_SAMPLES;
            return invalid(
                "opening_probe_stride",
                format!("{}; expected 0..={max}", self.opening_probe_stride),
            );
        }
        let e = self.refine_error;
        if !(e > 0.0 && e.is_finite()) {
            return invalid(
                "refine_error",
                format!("{e}; expected a positive relative standard error"),
            );
        }
        // No upper bound: the texel count it gives is limited where the layout is sized.
        let d = self.texels_per_metre;
        if !(d.is_finite() && d > 0.0) {
            return invalid(
                "texels_per_metre",
                format!("{d}; expected a finite number > 0"),
            );
        }
        Ok(())
    }
}

/// A setting outside the limits of [`Settings::validate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid setting `{name}`: {reason}")]
pub struct SettingError {
    /// The setting: its field of [`Settings`], also its key in a scene file's `[settings]`.
    pub name: &'static str,
    /// The value and what is allowed.
    pub reason: String,
}

impl Default for Settings {
    /// The converged method's `default` preset ([`Settings::preset`]).
    fn default() -> Self {
        Settings::preset(Quality::Default)
    }
}

/// Settings given key by key over a preset: a scene file's `[settings]` table, the flags of
/// `cargo xtask bake`, the options of the JavaScript package, the browser viewer's request.
/// Every field is optional; `None` keeps the value underneath. The one place that knows how
/// such a patch becomes [`Settings`].
///
/// Its keys (serde, e.g. TOML or JSON) are the field names, the scene file's: `method` and
/// `quality` (names, as [`Method`] and [`Quality`] parse them), `blur` (`"none"` or a sigma
/// in texels; 0 is none), `bvh`, `sampler` (names), the numbers, `tail` (a boolean). Unknown
/// keys are errors; [`SettingsPatch::from_entries`] names the key of a bad value.
///
/// # Rules
/// - **Preset**: a patch names one when it sets `method` or `quality`; `quality` without
///   `method` means [`Method::Converged`] (the quality is its preset). [`SettingsPatch::settings`]
///   starts from that preset ([`Settings::of`]; `quality` defaults to `default`), or from
///   [`Settings::default`] when the patch names none.
/// - **Bounces**: a patch that sets `bounces` and not `tail` turns [`Settings::tail`] off, so
///   an explicit count gives exactly that many bounces; with `tail = true` it is the cap.
/// - **Layering** ([`SettingsPatch::then`]): the later patch's values win key by key. When it
///   names a preset, that preset replaces the earlier one and every value a preset sets:
///   only the earlier `texels_per_metre`, `bvh` and `seed` (which no preset sets) and its
///   `quality` (when the later patch names only the method) stay. So
///   `file.then(&flags).settings()` is `file.settings()` with `flags` applied
///   ([`SettingsPatch::apply`]).
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SettingsPatch {
    /// [`Settings::method`] (the preset's method).
    #[serde(deserialize_with = "de::parsed")]
    pub method: Option<Method>,
    /// [`Settings::quality`] (the converged method's preset).
    #[serde(deserialize_with = "de::parsed")]
    pub quality: Option<Quality>,
    /// [`Settings::rays`].
    pub rays: Option<u32>,
    /// [`Settings::bounces`]; without `tail` it also turns the tail off.
    pub bounces: Option<u32>,
    /// [`Settings::tail`].
    pub tail: Option<bool>,
    /// [`Settings::blur`].
    #[serde(deserialize_with = "de::blur")]
    pub blur: Option<Blur>,
    /// [`Settings::tail_tolerance`].
    pub tail_tolerance: Option<f32>,
    /// [`Settings::texels_per_metre`].
    pub texels_per_metre: Option<f32>,
    /// [`Settings::bvh`].
    #[serde(deserialize_with = "de::parsed")]
    pub bvh: Option<BvhMode>,
    /// [`Settings::seed`].
    pub seed: Option<u32>,
    /// [`Settings::sampler`].
    #[serde(deserialize_with = "de::parsed")]
    pub sampler: Option<Sampler>,
    /// [`Settings::stride`].
    pub stride: Option<u32>,
    /// [`Settings::higher_rays`].
    pub higher_rays: Option<u32>,
    /// [`Settings::higher_stride`].
    pub higher_stride: Option<u32>,
    /// [`Settings::refine_rays`].
    pub refine_rays: Option<u32>,
    /// [`Settings::refine_error`].
    pub refine_error: Option<f32>,
    /// [`Settings::narrow_rays`].
    pub narrow_rays: Option<u32>,
    /// [`Settings::denoise_correction`].
    pub denoise_correction: Option<bool>,
    /// [`Settings::direct_at_hits`].
    pub direct_at_hits: Option<bool>,
    /// [`Settings::lamp_paths`].
    pub lamp_paths: Option<u32>,
    /// [`Settings::opening_samples`].
    pub opening_samples: Option<u32>,
    /// [`Settings::opening_probe_stride`].
    pub opening_probe_stride: Option<u32>,
}

impl SettingsPatch {
    /// The keys a patch reads, as its fields and the scene file's `[settings]` name them.
    pub const KEYS: [&'static str; 22] = [
        "method",
        "quality",
        "rays",
        "bounces",
        "tail",
        "blur",
        "tail_tolerance",
        "texels_per_metre",
        "bvh",
        "seed",
        "sampler",
        "stride",
        "higher_rays",
        "higher_stride",
        "refine_rays",
        "refine_error",
        "narrow_rays",
        "lamp_paths",
        "opening_samples",
        "opening_probe_stride",
        "denoise_correction",
        "direct_at_hits",
    ];

    /// A patch from `key → value` entries of any serde format (a TOML table, a JSON object);
    /// the keys are [`SettingsPatch::KEYS`].
    ///
    /// # Errors
    /// A [`PatchError`] naming the key of the first entry that is unknown or whose value has
    /// the wrong type or does not parse, as the entry spelled it.
    pub fn from_entries<'de, V, E>(entries: &[(String, V)]) -> Result<SettingsPatch, PatchError>
    where
        V: IntoDeserializer<'de, E> + Clone,
        E: serde::de::Error,
    {
        use serde::Deserialize;
        let patch = |entries: &[(String, V)]| {
            let pairs = entries.iter().map(|(k, v)| (k.as_str(), v.clone()));
            SettingsPatch::deserialize(MapDeserializer::<'de, _, E>::new(pairs))
        };
        patch(entries).map_err(|whole| {
            // Entry by entry, to name the key the error is about.
            entries
                .iter()
                .find_map(|entry| {
                    let e = patch(std::slice::from_ref(entry)).err()?;
                    Some(PatchError {
                        key: entry.0.clone(),
                        message: e.to_string(),
                    })
                })
                .unwrap_or_else(|| PatchError {
                    key: String::new(),
                    message: whole.to_string(),
                })
        })
    }

    /// The method of the preset this patch names, if it names one (see the type's rules).
    fn preset_method(&self) -> Option<Method> {
        self.method
            .or_else(|| self.quality.map(|_| Method::Converged))
    }

    /// [`Settings::tail`] as this patch sets it: `tail`, else off when it sets `bounces`.
    fn tail_setting(&self) -> Option<bool> {
        self.tail.or_else(|| self.bounces.map(|_| false))
    }

    /// `other` layered over this patch (see the type's rules).
    #[must_use]
    pub fn then(&self, other: &SettingsPatch) -> SettingsPatch {
        // A preset named by `other` replaces everything a preset sets.
        let base = match other.preset_method() {
            Some(method) => SettingsPatch {
                method: Some(method),
                quality: other.quality.or(self.quality),
                texels_per_metre: self.texels_per_metre,
                bvh: self.bvh,
                seed: self.seed,
                ..SettingsPatch::default()
            },
            None => self.clone(),
        };
        SettingsPatch {
            method: other.method.or(base.method),
            quality: other.quality.or(base.quality),
            rays: other.rays.or(base.rays),
            bounces: other.bounces.or(base.bounces),
            tail: other.tail_setting().or(base.tail),
            blur: other.blur.or(base.blur),
            tail_tolerance: other.tail_tolerance.or(base.tail_tolerance),
            texels_per_metre: other.texels_per_metre.or(base.texels_per_metre),
            bvh: other.bvh.or(base.bvh),
            seed: other.seed.or(base.seed),
            sampler: other.sampler.or(base.sampler),
            stride: other.stride.or(base.stride),
            higher_rays: other.higher_rays.or(base.higher_rays),
            higher_stride: other.higher_stride.or(base.higher_stride),
            refine_rays: other.refine_rays.or(base.refine_rays),
            refine_error: other.refine_error.or(base.refine_error),
            narrow_rays: other.narrow_rays.or(base.narrow_rays),
            denoise_correction: other.denoise_correction.or(base.denoise_correction),
            direct_at_hits: other.direct_at_hits.or(base.direct_at_hits),
            lamp_paths: other.lamp_paths.or(base.lamp_paths),
            opening_samples: other.opening_samples.or(base.opening_samples),
            opening_probe_stride: other.opening_probe_stride.or(base.opening_probe_stride),
        }
    }

    /// Applies the patch to `s`: a preset it names replaces `s` but for `texels_per_metre`,
    /// `bvh` and `seed` (and `quality` when the patch names only the method), then its values
    /// replace single settings. Unchecked: [`Settings::validate`] the result.
    pub fn apply(&self, s: &mut Settings) {
        if let Some(method) = self.preset_method() {
            *s = Settings {
                texels_per_metre: s.texels_per_metre,
                bvh: s.bvh,
                seed: s.seed,
                ..Settings::of(method, self.quality.unwrap_or(s.quality))
            };
        }
        fn set<T>(field: &mut T, value: Option<T>) {
            if let Some(v) = value {
                *field = v;
            }
        }
        set(&mut s.rays, self.rays);
        set(&mut s.bounces, self.bounces);
        set(&mut s.tail, self.tail_setting());
        set(&mut s.blur, self.blur);
        set(&mut s.tail_tolerance, self.tail_tolerance);
        set(&mut s.texels_per_metre, self.texels_per_metre);
        set(&mut s.bvh, self.bvh);
        set(&mut s.seed, self.seed);
        set(&mut s.sampler, self.sampler);
        set(&mut s.stride, self.stride);
        set(&mut s.higher_rays, self.higher_rays);
        set(&mut s.higher_stride, self.higher_stride);
        set(&mut s.refine_rays, self.refine_rays);
        set(&mut s.refine_error, self.refine_error);
        set(&mut s.narrow_rays, self.narrow_rays);
        set(&mut s.denoise_correction, self.denoise_correction);
        set(&mut s.direct_at_hits, self.direct_at_hits);
        set(&mut s.lamp_paths, self.lamp_paths);
        set(&mut s.opening_samples, self.opening_samples);
        set(&mut s.opening_probe_stride, self.opening_probe_stride);
    }

    /// The settings of this patch: the preset it names (or [`Settings::default`]) with its
    /// values applied, checked by [`Settings::validate`].
    ///
    /// # Errors
    /// The [`SettingError`] of [`Settings::validate`]; its `name` is the patch's key.
    pub fn settings(&self) -> Result<Settings, SettingError> {
        let mut s = Settings::default();
        self.apply(&mut s);
        s.validate()?;
        Ok(s)
    }
}

/// A key of a [`SettingsPatch`] that is unknown or whose value does not parse.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{key}`: {message}")]
pub struct PatchError {
    /// The key as the entry spelled it (empty if no single entry is at fault).
    pub key: String,
    /// The deserialiser's message.
    pub message: String,
}

/// Deserialisers of the [`SettingsPatch`] fields that are names.
mod de {
    use std::fmt;
    use std::str::FromStr;

    use serde::Deserializer;
    use serde::de::{Error, Visitor};

    use super::Blur;

    /// A name parsed with `T`'s `FromStr` (its message on failure).
    pub fn parsed<'de, D, T>(d: D) -> Result<Option<T>, D::Error>
    where
        D: Deserializer<'de>,
        T: FromStr<Err = String>,
    {
        let name: String = serde::Deserialize::deserialize(d)?;
        name.parse().map(Some).map_err(D::Error::custom)
    }

    /// `"none"` or a sigma in texels (0: none), as [`Blur`]'s `FromStr` and [`Blur::sigma`].
    pub fn blur<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Blur>, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Blur;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("\"none\" or a sigma in texels")
            }
            fn visit_str<E: Error>(self, v: &str) -> Result<Blur, E> {
                if v.trim().eq_ignore_ascii_case("none") {
                    Ok(Blur::None)
                } else {
                    Err(E::custom(format!(
                        "`{v}`; expected \"none\" or a sigma in texels"
                    )))
                }
            }
            fn visit_f64<E: Error>(self, v: f64) -> Result<Blur, E> {
                Ok(Blur::sigma(v as f32))
            }
            fn visit_i64<E: Error>(self, v: i64) -> Result<Blur, E> {
                Ok(Blur::sigma(v as f32))
            }
            fn visit_u64<E: Error>(self, v: u64) -> Result<Blur, E> {
                Ok(Blur::sigma(v as f32))
            }
        }
        d.deserialize_any(V).map(Some)
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

    /// The same scene scaled by `factor` about the world origin: object transforms and lamp
    /// positions are scaled and the texel density divided by `factor`, so every light map
    /// keeps its size in texels and every texel its place on the surface. Lamp intensities
    /// are unchanged, so illuminances scale as `1 / factor²`.
    pub fn scaled(&self, factor: f32) -> Scene {
        let mut s = self.clone();
        let scale = |v: [f32; 3]| (Vec3::from(v) * factor).to_array();
        let scale_f64 = |v: [f64; 3]| v.map(|c| c * f64::from(factor));
        for o in &mut s.objects {
            o.transform.linear = o.transform.linear.map(scale);
            o.transform.translation = scale_f64(o.transform.translation);
        }
        for l in &mut s.lamps {
            l.position = scale_f64(l.position);
        }
        s.settings.texels_per_metre /= factor;
        s
    }

    /// The same scene moved by `offset` metres: object translations and lamp positions (f64).
    /// Every light map keeps its size and every texel its place on the surface; moved back
    /// by `luxbake::bake::bake`'s re-centring, a scene at 10 km bakes like the original
    /// (the sums are exact while the offset and the coordinates fit f64's 53 bits together).
    pub fn translated(&self, offset: [f64; 3]) -> Scene {
        let mut s = self.clone();
        s.translate(offset);
        s
    }

    /// Moves the scene by `offset` metres in place, as [`Scene::translated`] does.
    pub fn translate(&mut self, offset: [f64; 3]) {
        let add = |v: [f64; 3]| std::array::from_fn(|c| v[c] + offset[c]);
        for o in &mut self.objects {
            o.transform.translation = add(o.transform.translation);
        }
        for l in &mut self.lamps {
            l.position = add(l.position);
        }
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
pub fn tri_indices(tri: &[u32; 3], m: &Mesh) -> Option<[usize; 3]> {
    let n = m
        .positions
        .len()
        .min(m.normals.len())
        .min(m.lightmap_uvs.len());
    let idx = tri.map(|i| i as usize);
    idx.iter().all(|&i| i < n).then_some(idx)
}

/// Rotation matrix `Rz · Ry · Rx` for angles in degrees (non-finite angles count as 0).
fn rotation_xyz(deg: DVec3) -> DMat3 {
    let [x, y, z] = deg
        .to_array()
        .map(|d| if d.is_finite() { d.to_radians() } else { 0.0 });
    DMat3::from_rotation_z(z) * (DMat3::from_rotation_y(y) * DMat3::from_rotation_x(x))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_back_and_other_words_list_every_name() {
        for m in Method::ALL {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
        }
        for q in Quality::ALL {
            assert_eq!(
                format!(" {} ", q.name().to_uppercase()).parse::<Quality>(),
                Ok(q)
            );
        }
        for b in BvhMode::ALL {
            assert_eq!(b.name().parse::<BvhMode>(), Ok(b));
        }
        for s in Sampler::ALL {
            assert_eq!(s.name().parse::<Sampler>(), Ok(s));
        }
        let err = |r: Result<(), String>| r.unwrap_err();
        assert_eq!(
            err("x".parse::<Method>().map(|_| ())),
            "expected \"paper\" or \"converged\", got `x`"
        );
        assert_eq!(
            err(" Best ".parse::<Quality>().map(|_| ())),
            "expected \"draft\", \"default\" or \"final\", got ` Best `"
        );
        assert_eq!(
            err("bvh".parse::<BvhMode>().map(|_| ())),
            "expected \"wide\", \"mtbvh\", \"tbvh\" or \"none\", got `bvh`"
        );
        assert_eq!(
            err("".parse::<Sampler>().map(|_| ())),
            "expected \"hash\" or \"sobol\", got ``"
        );
    }

    fn close(a: [f32; 3], b: [f32; 3]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5)
    }

    fn lamp(aim: [f32; 3], rotation_deg: f32) -> Lamp {
        let mut l = Lamp::new("t", Arc::new(Photometry::isotropic(1.0)), [0.0; 3]);
        l.aim = aim;
        l.rotation_deg = rotation_deg;
        l
    }

    #[test]
    fn lamp_validation_names_the_field() {
        assert_eq!(lamp([0.0, -1.0, 0.0], 0.0).validate(), Ok(()));
        type Edit = fn(&mut Lamp);
        let cases: [(&str, Edit); 6] = [
            ("position", |l| l.position[1] = f64::NAN),
            ("aim", |l| l.aim = [0.0; 3]),
            ("aim", |l| l.aim[0] = f32::INFINITY),
            ("rotation_deg", |l| l.rotation_deg = f32::NAN),
            ("multiplier", |l| l.multiplier = -1.0),
            ("color", |l| l.color[2] = -0.5),
        ];
        for (name, edit) in cases {
            let mut l = lamp([0.0, -1.0, 0.0], 0.0);
            edit(&mut l);
            assert_eq!(l.validate().map_err(|e| e.name), Err(name));
        }
    }

    #[test]
    fn transform_trs_with_explicit_vectors() {
        let t = Transform::IDENTITY;
        assert_eq!(t.point([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0]);
        // +90° about Y (right-handed) takes +X to −Z and +Z to +X.
        let ry = Transform::from_trs([0.0; 3], [0.0, 90.0, 0.0], [1.0; 3]);
        assert!(close(ry.point([1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]));
        assert!(close(ry.point([0.0, 0.0, 1.0]), [1.0, 0.0, 0.0]));
        // +90° about X takes +Y to +Z; about Z takes +X to +Y.
        let rx = Transform::from_trs([0.0; 3], [90.0, 0.0, 0.0], [1.0; 3]);
        assert!(close(rx.point([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]));
        let rz = Transform::from_trs([0.0; 3], [0.0, 0.0, 90.0], [1.0; 3]);
        assert!(close(rz.point([1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]));
        // Order: X first, then Y: +Y → (X) +Z → (Y) +X.
        let rxy = Transform::from_trs([0.0; 3], [90.0, 90.0, 0.0], [1.0; 3]);
        assert!(close(rxy.point([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0]));
        // Scale first, then rotate, then translate.
        let t = Transform::from_trs([1.0, 2.0, 3.0], [0.0, 90.0, 0.0], [2.0, 1.0, 1.0]);
        assert!(close(t.point([1.0, 0.0, 0.0]), [1.0, 2.0, 1.0]));
        assert!((t.determinant() - 2.0).abs() < 1e-6);
    }

    #[test]
    fn normals_use_the_inverse_transpose() {
        // A plane x + y = c squashed along x by 2: its normal turns toward +y.
        let t = Transform::from_trs([5.0, 0.0, 0.0], [0.0; 3], [2.0, 1.0, 1.0]);
        let s = 0.5f32.sqrt();
        let n = t.normal([s, s, 0.0]);
        let l = (0.25f32 + 1.0).sqrt();
        assert!(close(n, [0.5 / l, 1.0 / l, 0.0]), "{n:?}");
        // Perpendicular to a transformed tangent.
        let tangent = t.point([1.0, -1.0, 0.0]);
        let origin = t.point([0.0; 3]);
        let d: f32 = (0..3).map(|k| (tangent[k] - origin[k]) * n[k]).sum();
        assert!(d.abs() < 1e-6);
        // A mirror keeps the normal on the surface's side.
        let m = Transform::from_trs([0.0; 3], [0.0; 3], [-1.0, 1.0, 1.0]);
        assert!(close(m.normal([1.0, 0.0, 0.0]), [-1.0, 0.0, 0.0]));
        // Rotations rotate normals.
        let r = Transform::from_trs([0.0; 3], [0.0, 90.0, 0.0], [3.0; 3]);
        assert!(close(r.normal([1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]));
        // Singular transforms return the input, never NaN.
        let z = Transform::from_trs([0.0; 3], [0.0; 3], [0.0, 1.0, 1.0]);
        assert_eq!(z.normal([0.0, 1.0, 0.0]), [0.0, 1.0, 0.0]);
    }

    #[test]
    fn tilt_is_the_angle_between_aim_and_straight_down() {
        let h = 0.5f32.sqrt();
        for (aim, rotation, want) in [
            ([0.0, -1.0, 0.0], 0.0, 0.0),
            ([0.0, -2.0, 0.0], 70.0, 0.0),
            ([h, -h, 0.0], 0.0, 45.0),
            ([0.0, -h, h], 30.0, 45.0),
            ([0.5, -(0.75f32.sqrt()), 0.0], 0.0, 30.0),
            ([1.0, 0.0, 0.0], 90.0, 90.0),
            ([0.0, 1.0, 0.0], 0.0, 180.0),
            ([0.0, 0.0, 0.0], 0.0, 0.0),
        ] {
            let t = lamp(aim, rotation).tilt_deg();
            assert!((t - want).abs() < 1e-5, "{aim:?} {rotation}: {t}");
        }
    }

    #[test]
    fn default_lamp_frame() {
        let l = lamp([0.0, -1.0, 0.0], 0.0);
        assert!(
            close(l.to_photometric([0.0, -1.0, 0.0]), [0.0, 0.0, -1.0]),
            "−Y is the nadir"
        );
        assert!(
            close(l.to_photometric([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]),
            "+X is C0"
        );
        assert!(
            close(l.to_photometric([0.0, 0.0, -1.0]), [0.0, 1.0, 0.0]),
            "−Z is C90"
        );
        assert!(
            close(l.to_photometric([0.0, 2.0, 0.0]), [0.0, 0.0, 2.0]),
            "length kept"
        );
        let m = l.world_to_photometric_matrix();
        assert_eq!(m, [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]);
    }

    #[test]
    fn rotation_turns_c0_toward_c90() {
        let l = lamp([0.0, -1.0, 0.0], 90.0);
        assert!(
            close(l.to_photometric([0.0, 0.0, -1.0]), [1.0, 0.0, 0.0]),
            "C0 now at −Z"
        );
        assert!(
            close(l.to_photometric([-1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]),
            "C90 now at −X"
        );
        assert!(
            close(l.to_photometric([0.0, -1.0, 0.0]), [0.0, 0.0, -1.0]),
            "nadir unchanged"
        );
        let l = lamp([0.0, -1.0, 0.0], 180.0);
        assert!(close(l.to_photometric([-1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
    }

    #[test]
    fn aim_turns_the_frame() {
        // Aimed along +X (a wall washer): smallest rotation from −Y, about +Z.
        let l = lamp([2.0, 0.0, 0.0], 0.0);
        assert!(
            close(l.to_photometric([1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]),
            "+X is the nadir"
        );
        assert!(
            close(l.to_photometric([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0]),
            "+Y is C0"
        );
        assert!(
            close(l.to_photometric([0.0, 0.0, -1.0]), [0.0, 1.0, 0.0]),
            "−Z stays C90"
        );
        // Then rotation turns about the new axis: C0 moves to where C90 was.
        let l = lamp([1.0, 0.0, 0.0], 90.0);
        assert!(close(l.to_photometric([0.0, 0.0, -1.0]), [1.0, 0.0, 0.0]));
        assert!(close(l.to_photometric([1.0, 0.0, 0.0]), [0.0, 0.0, -1.0]));
        // Straight up: 180° about +X.
        let l = lamp([0.0, 1.0, 0.0], 0.0);
        assert!(close(l.to_photometric([0.0, 1.0, 0.0]), [0.0, 0.0, -1.0]));
        assert!(close(l.to_photometric([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
        assert!(close(l.to_photometric([0.0, 0.0, 1.0]), [0.0, 1.0, 0.0]));
        // Aimed along −Z: C0 stays +X.
        let l = lamp([0.0, 0.0, -1.0], 0.0);
        assert!(close(l.to_photometric([0.0, 0.0, -1.0]), [0.0, 0.0, -1.0]));
        assert!(close(l.to_photometric([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]));
        // Degenerate aims fall back to the default frame.
        for aim in [[0.0; 3], [f32::NAN, 0.0, 0.0]] {
            let l = lamp(aim, 0.0);
            assert!(close(l.to_photometric([0.0, -1.0, 0.0]), [0.0, 0.0, -1.0]));
        }
    }

    #[test]
    fn frames_are_rotations_for_any_aim() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) as f32 * 2.0 - 1.0
        };
        for _ in 0..500 {
            let aim = [next(), next(), next()];
            let l = lamp(aim, next() * 360.0);
            let m = l.frame_f64().map(DVec3::from);
            for r in 0..3 {
                for c in 0..3 {
                    let d = m[r].dot(m[c]);
                    let want = if r == c { 1.0 } else { 0.0 };
                    assert!((d - want).abs() < 1e-9, "aim {aim:?}: rows {r} {c}: {d}");
                }
            }
            assert!(
                (m[0].cross(m[1]).dot(m[2]) - 1.0).abs() < 1e-9,
                "right-handed"
            );
            let a = normalize_f64(Vec3::from(aim).as_dvec3()).unwrap_or(DVec3::NEG_Y);
            let p = l.to_photometric(a.as_vec3().to_array());
            assert!(
                close(p, [0.0, 0.0, -1.0]),
                "aim {aim:?} is the nadir: {p:?}"
            );
        }
    }

    #[test]
    fn settings_defaults_and_names() {
        let s = Settings::paper();
        assert_eq!((s.rays, s.bounces, s.seed), (4, 3, 0));
        assert_eq!((s.method, s.blur), (Method::Paper, Blur::Sigma(2.0)));
        assert_eq!(s.texels_per_metre, 64.0);
        assert_eq!((s.bvh, s.sampler), (BvhMode::Wide, Sampler::Hash));
        assert_eq!(Settings::default(), Settings::preset(Quality::Default));
        assert_eq!(Settings::default().sampler, Sampler::Sobol);
        for q in [Quality::Draft, Quality::Default, Quality::Final] {
            let p = Settings::preset(q);
            assert_eq!((p.method, p.quality), (Method::Converged, q));
            assert!(p.validate().is_ok(), "{q:?}");
            assert_eq!(q.name().parse::<Quality>(), Ok(q));
        }
        for m in [Method::Paper, Method::Converged] {
            assert_eq!(m.name().parse::<Method>(), Ok(m));
        }
        assert!("fast".parse::<Method>().is_err() && "best".parse::<Quality>().is_err());
        let bad = Settings {
            tail_tolerance: 0.0,
            ..Settings::default()
        };
        assert_eq!(bad.validate().map_err(|e| e.name), Err("tail_tolerance"));
        assert_eq!("none".parse::<Blur>(), Ok(Blur::None));
        assert_eq!("1.5".parse::<Blur>(), Ok(Blur::Sigma(1.5)));
        assert!("-1".parse::<Blur>().is_err() && "x".parse::<Blur>().is_err());
        assert!("inf".parse::<Blur>().is_err());
        for b in [BvhMode::Wide, BvhMode::Mtbvh, BvhMode::Tbvh, BvhMode::None] {
            assert_eq!(b.name().parse::<BvhMode>(), Ok(b));
            assert_ne!(b.encoded(), BvhMode::Wide);
        }
        assert!("bvh".parse::<BvhMode>().is_err());
    }

    #[test]
    fn a_patch_starts_from_its_preset() {
        let patch = |toml: &str| toml::from_str::<SettingsPatch>(toml).expect(toml);
        assert_eq!(SettingsPatch::default().settings(), Ok(Settings::default()));
        let draft = patch("quality = \"draft\"").settings();
        assert_eq!(draft, Ok(Settings::preset(Quality::Draft)));
        assert_eq!(
            patch("method = \"paper\"").settings(),
            Ok(Settings::paper())
        );
        let s = patch("method = \"paper\"\nquality = \"final\"\nrays = 9").settings();
        assert_eq!(
            s,
            Ok(Settings {
                rays: 9,
                ..Settings::paper()
            })
        );
        let s = patch("rays = 2\nblur = \"none\"\nbvh = \"tbvh\"\nsampler = \"hash\"").settings();
        let want = Settings {
            rays: 2,
            blur: Blur::None,
            bvh: BvhMode::Tbvh,
            sampler: Sampler::Hash,
            ..Settings::default()
        };
        assert_eq!(s, Ok(want));
        // Blur: a sigma, "none" or 0 (none); integers where floats are expected.
        let blur = |t: &str| patch(t).blur;
        assert_eq!(blur("blur = 3"), Some(Blur::Sigma(3.0)));
        assert_eq!(blur("blur = 0"), Some(Blur::None));
        assert_eq!(blur("blur = \"None\""), Some(Blur::None));
        assert_eq!(patch("texels_per_metre = 12").texels_per_metre, Some(12.0));
        // Validation names the key; the whole table's keys are the fields.
        let e = patch("rays = 0").settings().expect_err("rays 0");
        assert_eq!(e.name, "rays");
        let names: Vec<String> = SettingsPatch::KEYS
            .iter()
            .map(|k| format!("`{k}`"))
            .collect();
        let unknown = toml::from_str::<SettingsPatch>("raus = 1").expect_err("raus");
        for name in names {
            assert!(unknown.to_string().contains(&name), "{name}: {unknown}");
        }
    }

    #[test]
    fn bounces_without_tail_are_exact() {
        let patch = |toml: &str| toml::from_str::<SettingsPatch>(toml).expect(toml);
        let tail = |toml: &str| {
            let s = patch(toml).settings().expect(toml);
            (s.bounces, s.tail)
        };
        assert_eq!(tail(""), (Settings::CONVERGED_MAX_BOUNCES, true));
        assert_eq!(tail("quality = \"draft\""), (3, true));
        assert_eq!(tail("bounces = 2"), (2, false));
        assert_eq!(tail("bounces = 2\ntail = true"), (2, true));
        assert_eq!(tail("tail = false"), (32, false));
        assert_eq!(tail("method = \"paper\""), (3, false));
        // Layered: the later `bounces` turns the earlier tail off; a later `tail` keeps the
        // earlier count.
        let layered = |a: &str, b: &str| {
            let s = patch(a).then(&patch(b)).settings().expect(b);
            (s.bounces, s.tail)
        };
        assert_eq!(
            layered("bounces = 8\ntail = true", "bounces = 2"),
            (2, false)
        );
        assert_eq!(layered("bounces = 8", "tail = true"), (8, true));
        assert_eq!(layered("bounces = 8", "rays = 3"), (8, false));
    }

    #[test]
    fn layering_is_applying_in_order() {
        let patch = |toml: &str| toml::from_str::<SettingsPatch>(toml).expect(toml);
        let files = [
            "",
            "rays = 256\ntexels_per_metre = 32\nseed = 4",
            "method = \"paper\"\nbvh = \"none\"",
            "quality = \"final\"\nbounces = 5\nstride = 2",
            "quality = \"draft\"\ntail = false\nblur = 3.0",
        ];
        let flags = [
            "",
            "quality = \"draft\"",
            "method = \"converged\"\nrays = 8",
            "method = \"paper\"\nbounces = 1",
            "texels_per_metre = 12\ntail = true",
            "bounces = 2\nlamp_paths = 0",
        ];
        for file in files {
            for flag in flags {
                let (a, b) = (patch(file), patch(flag));
                let mut applied = a.settings().expect(file);
                b.apply(&mut applied);
                assert_eq!(a.then(&b).settings(), Ok(applied), "{file:?} then {flag:?}");
            }
        }
        // A preset named later replaces the earlier preset's values but keeps the density,
        // traversal and seed; `quality` alone means the converged method.
        let s = patch("method = \"paper\"\nrays = 256\ntexels_per_metre = 32\nseed = 4")
            .then(&patch("quality = \"draft\""))
            .settings()
            .expect("draft");
        let want = Settings {
            texels_per_metre: 32.0,
            seed: 4,
            ..Settings::preset(Quality::Draft)
        };
        assert_eq!(s, want);
    }

    #[test]
    fn entries_name_the_key_of_a_bad_value() {
        let entries = |toml: &str| -> Vec<(String, toml::Value)> {
            toml::from_str::<toml::Table>(toml)
                .expect(toml)
                .into_iter()
                .collect()
        };
        let p = SettingsPatch::from_entries(&entries("rays = 3\ntail = true")).expect("good");
        assert_eq!((p.rays, p.tail), (Some(3), Some(true)));
        for (toml, key, message) in [
            ("rays = 3\nbvh = \"kd\"", "bvh", "got `kd`"),
            ("method = \"fast\"", "method", "got `fast`"),
            ("quality = \"best\"\nrays = 1", "quality", "got `best`"),
            ("sampler = 3", "sampler", "string"),
            ("blur = \"soft\"", "blur", "`soft`"),
            ("blur = true", "blur", "\"none\" or a sigma"),
            ("seed = -3", "seed", "-3"),
            ("rays = 1\nraus = 3", "raus", "unknown field"),
            ("tail = 1", "tail", "bool"),
        ] {
            let e = SettingsPatch::from_entries(&entries(toml)).expect_err(toml);
            assert_eq!(e.key, key, "{toml}: {e}");
            assert!(e.message.contains(message), "{toml}: {e}");
        }
        let json = |text: &str| -> Vec<(String, serde_json::Value)> {
            let v: serde_json::Map<String, serde_json::Value> =
                serde_json::from_str(text).expect(text);
            v.into_iter().collect()
        };
        let p = SettingsPatch::from_entries(&json(r#"{"blur":0,"bounces":1}"#)).expect("json");
        assert_eq!((p.blur, p.bounces), (Some(Blur::None), Some(1)));
        let e = SettingsPatch::from_entries(&json(r#"{"rays":"many"}"#)).expect_err("json");
        assert_eq!(e.key, "rays");
    }

    #[test]
    fn validate_names_the_setting_out_of_range() {
        let with = |edit: &dyn Fn(&mut Settings)| {
            let mut s = Settings::default();
            edit(&mut s);
            s.validate().map_err(|e| e.name)
        };
        assert_eq!(with(&|_| {}), Ok(()));
        assert_eq!(with(&|s| s.blur = Blur::None), Ok(()));
        let at_the_limits = |s: &mut Settings| {
            s.rays = Settings::MAX_RAYS;
            s.bounces = Settings::MAX_BOUNCES;
            s.blur = Blur::Sigma(Settings::MAX_BLUR_SIGMA);
            s.texels_per_metre = 1e30;
        };
        assert_eq!(with(&at_the_limits), Ok(()));
        assert_eq!(with(&|s| s.rays = 0), Err("rays"));
        assert_eq!(with(&|s| s.rays = Settings::MAX_RAYS + 1), Err("rays"));
        for stride in [0, 1, MAX_OPENING_SAMPLES] {
            assert_eq!(
                with(&|s| s.opening_probe_stride = stride),
                Ok(()),
                "{stride}"
            );
        }
        assert_eq!(
            with(&|s| s.opening_probe_stride = MAX_OPENING_SAMPLES + 1),
            Err("opening_probe_stride")
        );
        assert_eq!(
            with(&|s| s.bounces = Settings::MAX_BOUNCES + 1),
            Err("bounces")
        );
        for sigma in [0.0, -1.0, 64.5, f32::NAN, f32::INFINITY] {
            assert_eq!(
                with(&|s| s.blur = Blur::Sigma(sigma)),
                Err("blur"),
                "{sigma}"
            );
        }
        for d in [0.0, -1.0, -1e-30, f32::NAN, f32::INFINITY] {
            assert_eq!(
                with(&|s| s.texels_per_metre = d),
                Err("texels_per_metre"),
                "{d}"
            );
        }
        let message = Settings {
            rays: 0,
            ..Settings::default()
        }
        .validate()
        .expect_err("rays 0")
        .to_string();
        assert_eq!(message, "invalid setting `rays`: 0; expected 1..=65536");
    }

    #[test]
    fn mesh_validation_names_the_problem() {
        let good = Mesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            normals: vec![[0.0, 1.0, 0.0]; 3],
            lightmap_uvs: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
            indices: vec![[0, 1, 2]],
            ..Mesh::default()
        };
        assert_eq!(good.validate(), Ok(()));
        let mut m = good.clone();
        m.indices.push([0, 1, 3]);
        assert!(m.validate().unwrap_err().contains("triangle 1"));
        let mut m = good.clone();
        m.normals.pop();
        assert!(m.validate().unwrap_err().contains("normals"));
        let mut m = good.clone();
        m.positions[1][2] = f32::NAN;
        assert!(m.validate().unwrap_err().contains("position 1"));
        let mut m = good.clone();
        m.colors = Some(vec![[1.0; 3]]);
        assert!(m.validate().unwrap_err().contains("colours"));
    }

    #[test]
    fn albedo_texture_samples_bilinearly_with_repeat() {
        let t = AlbedoTexture {
            width: 2,
            height: 1,
            texels: vec![[0.0; 3], [1.0; 3]],
        };
        assert_eq!(t.sample([0.25, 0.5]), [0.0; 3]);
        assert_eq!(t.sample([0.75, 0.5]), [1.0; 3]);
        assert_eq!(t.sample([0.5, 0.5]), [0.5; 3]);
        assert_eq!(t.sample([1.0, 0.5]), [0.5; 3], "wraps");
        assert_eq!(t.sample([f32::NAN, 0.0]), [1.0; 3]);
        let bad = AlbedoTexture {
            width: 3,
            height: 3,
            texels: vec![],
        };
        assert_eq!(bad.sample([0.5, 0.5]), [1.0; 3]);
    }

    #[test]
    fn world_triangles_carry_world_data() {
        let s = Scene::builtin("chairs_03").expect("builtin");
        let (tris, attrs) = s.world_triangles();
        assert_eq!(tris.len(), 12 + 3 * 240);
        assert_eq!(attrs.len(), tris.len());
        assert!(attrs[..12].iter().all(|a| a.object == 0));
        assert!(attrs[12..252].iter().all(|a| a.object == 1));
        assert!(attrs[732 - 1].object == 3);
        for (t, a) in tris.iter().zip(&attrs) {
            assert!(t.iter().flatten().all(|c| c.is_finite()));
            for n in a.normals {
                let l = n.iter().map(|c| c * c).sum::<f32>().sqrt();
                assert!((l - 1.0).abs() < 1e-5);
            }
            assert!(a.uvs.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
        }
        // The chairs are moved by their transforms: the first chair triangle matches.
        let chair = &s.objects[1];
        let i = chair.mesh.indices[0][0] as usize;
        assert_eq!(tris[12][0], chair.transform.point(chair.mesh.positions[i]));
        assert!(s.validate().is_ok());
        let mut dup = s.clone();
        dup.objects[2].name = "chair_01".into();
        assert!(matches!(dup.validate(), Err(SceneError::DuplicateName(n)) if n == "chair_01"));
    }
}
