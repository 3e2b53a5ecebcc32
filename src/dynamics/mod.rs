//! dynamics stage.
