//! Run reports: what a finished run amounts to, computed from its log, no I/O (the CLI writes
//! them). Today [`metrics`]: the SPEC §5 summary (`summary.json`) of a planar run.

pub mod metrics;
