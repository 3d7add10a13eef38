//! A pinhole camera with two radial distortion terms, as photogrammetry calibrates one (Tsai
//! 1986, which Tarini et al. 2002 §3 use; Brown's radial model x_d = x (1 + k₁r² + k₂r⁴)).
//!
//! Conventions: camera axes x right, y down, z forward (into the scene); pixel coordinates have
//! their origin at the image's top-left corner, so pixel (i, j) has its centre at (i+½, j+½).

use glam::{DMat3, DVec2, DVec3, Vec3};
use serde::{Deserialize, Serialize};

/// A calibrated camera: pose (world → camera) and intrinsics in pixels.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Rotation world → camera as a Rodrigues vector (axis × angle, radians).
    pub rotation: [f64; 3],
    /// Translation world → camera (mesh units): X_c = R X + t.
    pub translation: [f64; 3],
    /// Focal length in pixels (square pixels).
    pub focal_px: f64,
    /// Principal point in pixels.
    pub principal: [f64; 2],
    /// Radial distortion k₁ (of r², r in focal-length units).
    pub k1: f64,
    /// Radial distortion k₂ (of r⁴).
    pub k2: f64,
}

/// Rotation matrix of a Rodrigues vector.
pub fn rodrigues(r: [f64; 3]) -> DMat3 {
    let v = DVec3::from(r);
    let angle = v.length();
    if angle < 1e-12 {
        // First order: I + [v]ₓ.
        return DMat3::from_cols(
            DVec3::new(1.0, v.z, -v.y),
            DVec3::new(-v.z, 1.0, v.x),
            DVec3::new(v.y, -v.x, 1.0),
        );
    }
    DMat3::from_axis_angle(v / angle, angle)
}

/// Rodrigues vector of a rotation matrix.
pub fn rotation_vector(m: DMat3) -> [f64; 3] {
    let q = glam::DQuat::from_mat3(&m).normalize();
    let (axis, angle) = q.to_axis_angle();
    let angle = if angle > std::f64::consts::PI {
        angle - 2.0 * std::f64::consts::PI
    } else {
        angle
    };
    (axis * angle).to_array()
}

/// A camera with its rotation matrix and centre computed once, for projecting many points.
#[derive(Clone, Copy, Debug)]
pub struct Prepared {
    /// The camera.
    pub camera: Camera,
    /// Rotation world → camera.
    pub rotation: DMat3,
    /// Translation.
    pub translation: DVec3,
    /// Centre in world coordinates.
    pub centre: DVec3,
}

impl Prepared {
    /// Prepares `camera`.
    pub fn new(camera: &Camera) -> Self {
        Self {
            camera: *camera,
            rotation: camera.rotation_matrix(),
            translation: DVec3::from(camera.translation),
            centre: camera.centre(),
        }
    }

    /// Pixel of a world point, or `None` behind the camera (as [`Camera::project`]).
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        let c = self.rotation * p + self.translation;
        (c.z > 1e-9).then(|| self.camera.pixel_of_camera_point(c))
    }
}

/// The RMS distance (pixels) between where cameras `a` and `b` put the same points (those both
/// see in front of them); 0 for none.
pub fn pixel_distance(a: &Camera, b: &Camera, points: impl IntoIterator<Item = DVec3>) -> f64 {
    let (a, b) = (Prepared::new(a), Prepared::new(b));
    let (mut s, mut n) = (0.0f64, 0usize);
    for p in points {
        if let (Some(x), Some(y)) = (a.project(p), b.project(p)) {
            s += (x - y).length_squared();
            n += 1;
        }
    }
    (s / n.max(1) as f64).sqrt()
}

impl Camera {
    /// A camera at `eye` looking at `target` with `up` roughly up in the image, focal length
    /// `focal_px`, principal point at the image centre and no distortion.
    pub fn look_at(
        width: u32,
        height: u32,
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        focal_px: f64,
    ) -> Self {
        let (eye, target, up) = (eye.as_dvec3(), target.as_dvec3(), up.as_dvec3());
        let z = (target - eye).normalize();
        let x = z.cross(up).normalize();
        let y = z.cross(x);
        // Rows of R are the camera axes in world coordinates.
        let r = DMat3::from_cols(x, y, z).transpose();
        let t = -(r * eye);
        Camera {
            width,
            height,
            rotation: rotation_vector(r),
            translation: t.to_array(),
            focal_px,
            principal: [width as f64 / 2.0, height as f64 / 2.0],
            k1: 0.0,
            k2: 0.0,
        }
    }

