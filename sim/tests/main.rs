//! Integration tests of the simulator: one test binary, one module per concern (`no_adapter` sets a process-wide variable and keeps a binary of its own).

mod batch;
mod bounds;
mod common;
mod contacts;
mod desc;
mod determinism;
mod dynamics;
mod events;
mod goldens;
mod sensor;
mod sphere_size;
