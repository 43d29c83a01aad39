//! Integration tests of the escape agent: one test binary, one module per concern.

mod action;
mod escape;
