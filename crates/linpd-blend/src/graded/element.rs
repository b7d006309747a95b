//! The bilinear (2D) / trilinear (3D) element of side `s` with full `2^d`-point Gauss
//! quadrature, shared by the fine-lattice local model ([`crate::lattice`]) and the graded mesh
//! ([`super::GradedMesh`]): one routine, so that the graded mesh with no grading reproduces the
//! lattice's elements.
//!
//! With corner `c` (bit `a` of `c` set: `+s` along axis `a`), reference coordinates
//! `t in [0, 1]^d` and `N_c(t) = prod_a (bit_a ? t_a : 1 - t_a)`, the element matrix is
//!
//! ```text
//! K_e[(r,a),(l,b)] = int_e dN_r/dx_q C_aqbt dN_l/dx_t dx
//!                  = sum_g w_g  dN_r/dx_q (t_g) (C vol_e)_aqbt dN_l/dx_t (t_g),
//! t_g = 1/2 +- 1/(2 sqrt 3) per axis,  w_g = 2^-d,
//! ```
//!
//! exact for the constant `C` of a box (the integrand is a polynomial of degree at most 2 per
//! axis). The routine takes `E = C vol_e` (the lattice's moduli come as that product).

/// Where [`add_element_row`] adds its blocks: the `3 x 3` (row-major, `d x d` used) block
/// coupling the element row's corner with corner `l`.
pub(crate) trait ElementBlocks {
    /// Block of corner `l`.
    fn block(&mut self, l: usize) -> &mut [f64; 9];
}

/// Adds `scale` times block row `r` of the element matrix of a box of side `s` with
/// `E = C vol_e` (`((a*3+b)*3+c)*3+d` layout) to `out` (see the module docs).
pub(crate) fn add_element_row<S: ElementBlocks>(d: usize, s: f64, e: &[f64; 81], r: usize, scale: f64, out: &mut S) {
    let nc = 1usize << d;
    let g = 0.5 / 3f64.sqrt();
    let wg = 1.0 / nc as f64;
    // shape function gradient of corner c at Gauss point p (reference coordinates t in [0, 1]^d)
    let grad = |c: usize, t: &[f64; 3]| -> [f64; 3] {
        let mut out = [0.0; 3];
        for q in 0..d {
            let mut v = 1.0 / s;
            for a in 0..d {
                let bit = c >> a & 1 == 1;
                v *= if a == q {
                    if bit {
                        1.0
                    } else {
                        -1.0
                    }
                } else if bit {
                    t[a]
                } else {
                    1.0 - t[a]
                };
            }
            out[q] = v;
        }
        out
    };
    for p in 0..nc {
        let t: [f64; 3] = [0, 1, 2].map(|a| if a < d { 0.5 + if p >> a & 1 == 1 { g } else { -g } } else { 0.0 });
        let gr = grad(r, &t);
        for l in 0..nc {
            let gl = grad(l, &t);
            let blk = out.block(l);
            // K[(r,a),(l,b)] = w_g sum_{q,t} dN_r/dx_q E_{a q b t} dN_l/dx_t
            for a in 0..d {
                for b in 0..d {
                    let mut v = 0.0;
                    for q in 0..d {
                        for tt in 0..d {
                            v += gr[q] * e[((a * 3 + q) * 3 + b) * 3 + tt] * gl[tt];
                        }
                    }
                    blk[a * 3 + b] += scale * wg * v;
                }
            }
        }
    }
}

/// The dense element matrix (`d 2^d` square, row `(r, a)` at `d r + a`) of a box of side `s`
/// with `E = C vol_e`.
pub(crate) fn element_matrix(d: usize, s: f64, e: &[f64; 81]) -> Vec<f64> {
    struct Dense(Vec<[f64; 9]>);
    impl ElementBlocks for Dense {
        fn block(&mut self, l: usize) -> &mut [f64; 9] {
            &mut self.0[l]
        }
    }
    let nc = 1usize << d;
    let m = d * nc;
    let mut k = vec![0.0; m * m];
    for r in 0..nc {
        let mut row = Dense(vec![[0.0; 9]; nc]);
        add_element_row(d, s, e, r, 1.0, &mut row);
        for (l, blk) in row.0.iter().enumerate() {
            for a in 0..d {
                for b in 0..d {
                    k[(d * r + a) * m + d * l + b] = blk[a * 3 + b];
                }
            }
        }
    }
    k
}
