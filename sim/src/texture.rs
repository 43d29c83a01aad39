//! Procedural luminance textures, evaluated per pixel in WGSL (`render/shader.wgsl`).
//!
//! Every surface carries a [`Texture`]. Textures are functions of a 2-D *surface coordinate* `(u, v)` in
//! metres (plus time for drifting gratings); how a shape maps its surface to `(u, v)` is documented on
//! [`crate::ShapeDesc`] (v is always "up" on vertical faces, so `orientation_deg = 0` gives horizontal stripes).
//! Luminance is in `[0, 1]` (0 = black, 1 = white); there is no lighting: what you specify is what the
//! camera sees.
//!
//! The shader filters every texture over the pixel footprint (box-filtered square waves and checkers,
//! attenuated sine gratings, noise fading to its mean) so that fine patterns near the horizon do not alias
//! into spurious motion.

use serde::{Deserialize, Serialize};

use crate::SimError;

fn one() -> f32 {
    1.0
}
fn half() -> f32 {
    0.5
}
fn tenth() -> f32 {
    0.1
}

/// A procedural luminance texture (TOML: an inline table with a `kind` key).
///
/// ```toml
/// texture = { kind = "square_grating", period_m = 0.5, orientation_deg = 90, drift_hz = 1.0 }
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Texture {
    /// One luminance everywhere.
    Uniform {
        /// Luminance in [0, 1] (default 0.5).
        #[serde(default = "half")]
        luminance: f32,
    },
    /// A checkerboard of square cells.
    Checker {
        /// Cell edge length in metres (default 1).
        #[serde(default = "one")]
        size_m: f32,
        /// Luminance of the dark cells (default 0).
        #[serde(default)]
        dark: f32,
        /// Luminance of the light cells (default 1).
        #[serde(default = "one")]
        light: f32,
    },
    /// A square-wave grating (stripes with hard edges).
    SquareGrating(GratingDesc),
    /// A sinusoidal grating.
    SineGrating(GratingDesc),
    /// Blocky random noise: every `cell_m` × `cell_m` cell gets an independent luminance drawn from
    /// U(dark, light), or, with `binary = true`, either `dark` or `light` with probability 1/2 each.
    Noise {
        /// Cell edge length in metres (default 0.1).
        #[serde(default = "tenth")]
        cell_m: f32,
        /// Lower luminance (default 0).
        #[serde(default)]
        dark: f32,
        /// Upper luminance (default 1).
        #[serde(default = "one")]
        light: f32,
        /// Two-valued noise instead of uniform noise (default false).
        #[serde(default)]
        binary: bool,
        /// Noise pattern seed; default: derived from the simulation seed and the surface's index.
        #[serde(default)]
        seed: Option<u32>,
    },
}

impl Default for Texture {
    fn default() -> Self {
        Texture::Uniform { luminance: 0.5 }
    }
}

/// Parameters of a square or sine grating.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GratingDesc {
    /// Spatial period in metres. Give exactly one of `period_m` and `cycles`.
    #[serde(default)]
    pub period_m: Option<f32>,
    /// Number of cycles across the shape's reference size (sphere: diameter, box: largest edge,
    /// cylinder: height). Not allowed on the ground.
    #[serde(default)]
    pub cycles: Option<f32>,
    /// Stripe orientation: 0 = horizontal stripes (luminance varies along v), 90 = vertical stripes.
    #[serde(default)]
    pub orientation_deg: f32,
    /// Temporal frequency of the drift in cycles per second (positive: the pattern moves towards +v at
    /// orientation 0, towards +u at orientation 90).
    #[serde(default)]
    pub drift_hz: f32,
    /// Spatial phase in degrees at t = 0 (0: a dark-to-light edge at u = v = 0).
    #[serde(default)]
    pub phase_deg: f32,
    /// Luminance of the dark phase (default 0).
    #[serde(default)]
    pub dark: f32,
    /// Luminance of the light phase (default 1).
    #[serde(default = "one")]
    pub light: f32,
}

impl Default for GratingDesc {
    fn default() -> Self {
        GratingDesc {
            period_m: Some(1.0),
            cycles: None,
            orientation_deg: 0.0,
            drift_hz: 0.0,
            phase_deg: 0.0,
            dark: 0.0,
            light: 1.0,
        }
    }
}

/// Texture kind codes shared with the shader (`TEX_*` in `shader.wgsl`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum TextureKind {
    /// [`Texture::Uniform`].
    Uniform = 0,
    /// [`Texture::Checker`].
    Checker = 1,
    /// [`Texture::SquareGrating`].
    SquareGrating = 2,
    /// [`Texture::SineGrating`].
    SineGrating = 3,
    /// [`Texture::Noise`].
    Noise = 4,
}

