//! The wgpu device: adapter selection, error capture (error scopes, the device-lost callback,
//! the uncaptured-error handler) and blocking on wgpu's futures.
//!
//! Every wgpu call that can fail runs inside [`Gpu::scoped`], which pushes out-of-memory,
//! validation and internal error scopes and turns what they catch into a [`WgpuError`]; the
//! device-lost callback and the uncaptured-error handler only record what happened, so nothing
//! in wgpu's default handlers (which panic) is ever reached.

use std::future::Future;
use std::pin::pin;
use std::sync::{Arc, Mutex, MutexGuard};
use std::task::{Context, Poll, Waker};

use crate::error::{Result, WgpuError};

/// Drives a future to completion on this thread. On native wgpu every future this crate awaits
/// (adapter and device requests, error-scope pops) is already resolved when returned; the loop
/// only yields in case one is not.
pub(crate) fn block_on<F: Future>(future: F) -> F::Output {
    let mut future = pin!(future);
    let mut cx = Context::from_waker(Waker::noop());
    loop {
        if let Poll::Ready(v) = future.as_mut().poll(&mut cx) {
            return v;
        }
        std::thread::yield_now();
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A device, its queue and what its callbacks recorded.
#[derive(Debug)]
pub(crate) struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) info: wgpu::AdapterInfo,
    pub(crate) limits: wgpu::Limits,
    lost: Arc<Mutex<Option<String>>>,
    uncaptured: Arc<Mutex<Option<WgpuError>>>,
}

impl Gpu {
    /// Opens the first adapter of `backends` (high-performance preference), with every limit
    /// the adapter supports.
    pub(crate) fn open(backends: wgpu::Backends) -> Result<Gpu> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends = backends;
        let instance = wgpu::Instance::new(desc);
        let adapter = block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| WgpuError::NoAdapter {
            reason: format!("{e} (backends {backends:?})"),
        })?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("luxbake"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| WgpuError::RequestDevice {
            adapter: info.name.clone(),
            reason: e.to_string(),
        })?;
        let lost = Arc::new(Mutex::new(None));
        let slot = Arc::clone(&lost);
        device.set_device_lost_callback(move |reason, message| {
            let mut g = lock(&slot);
            if g.is_none() {
                *g = Some(format!("{reason:?}: {message}"));
            }
        });
        let uncaptured = Arc::new(Mutex::new(None));
        let slot = Arc::clone(&uncaptured);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut g = lock(&slot);
            if g.is_none() {
                *g = Some(WgpuError::from_wgpu(
                    "an operation outside any error scope",
                    &e,
                ));
            }
        }));
        Ok(Gpu {
            device,
            queue,
            info,
            limits,
            lost,
            uncaptured,
        })
    }

    /// The device-lost or uncaptured error recorded so far, if any.
    pub(crate) fn check(&self, during: &str) -> Result<()> {
        if let Some(reason) = lock(&self.lost).clone() {
            return Err(WgpuError::DeviceLost {
                during: during.to_owned(),
                reason,
            });
        }
        match lock(&self.uncaptured).take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// Runs `f` inside out-of-memory, validation and internal error scopes; the first error
    /// caught (or a lost device) is returned instead of `f`'s value.
    pub(crate) fn scoped<T>(&self, during: &str, f: impl FnOnce() -> T) -> Result<T> {
        self.check(during)?;
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let value = f();
        // Scopes pop in reverse order of pushing.
        let errors = [
            block_on(internal.pop()),
            block_on(validation.pop()),
            block_on(oom.pop()),
        ];
        if let Some(e) = errors.into_iter().flatten().next() {
            return Err(WgpuError::from_wgpu(during, &e));
        }
        self.check(during)?;
        Ok(value)
    }

    /// Waits until the queue is idle.
    pub(crate) fn wait(&self, during: &str) -> Result<()> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| WgpuError::Wait {
                during: during.to_owned(),
                reason: e.to_string(),
            })?;
        self.check(during)
    }
}
