//! `ParryReference`: the plain raycaster, one parry3d ray cast per ray against a
//! `Compound` of world-placed cuboids (parry's BVH inside), plus a half-space floor.
//!
//! It is the oracle the fast path is tested against, and the baseline in the benchmark.
//! It shares the fast path's conventions (sensor inside a box does not see that box; NaN
//! past max range) but none of its code. It allocates when bodies move (the compound
//! is rebuilt) and is not meant for the node. parry3d 0.31 works in glam f32 types; the
//! conversions stay in this file.

use crate::LidarConfig;
use crate::SensorPose;
use crate::error::LidarError;
use crate::pattern::ScanPattern;
use crate::world::{World, WorldBox};
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;
use parry3d::math::{Pose, Rot3, Vector};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::{Compound, HalfSpace, SharedShape};

pub struct ParryReference {
    pattern: ScanPattern,
    world: World,
    hit_floor: bool,
    /// Every enabled box, as (world pose, cuboid); `None` if there is none.
    compound: Option<Compound>,
}

fn placed(b: &WorldBox) -> (Pose, SharedShape) {
    let zc = 0.5 * (b.z_min + b.z_max);
    let pose = Pose::from_parts(
        Vector::new(b.center[0] as f32, b.center[1] as f32, zc as f32),
        Rot3::from_rotation_z(b.yaw as f32),
    );
    let shape = SharedShape::cuboid(
        b.half[0] as f32,
        b.half[1] as f32,
        (0.5 * (b.z_max - b.z_min)) as f32,
    );
    (pose, shape)
}

fn contains(b: &WorldBox, p: [f64; 3]) -> bool {
    let (s, c) = b.yaw.sin_cos();
    let dx = p[0] - b.center[0];
    let dy = p[1] - b.center[1];
    (c * dx + s * dy).abs() <= b.half[0]
        && (-s * dx + c * dy).abs() <= b.half[1]
        && p[2] >= b.z_min
        && p[2] <= b.z_max
}

impl ParryReference {
    pub fn new(config: &LidarConfig, scene: &Scene) -> Result<ParryReference, LidarError> {
        let mut r = ParryReference {
            pattern: ScanPattern::new(config)?,
            world: World::from_scene(scene)?,
            hit_floor: config.hit_floor,
            compound: None,
        };
        r.rebuild();
        Ok(r)
    }

    fn build(world: &World, skip_containing: Option<[f64; 3]>) -> Option<Compound> {
        let shapes: Vec<(Pose, SharedShape)> = world
            .enabled_boxes()
            .filter(|b| skip_containing.is_none_or(|p| !contains(b, p)))
            .map(placed)
            .collect();
        (!shapes.is_empty()).then(|| Compound::new(shapes))
    }

    fn rebuild(&mut self) {
        self.compound = Self::build(&self.world, None);
    }

    pub fn set_body_pose(&mut self, index: usize, pose: Pose2) -> Result<(), LidarError> {
        self.world.set_body_pose(index, pose)?;
        self.rebuild();
        Ok(())
    }

    pub fn set_body_enabled(&mut self, index: usize, enabled: bool) -> Result<(), LidarError> {
        self.world.set_body_enabled(index, enabled)?;
        self.rebuild();
        Ok(())
    }

    pub fn len(&self) -> usize {
        self.pattern.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pattern.is_empty()
    }

    /// Noise-free organised scan, same layout as the fast path.
    pub fn scan(&self, sensor: &SensorPose, out: &mut [[f32; 3]]) -> Result<usize, LidarError> {
        if out.len() != self.pattern.len() {
            return Err(LidarError::BufferSize {
                expected: self.pattern.len(),
                got: out.len(),
            });
        }
        if !sensor.is_valid() {
            return Err(LidarError::BadSensorPose);
        }
        let inside = self
            .world
            .enabled_boxes()
            .any(|b| contains(b, sensor.position));
        let filtered;
        let compound = if inside {
            filtered = Self::build(&self.world, Some(sensor.position));
            filtered.as_ref()
        } else {
            self.compound.as_ref()
        };
        let floor = HalfSpace::new(Vector::Z);
        let origin = Vector::new(
            sensor.position[0] as f32,
            sensor.position[1] as f32,
            sensor.position[2] as f32,
        );
        let max = self.pattern.max_range;
        let mut hits = 0;
        for row in 0..self.pattern.rows() {
            for col in 0..self.pattern.columns() {
                let d = sensor.vector_to_world(self.pattern.direction_f64(row, col));
                let ray = Ray::new(origin, Vector::new(d[0] as f32, d[1] as f32, d[2] as f32));
                let mut best = compound.and_then(|c| c.cast_ray(&Pose::IDENTITY, &ray, max, true));
                if self.hit_floor
                    && sensor.position[2] > 0.0
                    && let Some(t) = floor.cast_ray(&Pose::IDENTITY, &ray, max, true)
                {
                    best = Some(best.map_or(t, |b: f32| b.min(t)));
                }
                let i = self.pattern.index(row, col);
                out[i] = match best {
                    Some(t) => {
                        hits += 1;
                        let ds = self.pattern.direction(row, col);
                        [t * ds[0], t * ds[1], t * ds[2]]
                    }
                    None => [f32::NAN; 3],
                };
            }
        }
        Ok(hits)
    }
}
