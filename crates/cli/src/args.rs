//! Argument groups shared by every command: the scene and the camera.

use anyhow::{bail, Context, Result};
use glam::Vec3;
use sightline_core::near_plane::{default_near, near_clipping, nearest_distance};
use sightline_core::scene::{self, LoadOptions, UpAxis};
use sightline_core::validate::validate;
use sightline_core::{Camera, Scene};

/// The embedded default scene of every command.
pub(crate) const DEFAULT_SCENE: &str = "procedural:city";

/// Which scene to load, and how.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct SceneArgs {
    /// Scene file or `procedural:NAME[?seed=S&size=N]` (NAME: city, rooms, canyon, boxes,
    /// spheres, spikes, zoneplate, and `cull`'s grid and graveyard; default: the embedded
    /// procedural city).
    #[arg(value_name = "SCENE", default_value = DEFAULT_SCENE)]
    pub scene: String,
    /// Quake 3 maps: tessellate each bezier sub-patch into N x N quads (0 = leave patches out).
    #[arg(long, value_name = "N", default_value_t = LoadOptions::default().patch_subdivisions)]
    pub patch_subdivisions: u32,
    #[command(flatten)]
    pub limits: LoadLimitArgs,
}

/// The limits of loading a scene file (part of [`SceneArgs`]; `cull`, which takes its scene
/// spec its own way, flattens them too).
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct LoadLimitArgs {
    /// The most memory loading a scene may take: the file's bytes (after gzip inflation) and
    /// the geometry (12 bytes a vertex, 16 a triangle) are each checked against it, declared
    /// counts before anything is allocated. Bytes, or with a K, M, G or T suffix (powers of
    /// 1024); the default is 4 GiB.
    #[arg(
        long,
        value_name = "BYTES",
        default_value_t = LoadOptions::DEFAULT_MAX_SCENE_BYTES,
        value_parser = parse_bytes
    )]
    pub max_scene_bytes: u64,
    /// glTF: also read external buffer files outside the folder of the .gltf file (absolute
    /// paths, `../`); by default only files in that folder or below it are read.
    #[arg(long)]
    pub allow_outside_refs: bool,
    /// The scene's up axis, whatever the file says or sightline infers: x, y or z. glTF is
    /// Y-up and Quake 3 maps Z-up; OBJ, PLY and STL state no axis, so sightline takes the
    /// axis along which the scene is flat (its extent below a quarter of both others: cities,
    /// terrains) and Y otherwise, and says so in a warning when it is not Y. The axis sets the
    /// default camera's up vector and the report's map from above; `convert -o FILE.glb`
    /// writes the scene turned Y-up, as glTF requires.
    #[arg(long, value_name = "AXIS", value_parser = parse_up_axis)]
    pub up_axis: Option<UpAxis>,
}

impl Default for LoadLimitArgs {
    fn default() -> Self {
        let options = LoadOptions::default();
        Self {
            max_scene_bytes: options.max_scene_bytes,
            allow_outside_refs: options.allow_outside_refs,
            up_axis: options.up_axis,
        }
    }
}

/// `--up-axis`: x, y or z.
fn parse_up_axis(s: &str) -> Result<UpAxis, String> {
    UpAxis::parse(s).ok_or_else(|| format!("{s:?} is not an axis: use x, y or z"))
}

impl LoadLimitArgs {
    /// The load options with these limits and `patch_subdivisions`.
    pub fn options(&self, patch_subdivisions: u32) -> LoadOptions {
        LoadOptions {
            patch_subdivisions,
            max_scene_bytes: self.max_scene_bytes,
            allow_outside_refs: self.allow_outside_refs,
            up_axis: self.up_axis,
        }
    }
}

/// Prints the load warnings of `scene` (loaded from `spec`) on stderr.
pub(crate) fn print_load_warnings(spec: &str, scene: &Scene) {
    for w in &scene.load_warnings {
        eprintln!("warning: {spec}: {w}");
    }
}

