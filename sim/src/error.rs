//! The simulator's error type.

/// Everything that can go wrong when building or running a simulated world.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A value in the world description is out of range or inconsistent.
    #[error("invalid world description: {key} = {value}: {reason}")]
    InvalidDesc {
        /// Dotted path of the offending key, e.g. `world.projectiles[0].speed_mps`.
        key: String,
        /// The offending value, as written.
        value: String,
        /// Why it is rejected and what would be accepted.
        reason: String,
    },
    /// An episode duration (or frame count) is not a finite positive number or exceeds
    /// [`crate::MAX_EPISODE_FRAMES`].
    #[error("{key} = {value}: {reason}")]
    Duration {
        /// The key or flag as the user wrote it, e.g. `episode.duration_s` or `--seconds`.
        key: String,
        /// The offending value.
        value: String,
        /// Why it is rejected and what to give instead.
        reason: String,
    },
    /// No GPU adapter (not even a software one) could be found.
    #[error(
        "no GPU adapter found for offscreen rendering ({detail}). On Debian/Ubuntu install the Mesa software \
         Vulkan driver (lavapipe): `apt-get install mesa-vulkan-drivers`; or run without rendering \
         (`Sim::new_physics_only`)"
    )]
    NoAdapter {
        /// What was tried (backends, adapter filter).
        detail: String,
    },
    /// The adapter refused to create a device with the features/limits the renderer needs.
    #[error("could not create a GPU device on adapter `{adapter}`: {reason}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// The driver's reason.
        reason: String,
    },
    /// A GPU operation failed while rendering or reading back a frame.
    #[error("GPU error while {during}: {reason}")]
    Gpu {
        /// What the renderer was doing.
        during: &'static str,
        /// The driver's reason.
        reason: String,
    },
    /// A renderer was reused with a world whose camera resolution differs.
    #[error(
        "renderer was created for n = {renderer_n} but the world's camera has n = {world_n}; create a new Renderer"
    )]
    SizeMismatch {
        /// Resolution the renderer was built for.
        renderer_n: u32,
        /// Resolution the world description asks for.
        world_n: u32,
    },
    /// A frame was requested from a simulator created without a renderer.
    #[error("this simulator was created without a renderer (physics-only mode); no frames are available")]
    NoRenderer,
    /// Writing an image or table failed.
    #[error("could not write {path}: {reason}")]
    Output {
        /// The file being written.
        path: String,
        /// The underlying reason.
        reason: String,
    },
}

impl SimError {
    /// Shorthand for [`SimError::InvalidDesc`].
    pub(crate) fn invalid(key: impl Into<String>, value: impl std::fmt::Display, reason: impl Into<String>) -> Self {
        SimError::InvalidDesc {
            key: key.into(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}
