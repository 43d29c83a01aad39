//! The GPU device shared by renderers: created once, reused for any number of worlds and sizes.

use std::sync::Arc;

use crate::SimError;

/// Environment variable selecting an adapter by (case-insensitive) name substring, e.g.
/// `LOOMLAB_ADAPTER=llvmpipe` to force Mesa lavapipe on a machine with a GPU.
pub const ADAPTER_ENV: &str = "LOOMLAB_ADAPTER";

/// A wgpu device and queue plus what adapter they run on.
///
/// Creating a device costs tens of milliseconds (more on lavapipe); create one `GpuContext` per process
/// and share it (`Arc`) between renderers and episodes.
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter the device was created on.
    pub adapter_info: wgpu::AdapterInfo,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter_info.name)
            .finish()
    }
}

impl GpuContext {
    /// Finds an adapter (honouring `WGPU_BACKEND` and [`ADAPTER_ENV`]) and creates a device on it.
    ///
    /// Works headless: no window or display is needed. With no GPU, Mesa's lavapipe (a CPU Vulkan driver)
    /// is used when installed; without any adapter the error names the fix.
    pub fn new() -> Result<Arc<GpuContext>, SimError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
        desc.flags = wgpu::InstanceFlags::empty();
        let desc = desc.with_env();
        let backends = desc.backends;
        let instance = wgpu::Instance::new(desc);
        let wanted = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
        let adapter = match &wanted {
            Some(name) => {
                let all = pollster::block_on(instance.enumerate_adapters(backends));
                let names: Vec<String> = all.iter().map(|a| a.get_info().name).collect();
                let found = all
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&name.to_lowercase()));
                found.ok_or_else(|| SimError::NoAdapter {
                    detail: format!(
                        "{ADAPTER_ENV}={name} matches none of the adapters {names:?} on backends {backends:?}"
                    ),
                })?
            }
            None => pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter: false,
                compatible_surface: None,
                apply_limit_buckets: false,
            }))
            .map_err(|e| SimError::NoAdapter {
                detail: format!("backends {backends:?}: {e}"),
            })?,
        };
        let adapter_info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("loomlab-sim"),
            required_features: wgpu::Features::empty(),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| SimError::Device {
            adapter: adapter_info.name.clone(),
            reason: e.to_string(),
        })?;
        Ok(Arc::new(GpuContext {
            device,
            queue,
            adapter_info,
        }))
    }

    /// Whether the adapter renders on the CPU (a software rasterizer such as Mesa's lavapipe).
    pub fn renders_on_cpu(&self) -> bool {
        self.adapter_info.device_type == wgpu::DeviceType::Cpu
    }

    /// A one-line description of the adapter (name, backend, driver).
    pub fn describe(&self) -> String {
        let i = &self.adapter_info;
        format!(
            "{} ({:?}, {:?}, {} {})",
            i.name, i.backend, i.device_type, i.driver, i.driver_info
        )
    }
}
