//! The robot's frames, from its URDF (read with urdf-rs): where every link sits
//! relative to `base_link` (all joints at their zero position), where the floor is, and
//! the two mounting frames the stack needs (the lidar's, the carried rack's).
//!
//! Knows nothing of motion or of the world: the robot's pose in the map is given by
//! the caller. Joint positions are ignored (wheels spin about their own axis, which
//! moves no other frame), so every transform is computed once at load.

use crate::config::{MountConfig, RobotConfig};
use crate::shapes::{CollisionShape, Geometry};
use aisle_geometry::{Pose2, wrap_angle};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The frame every other frame is expressed in.
pub const BASE_LINK: &str = "base_link";

/// A URDF that cannot be used. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum ModelError {
    #[error("{}: cannot read URDF: {source}", file.display())]
    Read {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: malformed URDF: {message}", file.display())]
    Malformed { file: PathBuf, message: String },
    #[error("{}: no link named `{link}` (needed by {needed_by})", file.display())]
    MissingLink {
        file: PathBuf,
        link: String,
        needed_by: String,
    },
    #[error("{}: joint `{joint}`: {reason}", file.display())]
    BadJoint {
        file: PathBuf,
        joint: String,
        reason: String,
    },
    #[error("{}: link `{link}`: {reason}", file.display())]
    BadLink {
        file: PathBuf,
        link: String,
        reason: String,
    },
}

/// Frames and mass of the robot, resolved from a URDF and `robot.toml`.
#[derive(Debug, Clone)]
pub struct RobotModel {
    file: PathBuf,
    name: String,
    in_base: BTreeMap<String, Isometry3<f64>>,
    floor_z: f64,
    mass: f64,
    lidar_mount: Isometry3<f64>,
    carry_mount: Isometry3<f64>,
    shapes: Vec<CollisionShape>,
}

fn origin_to_isometry(o: &urdf_rs::Pose) -> Option<Isometry3<f64>> {
    let [x, y, z] = o.xyz.0;
    let [r, p, w] = o.rpy.0;
    if ![x, y, z, r, p, w].iter().all(|v| v.is_finite()) {
        return None;
    }
    // URDF rpy is fixed-axis roll about x, then pitch about y, then yaw about z,
    // which is nalgebra's `from_euler_angles` order.
    Some(Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(r, p, w),
    ))
}

/// The mount's offset and rotation in its link's frame.
fn mount_offset(m: &MountConfig) -> Isometry3<f64> {
    let [r, p, y] = m.rpy;
    Isometry3::from_parts(
        Translation3::from(Vector3::from(m.offset)),
        UnitQuaternion::from_euler_angles(r, p, y),
    )
}

/// Lowest z of a collision shape placed at `at` (frame z is up).
fn shape_bottom(geom: &urdf_rs::Geometry, at: &Isometry3<f64>) -> Option<f64> {
    let cz = at.translation.vector.z;
    let rot = at.rotation.to_rotation_matrix();
    let m = rot.matrix();
    match geom {
        urdf_rs::Geometry::Box { size } => {
            let h = [0.5 * size[0], 0.5 * size[1], 0.5 * size[2]];
            Some(cz - (0..3).map(|i| m[(2, i)].abs() * h[i]).sum::<f64>())
        }
        urdf_rs::Geometry::Cylinder { radius, length }
        | urdf_rs::Geometry::Capsule { radius, length } => {
            // Axis is the shape's local z.
            let az = m[(2, 2)].abs().min(1.0);
            let cap = if matches!(geom, urdf_rs::Geometry::Capsule { .. }) {
                *radius * az
            } else {
                0.0
            };
            Some(cz - 0.5 * length * az - radius * (1.0 - az * az).sqrt() - cap)
        }
        urdf_rs::Geometry::Sphere { radius } => Some(cz - radius),
        urdf_rs::Geometry::Mesh { .. } => None,
    }
}

impl RobotModel {
    /// Loads `urdf_path` and resolves the mounting links named in `cfg`
    /// (`lidar_mount.link`, `carry.link`): a missing one is an error naming it.
    pub fn load(urdf_path: &Path, cfg: &RobotConfig) -> Result<RobotModel, ModelError> {
        let text = aisle_config::read_capped(urdf_path).map_err(|source| ModelError::Read {
            file: urdf_path.to_path_buf(),
            source,
        })?;
        Self::parse(urdf_path, &text, cfg)
    }

