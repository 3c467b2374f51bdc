//! sightline-point: from-point visibility. [`analytic`] computes the exact visible fragments of
//! every triangle (and analytically anti-aliased images); [`rv`] computes a conservative
//! visible set while the scene streams through in bounded memory.
#![deny(missing_docs)]

pub mod analytic;
pub mod rv;
