//! Sensor mounts: a [`MountConfig`] (URDF link plus pose in it) resolved through the
//! robot's model to a [`SensorPose`] in the robot's floor frame.
//!
//! The floor frame is the frame a planar robot pose names: `base_link` projected onto
//! the floor (z = 0 on the floor). Knows nothing of what the sensor measures.

use crate::config::MountConfig;
use crate::model::{ModelError, RobotModel};
use crate::pose::SensorPose;

impl RobotModel {
    /// The sensor's pose in the robot's floor frame: `base_link`'s height above the
    /// floor, the mounting link's pose in `base_link`, then the mount's offset and
    /// rotation. An unknown link is an error naming the URDF and the link.
    pub fn mount_in_base(&self, mount: &MountConfig) -> Result<SensorPose, ModelError> {
        let link = self.mount(&mount.link, "lidar_mount.link")?;
        let r = link.rotation.to_rotation_matrix();
        let m = r.matrix();
        let link_pose = SensorPose {
            position: [
                link.translation.x,
                link.translation.y,
                link.translation.z + self.base_height(),
            ],
            rotation: [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ],
        };
        Ok(link_pose.compose(&SensorPose::from_xyz_rpy(mount.offset, mount.rpy)))
    }
}

#[cfg(test)]
mod tests {
    use crate::{MountConfig, load_robot};
    use aisle_config::testing::shipped;

    #[test]
    fn the_seed_mount_is_on_the_front_fender() {
        let (cfg, model) = load_robot(&shipped("robot.toml")).unwrap();
        let m = model.mount_in_base(&cfg.lidar_mount).unwrap();
        // front_fender_link sits at the chassis origin; the mount adds (0.25, 0.1, 0.2)
        // and base_link is 0.0635 m above the floor.
        assert!((m.position[0] - 0.25).abs() < 1e-9, "{:?}", m.position);
        assert!((m.position[1] - 0.1).abs() < 1e-9, "{:?}", m.position);
        assert!((m.position[2] - 0.2635).abs() < 1e-9, "{:?}", m.position);
        assert_eq!(m.level_yaw(), Some(0.0));
        let ghost = MountConfig {
            link: "ghost_link".into(),
            ..MountConfig::default()
        };
        let e = model.mount_in_base(&ghost).unwrap_err().to_string();
        assert!(e.contains("jackal.urdf") && e.contains("ghost_link"), "{e}");
    }
}
