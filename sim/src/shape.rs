//! Primitive shapes (box, sphere, cylinder) and multi-part bodies.
//!
//! A shape is used three ways: as a rapier/parry collider (contacts, exact time of impact), as a GPU
//! instance (rendering) and as a set of angular primitives (true angular size).

use rapier3d::parry::shape::SharedShape;
use rapier3d::prelude::Pose;
use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::glam::{DQuat, DVec3, Quat, Vec3};
use crate::texture::{ResolvedTexture, Texture};

/// A primitive shape in its own local frame (x forward, y left, z up, origin at its centre).
///
/// Texture coordinates `(u, v)` in metres, from the shape's centre:
/// - box: faces with normal ±x use `(y, z)`, ±y use `(x, z)`, ±z use `(x, y)`;
/// - sphere: `(y, z)`, a planar projection along local x (projectiles point local x along their flight,
///   so a head-on projectile shows its pattern like a flat disk, as in the paper's stimuli);
/// - cylinder (axis = local z): side `(radius · azimuth, z)`, caps `(x, y)`.
///
/// TOML: `shape = { kind = "box", size = [4.0, 1.8, 1.5] }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeDesc {
    /// Axis-aligned box with full edge lengths `size = [x, y, z]` in metres.
    Box {
        /// Full edge lengths in metres.
        size: [f32; 3],
    },
    /// Sphere.
    Sphere {
        /// Radius in metres.
        radius_m: f32,
    },
    /// Upright cylinder (axis along local z).
    Cylinder {
        /// Radius in metres.
        radius_m: f32,
        /// Height in metres.
        height_m: f32,
    },
}

impl Default for ShapeDesc {
    fn default() -> Self {
        ShapeDesc::Box { size: [1.0, 1.0, 1.0] }
    }
}

/// Shape kind codes shared with the shader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum PrimKind {
    /// Box (cube mesh scaled by `size`).
    Box = 0,
    /// Sphere (ray-cast impostor: exact silhouette).
    Sphere = 1,
    /// Cylinder (mesh with 64 sides).
    Cylinder = 2,
}

/// A validated primitive: kind and full size (`[x, y, z]` extents; sphere `[2r, 2r, 2r]`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Prim {
    /// Which primitive.
    pub kind: PrimKind,
    /// Full extents in metres.
    pub size: Vec3,
}

impl ShapeDesc {
    /// Validates the shape; `key` names it in error messages.
    pub fn to_prim(&self, key: &str) -> Result<Prim, SimError> {
        let pos = |name: &str, v: f32| -> Result<f32, SimError> {
            if v.is_finite() && v > 0.0 {
                Ok(v)
            } else {
                Err(SimError::invalid(
                    format!("{key}.{name}"),
                    v,
                    "must be a finite length > 0",
                ))
            }
        };
        Ok(match self {
            ShapeDesc::Box { size } => Prim {
                kind: PrimKind::Box,
                size: Vec3::new(
                    pos("size[0]", size[0])?,
                    pos("size[1]", size[1])?,
                    pos("size[2]", size[2])?,
                ),
            },
            ShapeDesc::Sphere { radius_m } => {
                let r = pos("radius_m", *radius_m)?;
                Prim {
                    kind: PrimKind::Sphere,
                    size: Vec3::splat(2.0 * r),
                }
            }
            ShapeDesc::Cylinder { radius_m, height_m } => {
                let r = pos("radius_m", *radius_m)?;
                Prim {
                    kind: PrimKind::Cylinder,
                    size: Vec3::new(2.0 * r, 2.0 * r, pos("height_m", *height_m)?),
                }
            }
        })
    }
}

impl Prim {
    /// The reference size that a grating's `cycles` is counted over (sphere: diameter, box: largest
    /// edge, cylinder: height).
    pub fn reference_size(&self) -> f32 {
        match self.kind {
            PrimKind::Box => self.size.max_element(),
            PrimKind::Sphere => self.size.x,
            PrimKind::Cylinder => self.size.z,
        }
    }

    /// Height of the primitive (z extent).
    pub fn height(&self) -> f32 {
        self.size.z
    }

