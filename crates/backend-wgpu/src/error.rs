//! The backend's error type: every failure of the GPU, the driver or the caller is a value,
//! never a panic.

/// Everything that can go wrong in the wgpu backend.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WgpuError {
    /// No adapter: no Vulkan driver (or none of the backends `WGPU_BACKEND` selects).
    #[error(
        "no wgpu adapter ({reason}); on Linux install Mesa's lavapipe Vulkan driver \
         (`apt-get install mesa-vulkan-drivers`) or a GPU driver, and check `WGPU_BACKEND`"
    )]
    NoAdapter {
        /// What wgpu reported.
        reason: String,
    },
    /// The adapter refused to create a device.
    #[error("wgpu adapter `{adapter}` could not create a device: {reason}")]
    RequestDevice {
        /// Adapter name.
        adapter: String,
        /// What wgpu reported.
        reason: String,
    },
    /// The device was lost (driver reset, GPU removed or hung, watchdog); the backend is
    /// unusable afterwards.
    #[error("the GPU device was lost during `{during}`: {reason}")]
    DeviceLost {
        /// The operation that noticed.
        during: String,
        /// What the driver reported.
        reason: String,
    },
    /// The GPU ran out of memory.
    #[error("out of GPU memory during `{during}`: {reason}")]
    OutOfMemory {
        /// The operation that failed.
        during: String,
        /// What wgpu reported.
        reason: String,
    },
    /// wgpu rejected an operation (a bug in this backend, or a limit the adapter lacks).
    #[error("wgpu validation error during `{during}`: {reason}")]
    Validation {
        /// The operation that failed.
        during: String,
        /// wgpu's message.
        reason: String,
    },
    /// An internal error of wgpu or the driver (e.g. a shader the driver cannot compile).
    #[error("wgpu internal error during `{during}`: {reason}")]
    Internal {
        /// The operation that failed.
        during: String,
        /// wgpu's message.
        reason: String,
    },
    /// Waiting for the GPU failed or timed out.
    #[error("waiting for the GPU during `{during}` failed: {reason}")]
    Wait {
        /// The operation that waited.
        during: String,
        /// wgpu's message.
        reason: String,
    },
    /// A request beyond what the adapter supports.
    #[error("{what}: {requested} exceeds the adapter's limit of {allowed}")]
    Limit {
        /// What was requested.
        what: &'static str,
        /// The requested amount.
        requested: u64,
        /// The adapter's limit.
        allowed: u64,
    },
    /// Misuse of the `GpuBackend` contract (unknown handle, wrong sizes or bindings).
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

/// `Result` with [`WgpuError`].
pub type Result<T, E = WgpuError> = std::result::Result<T, E>;

impl WgpuError {
    /// Whether the machine has no wgpu adapter to run on ([`WgpuError::NoAdapter`]): a test
    /// that needs one skips or fails by the workspace's rule (`luxbake_testkit::or_skip`). Every other error, opening
    /// included, is a failure of a driver that is there.
    pub fn is_driver_missing(&self) -> bool {
        matches!(self, WgpuError::NoAdapter { .. })
    }

    /// Classifies a wgpu error caught by an error scope or the uncaptured-error handler.
    pub(crate) fn from_wgpu(during: &str, e: &wgpu::Error) -> WgpuError {
        let during = during.to_owned();
        match e {
            wgpu::Error::OutOfMemory { source } => WgpuError::OutOfMemory {
                during,
                reason: source.to_string(),
            },
            wgpu::Error::Validation { description, .. } => WgpuError::Validation {
                during,
                reason: description.clone(),
            },
            wgpu::Error::Internal { description, .. } => WgpuError::Internal {
                during,
                reason: description.clone(),
            },
        }
    }
}
