//! `sightline bench`: whole-algorithm throughput, measured side by side in one run.
