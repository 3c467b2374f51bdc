//! The list of from-region methods: a new sampler is one file plus one line here.

use crate::gvs::{Gvs, GvsParams};
use crate::gvspp::{GvsPlusPlus, GvsPlusPlusParams, GvsPlusPlusParamsError};
use crate::rand::RandomSampler;
use crate::raster_sampler::RasterSampler;
use crate::sampler::Sampler;

/// Method names, as `--method` takes them.
pub const METHODS: [&str; 4] = ["gvs++", "gvs", "rand", "raster"];

/// Parameters of every method (each method reads its own).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MethodParams {
    /// GVS++ parameters.
    pub gvspp: GvsPlusPlusParams,
    /// GVS parameters.
    pub gvs: GvsParams,
    /// RASTER cube-map resolution.
    pub raster_resolution: Option<u32>,
}

/// The tunable parameters of the methods, as a user gives them: the one list that
/// `sightline pvs bake` takes as flags (with the `clap` feature, it is flattened into the
/// command's arguments: each field is `--field-name`, its doc comment is the flag's `--help`
/// text) and the Python `Method` takes as keyword arguments of the same names. `None` (or
/// `false`) keeps the method's default ([`GvsPlusPlusParams::default`],
/// [`GvsParams::default`], [`RasterSampler::default`]); one value may set the same parameter of
/// several methods. [`MethodOverrides::params`] applies them.
///
/// The field order is the order of the flags in `--help`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "clap", derive(clap::Args))]
pub struct MethodOverrides {
    /// GVS++/GVS: random rays per round (paper: 10,000,000). GVS++ has rounds only with
    /// --fixed-rounds: otherwise each batch of 16,384 rays goes to random, border, reverse or
    /// neighbour sampling, whichever found the most new triangles per ray lately (each keeps at
    /// least a tenth), and without --rays or --time the bake stops once the last 10^7 rays found
    /// fewer than --termination new triangles.
    #[cfg_attr(feature = "clap", arg(long))]
    pub n_rand: Option<u64>,
    /// GVS++: rounds of --n-rand random rays, each followed by the whole exploration queue, as in
    /// the paper (sized for a GPU: on a CPU a budget below one round is then spent on random
    /// rays alone).
    #[cfg_attr(feature = "clap", arg(long))]
    pub fixed_rounds: bool,
    /// GVS++: samples per border-polygon edge (paper: 20).
    #[cfg_attr(feature = "clap", arg(long))]
    pub n_abs_edge: Option<u32>,
    /// GVS++/GVS: border offset as a fraction of the scene diagonal (default 1e-6).
    #[cfg_attr(feature = "clap", arg(long))]
    pub delta_abs: Option<f32>,
    /// GVS++: reverse-sampling origins per cell edge (paper: 20).
    #[cfg_attr(feature = "clap", arg(long))]
    pub n_rs_edge: Option<u32>,
    /// GVS++: reverse-sampling origins on the cell surface (paper: 20).
    #[cfg_attr(feature = "clap", arg(long))]
    pub n_rs_area: Option<u32>,
    /// GVS++/GVS: discontinuity threshold as a fraction of the scene diagonal (default 1e-5).
    #[cfg_attr(feature = "clap", arg(long))]
    pub delta: Option<f32>,
    /// GVS++/GVS: without a budget, stop once the last 10^7 rays (GVS: the last round) found
    /// fewer new triangles than this (paper: 10).
    #[cfg_attr(feature = "clap", arg(long))]
    pub termination: Option<usize>,
    /// GVS++: reverse-sample only the discontinuities found at the 9 vertices of a border
    /// polygon, as the paper does (by default every border sample is searched: it finds what
    /// is seen through gaps between found objects, with fewer rays in all).
    #[cfg_attr(feature = "clap", arg(long))]
    pub paper_discontinuities: bool,
    /// RASTER: cube-map face resolution (default 512).
    #[cfg_attr(feature = "clap", arg(long))]
    pub raster_resolution: Option<u32>,
}

impl MethodOverrides {
    /// The default parameters with these overrides applied.
    pub fn params(&self) -> MethodParams {
        let mut p = MethodParams {
            raster_resolution: self.raster_resolution,
            ..MethodParams::default()
        };
        if let Some(v) = self.n_rand {
            p.gvspp.n_rand = v;
            p.gvs.n_rand = v;
        }
        if let Some(v) = self.n_abs_edge {
            p.gvspp.n_abs_edge = v;
        }
        if let Some(v) = self.delta_abs {
            p.gvspp.delta_abs = v;
            p.gvs.delta_abs = v;
        }
        if let Some(v) = self.n_rs_edge {
            p.gvspp.n_rs_edge = v;
        }
        if let Some(v) = self.n_rs_area {
            p.gvspp.n_rs_area = v;
        }
        if let Some(v) = self.delta {
            p.gvspp.delta_discontinuity = v;
            p.gvs.delta_discontinuity = v;
        }
        p.gvspp.fixed_rounds = self.fixed_rounds;
        p.gvspp.edge_discontinuities = !self.paper_discontinuities;
        if let Some(v) = self.termination {
            p.gvspp.termination_threshold = v;
            p.gvs.termination_threshold = v;
        }
        p
    }
}

