//! The general path: a scan from a sensor with any orientation (rolled or pitched).
//!
//! Boxes become oriented boxes in the sensor frame, so each ray runs a 3D slab test.
//! Per scan the boxes near the sensor (the grid's superset of those within range) are
//! moved to the sensor frame once, culled by range and by the elevations they span, and
//! given the columns they can occupy (`place.rs`). A sweep over columns (`sweep.rs`)
//! visits the boxes whose span covers the column nearest first and stops at the first
//! one beyond every row's best hit, testing only the rows a box's bounding box allows.
//! Which boxes are tested does not change the result (the nearest entry of every box
//! that can be hit), so the points equal those of a test against every box.
//!
//! With two threads (`LidarConfig::scan_threads`) a helper thread (`helper.rs`) sweeps
//! the second half of the columns while the calling thread sweeps the first: columns
//! are independent, so the points are the same bits either way. Knows nothing of noise.

mod helper;
mod place;
mod sweep;

use crate::SensorPose;
use crate::grid::Near;
use crate::pattern::ScanPattern;
use crate::world::World;
use helper::Helper;
use place::Placement;
use std::sync::Arc;
use sweep::Lane;

pub(crate) use sweep::tan_bounds;

/// Fewer columns than this are swept on the calling thread alone.
const MIN_SPLIT_COLUMNS: usize = 64;

#[derive(Debug)]
pub(crate) struct GeneralCaster {
    /// The scan's placed boxes; shared with the helper while it sweeps, else owned.
    placement: Arc<Placement>,
    near: Near,
    lane: Lane,
    threads: usize,
    /// `None` with one thread, when the OS refused one, or once it has gone.
    helper: Option<Helper>,
    /// The helper's buffer between jobs.
    helper_out: Vec<[f32; 3]>,
    spans: usize,
}

impl Clone for GeneralCaster {
    /// A copy with its own placement and its own helper thread.
    fn clone(&self) -> Self {
        GeneralCaster {
            placement: Arc::new((*self.placement).clone()),
            near: self.near.clone(),
            lane: self.lane.clone(),
            threads: self.threads,
            helper: (self.threads >= 2)
                .then(|| Helper::start(self.placement.pattern.rows(), self.spans))
                .flatten(),
            helper_out: Vec::with_capacity(helper_points(&self.placement.pattern)),
            spans: self.spans,
        }
    }
}

impl GeneralCaster {
    /// `threads`: 1, or 2 to sweep half the columns on a helper thread.
    pub(crate) fn new(box_count: usize, pattern: &ScanPattern, threads: usize) -> GeneralCaster {
        // A box can straddle the +-pi seam of a 360 deg scan: up to three spans.
        let spans = 3 * box_count;
        GeneralCaster {
            placement: Arc::new(Placement::new(box_count, pattern)),
            near: Near::new(box_count),
            lane: Lane::new(pattern.rows(), spans),
            threads,
            // Started now rather than on the first tilted scan, so that no scan
            // allocates (a thread and its slot do).
            helper: (threads >= 2)
                .then(|| Helper::start(pattern.rows(), spans))
                .flatten(),
            helper_out: Vec::with_capacity(helper_points(pattern)),
            spans,
        }
    }

    /// Casts every ray of the pattern from `sensor` into `out` (organised, sensor
    /// frame); returns the returns.
    pub(crate) fn scan(
        &mut self,
        world: &World,
        sensor: &SensorPose,
        hit_floor: bool,
        out: &mut [[f32; 3]],
    ) -> usize {
        // The helper has given its share back by now (only one that ended while holding
        // it could keep one, and then this copies).
        Arc::make_mut(&mut self.placement).place(world, sensor, hit_floor, &mut self.near);
        let (rows, cols) = (
            self.placement.pattern.rows(),
            self.placement.pattern.columns(),
        );
        let split = if self.helper.is_some() && cols >= MIN_SPLIT_COLUMNS {
            cols / 2
        } else {
            cols
        };
        let sent = split < cols
            && self.helper.as_ref().is_some_and(|h| {
                let buffer = std::mem::take(&mut self.helper_out);
                h.send(Arc::clone(&self.placement), split..cols, buffer)
            });
        if split < cols && !sent {
            self.helper = None;
        }
        let own = if sent { split } else { cols };
        let mut hits = self.lane.sweep(&self.placement, 0..own, out, cols);
        if !sent {
            return hits;
        }
        match self.helper.as_ref().and_then(Helper::wait) {
            Some(done) => {
                let w = cols - split;
                for row in 0..rows {
                    out[row * cols + split..(row + 1) * cols]
                        .copy_from_slice(&done.out[row * w..(row + 1) * w]);
                }
                self.helper_out = done.out;
                hits + done.hits
            }
            None => {
                // The helper has gone: the rest on this thread, and no helper again.
                self.helper = None;
                hits += self
                    .lane
                    .sweep(&self.placement, split..cols, &mut out[split..], cols);
                hits
            }
        }
    }
}

/// The points of the helper's half of the columns.
fn helper_points(pattern: &ScanPattern) -> usize {
    let cols = pattern.columns();
    pattern.rows() * (cols - cols / 2)
}