    /// As [`RobotModel::load`], from text already in memory (`file` names it in errors).
    pub fn parse(file: &Path, text: &str, cfg: &RobotConfig) -> Result<RobotModel, ModelError> {
        let robot = urdf_rs::read_from_string(text).map_err(|e| ModelError::Malformed {
            file: file.to_path_buf(),
            message: e.to_string(),
        })?;
        let mut model = Self::from_urdf(file, &robot)?;
        model.lidar_mount = model.mount(&cfg.lidar_mount.link, "lidar_mount.link")?
            * mount_offset(&cfg.lidar_mount);
        model.carry_mount = model.mount(&cfg.carry.link, "carry.link")?;
        Ok(model)
    }

    pub(crate) fn mount(&self, link: &str, key: &str) -> Result<Isometry3<f64>, ModelError> {
        self.in_base
            .get(link)
            .copied()
            .ok_or_else(|| ModelError::MissingLink {
                file: self.file.clone(),
                link: link.to_string(),
                needed_by: format!("robot.toml `{key}`"),
            })
    }

    fn from_urdf<'r>(file: &Path, robot: &'r urdf_rs::Robot) -> Result<RobotModel, ModelError> {
        let links = links_by_name(file, robot)?;
        let parent_of = joint_tree(file, robot, &links)?;
        // root_T_link for every link; a chain longer than the joint count is a cycle.
        let to_root = |link: &'r str| -> Result<(&'r str, Isometry3<f64>), ModelError> {
            let mut t = Isometry3::identity();
            let mut cur = link;
            for _ in 0..=robot.joints.len() {
                match parent_of.get(cur) {
                    Some((p, pt)) => {
                        t = pt * t;
                        cur = p;
                    }
                    None => return Ok((cur, t)),
                }
            }
            Err(ModelError::BadLink {
                file: file.to_path_buf(),
                link: link.to_string(),
                reason: "its joints form a cycle".into(),
            })
        };
        let (base_root, root_t_base) = to_root(BASE_LINK)?;
        let base_t_root = root_t_base.inverse();
        let mut in_base = BTreeMap::new();
        let mut floor_z = f64::INFINITY;
        let mut mass = 0.0;
        let mut shapes = Vec::new();
        for (name, link) in &links {
            let (root, root_t_link) = to_root(name)?;
            if root != base_root {
                return Err(ModelError::BadLink {
                    file: file.to_path_buf(),
                    link: name.to_string(),
                    reason: format!("not connected to `{BASE_LINK}`"),
                });
            }
            let base_t_link = base_t_root * root_t_link;
            for c in &link.collision {
                let at = origin_to_isometry(&c.origin).ok_or_else(|| ModelError::BadLink {
                    file: file.to_path_buf(),
                    link: name.to_string(),
                    reason: "collision origin is not finite".into(),
                })?;
                if let Some(z) = shape_bottom(&c.geometry, &(base_t_link * at)) {
                    floor_z = floor_z.min(z);
                }
                if let Some(geometry) = Geometry::of(&c.geometry) {
                    shapes.push(CollisionShape::new(name, base_t_link * at, geometry));
                }
            }
            let m = link.inertial.mass.value;
            if !(m.is_finite() && m >= 0.0) {
                return Err(ModelError::BadLink {
                    file: file.to_path_buf(),
                    link: name.to_string(),
                    reason: format!("mass must be >= 0 and finite, got {m}"),
                });
            }
            mass += m;
            in_base.insert(name.to_string(), base_t_link);
        }
        Ok(RobotModel {
            file: file.to_path_buf(),
            name: robot.name.clone(),
            in_base,
            // No collision geometry at all: take base_link to be on the floor.
            floor_z: if floor_z.is_finite() { floor_z } else { 0.0 },
            mass,
            lidar_mount: Isometry3::identity(),
            carry_mount: Isometry3::identity(),
            shapes,
        })
    }

    pub fn file(&self) -> &Path {
        &self.file
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// Pose of a link in `base_link`, joints at zero; `None` for an unknown link.
    pub fn link_pose_in_base(&self, link: &str) -> Option<Isometry3<f64>> {
        self.in_base.get(link).copied()
    }

    pub fn link_names(&self) -> impl Iterator<Item = &str> {
        self.in_base.keys().map(String::as_str)
    }

    /// The collision shapes of every link, placed in `base_link` (meshes left out).
    pub fn collision_shapes(&self) -> &[CollisionShape] {
        &self.shapes
    }

    /// Height of `base_link` above the floor: minus the lowest collision point.
    pub fn base_height(&self) -> f64 {
        -self.floor_z
    }

    /// Sum of the link masses, kg.
    pub fn total_mass(&self) -> f64 {
        self.mass
    }

    /// The lidar's sensor frame in `base_link`: mounting link, then the configured pose.
    pub fn lidar_in_base(&self) -> Isometry3<f64> {
        self.lidar_mount
    }

    /// The carry link's frame in `base_link`.
    pub fn carry_mount_in_base(&self) -> Isometry3<f64> {
        self.carry_mount
    }

    /// The carry link projected onto the floor plane (x, y, yaw), for planar attachment.
    pub fn carry_mount_planar(&self) -> Pose2 {
        planar(&self.carry_mount)
    }

    /// `base_link` in the map for a robot at planar pose `robot` on the floor.
    pub fn base_in_world(&self, robot: &Pose2) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::new(robot.x, robot.y, self.base_height()),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), robot.theta),
        )
    }

    /// The lidar's sensor frame in the map for a robot at `robot`.
    pub fn lidar_in_world(&self, robot: &Pose2) -> Isometry3<f64> {
        self.base_in_world(robot) * self.lidar_mount
    }
}

