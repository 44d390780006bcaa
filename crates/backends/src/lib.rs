//! # luxbake-backends: the backends at the edge of the program
//!
//! The bake ([`luxbake::bake()`]) is generic over [`GpuBackend`] and the core names no
//! backend. Choosing one at run time — a command-line flag, a scene file's
//! `settings.backend`, a test that loops over every backend — happens here:
//!
//! - [`BackendKind`]: `cpu`, `glow`, `wgpu` ([`BackendKind::ALL`], [`BackendKind::name`],
//!   [`FromStr`] as the CLI and scene files spell them);
//! - [`open`]: a backend by kind as an [`AnyBackend`], an enum that implements
//!   [`GpuBackend`] by delegating to the backend inside (each arm is a static call; the enum
//!   exists only at this edge). Its [`OpenError`] tells a machine without the driver
//!   ([`OpenError::DriverMissing`], which tests hand to the workspace's
//!   skip-or-fail rule, `luxbake_testkit::or_skip`) from a driver that fails;
//! - [`image_diff`]: light maps compared by relative RMSE and 99th-percentile relative error
//!   against a [`Tolerance`](image_diff::Tolerance), with expected / actual / difference PNGs
//!   for failures; used by the cross-backend tests (`luxbake-tests`) and the browser check
//!   (`cargo xtask web --check`).
//!
//! Native only: the glow backend opens a headless EGL context.
#![warn(missing_docs)]

use std::fmt;
use std::str::FromStr;

use luxbake::backend::{Dispatch, GpuBackend, Limits, SceneData};
use luxbake::cpu::CpuScene;
use luxbake::graph::TexDesc;
use luxbake_backend_cpu::{CpuBackend, CpuError, CpuTexture};
use luxbake_backend_glow::{GlowBackend, GlowError, GlowScene, GlowTexture};
use luxbake_backend_wgpu::{WgpuBackend, WgpuError, WgpuScene, WgpuTexture};

pub mod image_diff;

/// A backend, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BackendKind {
    /// The CPU reference backend in `luxbake`.
    Cpu,
    /// `luxbake-backend-glow`: OpenGL ES 3.0 through headless EGL (llvmpipe in CI).
    Glow,
    /// `luxbake-backend-wgpu`: WGSL compute on Vulkan (lavapipe in CI).
    Wgpu,
}

impl BackendKind {
    /// Every backend.
    pub const ALL: [BackendKind; 3] = [BackendKind::Cpu, BackendKind::Glow, BackendKind::Wgpu];

    /// The lower-case name used by the CLI and scene files.
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Cpu => "cpu",
            BackendKind::Glow => "glow",
            BackendKind::Wgpu => "wgpu",
        }
    }
}

impl fmt::Display for BackendKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for BackendKind {
    type Err = String;
    /// `cpu`, `glow` or `wgpu` (case-insensitive, surrounding spaces ignored): the names of
    /// `--backend` and of a scene file's `settings.backend`
    /// ([`luxbake::sources::scenefile::preferred_backend`]).
    fn from_str(s: &str) -> Result<BackendKind, String> {
        let lower = s.trim().to_ascii_lowercase();
        BackendKind::ALL
            .into_iter()
            .find(|k| k.name() == lower)
            .ok_or_else(|| format!("expected \"cpu\", \"glow\" or \"wgpu\", got `{s}`"))
    }
}

/// A backend chosen at run time ([`open`]). It implements [`GpuBackend`] by handing every call
/// to the backend inside; the handles it gives out ([`AnyTexture`], [`AnyScene`]) remember
/// their backend, and a handle of another backend is an [`AnyError::ForeignHandle`].
#[derive(Debug)]
pub enum AnyBackend {
    /// The CPU reference backend.
    Cpu(CpuBackend),
    /// The glow backend.
    Glow(Box<GlowBackend>),
    /// The wgpu backend.
    Wgpu(Box<WgpuBackend>),
}

/// A texture of an [`AnyBackend`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnyTexture {
    /// Of the CPU backend.
    Cpu(CpuTexture),
    /// Of the glow backend.
    Glow(GlowTexture),
    /// Of the wgpu backend.
    Wgpu(WgpuTexture),
}

