//! contact stage.
