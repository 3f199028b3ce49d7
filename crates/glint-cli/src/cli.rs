//! Command-line syntax (clap derive).

use clap::{Args, FromArgMatches, Parser, Subcommand, ValueEnum};
use glint_filter::FilterKind;
use glint_formats::points::ColourBy;
use glint_image::ToneMap;
use glint_render::points::{Fill, PointShading};
use glint_scene::RenderMode;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "glint",
    version,
    about = "A fast CPU renderer: Whitted ray tracing, path tracing with guided-filtered indirect light, skies."
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
    /// Memory budget, e.g. 512M or 4G: larger buffers (film, sky, images, trees) are refused
    /// with an error instead of being allocated. The budget is the smallest of this, the
    /// physical RAM, `ulimit -v` and the cgroup's limit (docs/limits.md).
    #[arg(long = "max-memory", value_name = "SIZE", global = true, value_parser = parse_memory_size)]
    pub max_memory: Option<u64>,
}

fn parse_memory_size(text: &str) -> Result<u64, String> {
    glint_core::memory::parse_size(text)
}

/// A count or size option: a negative number is read as a value (not as another flag) and
/// refused with what the option takes.
fn unsigned<T: std::str::FromStr>(text: &str) -> Result<T, String> {
    if text.trim_start().starts_with('-') {
        return Err(format!("{text} is negative; this option takes a whole number (0, 1, 2, ...)"));
    }
    text.parse().map_err(|_| format!("{text:?} is not a whole number"))
}

