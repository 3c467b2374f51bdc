//! Deterministic procedural scenes, so every command has an embedded default scene and tests
//! and benchmarks can dial the triangle count.
//!
//! Spec syntax: `procedural:NAME[?seed=S&size=N]`, where `size` is the *approximate* triangle
//! count (each generator rounds it to whole buildings, rooms, grid rows, boxes or spheres) and
//! `seed` picks the random layout. The same name, seed and size give the same triangles, in the
//! same order, on every run and platform.
//!
//! | name | what | objects |
//! |---|---|---|
//! | `city` | street grid of boxy buildings (urban canyon) on a ground plane, Z up | one per building, one per ground block |
//! | `rooms` | a storey of rooms joined by doors, with furniture, Z up | one per wall segment, one per room (floor, ceiling, furniture) |
//! | `canyon` | height field with a meandering river canyon, Z up | one per 16x16 terrain chunk |
//! | `boxes` | random boxes in a 100³ volume | one per box |
//! | `spheres` | random UV spheres ("planets") in a 100³ volume | one per sphere |
//! | `spikes` | a grid of square pyramids of random height (SPIKES of the analytic paper), Y up | one per row |
//! | `zoneplate` | two superposed zone plates (ZONEPLATES of the analytic paper), Z up | one per plate |

mod boxes;
mod canyon;
mod city;
pub(super) mod params;
mod rooms;
mod shapes;
mod spheres;
mod spikes;
mod zoneplate;

use super::builder::SceneBuilder;
use super::types::Scene;

pub use city::City;
pub use params::{Params, SpecError, GENERATORS, MAX_SIZE};

/// Generates the scene. Unknown names (not produced by [`Params::parse`]) give boxes.
pub fn generate(params: &Params) -> Scene {
    let mut b = SceneBuilder::new(params.spec());
    match params.name.as_str() {
        "city" => city::generate(&mut b, params.seed, params.size),
        "rooms" => rooms::generate(&mut b, params.seed, params.size),
        "canyon" => canyon::generate(&mut b, params.seed, params.size),
        "spheres" => spheres::generate(&mut b, params.seed, params.size),
        "spikes" => spikes::generate(&mut b, params.seed, params.size),
        "zoneplate" => zoneplate::generate(&mut b, params.seed, params.size),
        _ => boxes::generate(&mut b, params.seed, params.size),
    }
    b.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validate::validate;

    #[test]
    fn parse_defaults() {
        let p = Params::parse("city").unwrap();
        assert_eq!((p.seed, p.size), (1, 20_000));
    }

    #[test]
    fn parse_round_trips() {
        let p = Params::parse("rooms?seed=9&size=1_000").unwrap();
        assert_eq!(
            Params::parse(p.spec().trim_start_matches("procedural:")).unwrap(),
            p
        );
    }

    #[test]
    fn parse_rejects_unknown_generator() {
        let e = Params::parse("town").unwrap_err();
        assert_eq!(
            e,
            SpecError::UnknownGenerator {
                name: "town".into()
            }
        );
        assert_eq!(
            e.to_string(),
            "unknown generator 'town' (known: city, rooms, canyon, boxes, spheres, spikes, zoneplate)"
        );
    }

    #[test]
    fn parse_rejects_size_out_of_range() {
        let e = Params::parse("city?size=0").unwrap_err();
        assert_eq!(e, SpecError::SizeOutOfRange { size: 0 });
        assert_eq!(e.to_string(), "size=0: must be in 1..=200000000");
    }

    #[test]
    fn parse_rejects_negative_number() {
        let e = Params::parse("city?size=-3").unwrap_err();
        assert!(matches!(e, SpecError::NotANumber { .. }));
        assert_eq!(e.to_string(), "size=-3: not a non-negative integer");
    }

    #[test]
    fn parse_rejects_unknown_parameter() {
        let e = Params::parse("city?colour=red").unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown parameter 'colour' (known: seed, size)"
        );
    }

    #[test]
    fn parse_rejects_part_without_value() {
        let e = Params::parse("city?seed").unwrap_err();
        assert_eq!(e.to_string(), "'seed' is not key=value");
    }

    #[test]
    fn every_generator_is_deterministic_valid_and_near_its_size() {
        for name in GENERATORS {
            for size in [2_000usize, 20_000] {
                let p = Params {
                    name: name.into(),
                    seed: 3,
                    size,
                };
                let a = generate(&p);
                let b = generate(&p);
                assert_eq!(
                    a.geometry_hash(),
                    b.geometry_hash(),
                    "{name} not deterministic"
                );
                let n = a.triangle_count();
                assert!(
                    n as f64 >= size as f64 * 0.5 && n as f64 <= size as f64 * 1.6,
                    "{name} size {size} gave {n} triangles"
                );
                let report = validate(&a);
                assert!(report.errors().is_empty(), "{name}: {:?}", report.errors());
                assert_eq!(
                    report.degenerate_count, 0,
                    "{name} has degenerate triangles"
                );
                assert!(a.objects.len() > 1, "{name} has a single object");
            }
        }
    }

    #[test]
    fn seeds_change_layout() {
        for name in GENERATORS {
            let a = generate(&Params {
                name: name.into(),
                seed: 1,
                size: 2000,
            });
            let b = generate(&Params {
                name: name.into(),
                seed: 2,
                size: 2000,
            });
            assert_ne!(
                a.geometry_hash(),
                b.geometry_hash(),
                "{name} ignores its seed"
            );
        }
    }
}
