//! rapier3d world, wgpu offscreen renderer and ground truth (design §5).