/// The uploaded scene of an [`AnyBackend`].
#[derive(Debug)]
#[allow(
    clippy::large_enum_variant,
    reason = "one per bake: boxing the CPU scene would save nothing"
)]
pub enum AnyScene {
    /// Of the CPU backend.
    Cpu(CpuScene),
    /// Of the glow backend.
    Glow(GlowScene),
    /// Of the wgpu backend.
    Wgpu(WgpuScene),
}

/// The error of an [`AnyBackend`]: the inner backend's, unchanged.
#[derive(Debug, thiserror::Error)]
pub enum AnyError {
    /// The CPU backend's.
    #[error(transparent)]
    Cpu(#[from] CpuError),
    /// The glow backend's.
    #[error(transparent)]
    Glow(#[from] GlowError),
    /// The wgpu backend's.
    #[error(transparent)]
    Wgpu(#[from] WgpuError),
    /// A texture or scene handle of one backend was given to another.
    #[error("a {what} of the {owner} backend was given to the {backend} backend")]
    ForeignHandle {
        /// `"texture"` or `"scene"`.
        what: &'static str,
        /// The backend that made the handle.
        owner: BackendKind,
        /// The backend it was given to.
        backend: BackendKind,
    },
}

impl AnyError {
    /// Whether the machine has no driver for the backend (see
    /// [`GlowError::is_driver_missing`] and [`WgpuError::is_driver_missing`]).
    pub fn is_driver_missing(&self) -> bool {
        match self {
            AnyError::Glow(e) => e.is_driver_missing(),
            AnyError::Wgpu(e) => e.is_driver_missing(),
            AnyError::Cpu(_) | AnyError::ForeignHandle { .. } => false,
        }
    }
}

/// Why [`open`] failed.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The machine has no driver for the backend (glow: no OpenGL ES 3.0 context; wgpu: no
    /// adapter). Tests skip or fail by the workspace's rule
    /// (`luxbake_testkit::or_skip`).
    #[error("{kind} backend: {source}")]
    DriverMissing {
        /// The backend.
        kind: BackendKind,
        /// The backend's error.
        source: AnyError,
    },
    /// The driver is there, but the backend could not start on it.
    #[error("{kind} backend: {source}")]
    Failed {
        /// The backend.
        kind: BackendKind,
        /// The backend's error.
        source: AnyError,
    },
}

impl OpenError {
    /// Whether this is [`OpenError::DriverMissing`].
    pub fn is_driver_missing(&self) -> bool {
        matches!(self, OpenError::DriverMissing { .. })
    }
}

/// Opens the backend `kind` with its defaults (glow: a headless EGL context; wgpu: the first
/// adapter `WGPU_BACKEND` selects).
///
/// # Errors
/// [`OpenError::DriverMissing`] without a driver, [`OpenError::Failed`] when the backend
/// cannot start on the driver it found. The CPU backend always opens.
pub fn open(kind: BackendKind) -> Result<AnyBackend, OpenError> {
    let opened = match kind {
        BackendKind::Cpu => Ok(AnyBackend::Cpu(CpuBackend::new())),
        BackendKind::Glow => GlowBackend::headless()
            .map(|b| AnyBackend::Glow(Box::new(b)))
            .map_err(AnyError::from),
        BackendKind::Wgpu => WgpuBackend::new()
            .map(|b| AnyBackend::Wgpu(Box::new(b)))
            .map_err(AnyError::from),
    };
    opened.map_err(|source| {
        if source.is_driver_missing() {
            OpenError::DriverMissing { kind, source }
        } else {
            OpenError::Failed { kind, source }
        }
    })
}

impl AnyBackend {
    /// Keeps the gather rays' hits from bake to bake, up to `budget` bytes: the CPU backend in
    /// host memory (`CpuBackend::keep_gather_hits`), glow in hit textures and wgpu in storage
    /// buffers (`luxbake::kept`). For a backend that bakes one room several times (`--lamp`
    /// repeated, a lamp swap).
    ///
    /// # Errors
    /// glow without a current context.
    pub fn keep_gather_hits(&mut self, budget: usize) -> Result<(), String> {
        match self {
            AnyBackend::Cpu(b) => b.keep_gather_hits(budget),
            AnyBackend::Glow(b) => b
                .keep_gather_hits(budget as u64)
                .map_err(|e| e.to_string())?,
            AnyBackend::Wgpu(b) => b.keep_gather_hits(budget as u64),
        }
        Ok(())
    }

    /// Bytes the backend keeps from bake to bake besides a bake's textures: the CPU
    /// backend's gather hits and chart tests (`CpuBackend::kept_bytes`), the GPU backends'
    /// kept hits.
    pub fn kept_bytes(&self) -> usize {
        match self {
            AnyBackend::Cpu(b) => b.kept_bytes(),
            AnyBackend::Glow(b) => b.gather_hit_stats().map_or(0, |s| s.bytes as usize),
            AnyBackend::Wgpu(b) => b.gather_hit_stats().map_or(0, |s| s.bytes as usize),
        }
    }

    /// The driver's description of the device: glow `GL_RENDERER (GL_VERSION)`, wgpu
    /// `adapter (API, driver)`; `None` for the CPU backend.
    pub fn device(&self) -> Option<String> {
        match self {
            AnyBackend::Cpu(_) => None,
            AnyBackend::Glow(b) => {
                let c = b.capabilities();
                Some(format!("{} ({})", c.renderer, c.version))
            }
            AnyBackend::Wgpu(b) => {
                let i = b.adapter_info();
                Some(format!("{} ({:?}, {})", i.name, i.backend, i.driver_info))
            }
        }
    }
}

/// Writes, once for the variants `$V` (named as in [`BackendKind`]), the `kind()` of each
/// `Any*` enum and the delegating [`GpuBackend`] implementation: every call goes to the
/// backend inside with the handles of its own variant.
macro_rules! delegate {
    ($($V:ident),*) => {
        impl AnyBackend {
            /// Which backend this is.
            pub fn kind(&self) -> BackendKind {
                match self { $(AnyBackend::$V(_) => BackendKind::$V,)* }
            }
        }

        impl AnyTexture {
            /// The backend that made this texture.
            pub fn kind(&self) -> BackendKind {
                match self { $(AnyTexture::$V(_) => BackendKind::$V,)* }
            }
        }

        impl AnyScene {
            /// The backend that uploaded this scene.
            pub fn kind(&self) -> BackendKind {
                match self { $(AnyScene::$V(_) => BackendKind::$V,)* }
            }
        }

        impl GpuBackend for AnyBackend {
            type Texture = AnyTexture;
            type Scene = AnyScene;
            type Error = AnyError;

            fn name(&self) -> &'static str {
                match self { $(AnyBackend::$V(b) => b.name(),)* }
            }

            fn limits(&self) -> Limits {
                match self { $(AnyBackend::$V(b) => b.limits(),)* }
            }

            fn create_texture(&mut self, desc: &TexDesc) -> Result<AnyTexture, AnyError> {
                match self {
                    $(AnyBackend::$V(b) => Ok(AnyTexture::$V(b.create_texture(desc)?)),)*
                }
            }

            fn upload(
                &mut self,
                texture: &AnyTexture,
                layer: u32,
                texels: &[f32],
            ) -> Result<(), AnyError> {
                match (self, texture) {
                    $((AnyBackend::$V(b), AnyTexture::$V(t)) => Ok(b.upload(t, layer, texels)?),)*
                    (b, t) => Err(foreign("texture", t.kind(), b.kind())),
                }
            }

            fn upload_scene(&mut self, scene: &SceneData<'_>) -> Result<AnyScene, AnyError> {
                match self {
                    $(AnyBackend::$V(b) => Ok(AnyScene::$V(b.upload_scene(scene)?)),)*
                }
            }

            fn tile_work(&self) -> u64 {
                match self { $(AnyBackend::$V(b) => b.tile_work(),)* }
            }

            fn dispatch(
                &mut self,
                call: &Dispatch<'_, AnyTexture, AnyScene>,
            ) -> Result<(), AnyError> {
                match (self, call.scene) {
                    $((AnyBackend::$V(b), AnyScene::$V(scene)) => {
                        let reads = call
                            .reads
                            .iter()
                            .map(|t| match *t {
                                AnyTexture::$V(t) => Ok(t),
                                t => Err(foreign("texture", t.kind(), BackendKind::$V)),
                            })
                            .collect::<Result<Vec<_>, AnyError>>()?;
                        let write = match call.write {
                            AnyTexture::$V(t) => t,
                            t => return Err(foreign("texture", t.kind(), BackendKind::$V)),
                        };
                        Ok(b.dispatch(&Dispatch {
                            label: call.label,
                            program: call.program,
                            bvh: call.bvh,
                            reads: &reads,
                            write,
                            scene,
                            params: call.params,
                            tile: call.tile,
                            idle: call.idle,
                            narrow: call.narrow,
                        })?)
                    })*
                    (b, s) => Err(foreign("scene", s.kind(), b.kind())),
                }
            }

            fn read_back(
                &mut self,
                texture: &AnyTexture,
                layer: u32,
            ) -> Result<Vec<f32>, AnyError> {
                match (self, texture) {
                    $((AnyBackend::$V(b), AnyTexture::$V(t)) => Ok(b.read_back(t, layer)?),)*
                    (b, t) => Err(foreign("texture", t.kind(), b.kind())),
                }
            }

            fn release(&mut self) -> Result<(), AnyError> {
                match self {
                    $(AnyBackend::$V(b) => Ok(b.release()?),)*
                }
            }
        }
    };
}

delegate!(Cpu, Glow, Wgpu);

fn foreign(what: &'static str, owner: BackendKind, backend: BackendKind) -> AnyError {
    AnyError::ForeignHandle {
        what,
        owner,
        backend,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use luxbake::graph::TexFormat;
    use luxbake::scene::{Scene, Settings};

    #[test]
    fn names_parse_back() {
        let names = BackendKind::ALL.map(BackendKind::name);
        assert_eq!(names, ["cpu", "glow", "wgpu"]);
        assert_eq!(" Glow ".parse::<BackendKind>(), Ok(BackendKind::Glow));
        for b in BackendKind::ALL {
            assert_eq!(b.name().to_uppercase().parse::<BackendKind>(), Ok(b));
            assert_eq!(b.to_string(), b.name());
        }
        assert_eq!(
            "vulkan".parse::<BackendKind>(),
            Err("expected \"cpu\", \"glow\" or \"wgpu\", got `vulkan`".to_owned())
        );
    }

    #[test]
    fn the_cpu_backend_opens_and_bakes_like_the_cpu_backend() {
        let mut any = open(BackendKind::Cpu).expect("cpu");
        assert_eq!(
            (any.kind(), any.name(), any.device()),
            (BackendKind::Cpu, "cpu", None)
        );
        let settings = Settings {
            rays: 4,
            bounces: 1,
            texels_per_metre: 8.0,
            ..Settings::default()
        };
        let scene = Scene::builtin_with_settings("floor", settings.clone()).expect("floor");
        let a = luxbake::bake(&mut any, &scene, &settings, &mut |_| {}).expect("any");
        let b = luxbake::bake(&mut CpuBackend::new(), &scene, &settings, &mut |_| {}).expect("cpu");
        assert_eq!(a.report.backend, "cpu");
        for (x, y) in a.maps.iter().zip(&b.maps) {
            assert_eq!(x.stages, y.stages, "{}", x.name);
        }
    }

    #[test]
    fn a_handle_of_another_backend_is_an_error() {
        let mut cpu = open(BackendKind::Cpu).expect("cpu");
        let desc = TexDesc {
            label: "t",
            size: [1, 1],
            layers: 1,
            format: TexFormat::Rgba32F,
        };
        let t = cpu.create_texture(&desc).expect("texture");
        assert_eq!(t.kind(), BackendKind::Cpu);
        assert!(cpu.read_back(&t, 0).is_ok());
        let Some(mut gpu) = BackendKind::ALL[1..].iter().find_map(|&k| open(k).ok()) else {
            luxbake_testkit::skip_or_fail(
                "a_handle_of_another_backend_is_an_error",
                &"no GPU backend opens",
            );
            return;
        };
        let e = gpu.read_back(&t, 0).expect_err("foreign texture");
        assert_eq!(
            e.to_string(),
            format!(
                "a texture of the cpu backend was given to the {} backend",
                gpu.kind()
            )
        );
    }

    #[test]
    fn a_missing_driver_is_told_apart() {
        let missing = OpenError::DriverMissing {
            kind: BackendKind::Wgpu,
            source: WgpuError::NoAdapter {
                reason: "none".into(),
            }
            .into(),
        };
        assert!(
            missing.is_driver_missing()
                && missing
                    .to_string()
                    .starts_with("wgpu backend: no wgpu adapter")
        );
        let failed = AnyError::from(WgpuError::InvalidInput("x".into()));
        assert!(!failed.is_driver_missing());
    }
}
