//! A photograph as linear RGB (the sRGB transfer undone, IEC 61966-2-1; derma-core's image, with
//! its bilinear sampling) and its calibrated camera: the input of the resampling (Tarini et al. 2002 §3.2).

use crate::camera::Camera;
use crate::error::{PhotoError, Result};

/// A linear-RGB image, interleaved, row 0 at the top: derma-core's [`derma_core::image::Rgb`].
pub type RgbImage = derma_core::image::Rgb;

/// A photograph with its camera.
#[derive(Clone, Debug)]
pub struct Photo {
    /// Name (file name) for reports.
    pub name: String,
    /// The image, linear RGB.
    pub image: RgbImage,
    /// The calibrated camera.
    pub camera: Camera,
}

impl Photo {
    /// Checks that the image and camera agree in size.
    pub fn check(&self) -> Result<()> {
        if (self.image.width, self.image.height)
            != (self.camera.width as usize, self.camera.height as usize)
        {
            return Err(PhotoError::Camera {
                photo: self.name.clone(),
                detail: format!(
                    "the image is {}×{} but the camera was calibrated for {}×{}",
                    self.image.width, self.image.height, self.camera.width, self.camera.height
                ),
            });
        }
        Ok(())
    }
}