    /// The parry shape with its pose correction (parry cylinders are along y; ours along z).
    pub fn parry_shape(&self) -> (SharedShape, Pose) {
        match self.kind {
            PrimKind::Box => (
                SharedShape::cuboid(self.size.x / 2.0, self.size.y / 2.0, self.size.z / 2.0),
                Pose::IDENTITY,
            ),
            PrimKind::Sphere => (SharedShape::ball(self.size.x / 2.0), Pose::IDENTITY),
            PrimKind::Cylinder => (
                SharedShape::cylinder(self.size.z / 2.0, self.size.x / 2.0),
                Pose::from_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
            ),
        }
    }

    /// Radius of the smallest sphere around the centre that contains the primitive.
    pub fn bounding_radius(&self) -> f32 {
        match self.kind {
            PrimKind::Box => (self.size / 2.0).length(),
            PrimKind::Sphere => self.size.x / 2.0,
            PrimKind::Cylinder => (self.size.x / 2.0).hypot(self.size.z / 2.0),
        }
    }
}

/// One rigid part of a body: a primitive at a pose in the body's frame, with its texture.
#[derive(Clone, Debug)]
pub struct Part {
    /// The primitive.
    pub prim: Prim,
    /// Offset of the part's centre in the body frame (metres).
    pub offset: DVec3,
    /// Rotation of the part in the body frame.
    pub rotation: DQuat,
    /// Its texture.
    pub texture: ResolvedTexture,
}

/// Sides used for the angular-size polygon of a cylinder rim.
const RIM_POINTS: usize = 32;

/// What the true angular size of a body is computed from, in the body frame.
#[derive(Clone, Debug)]
pub enum AngularPrimitive {
    /// A point (vertex of a box, point on a cylinder rim).
    Point(DVec3),
    /// A sphere with centre and radius.
    Sphere(DVec3, f64),
}

impl Part {
    /// Builds a part from its description.
    pub fn new(
        shape: &ShapeDesc,
        offset: [f32; 3],
        yaw_deg: f32,
        texture: &Texture,
        key: &str,
        seed: u32,
    ) -> Result<Part, SimError> {
        let prim = shape.to_prim(&format!("{key}.shape"))?;
        let texture = texture.resolve(&format!("{key}.texture"), Some(prim.reference_size()), seed)?;
        if offset.iter().any(|v| !v.is_finite()) || !yaw_deg.is_finite() {
            return Err(SimError::invalid(
                format!("{key}.offset"),
                format!("{offset:?}"),
                "must be finite",
            ));
        }
        Ok(Part {
            prim,
            offset: DVec3::new(offset[0].into(), offset[1].into(), offset[2].into()),
            rotation: DQuat::from_rotation_z(f64::from(yaw_deg).to_radians()),
            texture,
        })
    }

    /// Appends the part's angular primitives (in the body frame) to `out`.
    pub fn angular_primitives(&self, out: &mut Vec<AngularPrimitive>) {
        let h = self.prim.size.as_dvec3() / 2.0;
        match self.prim.kind {
            PrimKind::Sphere => out.push(AngularPrimitive::Sphere(self.offset, h.x)),
            PrimKind::Box => {
                for i in 0..8 {
                    let c = DVec3::new(
                        if i & 1 == 0 { -h.x } else { h.x },
                        if i & 2 == 0 { -h.y } else { h.y },
                        if i & 4 == 0 { -h.z } else { h.z },
                    );
                    out.push(AngularPrimitive::Point(self.offset + self.rotation * c));
                }
            }
            PrimKind::Cylinder => {
                for k in 0..RIM_POINTS {
                    let a = std::f64::consts::TAU * k as f64 / RIM_POINTS as f64;
                    for z in [-h.z, h.z] {
                        let c = DVec3::new(h.x * a.cos(), h.x * a.sin(), z);
                        out.push(AngularPrimitive::Point(self.offset + self.rotation * c));
                    }
                }
            }
        }
    }
}

/// The collision shape of a set of parts and its pose in the body frame: the primitive itself when there
/// is one part, else a compound (whose pose is the identity).
pub fn collider_shape(parts: &[Part]) -> (SharedShape, Pose) {
    let mut pieces: Vec<(Pose, SharedShape)> = parts
        .iter()
        .map(|p| {
            let (shape, fix) = p.prim.parry_shape();
            let pose = Pose::from_parts(p.offset.as_vec3(), p.rotation.as_quat()) * fix;
            (pose, shape)
        })
        .collect();
    if pieces.len() == 1 {
        let (pose, shape) = pieces.pop().expect("one piece");
        return (shape, pose);
    }
    (SharedShape::compound(pieces), Pose::IDENTITY)
}
