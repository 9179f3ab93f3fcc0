//! The structure of one subproblem as the interior-point iterations see it, and the
//! Newton system they solve each iteration: (P + G' M G) dx = r, where M is the
//! block-diagonal W^-2 of the cone blocks (a scalar for each row of the non-negative
//! part, a 3 x 3 matrix for each second-order cone).
//!
//! Two properties of the TEB subproblems make that system cheap, and both are checked
//! here rather than assumed:
//! - every slack column (a column without a quadratic term) shares no row or cone with
//!   another slack, so the slack part of the matrix is diagonal and each slack is
//!   eliminated on its own (a Schur complement of one entry);
//! - in the caller's elimination order of the core columns (`Data::position`: for the
//!   band, each pose beside its time step) the remaining matrix is banded.
//!
//! Rows are scaled to a largest coefficient of 1 (one factor for a cone's three rows),
//! so the iterations work on rows of one size; `row_scale` says by how much. Knows
//! nothing of cones beyond the matrix of each it is given, nor of the iterations.

use super::banded::Banded;
use super::data::Data;
use super::pairs::Pairs;

mod products;

/// No position: the entry is the row's slack.
const SLACK: usize = usize::MAX;

/// The rows of G, the slacks and the reduced banded matrix.
#[derive(Default)]
pub(super) struct Kkt {
    n_core: usize,
    /// Non-negative rows ("rays") and second-order cones.
    pub n_ray: usize,
    pub n_cone: usize,
    ray_ptr: Vec<usize>,
    ray_col: Vec<usize>,
    /// Elimination position of each entry's column, SLACK for a slack.
    ray_pos: Vec<usize>,
    ray_val: Vec<f64>,
    cone_ptr: Vec<usize>,
    cone_col: Vec<usize>,
    cone_pos: Vec<usize>,
    cone_val: Vec<[f64; 3]>,
    /// Per row of G: the factor it was scaled by.
    pub row_scale: Vec<f64>,
    /// Rays and cones without a slack.
    free_rays: Vec<usize>,
    free_cones: Vec<usize>,
    /// Per slack (column - n_core): its rays and cones (a cone k as n_ray + k), the
    /// core positions it couples with and their entries of the slack's column of the
    /// matrix, and its diagonal entry.
    sl_ptr: Vec<usize>,
    sl_items: Vec<usize>,
    nb_ptr: Vec<usize>,
    nb_pos: Vec<usize>,
    hcs: Vec<f64>,
    hss: Vec<f64>,
    /// P's nonzeros as (position, position, value), as (offset in the band, value) and
    /// as (column, column, value).
    p_entries: Vec<(usize, usize, f64)>,
    p_band: Vec<(usize, f64)>,
    p_cols: Vec<(usize, usize, f64)>,
    /// Where the products of each row's and each cone's entries land in the band, and
    /// those of each slack's neighbours (per slack, its pairs from `nb_pair_ptr`).
    ray_pairs: Pairs<f64>,
    cone_pairs: Pairs<[f64; 3]>,
    nb_pair_ptr: Vec<usize>,
    nb_pairs: Vec<usize>,
    item_slack: Vec<usize>,
    counts: Vec<usize>,
    pos: Vec<usize>,
    band: Banded,
    scratch: Vec<f64>,
    /// The reduced matrix's half-bandwidth (for diagnostics and tests).
    pub bandwidth: usize,
}

impl Kkt {
    /// Reads the structure of `d`, with P scaled by `cost_scale`. False when it lacks
    /// the properties this solver relies on (two slacks in one row or cone).
    pub fn analyse(&mut self, d: &Data, cost_scale: f64) -> bool {
        self.n_core = d.n_core;
        self.pos.clear();
        self.pos.extend_from_slice(d.position);
        self.read_rays(d);
        self.read_cones(d);
        if !self.find_slacks(d) {
            return false;
        }
        self.p_entries.clear();
        self.p_cols.clear();
        let nc = d.n_core;
        for r in 0..nc {
            for c in r..nc {
                let v = d.p_dense[r * nc + c];
                if v != 0.0 {
                    self.p_entries
                        .push((self.pos[r], self.pos[c], cost_scale * v));
                    self.p_cols.push((r, c, cost_scale * v));
                }
            }
        }
        self.bandwidth = self.find_bandwidth();
        self.band.reset(nc, self.bandwidth);
        self.find_offsets();
        self.scratch.clear();
        self.scratch.resize(nc, 0.0);
        true
    }