    /// The rotation world → camera.
    pub fn rotation_matrix(&self) -> DMat3 {
        rodrigues(self.rotation)
    }

    /// The camera's centre in world coordinates, C = −Rᵀt.
    pub fn centre(&self) -> DVec3 {
        -(self.rotation_matrix().transpose() * DVec3::from(self.translation))
    }

    /// The viewing direction (camera +z) in world coordinates.
    pub fn forward(&self) -> DVec3 {
        self.rotation_matrix().row(2)
    }

    /// A world point in camera coordinates.
    pub fn to_camera(&self, p: DVec3) -> DVec3 {
        self.rotation_matrix() * p + DVec3::from(self.translation)
    }

    /// Pixel of a point in camera coordinates (z > 0), with distortion.
    pub fn pixel_of_camera_point(&self, c: DVec3) -> DVec2 {
        let (x, y) = (c.x / c.z, c.y / c.z);
        let r2 = x * x + y * y;
        let d = 1.0 + self.k1 * r2 + self.k2 * r2 * r2;
        DVec2::new(
            self.focal_px * x * d + self.principal[0],
            self.focal_px * y * d + self.principal[1],
        )
    }

    /// Pixel of a world point, or `None` when it lies behind the camera.
    pub fn project(&self, p: DVec3) -> Option<DVec2> {
        let c = self.to_camera(p);
        (c.z > 1e-9).then(|| self.pixel_of_camera_point(c))
    }

    /// Whether a pixel lies inside the image.
    pub fn in_image(&self, px: DVec2) -> bool {
        px.x >= 0.0 && px.y >= 0.0 && px.x < self.width as f64 && px.y < self.height as f64
    }

    /// What this camera sees of `mesh`, per pixel (row-major, one sample at each pixel centre):
    /// derma-render's rasteriser through the pinhole.
    pub fn rasterise(
        &self,
        mesh: &derma_core::mesh::TriMesh,
    ) -> Vec<Option<derma_render::raster::Hit>> {
        use derma_render::raster::{rasterise, Object, Projection};
        let projection = Projection::Pinhole {
            rotation: self.rotation_matrix().as_mat3(),
            position: self.centre().as_vec3(),
            focal: self.focal_px as f32,
            principal: glam::Vec2::new(self.principal[0] as f32, self.principal[1] as f32),
        };
        rasterise(
            &[Object {
                mesh,
                coverage: None,
            }],
            &projection,
            self.width as usize,
            self.height as usize,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rodrigues_round_trips() {
        for r in [
            [0.1, -0.2, 0.3],
            [1.5, 0.2, -0.7],
            [0.0, 0.0, 1e-14],
            [0.0, 3.0, 0.0],
        ] {
            let m = rodrigues(r);
            let back = rodrigues(rotation_vector(m));
            assert!((m - back).abs_diff_eq(DMat3::ZERO, 1e-9), "{r:?}");
            assert!((m.determinant() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn look_at_puts_the_target_at_the_principal_point() {
        let cam = Camera::look_at(
            800,
            600,
            Vec3::new(0.0, 0.0, 500.0),
            Vec3::ZERO,
            Vec3::Y,
            1000.0,
        );
        let px = cam.project(DVec3::ZERO).unwrap();
        assert!((px - DVec2::new(400.0, 300.0)).length() < 1e-9);
        // World +Y (up) goes up in the image (smaller row), world +X to the right (viewer's
        // right when looking down −Z).
        assert!(cam.project(DVec3::new(0.0, 10.0, 0.0)).unwrap().y < 300.0);
        assert!(cam.project(DVec3::new(10.0, 0.0, 0.0)).unwrap().x > 400.0);
        assert!((cam.centre() - DVec3::new(0.0, 0.0, 500.0)).length() < 1e-9);
        assert!(cam.project(DVec3::new(0.0, 0.0, 600.0)).is_none());
    }
}
