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
/// `E = C vol_e` (`((a*3+b)*3+c)*3+d` layout) to `out` (see the module docs):
/// `K[(r,a),(l,b)] = (1/s^2) sum_{q,t} E_aqbt B^d[r][l][q][t]` with the quadrature of the unit
/// box's shape gradients `B^d[r][l][q][t] = sum_g w_g dN_r/dt_q(t_g) dN_l/dt_t(t_g)` tabulated
/// once per dimension ([`gradient_products`]).
pub(crate) fn add_element_row<S: ElementBlocks>(d: usize, s: f64, e: &[f64; 81], r: usize, scale: f64, out: &mut S) {
    let nc = 1usize << d;
    let b_table = gradient_products(d);
    let f = scale / (s * s);
    for l in 0..nc {
        let b_rl = &b_table[r * 8 + l];
        let blk = out.block(l);
        for a in 0..d {
            for b in 0..d {
                let mut v = 0.0;
                for q in 0..d {
                    for tt in 0..d {
                        v += e[((a * 3 + q) * 3 + b) * 3 + tt] * b_rl[q * 3 + tt];
                    }
                }
                blk[a * 3 + b] += f * v;
            }
        }
    }
}

/// `B^d[r * 8 + l][q * 3 + t] = sum_g w_g dN_r/dt_q(t_g) dN_l/dt_t(t_g)` on the unit box
/// (`t_g = 1/2 +- 1/(2 sqrt 3)` per axis, `w_g = 2^-d`), for `d` = 2 and 3.
fn gradient_products(d: usize) -> &'static [[f64; 9]; 64] {
    static TABLES: [std::sync::OnceLock<[[f64; 9]; 64]>; 2] = [std::sync::OnceLock::new(), std::sync::OnceLock::new()];
    TABLES[d - 2].get_or_init(|| {
        let nc = 1usize << d;
        let g = 0.5 / 3f64.sqrt();
        let wg = 1.0 / nc as f64;
        // shape function gradient of corner c at reference point t
        let grad = |c: usize, t: &[f64; 3]| -> [f64; 3] {
            let mut out = [0.0; 3];
            for q in 0..d {
                let mut v = 1.0;
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
        let mut table = [[0.0; 9]; 64];
        for p in 0..nc {
            let t: [f64; 3] = [0, 1, 2].map(|a| if a < d { 0.5 + if p >> a & 1 == 1 { g } else { -g } } else { 0.0 });
            for r in 0..nc {
                let gr = grad(r, &t);
                for l in 0..nc {
                    let gl = grad(l, &t);
                    for q in 0..d {
                        for tt in 0..d {
                            table[r * 8 + l][q * 3 + tt] += wg * gr[q] * gl[tt];
                        }
                    }
                }
            }
        }
        table
    })
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