impl SceneArgs {
    /// The scene `spec` with default limits (commands that load a second scene of their own).
    pub fn new(spec: impl Into<String>, patch_subdivisions: u32) -> Self {
        Self {
            scene: spec.into(),
            patch_subdivisions,
            limits: LoadLimitArgs::default(),
        }
    }

    /// Loads the scene and rejects unusable ones (empty, bad indices, NaN coordinates).
    pub fn load(&self) -> Result<Scene> {
        let scene = self.load_unchecked()?;
        let report = validate(&scene);
        if let Err(e) = report.check() {
            bail!("{}: {e}", self.scene);
        }
        Ok(scene)
    }

    /// Loads the scene without rejecting it (for `info`, which reports the problems); its
    /// load warnings go to stderr.
    pub fn load_unchecked(&self) -> Result<Scene> {
        let options = self.limits.options(self.patch_subdivisions);
        if self.patch_subdivisions > 64 {
            bail!(
                "--patch-subdivisions {} is above the maximum of 64",
                self.patch_subdivisions
            );
        }
        // `cull`'s own procedural scenes are scenes like any other: their geometry at time 0.
        if let Some(ours) = crate::cull_scenes::procedural(&self.scene) {
            return Ok(ours?.scene);
        }
        let scene = scene::open(&self.scene, &options)?;
        print_load_warnings(&self.scene, &scene);
        Ok(scene)
    }
}

/// The camera options, the same in every command.
#[derive(clap::Args, Debug, Clone)]
pub(crate) struct CameraArgs {
    /// Eye position `x,y,z` (default: outside the scene bounds, looking at the centre).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Look-at point `x,y,z` (default: the centre of the scene bounds).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub look: Option<Vec3>,
    /// Up vector `x,y,z` (default: the scene's up axis).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long, default_value_t = 60.0)]
    pub fov: f32,
    /// Image size `WxH` in pixels (each side at most 16384, at most 8192x8192 pixels).
    #[arg(long, value_name = "WxH", default_value = "1024x768", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Near-plane distance. Default: 1/100 of the distance from the eye to the nearest
    /// triangle, at most 1e-4 of the scene's bounding-box diagonal and at least 1e-4 of the
    /// median triangle's longest edge, so nothing in view is clipped unless the eye touches a
    /// surface. A warning names the triangles in view that the near plane hides entirely.
    #[arg(long)]
    pub near: Option<f32>,
}

impl CameraArgs {
    /// The camera for `scene`, filling defaults from its bounds, up axis and geometry (the near
    /// plane: [`sightline_core::near_plane`]), with a warning on stderr when its near plane
    /// hides triangles in view ([`CameraArgs::warn_if_near_hides`]).
    pub fn camera(&self, scene: &Scene) -> Result<Camera> {
        let camera = self.camera_unchecked(scene)?;
        self.warn_if_near_hides(scene, &[camera]);
        Ok(camera)
    }

    /// [`CameraArgs::camera`] without the near-plane check, for commands that check the
    /// cameras they derive from it instead (`render --cube`).
    pub fn camera_unchecked(&self, scene: &Scene) -> Result<Camera> {
        let bounds = scene.bounds();
        let diagonal = bounds.diagonal().max(1e-6);
        let up = self.up.unwrap_or(scene.up.vector());
        let look = self.look.unwrap_or(bounds.center());
        let eye = match self.eye {
            Some(e) => e,
            None => default_eye(scene, look, diagonal),
        };
        let near = match self.near {
            Some(near) => near,
            None => default_near(scene, eye),
        };
        let (w, h) = self.size;
        Camera::look_at(eye, look, up, self.fov, w, h, near).context("invalid camera")
    }

