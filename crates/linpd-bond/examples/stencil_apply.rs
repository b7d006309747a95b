//! Time of the lattice stencil's apply (the finest-level product of matrix-free solves).
//!
//! ```text
//! cargo run --release -p linpd-bond --example stencil_apply -- NODES [REPEATS]
//! ```
//!
//! A `NODES^3` lattice, `delta = 3h` (122 bonds per interior node); prints the seconds per
//! apply and the nanoseconds per node-bond, and checks the stencil against the per-bond
//! operator on a random vector (relative max difference).

use linpd_bond::{BondOperator, StencilOperator};
use linpd_core::{Grid, Kernel, Material, Micromodulus, Normalization, Placement};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let nodes: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(40);
    let repeats: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let max = (nodes - 1) as f64;
    let g = Grid::new(&[0.0; 3], &[max; 3], 1.0, 0.0, Placement::Vertex).unwrap();
    let mm = Micromodulus {
        kernel: Kernel::InverseDistance,
        normalization: Normalization::Discrete,
        modulus: 1.0,
        plane: None,
        partial_volume: false,
    };
    let s = StencilOperator::new(&g, 3.0, &mm).unwrap();
    let n = s.n_dofs();
    let mut state = 7u64;
    let u: Vec<f64> = (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        })
        .collect();
    let mut y = vec![0.0; n];
    s.apply(&u, &mut y);
    let t = Instant::now();
    for _ in 0..repeats {
        s.apply(&u, &mut y);
    }
    let per = t.elapsed().as_secs_f64() / repeats as f64;
    let bonds = (n / 3) as f64 * s.stencil_len() as f64;
    println!("{nodes}^3 nodes, {n} DOFs: {per:.4} s per apply, {:.2} ns per node-bond", per / bonds * 1e9);
    if nodes <= 40 {
        let op = BondOperator::on_grid(&g, 3.0, &mm, &Material::default()).unwrap();
        let mut z = vec![0.0; n];
        op.apply(&u, &mut z);
        let scale = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = y.iter().zip(&z).fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        println!("stencil vs per-bond operator: {:.1e} relative", diff / scale);
    }
}
