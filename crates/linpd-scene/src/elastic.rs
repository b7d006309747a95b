//! Engineering constants (issue #32): `young_modulus` and `poisson_ratio` wherever a scene gives
//! a modulus, and the isotropic constants `E, nu, K, G` of every phase in `result.json`.
//!
//! A bond-based model has one modulus, `K` (`micromodulus.modulus`, a phase's `modulus`), and
//! fixes Poisson's ratio (docs/problem-format.md, "What `modulus` means"):
//!
//! | dimension | `nu` | `E` |
//! |---|---|---|
//! | 1 (a bar) | - | `K` |
//! | 2, plane stress | 1/3 | `K` |
//! | 2, plane strain | 1/4 | `3K/2` |
//! | 3 | 1/4 | `3K/2` |
//!
//! so `young_modulus` gives `K = E / (E/K)`, and a `poisson_ratio` other than the model's is an
//! error that names the model's `nu` and points at LPS, whose two moduli take any
//! `-1 < nu < 1/2`: `K = E / (3 (1 - 2 nu))`, `G = E / (2 (1 + nu))` (the 3D moduli, also in
//! 2D where LPS takes the 3D `K` and `G` with its plane assumption). In 2D and 3D `G` of a bond
//! model is `E / (2 (1 + nu))`, `K` the 3D bulk modulus `micromodulus.modulus` means.

use crate::ProblemError;
use linpd_core::PlaneModel;
use serde::Serialize;

/// How close a given `poisson_ratio` must be to a bond model's (`1/4` typed as `0.25`, `1/3` as
/// `0.3333333333333333` or `0.333333`: six digits).
const NU_RTOL: f64 = 1e-6;

/// The isotropic elastic constants of one phase, as `result.json` lists them (`material`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PhaseConstants {
    /// `"reference"` (the model's own modulus: nodes of no phase) or `"phases[k]"`.
    pub phase: String,
    /// `E`.
    pub young_modulus: f64,
    /// `nu` (`None` for a 1D bar).
    pub poisson_ratio: Option<f64>,
    /// The 3D bulk modulus `K` (for a 1D bar: the bar modulus, `= E`).
    pub bulk_modulus: f64,
    /// `G` (`None` for a 1D bar).
    pub shear_modulus: Option<f64>,
}

/// The constants a bond-based model fixes in dimension `dim` with `plane`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct BondElastic {
    /// `nu` (`None` in 1D).
    pub nu: Option<f64>,
    /// `E / K`.
    pub e_per_k: f64,
}

impl BondElastic {
    /// The bond model's `nu` and `E/K` (see the module docs).
    pub fn of(dim: usize, plane: Option<PlaneModel>) -> Self {
        match (dim, plane) {
            (1, _) => BondElastic { nu: None, e_per_k: 1.0 },
            (2, Some(PlaneModel::Stress)) => BondElastic { nu: Some(1.0 / 3.0), e_per_k: 1.0 },
            _ => BondElastic { nu: Some(0.25), e_per_k: 1.5 },
        }
    }

    /// The modulus `K` at `path` (`micromodulus` or a phase) from `modulus` or from
    /// `young_modulus` (with an optional `poisson_ratio`, which must be the model's); `None`
    /// when neither is given (the caller says what is missing).
    pub fn modulus(
        &self,
        path: &str,
        modulus: Option<f64>,
        young: Option<f64>,
        nu: Option<f64>,
    ) -> Result<Option<f64>, ProblemError> {
        match (modulus, young) {
            (Some(_), Some(_)) => Err(ProblemError::invalid(
                format!("{path}.young_modulus"),
                "give either modulus (the bulk modulus K) or young_modulus (E), not both",
            )),
            (_, None) if nu.is_some() => Err(ProblemError::invalid(
                format!("{path}.poisson_ratio"),
                "goes with young_modulus (a bond model's modulus fixes nu)",
            )),
            (k, None) => Ok(k),
            (None, Some(e)) => {
                positive(&format!("{path}.young_modulus"), e)?;
                if let Some(nu) = nu {
                    self.check_nu(&format!("{path}.poisson_ratio"), nu)?;
                }
                Ok(Some(e / self.e_per_k))
            }
        }
    }

    /// A given `nu` must be the model's: bond-based peridynamics has one modulus.
    fn check_nu(&self, path: &str, nu: f64) -> Result<(), ProblemError> {
        in_range(path, nu)?;
        match self.nu {
            None => Err(ProblemError::invalid(path, "a 1D bar has no Poisson's ratio: give young_modulus alone")),
            Some(m) if (nu - m).abs() <= NU_RTOL * m => Ok(()),
            Some(m) => Err(ProblemError::invalid(
                path,
                format!(
                    "{nu} is not this bond-based model's: a pairwise bond force fixes nu = {} here ({}); for another nu \
                     use \"type\": \"lps\" (bulk and shear moduli, or young_modulus and poisson_ratio)",
                    if m == 0.25 { "1/4" } else { "1/3" },
                    if m == 0.25 { "3D and plane strain" } else { "plane stress" }
                ),
            )),
        }
    }

