//! The viewer's camera: orbit around a point, or walk through the room at eye height.
//!
//! Conventions: right-handed, +Y up, metres, radians. Both modes share one look direction
//! `d(yaw, pitch) = (cos p · sin y, sin p, cos p · cos y)`; orbit places the eye at
//! `target − distance · d`, walk looks along `d` from `eye`. Switching modes keeps the view.
//! Vectors and matrices are glam's (`Mat4` is column-major, as OpenGL/WebGL take it), clip
//! space z in −1..1. Near and far planes ([`NEAR`], [`FAR`]) suit a room: 5 cm to 60 m.

use glam::camera::rh::{proj, view};
use glam::{Mat4, Vec2, Vec3};

/// Near clip plane, metres.
pub const NEAR: f32 = 0.05;
/// Far clip plane, metres.
pub const FAR: f32 = 60.0;
/// Eye height of the walk mode above the floor, metres.
pub const EYE_HEIGHT: f32 = 1.6;
/// Radians per pixel of mouse or touch drag.
pub const RADIANS_PER_PIXEL: f32 = 0.005;

const MAX_PITCH: f32 = 1.55;
const MIN_DISTANCE: f32 = 0.3;
const MAX_DISTANCE: f32 = 25.0;

/// Orbit or walk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Turn around `target` at `distance`.
    Orbit,
    /// First person at `eye`, kept inside the walk bounds.
    Walk,
}

/// A perspective camera with orbit and walk controls.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Current mode.
    pub mode: Mode,
    /// Orbit centre, metres.
    pub target: Vec3,
    /// Orbit distance, metres.
    pub distance: f32,
    /// Walk eye position, metres.
    pub eye: Vec3,
    /// Turn about +Y, radians (0 looks along +Z).
    pub yaw: f32,
    /// Up/down, radians (negative looks down).
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Where the walk eye may go: `(min, max)` corners, metres.
    pub walk_bounds: (Vec3, Vec3),
}

impl Camera {
    /// An orbit camera looking at a room of size `room` (x, y, z extents, floor at y = 0,
    /// centred on x = z = 0) from above the +Z side, seeing the floor and the far walls.
    pub fn for_room(room: [f32; 3]) -> Camera {
        let margin = 0.15;
        Camera {
            mode: Mode::Orbit,
            target: Vec3::new(0.0, room[1] * 0.3, 0.0),
            distance: room[0].max(room[2]) * 1.25,
            eye: Vec3::new(0.0, EYE_HEIGHT, room[2] / 2.0 - 0.4),
            yaw: std::f32::consts::PI,
            pitch: -0.55,
            fov_y: 55f32.to_radians(),
            walk_bounds: (
                Vec3::new(-room[0] / 2.0 + margin, 0.2, -room[2] / 2.0 + margin),
                Vec3::new(
                    room[0] / 2.0 - margin,
                    room[1] - margin,
                    room[2] / 2.0 - margin,
                ),
            ),
        }
    }

    /// The unit look direction.
    pub fn direction(&self) -> Vec3 {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        Vec3::new(cp * sy, sp, cp * cy)
    }

    /// The eye position in the current mode.
    pub fn position(&self) -> Vec3 {
        match self.mode {
            Mode::Orbit => self.target + self.direction() * -self.distance,
            Mode::Walk => self.eye,
        }
    }

    /// Switches mode, keeping the current view (the walk eye is clamped into the room).
    pub fn set_mode(&mut self, mode: Mode) {
        if mode == self.mode {
            return;
        }
        match mode {
            Mode::Walk => {
                let mut eye = self.position();
                eye.y = EYE_HEIGHT;
                self.eye = self.clamp_walk(eye);
                self.pitch = self.pitch.clamp(-0.5, 0.5);
            }
            Mode::Orbit => {
                self.target = self.eye + self.direction() * self.distance;
            }
        }
        self.mode = mode;
    }

    /// `p` clamped into the walk bounds; a non-finite coordinate goes to the lower bound.
    fn clamp_walk(&self, p: Vec3) -> Vec3 {
        let (lo, hi) = self.walk_bounds;
        Vec3::select(p.is_finite_mask(), p.max(lo).min(hi.max(lo)), lo)
    }

    /// Turns the view by a drag of `(dx, dy)` pixels: orbit turns around the target, walk
    /// looks around. Dragging right turns the scene right in both modes.
    pub fn drag(&mut self, dx: f32, dy: f32) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        let sign = if self.mode == Mode::Orbit { 1.0 } else { -1.0 };
        self.yaw += sign * dx * RADIANS_PER_PIXEL;
        self.pitch = (self.pitch - sign * dy * RADIANS_PER_PIXEL).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Zooms by `factor` (> 1 moves away): orbit changes the distance, walk steps backward
    /// or forward by `ln(factor)` metres.
    pub fn zoom(&mut self, factor: f32) {
        if !(factor.is_finite() && factor > 0.0) {
            return;
        }
        match self.mode {
            Mode::Orbit => {
                self.distance = (self.distance * factor).clamp(MIN_DISTANCE, MAX_DISTANCE);
            }
            Mode::Walk => self.walk(-factor.ln(), 0.0, 0.0),
        }
    }

