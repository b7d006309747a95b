//! Reading and writing coarsened moduli (Matrix Market + node list). Placeholder: filled in by
//! the I/O work for issue #4.
