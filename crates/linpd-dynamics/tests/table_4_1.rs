//! Table 4.1 of Seleson, Parks, Gunzburger & Lehoucq (2009): cost of the coarse PD simulation
//! relative to MD, and whether its step counts follow the refinement rule (4.13).
//!
//! | model       | N_x   | N  | N_t | relative cost |
//! |-------------|-------|----|-----|---------------|
//! | MD          | 4,001 | 20 | 184 | 1.00          |
//! | PD (coarse) | 2,001 | 10 | 162 | 0.22          |
//!
//! Cost = `N_x N N_t` (bond updates times steps). Domain `[0, 1000]` (so `a = 0.25`,
//! `dx = 0.5`, `delta = 5`), `rho = K_1 = 1` (the values of Fig. 4.2; section 4.4.1 does not
//! restate them), `dt_0 = 0.85` in (4.13).

use linpd_dynamics::stability::{lattice_limit, refinement_dt};
use linpd_dynamics::Chain;

struct Row {
    nx: usize,
    n: usize,
    nt: usize,
}

const MD: Row = Row { nx: 4001, n: 20, nt: 184 };
const PD: Row = Row { nx: 2001, n: 10, nt: 162 };

fn dt_4_13(r: &Row) -> f64 {
    let dx = 1000.0 / (r.nx - 1) as f64;
    refinement_dt(0.85, 1.0, 1.0, r.n, dx)
}

#[test]
fn relative_cost_is_the_tables() {
    let cost = |r: &Row| (r.nx * r.n * r.nt) as f64;
    let rel = cost(&PD) / cost(&MD);
    println!("relative cost from the table's own N_x, N, N_t: {rel:.4} (table: 0.22; text: \"1/5\")");
    // The table prints two decimals.
    assert!((rel - 0.22).abs() < 0.005, "{rel}");
    // The same ratio from (4.13) over a common final time: cost ~ N_x N / dt.
    let rel_dt = (PD.nx * PD.n) as f64 / dt_4_13(&PD) / ((MD.nx * MD.n) as f64 / dt_4_13(&MD));
    println!("relative cost with dt from (4.13) and a common final time: {rel_dt:.4}");
    assert!((rel_dt - 0.22).abs() < 0.005, "{rel_dt}");
}

#[test]
fn step_counts_follow_4_13_for_a_final_time_of_300_not_150() {
    let (dt_md, dt_pd) = (dt_4_13(&MD), dt_4_13(&PD));
    println!("(4.13): dt_MD = {dt_md:.6}, dt_PD = {dt_pd:.6}");
    // Both runs are stable: (4.13) is 0.85 x (4.12), below the exact limit.
    for (r, dt) in [(&MD, dt_md), (&PD, dt_pd)] {
        let chain = Chain::springs(1.0, r.n, 1000.0 / (r.nx - 1) as f64).unwrap();
        assert!(dt < lattice_limit(&chain, 1.0).dt);
    }
    // The only time the section states is the frame of Fig. 4.4, t = 150.05: it needs
    // 93 MD and 82 PD steps, about half the table's counts.
    let at = |t: f64, dt: f64| (t / dt).ceil() as usize;
    println!("steps to t = 150.05: MD {}, PD {}", at(150.05, dt_md), at(150.05, dt_pd));
    assert_eq!((at(150.05, dt_md), at(150.05, dt_pd)), (93, 82));
    // floor(T / dt) reproduces 184 and 162 for T in [184 dt_MD, 163 dt_PD) = [298.7, 300.2),
    // which holds T = 300 = 2 x 150 (the runs end at t = 298.7 and 298.4).
    let lo = (MD.nt as f64 * dt_md).max(PD.nt as f64 * dt_pd);
    let hi = ((MD.nt + 1) as f64 * dt_md).min((PD.nt + 1) as f64 * dt_pd);
    println!("floor(T/dt) = table for T in [{lo:.2}, {hi:.2})");
    assert!(lo <= 300.0 && 300.0 < hi);
    assert_eq!(((300.0 / dt_md) as usize, (300.0 / dt_pd) as usize), (MD.nt, PD.nt));
}

#[test]
fn section_4_4_3_time_step_is_4_13_with_ccm_parameters() {
    // "the same time step (dt = 0.0649) ... calculated using the CCM simulation parameters in
    // (4.13)": CCM uses 100,001 nodes and N = 20, so dx = 0.01.
    let dt = refinement_dt(0.85, 1.0, 1.0, 20, 0.01);
    println!("CCM dt from (4.13) = {dt:.6}");
    assert!((dt - 0.0649).abs() < 5e-5, "{dt}");
}
