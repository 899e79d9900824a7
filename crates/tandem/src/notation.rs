//! Notation (filled in below).
