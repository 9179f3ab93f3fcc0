//! The solver on problems with known solutions; `qp.rs` compares it with clarabel on
//! band-shaped ones.

use super::*;

fn settings() -> Settings {
    Settings {
        max_iter: 50,
        tol_gap_abs: 1e-8,
        tol_gap_rel: 1e-8,
        tol_feas: 1e-8,
    }
}

#[test]
fn a_projection_onto_a_disk_and_a_half_plane() {
    // min (x0 - 1)^2 + (x1 - 1)^2 s.t. ||(x0, x1)|| <= 1, x0 <= 0.5: P = 2I, q = -2.
    let p_dense = [2.0, 0.0, 0.0, 2.0];
    let q = [-2.0, -2.0];
    let lin = [(0, 0, 1.0)];
    let soc = [(1, 0, -1.0), (2, 1, -1.0)];
    let d = Data {
        n_core: 2,
        n: 2,
        p_dense: &p_dense,
        q: &q,
        lin: &lin,
        lin_b: &[0.5],
        soc: &soc,
        soc_b: &[1.0, 0.0, 0.0],
        position: &[0, 1],
    };
    let mut c = Conic::default();
    assert!(c.solve(&d, &settings()));
    assert!((c.x[0] - 0.5).abs() < 1e-6, "{:?}", c.x);
    assert!((c.x[1] - 0.75f64.sqrt()).abs() < 1e-6, "{:?}", c.x);
}

#[test]
fn an_l1_penalty_through_a_slack_column() {
    // min (x - 2)^2 + 3 |x - 1|  ->  x = 1 (the kink: 2 (x - 2) + 3 g = 0, g in [-1, 1]).
    // Slack t >= |x - 1|: x - t <= 1, -x - t <= -1, -t <= 0.
    let p_dense = [2.0];
    let q = [-4.0, 3.0];
    let lin = [
        (0, 0, 1.0),
        (0, 1, -1.0),
        (1, 0, -1.0),
        (1, 1, -1.0),
        (2, 1, -1.0),
    ];
    let d = Data {
        n_core: 1,
        n: 2,
        p_dense: &p_dense,
        q: &q,
        lin: &lin,
        lin_b: &[1.0, -1.0, 0.0],
        soc: &[],
        soc_b: &[],
        position: &[0],
    };
    let mut c = Conic::default();
    assert!(c.solve(&d, &settings()));
    assert!((c.x[0] - 1.0).abs() < 1e-6, "{:?}", c.x);
    assert!(c.x[1].abs() < 1e-6, "{:?}", c.x);
}

#[test]
fn two_slacks_in_one_block_are_left_to_the_caller() {
    let p_dense = [2.0];
    let q = [0.0, 1.0, 1.0];
    let lin = [(0, 0, 1.0), (0, 1, -1.0), (0, 2, -1.0)];
    let d = Data {
        n_core: 1,
        n: 3,
        p_dense: &p_dense,
        q: &q,
        lin: &lin,
        lin_b: &[1.0],
        soc: &[],
        soc_b: &[],
        position: &[0],
    };
    assert!(!Conic::default().solve(&d, &settings()));
}

#[test]
fn an_infeasible_problem_is_reported_not_solved() {
    // x <= -1 and -x <= -1 (x >= 1).
    let p_dense = [2.0];
    let lin = [(0, 0, 1.0), (1, 0, -1.0)];
    let d = Data {
        n_core: 1,
        n: 1,
        p_dense: &p_dense,
        q: &[0.0],
        lin: &lin,
        lin_b: &[-1.0, -1.0],
        soc: &[],
        soc_b: &[],
        position: &[0],
    };
    assert!(!Conic::default().solve(&d, &settings()));
}
