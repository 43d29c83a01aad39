//! Without an adapter the error names the fix. (Own test binary: it sets an environment variable.)

use loomlab_sim::{Sim, SimError, WorldDesc};

#[test]
fn missing_adapter_error_names_the_fix() {
    // SAFETY: this test binary has a single test, so no other thread reads the environment concurrently.
    unsafe { std::env::set_var(loomlab_sim::render::ADAPTER_ENV, "no-such-adapter-anywhere") };
    let err = Sim::new(&WorldDesc::default(), 0).unwrap_err();
    assert!(matches!(err, SimError::NoAdapter { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("apt-get install mesa-vulkan-drivers"), "{msg}");
    assert!(msg.contains("no-such-adapter-anywhere"), "{msg}");
    // physics-only mode needs no adapter
    assert!(Sim::new_physics_only(&WorldDesc::default(), 0).is_ok());
}
