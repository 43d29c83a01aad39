//! Unit meshes generated once at start-up: a cube (boxes, and the proxy of sphere impostors) and a
//! cylinder, as non-indexed triangle lists with per-face normals.

use bytemuck::{Pod, Zeroable};

/// A mesh vertex: position in the unit shape (extent 1 along each axis, centred) and normal.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct Vertex {
    /// Position.
    pub pos: [f32; 3],
    /// Outward normal.
    pub normal: [f32; 3],
}

/// Number of sides of the cylinder mesh.
pub const CYLINDER_SIDES: usize = 64;

/// The unit cube [-0.5, 0.5]³, counter-clockwise outward faces.
pub fn cube() -> Vec<Vertex> {
    let mut out = Vec::with_capacity(36);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = [0.0; 3];
            n[axis] = sign;
            let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |s: f32, t: f32| {
                let mut p = [0.0; 3];
                p[axis] = 0.5 * sign;
                p[a] = 0.5 * s;
                p[b] = 0.5 * t;
                Vertex { pos: p, normal: n }
            };
            let (c0, c1, c2, c3) = (
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            );
            if sign > 0.0 {
                out.extend([c0, c1, c2, c0, c2, c3]);
            } else {
                out.extend([c0, c2, c1, c0, c3, c2]);
            }
        }
    }
    out
}

/// The unit cylinder: radius 0.5, height 1, axis z, centred; counter-clockwise outward faces.
pub fn cylinder() -> Vec<Vertex> {
    let mut out = Vec::with_capacity(CYLINDER_SIDES * 12);
    let p = |k: usize| {
        let a = std::f32::consts::TAU * k as f32 / CYLINDER_SIDES as f32;
        (0.5 * a.cos(), 0.5 * a.sin())
    };
    for k in 0..CYLINDER_SIDES {
        let (x0, y0) = p(k);
        let (x1, y1) = p(k + 1);
        let n0 = [2.0 * x0, 2.0 * y0, 0.0];
        let n1 = [2.0 * x1, 2.0 * y1, 0.0];
        let v = |x: f32, y: f32, z: f32, n: [f32; 3]| Vertex {
            pos: [x, y, z],
            normal: n,
        };
        // side
        out.extend([
            v(x0, y0, -0.5, n0),
            v(x1, y1, -0.5, n1),
            v(x1, y1, 0.5, n1),
            v(x0, y0, -0.5, n0),
            v(x1, y1, 0.5, n1),
            v(x0, y0, 0.5, n0),
        ]);
        // caps
        out.extend([
            v(0.0, 0.0, 0.5, [0.0, 0.0, 1.0]),
            v(x0, y0, 0.5, [0.0, 0.0, 1.0]),
            v(x1, y1, 0.5, [0.0, 0.0, 1.0]),
        ]);
        out.extend([
            v(0.0, 0.0, -0.5, [0.0, 0.0, -1.0]),
            v(x1, y1, -0.5, [0.0, 0.0, -1.0]),
            v(x0, y0, -0.5, [0.0, 0.0, -1.0]),
        ]);
    }
    out
}

/// One triangle covering the whole screen, in normalised device coordinates (x, y; z = 0).
pub fn fullscreen_triangle() -> Vec<Vertex> {
    [[-1.0, -1.0], [3.0, -1.0], [-1.0, 3.0]]
        .into_iter()
        .map(|[x, y]| Vertex {
            pos: [x, y, 0.0],
            normal: [0.0, 0.0, 1.0],
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_outward(mesh: &[Vertex]) {
        for tri in mesh.chunks(3) {
            let p = |i: usize| crate::glam::Vec3::from(tri[i].pos);
            let n = (p(1) - p(0)).cross(p(2) - p(0));
            let centroid = (p(0) + p(1) + p(2)) / 3.0;
            let normal = crate::glam::Vec3::from(tri[0].normal);
            assert!(n.dot(normal) > 0.0, "winding disagrees with normal at {centroid:?}");
            assert!(n.dot(centroid) > 0.0, "face points inwards at {centroid:?}");
        }
    }

    #[test]
    fn meshes_are_closed_and_outward() {
        check_outward(&cube());
        check_outward(&cylinder());
        assert_eq!(cube().len(), 36);
    }
}