/// A validated texture with all lengths resolved to metres, ready for the GPU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResolvedTexture {
    /// Which pattern.
    pub kind: TextureKind,
    /// Dark luminance.
    pub dark: f32,
    /// Light luminance.
    pub light: f32,
    /// Period (gratings), cell size (checker, noise) in metres; unused for uniform.
    pub scale_m: f32,
    /// Grating orientation in radians.
    pub orientation_rad: f32,
    /// Grating phase at t = 0, in cycles.
    pub phase0_cycles: f64,
    /// Grating drift, cycles per second.
    pub drift_hz: f64,
    /// Binary noise.
    pub binary: bool,
    /// Noise seed.
    pub seed: u32,
}

fn check_lum(key: &str, name: &str, v: f32) -> Result<(), SimError> {
    if !(0.0..=1.0).contains(&v) {
        return Err(SimError::invalid(
            format!("{key}.{name}"),
            v,
            "luminance must be in [0, 1]",
        ));
    }
    Ok(())
}

fn check_pos(key: &str, name: &str, v: f32) -> Result<(), SimError> {
    if !(v.is_finite() && v > 0.0) {
        return Err(SimError::invalid(
            format!("{key}.{name}"),
            v,
            "must be a finite number > 0",
        ));
    }
    Ok(())
}

impl Texture {
    /// A uniform texture of the given luminance.
    pub fn uniform(luminance: f32) -> Self {
        Texture::Uniform { luminance }
    }

    /// Validates the texture and resolves `cycles` against the shape's reference size.
    ///
    /// `key` names the texture in error messages; `reference_size_m` is `None` for infinite surfaces
    /// (the ground), where `cycles` is rejected; `default_seed` seeds noise without an explicit seed.
    pub fn resolve(
        &self,
        key: &str,
        reference_size_m: Option<f32>,
        default_seed: u32,
    ) -> Result<ResolvedTexture, SimError> {
        let base = ResolvedTexture {
            kind: TextureKind::Uniform,
            dark: 0.5,
            light: 0.5,
            scale_m: 1.0,
            orientation_rad: 0.0,
            phase0_cycles: 0.0,
            drift_hz: 0.0,
            binary: false,
            seed: default_seed,
        };
        match self {
            Texture::Uniform { luminance } => {
                check_lum(key, "luminance", *luminance)?;
                Ok(ResolvedTexture {
                    dark: *luminance,
                    light: *luminance,
                    ..base
                })
            }
            Texture::Checker { size_m, dark, light } => {
                check_pos(key, "size_m", *size_m)?;
                check_lum(key, "dark", *dark)?;
                check_lum(key, "light", *light)?;
                Ok(ResolvedTexture {
                    kind: TextureKind::Checker,
                    dark: *dark,
                    light: *light,
                    scale_m: *size_m,
                    ..base
                })
            }
            Texture::SquareGrating(g) | Texture::SineGrating(g) => {
                let kind = if matches!(self, Texture::SquareGrating(_)) {
                    TextureKind::SquareGrating
                } else {
                    TextureKind::SineGrating
                };
                check_lum(key, "dark", g.dark)?;
                check_lum(key, "light", g.light)?;
                let period = match (g.period_m, g.cycles) {
                    (Some(p), None) => {
                        check_pos(key, "period_m", p)?;
                        p
                    }
                    (None, Some(c)) => {
                        check_pos(key, "cycles", c)?;
                        let Some(size) = reference_size_m else {
                            return Err(SimError::invalid(
                                format!("{key}.cycles"),
                                c,
                                "`cycles` needs a finite surface; use `period_m` on the ground",
                            ));
                        };
                        size / c
                    }
                    (Some(_), Some(_)) => {
                        return Err(SimError::invalid(
                            format!("{key}.period_m"),
                            "(both set)",
                            "give exactly one of `period_m` and `cycles`",
                        ));
                    }
                    (None, None) => {
                        return Err(SimError::invalid(
                            format!("{key}.period_m"),
                            "(missing)",
                            "a grating needs `period_m` (metres) or `cycles` (per reference size)",
                        ));
                    }
                };
                for (name, v) in [
                    ("orientation_deg", g.orientation_deg),
                    ("drift_hz", g.drift_hz),
                    ("phase_deg", g.phase_deg),
                ] {
                    if !v.is_finite() {
                        return Err(SimError::invalid(format!("{key}.{name}"), v, "must be finite"));
                    }
                }
                Ok(ResolvedTexture {
                    kind,
                    dark: g.dark,
                    light: g.light,
                    scale_m: period,
                    orientation_rad: g.orientation_deg.to_radians(),
                    phase0_cycles: f64::from(g.phase_deg) / 360.0,
                    drift_hz: f64::from(g.drift_hz),
                    ..base
                })
            }
            Texture::Noise {
                cell_m,
                dark,
                light,
                binary,
                seed,
            } => {
                check_pos(key, "cell_m", *cell_m)?;
                check_lum(key, "dark", *dark)?;
                check_lum(key, "light", *light)?;
                Ok(ResolvedTexture {
                    kind: TextureKind::Noise,
                    dark: *dark,
                    light: *light,
                    scale_m: *cell_m,
                    binary: *binary,
                    seed: seed.unwrap_or(default_seed),
                    ..base
                })
            }
        }
    }
}

