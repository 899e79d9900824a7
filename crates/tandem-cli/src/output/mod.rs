//! What a run writes: the summary, the time series, the terminal and Markdown tables
//! ([`table`]), for planar and [`spatial`] runs.

pub mod planar;
pub mod spatial;
pub mod table;
