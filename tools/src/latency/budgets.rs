//! Latency budgets (`config/budgets.toml`): the compute budget of each stage and the
//! end-to-end budget, in milliseconds. A run reads the config directory's copy; a
//! profile the copy attached to the record.

use aisle_config::{InvalidKey, Validate};
use serde::Deserialize;

/// The budgeted series, in table order.
pub const STAGE_ORDER: [&str; 7] = [
    "simulator",
    "lidar",
    "mapper",
    "teb_controller",
    "global_planner",
    "supervisor",
    "end_to_end",
];

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageBudgets {
    pub simulator: f64,
    pub lidar: f64,
    pub mapper: f64,
    pub teb_controller: f64,
    pub global_planner: f64,
    pub supervisor: f64,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndToEndBudget {
    pub tick_to_command: f64,
}

#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budgets {
    pub stage: StageBudgets,
    pub end_to_end: EndToEndBudget,
}

impl Validate for Budgets {
    fn validate(&self) -> Result<(), InvalidKey> {
        let s = &self.stage;
        for (key, v) in [
            ("stage.simulator", s.simulator),
            ("stage.lidar", s.lidar),
            ("stage.mapper", s.mapper),
            ("stage.teb_controller", s.teb_controller),
            ("stage.global_planner", s.global_planner),
            ("stage.supervisor", s.supervisor),
            (
                "end_to_end.tick_to_command",
                self.end_to_end.tick_to_command,
            ),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(InvalidKey::new(
                    key,
                    format!("a budget must be a positive number of milliseconds, got {v}"),
                ));
            }
        }
        Ok(())
    }
}

impl Budgets {
    /// Budget in milliseconds of a named series (a stage or `end_to_end`).
    pub fn of(&self, stage: &str) -> Option<f64> {
        let s = &self.stage;
        Some(match stage {
            "simulator" => s.simulator,
            "lidar" => s.lidar,
            "mapper" => s.mapper,
            "teb_controller" => s.teb_controller,
            "global_planner" => s.global_planner,
            "supervisor" => s.supervisor,
            "end_to_end" => self.end_to_end.tick_to_command,
            _ => return None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_budgets_load_and_name_every_ordered_series() {
        let p = aisle_config::testing::shipped("budgets.toml");
        let b = aisle_config::load::<Budgets>(&p).unwrap();
        for s in STAGE_ORDER {
            assert!(b.of(s).unwrap() > 0.0, "{s}");
        }
        assert_eq!(b.of("recorder"), None);
    }

    #[test]
    fn a_budget_that_is_not_positive_is_refused_by_key() {
        let text = "[stage]\nsimulator = 1.0\nlidar = 0.0\nmapper = 1.0\nteb_controller = 1.0\n\
                    global_planner = 1.0\nsupervisor = 1.0\n[end_to_end]\ntick_to_command = 1.0\n";
        let e = aisle_config::parse::<Budgets>(std::path::Path::new("b.toml"), text).unwrap_err();
        assert!(e.to_string().contains("stage.lidar"), "{e}");
    }
}
