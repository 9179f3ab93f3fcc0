//! `World`: the scene's boxes flattened into one array, with per-body poses that can
//! change between scans (the carried rack, any movable body).
//!
//! Each box keeps its part geometry (body frame) and its world placement (planar centre,
//! yaw, z interval). Moving a body rewrites only that body's boxes and re-buckets them in
//! the grid index (`grid.rs`), through which a scan gathers the boxes near the sensor.
//! Knows nothing of rays or of the sensor.

use crate::error::LidarError;
use crate::grid::{self, BoxGrid, Near};
use aisle_config::scene::Scene;
use aisle_geometry::Pose2;

/// One box in the world: axis-aligned in its body's frame, so a yaw plus a z interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorldBox {
    pub body: u32,
    /// Part centre in the body frame (x, y) and half sizes (x, y).
    pub local: [f64; 2],
    pub half: [f64; 2],
    /// World placement, recomputed from the body pose.
    pub center: [f64; 2],
    pub yaw: f64,
    pub z_min: f64,
    pub z_max: f64,
}

impl WorldBox {
    /// Its axis-aligned rectangle on the floor plane: x0, y0, x1, y1.
    pub fn bounds(&self) -> [f64; 4] {
        grid::bounds(self.center, self.half, self.yaw)
    }
}

#[derive(Debug, Clone)]
struct BodyEntry {
    name: String,
    pose: Pose2,
    enabled: bool,
    boxes: std::ops::Range<usize>,
}

#[derive(Debug, Clone)]
pub struct World {
    bodies: Vec<BodyEntry>,
    boxes: Vec<WorldBox>,
    grid: BoxGrid,
}

impl World {
    pub fn from_scene(scene: &Scene) -> Result<World, LidarError> {
        let mut bodies = Vec::with_capacity(scene.bodies.len());
        let mut boxes = Vec::new();
        for (i, b) in scene.bodies.iter().enumerate() {
            if !b.pose.is_finite() {
                return Err(LidarError::BodyPose {
                    name: b.name.clone(),
                });
            }
            let start = boxes.len();
            for p in &b.parts {
                let ok = p.size.iter().all(|s| s.is_finite() && *s > 0.0)
                    && p.center.iter().all(|c| c.is_finite());
                if !ok {
                    return Err(LidarError::BodyPart {
                        name: b.name.clone(),
                    });
                }
                boxes.push(WorldBox {
                    body: i as u32,
                    local: [p.center[0], p.center[1]],
                    half: [0.5 * p.size[0], 0.5 * p.size[1]],
                    center: [0.0; 2],
                    yaw: 0.0,
                    z_min: p.z_min(),
                    z_max: p.z_max(),
                });
            }
            bodies.push(BodyEntry {
                name: b.name.clone(),
                pose: b.pose,
                enabled: true,
                boxes: start..boxes.len(),
            });
        }
        let mut w = World {
            bodies,
            boxes,
            grid: BoxGrid::new(&[]),
        };
        for i in 0..w.bodies.len() {
            w.place(i);
        }
        let rects: Vec<[f64; 4]> = w.boxes.iter().map(WorldBox::bounds).collect();
        w.grid = BoxGrid::new(&rects);
        Ok(w)
    }

    /// Places the boxes of `body` at its pose (the grid is the caller's business).
    fn place(&mut self, body: usize) {
        let e = &self.bodies[body];
        for b in &mut self.boxes[e.boxes.clone()] {
            let (x, y) = e.pose.transform_point(b.local[0], b.local[1]);
            b.center = [x, y];
            b.yaw = e.pose.theta;
        }
    }

    fn check(&self, index: usize) -> Result<(), LidarError> {
        if index < self.bodies.len() {
            Ok(())
        } else {
            Err(LidarError::BodyIndex {
                index,
                len: self.bodies.len(),
            })
        }
    }

    /// Moves one body; O(number of its parts).
    pub fn set_body_pose(&mut self, index: usize, pose: Pose2) -> Result<(), LidarError> {
        self.check(index)?;
        if !pose.is_finite() {
            return Err(LidarError::BodyPose {
                name: self.bodies[index].name.clone(),
            });
        }
        self.bodies[index].pose = pose;
        self.place(index);
        for i in self.bodies[index].boxes.clone() {
            self.grid.update(i, &self.boxes[i].bounds());
        }
        Ok(())
    }

    /// A disabled body is never hit (e.g. the robot itself, if the caller's scene has it).
    pub fn set_body_enabled(&mut self, index: usize, enabled: bool) -> Result<(), LidarError> {
        self.check(index)?;
        self.bodies[index].enabled = enabled;
        Ok(())
    }

    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    pub fn body_pose(&self, index: usize) -> Option<Pose2> {
        self.bodies.get(index).map(|b| b.pose)
    }

    pub fn body_enabled(&self, index: usize) -> Option<bool> {
        self.bodies.get(index).map(|b| b.enabled)
    }

    pub fn body_count(&self) -> usize {
        self.bodies.len()
    }

    pub fn box_count(&self) -> usize {
        self.boxes.len()
    }

    /// The boxes of enabled bodies.
    pub fn enabled_boxes(&self) -> impl Iterator<Item = &WorldBox> {
        self.boxes
            .iter()
            .filter(|b| self.bodies[b.body as usize].enabled)
    }

    /// Lists in `near.list`, in box order, the boxes that may lie within `radius`
    /// (metres, horizontally) of `center`: a superset, through the grid. `near` is the
    /// caller's scratch, so nothing is allocated once it has grown.
    pub(crate) fn gather_near(&self, center: [f64; 2], radius: f64, near: &mut Near) {
        self.grid.gather(center, radius, near);
    }

    /// Box `index` if its body is enabled.
    #[inline]
    pub(crate) fn enabled_box(&self, index: u32) -> Option<&WorldBox> {
        let b = &self.boxes[index as usize];
        self.bodies[b.body as usize].enabled.then_some(b)
    }
}
