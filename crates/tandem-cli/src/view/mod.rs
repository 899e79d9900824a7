//! Watching a run move: the planar animation ([`planar`]: GIF frames and an HTML player) and the
//! spatial 3-D viewer ([`spatial`]: `viewer.html` and PNG snapshots).

pub mod planar;
pub mod spatial;
