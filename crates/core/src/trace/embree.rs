//! Embree 3 backend (being written).
