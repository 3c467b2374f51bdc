//! Scene validation (being written).