/// A group of options as an empty command line gives it: clap's documented defaults, the one
/// source of defaults. The binary without a subcommand and the benchmarks that borrow option
/// groups take their settings from here, so they cannot drift from `--help`.
///
/// # Errors
/// When the group has a required option (a programming error, reported rather than panicking).
pub fn clap_defaults<T: Args + FromArgMatches>() -> Result<T, clap::Error> {
    let command = T::augment_args(clap::Command::new("glint").no_binary_name(true));
    T::from_arg_matches(&command.try_get_matches_from(std::iter::empty::<&str>())?)
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (.toml), a model file (.obj, .ply, .gltf, .glb) or a point cloud (.las,
    /// .laz, .ply, .xyz, .pts); the demo scene without one.
    Render(Box<RenderArgs>),
    /// Open a window on a scene, model or point cloud (the demo scene without one) and render
    /// it live: keys 1/2/3 switch Whitted / path / points, H lists every key (docs/viewer.md).
    View(Box<ViewArgs>),
    /// Point clouds: sample a mesh into an oriented cloud.
    #[command(subcommand)]
    Points(PointsCommand),
    /// Benchmarks (ray throughput, Whitted frames).
    #[command(subcommand)]
    Bench(BenchCommand),
    /// Sky maps: convert between six faces, crosses, strips and lat-long maps (docs/skies.md).
    #[command(subcommand)]
    Sky(SkyCommand),
    /// Measure an image against a reference: MSE, relMSE, PSNR, SSIM, and a false-colour error
    /// image (docs/compare.md).
    Compare(CompareArgs),
    /// Add the chunk files of a frame (`glint render --chunk I/N` or `--tile I/N`) and finish it exactly as
    /// one process would have: every setting comes from the chunks' headers (docs/cluster.md).
    Merge(MergeArgs),
    /// Filter the indirect light of a path-mode AOV EXR (docs/aovs.md; the paper's split: the
    /// direct light stays as rendered): guided, bilateral or
    /// A-Trous, guided by its normal and depth channels.
    Filter(FilterArgs),
}

/// How scene files from other renderers are read (docs/scene-format.md).
#[derive(Args, Debug, Clone, Default)]
pub struct SceneArgs {
    /// Mitsuba XML: give the scene parameter `$NAME` the value VALUE (overrides its
    /// `<default>`); repeatable.
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub define: Vec<String>,
    /// Mitsuba XML: what glint cannot represent becomes one warning each and the nearest
    /// supported thing, not an error.
    #[arg(long)]
    pub lenient: bool,
    /// glTF: render from the camera of this name (default: the first camera in node order).
    #[arg(long = "camera-name", value_name = "NAME")]
    pub camera_name: Option<String>,
    /// Read only files inside DIR: every file the scene names (meshes, textures, skies,
    /// includes, glTF buffers and images) must resolve, after symlinks, inside DIR, and so must
    /// the input itself. For scenes from others (render services, queues); see docs/limits.md.
    #[arg(long, value_name = "DIR")]
    pub sandbox: Option<std::path::PathBuf>,
}

#[derive(Args, Debug, Clone)]
pub struct CameraArgs {
    /// Camera position "X,Y,Z" (overrides the scene's camera).
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub eye: Option<String>,
    /// Point the camera looks at "X,Y,Z".
    #[arg(long = "look-at", value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub look_at: Option<String>,
    /// Up direction "X,Y,Z".
    #[arg(long, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub up: Option<String>,
    /// Vertical field of view in degrees.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub fov: Option<f32>,
}

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene or model file; omitted: the built-in demo scene.
    pub input: Option<PathBuf>,
    /// Output image: .png (tone-mapped sRGB) or .exr (linear float, with AOVs).
    #[arg(short, long, default_value = "glint.png")]
    pub output: PathBuf,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: Option<u32>,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: Option<u32>,
    /// Render only pixels x0..x1, y0..y1 of the frame (pbrt's --pixelbounds): the output is
    /// that window, its pixels exactly the whole frame's (same rays, same random numbers);
    /// a filter sees only the window. Overrides a Mitsuba film's crop.
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    pub crop: Option<String>,
    /// Render chunk I (0-based) of N of a frame's passes (path mode with a filter) or samples
    /// per pixel (path mode without one, Whitted) into a chunk file (-o part_I.exr) for
    /// `glint merge`; `auto/N` takes I from a Slurm array (SLURM_ARRAY_TASK_ID −
    /// SLURM_ARRAY_TASK_MIN) or a Kubernetes Indexed Job (JOB_COMPLETION_INDEX).
    /// docs/cluster.md.
    #[arg(long, value_name = "I/N")]
    pub chunk: Option<String>,
    /// Render tile I (0-based) of N of the frame (a grid of N tiles, as square as N allows)
    /// with all its samples into a chunk file (-o part_I.exr) for `glint merge`; `auto/N` as
    /// for --chunk. Whitted and path frames (with a filter, every pass also traces and filters
    /// the whole frame's guide rays, one sample per pixel). docs/cluster.md.
    #[arg(long, value_name = "I/N")]
    pub tile: Option<String>,
    /// Samples per pixel. Whitted: a square number (N×N stratified supersampling): 1, 4, 9,
    /// 16, ...; path: any number (per pass with --time).
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub spp: Option<u32>,
    /// Rendering mode: whitted (ray tracing, Phong), path (path tracing, indirect light
    /// filtered) or points (point clouds, pull-push). Default: the scene's `[render] mode`, else
    /// points for a point-cloud file and whitted for the rest.
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
    #[command(flatten)]
    pub path: PathArgs,
    #[command(flatten)]
    pub points: PointArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Worker threads (default: every core).
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
    /// Seed of every random number in the render.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = unsigned::<u64>)]
    pub seed: u64,
    /// Show the scene's animations at this time, in seconds (default 0; see --time for the
    /// path tracer's time budget).
    #[arg(long = "scene-time", value_name = "SECONDS", allow_hyphen_values = true)]
    pub scene_time: Option<f32>,
    /// Render frames A to B (inclusive) of the scene's animation, frame f at scene time f / fps,
    /// each to -o with its number in place of %d or %0Nd (out_%04d.png); combines with
    /// --chunk (one chunk file per frame). docs/cluster.md.
    #[arg(long = "frame-range", value_name = "A..B", allow_hyphen_values = true)]
    pub frame_range: Option<String>,
    /// Every K-th frame of --frame-range.
    #[arg(long = "frame-step", value_name = "K", default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub frame_step: u32,
    /// Frames per second of --frame-range.
    #[arg(long, value_name = "F", default_value_t = 24.0, allow_hyphen_values = true)]
    pub fps: f32,
    /// Leave outputs that exist alone (resume an interrupted job array: an output file only
    /// appears once complete, written to a temporary name and renamed).
    #[arg(long = "skip-existing")]
    pub skip_existing: bool,
    /// Maximum ray depth (reflection/refraction bounces).
    #[arg(long = "max-depth", allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_depth: Option<u32>,
    /// Exposure in stops (PNG output).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f32,
    /// Tone map for PNG output.
    #[arg(long, value_enum, default_value = "clamp")]
    pub tonemap: ToneMapArg,
    /// Write RGBA PNG with coverage as alpha.
    #[arg(long)]
    pub alpha: bool,
    /// EXR output: write the picture alone (R, G, B, A), without the AOVs; a path frame then
    /// does not sum its path AOVs (faster, the same picture). Not with --chunk or --tile (a
    /// chunk carries every AOV for the merge).
    #[arg(long = "beauty-only")]
    pub beauty_only: bool,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub sky: SkyArgs,
    /// Print no progress bar or summary.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum ModeArg {
    #[default]
    Whitted,
    Path,
    Points,
}

