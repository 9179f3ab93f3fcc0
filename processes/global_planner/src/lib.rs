//! aisle-global-planner
