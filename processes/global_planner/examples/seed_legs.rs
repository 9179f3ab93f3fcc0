//! Plans the seed mission's three legs on the stand-in seed map and prints what each
//! request returned: `cargo run --release -p aisle-global-planner --example seed_legs
//! [cells_per_metre] [repeats] [planner.toml]`. Repeats plan the same request again on the same
//! planner (warm buffers and map tables), for profiling.

use aisle_global_planner::seed_map::{seed_map, seed_segments};
use aisle_global_planner::{PlanRequest, Planner, PlannerConfig};

fn main() {
    let mut args = std::env::args().skip(1);
    let cpm: f64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(20.0);
    let repeats: u32 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let mut cfg = PlannerConfig::default();
    if let Some(path) = args.next() {
        cfg = aisle_config::load_toml(std::path::Path::new(&path))
            .map(|(c, _)| c)
            .unwrap_or_else(|e| panic!("{e}"));
    }
    let map = seed_map(cpm);
    let mut planner = Planner::new(cfg).unwrap_or_else(|e| panic!("{e}"));
    for seg in seed_segments() {
        let req = PlanRequest {
            start: seg.start,
            goal: seg.goal,
            footprint: seg.footprint,
            margin: seg.margin,
            max_expansions: 200_000,
            fixed_budget: false,
        };
        for _ in 0..repeats {
            match planner.plan(&req, &map.view()) {
                Ok(plan) => println!(
                    "{} @ {cpm} cells/m: {:.2} m, {} poses, {:?}",
                    seg.name,
                    plan.stats.path_length,
                    plan.path.len(),
                    plan.stats
                ),
                Err(e) => println!("{} @ {cpm} cells/m: {e} {:?}", seg.name, e.stats),
            }
        }
    }
}
