//! Helpers shared by the sim integration tests.
#![allow(dead_code)]

use loomlab_sim::{Sim, SimError, WorldDesc};

/// Creates a rendering simulator. Rendering tests must run in CI (lavapipe is installed there), so a
/// missing adapter is a failure with the fix in the message, never a silent skip.
pub fn rendering_sim(desc: &WorldDesc, seed: u64) -> Sim {
    match Sim::new(desc, seed) {
        Ok(sim) => sim,
        Err(e @ SimError::NoAdapter { .. }) => {
            panic!("rendering test needs a GPU adapter: {e}")
        }
        Err(e) => panic!("could not build the world: {e}"),
    }
}

/// FNV-1a hash of a frame's bits.
pub fn frame_hash(frame: &[f32]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for v in frame {
        for b in v.to_bits().to_le_bytes() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x100_0000_01b3);
        }
    }
    h
}
