//! Typed planning failures, the statistics reported with every outcome, and the check of
//! a request's inputs.

use crate::search::{MAX_MAP_CELLS, PlanRequest};
use aisle_geometry::GridView;

/// Counters of one planning request, reported on success and on failure.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlanStats {
    /// Nodes taken from the open list and expanded.
    pub expansions: u32,
    /// Search nodes created (the start included).
    pub nodes: u32,
    /// Analytic connections to the goal that were collision-checked.
    pub analytic_checks: u32,
    /// Pose probes made by the collision checker.
    pub collision_probes: u64,
    /// Cells settled by the 2D heuristic's grid search (on a large map, a search resumed
    /// from an earlier request to the same goal on the same map counts those it settled
    /// then too).
    pub heuristic_cells: u32,
    /// Whether this request had to rebuild the map's distance tables.
    pub map_rebuilt: bool,
    /// Length of the returned path in metres (0 on failure).
    pub path_length: f64,
    /// Search cost of the returned path (0 on failure).
    pub path_cost: f64,
    /// Whether smoothing changed the path.
    pub smoothed: bool,
    /// The margin (m) kept near a start that stands inside the full one (`relief.rs`);
    /// `None` when the start keeps the full margin.
    pub start_relief: Option<f64>,
    /// The margin (m) kept near a goal the search could not reach with the full one
    /// (within its sagitta and sweep cover of an obstacle, `relief.rs`); `None` when it
    /// can.
    pub goal_relief: Option<f64>,
    /// Whether the path came from the search from the goal's end (`both_ends.rs`).
    pub from_goal: bool,
    /// Whether the path joins the searches from both ends where they met (`meet.rs`).
    pub met: bool,
    /// Whether the search from the start failed without closing a node beyond
    /// `start_relief_radius`: the start is boxed in.
    pub boxed_in: bool,
    /// Whether the request was searched again from a boxed-in start, with the margin
    /// near it reduced to `boxed_in_margin` of itself (`relief.rs`).
    pub escaped: bool,
}

/// What was wrong with a request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum InvalidInput {
    #[error("start pose is not finite")]
    StartNotFinite,
    #[error("goal pose is not finite")]
    GoalNotFinite,
    #[error("footprint length and width must be positive and finite")]
    Footprint,
    #[error("margin must be finite and not negative")]
    Margin,
    #[error("the map's resolution, origin or cell count is inconsistent")]
    Map,
    #[error("the map has more than MAX_MAP_CELLS (2^25) cells")]
    MapTooLarge,
    #[error(
        "the map has more search states (cells of search_resolution x heading bins) than 32-bit numbers hold"
    )]
    TooManyStates,
    #[error("the expansion budget is zero")]
    ZeroBudget,
}

/// Why no path was returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PlanErrorKind {
    #[error("invalid request: {0}")]
    InvalidInput(InvalidInput),
    #[error("the start pose is in collision")]
    StartOccupied,
    #[error("the goal pose is in collision")]
    GoalOccupied,
    /// The start's centre is beyond the map (cells beyond it count as occupied, but
    /// "in collision" would send a reader looking for an obstacle).
    #[error("the start pose is outside the map")]
    StartOutsideMap,
    #[error("the goal pose is outside the map")]
    GoalOutsideMap,
    #[error("no collision-free path exists")]
    NoPath,
    #[error("the expansion budget ran out")]
    BudgetExhausted,
    #[error("stopped by the caller (deadline or cancel)")]
    Stopped,
    #[error("internal error: the found path failed its final validation")]
    ValidationFailed,
    /// A search bounded by the cost of a plan already in hand (a docking side that
    /// cannot beat one searched before it) has no node left below that cost.
    #[error("no path cheaper than the bound the search was given")]
    AboveBound,
    /// Docking: no side of the body has a clear straight way in (or out).
    #[error("no side of the body has a clear straight way in or out")]
    NoOpenSide,
}

/// A failed request: the reason and what the search did before giving up.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{kind} (after {} expansions)", stats.expansions)]
pub struct PlanError {
    pub kind: PlanErrorKind,
    pub stats: PlanStats,
}

/// What is wrong with `req` on `map`, if anything.
pub(crate) fn check_input(req: &PlanRequest, map: &GridView) -> Result<(), InvalidInput> {
    if !req.start.is_finite() {
        return Err(InvalidInput::StartNotFinite);
    }
    if !req.goal.is_finite() {
        return Err(InvalidInput::GoalNotFinite);
    }
    let f = req.footprint;
    if !(f.length.is_finite() && f.width.is_finite() && f.length > 0.0 && f.width > 0.0) {
        return Err(InvalidInput::Footprint);
    }
    if !(req.margin.is_finite() && req.margin >= 0.0) {
        return Err(InvalidInput::Margin);
    }
    let geometry_ok = map.resolution.is_finite()
        && map.resolution > 0.0
        && map.origin_x.is_finite()
        && map.origin_y.is_finite();
    if !geometry_ok
        || map.width == 0
        || map.height == 0
        || map.cells.len() != map.width * map.height
    {
        return Err(InvalidInput::Map);
    }
    if map.width as u64 * map.height as u64 > MAX_MAP_CELLS {
        return Err(InvalidInput::MapTooLarge);
    }
    if req.max_expansions == 0 {
        return Err(InvalidInput::ZeroBudget);
    }
    Ok(())
}
