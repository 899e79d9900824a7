//! The planar animation: [`anim`] renders frames, [`scene`] turns a run's log into them.

pub mod anim;
pub mod scene;
