//! What the graded mesh gives a solution: the small strain of its leaves at a site
//! ([`GradedMesh::leaf_strain`]) and its leaves' connectivity for a cell-based writer
//! ([`GradedMesh::cell_corners`]).

use super::GradedMesh;

impl GradedMesh {
    /// The symmetric part of the mean gradient at site `k` of the leaves around it
    /// ([`GradedMesh::leaves_around`]): `grad u = sum_c u_c grad N_c` of each bilinear /
    /// trilinear leaf at `k`, `u_c = u_at(corner c)`. Row-major `3 x 3`, the first `d x d` used.
    pub fn leaf_strain(&self, u_at: &dyn Fn([usize; 3]) -> [f64; 3], k: [usize; 3]) -> [f64; 9] {
        let d = self.dim();
        let leaves = self.leaves_around(k);
        let h = self.lattice().spacing();
        let mut grad = [0.0; 9];
        for e in &leaves {
            let s = e.side() as f64;
            let t = [0, 1, 2].map(|a| (k[a] as f64 - e.origin[a] as f64) / s);
            for c in 0..1usize << d {
                let u_c = u_at(e.corner(d, c));
                for b in 0..d {
                    // dN_c / dx_b
                    let dn: f64 = (0..d)
                        .map(|a| {
                            let on = c >> a & 1 == 1;
                            if a == b {
                                if on {
                                    1.0
                                } else {
                                    -1.0
                                }
                            } else if on {
                                t[a]
                            } else {
                                1.0 - t[a]
                            }
                        })
                        .product::<f64>()
                        / (s * h);
                    for a in 0..d {
                        grad[3 * a + b] += u_c[a] * dn / leaves.len() as f64;
                    }
                }
            }
        }
        let mut eps = [0.0; 9];
        for a in 0..d {
            for b in 0..d {
                eps[3 * a + b] = 0.5 * (grad[3 * a + b] + grad[3 * b + a]);
            }
        }
        eps
    }

    /// Every leaf's corners as `point(site)`, `2^d` a leaf, counter-clockwise on the lower
    /// face, then the upper (the order of VTK's `VTK_QUAD` and `VTK_HEXAHEDRON`): a reader
    /// draws `u` over them continuously (a hanging node lies on an edge or face of a coarser
    /// leaf, where `P` gives it the leaf's own interpolant).
    pub fn cell_corners(&self, point: &dyn Fn([usize; 3]) -> usize) -> Vec<usize> {
        let d = self.dim();
        // corner numbers (bit a: +side along axis a) in that order
        let order: &[usize] = if d == 2 { &[0, 1, 3, 2] } else { &[0, 1, 3, 2, 4, 5, 7, 6] };
        self.cells().iter().flat_map(|e| order.iter().map(move |&c| point(e.corner(d, c)))).collect()
    }
}
