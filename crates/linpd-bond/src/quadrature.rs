//! How a point cloud's bonds weigh their neighbour's volume near the horizon
//! ([`Quadrature`]), for [`crate::BondOperator::on_points`].
//!
//! On a lattice a neighbour's volume `h^d` is in or out of the horizon ball `|xi| <= delta`
//! (or ramped, [`linpd_core::kernel::partial_volume`]), and a small change of `delta` moves no
//! node across it unless `delta / h` crosses the root of an integer. On an irregular cloud
//! neighbours sit at every distance: with full volumes a 1e-4 relative change of `delta`
//! gains or loses whole neighbours and moved a meshed bracket's tip by 15 % (issue #33).
//!
//! [`Quadrature::Ball`] weighs node `j`'s volume by the fraction of an equivalent ball of
//! radius `R` (its volume's: `R = V^(1/3) (3 / 4 pi)^(1/3)` in 3D, `sqrt(V / pi)` in 2D,
//! `V / 2` in 1D) that lies inside node `i`'s horizon ball, with `R = (R_i + R_j) / 2` so that
//! `w_ij = w_ji`:
//!
//! * 3D: the lens volume of two balls of radii `delta` and `R` at distance `r`,
//!   `pi (delta + R - r)^2 (r^2 + 2 r (delta + R) - 3 (delta - R)^2) / (12 r)`, over
//!   `4/3 pi R^3`;
//! * 2D: the lens area `R^2 acos((r^2 + R^2 - delta^2) / (2 r R)) + delta^2 acos((r^2 +
//!   delta^2 - R^2) / (2 r delta)) - sqrt((-r + R + delta)(r + R - delta)(r - R + delta)(r + R
//!   + delta)) / 2`, over `pi R^2`;
//! * 1D: the overlap `(delta + R - r) / (2 R)` clamped to `[0, 1]`;
//!
//! 1 for `r <= delta - R`, 0 for `r >= delta + R` (the family is built to `delta + max R`).
//! The fraction is continuous in `delta` and in the positions, so the operator is too.

/// The weighting of a cloud's neighbours near the horizon.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Quadrature {
    /// The whole volume of every neighbour within `delta` (the lattice's default).
    #[default]
    Full,
    /// [`linpd_core::kernel::partial_volume`]'s one-sided ramp (PDLAMMPS), neighbours within
    /// `delta` only: `micromodulus.partial_volume`.
    Ramp,
    /// The fraction of the neighbour's equivalent ball inside the horizon ball (module docs).
    Ball,
}

impl Quadrature {
    /// The per-node length [`volume_factor`] reads, computed once per node: the node size
    /// `V^(1/d)` ([`Quadrature::Ramp`]), the equivalent radius ([`Quadrature::Ball`]), 0
    /// ([`Quadrature::Full`]).
    pub fn node_scale(self, dim: usize, v: f64) -> f64 {
        match self {
            Quadrature::Full => 0.0,
            Quadrature::Ramp => v.powf(1.0 / dim as f64),
            Quadrature::Ball => equivalent_radius(dim, v),
        }
    }
}

/// The volume factor `nu_ij` of a bond of length `r` between nodes of scales `s_i`, `s_j`
/// ([`Quadrature::node_scale`]; symmetric in the pair): 1 ([`Quadrature::Full`]), the ramp of
/// the mean node size ([`Quadrature::Ramp`]) or the ball fraction of the mean equivalent radius
/// ([`Quadrature::Ball`]).
pub fn volume_factor(q: Quadrature, dim: usize, r: f64, horizon: f64, s_i: f64, s_j: f64) -> f64 {
    match q {
        Quadrature::Full => 1.0,
        Quadrature::Ramp => linpd_core::kernel::partial_volume(r, horizon, 0.5 * (s_i + s_j)),
        Quadrature::Ball => ball_fraction(dim, r, horizon, 0.5 * (s_i + s_j)),
    }
}

/// How far the bonds of nodes with `volumes` reach under `q`: `horizon`, plus the largest
/// equivalent radius with [`Quadrature::Ball`].
pub fn reach(q: Quadrature, dim: usize, horizon: f64, volumes: &[f64]) -> f64 {
    match q {
        Quadrature::Ball => horizon + volumes.iter().fold(0.0f64, |m, &v| m.max(equivalent_radius(dim, v))),
        _ => horizon,
    }
}

/// The radius of the ball of volume `v` in dimension `dim` (the half length in 1D).
pub fn equivalent_radius(dim: usize, v: f64) -> f64 {
    match dim {
        1 => 0.5 * v,
        2 => (v / std::f64::consts::PI).sqrt(),
        _ => (3.0 * v / (4.0 * std::f64::consts::PI)).cbrt(),
    }
}

