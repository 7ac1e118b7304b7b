//! `trn-studies`: studies of many runs on the run engine ([`trn_bench`]): study files, runs
//! in parallel, one file per finished run, resume, shards and their merge ([`study`]), and
//! the three kinds of study: [`compare`] (configurations over seeds), [`sweep`] (plant
//! variants over seeds) and [`lifelong`] (controllers' snapshot curves over a long run).
//! Like the engine it prints nothing: its tables are text the caller prints.

pub mod compare;
pub mod lifelong;
pub mod study;
pub mod sweep;
