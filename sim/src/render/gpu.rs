//! The GPU device shared by renderers: created once, reused for any number of worlds and sizes.

use std::sync::Arc;

use crate::SimError;

/// Environment variable selecting an adapter by (case-insensitive) name substring, e.g.
/// `LOOMLAB_ADAPTER=llvmpipe` to force Mesa lavapipe on a machine with a GPU.
pub const ADAPTER_ENV: &str = "LOOMLAB_ADAPTER";

/// Mesa's llvmpipe (lavapipe, the software Vulkan of a machine without a GPU) setting for its
/// rasterizer threads; other drivers ignore it.
pub const LLVMPIPE_THREADS_ENV: &str = "LP_NUM_THREADS";

/// Most CPUs on which a process that keeps every CPU busy has llvmpipe rasterise on its queue
/// thread (see [`llvmpipe_threads`]): rendering is about a sixth of a suite run's CPU time, so one
/// queue thread keeps up with the workers of a few CPUs, not with those of many.
const MAX_CPUS_FOR_QUEUE_RASTERIZER: usize = 4;

/// The [`LLVMPIPE_THREADS_ENV`] value for a process on `cpus` CPUs that runs `several_threads`
/// (workers, a vector environment's parallel members, or batched steps, whose physics runs while
/// lavapipe's queue thread renders: [`crate::Sim::step_batch`]) when the user has not set it
/// (`user_set`); `None`: leave it alone. Read before the first [`GpuContext`] is created: `loomlab
/// run` sets it in `main`, the Python package when it is imported.
///
/// On llvmpipe every render pass otherwise hands its tiles to llvmpipe's own rasterizer threads,
/// one per CPU, while the process already keeps every CPU busy: the hand-offs and wake-ups cost
/// more than they save (default suite, 2 workers on 2 CPUs: 155 → 132 s wall, 244 → 216 s CPU;
/// the Python vector env, N = 16 at 64²: +5–22 % steps/s; the same pixels). `"0"` has llvmpipe
/// rasterise on its queue thread.
pub fn llvmpipe_threads(cpus: usize, several_threads: bool, user_set: bool) -> Option<&'static str> {
    (!user_set && several_threads && cpus <= MAX_CPUS_FOR_QUEUE_RASTERIZER).then_some("0")
}

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

#[cfg(test)]
mod tests {
    use super::llvmpipe_threads;

    #[test]
    fn llvmpipe_rasterises_on_its_queue_thread_on_a_few_busy_cpus_unless_the_user_chose() {
        assert_eq!(llvmpipe_threads(2, true, false), Some("0"));
        assert_eq!(llvmpipe_threads(4, true, false), Some("0"));
        // one thread: llvmpipe's threads use the CPUs the process leaves idle
        assert_eq!(llvmpipe_threads(2, false, false), None);
        // many CPUs: one queue thread would not keep up with their workers' renders
        assert_eq!(llvmpipe_threads(16, true, false), None);
        assert_eq!(llvmpipe_threads(2, true, true), None);
    }
}
