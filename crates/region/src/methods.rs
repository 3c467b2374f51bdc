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

/// Optional overrides of the default parameters, as the command line and the Python package
/// take them; one value may set the same parameter of several methods.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MethodOverrides {
    /// Random rays per round (GVS++ and GVS).
    pub n_rand: Option<u64>,
    /// Samples along each long edge of the ABS border polygon (GVS++).
    pub n_abs_edge: Option<u32>,
    /// Border polygon offset as a fraction of the scene diagonal (GVS++ and GVS).
    pub delta_abs: Option<f32>,
    /// Reverse-sampling samples per edge (GVS++).
    pub n_rs_edge: Option<u32>,
    /// Reverse-sampling samples per area (GVS++).
    pub n_rs_area: Option<u32>,
    /// Discontinuity threshold as a fraction of the scene diagonal (GVS++ and GVS).
    pub delta: Option<f32>,
    /// Rounds without news before stopping (GVS++ and GVS).
    pub termination: Option<usize>,
    /// RASTER cube-map resolution.
    pub raster_resolution: Option<u32>,
    /// GVS++: every round casts `n_rand` random rays, as in the paper (default: adaptive under a
    /// budget).
    pub fixed_rounds: bool,
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