/// The fraction of a ball of radius `radius` centred at distance `r` from the centre of the
/// horizon ball of radius `delta` that lies inside it (module docs).
pub fn ball_fraction(dim: usize, r: f64, delta: f64, radius: f64) -> f64 {
    let (big, small) = (delta.max(radius), delta.min(radius));
    if r + radius <= delta {
        return 1.0;
    }
    if r >= delta + radius {
        return 0.0;
    }
    if r + small <= big {
        // the horizon ball inside the node's (a node larger than the horizon)
        return match dim {
            1 => delta / radius,
            2 => (delta / radius).powi(2),
            _ => (delta / radius).powi(3),
        };
    }
    let (d, rr) = (delta, radius);
    let f = match dim {
        1 => (d + rr - r) / (2.0 * rr),
        2 => {
            let a = rr * rr * ((r * r + rr * rr - d * d) / (2.0 * r * rr)).clamp(-1.0, 1.0).acos()
                + d * d * ((r * r + d * d - rr * rr) / (2.0 * r * d)).clamp(-1.0, 1.0).acos()
                - 0.5 * ((-r + rr + d) * (r + rr - d) * (r - rr + d) * (r + rr + d)).max(0.0).sqrt();
            a / (std::f64::consts::PI * rr * rr)
        }
        _ => {
            let v = std::f64::consts::PI * (d + rr - r).powi(2) * (r * r + 2.0 * r * (d + rr) - 3.0 * (d - rr).powi(2))
                / (12.0 * r);
            v / (4.0 / 3.0 * std::f64::consts::PI * rr.powi(3))
        }
    };
    f.clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fraction is 1 inside, 0 outside, continuous at both ends of the lens (the lens
    /// formulas give 1 and 0 there), a half at `r = delta` to first order in `R / delta`, and
    /// matches a Monte Carlo count of the small ball's points inside the big one (4e5 points:
    /// standard error below 1e-3).
    #[test]
    fn ball_fraction_is_the_lens_over_the_ball() {
        for dim in [1usize, 2, 3] {
            let (delta, radius) = (3.0, 0.6);
            for (r, want) in [(delta - radius, 1.0), (delta + radius, 0.0)] {
                let eps = 1e-9;
                assert!((ball_fraction(dim, r - eps, delta, radius) - want).abs() <= 1e-6, "dim {dim} at {r}");
                assert!((ball_fraction(dim, r + eps, delta, radius) - want).abs() <= 1e-6, "dim {dim} at {r}");
            }
            let half = ball_fraction(dim, delta, delta, radius);
            assert!((half - 0.5).abs() <= 0.1 * radius / delta * dim as f64, "dim {dim}: {half}");
            // Monte Carlo: a deterministic sequence filling the small ball's bounding box
            for r in [2.5, 2.9, 3.2, 3.5] {
                let (mut inside, mut total) = (0u64, 0u64);
                let mut s = 0x2545_f491_4f6c_dd1du64;
                let mut next = || {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
                };
                while total < 400_000 {
                    let p: Vec<f64> = (0..dim).map(|_| radius * next()).collect();
                    if p.iter().map(|x| x * x).sum::<f64>() > radius * radius {
                        continue;
                    }
                    total += 1;
                    let d2 = (r + p[0]).powi(2) + p[1..].iter().map(|x| x * x).sum::<f64>();
                    inside += u64::from(d2 <= delta * delta);
                }
                let mc = inside as f64 / total as f64;
                let f = ball_fraction(dim, r, delta, radius);
                assert!((f - mc).abs() <= 3e-3, "dim {dim}, r {r}: {f} vs Monte Carlo {mc}");
            }
        }
    }

    /// On the unit cubic lattice the ball-weighted volume of the neighbours (and the node
    /// itself) approximates the horizon ball's volume `4/3 pi delta^3` far better than whole
    /// volumes do, and varies continuously with `delta`: over `delta` in [2, 4] its relative
    /// error stays below 1.5 % where whole volumes reach 10 %, and a step of 0.005 in `delta`
    /// changes it by at most twice the ball's own change `4 pi delta^2 0.005` (whole volumes
    /// jump by whole shells of neighbours, up to 48 nodes at once: more than 10 times).
    #[test]
    fn ball_weights_integrate_the_horizon_ball() {
        let sum = |delta: f64, ball: bool| -> f64 {
            let n = (delta + 1.0).ceil() as i64;
            let mut v = 0.0;
            for i in -n..=n {
                for j in -n..=n {
                    for k in -n..=n {
                        let r = ((i * i + j * j + k * k) as f64).sqrt();
                        v += match ball {
                            true => ball_fraction(3, r, delta, equivalent_radius(3, 1.0)),
                            false => f64::from(u8::from(r <= delta)),
                        };
                    }
                }
            }
            v
        };
        let (mut worst_ball, mut worst_full, mut jump_ball, mut jump_full) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for step in 0..=400 {
            let delta = 2.0 + step as f64 * 0.005;
            let exact = 4.0 / 3.0 * std::f64::consts::PI * delta.powi(3);
            worst_ball = worst_ball.max((sum(delta, true) - exact).abs() / exact);
            worst_full = worst_full.max((sum(delta, false) - exact).abs() / exact);
            // the change over a step against the ball's own, 4 pi delta^2 d(delta)
            let smooth = 4.0 * std::f64::consts::PI * delta * delta * 0.005;
            jump_ball = jump_ball.max((sum(delta + 0.005, true) - sum(delta, true)).abs() / smooth);
            jump_full = jump_full.max((sum(delta + 0.005, false) - sum(delta, false)).abs() / smooth);
        }
        eprintln!("relative error: ball {worst_ball:.3e}, whole {worst_full:.3e}; steps: ball {jump_ball:.2}, whole {jump_full:.2}");
        assert!(worst_ball <= 0.015 && worst_full >= 0.1, "ball {worst_ball}, whole {worst_full}");
        assert!(jump_ball <= 2.0 && jump_full >= 10.0, "steps: ball {jump_ball}, whole {jump_full}");
    }
}
