//! The expansion budget of one request (`search_core.rs` spends it; `search.rs` sets
//! it from the request and the area the goal can be reached from).

use crate::config::PlannerConfig;
use crate::search::PlanRequest;

/// Expansions spent so far: by the whole request (every search it made), and by the
/// search about to go on.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Spent {
    request: u32,
    search: u32,
}

impl Spent {
    pub(crate) fn new(request: u32, search: u32) -> Spent {
        Spent { request, search }
    }
}

/// The expansion budget of one request: the request's own, raised to so many expansions
/// per cell the goal can be reached from (`expansions_per_reachable_cell`) once it is
/// spent, which is when the heuristic's backward search is run to its end to count them.
pub(crate) struct Budget {
    pub(crate) limit: u32,
    /// Expansions per reachable cell, while the limit may still grow with them.
    pub(crate) per_cell: Option<f64>,
}

impl Budget {
    /// A fixed budget that suits a 20 x 30 m hall gives up on a detour in a larger one:
    /// the request's `own` budget grows to `per_cell` expansions per cell the goal can
    /// be reached from, counted up front (`reachable`, on a small map) or when the own
    /// budget is spent (on a large one).
    pub(crate) fn new(own: u32, per_cell: f64, reachable: Option<u32>) -> Budget {
        match reachable {
            Some(cells) => {
                let scaled = per_cell * f64::from(cells);
                Budget {
                    limit: own.max(scaled.min(f64::from(u32::MAX)) as u32),
                    per_cell: None,
                }
            }
            None => Budget {
                limit: own,
                per_cell: (per_cell > 0.0).then_some(per_cell),
            },
        }
    }

    /// The budget of a turn of a search of `req`: `cap` (one turn of the searches from
    /// both ends), the request's fixed budget less what its searches have spent, the
    /// smaller of the two, or else the growing budget.
    pub(crate) fn of_turn(
        req: &PlanRequest,
        cap: Option<u32>,
        spent: Spent,
        cfg: &PlannerConfig,
        reachable: Option<u32>,
    ) -> Budget {
        let per_cell = cfg.expansions_per_reachable_cell;
        // What the request has left, on top of what this search has done.
        let left = req.max_expansions.saturating_sub(spent.request);
        let fixed = req.fixed_budget.then(|| spent.search.saturating_add(left));
        match (cap, fixed) {
            (Some(cap), Some(fixed)) => Budget::capped(cap.min(fixed)),
            (Some(limit), None) | (None, Some(limit)) => Budget::capped(limit),
            (None, None) => Budget::new(req.max_expansions, per_cell, reachable),
        }
    }

    /// A hard limit that does not grow: one turn of a search that alternates between
    /// a request's ends (`both_ends.rs`).
    pub(crate) fn capped(limit: u32) -> Budget {
        Budget {
            limit,
            per_cell: None,
        }
    }
}
