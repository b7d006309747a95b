//! Memory guards: an estimate of what a model and solver path will allocate, compared with
//! the memory the machine has available *before* allocating, so that a scene too large for
//! the machine is an error stating both amounts instead of an allocation abort (SIGABRT) half
//! way through assembly.
//!
//! The available amount is, in order: the environment variable [`LIMIT_ENV`] (GiB; to cap a
//! run on a shared machine, and for reproducible tests), `MemAvailable` of `/proc/meminfo`
//! (Linux), or [`FALLBACK_AVAILABLE_BYTES`] elsewhere.
//!
//! The bytes of each structure live in the crate that defines it (`linpd_bond::memory`,
//! `linpd_lps::memory`, `linpd_solve::memory`, ...; the lattice's nodes and neighbour counts
//! here, [`NODE_BYTES`], [`neighbours`]); a scene sums those its solver plan names
//! (`linpd_scene::memory`); the factor fill is checked in linpd-solve after the symbolic
//! analysis.

use thiserror::Error;

/// Bytes per GiB.
pub const GIB: f64 = 1073741824.0;

/// The available memory assumed where `/proc/meminfo` cannot be read.
pub const FALLBACK_AVAILABLE_BYTES: f64 = 16.0 * GIB;

/// Environment variable overriding the available memory, in GiB (e.g. `LINPD_MEMORY_GIB=4`).
pub const LIMIT_ENV: &str = "LINPD_MEMORY_GIB";

/// An estimate above the available memory.
#[derive(Debug, Clone, PartialEq, Error)]
#[error(
    "{what} would take an estimated {:.1} GiB, more than the {:.1} GiB available ({origin}); {hint}",
    bytes / GIB,
    available / GIB
)]
pub struct OutOfMemory {
    /// What would be allocated (`"the LPS tangent of 274625 nodes, reach 2 delta"`).
    pub what: String,
    /// The estimate, bytes.
    pub bytes: f64,
    /// The memory available, bytes.
    pub available: f64,
    /// Where `available` comes from (`MemAvailable in /proc/meminfo`, [`LIMIT_ENV`], ...).
    pub origin: &'static str,
    /// What to change.
    pub hint: String,
}

/// The memory available for a new allocation, in bytes, and where the number comes from.
pub fn available_bytes() -> (f64, &'static str) {
    if let Some(gib) = std::env::var(LIMIT_ENV).ok().and_then(|v| v.trim().parse::<f64>().ok()) {
        if gib.is_finite() && gib > 0.0 {
            return (gib * GIB, "LINPD_MEMORY_GIB");
        }
    }
    if let Some(kib) = mem_available_kib() {
        return (kib * 1024.0, "MemAvailable in /proc/meminfo");
    }
    (FALLBACK_AVAILABLE_BYTES, "fixed limit: /proc/meminfo not readable")
}

/// `MemAvailable` of `/proc/meminfo`, KiB.
fn mem_available_kib() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// `Err` when `bytes` (what `what` would allocate) exceeds the available memory.
pub fn check(what: impl Into<String>, bytes: f64, hint: impl Into<String>) -> Result<(), OutOfMemory> {
    let (available, origin) = available_bytes();
    if bytes <= available {
        return Ok(());
    }
    Err(OutOfMemory { what: what.into(), bytes, available, origin, hint: hint.into() })
}

/// Per node of a scene on a lattice, for the memory guard: positions, lattice index, family
/// offsets and the per-node lists the family is built from, layer flags.
pub const NODE_BYTES: f64 = 96.0;

/// The largest stencil enumerated exactly; beyond it the ball's volume in lattice units is
/// used (enumerating a 3D stencil of ratio 1e4 would itself never end).
pub const EXACT_STENCIL: f64 = 2000.0;

/// `pi^(d/2) / Gamma(d/2 + 1) r^d`: lattice points per unit ball of radius `r` spacings.
pub fn ball(dim: usize, r: f64) -> f64 {
    match dim {
        1 => 2.0 * r,
        2 => std::f64::consts::PI * r * r,
        _ => 4.0 / 3.0 * std::f64::consts::PI * r.powi(3),
    }
}

/// Lattice neighbours within `ratio` spacings (self excluded).
pub fn neighbours(dim: usize, ratio: f64) -> f64 {
    if ball(dim, ratio) > EXACT_STENCIL {
        return ball(dim, ratio);
    }
    crate::family::lattice_stencil(dim, ratio).len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn message_states_both_amounts_in_gib() {
        let e = OutOfMemory {
            what: "the tangent".into(),
            bytes: 40.0 * GIB,
            available: 16.0 * GIB,
            origin: "MemAvailable in /proc/meminfo",
            hint: "use a coarser spacing".into(),
        };
        assert_eq!(
            e.to_string(),
            "the tangent would take an estimated 40.0 GiB, more than the 16.0 GiB available (MemAvailable in /proc/meminfo); \
             use a coarser spacing"
        );
        assert!(available_bytes().0 > 0.0);
        assert!(check("nothing", 0.0, "").is_ok());
        assert!(check("everything", f64::INFINITY, "").is_err());
    }
}
