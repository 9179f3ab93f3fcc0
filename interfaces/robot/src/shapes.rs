//! The robot's collision shapes as the URDF gives them, each placed in `base_link`
//! (joints at zero): what a viewer draws as the robot.
//!
//! Knows the URDF's primitive geometries; meshes are left out (nothing in the stack
//! reads mesh files). Knows nothing of viewers or of the world.

use nalgebra::Isometry3;

/// The geometry of one collision element, in its own frame (URDF conventions: a box is
/// centred on its origin, a cylinder's axis is its z axis).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Geometry {
    /// Edge lengths along x, y, z.
    Box {
        size: [f64; 3],
    },
    Cylinder {
        radius: f64,
        length: f64,
    },
    Sphere {
        radius: f64,
    },
}

/// One collision element of a link: its geometry and where it sits in `base_link`.
#[derive(Debug, Clone, PartialEq)]
pub struct CollisionShape {
    /// The link it belongs to.
    pub link: String,
    pub in_base: Isometry3<f64>,
    pub geometry: Geometry,
}

impl CollisionShape {
    pub(crate) fn new(link: &str, in_base: Isometry3<f64>, geometry: Geometry) -> Self {
        Self {
            link: link.to_string(),
            in_base,
            geometry,
        }
    }
}

impl Geometry {
    /// The geometry of a URDF collision element; `None` for a mesh, a capsule (no
    /// viewer primitive for it) or a size that is not finite and positive.
    pub(crate) fn of(g: &urdf_rs::Geometry) -> Option<Geometry> {
        let ok = |v: &[f64]| v.iter().all(|x| x.is_finite() && *x > 0.0);
        match g {
            urdf_rs::Geometry::Box { size } => {
                let size = size.0;
                ok(&size).then_some(Geometry::Box { size })
            }
            urdf_rs::Geometry::Cylinder { radius, length } => {
                ok(&[*radius, *length]).then_some(Geometry::Cylinder {
                    radius: *radius,
                    length: *length,
                })
            }
            urdf_rs::Geometry::Sphere { radius } => {
                ok(&[*radius]).then_some(Geometry::Sphere { radius: *radius })
            }
            urdf_rs::Geometry::Capsule { .. } | urdf_rs::Geometry::Mesh { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{RobotConfig, RobotModel};

    #[test]
    fn the_jackal_is_its_chassis_box_and_four_wheels() {
        let p = aisle_config::testing::shipped("jackal.urdf");
        let m = RobotModel::load(&p, &RobotConfig::default()).unwrap();
        let shapes = m.collision_shapes();
        assert_eq!(shapes.len(), 5);
        let chassis = shapes.iter().find(|s| s.link == "chassis_link").unwrap();
        assert_eq!(
            chassis.geometry,
            Geometry::Box {
                size: [0.42, 0.31, 0.184]
            }
        );
        assert!((chassis.in_base.translation.vector.z - 0.092).abs() < 1e-12);
        let wheels = shapes
            .iter()
            .filter(|s| matches!(s.geometry, Geometry::Cylinder { radius, .. } if radius == 0.098))
            .count();
        assert_eq!(wheels, 4);
    }
}
