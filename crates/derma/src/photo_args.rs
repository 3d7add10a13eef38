//! The flags of `derma photo …` (derma-photo, after Tarini et al. 2002; docs/photo.md): one
//! struct per subcommand, parsed by clap; `photo.rs` runs them.

use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct CalibrateArgs {
    /// Correspondences: JSON or CSV (format in docs/photo.md, "1. Correspondences and cameras",
    /// under "Formats").
    #[arg(long)]
    pub points: PathBuf,
    /// The mesh the points lie on (OBJ/glTF/GLB, UVs not needed); default: the built-in face.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Named landmarks of --mesh (JSON {"name": [x, y, z]}), for points given by name.
    #[arg(long)]
    pub landmarks: Option<PathBuf>,
    /// --mesh is in MediaPipe's 468-vertex topology (vertex index = landmark id).
    #[arg(long)]
    pub mediapipe_topology: bool,
    /// Fix each photo's focal length from its EXIF (FocalLengthIn35mmFilm) when present.
    #[arg(long)]
    pub exif: bool,
    /// Intrinsics per photo instead of one shared camera.
    #[arg(long)]
    pub per_photo: bool,
    /// With --per-photo: relative standard deviation of the log-normal prior that keeps each
    /// photo's focal length near the shared camera's, fitted first ("inf": no prior).
    #[arg(long, default_value_t = 0.1)]
    pub focal_deviation: f64,
    /// Also refine the principal point.
    #[arg(long)]
    pub refine_principal: bool,
    /// Also refine radial distortion k1, k2.
    #[arg(long)]
    pub refine_distortion: bool,
    /// Output cameras file.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct UnwrapArgs {
    /// Disc-topology mesh (one boundary loop); default: the built-in face.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Direction of view onto the face, X,Y,Z (Tarini et al. §3.1's V), or "none" for a
    /// view-independent layout.
    #[arg(long, default_value = "0,0,-1")]
    pub view: String,
    /// k of the view weight 1/(⟨N,V⟩ + k), 1.01–2: smaller gives the face more texture.
    #[arg(long, default_value_t = 1.2)]
    pub k: f32,
    /// Output OBJ with UVs.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct BakeArgs {
    /// UV-mapped mesh (from `derma photo unwrap`, or any single-chart UV layout).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Cameras from `derma photo calibrate`.
    #[arg(long)]
    pub cameras: PathBuf,
    /// Texture size (texels).
    #[arg(long, default_value_t = 2048)]
    pub size: usize,
    /// Keep each photo's lighting in the texture (no de-lighting): writes texture.png/.exr
    /// instead of albedo.png/.exr and shading_K.png.
    #[arg(long)]
    pub keep_lighting: bool,
    /// No per-photo gain and white-balance compensation (with --keep-lighting).
    #[arg(long)]
    pub no_gain: bool,
    /// No multiresolution spline: the weighted mean only.
    #[arg(long)]
    pub no_multiband: bool,
    /// Take the cameras as calibrated (no photometric registration of the de-lit photos).
    #[arg(long)]
    pub no_register: bool,
    /// Refuse instead of falling back: a lighting no model explains, a registration that moves
    /// a camera beyond its clicks' reach, or gains far from 1 are an error, not a warning.
    #[arg(long)]
    pub strict: bool,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct ChromophoreArgs {
    /// Texture (PNG sRGB or linear EXR), e.g. a baked texture.png.
    #[arg(long)]
    pub texture: PathBuf,
    /// Grey mask: texels > 0.5 are the ones the exposure fit and the report use (e.g. the
    /// bake's mask.png: texels coloured from photos); every texel gets its maps.
    #[arg(long)]
    pub mask: Option<PathBuf>,
    /// Exposure the texture is divided by, or "auto" to fit it.
    #[arg(long, default_value = "auto")]
    pub exposure: String,
    /// The `derma skin` config the maps will be painted with (its baseline's mean tissue fixes
    /// the parameters other than melanin and blood); default: the built-in config.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct IrisArgs {
    /// Photo of one open eye looking at the camera.
    #[arg(long)]
    pub photo: PathBuf,
    /// A rough centre X,Y (pixels) inside the pupil or iris; default: the darkest spot.
    #[arg(long, value_parser = crate::args::point)]
    pub start: Option<[f64; 2]>,
    /// Texture size (the globe's UV square).
    #[arg(long, default_value_t = 1024)]
    pub size: usize,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct TeethArgs {
    /// Photo of the subject's teeth (a smile), cropped around the mouth.
    #[arg(long)]
    pub photo: PathBuf,
    /// Texture size.
    #[arg(long, default_value_t = 1024)]
    pub size: usize,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Args)]
pub struct SyntheticArgs {
    /// Photo width in pixels (height ¾ of it).
    #[arg(long, default_value_t = 1200)]
    pub width: u32,
    /// Landmark click noise (pixels).
    #[arg(long, default_value_t = 1.5)]
    pub noise: f64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output directory.
    #[arg(long)]
    pub out: PathBuf,
}
