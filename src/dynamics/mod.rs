//! dynamics stage.

pub mod abradable;
