//! sightline-cull: run-time occlusion culling with a uniform grid, occlusion queries and query
//! scheduling (Seletsky 2013), and a software occlusion buffer backend. Being written.
#![deny(missing_docs)]
