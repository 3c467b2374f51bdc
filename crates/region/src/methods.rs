//! The list of from-region methods: a new sampler is one file plus one line here.

use crate::gvs::{Gvs, GvsParams};
use crate::gvspp::{GvsPlusPlus, GvsPlusPlusParams};
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

/// The sampler called `name` with `params`.
pub fn sampler(name: &str, params: &MethodParams) -> Result<Box<dyn Sampler>, String> {
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
                    return Err(format!("raster resolution {r} is outside 1..=8192"));
                }
                s.resolution = r;
            }
            Ok(Box::new(s))
        }
        _ => Err(format!(
            "unknown method '{name}' (known: {})",
            METHODS.join(", ")
        )),
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
        assert!(e.contains("unknown"));
        let mut p = MethodParams::default();
        p.gvspp.delta_abs = -1.0;
        assert!(sampler("gvs++", &p).is_err());
        p = MethodParams {
            raster_resolution: Some(0),
            ..MethodParams::default()
        };
        assert!(sampler("raster", &p).is_err());
    }
}
