//! Test-only helpers shared by several integration tests (`mod support;`); the presets that
//! benches, examples and the CLI use too are in `tandem::presets`.
#![allow(dead_code)]

use tandem::model::planar::object::ObjectParams;
use tandem::plant::planar::PlantParams;

/// A plant with no damping on the object (for energy-conservation checks).
pub fn undamped(mut p: PlantParams) -> PlantParams {
    p.object = ObjectParams {
        damping: [0.0; 3],
        ..p.object
    };
    p
}