    /// Warns on stderr (once) when the near plane of one of `cameras` hides triangles of its
    /// view frustum entirely: no method can report them, and the result would otherwise look
    /// complete. Of a long path only 16 cameras spread along it are checked (each check scans
    /// the scene).
    pub fn warn_if_near_hides(&self, scene: &Scene, cameras: &[Camera]) {
        const CHECKED: usize = 16;
        let step = cameras.len().div_ceil(CHECKED).max(1);
        let Some((camera, clip)) = cameras
            .iter()
            .step_by(step)
            .map(|c| (c, near_clipping(scene, c)))
            .find(|(_, clip)| clip.hidden > 0)
        else {
            return;
        };
        let near = camera.near;
        let (hidden, in_view) = (clip.hidden, clip.in_frustum);
        if self.near.is_some() {
            eprintln!(
                "warning: the near plane at {near} (--near) hides {hidden} of the {in_view} \
                 triangles in the view frustum: they lie entirely nearer than {near} to the eye, \
                 so no method reports them; give a smaller --near (the default here is {})",
                default_near(scene, camera.eye)
            );
        } else {
            eprintln!(
                "warning: the default near plane at {near} hides {hidden} of the {in_view} \
                 triangles in the view frustum: the eye is {} from the nearest triangle; give a \
                 smaller --near to see them",
                nearest_distance(scene, camera.eye) as f32
            );
        }
    }
}

/// The worker count for a `--threads` option: `None` is all cores; a count above
/// [`sightline_core::threads::OVERSUBSCRIPTION`] per core is capped with a warning on stderr
/// ([`sightline_core::threads::capped_threads`]); 0 is refused, as a typo rather than "none".
pub(crate) fn thread_count(requested: Option<usize>) -> Result<usize> {
    if requested == Some(0) {
        bail!("--threads must be at least 1 (leave it out to use all cores)");
    }
    let (threads, warning) = sightline_core::threads::capped_threads(requested.unwrap_or(0));
    if let Some(w) = warning {
        eprintln!("warning: --threads: {w}");
    }
    Ok(threads)
}

/// A three-quarter view from outside the bounds, above the scene on its up axis.
pub(crate) fn default_eye(scene: &Scene, look: Vec3, diagonal: f32) -> Vec3 {
    let up = scene.up.vector();
    let side = if up == Vec3::Z {
        Vec3::new(-0.55, -0.75, 0.0)
    } else {
        Vec3::new(-0.55, 0.0, 0.75)
    };
    look + (side + up * 0.45) * diagonal * 0.75
}

/// Parses `x,y,z`.
pub(crate) fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!(
            "'{s}' is not x,y,z (three comma-separated numbers)"
        ));
    }
    let mut v = [0.0f32; 3];
    for (slot, part) in v.iter_mut().zip(&parts) {
        let x: f32 = part
            .parse()
            .map_err(|_| format!("'{part}' in '{s}' is not a number"))?;
        if !x.is_finite() {
            return Err(format!("'{part}' in '{s}' is not finite"));
        }
        *slot = x;
    }
    Ok(Vec3::from_array(v))
}

/// Parses a byte count: digits with an optional K, M, G or T suffix (powers of 1024, an
/// optional trailing `B` or `iB` allowed: `512M`, `8GiB`).
pub(crate) fn parse_bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let t = t
        .strip_suffix("iB")
        .or_else(|| t.strip_suffix('B'))
        .unwrap_or(t);
    let (digits, shift) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => {
            let shift = match c.to_ascii_uppercase() {
                'K' => 10,
                'M' => 20,
                'G' => 30,
                'T' => 40,
                _ => return Err(format!("'{s}': unknown unit '{c}' (use K, M, G or T)")),
            };
            (&t[..i], shift)
        }
        _ => (t, 0),
    };
    let n: u64 = digits
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a byte count (e.g. 4294967296, 512M, 8G)"))?;
    n.checked_mul(1u64 << shift)
        .ok_or_else(|| format!("'{s}' is more than 2^64 bytes"))
}

