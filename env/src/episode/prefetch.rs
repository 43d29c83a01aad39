//! Preparing the next drawn episode ahead, on a thread of its own, while the current one runs.
//!
//! A reset's costly part is the open-loop pass (ground truth and, for a threat, the escape
//! deadline's physics-only replays and the views they latch the looming side from: tens of
//! milliseconds, most of the reset). It depends only on the episode drawn and its simulator seed,
//! and those only on the seed stream's state, which no action changes. So once an environment has
//! drawn an episode, it draws the **next** one from a copy of its stream and computes that
//! episode's open-loop truth and deadline on a background thread (with a renderer of its own, on a
//! second GPU device when one can be created, so that these views do not queue ahead of the
//! environments' own frames). The next [`EscapeEnv::reset`] without a seed finds it ready when its
//! stream is still in the state the draw started from and uses it; any other reset (a new seed, a
//! fixed episode, a restored snapshot at another state) waits for the thread, drops its work and
//! computes inline. The results are the same either way (the same functions on the same inputs:
//! test `prefetched_resets_equal_inline_ones`); in a vector environment a reset no longer holds up
//! the other environments' step for its open-loop pass.
//!
//! The thread never outlives its environment: [`EscapeEnv::close`](crate::EscapeEnv::close) and
//! dropping the environment join it (a thread still rendering on lavapipe while the process exits
//! crashes it in LLVM's exit handlers: test `close_joins_the_prefetch_thread`).

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::thread::JoinHandle;

use loomlab_agents::EscapeController;
use loomlab_scenarios::deadline::EscapeDeadline;
use loomlab_scenarios::schema::EpisodeSpec;
use loomlab_scenarios::truth::{EpisodeTruth, open_loop_truth_and_deadline};
use loomlab_sim::{GpuContext, Renderer};

use crate::{EnvError, EnvOptions, EnvScenario, EpisodeRng, ScenarioEpisodes, SeedStream, background_gpu_context};

/// An episode drawn from the seed stream: its spec, its simulator seed and the stream after the
/// draw.
pub(super) struct Drawn {
    pub(super) spec: EpisodeSpec,
    pub(super) sim_seed: u64,
    pub(super) rng_after: EpisodeRng,
}

/// What the environment draws from: its scenario (re-expanded at every draw when it has random
/// ranges, a suite always) or its fixed episodes, and the seed stream its draws are tagged with
/// ([`crate::SeedStream`]).
pub(super) enum DrawSource<'a> {
    Resample {
        scenario: &'a EnvScenario,
        options: &'a EnvOptions,
    },
    Fixed(&'a ScenarioEpisodes, Option<SeedStream>),
}

impl<'a> DrawSource<'a> {
    /// The environment's source: its scenario when it has random ranges, else its episodes.
    pub(super) fn new(
        resample: bool,
        scenario: &'a EnvScenario,
        options: &'a EnvOptions,
        base: &'a ScenarioEpisodes,
    ) -> Self {
        if resample {
            DrawSource::Resample { scenario, options }
        } else {
            DrawSource::Fixed(base, options.seed_stream)
        }
    }

    /// Draws the next episode from `rng` (advancing a copy; the caller takes
    /// [`Drawn::rng_after`]). The simulator seed and the expansion seed are tagged with the seed
    /// stream (their top bit), so the train and eval streams never draw the same seeds.
    pub(super) fn draw(&self, mut rng: EpisodeRng) -> Result<Drawn, EnvError> {
        let stream = match self {
            DrawSource::Resample { options, .. } => options.seed_stream,
            DrawSource::Fixed(_, stream) => *stream,
        };
        let tag = |seed: u64| stream.map_or(seed, |s| s.tag(seed));
        let sim_seed = tag(rng.next_u64());
        let draw = tag(rng.next_u64());
        let spec = match self {
            DrawSource::Resample { scenario, options } if scenario.is_suite() => {
                scenario.draw_episode(options, draw | 1, rng.next_u64())?
            }
            DrawSource::Resample { scenario, options } => {
                // a fresh expansion of the random ranges (a nonzero seed mixed into the file's)
                let sc = scenario.load(options, draw | 1)?;
                let i = (rng.next_u64() % sc.episodes.len() as u64) as usize;
                sc.episodes[i].clone()
            }
            DrawSource::Fixed(base, _) => base.episodes[(draw % base.episodes.len() as u64) as usize].clone(),
        };
        Ok(Drawn {
            spec,
            sim_seed,
            rng_after: rng,
        })
    }
}

/// An episode's open-loop truth and escape deadline (`None`: no threat).
pub(super) type OpenLoop = (EpisodeTruth, Option<EscapeDeadline>);

/// The open-loop truth and deadline of `spec` with simulator seed `sim_seed`, the views rendered
/// on `renderer`.
pub(super) fn open_loop(spec: &EpisodeSpec, sim_seed: u64, renderer: &mut Renderer) -> Result<OpenLoop, EnvError> {
    let escape = EscapeController::new(spec.controller.clone(), spec.facts)?;
    Ok(open_loop_truth_and_deadline(spec, sim_seed, &escape, renderer)?)
}

