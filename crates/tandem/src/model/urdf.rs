//! URDF reading (SPEC-spatial S2). Filled in by the URDF work.