    /// Moves `forward`, `right` and `up` metres in the horizontal frame of the view: walk
    /// moves the eye (clamped into the room), orbit moves the target.
    pub fn walk(&mut self, forward: f32, right: f32, up: f32) {
        if !(forward.is_finite() && right.is_finite() && up.is_finite()) {
            return;
        }
        let (sy, cy) = self.yaw.sin_cos();
        let ahead = Vec3::new(sy, 0.0, cy);
        let side = Vec3::new(-cy, 0.0, sy);
        let delta = ahead * forward + side * right + Vec3::new(0.0, up, 0.0);
        match self.mode {
            Mode::Walk => self.eye = self.clamp_walk(self.eye + delta),
            Mode::Orbit => self.target += delta,
        }
    }

    /// The view matrix (world → eye): right-handed, looking along [`Camera::direction`] with
    /// +Y up.
    pub fn view(&self) -> Mat4 {
        view::look_to_mat4(self.position(), self.direction(), Vec3::Y)
    }

    /// The perspective projection for a viewport of `aspect` = width / height (OpenGL clip
    /// space, z in −1..1).
    pub fn projection(&self, aspect: f32) -> Mat4 {
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        proj::opengl::perspective(self.fov_y, aspect, NEAR, FAR)
    }

    /// `projection · view`.
    pub fn view_projection(&self, aspect: f32) -> Mat4 {
        self.projection(aspect) * self.view()
    }