    fn find_bandwidth(&self) -> usize {
        let span = |pos: &[usize]| {
            let core = pos.iter().filter(|&&p| p != SLACK);
            match (core.clone().min(), core.max()) {
                (Some(lo), Some(hi)) => hi - lo,
                _ => 0,
            }
        };
        let mut bw = self
            .p_entries
            .iter()
            .map(|&(a, b, _)| a.abs_diff(b))
            .max()
            .unwrap_or(0);
        for &r in &self.free_rays {
            bw = bw.max(span(&self.ray_pos[self.ray_ptr[r]..self.ray_ptr[r + 1]]));
        }
        for &k in &self.free_cones {
            bw = bw.max(span(&self.cone_pos[self.cone_ptr[k]..self.cone_ptr[k + 1]]));
        }
        for s in 0..self.hss.len() {
            bw = bw.max(span(&self.nb_pos[self.nb_ptr[s]..self.nb_ptr[s + 1]]));
        }
        bw
    }

    /// The band offsets of P's entries, of the products within each row and cone, and
    /// of the products of each slack's neighbours.
    fn find_offsets(&mut self) {
        let band = &self.band;
        self.p_band.clear();
        self.p_band.extend(
            self.p_entries
                .iter()
                .map(|&(a, b, v)| (band.offset(a, b), v)),
        );
        self.ray_pairs
            .build(&self.ray_ptr, &self.ray_pos, &self.ray_val, SLACK, band);
        self.cone_pairs
            .build(&self.cone_ptr, &self.cone_pos, &self.cone_val, SLACK, band);
        self.nb_pair_ptr.clear();
        self.nb_pairs.clear();
        for s in 0..self.hss.len() {
            self.nb_pair_ptr.push(self.nb_pairs.len());
            let range = self.nb_ptr[s]..self.nb_ptr[s + 1];
            for i in range.clone() {
                for j in range.start..=i {
                    self.nb_pairs
                        .push(band.offset(self.nb_pos[i], self.nb_pos[j]));
                }
            }
        }
        self.nb_pair_ptr.push(self.nb_pairs.len());
    }

    /// The non-negative rows, each scaled to a largest coefficient of 1.
    fn read_rays(&mut self, d: &Data) {
        self.n_ray = d.lin_b.len();
        self.ray_ptr.clear();
        self.ray_col.clear();
        self.ray_pos.clear();
        self.ray_val.clear();
        self.row_scale.clear();
        self.ray_ptr.push(0);
        let mut k = 0;
        for r in 0..self.n_ray {
            let start = self.ray_val.len();
            while k < d.lin.len() && d.lin[k].0 == r {
                let c = d.lin[k].1;
                self.ray_col.push(c);
                self.ray_pos
                    .push(if c < d.n_core { self.pos[c] } else { SLACK });
                self.ray_val.push(d.lin[k].2);
                k += 1;
            }
            let f = unit_scale(self.ray_val[start..].iter().copied());
            self.ray_val[start..].iter_mut().for_each(|v| *v *= f);
            self.row_scale.push(f);
            self.ray_ptr.push(self.ray_val.len());
        }
    }

    /// The cones, entries merged by column, each scaled by one factor.
    fn read_cones(&mut self, d: &Data) {
        self.n_cone = d.soc_b.len() / 3;
        self.cone_ptr.clear();
        self.cone_col.clear();
        self.cone_pos.clear();
        self.cone_val.clear();
        self.cone_ptr.push(0);
        let mut k = 0;
        for b in 0..self.n_cone {
            let start = self.cone_col.len();
            while k < d.soc.len() && d.soc[k].0 < 3 * (b + 1) {
                let (r, c, v) = d.soc[k];
                let at = match self.cone_col[start..].iter().position(|&x| x == c) {
                    Some(i) => start + i,
                    None => {
                        self.cone_col.push(c);
                        self.cone_pos
                            .push(if c < d.n_core { self.pos[c] } else { SLACK });
                        self.cone_val.push([0.0; 3]);
                        self.cone_col.len() - 1
                    }
                };
                self.cone_val[at][r - 3 * b] += v;
                k += 1;
            }
            let f = unit_scale(self.cone_val[start..].iter().flatten().copied());
            for v in &mut self.cone_val[start..] {
                v.iter_mut().for_each(|x| *x *= f);
            }
            self.row_scale.extend([f; 3]);
            self.cone_ptr.push(self.cone_col.len());
        }
    }