impl From<ModeArg> for RenderMode {
    fn from(m: ModeArg) -> Self {
        match m {
            ModeArg::Whitted => RenderMode::Whitted,
            ModeArg::Path => RenderMode::Path,
            ModeArg::Points => RenderMode::Points,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum ToneMapArg {
    /// min(x, 1): exact below 1, hard clip above.
    #[default]
    Clamp,
    /// x / (1 + x): never clips.
    Reinhard,
    /// The ACES filmic curve (Narkowicz's fit).
    Aces,
}

impl From<ToneMapArg> for ToneMap {
    fn from(t: ToneMapArg) -> Self {
        match t {
            ToneMapArg::Clamp => ToneMap::Clamp,
            ToneMapArg::Reinhard => ToneMap::Reinhard,
            ToneMapArg::Aces => ToneMap::Aces,
        }
    }
}

/// Points mode (DESIGN.md §3) and point-cloud preparation.
#[derive(Args, Debug, Clone)]
pub struct PointArgs {
    /// How holes between points are filled: ellipses (pull-push with elliptical box filters,
    /// the paper's method), pull-push (without ellipses), raw (one pixel per point), squares
    /// (fixed-size square splats, the common viewer's baseline).
    #[arg(long, value_enum, default_value = "ellipses")]
    pub fill: FillArg,
    /// Side of the squares of --fill squares, in pixels.
    #[arg(long = "square-size", default_value_t = 3, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub square_size: u32,
    /// Shading: auto (phong with normals, edl without), phong, edl (eye-dome lighting), flat.
    #[arg(long, value_enum, default_value = "auto")]
    pub shading: ShadingArg,
    /// Eye-dome lighting strength.
    #[arg(long = "edl-strength", default_value_t = 1.0, allow_hyphen_values = true)]
    pub edl_strength: f32,
    /// Draw back faces of clouds with oriented normals too (no culling).
    #[arg(long = "two-sided")]
    pub two_sided: bool,
    /// Colour of a cloud file's points: auto (RGB, else intensity; elevation for LAS), rgb,
    /// intensity, classification, elevation. (A scene's clouds take `colour_by` instead.)
    #[arg(long = "colour-by", value_parser = parse_colour_by, default_value = "auto")]
    pub colour_by: ColourBy,
    /// Neighbours for normal and radius estimation of clouds without them.
    #[arg(long, default_value_t = 16, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub neighbours: usize,
    /// Scale of the point radii (estimated or given).
    #[arg(long = "radius-scale", default_value_t = 1.0, allow_hyphen_values = true)]
    pub radius_scale: f32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum FillArg {
    #[default]
    Ellipses,
    PullPush,
    Raw,
    Squares,
}

impl From<FillArg> for Fill {
    fn from(f: FillArg) -> Self {
        match f {
            FillArg::Ellipses => Fill::Ellipses,
            FillArg::PullPush => Fill::PullPush,
            FillArg::Raw => Fill::Raw,
            FillArg::Squares => Fill::Squares,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum ShadingArg {
    #[default]
    Auto,
    Phong,
    Edl,
    Flat,
}

impl From<ShadingArg> for PointShading {
    fn from(s: ShadingArg) -> Self {
        match s {
            ShadingArg::Auto => PointShading::Auto,
            ShadingArg::Phong => PointShading::Phong,
            ShadingArg::Edl => PointShading::EyeDome,
            ShadingArg::Flat => PointShading::Flat,
        }
    }
}

/// `--colour-by NAME`, by the names the scene format uses.
fn parse_colour_by(name: &str) -> Result<ColourBy, String> {
    ColourBy::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = ColourBy::NAMES.iter().map(|(n, _)| *n).collect();
        format!("use {}", names.join(", "))
    })
}

#[derive(Subcommand, Debug)]
pub enum PointsCommand {
    /// Sample a mesh into a point cloud: area-weighted, with oriented normals and radii
    /// (binary PLY out).
    Sample(SampleArgs),
}

#[derive(Args, Debug)]
pub struct SampleArgs {
    /// Mesh file (.obj, .ply, .gltf, .glb).
    pub mesh: PathBuf,
    /// Number of points.
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub count: usize,
    /// Output point cloud (.ply).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Seed of the sample positions.
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = unsigned::<u64>)]
    pub seed: u64,
    /// Print no summary.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum FilterArg {
    /// Guided image filter (He et al. 2010) on normal and depth: the paper's method.
    #[default]
    Guided,
    /// Cross-bilateral filter (brute force; the quality reference, slow).
    Bilateral,
    /// Edge-avoiding A-Trous wavelet filter (Dammertz et al. 2010).
    Atrous,
    /// No filter: plain path tracing, every sample traces its own indirect light.
    None,
}

impl FilterArg {
    /// The filter a scene gets without `--filter`: guided, or none where the scene asks for
    /// plain path tracing (Mitsuba scenes).
    pub fn scene_default(scene: &glint_scene::Scene) -> Self {
        if scene.render.image_filter { FilterArg::Guided } else { FilterArg::None }
    }
}

impl From<FilterArg> for FilterKind {
    fn from(f: FilterArg) -> Self {
        match f {
            FilterArg::Guided => FilterKind::Guided,
            FilterArg::Bilateral => FilterKind::Bilateral,
            FilterArg::Atrous => FilterKind::Atrous,
            FilterArg::None => FilterKind::None,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum GuideArg {
    /// Grey normal (Rec. 709 luma of (n+1)/2).
    #[value(name = "1d")]
    Grey,
    /// The normal.
    #[value(name = "3d")]
    Normal,
    /// Normal and depth.
    #[default]
    #[value(name = "4d")]
    NormalDepth,
}

/// Filter settings shared by `glint render --mode path` and `glint filter`.
#[derive(Args, Debug, Clone)]
pub struct FilterOptions {
    /// Guided filter: guide channels.
    #[arg(long, value_enum, default_value = "4d")]
    pub guide: GuideArg,
    /// Window radius in pixels (guided, bilateral; default: scaled with the image width, 28 at
    /// 1024 pixels).
    #[arg(long, value_name = "PX", allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub radius: Option<usize>,
    /// Guided filter: regularisation of the normal channels.
    #[arg(long = "eps-normal", value_name = "X", allow_hyphen_values = true)]
    pub eps_normal: Option<f32>,
    /// Guided filter: regularisation of the depth channel.
    #[arg(long = "eps-depth", value_name = "X", allow_hyphen_values = true)]
    pub eps_depth: Option<f32>,
    /// A-Trous: iterations (steps 1, 2, 4, ...).
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub iterations: Option<u32>,
}

/// Path-mode options of `glint render`.
#[derive(Args, Debug, Clone)]
pub struct PathArgs {
    /// Path mode: image-space filter of the indirect light. Default: guided; none for a
    /// Mitsuba scene (plain path tracing, as Mitsuba renders it).
    #[arg(long, value_enum)]
    pub filter: Option<FilterArg>,
    /// Path mode: indirect bounces (0 = direct light only).
    #[arg(long = "max-bounces", value_name = "N", allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_bounces: Option<u32>,
    /// Path mode: render passes of --spp samples until this many seconds are spent.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true)]
    pub time: Option<f64>,
    /// Path mode: passes of --spp samples each (each filtered with its own guide rays, then
    /// averaged); --time may add more.
    #[arg(long, value_name = "N", default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub passes: u32,
    /// Path mode: firefly clamp — the largest indirect radiance one sample may bring (biased;
    /// off by default).
    #[arg(long, value_name = "X", allow_hyphen_values = true)]
    pub clamp: Option<f32>,
    /// Path mode: the paper's split — filter only the indirect light, and leave the direct
    /// light of area lights and the sky unfiltered (by default it is filtered too; point, spot
    /// and directional lights always stay sharp).
    #[arg(long = "paper-split")]
    pub paper_split: bool,
    /// Path mode: how camera samples draw their random numbers. sobol: stratified across a
    /// pixel's samples (lower error at the same spp); independent: Mitsuba's `independent`
    /// sampler. Default: the scene's (`[render] sampler`; sobol).
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerArg>,
    /// Path mode, unfiltered, with a pixel filter wider than a pixel (a Mitsuba film's
    /// gaussian or tent): splat: each sample, uniform in its pixel, adds to every pixel the
    /// filter reaches, weighted (Mitsuba's film: lower error per sample, neighbours
    /// correlated); sample: each sample's position is drawn from the filter and it stays in
    /// its pixel (pbrt-v4's; pixels independent, with a Variance AOV).
    #[arg(long, value_enum, default_value = "splat")]
    pub reconstruction: ReconstructionArg,
    #[command(flatten)]
    pub filter_options: FilterOptions,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ReconstructionArg {
    Splat,
    Sample,
}

impl From<ReconstructionArg> for glint_core::Reconstruction {
    fn from(r: ReconstructionArg) -> Self {
        match r {
            ReconstructionArg::Splat => glint_core::Reconstruction::Splat,
            ReconstructionArg::Sample => glint_core::Reconstruction::Sample,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SamplerArg {
    Sobol,
    Independent,
}

impl From<SamplerArg> for glint_core::random::Sampler {
    fn from(s: SamplerArg) -> Self {
        match s {
            SamplerArg::Sobol => glint_core::random::Sampler::Sobol,
            SamplerArg::Independent => glint_core::random::Sampler::Independent,
        }
    }
}

/// Arguments of `glint filter`.
#[derive(Args, Debug)]
pub struct FilterArgs {
    /// An EXR written by `glint render --mode path` (R, G, B, Albedo.*, Ns.*, Z, Indirect.*).
    pub input: PathBuf,
    /// Output: .exr (every channel, the beauty and Indirect filtered) or .png (the beauty).
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, value_enum, default_value = "guided")]
    pub filter: FilterArg,
    #[command(flatten)]
    pub filter_options: FilterOptions,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
    /// Print no summary.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// The chunk files, every chunk of the frame once (any order).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output image: .png (tone-mapped as the chunks' render said) or .exr (with AOVs); never
    /// one of the inputs.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Print no summary.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Sky options of `glint render` (docs/skies.md).
#[derive(Args, Debug, Clone)]
pub struct SkyArgs {
    /// Sky image: a folder of six faces, a cross or strip, or a 2:1 lat-long map (PNG, JPEG,
    /// HDR, EXR). Replaces the scene's sky; a model rendered without a scene is then lit by it.
    #[arg(long, value_name = "PATH")]
    pub sky: Option<PathBuf>,
    /// Turn the sky about the up axis (degrees, counter-clockwise seen from above).
    #[arg(long = "sky-rotation", value_name = "DEG", allow_hyphen_values = true)]
    pub sky_rotation: Option<f32>,
    /// Multiply the sky's radiance.
    #[arg(long = "sky-intensity", value_name = "X", allow_hyphen_values = true)]
    pub sky_intensity: Option<f32>,
    /// Flip every cube face as it is read (sets stored upside down need `vertical`).
    #[arg(long = "sky-flip", value_enum, value_name = "HOW")]
    pub sky_flip: Option<FlipArg>,
    /// Take the ambient light from the sky (its irradiance by surface normal).
    #[arg(long = "sky-ambient")]
    pub sky_ambient: bool,
    /// What to do when the faces of --sky do not meet at their edges: `none` warns with the
    /// fix (`[sky.face.ny] rotate = 180`, ...), `auto` applies it and says which it applied.
    #[arg(long = "sky-fix", value_enum, value_name = "HOW")]
    pub sky_fix: Option<SkyFixArg>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SkyFixArg {
    None,
    Auto,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum FlipArg {
    None,
    Horizontal,
    Vertical,
    Both,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum RayKind {
    /// Camera rays through pixel centres.
    Primary,
    /// Cosine-distributed bounce rays from the primary hits.
    Diffuse,
    /// Any-hit rays from the primary hits toward the first light.
    Shadow,
}

/// How `glint bench rays` builds the scene's trees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BuildArg {
    /// As the renderer does: spatial splits for closest hits, object splits for any hits.
    Spatial,
    /// Object splits only, one tree (the build Embree does at its default quality).
    Fast,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScheduleArg {
    Stealing,
    Static,
}

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// Time traversal over a fixed set of rays; optionally dump them for ../shared/bench (Embree).
    Rays(BenchRaysArgs),
    /// Time Whitted frames (the thesis's benchmark scene by default).
    Whitted(BenchWhittedArgs),
    /// The guided-filtering paper's table 2: filter times on a rendered indirect buffer.
    Filters(BenchFiltersArgs),
    /// The guided-filtering paper's table 1 (render times) and figure 8 (MSE against a
    /// converged reference, with a contact sheet).
    Gi(BenchGiArgs),
    /// The point-rendering paper's table 1: frames per second of the points mode on scans, a
    /// LiDAR tile and sampled clouds, split into projection, pull-push and shading.
    Points(BenchPointsArgs),
    /// The viewer's frame loop without a window: a fixed orbit around the content, per-frame
    /// times of any mode (what the window would show, measured).
    View(BenchViewArgs),
    /// Path tracing throughput: whole path-mode frames of a scene, millions of paths per second
    /// (median of several frames; the last line is `mpaths_per_s_median=X`).
    Path(BenchPathArgs),
}

#[derive(Args, Debug)]
pub struct BenchPathArgs {
    /// Scene or model file.
    pub scene: PathBuf,
    /// Samples per pixel per frame (one path each).
    #[arg(long, default_value_t = 16, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub spp: u32,
    /// Image size; default: the scene's.
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: Option<u32>,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: Option<u32>,
    /// Indirect bounces; default: the scene's.
    #[arg(long = "max-bounces", allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_bounces: Option<u32>,
    /// Filter of the indirect light (none: plain path tracing, the throughput measure).
    #[arg(long, value_enum, default_value = "none")]
    pub filter: FilterArg,
    /// Timed frames (the median is reported).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub frames: usize,
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = unsigned::<u64>)]
    pub seed: u64,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
    /// Path tracer(s) to time, comma-separated: wavefront (breadth first, rays eight at a
    /// time), recursive (depth first, one sample after another). Frames of several kernels are
    /// interleaved; the last line is the first kernel's.
    #[arg(long, value_delimiter = ',', value_enum, default_value = "wavefront")]
    pub kernel: Vec<PathKernelArg>,
    /// How camera samples draw their random numbers; default: the scene's.
    #[arg(long, value_enum)]
    pub sampler: Option<SamplerArg>,
    /// How an unfiltered frame applies a film filter wider than a pixel (as `glint render`).
    #[arg(long, value_enum, default_value = "splat")]
    pub reconstruction: ReconstructionArg,
    /// Sum the path AOVs (Direct, Indirect, SampleCount, Variance) beside the picture, as a
    /// render to EXR does; without it a frame keeps the picture's sums alone, as a render to
    /// PNG does.
    #[arg(long)]
    pub aovs: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PathKernelArg {
    Wavefront,
    /// The wavefront shading every vertex one at a time (its batched shading's baseline).
    WavefrontScalar,
    Recursive,
}

impl From<PathKernelArg> for glint_render::path::PathKernel {
    fn from(k: PathKernelArg) -> Self {
        match k {
            PathKernelArg::Wavefront => glint_render::path::PathKernel::Wavefront,
            PathKernelArg::WavefrontScalar => glint_render::path::PathKernel::WavefrontScalar,
            PathKernelArg::Recursive => glint_render::path::PathKernel::Recursive,
        }
    }
}

#[derive(Args, Debug)]
pub struct BenchViewArgs {
    /// Scene, model or point cloud; omitted: the built-in demo scene.
    pub input: Option<PathBuf>,
    /// Frames of the orbit (one full turn).
    #[arg(long, default_value_t = 60, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub frames: usize,
    /// whitted, path or points; default: the scene's mode.
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
    #[arg(long, default_value_t = 1280, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: u32,
    #[arg(long, default_value_t = 720, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: u32,
    /// Path mode: samples per pixel per frame.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub spp: u32,
    /// Path mode: indirect bounces.
    #[arg(long = "max-bounces", default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_bounces: u32,
    /// Path mode: filter of the indirect light.
    #[arg(long, value_enum, default_value = "guided")]
    pub filter: FilterArg,
    /// Print every frame's time, not only the summary.
    #[arg(long = "per-frame")]
    pub per_frame: bool,
    /// Lower the resolution while the camera moves, as the window does (default: every frame
    /// at full size).
    #[arg(long)]
    pub adaptive: bool,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
}

#[derive(Args, Debug)]
pub struct BenchPointsArgs {
    /// Folder of the shared test data (pointclouds/, meshes/).
    #[arg(long, default_value = "../shared/data")]
    pub data: PathBuf,
    /// Comma-separated subset of bunny, dragon, autzen, sampled-1m, sampled-5m.
    #[arg(long)]
    pub clouds: Option<String>,
    /// Comma-separated square image sides.
    #[arg(long, default_value = "512,1024")]
    pub sizes: String,
    /// Comma-separated subset of full, pull-push, raw, squares (the ablations).
    #[arg(long, default_value = "full")]
    pub fills: String,
    /// Timed frames per setting (the median is reported).
    #[arg(long, default_value_t = 21, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub reps: usize,
    /// Write each first frame as PNG into this folder (the side-by-side figures).
    #[arg(long)]
    pub images: Option<PathBuf>,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
}

#[derive(Args, Debug)]
pub struct BenchFiltersArgs {
    /// Folder of the shared test data (scenes/*.toml refer to models in it).
    #[arg(long, default_value = "../shared/data")]
    pub data: PathBuf,
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: u32,
    #[arg(long, default_value_t = 768, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: u32,
    /// Timed runs per filter (the median is reported; bilateral runs at most 3).
    #[arg(long, default_value_t = 11, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub reps: usize,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
    /// Catch a regression: each filter's median over the guided 4-D filter's (r = 28) from
    /// the same run must stay within 2x the ratio recorded in BENCHMARKS.md 6.1 (A-Trous with
    /// AVX-512: 13.5); a filter past it is named and the command fails. Meant for the default
    /// size.
    #[arg(long)]
    pub check: bool,
}

#[derive(Args, Debug)]
pub struct BenchGiArgs {
    /// Folder of the shared test data (scenes/*.toml refer to models in it).
    #[arg(long, default_value = "../shared/data")]
    pub data: PathBuf,
    /// Comma-separated subset of sponza, cornell-dragon, buddha, cornell-box.
    #[arg(long)]
    pub scenes: Option<String>,
    /// Size of the timed frames (table 1).
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: u32,
    #[arg(long, default_value_t = 768, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: u32,
    /// Timed frames per setting (the median is reported).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub reps: usize,
    /// Size of the quality comparison (figure 8).
    #[arg(long = "quality-width", default_value_t = 512, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub quality_width: u32,
    #[arg(long = "quality-height", default_value_t = 384, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub quality_height: u32,
    /// Samples per pixel of the reference (cached in --out).
    #[arg(long = "ref-spp", default_value_t = 1024, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub ref_spp: u32,
    /// Indirect bounces in the quality comparison.
    #[arg(long, default_value_t = 2, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub bounces: u32,
    /// Where references, images and the contact sheet go.
    #[arg(long, default_value = "target/bench-gi")]
    pub out: PathBuf,
    #[arg(long = "skip-times")]
    pub skip_times: bool,
    #[arg(long = "skip-quality")]
    pub skip_quality: bool,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
}

#[derive(Args, Debug)]
pub struct BenchRaysArgs {
    /// Scene or model file.
    #[arg(long)]
    pub scene: PathBuf,
    #[arg(long, value_enum, default_value = "primary")]
    pub kind: RayKind,
    /// Time any-hit queries (is anything hit?) on the rays instead of closest hits, as
    /// Embree's rtcOccluded1 does on every dump (shadow rays are always any-hit queries): a
    /// diffuse kind's any-hit rays are the path tracer's incoherent shadow rays (sky light).
    #[arg(long)]
    pub any_hit: bool,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
    #[arg(long, default_value_t = 1024, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: u32,
    #[arg(long, default_value_t = 768, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: u32,
    /// Timed passes over the rays (the median is reported).
    #[arg(long, default_value_t = 7, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub reps: usize,
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = unsigned::<u64>)]
    pub seed: u64,
    /// Write PREFIX.tris.f32, PREFIX.rays.f32 and PREFIX.hits.f32 for the Embree scripts.
    #[arg(long)]
    pub dump: Option<PathBuf>,
    /// Split every triangle into 4^N before building (e.g. 2: the 100k dragon becomes 1.6 M).
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub subdivide: u32,
    /// Build the scene's acceleration structures this many times and report the median and
    /// fastest build (the BVH build benchmark; the rays are timed on the last build).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub builds: usize,
    /// How the trees are built: `spatial` as the renderer does, `fast` without spatial splits.
    #[arg(long, value_enum, default_value = "spatial")]
    pub build: BuildArg,
}

#[derive(Args, Debug)]
pub struct BenchWhittedArgs {
    /// Scene (default: scenes/whitted-bench.toml's embedded copy).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    #[arg(long, default_value_t = 1280, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: u32,
    #[arg(long, default_value_t = 720, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: u32,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
    #[arg(long, default_value_t = 20, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub frames: usize,
    #[arg(long, value_enum, default_value = "stealing")]
    pub schedule: ScheduleArg,
    /// Also time the scene under this sky (a cube map or lat-long map), frames interleaved
    /// with the scene's own sky, and report the ratio.
    #[arg(long, value_name = "PATH")]
    pub sky: Option<PathBuf>,
    /// Tracer(s) to time, comma-separated: batched (eight-ray streams, AVX2 where the CPU has
    /// it), batched-sse (the same, baseline SSE lanes), scalar (one ray at a time). Frames of
    /// several kernels are interleaved.
    #[arg(long, value_delimiter = ',', value_enum, default_value = "batched")]
    pub kernel: Vec<KernelArg>,
    /// Draw each frame into a float film with every AOV (normal, albedo, depth), as a render to
    /// EXR and the viewer do; without it a frame is encoded to 8-bit sRGB band by band as it
    /// is traced, as a render to PNG does.
    #[arg(long)]
    pub aovs: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum KernelArg {
    Batched,
    BatchedSse,
    Scalar,
}

impl From<KernelArg> for glint_render::WhittedKernel {
    fn from(k: KernelArg) -> Self {
        match k {
            KernelArg::Batched => glint_render::WhittedKernel::Batched,
            KernelArg::BatchedSse => glint_render::WhittedKernel::BatchedBaseline,
            KernelArg::Scalar => glint_render::WhittedKernel::Scalar,
        }
    }
}

#[derive(Subcommand, Debug)]
pub enum SkyCommand {
    /// Convert a sky to another layout: e.g. a lat-long HDR to six faces, a cross to faces.
    Convert(SkyConvertArgs),
}

#[derive(Args, Debug)]
pub struct SkyConvertArgs {
    /// Sky to read: one image (cross, strip or lat-long, told by its aspect) or a folder of six
    /// faces (px/nx/..., posx/..., right/left/up/down/front/back).
    pub input: PathBuf,
    /// Where to write: a folder for --to faces, else an image whose extension (.png, .jpg, .hdr,
    /// .exr) picks the format.
    pub output: PathBuf,
    /// Layout to write.
    #[arg(long, value_enum)]
    pub to: SkyLayoutArg,
    /// Face edge (faces, crosses, strips) or height (lat-long, width twice that) in texels.
    /// Default: the input's face edge, or its height for a lat-long input.
    #[arg(long, value_name = "N", allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub size: Option<u32>,
    /// Flip every input face first (sets stored upside down or mirrored).
    #[arg(long, value_enum)]
    pub flip: Option<FlipArg>,
    /// Print no warnings or summary.
    #[arg(long, short)]
    pub quiet: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SkyLayoutArg {
    /// A folder with px, nx, py, ny, pz, nz (PNG for LDR input, .hdr/.exr for HDR input).
    Faces,
    /// One 4:3 image, horizontal cross.
    Cross,
    /// One 3:4 image, vertical cross.
    VerticalCross,
    /// One 6:1 image, faces px nx py ny pz nz left to right.
    Strip,
    /// One 1:6 image, faces top to bottom.
    VerticalStrip,
    /// One 2:1 equirectangular image.
    Latlong,
}

/// Arguments of `glint compare` (docs/compare.md).
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The image to measure: PNG, JPEG, TGA, BMP (sRGB, decoded to linear), HDR or EXR (its
    /// R, G, B channels).
    #[arg(value_name = "A")]
    pub image: PathBuf,
    /// The reference image, of the same size.
    #[arg(value_name = "B")]
    pub reference: PathBuf,
    /// Write a false-colour picture of the per-pixel error (RMS of the R, G, B differences,
    /// inferno colour map): .png (or .jpg, .exr, .hdr).
    #[arg(long, value_name = "OUT.png")]
    pub diff: Option<PathBuf>,
    /// The error shown as the top colour of --diff (default: the 99th percentile of the error).
    #[arg(long = "diff-scale", value_name = "X", requires = "diff", allow_hyphen_values = true)]
    pub diff_scale: Option<f32>,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Run Mitsuba 3's render test against the reference, whose per-sample variance is in
    /// VAR.exr (R, G, B): a per-pixel z-test in XYZ, Šidák-corrected significance 0.01,
    /// passing where at least 99.75 % of the pixel-channels accept (docs/compare.md). When A
    /// has glint's Variance.R/G/B layer its own variance is used; otherwise the reference's
    /// stands for both (Mitsuba's form). Exit status 1 when the test fails.
    #[arg(long, value_name = "VAR.exr")]
    pub ztest: Option<PathBuf>,
    /// A's samples per pixel for --ztest (default: the mean of its SampleCount channel).
    #[arg(long, value_name = "N", requires = "ztest", allow_negative_numbers = true)]
    pub spp: Option<f64>,
    /// The reference's samples per pixel for --ztest: its own noise joins the test's
    /// variance (Mitsuba's references: 32000). Default: ignored.
    #[arg(long = "reference-spp", value_name = "M", requires = "ztest", allow_negative_numbers = true)]
    pub reference_spp: Option<f64>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, ValueEnum)]
pub enum CameraControlArg {
    /// Turn around the content's centre (drag), zoom with the wheel.
    #[default]
    Orbit,
    /// WASD + mouse look.
    Fly,
}

/// The viewer's starting state; everything but the size, threads and seed can be changed with
/// keys in the window.
#[derive(Args, Debug, Clone)]
pub struct ViewArgs {
    /// Scene, model or point cloud; omitted: the built-in demo scene.
    pub input: Option<PathBuf>,
    /// Window size in pixels.
    #[arg(long, default_value_t = 1280, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub width: u32,
    #[arg(long, default_value_t = 720, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub height: u32,
    /// Starting mode; default: the scene's, points for a point cloud.
    #[arg(long, value_enum)]
    pub mode: Option<ModeArg>,
    /// Path mode: filter of the indirect light (key F cycles). Default: guided; none for a
    /// Mitsuba scene.
    #[arg(long, value_enum)]
    pub filter: Option<FilterArg>,
    /// Path mode: samples per pixel per frame (keys - and =).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub spp: u32,
    /// Path mode: indirect bounces (keys [ and ]).
    #[arg(long = "max-bounces", default_value_t = 1, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_bounces: u32,
    /// Path mode: the paper's split — filter only the indirect light (by default the direct
    /// light of area lights and the sky is filtered too).
    #[arg(long = "paper-split")]
    pub paper_split: bool,
    /// Whitted: deepest reflection/refraction chain.
    #[arg(long = "max-depth", default_value_t = 8, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_depth: u32,
    /// Camera control (key C switches).
    #[arg(long, value_enum, default_value = "orbit")]
    pub camera: CameraControlArg,
    /// Whitted passes / path samples per pixel after which a resting picture is final.
    #[arg(long = "max-samples", default_value_t = 1024, allow_negative_numbers = true, value_parser = unsigned::<u32>)]
    pub max_samples: u32,
    /// Draw at full resolution while the camera moves (default: lower it to keep 30 fps).
    #[arg(long = "fixed-resolution")]
    pub fixed_resolution: bool,
    /// Folder for screenshots (key P: glint-view-NNN.png and .exr).
    #[arg(long = "screenshot-dir", default_value = ".")]
    pub screenshot_dir: PathBuf,
    /// Close after this many frames (scripted runs).
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<u64>)]
    pub frames: Option<u64>,
    /// On close, read the window back from the display and write it as PNG here.
    #[arg(long)]
    pub capture: Option<PathBuf>,
    #[command(flatten)]
    pub points: PointArgs,
    #[command(flatten)]
    pub scene: SceneArgs,
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, value_parser = unsigned::<u64>)]
    pub seed: u64,
    #[arg(long, allow_negative_numbers = true, value_parser = unsigned::<usize>)]
    pub threads: Option<usize>,
}
