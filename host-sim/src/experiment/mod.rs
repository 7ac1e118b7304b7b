//! The experiment: training, evaluation and grasping runs over the bus, their reports and
//! plots, and the `trn` command line.

pub mod cli;
pub mod compare;
pub mod controller_loop;
#[cfg(feature = "plot")]
pub mod plot;
pub mod report;
pub mod run;
pub mod session;
pub mod slcan_bus;
pub mod summary;

pub use report::Report;
