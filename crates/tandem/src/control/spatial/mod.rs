//! Spatial cooperative control (SPEC-spatial S5): the object-level model, the wrench distribution and the model bound `f^U`.
pub mod bound;
pub mod distribute;
pub mod model;