    /// Where world point `p` lands in a `width × height` viewport, pixels from the top-left
    /// corner; `None` behind the eye or outside the near/far range.
    pub fn project(&self, p: Vec3, width: f32, height: f32) -> Option<Vec2> {
        let c = self.view_projection(width / height) * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = c.truncate() / c.w;
        if !(-1.0..=1.0).contains(&ndc.z) {
            return None;
        }
        Some(Vec2::new(
            (ndc.x + 1.0) * 0.5 * width,
            (1.0 - ndc.y) * 0.5 * height,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: [f32; 3] = [5.0, 2.6, 4.0];

    fn close(a: Vec2, b: [f32; 2], tol: f32) -> bool {
        (a.x - b[0]).abs() <= tol && (a.y - b[1]).abs() <= tol
    }

    #[test]
    fn the_target_projects_to_the_centre_and_up_is_up() {
        let c = Camera::for_room(ROOM);
        let p = c.project(c.target, 800.0, 600.0).unwrap();
        assert!(close(p, [400.0, 300.0], 1e-3), "{p:?}");
        let above = c
            .project(c.target + Vec3::new(0.0, 0.5, 0.0), 800.0, 600.0)
            .unwrap();
        assert!(above.y < 300.0, "{above:?}");
        // Looking along −Z from +Z: +X is on the right.
        let right = c
            .project(c.target + Vec3::new(1.0, 0.0, 0.0), 800.0, 600.0)
            .unwrap();
        assert!(right.x > 400.0, "{right:?}");
    }

    #[test]
    fn the_default_view_sees_the_floor_under_the_lamp_and_the_far_corners() {
        let c = Camera::for_room(ROOM);
        for p in [[0.0, 0.0, 0.0], [2.4, 0.0, -1.9], [-2.4, 0.0, -1.9]] {
            let s = c.project(Vec3::from(p), 800.0, 600.0).unwrap();
            assert!(
                (0.0..800.0).contains(&s.x) && (0.0..600.0).contains(&s.y),
                "{p:?} {s:?}"
            );
        }
        assert!(
            c.position().z > ROOM[2] / 2.0,
            "the orbit eye starts outside the +Z wall"
        );
    }

    #[test]
    fn points_behind_the_eye_do_not_project() {
        let c = Camera::for_room(ROOM);
        let behind = c.position() - c.direction();
        assert_eq!(c.project(behind, 800.0, 600.0), None);
    }

    #[test]
    fn switching_modes_keeps_the_view_direction_and_walk_stays_inside() {
        let mut c = Camera::for_room(ROOM);
        c.set_mode(Mode::Walk);
        let e = c.position();
        assert!(
            e.z < ROOM[2] / 2.0 && (e.y - EYE_HEIGHT).abs() < 1e-6,
            "{e:?}"
        );
        c.walk(100.0, 0.0, 0.0);
        let (lo, hi) = c.walk_bounds;
        let e = c.position();
        assert!(e.cmpge(lo).all() && e.cmple(hi).all(), "{e:?}");
        let d = c.direction();
        c.set_mode(Mode::Orbit);
        assert_eq!(c.direction(), d);
        assert!(close(
            c.project(c.target, 100.0, 100.0).unwrap(),
            [50.0, 50.0],
            1e-3
        ));
    }

    #[test]
    fn controls_clamp_and_ignore_non_finite_input() {
        let mut c = Camera::for_room(ROOM);
        c.drag(0.0, 1e6);
        assert!(c.pitch.abs() <= MAX_PITCH);
        c.zoom(1e9);
        assert_eq!(c.distance, MAX_DISTANCE);
        c.zoom(0.0);
        c.zoom(f32::NAN);
        c.drag(f32::NAN, 0.0);
        c.walk(f32::INFINITY, 0.0, 0.0);
        assert_eq!(c.distance, MAX_DISTANCE);
        assert!(c.yaw.is_finite() && c.target.is_finite());
        c.set_mode(Mode::Walk);
        c.eye = Vec3::new(f32::NAN, 100.0, -100.0);
        c.walk(0.0, 0.0, 0.0);
        assert_eq!(
            c.eye,
            Vec3::new(c.walk_bounds.0.x, c.walk_bounds.1.y, c.walk_bounds.0.z)
        );
    }

    #[test]
    fn projection_maps_near_and_far_to_the_clip_range() {
        let c = Camera::for_room(ROOM);
        let p = c.projection(1.0).to_cols_array();
        let z = |d: f32| (p[10] * -d + p[14]) / d;
        assert!((z(NEAR) + 1.0).abs() < 1e-4 && (z(FAR) - 1.0).abs() < 1e-4);
    }

    /// The matrices as the camera computed them before it used glam (column-major, written
    /// out): glam's must be the same ones.
    mod hand_written {
        use super::super::{FAR, NEAR};

        fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        }

        fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
            a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
        }

        fn normalize(a: [f32; 3]) -> [f32; 3] {
            let l = dot(a, a).sqrt();
            if l > 0.0 { a.map(|c| c * (1.0 / l)) } else { a }
        }

        pub fn view(eye: [f32; 3], f: [f32; 3]) -> [f32; 16] {
            let s = normalize(cross(f, [0.0, 1.0, 0.0]));
            let u = cross(s, f);
            [
                s[0],
                u[0],
                -f[0],
                0.0,
                s[1],
                u[1],
                -f[1],
                0.0,
                s[2],
                u[2],
                -f[2],
                0.0,
                -dot(s, eye),
                -dot(u, eye),
                dot(f, eye),
                1.0,
            ]
        }

        pub fn projection(fov_y: f32, aspect: f32) -> [f32; 16] {
            let t = 1.0 / (fov_y * 0.5).tan();
            let (n, f) = (NEAR, FAR);
            let mut m = [0.0; 16];
            m[0] = t / aspect;
            m[5] = t;
            m[10] = (f + n) / (n - f);
            m[11] = -1.0;
            m[14] = 2.0 * f * n / (n - f);
            m
        }

        pub fn mat_mul(a: &[f32; 16], b: &[f32; 16]) -> [f32; 16] {
            std::array::from_fn(|i| {
                let (col, row) = (i / 4, i % 4);
                (0..4).map(|k| a[k * 4 + row] * b[col * 4 + k]).sum()
            })
        }
    }

    #[test]
    fn the_matrices_are_the_hand_written_ones() {
        let same = |got: Mat4, want: [f32; 16], what: &str| {
            let got = got.to_cols_array();
            for (g, w) in got.iter().zip(want) {
                assert!(
                    (g - w).abs() <= 1e-6 * w.abs().max(1.0),
                    "{what}: {got:?} vs {want:?}"
                );
            }
        };
        let mut c = Camera::for_room(ROOM);
        for (i, (yaw, pitch)) in [(0.0, 0.0), (3.1, -0.55), (-2.0, 1.5), (0.7, -1.55)]
            .into_iter()
            .enumerate()
        {
            c.yaw = yaw;
            c.pitch = pitch;
            c.set_mode(if i % 2 == 0 { Mode::Orbit } else { Mode::Walk });
            let (eye, f) = (c.position().to_array(), c.direction().to_array());
            for aspect in [0.5, 1.0, 16.0 / 9.0] {
                let (v, p) = (
                    hand_written::view(eye, f),
                    hand_written::projection(c.fov_y, aspect),
                );
                same(c.view(), v, "view");
                same(c.projection(aspect), p, "projection");
                same(
                    c.view_projection(aspect),
                    hand_written::mat_mul(&p, &v),
                    "view · projection",
                );
            }
        }
    }
}
