//! The robot as a Foxglove scene entity (`/viz/robot`, `foxglove.SceneUpdate`): one
//! cube or cylinder per collision shape of its URDF, in the `base_link` frame and
//! frame-locked, so the 3D panel draws it wherever the transforms put the robot, with no
//! URDF layer to set up. Published once (and latched by the live view): it never
//! changes. The carried rack is not part of it: it is a body of the scene
//! (`/viz/scene`), drawn where the simulator puts it.
//!
//! The viewer's `base_link` lies on the floor (the transforms place it at z = 0), the
//! URDF's `base_link` `RobotModel::base_height` above it: the shapes are lifted by that height.
//! Knows the robot model and the Foxglove primitives; nothing of files or the bus.

use super::build::{encode, rgba, timestamp};
use super::{ViewerMessage, ViewerTopic};
use aisle_robot::{Geometry, RobotModel};
use foxglove::messages as fg;

/// The robot's entity, without its timestamp (set when it is sent).
pub(super) fn entity(model: &RobotModel) -> fg::SceneEntity {
    let lift = model.base_height();
    let mut e = fg::SceneEntity {
        frame_id: "base_link".into(),
        id: "robot".into(),
        frame_locked: true,
        metadata: vec![fg::KeyValuePair {
            key: "urdf".into(),
            value: model.name().into(),
        }],
        ..Default::default()
    };
    for s in model.collision_shapes() {
        let t = s.in_base.translation.vector;
        let q = s.in_base.rotation;
        let pose = Some(fg::Pose {
            position: Some(fg::Vector3 {
                x: t.x,
                y: t.y,
                z: t.z + lift,
            }),
            orientation: Some(fg::Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            }),
        });
        match s.geometry {
            Geometry::Box { size: [x, y, z] } => e.cubes.push(fg::CubePrimitive {
                pose,
                size: Some(fg::Vector3 { x, y, z }),
                color: Some(rgba(0.95, 0.75, 0.1, 1.0)),
            }),
            Geometry::Cylinder { radius, length } => e.cylinders.push(fg::CylinderPrimitive {
                pose,
                size: Some(fg::Vector3 {
                    x: 2.0 * radius,
                    y: 2.0 * radius,
                    z: length,
                }),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: Some(rgba(0.12, 0.12, 0.12, 1.0)),
            }),
            Geometry::Sphere { radius } => e.spheres.push(fg::SpherePrimitive {
                pose,
                size: Some(fg::Vector3 {
                    x: 2.0 * radius,
                    y: 2.0 * radius,
                    z: 2.0 * radius,
                }),
                color: Some(rgba(0.3, 0.3, 0.3, 1.0)),
            }),
        }
    }
    e
}

/// The robot's scene update stamped `stamp_ns`.
pub(super) fn message(entity: &fg::SceneEntity, stamp_ns: u64) -> ViewerMessage {
    let update = fg::SceneUpdate {
        deletions: vec![],
        entities: vec![fg::SceneEntity {
            timestamp: Some(timestamp(stamp_ns)),
            ..entity.clone()
        }],
    };
    encode(ViewerTopic::Robot, stamp_ns, &update)
}
