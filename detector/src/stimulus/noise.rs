//! Reproducible random streams of a stimulus.
//!
//! Every random element draws from its own ChaCha8 generator seeded from
//! (`stimulus.seed`, stream, frame), so a single frame `t` renders identically whether it
//! is rendered alone or as part of the whole video, and changing one element (e.g. adding
//! dropout) does not change the others' noise.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::spec::NoiseDistribution;

/// Which random element a generator feeds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Stream {
    /// The static noise texture fixed to the object (one per episode).
    ObjectNoise = 1,
    /// The noise background (per frame if dynamic, else one per episode).
    BackgroundNoise = 2,
    /// Pixel dropout (per frame).
    Dropout = 3,
}

/// SplitMix64 finaliser: a bijective, well-mixing 64-bit hash.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The generator of `stream` for frame `t` (pass 0 for per-episode streams).
pub(crate) fn rng(seed: u64, stream: Stream, t: u64) -> ChaCha8Rng {
    let key = splitmix64(splitmix64(splitmix64(seed) ^ stream as u64) ^ t);
    ChaCha8Rng::seed_from_u64(key)
}

/// Fills `out` with independent values in [0, 1] of the given distribution
/// (uniform: U[0, 1); binary: 0 or 1 with probability ½).
pub(crate) fn fill(rng: &mut ChaCha8Rng, dist: NoiseDistribution, out: &mut [f32]) {
    match dist {
        NoiseDistribution::Uniform => out.iter_mut().for_each(|v| *v = rng.random::<f32>()),
        NoiseDistribution::Binary => {
            // 64 binary values per random word.
            for chunk in out.chunks_mut(64) {
                let bits: u64 = rng.random();
                for (k, v) in chunk.iter_mut().enumerate() {
                    *v = ((bits >> k) & 1) as f32;
                }
            }
        }
    }
}
