//! Offscreen wgpu rendering of the robot's view (headless; Mesa lavapipe or any Vulkan/Metal/DX12 GPU).

mod gpu;
mod mesh;
mod renderer;

pub use gpu::{ADAPTER_ENV, GpuContext, LLVMPIPE_THREADS_ENV, llvmpipe_threads};
pub use renderer::{
    FrameDesc, MAX_BATCH, PastView, PendingViews, RenderInstance, RenderTimings, Renderer, SensorFrame, frame_to_u8,
    padded_bytes_per_row,
};
