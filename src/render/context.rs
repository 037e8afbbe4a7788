//! The headless GPU context: the wgpu instance, adapter, device and queue.

use std::sync::{Arc, Mutex};

use super::RenderError;
use super::shared::SharedPipelines;

/// Turn off Mesa's Vulkan device-select layer for a process that opens no window.
///
/// wgpu enables every window-system extension the driver offers
/// (`VK_KHR_wayland_surface` included) on every instance, headless or not. When
/// that extension is enabled, Mesa's implicit `VK_LAYER_MESA_device_select`
/// calls `wl_display_connect` while the physical devices are enumerated to find
/// the GPU a Wayland compositor runs on; without `XDG_RUNTIME_DIR` libwayland
/// prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.`
/// (once per enumeration) even though nothing failed. A headless process has no
/// compositor to match, so the layer has nothing to choose: its documented
/// switch `NODEVICE_SELECT=1` (the `disable_environment` of its loader manifest)
/// skips it. A value the user set is kept, and so is the layer when the user asks
/// it for a device (`MESA_VK_DEVICE_SELECT`, `DRI_PRIME`).
///
/// # Safety
/// Changes the process environment: call it before any other thread exists
/// (first thing in `main`), as [`std::env::set_var`] requires.
#[allow(unsafe_code)]
pub unsafe fn quiet_headless_vulkan() {
    let wants_layer = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|name| std::env::var_os(name).is_some());
    if !wants_layer {
        // SAFETY: the caller guarantees no other thread reads or writes the environment.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

/// A device and queue, from a headless adapter or handed in by a host (eframe).
#[derive(Clone)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter_info: wgpu::AdapterInfo,
    pub max_texture_side: u32,
    /// Pipelines the device's renderers share (the batch's makers each
    /// have one): each is compiled once per device.
    pub shared: SharedPipelines,
    /// Frame targets made before any renderer ([`GpuContext::prepare_frame_targets`]).
    pub prepared: PreparedTargets,
}

/// Frame targets made ahead, for the first renderer that draws frames of
/// their size and sample count. At most one set is held: a renderer that
/// makes targets of another shape releases it.
#[derive(Clone, Default)]
pub struct PreparedTargets(Arc<Mutex<Option<super::targets::FrameTargets>>>);

impl PreparedTargets {
    /// The targets of `size` and `msaa` samples, if held; any others are released.
    pub(super) fn take(&self, size: (u32, u32), msaa: u32) -> Option<super::targets::FrameTargets> {
        let mut held = self
            .0
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        held.take()
            .filter(|t| (t.width, t.height, t.msaa) == (size.0, size.1, msaa))
    }

    /// Whether a set of targets is held (for tests).
    #[cfg(test)]
    pub(super) fn is_held(&self) -> bool {
        self.0.lock().is_ok_and(|held| held.is_some())
    }
}

impl GpuContext {
    /// Open a headless adapter; honours `WGPU_BACKEND` (vulkan, gl, …). Fails
    /// loudly when none is found — callers never fall back to "no rendering".
    pub fn headless() -> Result<Self, RenderError> {
        let from_env = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        // With no backend named, Vulkan alone is asked first: an instance of
        // every backend also loads and probes EGL and the GL driver (a tenth of
        // a cached start-up on lavapipe) only for the adapter choice to settle
        // on Vulkan. Every backend is asked only when Vulkan offers no adapter,
        // so machines without a Vulkan driver still find theirs.
        let vulkan_first = std::env::var_os("WGPU_BACKEND").is_none()
            && from_env.backends.contains(wgpu::Backends::VULKAN);
        let vulkan = vulkan_first.then(|| wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
        });
        let adapter = match vulkan.map(request_adapter) {
            Some(Ok(adapter)) => Ok(adapter),
            Some(Err(_)) | None => request_adapter(from_env),
        }
        .map_err(|e| RenderError::NoAdapter {
            backend: std::env::var("WGPU_BACKEND").unwrap_or_else(|_| "(default)".into()),
            reason: e,
        })?;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("swarmshot device"),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(RenderError::Device)?;
        Ok(Self {
            device,
            queue,
            adapter_info: adapter.get_info(),
            max_texture_side: limits.max_texture_dimension_2d,
            shared: SharedPipelines::default(),
            prepared: PreparedTargets::default(),
        })
    }

    /// Make the targets frames of `size` pixels and `msaa` samples draw
    /// into and submit their first use, before any renderer exists (see
    /// [`super::Renderer::prepare_targets`]): a command that starts its
    /// context beside the preset's loading has the device zero them
    /// meanwhile, and its first renderer takes them. A size the device
    /// cannot draw is left alone (the preset's checks report it). The
    /// caller has checked that the frame fits in memory.
    pub fn prepare_frame_targets(&self, (width, height): (u32, u32), msaa: u32) {
        let side = 1..=self.max_texture_side;
        if !side.contains(&width) || !side.contains(&height) || !matches!(msaa, 1 | 4) {
            return;
        }
        let targets =
            super::frame::first_used_targets((&self.device, &self.queue), (width, height), msaa);
        let mut held = (self.prepared.0.lock()).unwrap_or_else(|poisoned| poisoned.into_inner());
        *held = Some(targets);
    }

    /// "lavapipe (Vulkan)" and the like, for logs and reports.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?})",
            self.adapter_info.name, self.adapter_info.backend
        )
    }
}

/// The high-performance adapter of an instance made from `descriptor`.
fn request_adapter(
    descriptor: wgpu::InstanceDescriptor,
) -> Result<wgpu::Adapter, wgpu::RequestAdapterError> {
    let instance = wgpu::Instance::new(descriptor);
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
}
