//! Renderers and workers: the renderer pool episodes share, and how many workers a runner uses.

use std::sync::{Arc, Mutex};

use loomlab_sim::{GpuContext, Renderer, SimError};

/// Renderers kept between episodes, one per frame size and worker at most.
#[derive(Default)]
pub(super) struct RendererPool(Mutex<Vec<Renderer>>);

impl RendererPool {
    pub(super) fn take(&self, ctx: &Arc<GpuContext>, n: u32) -> Result<Renderer, SimError> {
        let found = {
            let mut pool = self.0.lock().unwrap_or_else(|e| e.into_inner());
            pool.iter().position(|r| r.n() == n).map(|i| pool.swap_remove(i))
        };
        match found {
            Some(r) => Ok(r),
            None => Renderer::with_context(Arc::clone(ctx), n),
        }
    }

    pub(super) fn give_back(&self, r: Renderer) {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).push(r);
    }
}

/// The number of CPUs the process may use.
pub fn cpus() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// The most workers a runner uses, and its default: one per CPU, two per CPU when the frames are
/// rendered on the CPU (`renders_on_cpu`, lavapipe). A worker that waits for its frames to be
/// rendered then leaves its CPU to the other: the default suite on 2 CPUs took 132 s with 2
/// workers, 124–128 s with 3 and 123 s with 4, with the same report. With a GPU, each worker keeps
/// one CPU busy. `Runner::new(Some(jobs))` clamps to it.
pub fn max_jobs(cpus: usize, renders_on_cpu: bool) -> usize {
    cpus * if renders_on_cpu { 2 } else { 1 }
}
