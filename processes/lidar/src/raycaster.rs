//! `Raycaster`: the library's entry point. Owns the ray pattern, the scene's boxes and
//! the scratch buffers, and turns a sensor pose into an organised cloud.
//!
//! Everything is sized at construction; `scan` allocates nothing. A level sensor takes
//! the fast `planar` path, any other orientation the `general` one; noise is added last.
//! Knows nothing of the bus, the URDF or the clock: the caller passes the sensor pose
//! and the scan index.

use crate::LidarConfig;
use crate::SensorPose;
use crate::error::LidarError;
use crate::general::GeneralCaster;
use crate::noise;
use crate::pattern::ScanPattern;
use crate::planar::PlanarCaster;
use crate::world::World;
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;

/// Which algorithm served a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanPath {
    /// Level sensor: per-column 2D slabs, per-ray height test.
    Planar,
    /// Tilted sensor: per-ray 3D slab tests.
    General,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScanStats {
    /// Rays with a return (not NaN).
    pub returns: usize,
    pub path: ScanPath,
}

#[derive(Debug, Clone)]
pub struct Raycaster {
    pattern: ScanPattern,
    world: World,
    hit_floor: bool,
    noise: Option<(f32, u64)>,
    normals: noise::NormalTable,
    /// The sensor in the robot's floor frame (origin on the floor under the robot's
    /// planar pose, x forward, z up), for [`Raycaster::scan_robot`].
    mount: SensorPose,
    planar: PlanarCaster,
    general: GeneralCaster,
}

impl Raycaster {
    /// Validates `config` and takes every body of `scene` (static and movable), in scene
    /// order. The mount starts at the robot's floor-frame origin: resolve the real one
    /// (`aisle_robot::RobotModel::mount_in_base`) and call [`Raycaster::set_mount`]
    /// before using [`Raycaster::scan_robot`].
    pub fn new(config: &LidarConfig, scene: &Scene) -> Result<Raycaster, LidarError> {
        let pattern = ScanPattern::new(config)?;
        let world = World::from_scene(scene)?;
        let boxes = world.box_count();
        let mut r = Raycaster {
            planar: PlanarCaster::new(boxes, &pattern),
            general: GeneralCaster::new(boxes, &pattern, config.scan_threads as usize),
            pattern,
            world,
            hit_floor: config.hit_floor,
            noise: None,
            normals: noise::NormalTable::new(),
            mount: SensorPose::IDENTITY,
        };
        r.set_noise(config.noise.enabled, config.noise.sigma, config.noise.seed)?;
        Ok(r)
    }

    /// Turns the range noise on or off, or changes its sigma (metres) and seed.
    pub fn set_noise(&mut self, enabled: bool, sigma: f64, seed: u64) -> Result<(), LidarError> {
        if !(sigma.is_finite() && sigma >= 0.0) {
            return Err(aisle_config::InvalidKey::new(
                "noise.sigma",
                format!("must be >= 0, got {sigma}"),
            )
            .into());
        }
        self.noise = (enabled && sigma > 0.0).then_some((sigma as f32, seed));
        Ok(())
    }

    /// Sets the sensor's pose in the robot's floor frame (see [`Raycaster::scan_robot`]).
    pub fn set_mount(&mut self, mount: SensorPose) -> Result<(), LidarError> {
        if !mount.is_valid() {
            return Err(LidarError::BadMount);
        }
        self.mount = mount;
        Ok(())
    }

    pub fn mount(&self) -> &SensorPose {
        &self.mount
    }

    /// The sensor's world pose for a robot at planar pose `robot` on the floor (z = 0).
    pub fn sensor_pose(&self, robot: &Pose2) -> SensorPose {
        SensorPose::on_robot(robot, &self.mount)
    }

    pub fn pattern(&self) -> &ScanPattern {
        &self.pattern
    }

    pub fn rows(&self) -> usize {
        self.pattern.rows()
    }

    pub fn columns(&self) -> usize {
        self.pattern.columns()
    }

    /// rows x columns: the length `scan` expects of its output buffer.
    pub fn len(&self) -> usize {
        self.pattern.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pattern.is_empty()
    }

    /// Bodies in scene order; indices are the scene's.
    pub fn body_count(&self) -> usize {
        self.world.body_count()
    }

    /// Moves body `index` (scene order) to a new planar pose; costs O(its parts).
    pub fn set_body_pose(&mut self, index: usize, pose: Pose2) -> Result<(), LidarError> {
        self.world.set_body_pose(index, pose)
    }

    /// Excludes a body from the scan (e.g. the robot's own body if the scene holds it).
    pub fn set_body_enabled(&mut self, index: usize, enabled: bool) -> Result<(), LidarError> {
        self.world.set_body_enabled(index, enabled)
    }

    /// Index of the first body called `name` (the scene's index), if any.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.world.body_index(name)
    }

    pub fn body_pose(&self, index: usize) -> Option<Pose2> {
        self.world.body_pose(index)
    }

    pub fn body_enabled(&self, index: usize) -> Option<bool> {
        self.world.body_enabled(index)
    }

    /// Casts every ray from `sensor` and writes the organised cloud into `out`
    /// (row-major, rows x columns, sensor frame, NaN for no return within max range).
    /// `scan_index` selects the noise stream: the same (seed, scan_index) gives the same
    /// noise. Allocates nothing.
    pub fn scan(
        &mut self,
        sensor: &SensorPose,
        scan_index: u64,
        out: &mut [[f32; 3]],
    ) -> Result<ScanStats, LidarError> {
        if out.len() != self.pattern.len() {
            return Err(LidarError::BufferSize {
                expected: self.pattern.len(),
                got: out.len(),
            });
        }
        if !sensor.is_valid() {
            return Err(LidarError::BadSensorPose);
        }
        let (returns, path) = match sensor.level_yaw() {
            Some(yaw) => (
                self.planar.scan(
                    &self.pattern,
                    &self.world,
                    sensor.position,
                    yaw,
                    self.hit_floor,
                    out,
                ),
                ScanPath::Planar,
            ),
            None => (
                self.general.scan(&self.world, sensor, self.hit_floor, out),
                ScanPath::General,
            ),
        };
        if let Some((sigma, seed)) = self.noise {
            self.normals.apply(
                &self.pattern,
                sigma,
                noise::stream_key(seed, scan_index),
                out,
            );
        }
        Ok(ScanStats { returns, path })
    }

    /// [`Raycaster::scan`] from the sensor of a robot at planar pose `robot` (its floor
    /// frame at z = 0), mounted at [`Raycaster::mount`]. Allocates nothing.
    pub fn scan_robot(
        &mut self,
        robot: &Pose2,
        scan_index: u64,
        out: &mut [[f32; 3]],
    ) -> Result<ScanStats, LidarError> {
        if !robot.is_finite() {
            return Err(LidarError::BadSensorPose);
        }
        let sensor = self.sensor_pose(robot);
        self.scan(&sensor, scan_index, out)
    }
}
