//! The time series of a run (SPEC §5): preallocated columns with names and units.

use crate::drive::Record;
use crate::plant::ClosedChain;

/// One logged column: name, unit and samples (capacity reserved at start).
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// Name, e.g. `x_o.x`.
    pub name: String,
    /// Unit, e.g. `m`.
    pub unit: String,
    /// Samples.
    pub data: Vec<f64>,
}

/// The time series of a run (SPEC §5), column-major, preallocated.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Log {
    /// Columns in a fixed order (see [`Log::names`]).
    pub columns: Vec<Column>,
}

impl Log {
    pub(super) fn with_layout(layout: &[(String, String)], rows: usize) -> Self {
        Log {
            columns: layout
                .iter()
                .map(|(n, u)| Column {
                    name: n.clone(),
                    unit: u.clone(),
                    data: Vec::with_capacity(rows),
                })
                .collect(),
        }
    }
    /// Column by name.
    pub fn get(&self, name: &str) -> Option<&[f64]> {
        self.columns
            .iter()
            .find(|c| c.name == name)
            .map(|c| c.data.as_slice())
    }
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, |c| c.data.len())
    }
    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Column names with units, `name [unit]`.
    pub fn names(&self) -> Vec<String> {
        self.columns
            .iter()
            .map(|c| format!("{} [{}]", c.name, c.unit))
            .collect()
    }
}

/// The column layout of a run (SPEC §5): `t`; the plant's true object state (planar
/// `x_o.{x,y,theta}`); the driver record's head (planar `x_hat … w_norm`); the joint torques
/// `tau_q*`; the plant's true joint state (planar `q*`; spatial `q*`, `qd*`); the grasp wrenches
/// `F{i}.*` (world axes); the wrist readings `F_meas{i}.*` (planar world axes, spatial tool
/// axes); the record's tail (planar `Q`, `margin`); the plant's drift columns; the plant's
/// contact columns (spatial contact grasps' pads).
pub fn layout<P: ClosedChain, R: Record>(plant: &P, rec: &R) -> Vec<(String, String)> {
    let mut l: Vec<(String, String)> = vec![("t".into(), "s".into())];
    l.extend(plant.object_columns());
    l.extend(rec.head_columns());
    for (k, u) in plant.torque_units().into_iter().enumerate() {
        l.push((format!("tau_q{}", k + 1), u));
    }
    l.extend(plant.joint_columns());
    let ch = plant.wrench_channels();
    for group in ["F", "F_meas"] {
        for i in 0..plant.n_arms() {
            for (a, u) in &ch {
                l.push((format!("{group}{}.{a}", i + 1), u.to_string()));
            }
        }
    }
    l.extend(rec.tail_columns());
    l.extend(plant.drift_columns());
    l.extend(plant.contact_columns());
    l
}
