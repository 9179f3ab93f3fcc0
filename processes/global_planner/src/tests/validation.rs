//! The output check holds the path to what the search proved, not more. Found by random
//! requests carrying the rack on the seed map: the search had swept every motion with
//! the margin and the sagitta to spare, but the output check swept the straight joins
//! between the traced poses again and demanded `sweep_cover` (3 cm) beyond the margin at
//! its own samples, which the search proves only at its own; about one rack request in
//! sixty then failed with `ValidationFailed` (request 4 of `config/large` among them).

use super::check_plan;
use crate::seed_map::{self, RACK, RACK_MARGIN};
use crate::{PlanRequest, Planner, PlannerConfig};
use aisle_geometry::Pose2;

#[test]
fn paths_the_search_found_pass_the_output_check() {
    let map = seed_map::seed_map(10.0);
    let cfg = PlannerConfig::default();
    let mut planner = Planner::new(cfg.clone()).unwrap();
    let cases = [
        ((-3.4312, 1.99, 0.24428), (7.0322, 7.4584, 1.18854)),
        ((-1.2442, 12.7476, -1.92882), (1.4846, -1.9972, -1.31068)),
        ((12.7202, -6.6312, 1.81226), (1.9904, 6.6492, 1.40678)),
    ];
    for (s, g) in cases {
        let req = PlanRequest {
            start: Pose2::new(s.0, s.1, s.2),
            goal: Pose2::new(g.0, g.1, g.2),
            footprint: RACK,
            margin: RACK_MARGIN,
            max_expansions: 20_000,
            fixed_budget: false,
        };
        let plan = planner
            .plan(&req, &map.view())
            .unwrap_or_else(|e| panic!("{req:?}: {e:?}"));
        // The independent sweep of the tests holds it to the full margin (to the margin
        // kept near a start inside it: the first stands there).
        let margin = plan.stats.start_relief.unwrap_or(RACK_MARGIN);
        check_plan(&plan, &PlanRequest { margin, ..req }, &map.view(), &cfg);
    }
}