/// Why [`sampler`] cannot make a sampler.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MethodError {
    /// The name is none of [`METHODS`].
    #[error("unknown method '{name}' (known: {})", METHODS.join(", "))]
    Unknown {
        /// The name as given.
        name: String,
    },
    /// The GVS++ parameters make no sense.
    #[error(transparent)]
    GvsPlusPlus(#[from] GvsPlusPlusParamsError),
    /// The RASTER resolution is outside 1..=8192.
    #[error("raster resolution {0} is outside 1..=8192")]
    RasterResolution(u32),
}

/// The sampler called `name` with `params`.
pub fn sampler(name: &str, params: &MethodParams) -> Result<Box<dyn Sampler>, MethodError> {
    match name {
        "gvs++" | "gvspp" => {
            params.gvspp.validate()?;
            Ok(Box::new(GvsPlusPlus {
                params: params.gvspp.clone(),
            }))
        }
        "gvs" => Ok(Box::new(Gvs {
            params: params.gvs.clone(),
        })),
        "rand" => Ok(Box::new(RandomSampler)),
        "raster" => {
            let mut s = RasterSampler::default();
            if let Some(r) = params.raster_resolution {
                if r == 0 || r > 8192 {
                    return Err(MethodError::RasterResolution(r));
                }
                s.resolution = r;
            }
            Ok(Box::new(s))
        }
        _ => Err(MethodError::Unknown {
            name: name.to_string(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flags' help text states these defaults; it is written by hand, so this keeps it
    /// true.
    #[test]
    fn documented_defaults_are_the_samplers_defaults() {
        let p = MethodOverrides::default().params();
        assert_eq!((p.gvspp.n_rand, p.gvs.n_rand), (10_000_000, 10_000_000));
        assert_eq!(
            (p.gvspp.n_abs_edge, p.gvspp.n_rs_edge, p.gvspp.n_rs_area),
            (20, 20, 20)
        );
        assert_eq!((p.gvspp.delta_abs, p.gvs.delta_abs), (1e-6, 1e-6));
        assert_eq!(
            (p.gvspp.delta_discontinuity, p.gvs.delta_discontinuity),
            (1e-5, 1e-5)
        );
        assert_eq!(
            (p.gvspp.termination_threshold, p.gvs.termination_threshold),
            (10, 10)
        );
        assert!(!p.gvspp.fixed_rounds);
        assert!(p.gvspp.edge_discontinuities);
        assert_eq!(p.raster_resolution, None);
        assert_eq!(RasterSampler::default().resolution, 512);
    }

    #[test]
    fn overrides_set_every_method_they_name() {
        let p = MethodOverrides {
            n_rand: Some(7),
            delta: Some(0.01),
            fixed_rounds: true,
            paper_discontinuities: true,
            ..MethodOverrides::default()
        }
        .params();
        assert_eq!((p.gvspp.n_rand, p.gvs.n_rand), (7, 7));
        assert!(!p.gvspp.edge_discontinuities);
        assert_eq!(
            (p.gvspp.delta_discontinuity, p.gvs.delta_discontinuity),
            (0.01, 0.01)
        );
        assert!(p.gvspp.fixed_rounds);
    }

    #[test]
    fn every_listed_method_exists_under_its_name() {
        for m in METHODS {
            assert_eq!(sampler(m, &MethodParams::default()).unwrap().name(), m);
        }
    }

    #[test]
    fn unknown_method_and_bad_parameters_are_errors() {
        let e = sampler("magic", &MethodParams::default()).err().unwrap();
        assert_eq!(
            e.to_string(),
            "unknown method 'magic' (known: gvs++, gvs, rand, raster)"
        );
        let mut p = MethodParams::default();
        p.gvspp.delta_abs = -1.0;
        assert_eq!(
            sampler("gvs++", &p).err(),
            Some(MethodError::GvsPlusPlus(GvsPlusPlusParamsError::DeltaAbs(
                -1.0
            )))
        );
        p = MethodParams {
            raster_resolution: Some(0),
            ..MethodParams::default()
        };
        assert_eq!(
            sampler("raster", &p).err(),
            Some(MethodError::RasterResolution(0))
        );
    }
}