/// The URDF's links by name; `base_link` must be among them, each only once.
fn links_by_name<'r>(
    file: &Path,
    robot: &'r urdf_rs::Robot,
) -> Result<BTreeMap<&'r str, &'r urdf_rs::Link>, ModelError> {
    let mut links: BTreeMap<&'r str, &'r urdf_rs::Link> = BTreeMap::new();
    for l in &robot.links {
        if links.insert(l.name.as_str(), l).is_some() {
            return Err(ModelError::BadLink {
                file: file.to_path_buf(),
                link: l.name.clone(),
                reason: "defined twice".into(),
            });
        }
    }
    if !links.contains_key(BASE_LINK) {
        return Err(ModelError::MissingLink {
            file: file.to_path_buf(),
            link: BASE_LINK.into(),
            needed_by: "every frame of the stack".into(),
        });
    }
    Ok(links)
}

/// child -> (parent, parent_T_child) for every joint; each link has one parent.
fn joint_tree<'r>(
    file: &Path,
    robot: &'r urdf_rs::Robot,
    links: &BTreeMap<&'r str, &'r urdf_rs::Link>,
) -> Result<BTreeMap<&'r str, (&'r str, Isometry3<f64>)>, ModelError> {
    let bad_joint = |joint: &str, reason: String| ModelError::BadJoint {
        file: file.to_path_buf(),
        joint: joint.to_string(),
        reason,
    };
    // child -> (parent, parent_T_child)
    let mut parent_of: BTreeMap<&'r str, (&'r str, Isometry3<f64>)> = BTreeMap::new();
    for j in &robot.joints {
        for end in [&j.parent.link, &j.child.link] {
            if !links.contains_key(end.as_str()) {
                return Err(bad_joint(
                    &j.name,
                    format!("refers to unknown link `{end}`"),
                ));
            }
        }
        let t = origin_to_isometry(&j.origin)
            .ok_or_else(|| bad_joint(&j.name, "origin is not finite".into()))?;
        if parent_of
            .insert(j.child.link.as_str(), (j.parent.link.as_str(), t))
            .is_some()
        {
            return Err(bad_joint(
                &j.name,
                format!("link `{}` has two parents", j.child.link),
            ));
        }
    }
    Ok(parent_of)
}

