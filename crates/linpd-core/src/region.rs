//! Regions that name node sets: boxes (intervals in 1D), unions and differences.
//!
//! Membership is closed (a node on a box face belongs to the box) with a tolerance of
//! [`GEOMETRY_RTOL`](crate::GEOMETRY_RTOL) times the lattice spacing, so that nodes computed
//! as `min + i h` in floating point are not lost on round-off.

use crate::{CoreError, Grid, Point};

/// A subset of space.
#[derive(Debug, Clone, PartialEq)]
pub enum Region {
    /// Every point.
    All,
    /// The closed box `[min, max]` (an interval in 1D, a rectangle in 2D).
    Box {
        /// Lower corner.
        min: Vec<f64>,
        /// Upper corner.
        max: Vec<f64>,
    },
    /// Points in any of the regions.
    Union(Vec<Region>),
    /// Points in the first region and not in the second.
    Difference(Box<Region>, Box<Region>),
}

impl Region {
    /// Checks that every box has `dim` components and `min <= max`.
    pub fn validate(&self, dim: usize) -> Result<(), CoreError> {
        match self {
            Region::All => Ok(()),
            Region::Box { min, max } => {
                for v in [min, max] {
                    if v.len() != dim {
                        return Err(CoreError::Components { expected: dim, got: v.len() });
                    }
                }
                for a in 0..dim {
                    if !(min[a].is_finite() && max[a].is_finite()) || min[a] > max[a] {
                        return Err(CoreError::param(
                            "box",
                            format!("axis {a}: min ({}) must be <= max ({})", min[a], max[a]),
                        ));
                    }
                }
                Ok(())
            }
            Region::Union(parts) => parts.iter().try_for_each(|r| r.validate(dim)),
            Region::Difference(a, b) => {
                a.validate(dim)?;
                b.validate(dim)
            }
        }
    }

    /// True when `x` lies in the region, faces included up to `tol`.
    pub fn contains(&self, x: &Point, dim: usize, tol: f64) -> bool {
        match self {
            Region::All => true,
            Region::Box { min, max } => (0..dim).all(|a| x[a] >= min[a] - tol && x[a] <= max[a] + tol),
            Region::Union(parts) => parts.iter().any(|r| r.contains(x, dim, tol)),
            Region::Difference(a, b) => a.contains(x, dim, tol) && !b.contains(x, dim, tol),
        }
    }

    /// The nodes of `grid` inside the region, ascending.
    pub fn nodes(&self, grid: &Grid) -> Vec<usize> {
        let tol = crate::GEOMETRY_RTOL * grid.spacing();
        (0..grid.len()).filter(|&n| self.contains(&grid.position(n), grid.dim(), tol)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Placement;

    #[test]
    fn boxes_unions_differences_select_lattice_nodes() {
        let g = Grid::new(&[0.0], &[1.0], 0.1, 0.2, Placement::Vertex).unwrap();
        let left = Region::Box { min: vec![-1.0], max: vec![0.0] };
        // -0.2, -0.1, 0.0: the face node at 0 is included despite round-off.
        assert_eq!(left.nodes(&g).len(), 3);
        let both = Region::Union(vec![left.clone(), Region::Box { min: vec![1.0], max: vec![2.0] }]);
        assert_eq!(both.nodes(&g).len(), 6);
        let inner = Region::Difference(Box::new(Region::All), Box::new(both));
        assert_eq!(inner.nodes(&g).len(), g.len() - 6);
        // 0.3 is computed as 0.30000000000000004 on the lattice: still inside [0.3, 0.3].
        assert_eq!(Region::Box { min: vec![0.3], max: vec![0.3] }.nodes(&g).len(), 1);
    }

    #[test]
    fn validation_names_the_problem() {
        let r = Region::Box { min: vec![1.0, 0.0], max: vec![0.0, 1.0] };
        assert!(matches!(r.validate(2), Err(CoreError::Parameter { .. })));
        assert!(matches!(r.validate(3), Err(CoreError::Components { expected: 3, got: 2 })));
    }
}