    /// The slack column of a row or cone's entries, NONE if it has none; None when it
    /// has two.
    fn slack_in(cols: &[usize], pos: &[usize]) -> Option<usize> {
        let mut slack = SLACK;
        for (&c, &p) in cols.iter().zip(pos) {
            if p == SLACK {
                if slack != SLACK && slack != c {
                    return None;
                }
                slack = c;
            }
        }
        Some(slack)
    }

    /// Each row and cone's slack, each slack's rows and cones and the core positions
    /// it couples with.
    fn find_slacks(&mut self, d: &Data) -> bool {
        let n_slack = d.n - d.n_core;
        let items = self.n_ray + self.n_cone;
        self.item_slack.clear();
        self.free_rays.clear();
        self.free_cones.clear();
        for i in 0..items {
            let found = if i < self.n_ray {
                let r = self.ray_ptr[i]..self.ray_ptr[i + 1];
                Self::slack_in(&self.ray_col[r.clone()], &self.ray_pos[r])
            } else {
                let k = i - self.n_ray;
                let r = self.cone_ptr[k]..self.cone_ptr[k + 1];
                Self::slack_in(&self.cone_col[r.clone()], &self.cone_pos[r])
            };
            let Some(slack) = found else {
                return false;
            };
            if slack == SLACK {
                if i < self.n_ray {
                    self.free_rays.push(i);
                } else {
                    self.free_cones.push(i - self.n_ray);
                }
            }
            self.item_slack.push(slack);
        }
        self.counts.clear();
        self.counts.resize(n_slack + 1, 0);
        for &s in &self.item_slack {
            if s != SLACK {
                self.counts[s - d.n_core + 1] += 1;
            }
        }
        for s in 0..n_slack {
            self.counts[s + 1] += self.counts[s];
        }
        self.sl_ptr.clear();
        self.sl_ptr.extend_from_slice(&self.counts);
        self.sl_items.clear();
        self.sl_items.resize(self.counts[n_slack], 0);
        for i in 0..items {
            let s = self.item_slack[i];
            if s != SLACK {
                let k = s - d.n_core;
                self.sl_items[self.counts[k]] = i;
                self.counts[k] += 1;
            }
        }
        self.neighbours(n_slack);
        true
    }

    /// Per slack, the sorted core positions of its rows and cones.
    fn neighbours(&mut self, n_slack: usize) {
        self.nb_ptr.clear();
        self.nb_pos.clear();
        self.nb_ptr.push(0);
        for s in 0..n_slack {
            let start = self.nb_pos.len();
            for j in self.sl_ptr[s]..self.sl_ptr[s + 1] {
                let i = self.sl_items[j];
                let pos = if i < self.n_ray {
                    &self.ray_pos[self.ray_ptr[i]..self.ray_ptr[i + 1]]
                } else {
                    let k = i - self.n_ray;
                    &self.cone_pos[self.cone_ptr[k]..self.cone_ptr[k + 1]]
                };
                self.nb_pos.extend(pos.iter().filter(|&&p| p != SLACK));
            }
            self.nb_pos[start..].sort_unstable();
            let mut w = start;
            for r in start..self.nb_pos.len() {
                if w == start || self.nb_pos[r] != self.nb_pos[w - 1] {
                    self.nb_pos[w] = self.nb_pos[r];
                    w += 1;
                }
            }
            self.nb_pos.truncate(w);
            self.nb_ptr.push(w);
        }
        self.hcs.clear();
        self.hcs.resize(self.nb_pos.len(), 0.0);
        self.hss.clear();
        self.hss.resize(n_slack, 0.0);
    }