impl ResolvedTexture {
    /// Grating phase (cycles, in [0, 1)) at simulation time `t_s`.
    pub fn phase_at(&self, t_s: f64) -> f32 {
        (self.phase0_cycles + self.drift_hz * t_s).rem_euclid(1.0) as f32
    }

    /// Mean luminance of the pattern (what it fades to when it is far finer than a pixel).
    pub fn mean(&self) -> f32 {
        0.5 * (self.dark + self.light)
    }

    /// Unfiltered luminance at surface coordinate `(u, v)` and time `t_s`: the CPU twin of the shader's
    /// `texture_value` (without the pixel-footprint filtering).
    pub fn eval(&self, u: f32, v: f32, t_s: f64) -> f32 {
        let (dark, light) = (self.dark, self.light);
        match self.kind {
            TextureKind::Uniform => dark,
            TextureKind::Checker => {
                let i = (u / self.scale_m).floor() as i64 + (v / self.scale_m).floor() as i64;
                if i.rem_euclid(2) == 0 { dark } else { light }
            }
            TextureKind::SquareGrating | TextureKind::SineGrating => {
                let (s, c) = self.orientation_rad.sin_cos();
                let x = (u * s + v * c) / self.scale_m - self.phase_at(t_s);
                if self.kind == TextureKind::SquareGrating {
                    if x.rem_euclid(1.0) < 0.5 { light } else { dark }
                } else {
                    self.mean() + 0.5 * (light - dark) * (2.0 * std::f32::consts::PI * x).sin()
                }
            }
            TextureKind::Noise => {
                let ix = (u / self.scale_m).floor() as i32;
                let iy = (v / self.scale_m).floor() as i32;
                let h = noise_hash(ix as u32, iy as u32, self.seed);
                if self.binary {
                    if h < 0.5 { dark } else { light }
                } else {
                    dark + (light - dark) * h
                }
            }
        }
    }
}

/// The integer hash used for noise cells (PCG-style; identical to `hash3` in `shader.wgsl`), in [0, 1).
pub fn noise_hash(x: u32, y: u32, seed: u32) -> f32 {
    fn pcg(v: u32) -> u32 {
        let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
        let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
        (word >> 22) ^ word
    }
    let h = pcg(x ^ pcg(y ^ pcg(seed)));
    (h >> 8) as f32 / 16_777_216.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Holder {
        texture: Texture,
    }

    #[test]
    fn parses_all_kinds_from_toml() {
        for src in [
            r#"texture = { kind = "uniform", luminance = 0.2 }"#,
            r#"texture = { kind = "checker", size_m = 0.5 }"#,
            r#"texture = { kind = "square_grating", period_m = 0.5, orientation_deg = 90, drift_hz = 2 }"#,
            r#"texture = { kind = "sine_grating", cycles = 2 }"#,
            r#"texture = { kind = "noise", cell_m = 0.05, binary = true }"#,
        ] {
            let h: Holder = toml::from_str(src).unwrap_or_else(|e| panic!("{src}: {e}"));
            h.texture.resolve("t", Some(1.0), 7).unwrap();
        }
    }

    #[test]
    fn rejects_unknown_keys_and_bad_values() {
        assert!(toml::from_str::<Holder>(r#"texture = { kind = "uniform", luminanse = 0.2 }"#).is_err());
        assert!(
            toml::from_str::<Holder>(r#"texture = { kind = "square_grating", period_m = 1, colour = 2 }"#).is_err()
        );
        let t = Texture::uniform(1.5);
        assert!(t.resolve("w", None, 0).unwrap_err().to_string().contains("w.luminance"));
        let g = Texture::SquareGrating(GratingDesc {
            period_m: None,
            cycles: Some(2.0),
            ..Default::default()
        });
        assert!(g.resolve("ground.texture", None, 0).is_err());
        assert_eq!(g.resolve("ball", Some(0.5), 0).unwrap().scale_m, 0.25);
    }

    #[test]
    fn square_grating_alternates_every_half_period() {
        let g = Texture::SquareGrating(GratingDesc::default())
            .resolve("g", None, 0)
            .unwrap();
        assert_eq!(g.eval(0.0, 0.25, 0.0), 1.0);
        assert_eq!(g.eval(0.0, 0.75, 0.0), 0.0);
        // drift by half a cycle swaps the phases
        let d = Texture::SquareGrating(GratingDesc {
            drift_hz: 1.0,
            ..Default::default()
        })
        .resolve("g", None, 0)
        .unwrap();
        assert_eq!(d.eval(0.0, 0.25, 0.5), 0.0);
    }

    #[test]
    fn noise_hash_is_uniformish() {
        let n = 10_000;
        let mean: f32 = (0..n).map(|i| noise_hash(i, i / 7, 3)).sum::<f32>() / n as f32;
        assert!((mean - 0.5).abs() < 0.02, "{mean}");
    }
}
