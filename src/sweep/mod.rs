//! sweep stage.
