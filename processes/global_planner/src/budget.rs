//! The expansion budget of one request (`search_core.rs` spends it; `search.rs` sets
//! it from the request and the area the goal can be reached from).

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

    /// A hard limit that does not grow: one turn of a search that alternates between
    /// a request's ends (`both_ends.rs`).
    pub(crate) fn capped(limit: u32) -> Budget {
        Budget {
            limit,
            per_cell: None,
        }
    }
}