/// Projection of a 3D frame onto the floor plane: its origin's x, y and the heading of
/// its x axis.
pub fn planar(t: &Isometry3<f64>) -> Pose2 {
    let ax = t.rotation * Vector3::x();
    let p = t * Point3::origin();
    Pose2::new(p.x, p.y, wrap_angle(ax.y.atan2(ax.x)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn shipped() -> (PathBuf, RobotConfig) {
        let p = aisle_config::testing::shipped("jackal.urdf");
        (p, RobotConfig::default())
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-9
    }

    #[test]
    fn shipped_urdf_frames_match_the_jackal_facts() {
        let (p, cfg) = shipped();
        let m = RobotModel::load(&p, &cfg).unwrap();
        assert_eq!(m.name(), "jackal");
        for l in [
            "base_link",
            "chassis_link",
            "front_left_wheel_link",
            "front_right_wheel_link",
            "rear_left_wheel_link",
            "rear_right_wheel_link",
            "front_fender_link",
            "rear_fender_link",
            "mid_mount",
            "front_mount",
            "rear_mount",
            "imu_link",
            "navsat_link",
        ] {
            assert!(m.link_pose_in_base(l).is_some(), "{l}");
        }
        let w = m.link_pose_in_base("rear_right_wheel_link").unwrap();
        let v = w.translation.vector;
        assert!(close(v.x, -0.131) && close(v.y, -0.187795) && close(v.z, 0.0345));
        let fm = m
            .link_pose_in_base("front_mount")
            .unwrap()
            .translation
            .vector;
        assert!(close(fm.x, 0.12) && close(fm.y, 0.0) && close(fm.z, 0.184));
        let rear = planar(&m.link_pose_in_base("rear_fender_link").unwrap());
        assert!(close(rear.theta.abs(), PI));
        // Floor: wheel axle 0.0345 above base_link, radius 0.098.
        assert!(
            close(m.base_height(), 0.098 - 0.0345),
            "{}",
            m.base_height()
        );
        assert!((m.total_mass() - 18.43).abs() < 0.01, "{}", m.total_mass());
        let mid = m.carry_mount_in_base().translation.vector;
        assert!(close(mid.z, 0.184));
        assert_eq!(m.carry_mount_planar(), Pose2::new(0.0, 0.0, 0.0));
    }

    #[test]
    fn lidar_sits_at_the_fender_plus_the_offset() {
        let (p, cfg) = shipped();
        let m = RobotModel::load(&p, &cfg).unwrap();
        let s = m.lidar_in_base().translation.vector;
        assert!(
            close(s.x, 0.25) && close(s.y, 0.1) && close(s.z, 0.2),
            "{s:?}"
        );
        // Rotated robot: the offset turns with it, and base_link is lifted off the floor.
        let wpose = m.lidar_in_world(&Pose2::new(1.0, 2.0, PI / 2.0));
        let t = wpose.translation.vector;
        assert!(close(t.x, 1.0 - 0.1) && close(t.y, 2.0 + 0.25), "{t:?}");
        assert!(close(t.z, 0.2 + 0.0635), "{t:?}");
        // A mount on the rear fender (yawed by pi) flips the offset.
        let mut cfg = RobotConfig::default();
        cfg.lidar_mount.link = "rear_fender_link".into();
        let m = RobotModel::load(&p, &cfg).unwrap();
        let s = m.lidar_in_base().translation.vector;
        assert!(
            close(s.x, -0.25) && close(s.y, -0.1) && close(s.z, 0.2),
            "{s:?}"
        );
    }

    #[test]
    fn missing_mount_link_names_file_and_link() {
        let text = r#"<robot name="r"><link name="base_link"/><link name="mid_mount"/>
            <joint name="j" type="fixed"><parent link="base_link"/><child link="mid_mount"/></joint>
            </robot>"#;
        let e = RobotModel::parse(Path::new("bot.urdf"), text, &RobotConfig::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bot.urdf") && e.contains("front_fender_link"),
            "{e}"
        );
        assert!(e.contains("lidar_mount.link"), "{e}");
    }

    #[test]
    fn malformed_urdf_is_an_error_naming_the_file() {
        for text in [
            "<robot name=\"r\"><link name=\"base_link\">",
            "not xml at all",
            "",
            "<robot><joint name=\"j\" type=\"fixed\"><parent link=\"a\"/></joint></robot>",
        ] {
            let e = RobotModel::parse(Path::new("broken.urdf"), text, &RobotConfig::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains("broken.urdf"), "{e}");
        }
        let e = RobotModel::load(Path::new("/nonexistent/x.urdf"), &RobotConfig::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("/nonexistent/x.urdf"), "{e}");
    }

    #[test]
    fn structural_errors_are_refused() {
        let cfg = RobotConfig {
            lidar_mount: MountConfig {
                link: "base_link".into(),
                offset: [0.0; 3],
                rpy: [0.0; 3],
            },
            carry: crate::config::CarryConfig {
                link: "base_link".into(),
            },
            ..RobotConfig::default()
        };
        let cycle = r#"<robot name="r"><link name="base_link"/><link name="a"/><link name="b"/>
            <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
            <joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint>
            </robot>"#;
        let e = RobotModel::parse(Path::new("c.urdf"), cycle, &cfg).unwrap_err();
        assert!(e.to_string().contains("cycle"), "{e}");
        let unknown = r#"<robot name="r"><link name="base_link"/>
            <joint name="j" type="fixed"><parent link="base_link"/><child link="ghost"/></joint>
            </robot>"#;
        let e = RobotModel::parse(Path::new("u.urdf"), unknown, &cfg).unwrap_err();
        assert!(e.to_string().contains("ghost"), "{e}");
        let no_base = r#"<robot name="r"><link name="chassis"/></robot>"#;
        let e = RobotModel::parse(Path::new("n.urdf"), no_base, &cfg).unwrap_err();
        assert!(e.to_string().contains("base_link"), "{e}");
    }
}
