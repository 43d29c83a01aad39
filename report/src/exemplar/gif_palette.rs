//! The GIF palette: grey levels for the robot's view, then the detectors' colours.

use plotters::prelude::*;

use crate::plot::palette;

/// Grey levels of the GIF palette (the rest of its 256 entries are the detectors' colours).
const GREYS: usize = 64;

/// The GIF palette: [`GREYS`] grey levels, then the detectors' colours.
pub(super) fn gif_palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(256 * 3);
    for i in 0..GREYS {
        let g = (i * 255 / (GREYS - 1)) as u8;
        p.extend([g, g, g]);
    }
    for i in 0..8 {
        let c = palette(i);
        p.extend([c.0, c.1, c.2]);
    }
    p
}

pub(super) fn palette_index(rgb: [u8; 3]) -> u8 {
    let [r, g, b] = rgb;
    if r == g && g == b {
        return ((usize::from(r) * (GREYS - 1) + 127) / 255) as u8;
    }
    let d = |c: RGBColor| {
        let dr = i32::from(c.0) - i32::from(r);
        let dg = i32::from(c.1) - i32::from(g);
        let db = i32::from(c.2) - i32::from(b);
        dr * dr + dg * dg + db * db
    };
    let (best, dist) = (0..8)
        .map(|i| (i, d(palette(i))))
        .min_by_key(|&(_, d)| d)
        .unwrap_or((0, i32::MAX));
    // anti-aliased text edges between a colour and the grey strip: the nearer of the two
    let grey = (u32::from(r) + u32::from(g) + u32::from(b)) / 3;
    let gd = {
        let gg = grey as i32;
        (gg - i32::from(r)).pow(2) + (gg - i32::from(g)).pow(2) + (gg - i32::from(b)).pow(2)
    };
    if gd < dist {
        ((grey as usize * (GREYS - 1) + 127) / 255) as u8
    } else {
        (GREYS + best) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn palette_maps_greys_and_colours() {
        assert_eq!(palette_index([0, 0, 0]), 0);
        assert_eq!(palette_index([255, 255, 255]), (GREYS - 1) as u8);
        let c = palette(2);
        assert_eq!(palette_index([c.0, c.1, c.2]), (GREYS + 2) as u8);
        assert!(gif_palette().len() <= 256 * 3);
    }
}
