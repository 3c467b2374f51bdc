//! The parameters of a procedural scene: the generator names, [`Params`] and the parser of the
//! part of a spec after `procedural:`, with its [`SpecError`]. A leaf: the scene's
//! [`LoadError`](crate::scene::LoadError) names [`SpecError`] from here, not from the module's
//! face (`mod.rs`), which re-exports these and generates the scenes.

/// The generator names, in the order `--help` lists them.
pub const GENERATORS: [&str; 7] = [
    "city",
    "rooms",
    "canyon",
    "boxes",
    "spheres",
    "spikes",
    "zoneplate",
];

/// The largest `size` accepted: beyond this a scene would not fit the memory of the machines
/// this is built for (about 24 bytes per triangle plus ray-casting structures).
pub const MAX_SIZE: usize = 200_000_000;

/// Parameters of a procedural scene.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Params {
    /// Generator name, one of [`GENERATORS`].
    pub name: String,
    /// Random seed.
    pub seed: u64,
    /// Approximate triangle count.
    pub size: usize,
}

/// Why the part of a spec after `procedural:` does not parse.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum SpecError {
    /// The name is none of [`GENERATORS`].
    #[error("unknown generator '{name}' (known: {})", GENERATORS.join(", "))]
    UnknownGenerator {
        /// The name as given.
        name: String,
    },
    /// A query part without `=`.
    #[error("'{pair}' is not key=value")]
    NotKeyValue {
        /// The part as given.
        pair: String,
    },
    /// A value that is not a non-negative integer (`_` separators allowed).
    #[error("{key}={value}: not a non-negative integer")]
    NotANumber {
        /// The key.
        key: String,
        /// The value as given.
        value: String,
    },
    /// A `size` of 0 or above [`MAX_SIZE`].
    #[error("size={size}: must be in 1..={MAX_SIZE}")]
    SizeOutOfRange {
        /// The size given.
        size: usize,
    },
    /// A key other than `seed` and `size`.
    #[error("unknown parameter '{key}' (known: seed, size)")]
    UnknownParameter {
        /// The key as given.
        key: String,
    },
}

impl Params {
    /// Default parameters of generator `name` (seed 1, a size that renders in well under a
    /// second).
    pub fn new(name: &str) -> Self {
        let size = match name {
            "city" => 20_000,
            "rooms" => 8_000,
            "canyon" => 32_000,
            "spheres" => 20_000,
            _ => 12_000,
        };
        Self {
            name: name.to_string(),
            seed: 1,
            size,
        }
    }

    /// Parses `NAME[?seed=S&size=N]` (the part after `procedural:`).
    pub fn parse(s: &str) -> Result<Self, SpecError> {
        let (name, query) = s.split_once('?').unwrap_or((s, ""));
        if !GENERATORS.contains(&name) {
            return Err(SpecError::UnknownGenerator {
                name: name.to_string(),
            });
        }
        let mut params = Self::new(name);
        for pair in query.split('&').filter(|p| !p.is_empty()) {
            let (key, value) = pair.split_once('=').ok_or_else(|| SpecError::NotKeyValue {
                pair: pair.to_string(),
            })?;
            let number = || {
                value
                    .replace('_', "")
                    .parse::<u64>()
                    .map_err(|_| SpecError::NotANumber {
                        key: key.to_string(),
                        value: value.to_string(),
                    })
            };
            match key {
                "seed" => params.seed = number()?,
                "size" => {
                    let n = number()? as usize;
                    if n == 0 || n > MAX_SIZE {
                        return Err(SpecError::SizeOutOfRange { size: n });
                    }
                    params.size = n;
                }
                _ => {
                    return Err(SpecError::UnknownParameter {
                        key: key.to_string(),
                    })
                }
            }
        }
        Ok(params)
    }

    /// The spec string that parses back to these parameters.
    pub fn spec(&self) -> String {
        format!(
            "procedural:{}?seed={}&size={}",
            self.name, self.seed, self.size
        )
    }
}
