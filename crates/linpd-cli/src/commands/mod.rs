//! One module per command: each function takes the command's parsed arguments, runs it and
//! prints its report on stdout (phase lines and progress bars on stderr, see `Reporter`).

mod bench;
mod coarsen;
mod export;
mod modes;
mod run;
mod solve;
mod study;
mod validate;

pub(crate) use bench::bench;
pub(crate) use coarsen::coarsen;
pub(crate) use export::export;
pub(crate) use modes::modes;
pub(crate) use run::run;
pub(crate) use solve::solve;
pub(crate) use study::study;
pub(crate) use validate::validate;
