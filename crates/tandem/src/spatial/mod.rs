//! Spatial algebra on fixed-size nalgebra types (SPEC-spatial S1). Filled in by the dynamics work.
