//! Static scenery: walls, poles, boxes and overpasses (fixed rapier colliders; world coordinates).
//!
//! Scenery creates background motion in the image as the robot moves, and it is part of the ground
//! truth like every other object (the robot can drive into a wall).

use serde::{Deserialize, Serialize};

use crate::SimError;
use crate::glam::{DQuat, DVec3};
use crate::object::{ObjectKind, ObjectSpec};
use crate::shape::{Part, ShapeDesc};
use crate::texture::Texture;
use crate::trajectory::{Pose64, Trajectory};

/// A static scenery item (TOML array of tables `[[world.scenery]]` with a `kind` key).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SceneryDesc {
    /// A straight wall standing on the ground.
    Wall(WallDesc),
    /// A vertical pole (cylinder) standing on the ground.
    Pole(PoleDesc),
    /// A box.
    Box(BoxDesc),
    /// A bridge over the robot's path: two pillars and a deck.
    Overpass(OverpassDesc),
}

fn default_texture() -> Texture {
    Texture::uniform(0.6)
}

/// A wall from `start` to `end` (its texture's u runs along the wall, v up).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WallDesc {
    /// Name (default `scenery<i>`).
    pub name: Option<String>,
    /// One end `[x, y]` (m).
    pub start: [f32; 2],
    /// The other end `[x, y]` (m).
    pub end: [f32; 2],
    /// Height (m). Default 2.
    pub height_m: f32,
    /// Thickness (m). Default 0.2.
    pub thickness_m: f32,
    /// Texture (default uniform 0.6).
    pub texture: Texture,
}

impl Default for WallDesc {
    fn default() -> Self {
        WallDesc {
            name: None,
            start: [0.0, 3.0],
            end: [20.0, 3.0],
            height_m: 2.0,
            thickness_m: 0.2,
            texture: default_texture(),
        }
    }
}

/// A vertical pole.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PoleDesc {
    /// Name (default `scenery<i>`).
    pub name: Option<String>,
    /// Foot position `[x, y]` (m).
    pub position: [f32; 2],
    /// Radius (m). Default 0.1.
    pub radius_m: f32,
    /// Height (m). Default 3.
    pub height_m: f32,
    /// Texture (default uniform 0.6).
    pub texture: Texture,
}

impl Default for PoleDesc {
    fn default() -> Self {
        PoleDesc {
            name: None,
            position: [10.0, 2.0],
            radius_m: 0.1,
            height_m: 3.0,
            texture: default_texture(),
        }
    }
}

/// A box.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxDesc {
    /// Name (default `scenery<i>`).
    pub name: Option<String>,
    /// Centre of the footprint `[x, y]` (m).
    pub position: [f32; 2],
    /// Height of the bottom face above the ground (m). Default 0.
    pub base_z_m: f32,
    /// Full edge lengths `[x, y, z]` (m). Default `[1, 1, 1]`.
    pub size: [f32; 3],
    /// Rotation about the vertical (degrees).
    pub yaw_deg: f32,
    /// Texture (default uniform 0.6).
    pub texture: Texture,
}

impl Default for BoxDesc {
    fn default() -> Self {
        BoxDesc {
            name: None,
            position: [10.0, 0.0],
            base_z_m: 0.0,
            size: [1.0, 1.0, 1.0],
            yaw_deg: 0.0,
            texture: default_texture(),
        }
    }
}

/// An overpass: the road passes under it along its local x axis (`yaw_deg = 0`: along world +x, the
/// default robot heading), between two pillars that carry a deck.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OverpassDesc {
    /// Name (default `scenery<i>`).
    pub name: Option<String>,
    /// Centre of the passage on the ground `[x, y]` (m). Default `[15, 0]`.
    pub position: [f32; 2],
    /// Direction of the road passing under it (degrees from +x). Default 0.
    pub yaw_deg: f32,
    /// Free height under the deck (m). Default 4.
    pub clearance_m: f32,
    /// Free width between the pillars (m). Default 8.
    pub span_m: f32,
    /// Extent of deck and pillars along the road (m). Default 3.
    pub depth_m: f32,
    /// Deck thickness (m). Default 0.8.
    pub deck_thickness_m: f32,
    /// Pillar width across the road (m). Default 1.
    pub pillar_width_m: f32,
    /// Deck texture (default uniform 0.6).
    pub texture: Texture,
    /// Pillar texture (default: the deck texture).
    pub pillar_texture: Option<Texture>,
}

impl Default for OverpassDesc {
    fn default() -> Self {
        OverpassDesc {
            name: None,
            position: [15.0, 0.0],
            yaw_deg: 0.0,
            clearance_m: 4.0,
            span_m: 8.0,
            depth_m: 3.0,
            deck_thickness_m: 0.8,
            pillar_width_m: 1.0,
            texture: default_texture(),
            pillar_texture: None,
        }
    }
}

fn check(key: &str, name: &str, v: f32, positive: bool) -> Result<f32, SimError> {
    if !v.is_finite() || (positive && v <= 0.0) {
        let what = if positive {
            "must be a finite number > 0"
        } else {
            "must be finite"
        };
        return Err(SimError::invalid(format!("{key}.{name}"), v, what));
    }
    Ok(v)
}

