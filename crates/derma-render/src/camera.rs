//! The camera: an orbit around the subject's bounding sphere (yaw about +Y, 0 = from +Z, the
//! face's front), perspective with a portrait lens, and the key light's shadow projection.

use glam::{Mat4, Vec3};

/// Vertical field of view: a 85 mm portrait lens on a full-frame sensor (24 mm high).
pub const FOV_Y_DEG: f32 = 16.1;

/// A view of a subject.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    /// Degrees about +Y; 0 looks at the front (+Z side), 90 at the subject's left (+X).
    pub yaw_deg: f32,
    /// Degrees above the horizon.
    pub pitch_deg: f32,
    /// Distance as a multiple of the framing distance (1 = the subject fills the frame).
    pub zoom: f32,
}

impl Default for View {
    fn default() -> Self {
        View {
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            zoom: 1.0,
        }
    }
}

/// The matrices of a view of the sphere (centre, radius) at aspect w/h.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// World → clip (wgpu depth 0..1).
    pub view_proj: Mat4,
    /// Camera position.
    pub eye: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Camera-space axes in world: right, up, back (towards the viewer).
    pub basis: [Vec3; 3],
    /// Focal length in pixels (vertical).
    pub focal_px: f32,
}

impl Camera {
    /// Frames the bounding sphere (`centre`, `radius`) from `view` in a `w`×`h` image.
    pub fn frame(centre: Vec3, radius: f32, view: &View, w: u32, h: u32) -> Camera {
        let fov = FOV_Y_DEG.to_radians();
        let aspect = w as f32 / h as f32;
        // The sphere fits the narrower of the two fields.
        let half = (fov * 0.5).tan() * aspect.min(1.0);
        let dist = view.zoom * radius * (1.0 + half * half).sqrt() / half;
        let (yaw, pitch) = (view.yaw_deg.to_radians(), view.pitch_deg.to_radians());
        let dir = Vec3::new(
            yaw.sin() * pitch.cos(),
            pitch.sin(),
            yaw.cos() * pitch.cos(),
        );
        let eye = centre + dir * dist;
        let view_m = Mat4::look_at_rh(eye, centre, Vec3::Y);
        let near = (dist - 1.5 * radius).max(dist * 0.05);
        let proj = Mat4::perspective_rh(fov, aspect, near, dist + 1.5 * radius);
        let back = dir;
        let right = Vec3::Y.cross(back).normalize();
        let up = back.cross(right);
        Camera {
            view_proj: proj * view_m,
            eye,
            forward: -dir,
            basis: [right, up, back],
            focal_px: 0.5 * h as f32 / (fov * 0.5).tan(),
        }
    }

    /// A camera-space direction in world space.
    pub fn to_world(&self, d: Vec3) -> Vec3 {
        (self.basis[0] * d.x + self.basis[1] * d.y + self.basis[2] * d.z).normalize()
    }
}

/// The orthographic projection of a light along `to_light` covering the sphere.
pub fn light_view_proj(centre: Vec3, radius: f32, to_light: Vec3) -> Mat4 {
    let up = if to_light.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let view = Mat4::look_at_rh(centre + to_light * 2.0 * radius, centre, up);
    Mat4::orthographic_rh(-radius, radius, -radius, radius, 0.5 * radius, 3.5 * radius) * view
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4Swizzles;

    #[test]
    fn the_sphere_fits_the_frame_and_the_centre_projects_to_the_middle() {
        let c = Vec3::new(10.0, 20.0, 30.0);
        for yaw in [0.0, 45.0, 180.0] {
            let cam = Camera::frame(
                c,
                100.0,
                &View {
                    yaw_deg: yaw,
                    ..Default::default()
                },
                800,
                600,
            );
            let p = cam.view_proj * c.extend(1.0);
            assert!((p.xy() / p.w).length() < 1e-5);
            assert!(p.z / p.w > 0.0 && p.z / p.w < 1.0);
            // The sphere's top (perpendicular to the view) stays inside the frame.
            let top = cam.view_proj * (c + cam.basis[1] * 100.0).extend(1.0);
            assert!(
                (top.y / top.w) < 1.0 && (top.y / top.w) > 0.8,
                "{}",
                top.y / top.w
            );
        }
        let l = light_view_proj(c, 100.0, Vec3::new(1.0, 1.0, 1.0).normalize());
        let p = l * c.extend(1.0);
        assert!((p.xy() / p.w).length() < 1e-5 && p.z > 0.0 && p.z < 1.0);
    }
}
