//! One module per subcommand.

pub(crate) mod bench;
pub(crate) mod convert;
pub(crate) mod cull;
pub(crate) mod demo;
pub(crate) mod demo_sections;
pub(crate) mod eval;
pub(crate) mod info;
pub(crate) mod pvs;
pub(crate) mod render;
pub(crate) mod report;
pub(crate) mod view;
pub(crate) mod visible;