impl SceneryDesc {
    /// Builds the item; `index` is its position in `world.scenery`.
    pub(crate) fn build(&self, index: usize, seed: u32) -> Result<ObjectSpec, SimError> {
        let key = format!("world.scenery[{index}]");
        let (name, pose, parts) = match self {
            SceneryDesc::Wall(w) => {
                let a = DVec3::new(
                    check(&key, "start[0]", w.start[0], false)?.into(),
                    check(&key, "start[1]", w.start[1], false)?.into(),
                    0.0,
                );
                let b = DVec3::new(
                    check(&key, "end[0]", w.end[0], false)?.into(),
                    check(&key, "end[1]", w.end[1], false)?.into(),
                    0.0,
                );
                let len = (b - a).length();
                if len < 1e-6 {
                    return Err(SimError::invalid(
                        format!("{key}.end"),
                        format!("{:?}", w.end),
                        "a wall needs start != end",
                    ));
                }
                let h = check(&key, "height_m", w.height_m, true)?;
                let t = check(&key, "thickness_m", w.thickness_m, true)?;
                let shape = ShapeDesc::Box {
                    size: [len as f32, t, h],
                };
                let part = Part::new(&shape, [0.0, 0.0, h / 2.0], 0.0, &w.texture, &key, seed)?;
                let d = b - a;
                (&w.name, Pose64::from_xyz_yaw((a + b) / 2.0, d.y.atan2(d.x)), vec![part])
            }
            SceneryDesc::Pole(p) => {
                let h = check(&key, "height_m", p.height_m, true)?;
                let shape = ShapeDesc::Cylinder {
                    radius_m: p.radius_m,
                    height_m: h,
                };
                let part = Part::new(&shape, [0.0, 0.0, h / 2.0], 0.0, &p.texture, &key, seed)?;
                let pos = DVec3::new(
                    check(&key, "position[0]", p.position[0], false)?.into(),
                    check(&key, "position[1]", p.position[1], false)?.into(),
                    0.0,
                );
                (&p.name, Pose64::from_xyz_yaw(pos, 0.0), vec![part])
            }
            SceneryDesc::Box(b) => {
                let base = check(&key, "base_z_m", b.base_z_m, false)?;
                let shape = ShapeDesc::Box { size: b.size };
                let part = Part::new(&shape, [0.0, 0.0, base + b.size[2] / 2.0], 0.0, &b.texture, &key, seed)?;
                let pos = DVec3::new(
                    check(&key, "position[0]", b.position[0], false)?.into(),
                    check(&key, "position[1]", b.position[1], false)?.into(),
                    0.0,
                );
                let yaw = f64::from(check(&key, "yaw_deg", b.yaw_deg, false)?).to_radians();
                (&b.name, Pose64::from_xyz_yaw(pos, yaw), vec![part])
            }
            SceneryDesc::Overpass(o) => {
                let clear = check(&key, "clearance_m", o.clearance_m, true)?;
                let span = check(&key, "span_m", o.span_m, true)?;
                let depth = check(&key, "depth_m", o.depth_m, true)?;
                let thick = check(&key, "deck_thickness_m", o.deck_thickness_m, true)?;
                let pw = check(&key, "pillar_width_m", o.pillar_width_m, true)?;
                let pillar_tex = o.pillar_texture.as_ref().unwrap_or(&o.texture);
                let pillar = ShapeDesc::Box {
                    size: [depth, pw, clear],
                };
                let deck = ShapeDesc::Box {
                    size: [depth, span + 2.0 * pw, thick],
                };
                let y = span / 2.0 + pw / 2.0;
                let parts = vec![
                    Part::new(
                        &pillar,
                        [0.0, y, clear / 2.0],
                        0.0,
                        pillar_tex,
                        &format!("{key}.pillar_texture"),
                        seed,
                    )?,
                    Part::new(
                        &pillar,
                        [0.0, -y, clear / 2.0],
                        0.0,
                        pillar_tex,
                        &format!("{key}.pillar_texture"),
                        seed.wrapping_add(1),
                    )?,
                    Part::new(
                        &deck,
                        [0.0, 0.0, clear + thick / 2.0],
                        0.0,
                        &o.texture,
                        &key,
                        seed.wrapping_add(2),
                    )?,
                ];
                let pos = DVec3::new(
                    check(&key, "position[0]", o.position[0], false)?.into(),
                    check(&key, "position[1]", o.position[1], false)?.into(),
                    0.0,
                );
                let yaw = f64::from(check(&key, "yaw_deg", o.yaw_deg, false)?).to_radians();
                (&o.name, Pose64::from_xyz_yaw(pos, yaw), parts)
            }
        };
        Ok(ObjectSpec {
            name: name.clone().unwrap_or_else(|| format!("scenery{index}")),
            kind: ObjectKind::Scenery,
            parts,
            trajectory: Trajectory::fixed(Pose64 {
                position: pose.position,
                rotation: pose.rotation * DQuat::IDENTITY,
            }),
            ball: None,
        })
    }
}
