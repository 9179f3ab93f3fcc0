//! The motion model and cost model of the search, derived once from the configuration:
//! the primitive set (arcs left, straight, right, forward and reverse, plus rotations on
//! the spot), what each motion costs, and the analytic connections to the goal
//! (Reeds-Shepp words and rotate-drive-rotate) with their costs.
//!
//! Knows nothing of grids or collision; pure arithmetic on poses.

// Bit for bit `aisle_geometry::wrap_angle`, without its `fmod` call within one turn.
use crate::angle::wrap as wrap_angle;
use crate::config::PlannerConfig;
use crate::motion::Motion;
use crate::reeds_shepp::{Candidates, RsPath};
use aisle_geometry::Pose2;
use std::f64::consts::{PI, TAU};

/// Direction codes stored in search nodes.
pub(crate) const DIR_NONE: i8 = 2;
pub(crate) const DIR_FWD: i8 = 1;
pub(crate) const DIR_REV: i8 = -1;
pub(crate) const DIR_ROT: i8 = 0;

/// A connection to the goal made of at most five motions.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shot {
    pub cost: f64,
    pub motions: [Motion; 5],
    pub len: usize,
}

impl Shot {
    pub fn motions(&self) -> &[Motion] {
        &self.motions[..self.len]
    }
}

#[derive(Debug, Clone)]
pub(crate) struct Model {
    pub radius: f64,
    pub bins: u32,
    pub bin_width: f64,
    /// The primitives: `regular` of them for every node, then the short straight
    /// moves that only a start inside the margin gets (`search_core.rs`, `expand`).
    pub prims: Vec<Motion>,
    pub prim_cost: Vec<f64>,
    pub prim_dir: Vec<i8>,
    pub regular: usize,
    forward_cost: f64,
    reverse_cost: f64,
    switch_cost: f64,
    steering_penalty: f64,
    rotation_cost: f64,
    pub allow_rotation: bool,
    /// The cheapest cost of one metre of travel, to turn grid distance into cost.
    pub min_cost_per_metre: f64,
}

impl Model {
    pub fn new(cfg: &PlannerConfig) -> Self {
        let radius = cfg.min_turning_radius;
        let bin_width = TAU / f64::from(cfg.heading_bins);
        // Every primitive must leave its search cell: at least one cell diagonal.
        let leave = 1.05 * std::f64::consts::SQRT_2 * cfg.search_resolution;
        let min_len = cfg.primitive_length.max(leave);
        let k = (min_len / (radius * bin_width)).ceil().max(1.0);
        let length = k * radius * bin_width;
        let mut m = Self {
            radius,
            bins: cfg.heading_bins,
            bin_width,
            prims: Vec::new(),
            prim_cost: Vec::new(),
            prim_dir: Vec::new(),
            regular: 0,
            forward_cost: cfg.forward_cost,
            reverse_cost: cfg.reverse_cost,
            switch_cost: cfg.direction_switch_cost,
            steering_penalty: cfg.steering_penalty,
            rotation_cost: cfg.rotation_cost,
            allow_rotation: cfg.allow_rotation,
            min_cost_per_metre: cfg.forward_cost.min(cfg.reverse_cost),
        };
        for sign in [1.0, -1.0] {
            for curvature in [1.0 / radius, 0.0, -1.0 / radius] {
                let motion = Motion::Drive {
                    length: sign * length,
                    curvature,
                };
                m.push_prim(motion);
            }
        }
        if cfg.allow_rotation {
            let angle = f64::from(cfg.rotation_step_bins) * bin_width;
            for sign in [1.0, -1.0] {
                let motion = Motion::Rotate {
                    angle: sign * angle,
                };
                m.push_prim(motion);
            }
        }
        m.regular = m.prims.len();
        // A robot standing inside the margin between two obstacles may have no room for
        // a whole primitive either way (a 0.26 m move reaches one or the other) where a
        // shorter one takes it to where it can turn: the shortest move that still leaves
        // its search cell, forwards and backwards.
        if leave < cfg.primitive_length {
            for sign in [1.0, -1.0] {
                let motion = Motion::Drive {
                    length: sign * leave,
                    curvature: 0.0,
                };
                m.push_prim(motion);
            }
        }
        m
    }

    /// Adds a primitive with its cost and direction.
    fn push_prim(&mut self, motion: Motion) {
        self.prim_cost.push(self.motion_cost(&motion));
        self.prim_dir.push(Self::dir_of(&motion));
        self.prims.push(motion);
    }

    pub fn dir_of(motion: &Motion) -> i8 {
        match *motion {
            Motion::Drive { length, .. } if length < 0.0 => DIR_REV,
            Motion::Drive { .. } => DIR_FWD,
            _ => DIR_ROT,
        }
    }

    /// Cost of one motion, without direction-switch charges.
    pub fn motion_cost(&self, m: &Motion) -> f64 {
        match *m {
            Motion::Drive { length, curvature } => {
                let per_metre = if length < 0.0 {
                    self.reverse_cost
                } else {
                    self.forward_cost
                };
                let steer = if curvature != 0.0 {
                    1.0 + self.steering_penalty
                } else {
                    1.0
                };
                length.abs() * per_metre * steer
            }
            Motion::Rotate { angle } => angle.abs() * self.rotation_cost,
            Motion::Lerp { .. } => 0.0,
        }
    }

    /// Charge for going from direction `a` to direction `b`.
    #[inline]
    pub fn switch(&self, a: i8, b: i8) -> f64 {
        if (a == DIR_FWD && b == DIR_REV) || (a == DIR_REV && b == DIR_FWD) {
            self.switch_cost
        } else {
            0.0
        }
    }

