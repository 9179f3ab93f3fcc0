//! The general path: a scan from a sensor with any orientation (rolled or pitched).
//!
//! Boxes become oriented boxes in the sensor frame, so each ray runs a 3D slab test.
//! Per scan every box is moved to the sensor frame once and culled by range; per column
//! only the boxes whose bounding sphere meets the column's half-plane are kept, in order
//! of their nearest possible hit, so a ray stops early. Correct for every pose, but
//! several times slower than `planar`; the simulator's robot stays level, so this is
//! only used if a caller passes a tilted pose. Knows nothing of noise.

use crate::SensorPose;
use crate::pattern::ScanPattern;
use crate::world::World;

/// An oriented box in the sensor frame.
#[derive(Debug, Clone, Copy, Default)]
struct SensorObb {
    center: [f32; 3],
    /// Box axes in the sensor frame (rows).
    axes: [[f32; 3]; 3],
    /// Sensor origin in the box frame.
    origin: [f32; 3],
    half: [f32; 3],
    radius: f32,
    /// Lower bound on the distance of any hit: |center| - radius.
    near: f32,
}

/// A box as seen by one column: ray direction in the box frame is
/// `cos e * a + sin e * b`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    a: [f32; 3],
    b: [f32; 3],
    origin: [f32; 3],
    half: [f32; 3],
    near: f32,
}

#[derive(Debug, Clone)]
pub(crate) struct GeneralCaster {
    obbs: Vec<SensorObb>,
    cands: Vec<Candidate>,
}

impl GeneralCaster {
    pub(crate) fn new(box_count: usize) -> GeneralCaster {
        GeneralCaster {
            obbs: Vec::with_capacity(box_count),
            cands: Vec::with_capacity(box_count),
        }
    }

    pub(crate) fn scan(
        &mut self,
        pattern: &ScanPattern,
        world: &World,
        sensor: &SensorPose,
        hit_floor: bool,
        out: &mut [[f32; 3]],
    ) -> usize {
        let range = pattern.max_range;
        self.place_boxes(world, sensor, range);
        let r = &sensor.rotation;
        let height = sensor.position[2];
        let rows = pattern.rows();
        let cols = pattern.columns();
        let mut hits = 0;
        for col in 0..cols {
            let ca = pattern.cos_az[col];
            let sa = pattern.sin_az[col];
            self.column_candidates(ca, sa);
            // World z of the column's horizontal direction, for the floor.
            let gz_h = (r[2][0] * f64::from(ca) + r[2][1] * f64::from(sa)) as f32;
            for row in 0..rows {
                let ce = pattern.cos_el[row];
                let se = pattern.sin_el[row];
                let mut best = range;
                let mut hit = false;
                let dz = ce * gz_h + se * r[2][2] as f32;
                if hit_floor && dz < 0.0 && height > 0.0 {
                    let t = (height / f64::from(-dz)) as f32;
                    if t <= best {
                        best = t;
                        hit = true;
                    }
                }
                hit |= self.nearest_box(ce, se, &mut best);
                out[row * cols + col] = if hit {
                    hits += 1;
                    let d = pattern.direction(row, col);
                    [best * d[0], best * d[1], best * d[2]]
                } else {
                    [f32::NAN; 3]
                };
            }
        }
        hits
    }

    /// Moves every enabled box into the sensor frame, drops those that hold the sensor
    /// or lie beyond `range`, and sorts the rest by their nearest possible hit.
    fn place_boxes(&mut self, world: &World, sensor: &SensorPose, range: f32) {
        self.obbs.clear();
        for b in world.enabled_boxes() {
            let zc = 0.5 * (b.z_min + b.z_max);
            let rel = [
                b.center[0] - sensor.position[0],
                b.center[1] - sensor.position[1],
                zc - sensor.position[2],
            ];
            let c = sensor.vector_to_sensor(rel);
            let (sy, cy) = b.yaw.sin_cos();
            let axes = [
                sensor.vector_to_sensor([cy, sy, 0.0]),
                sensor.vector_to_sensor([-sy, cy, 0.0]),
                sensor.vector_to_sensor([0.0, 0.0, 1.0]),
            ];
            let half = [b.half[0], b.half[1], 0.5 * (b.z_max - b.z_min)];
            let origin: [f64; 3] = std::array::from_fn(|i| -dot(axes[i], c));
            if (0..3).all(|i| origin[i].abs() <= half[i]) {
                // The sensor is inside this box: it sees out of it, not its walls.
                continue;
            }
            let radius = (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt();
            let near = dot(c, c).sqrt() - radius;
            if near > f64::from(range) {
                continue;
            }
            self.obbs.push(SensorObb {
                center: c.map(|v| v as f32),
                axes: axes.map(|a| a.map(|v| v as f32)),
                origin: origin.map(|v| v as f32),
                half: half.map(|v| v as f32),
                radius: radius as f32,
                near: near as f32,
            });
        }
        self.obbs.sort_unstable_by(|a, b| a.near.total_cmp(&b.near));
    }

    /// Keeps, in order of nearest hit, the boxes whose bounding sphere meets the
    /// half-plane of the column at azimuth (cos `ca`, sin `sa`).
    #[inline]
    fn column_candidates(&mut self, ca: f32, sa: f32) {
        self.cands.clear();
        for o in &self.obbs {
            // The column's rays lie in the half-plane spanned by (ca, sa, 0), cos e >= 0,
            // and the sensor z axis.
            let across = -sa * o.center[0] + ca * o.center[1];
            let along = ca * o.center[0] + sa * o.center[1];
            if across.abs() > o.radius || along < -o.radius {
                continue;
            }
            self.cands.push(Candidate {
                a: o.axes.map(|ax| ax[0] * ca + ax[1] * sa),
                b: o.axes.map(|ax| ax[2]),
                origin: o.origin,
                half: o.half,
                near: o.near,
            });
        }
    }

    /// Lowers `best` to the nearest entry into a candidate of the ray at elevation
    /// (cos `ce`, sin `se`) of the current column; whether any candidate was hit.
    #[inline]
    fn nearest_box(&self, ce: f32, se: f32, best: &mut f32) -> bool {
        let mut hit = false;
        for cand in &self.cands {
            if cand.near > *best {
                break;
            }
            if let Some(t) = entry(cand, ce, se)
                && t <= *best
            {
                *best = t;
                hit = true;
            }
        }
        hit
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Entry distance of the ray into the box, if it enters at t >= 0.
#[inline]
fn entry(c: &Candidate, ce: f32, se: f32) -> Option<f32> {
    let mut t0 = 0.0f32;
    let mut t1 = f32::INFINITY;
    for i in 0..3 {
        let d = ce * c.a[i] + se * c.b[i];
        let o = c.origin[i];
        let h = c.half[i];
        if d != 0.0 {
            let inv = 1.0 / d;
            let ta = (-h - o) * inv;
            let tb = (h - o) * inv;
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        } else if o.abs() > h {
            return None;
        }
    }
    (t0 <= t1).then_some(t0)
}
