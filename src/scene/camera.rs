//! Pinhole camera: `origin`, `target`, `up`, `fov` (degrees) along `fov_axis`, `resolution`.
use crate::math::Ray;
use crate::scene::file::FovAxis;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Camera {
    pub origin: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
    pub tan_half: [f32; 2],
    pub width: u32,
    pub height: u32,
}

impl Camera {
    pub fn new(origin: Vec3, target: Vec3, up: Vec3, fov_deg: f32, axis: FovAxis, res: [u32; 2]) -> Camera {
        let forward = (target - origin).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        let t = (fov_deg.to_radians() * 0.5).tan();
        let aspect = res[0] as f32 / res[1] as f32;
        let tan_half = match axis {
            FovAxis::X => [t, t / aspect],
            FovAxis::Y => [t * aspect, t],
        };
        Camera { origin, right, up, forward, tan_half, width: res[0], height: res[1] }
    }

    /// Primary ray through film position (x, y) in pixels, (0,0) = top-left corner.
    pub fn ray(&self, x: f32, y: f32) -> Ray {
        let sx = (2.0 * x / self.width as f32 - 1.0) * self.tan_half[0];
        let sy = (1.0 - 2.0 * y / self.height as f32) * self.tan_half[1];
        Ray::new(self.origin, (self.forward + sx * self.right + sy * self.up).normalize())
    }

    /// Distance from the pinhole to the plane on which one pixel has unit area.
    pub fn pixel_plane_distance(&self) -> f32 {
        self.width as f32 / (2.0 * self.tan_half[0])
    }

    /// Solid-angle density of a primary ray along unit direction `d` when the film position is uniform
    /// over one pixel (D²/cos³θ with D the unit-pixel plane's distance), 0 behind the camera. It is also
    /// the pixel's importance times cos θ: light tracing divides by it to land on the film.
    pub fn pixel_pdf_dir(&self, d: Vec3) -> f32 {
        let c = d.dot(self.forward);
        if c <= 0.0 {
            return 0.0;
        }
        let dd = self.pixel_plane_distance();
        dd * dd / (c * c * c)
    }

    /// Film position of a world point, if it is in front of the camera and on the film.
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.origin;
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(self.right) / z / self.tan_half[0];
        let sy = d.dot(self.up) / z / self.tan_half[1];
        let x = (sx + 1.0) * 0.5 * self.width as f32;
        let y = (1.0 - sy) * 0.5 * self.height as f32;
        (x >= 0.0 && y >= 0.0 && x < self.width as f32 && y < self.height as f32).then_some((x, y))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn project_inverts_ray() {
        let c = Camera::new(Vec3::new(0.0, 1.0, 4.0), Vec3::new(0.0, 1.0, 0.0), Vec3::Y, 40.0, FovAxis::X, [320, 200]);
        for (x, y) in [(10.5, 20.5), (160.0, 100.0), (300.2, 190.9)] {
            let r = c.ray(x, y);
            let (px, py) = c.project(r.at(3.0)).unwrap();
            assert!((px - x).abs() < 1e-3 && (py - y).abs() < 1e-3);
        }
    }
}