    /// Cost of an analytic connection entered after moving in direction `dir`.
    fn chain_cost(&self, motions: &[Motion], mut dir: i8) -> f64 {
        let mut c = 0.0;
        for m in motions {
            let d = Self::dir_of(m);
            c += self.motion_cost(m) + self.switch(dir, d);
            dir = d;
        }
        c
    }

    pub fn rs_shot(&self, p: &RsPath, entry_dir: i8) -> Shot {
        let mut shot = Shot {
            cost: 0.0,
            motions: [Motion::Rotate { angle: 0.0 }; 5],
            len: 0,
        };
        for m in p.motions(self.radius) {
            shot.motions[shot.len] = m;
            shot.len += 1;
        }
        shot.cost = self.chain_cost(shot.motions(), entry_dir);
        shot
    }

    /// Turn on the spot towards (or away from) the goal, drive straight, turn to the
    /// goal heading. Returns the forward and the reverse variant.
    pub fn rtr_shots(&self, from: &Pose2, goal: &Pose2, entry_dir: i8) -> [Shot; 2] {
        let d = from.distance(goal);
        let towards = if d < 1e-9 {
            from.theta
        } else {
            (goal.y - from.y).atan2(goal.x - from.x)
        };
        let mut out = [Shot {
            cost: 0.0,
            motions: [Motion::Rotate { angle: 0.0 }; 5],
            len: 0,
        }; 2];
        for (k, (heading, length)) in [(towards, d), (towards + PI, -d)].into_iter().enumerate() {
            let shot = &mut out[k];
            let a1 = wrap_angle(heading - from.theta);
            let a2 = wrap_angle(goal.theta - heading);
            for m in [
                Motion::Rotate { angle: a1 },
                Motion::Drive {
                    length,
                    curvature: 0.0,
                },
                Motion::Rotate { angle: a2 },
            ] {
                let empty = match m {
                    Motion::Rotate { angle } => angle.abs() < 1e-12,
                    Motion::Drive { length, .. } => length.abs() < 1e-12,
                    Motion::Lerp { .. } => true,
                };
                if !empty {
                    shot.motions[shot.len] = m;
                    shot.len += 1;
                }
            }
            shot.cost = self.chain_cost(shot.motions(), entry_dir);
        }
        out
    }

    /// The non-holonomic part of the heuristic: the cheapest obstacle-free connection
    /// (Reeds-Shepp under this cost model, or rotate-drive-rotate when allowed).
    pub fn free_space_cost(&self, from: &Pose2, goal: &Pose2, rs: &mut Candidates) -> f64 {
        crate::reeds_shepp::solve(from, goal, self.radius, rs);
        let mut best = rs
            .as_slice()
            .iter()
            .map(|p| self.rs_shot(p, DIR_NONE).cost)
            .fold(f64::INFINITY, f64::min);
        if self.allow_rotation {
            for s in self.rtr_shots(from, goal, DIR_NONE) {
                best = best.min(s.cost);
            }
        }
        best
    }

    /// Heading bin of an angle.
    #[inline]
    pub fn bin(&self, theta: f64) -> u32 {
        ((theta / self.bin_width).round() as i64).rem_euclid(i64::from(self.bins)) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primitives_land_on_whole_bins_and_cost_as_configured() {
        let cfg = PlannerConfig::default();
        let m = Model::new(&cfg);
        assert_eq!(m.regular, 8);
        assert_eq!(m.prims.len(), 10);
        let o = Pose2::default();
        for (i, (p, c)) in m.prims.iter().zip(&m.prim_cost).enumerate() {
            let e = p.end(&o);
            let bins = e.theta / m.bin_width;
            assert!((bins - bins.round()).abs() < 1e-9);
            if let Motion::Drive { length, .. } = p {
                // The regular ones as long as configured; the start's short ones leave
                // their cell (next assertion).
                assert_eq!(length.abs() >= cfg.primitive_length, i < m.regular);
                assert!(e.distance(&o) > std::f64::consts::SQRT_2 * cfg.search_resolution);
                let per_m = if *length < 0.0 { 3.0 } else { 1.0 };
                assert!(*c >= per_m * length.abs() - 1e-12);
            }
        }
        assert_eq!(m.switch(DIR_FWD, DIR_REV), cfg.direction_switch_cost);
        assert_eq!(m.switch(DIR_FWD, DIR_ROT), 0.0);
        assert_eq!(m.bin(-1e-9), 0);
        assert_eq!(m.bin(PI), 36);
        assert_eq!(m.bin(-PI), 36);
    }

    #[test]
    fn reversing_costs_three_times_forward() {
        let m = Model::new(&PlannerConfig::default());
        let mut rs = Candidates::default();
        let o = Pose2::default();
        let ahead = m.free_space_cost(&o, &Pose2::new(2.0, 0.0, 0.0), &mut rs);
        let behind = m.free_space_cost(&o, &Pose2::new(-2.0, 0.0, 0.0), &mut rs);
        assert!((ahead - 2.0).abs() < 1e-9, "{ahead}");
        // Backing up 2 m costs 6 unless rotating on the spot (2 * pi * 1.5) is cheaper.
        assert!((behind - 6.0).abs() < 1e-9, "{behind}");
        let rtr = m.rtr_shots(&o, &Pose2::new(0.0, 0.0, PI / 2.0), DIR_NONE);
        assert_eq!(rtr[0].len, 1);
        assert!((rtr[0].cost - 1.5 * PI / 2.0).abs() < 1e-9);
    }
}