    /// The constants of the reference material (modulus `reference`) and of the phases of
    /// moduli `phases`, in order (`result.json`'s `material`).
    pub fn table(&self, reference: f64, phases: impl IntoIterator<Item = f64>) -> Vec<PhaseConstants> {
        std::iter::once(self.constants("reference".into(), reference))
            .chain(phases.into_iter().enumerate().map(|(k, m)| self.constants(format!("phases[{k}]"), m)))
            .collect()
    }

    /// The constants of a phase of modulus `k`.
    pub fn constants(&self, phase: String, k: f64) -> PhaseConstants {
        let e = self.e_per_k * k;
        PhaseConstants {
            phase,
            young_modulus: e,
            poisson_ratio: self.nu,
            bulk_modulus: k,
            shear_modulus: self.nu.map(|nu| e / (2.0 * (1.0 + nu))),
        }
    }
}

/// LPS's `(K, G)` at `path` (`model`) from `bulk_modulus` and `shear_modulus` or from
/// `young_modulus` and `poisson_ratio` (see the module docs).
pub(crate) fn lps_moduli(
    path: &str,
    bulk: Option<f64>,
    shear: Option<f64>,
    young: Option<f64>,
    nu: Option<f64>,
) -> Result<(f64, f64), ProblemError> {
    let missing = |key: &str, why: &str| Err(ProblemError::invalid(format!("{path}.{key}"), format!("missing: {why}")));
    match (bulk, shear, young, nu) {
        (Some(k), Some(g), None, None) => Ok((k, g)),
        (None, None, Some(e), Some(nu)) => {
            positive(&format!("{path}.young_modulus"), e)?;
            in_range(&format!("{path}.poisson_ratio"), nu)?;
            Ok((e / (3.0 * (1.0 - 2.0 * nu)), e / (2.0 * (1.0 + nu))))
        }
        (None, None, None, None) => {
            missing("bulk_modulus", "give bulk_modulus and shear_modulus, or young_modulus and poisson_ratio")
        }
        (Some(_), None, None, None) => missing("shear_modulus", "LPS takes K and G together"),
        (None, Some(_), None, None) => missing("bulk_modulus", "LPS takes K and G together"),
        (None, None, Some(_), None) => missing("poisson_ratio", "LPS takes E and nu together"),
        (None, None, None, Some(_)) => missing("young_modulus", "LPS takes E and nu together"),
        _ => Err(ProblemError::invalid(
            format!("{path}.young_modulus"),
            "give bulk_modulus and shear_modulus, or young_modulus and poisson_ratio, not a mix",
        )),
    }
}

/// The constants of an LPS material `(K, G)`.
pub(crate) fn lps_constants(k: f64, g: f64) -> PhaseConstants {
    PhaseConstants {
        phase: "reference".into(),
        young_modulus: 9.0 * k * g / (3.0 * k + g),
        poisson_ratio: Some((3.0 * k - 2.0 * g) / (2.0 * (3.0 * k + g))),
        bulk_modulus: k,
        shear_modulus: Some(g),
    }
}

fn positive(path: &str, v: f64) -> Result<(), ProblemError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ProblemError::invalid(path, format!("must be > 0, got {v:e}")))
    }
}

/// `-1 < nu < 1/2`: positive-definite isotropic elasticity.
fn in_range(path: &str, nu: f64) -> Result<(), ProblemError> {
    if nu.is_finite() && nu > -1.0 && nu < 0.5 {
        Ok(())
    } else {
        Err(ProblemError::invalid(
            path,
            format!("must be in (-1, 0.5) (isotropic elasticity is stable there), got {nu}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `E, nu -> K, G -> E, nu` round trips (1e-15), and the bond table's `G = E / (2 (1 + nu))`
    /// equals LPS's constants of the same `K` and `G` (a bond model is an LPS material with the
    /// fixed nu).
    #[test]
    fn constants_round_trip() {
        for nu in [-0.5, 0.0, 0.25, 0.3, 0.49] {
            let (k, g) = lps_moduli("model", None, None, Some(210.0), Some(nu)).unwrap();
            let c = lps_constants(k, g);
            assert!((c.young_modulus - 210.0).abs() <= 1e-12 * 210.0, "{c:?}");
            assert!((c.poisson_ratio.unwrap() - nu).abs() <= 1e-14, "{c:?}");
        }
        for (dim, plane, nu) in
            [(2, Some(PlaneModel::Stress), 1.0 / 3.0), (2, Some(PlaneModel::Strain), 0.25), (3, None, 0.25)]
        {
            let b = BondElastic::of(dim, plane);
            let c = b.constants("reference".into(), 2.0);
            let l = lps_constants(c.bulk_modulus, c.shear_modulus.unwrap());
            assert!((l.young_modulus - c.young_modulus).abs() <= 1e-14 * c.young_modulus, "{c:?} vs {l:?}");
            assert!((l.poisson_ratio.unwrap() - nu).abs() <= 1e-15, "{l:?}");
        }
    }
}