/// A drawn episode with its open-loop truth and deadline.
pub(super) struct Prepared {
    pub(super) drawn: Drawn,
    pub(super) open_loop: OpenLoop,
}

type Job = JoinHandle<(Result<Prepared, EnvError>, Renderer)>;

/// The background preparation of one episode (see the module docs) and the renderer it uses
/// between preparations.
#[derive(Default)]
pub(super) struct Prefetcher {
    /// The stream state the draw in flight started from, and its thread.
    in_flight: Option<(u64, Job)>,
    renderer: Option<Renderer>,
    /// Resets that used a prepared episode.
    pub(super) hits: u64,
    /// Preparation threads of this prefetcher that have not finished yet (each decrements it as
    /// its last act).
    alive: Arc<AtomicUsize>,
}

/// Decrements a live-thread count when dropped (at the end of the thread, panics included).
struct AliveGuard(Arc<AtomicUsize>);

impl Drop for AliveGuard {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

impl Drop for Prefetcher {
    fn drop(&mut self) {
        self.join();
    }
}

impl Prefetcher {
    /// The episode prepared from stream state `rng_state`, if that is what the thread in flight
    /// prepared (waiting for it to finish); `None` otherwise (work for another state is dropped).
    /// A preparation that failed gives `None` too: the reset then computes inline and reports the
    /// error itself.
    pub(super) fn take(&mut self, rng_state: u64) -> Option<Prepared> {
        let (state, job) = self.in_flight.take()?;
        let (result, renderer) = job.join().ok()?;
        self.renderer = Some(renderer);
        let prepared = result.ok().filter(|_| state == rng_state);
        self.hits += u64::from(prepared.is_some());
        prepared
    }

    /// Waits for the preparation in flight, if any, and drops its work (closing or dropping the
    /// environment: no thread outlives it).
    pub(super) fn join(&mut self) {
        if let Some((_, job)) = self.in_flight.take()
            && let Ok((_, renderer)) = job.join()
        {
            self.renderer = Some(renderer);
        }
    }

    /// The count of this prefetcher's preparation threads still running (shared with them).
    pub(super) fn alive(&self) -> Arc<AtomicUsize> {
        Arc::clone(&self.alive)
    }

    /// The preparations' renderer (created on first use, on [`background_gpu_context`] when there
    /// is one), taken out: give it back with [`Self::keep_renderer`].
    pub(super) fn take_renderer(&mut self, ctx: &Arc<GpuContext>, n: u32) -> Result<Renderer, EnvError> {
        if let Some(r) = self.renderer.take() {
            return Ok(r);
        }
        let ctx = background_gpu_context().unwrap_or_else(|| Arc::clone(ctx));
        Ok(Renderer::with_context(ctx, n)?)
    }

    /// Keeps `renderer` for the next preparation.
    pub(super) fn keep_renderer(&mut self, renderer: Renderer) {
        self.renderer = Some(renderer);
    }

    /// Starts preparing the episode `source` draws from stream `rng` on a background thread,
    /// unless one is in flight for that state already. Without a thread or a renderer the next
    /// reset computes inline.
    pub(super) fn start(&mut self, source: DrawSource<'_>, rng: EpisodeRng, ctx: &Arc<GpuContext>, n: u32) {
        if self.in_flight.as_ref().is_some_and(|(s, _)| *s == rng.state()) {
            return;
        }
        if self.in_flight.is_some() {
            self.take(rng.state());
        }
        let Ok(mut renderer) = self.take_renderer(ctx, n) else {
            return;
        };
        // the draw itself runs on the thread when it re-expands the scenario (about a millisecond)
        let draw: Box<dyn FnOnce() -> Result<Drawn, EnvError> + Send> = match source {
            DrawSource::Resample { scenario, options } => {
                let (scenario, options) = (scenario.clone(), options.clone());
                Box::new(move || {
                    DrawSource::Resample {
                        scenario: &scenario,
                        options: &options,
                    }
                    .draw(rng)
                })
            }
            DrawSource::Fixed(..) => {
                let drawn = source.draw(rng);
                Box::new(move || drawn)
            }
        };
        self.alive.fetch_add(1, Ordering::SeqCst);
        let guard = AliveGuard(Arc::clone(&self.alive));
        let job = std::thread::Builder::new()
            .name("loomlab-env-prefetch".into())
            .spawn(move || {
                let _alive = guard;
                let result = draw().and_then(|drawn| {
                    let open_loop = open_loop(&drawn.spec, drawn.sim_seed, &mut renderer)?;
                    Ok(Prepared { drawn, open_loop })
                });
                (result, renderer)
            });
        if let Ok(job) = job {
            self.in_flight = Some((rng.state(), job));
        }
    }
}
