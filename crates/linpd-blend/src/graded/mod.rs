//! A graded local mesh (issue #31): bilinear / trilinear elements on a quadtree / octree aligned
//! with the lattice (work in progress).

pub(crate) mod element;
