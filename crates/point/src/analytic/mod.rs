//! Exact analytic from-point visibility (Auzinger et al. 2013). Being written.
