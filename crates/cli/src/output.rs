//! Writing results: PNG images (atomically), JSON to stdout, the id image (its colours come
//! from `sightline_eval::report::shading`), and the checks every command makes on its output
//! paths before working (an output that is an input, an image extension that is not PNG).
//!
//! Colour conventions: the id and shaded images are 8-bit colours chosen as stored (sRGB codes,
//! untagged); images of linear quantities averaged over pixel areas (the analytically
//! anti-aliased grey image) are encoded with the sRGB transfer function and tagged sRGB, so an
//! edge pixel half covered by white shows as half the light, not as code 128.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use anyhow::{bail, Context, Result};
use image::RgbImage;
use sightline_core::atomic_file::write_atomic;
use sightline_core::raster::Frame;
use sightline_core::Hit;
use sightline_eval::report::shading::{id_colour, BACKGROUND};

/// Where `path` is or would be: its canonical path, or for a file not yet there its
/// canonical parent (`.` for a bare name) joined with its name. `None` when the parent does
/// not exist either (the write will fail with its own error).
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}

/// True when `a` and `b` are one file: the same canonical path (symbolic links, `..`), or on
/// Unix the same device and inode (hard links).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y)
}

/// Refuses to start when one of `outputs` is one of `inputs`: a command writes its results
/// atomically over the output, so `render t.glb -o t.glb` would replace the scene by an image.
/// Inputs that are not files (procedural scene specs) never match. Commands call this before
/// any work, so the refusal costs nothing.
pub(crate) fn refuse_overwriting_inputs(outputs: &[&Path], inputs: &[&Path]) -> Result<()> {
    for output in outputs {
        if let Some(input) = inputs
            .iter()
            .find(|input| input.exists() && same_file(output, input))
        {
            bail!(
                "the output {} is the input {}: refusing to overwrite an input; choose another \
                 output path",
                output.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Refuses an image output whose extension is not `.png`: the images are written as PNG only
/// (their id colours must survive exactly, which a lossy format would not keep), and a file
/// named `.jpg` holding PNG bytes misleads every tool that trusts the name.
pub(crate) fn require_png_extension(path: &Path, option: &str) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !ext.eq_ignore_ascii_case("png") {
        bail!(
            "{option} {}: images are written as PNG only; name the file .png (supported \
             formats: png)",
            path.display()
        );
    }
    Ok(())
}

/// Writes `image` as PNG to `path` atomically.
pub(crate) fn save_png(image: &RgbImage, path: &Path) -> Result<()> {
    write_atomic(path, |w| {
        image
            .write_to(w, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// The 8-bit sRGB code of a linear-light value (IEC 61966-2-1 transfer function: linear below
/// 0.0031308, then `1.055 v^(1/2.4) - 0.055`); values outside [0, 1] are clamped, NaN gives 0.
pub(crate) fn srgb_from_linear(linear: f32) -> u8 {
    let v = if linear.is_nan() {
        0.0
    } else {
        f64::from(linear).clamp(0.0, 1.0)
    };
    let encoded = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (encoded * 255.0).round() as u8
}

/// The 255 linear values where [`srgb_from_linear`] steps up: code `k + 1` from `steps[k]` on.
fn srgb_steps() -> &'static [f32; 255] {
    static STEPS: OnceLock<[f32; 255]> = OnceLock::new();
    STEPS.get_or_init(|| {
        std::array::from_fn(|k| {
            // The smallest f32 in [0, 1] whose code exceeds k: bisection over the bit patterns,
            // which non-negative floats order like their values.
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if usize::from(srgb_from_linear(f32::from_bits(mid))) > k {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            f32::from_bits(lo)
        })
    })
}

/// [`srgb_from_linear`] by a search among [`srgb_steps`]: the same codes without a `powf` per
/// pixel (which costs 20-35 ms for a 1024² image on the development machine).
fn srgb_from_linear_by_steps(linear: f32) -> u8 {
    // NaN compares false with every step, so it gets code 0 as in `srgb_from_linear`.
    srgb_steps().partition_point(|&s| s <= linear) as u8
}

/// Writes linear-light grey values (row-major, `width × height`, nominally in [0, 1]) to `path`
/// atomically as an 8-bit PNG, encoded with [`srgb_from_linear`] and tagged with an sRGB chunk
/// plus the gAMA 1/2.2 (45455) that the PNG specification recommends beside it for readers
/// without sRGB support.
pub(crate) fn save_linear_grey_png(
    values: &[f32],
    width: u32,
    height: u32,
    path: &Path,
) -> Result<()> {
    debug_assert_eq!(values.len(), width as usize * height as usize);
    let pixels: Vec<u8> = values
        .iter()
        .map(|&v| srgb_from_linear_by_steps(v))
        .collect();
    write_atomic(path, |w| {
        let mut encoder = png::Encoder::new(w, width, height);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Eight);
        // What the `image` crate's encoder (used for the other PNGs) defaults to; the `png`
        // crate's own default, zlib level 6, took 13 ms more on a 1024² image for 15 % less.
        encoder.set_compression(png::Compression::Fast);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        encoder.set_source_gamma(png::ScaledFloat::from_scaled(45455));
        let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
        writer
            .write_image_data(&pixels)
            .map_err(std::io::Error::other)?;
        writer.finish().map_err(std::io::Error::other)
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// Prints `value` as pretty JSON on stdout.
pub(crate) fn print_json<T: serde::Serialize>(value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    outln!("{text}");
    Ok(())
}

/// Triangle-id image: every triangle its own colour.
pub(crate) fn id_image(frame: &Frame) -> RgbImage {
    RgbImage::from_fn(frame.width, frame.height, |x, y| {
        let id = frame.ids[(y * frame.width + x) as usize];
        image::Rgb(if id == Hit::NONE {
            BACKGROUND
        } else {
            id_colour(id)
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_of_half_linear_is_188() {
        // 1.055 · 0.5^(1/2.4) - 0.055 = 0.7354, · 255 = 187.5 (the gamma-encoded grey of 50 %).
        assert_eq!(srgb_from_linear(0.5), 188);
    }

    #[test]
    fn srgb_keeps_black_and_white() {
        assert_eq!(srgb_from_linear(0.0), 0);
        assert_eq!(srgb_from_linear(1.0), 255);
    }

    #[test]
    fn srgb_clamps_out_of_range_and_nan() {
        assert_eq!(srgb_from_linear(-0.25), 0);
        assert_eq!(srgb_from_linear(1.5), 255);
        assert_eq!(srgb_from_linear(f32::NAN), 0);
    }

    #[test]
    fn srgb_is_monotone_and_reaches_every_code() {
        let codes: Vec<u8> = (0..=100_000)
            .map(|k| srgb_from_linear(k as f32 / 100_000.0))
            .collect();
        assert!(codes.windows(2).all(|w| w[0] <= w[1]));
        // The linear toe (12.92 · 255 codes per unit) is steep enough that no code is skipped.
        assert!(codes.windows(2).all(|w| w[1] - w[0] <= 1));
    }

    #[test]
    fn srgb_by_steps_matches_the_formula() {
        let specials = [
            0.0,
            -0.0,
            -1.0,
            1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            0.003_130_8,
        ];
        let grid = (0..=200_000).map(|k| k as f32 / 200_000.0);
        // Each step and the float just below it, where a wrong step would show first.
        let around = srgb_steps()
            .iter()
            .flat_map(|&s| [s, f32::from_bits(s.to_bits() - 1)]);
        for v in grid.chain(specials).chain(around) {
            assert_eq!(srgb_from_linear_by_steps(v), srgb_from_linear(v), "{v}");
        }
    }

    #[test]
    fn linear_grey_png_is_tagged_srgb() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let path = dir.path().join("grey.png");
        save_linear_grey_png(&[0.0, 0.5, 1.0, 0.2], 2, 2, &path).expect("written");
        let bytes = std::fs::read(&path).expect("read back");
        let chunk = |name: &[u8]| bytes.windows(4).position(|w| w == name);
        // sRGB, then gAMA = 45455 (big-endian) before the image data.
        let (srgb, gama, idat) = (chunk(b"sRGB"), chunk(b"gAMA"), chunk(b"IDAT"));
        assert!(srgb.is_some() && gama.is_some() && srgb < idat && gama < idat);
        let g = gama.expect("gAMA") + 4;
        assert_eq!(bytes[g..g + 4], 45_455u32.to_be_bytes());
        let img = image::open(&path).expect("decodes").into_luma8();
        assert_eq!(img.into_raw(), vec![0, 188, 255, 124]);
    }
}
