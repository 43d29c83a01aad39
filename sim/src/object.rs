//! Objects of the world other than the robot: what they are made of and how they move.

use serde::{Deserialize, Serialize};

use crate::dynamics::BallDynamics;
use crate::shape::{AngularPrimitive, Part};
use crate::trajectory::Trajectory;

/// What kind of object a ground-truth row or contact refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObjectKind {
    /// A launched sphere.
    Projectile,
    /// A driving box or composite.
    Vehicle,
    /// Static scenery (walls, poles, boxes, overpasses).
    Scenery,
}

impl ObjectKind {
    /// Lower-case name (`projectile`, `vehicle`, `scenery`), as used in CSV files.
    pub fn as_str(&self) -> &'static str {
        match self {
            ObjectKind::Projectile => "projectile",
            ObjectKind::Vehicle => "vehicle",
            ObjectKind::Scenery => "scenery",
        }
    }
}

impl std::fmt::Display for ObjectKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A built object: name, kind, rigid parts (in the body frame) and trajectory of the body frame.
#[derive(Clone, Debug)]
pub struct ObjectSpec {
    /// Unique name (ground truth, contacts, CSV).
    pub name: String,
    /// Kind.
    pub kind: ObjectKind,
    /// Rigid parts, in the body frame.
    pub parts: Vec<Part>,
    /// Motion of the body frame (with dynamic physics: the planned motion; for a projectile its
    /// path until launch and the launch state).
    pub trajectory: Trajectory,
    /// Dynamic physics: a projectile's mass and material (`None`: scenery and vehicles, which stay
    /// fixed or kinematic).
    pub(crate) ball: Option<BallDynamics>,
}

impl ObjectSpec {
    /// Angular primitives of all parts, in the body frame.
    pub fn angular_primitives(&self) -> Vec<AngularPrimitive> {
        let mut out = Vec::new();
        for p in &self.parts {
            p.angular_primitives(&mut out);
        }
        out
    }

    /// Radius about the body origin containing every part.
    pub fn bounding_radius(&self) -> f64 {
        self.parts
            .iter()
            .map(|p| p.offset.length() + f64::from(p.prim.bounding_radius()))
            .fold(0.0, f64::max)
    }
}