/// Parses an image size, `WxH` or one number `N` for `NxN` (every command takes both), with
/// both sides in 1..=16384 and at most [`crate::limits::MAX_PIXELS`] pixels.
pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).unwrap_or((s, s));
    let parse = |p: &str| -> Result<u32, String> {
        let n: u32 = p.trim().parse().map_err(|_| {
            format!("'{p}' in '{s}' is not a whole number (an image size is WxH, or N for NxN)")
        })?;
        if n == 0 || n > 16384 {
            return Err(format!("{n} in '{s}' is outside 1..=16384"));
        }
        Ok(n)
    };
    let (w, h) = (parse(w)?, parse(h)?);
    crate::limits::check_pixels(w, h)?;
    Ok((w, h))
}

/// Parses the size of square images (the pixel-error evaluation's): `N`, or `NxN` as the
/// other commands write sizes; `WxH` with two different sides is an error that says why.
pub(crate) fn parse_square_size(s: &str) -> Result<u32, String> {
    let (w, h) = parse_size(s)?;
    if w != h {
        return Err(format!(
            "'{s}': these images are square (cube faces); give one number, e.g. {w}"
        ));
    }
    Ok(w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec3_parses_negative_numbers() {
        assert_eq!(parse_vec3("-1, 2.5,3").unwrap(), Vec3::new(-1.0, 2.5, 3.0));
    }

    #[test]
    fn vec3_rejects_nan_and_wrong_arity() {
        assert!(parse_vec3("nan,0,0").unwrap_err().contains("not finite"));
        assert!(parse_vec3("1,2").unwrap_err().contains("three"));
        assert!(parse_vec3("1,a,2").unwrap_err().contains("'a'"));
    }

    #[test]
    fn bytes_parse_with_units() {
        assert_eq!(parse_bytes("1000").unwrap(), 1000);
        assert_eq!(parse_bytes("512M").unwrap(), 512 << 20);
        assert_eq!(parse_bytes("8GiB").unwrap(), 8 << 30);
        assert_eq!(parse_bytes("4g").unwrap(), 4 << 30);
        assert!(parse_bytes("12X").is_err());
        assert!(parse_bytes("-1").is_err());
        assert!(parse_bytes("99999999T").is_err());
    }

    #[test]
    fn size_parses_and_rejects_zero() {
        assert_eq!(parse_size("640x480").unwrap(), (640, 480));
        assert!(parse_size("0x480").unwrap_err().contains("outside"));
        assert_eq!(parse_size("640").unwrap(), (640, 640));
        assert!(parse_size("640y").unwrap_err().contains("WxH, or N"));
    }

    #[test]
    fn square_sizes_take_one_number_or_equal_sides() {
        assert_eq!(parse_square_size("256").unwrap(), 256);
        assert_eq!(parse_square_size("256x256").unwrap(), 256);
        assert!(parse_square_size("256x128").unwrap_err().contains("square"));
        assert!(parse_square_size("0").unwrap_err().contains("outside"));
    }
}

/// A comma-separated list of budgets (rays or milliseconds), or `none` (empty).
#[derive(Clone, Debug, Default)]
pub(crate) struct BudgetList(pub Vec<u64>);

/// Parses a `--...-budgets` list of ray counts (`none` or nothing: empty).
pub(crate) fn parse_ray_budgets(s: &str) -> Result<BudgetList, String> {
    parse_budget_list(s, "a ray count")
}

/// Parses a `--time-budgets` list of milliseconds (`none` or nothing: empty).
pub(crate) fn parse_ms_budgets(s: &str) -> Result<BudgetList, String> {
    parse_budget_list(s, "a number of milliseconds")
}

fn parse_budget_list(s: &str, what: &str) -> Result<BudgetList, String> {
    if s.trim() == "none" || s.trim().is_empty() {
        return Ok(BudgetList::default());
    }
    s.split(',')
        .map(|t| {
            t.trim()
                .parse::<u64>()
                .map_err(|_| format!("`{}` is not {what} (a whole number, or `none`)", t.trim()))
        })
        .collect::<Result<_, _>>()
        .map(BudgetList)
}