    /// Builds and factors P + G' M G with the slacks eliminated: `ray_d` the rays'
    /// scalars, `cone_m` the cones' matrices (row-major 3 x 3). False when it is not
    /// positive definite.
    pub fn factor(&mut self, ray_d: &[f64], cone_m: &[[f64; 9]]) -> bool {
        self.band.clear();
        for &(at, v) in &self.p_band {
            self.band.add_at(at, v);
        }
        for i in 0..self.free_rays.len() {
            let r = self.free_rays[i];
            self.add_ray(r, ray_d[r], 0);
        }
        for i in 0..self.free_cones.len() {
            let k = self.free_cones[i];
            self.add_cone(k, &cone_m[k], 0);
        }
        for s in 0..self.hss.len() {
            self.hss[s] = 0.0;
            for j in self.sl_ptr[s]..self.sl_ptr[s + 1] {
                let i = self.sl_items[j];
                if i < self.n_ray {
                    self.add_ray(i, ray_d[i], s);
                } else {
                    self.add_cone(i - self.n_ray, &cone_m[i - self.n_ray], s);
                }
            }
            let hss = self.hss[s];
            if hss.is_nan() || hss <= 0.0 {
                return false;
            }
            let range = self.nb_ptr[s]..self.nb_ptr[s + 1];
            for k in range.clone() {
                let p = self.nb_pos[k];
                self.hcs[k] = self.scratch[p];
                self.scratch[p] = 0.0;
            }
            let mut at = self.nb_pair_ptr[s];
            for i in range.clone() {
                let f = self.hcs[i] / hss;
                for j in range.start..=i {
                    self.band.add_at(self.nb_pairs[at], -f * self.hcs[j]);
                    at += 1;
                }
            }
        }
        self.band.factor()
    }

    /// Adds ray r's d g g'; its slack's (if any: slack `s`) diagonal and coupling go
    /// to `hss` and `scratch`.
    #[inline]
    fn add_ray(&mut self, r: usize, d: f64, s: usize) {
        let (lo, hi) = (self.ray_ptr[r], self.ray_ptr[r + 1]);
        for a in lo..hi {
            let u = d * self.ray_val[a];
            let pa = self.ray_pos[a];
            if pa == SLACK {
                self.hss[s] += u * self.ray_val[a];
                for b in lo..hi {
                    let pb = self.ray_pos[b];
                    if pb != SLACK {
                        self.scratch[pb] += u * self.ray_val[b];
                    }
                }
                continue;
            }
            for &(at, g) in self.ray_pairs.of(a) {
                self.band.add_at(at as usize, u * g);
            }
        }
    }

    /// Adds cone k's G_k' M G_k, the slack's part (if any: slack `s`) as in `add_ray`.
    fn add_cone(&mut self, k: usize, m: &[f64; 9], s: usize) {
        let (lo, hi) = (self.cone_ptr[k], self.cone_ptr[k + 1]);
        let dot = |u: &[f64; 3], g: &[f64; 3]| u[0] * g[0] + u[1] * g[1] + u[2] * g[2];
        for a in lo..hi {
            let g = &self.cone_val[a];
            let u: [f64; 3] = std::array::from_fn(|r| {
                m[3 * r] * g[0] + m[3 * r + 1] * g[1] + m[3 * r + 2] * g[2]
            });
            let pa = self.cone_pos[a];
            if pa == SLACK {
                self.hss[s] += dot(&u, g);
                for b in lo..hi {
                    let pb = self.cone_pos[b];
                    if pb != SLACK {
                        self.scratch[pb] += dot(&u, &self.cone_val[b]);
                    }
                }
                continue;
            }
            for (at, g) in self.cone_pairs.of(a) {
                self.band.add_at(*at as usize, dot(&u, g));
            }
        }
    }
}

/// The factor that brings the largest of `values` to 1 (1 when all are zero).
fn unit_scale(values: impl Iterator<Item = f64>) -> f64 {
    let big = values.fold(0.0f64, |m, v| m.max(v.abs()));
    if big > 0.0 { 1.0 / big } else { 1.0 }
}
