//! The seed mission's slowest steps (`benches/cases/seed_worst.mcap`) replay bit for bit
//! from their messages: the library alone, given what the node was given, is the node.
//! A change to the controller's behaviour changes these steps on purpose; then record
//! the seed again and re-export them (`examples/export_steps.rs`, see its doc).

#[path = "../benches/support/step_cases.rs"]
mod step_cases;

use aisle_teb_controller::TebConfig;
use aisle_teb_controller::case::{RecordedStep, reproduces};
use std::path::Path;
use step_cases::AlignedStep;

#[test]
fn the_exported_mission_steps_replay_bit_for_bit_and_repeatably() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cfg: TebConfig = aisle_config::load(&dir.join("../../config/teb.toml")).unwrap();
    let steps = step_cases::steps_in(&dir.join("benches/cases/seed_worst.mcap")).unwrap();
    assert!(steps.len() >= 5, "{} steps", steps.len());
    for s in &steps {
        let at = s.trajectory.publish_time as f64 * 1e-9;
        let aligned = AlignedStep::of(s);
        let mut step = RecordedStep::new(cfg.clone(), &aligned.inputs().unwrap()).unwrap();
        let first = step.step().unwrap().clone();
        assert!(
            reproduces(&first, aligned.trajectory().unwrap()),
            "step at {at} s differs from the mission's: re-export the cases"
        );
        step.reset().unwrap();
        assert_eq!(
            *step.step().unwrap(),
            first,
            "step at {at} s, replayed again"
        );
    }
}
