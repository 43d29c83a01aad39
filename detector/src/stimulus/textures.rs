//! Object textures, evaluated in object-centred coordinates so they grow with the object.
//!
//! Coordinates `(a, b)` are measured from the object's centre in units of its image
//! diameter (disk) or side (square): `a` to the right, `b` up, so the object spans
//! [-½, ½]. The texture is first rotated by `orientation_deg` (counter-clockwise):
//! `a' = a·cos φ + b·sin φ`, `b' = −a·sin φ + b·cos φ`. With dark value `D` =
//! `dark_luminance` and bright value `B` = `luminance`, `c` = `cycles`, `p` = `phase`:
//!
//! | texture     | value                                                                          |
//! |-------------|--------------------------------------------------------------------------------|
//! | `uniform`   | `B`                                                                            |
//! | `grating`   | `B` where frac(c·b' + p) < ½, else `D` (square wave across the stripes)        |
//! | `checker`   | `B` where ⌊2(c·a' + p)⌋ + ⌊2(c·b' + p)⌋ is even, else `D`                      |
//! | `circular`  | `B` where frac(c·ρ + p) < ½ with ρ = √(a² + b²), else `D` (c rings per diameter)|
//! | `starburst` | `B` where frac(c·ψ/2π + p) < ½ with ψ = atan2(b', a'), else `D`                |
//! | `noise`     | `D + (B − D)·g` with `g` the cell of a `noise_cells`² grid over the object's   |
//! |             | bounding square (rotated with φ), drawn once per episode: uniform U[0, 1) or   |
//! |             | binary {0, 1} (`object.noise`)                                                 |
//!
//! Textures are point-sampled at pixel centres (only the object's outline is anti-aliased).

use std::f64::consts::TAU;

use super::noise::{self, Stream};
use super::spec::{ObjectSection, Texture};

/// Per-episode texture constants (the noise grid is drawn once from the seed).
#[derive(Debug, Clone)]
pub(crate) struct ObjectTexture {
    kind: Texture,
    bright: f64,
    dark: f64,
    cycles: f64,
    phase: f64,
    cos_o: f64,
    sin_o: f64,
    cells: usize,
    grid: Vec<f32>,
}

impl ObjectTexture {
    /// Precomputes the texture of `object` (the noise grid from `seed`).
    pub(crate) fn new(object: &ObjectSection, seed: u64) -> Self {
        let (sin_o, cos_o) = object.orientation_deg.to_radians().sin_cos();
        let cells = object.noise_cells.max(1);
        let grid = if object.texture == Texture::Noise {
            let mut g = vec![0.0f32; cells * cells];
            noise::fill(&mut noise::rng(seed, Stream::ObjectNoise, 0), object.noise, &mut g);
            g
        } else {
            Vec::new()
        };
        Self {
            kind: object.texture,
            bright: object.luminance,
            dark: object.dark_luminance,
            cycles: object.cycles,
            phase: object.phase,
            cos_o,
            sin_o,
            cells,
            grid,
        }
    }

    /// Whether the texture is the same everywhere (lets the renderer skip evaluation).
    pub(crate) fn is_uniform(&self) -> bool {
        self.kind == Texture::Uniform
    }

    /// Luminance at object coordinates `(a, b)` (diameters from the centre; `a` right, `b` up).
    #[inline]
    pub(crate) fn value(&self, a: f64, b: f64) -> f64 {
        let on = |s: f64| s - s.floor() < 0.5;
        let pick = |bright: bool| if bright { self.bright } else { self.dark };
        let ar = a * self.cos_o + b * self.sin_o;
        let br = -a * self.sin_o + b * self.cos_o;
        match self.kind {
            Texture::Uniform => self.bright,
            Texture::Grating => pick(on(self.cycles * br + self.phase)),
            Texture::Checker => {
                let i = (2.0 * (self.cycles * ar + self.phase)).floor() as i64;
                let j = (2.0 * (self.cycles * br + self.phase)).floor() as i64;
                pick((i + j).rem_euclid(2) == 0)
            }
            Texture::Circular => pick(on(self.cycles * (a * a + b * b).sqrt() + self.phase)),
            Texture::Starburst => pick(on(self.cycles * br.atan2(ar) / TAU + self.phase)),
            Texture::Noise => {
                let g = self.cells as f64;
                let col = (((ar + 0.5) * g).floor().max(0.0) as usize).min(self.cells - 1);
                let row = (((0.5 - br) * g).floor().max(0.0) as usize).min(self.cells - 1);
                self.dark + (self.bright - self.dark) * self.grid[row * self.cells + col] as f64
            }
        }
    }
}
