//! The viewer's camera: orbit around a point, or walk through the room at eye height.
//!
//! Conventions: right-handed, +Y up, metres, radians. Both modes share one look direction
//! `d(yaw, pitch) = (cos p · sin y, sin p, cos p · cos y)`; orbit places the eye at
//! `target − distance · d`, walk looks along `d` from `eye`. Switching modes keeps the view.
//! Matrices are column-major `[f32; 16]` (OpenGL/WebGL), clip space z in −1..1. Near and far
//! planes ([`NEAR`], [`FAR`]) suit a room: 5 cm to 60 m.

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
    pub target: [f32; 3],
    /// Orbit distance, metres.
    pub distance: f32,
    /// Walk eye position, metres.
    pub eye: [f32; 3],
    /// Turn about +Y, radians (0 looks along +Z).
    pub yaw: f32,
    /// Up/down, radians (negative looks down).
    pub pitch: f32,
    /// Vertical field of view, radians.
    pub fov_y: f32,
    /// Where the walk eye may go: `(min, max)` corners, metres.
    pub walk_bounds: ([f32; 3], [f32; 3]),
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale(a: [f32; 3], s: f32) -> [f32; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

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
    if l > 0.0 { scale(a, 1.0 / l) } else { a }
}

/// `a · b` for column-major 4×4 matrices.
pub fn mat_mul(a: &[f32; 16], b: &[f32; 16]) -> [f32; 16] {
    std::array::from_fn(|i| {
        let (col, row) = (i / 4, i % 4);
        (0..4).map(|k| a[k * 4 + row] * b[col * 4 + k]).sum()
    })
}

impl Camera {
    /// An orbit camera looking at a room of size `room` (x, y, z extents, floor at y = 0,
    /// centred on x = z = 0) from above the +Z side, seeing the floor and the far walls.
    pub fn for_room(room: [f32; 3]) -> Camera {
        let margin = 0.15;
        Camera {
            mode: Mode::Orbit,
            target: [0.0, room[1] * 0.3, 0.0],
            distance: room[0].max(room[2]) * 1.25,
            eye: [0.0, EYE_HEIGHT, room[2] / 2.0 - 0.4],
            yaw: std::f32::consts::PI,
            pitch: -0.55,
            fov_y: 55f32.to_radians(),
            walk_bounds: (
                [-room[0] / 2.0 + margin, 0.2, -room[2] / 2.0 + margin],
                [
                    room[0] / 2.0 - margin,
                    room[1] - margin,
                    room[2] / 2.0 - margin,
                ],
            ),
        }
    }

    /// The unit look direction.
    pub fn direction(&self) -> [f32; 3] {
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        [cp * sy, sp, cp * cy]
    }

    /// The eye position in the current mode.
    pub fn position(&self) -> [f32; 3] {
        match self.mode {
            Mode::Orbit => add(self.target, scale(self.direction(), -self.distance)),
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
                eye[1] = EYE_HEIGHT;
                self.eye = self.clamp_walk(eye);
                self.pitch = self.pitch.clamp(-0.5, 0.5);
            }
            Mode::Orbit => {
                self.target = add(self.eye, scale(self.direction(), self.distance));
            }
        }
        self.mode = mode;
    }

    fn clamp_walk(&self, p: [f32; 3]) -> [f32; 3] {
        let (lo, hi) = self.walk_bounds;
        std::array::from_fn(|i| {
            if p[i].is_finite() {
                p[i].clamp(lo[i], hi[i].max(lo[i]))
            } else {
                lo[i]
            }
        })
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
        let ahead = [sy, 0.0, cy];
        let side = [-cy, 0.0, sy];
        let delta = add(
            add(scale(ahead, forward), scale(side, right)),
            [0.0, up, 0.0],
        );
        match self.mode {
            Mode::Walk => self.eye = self.clamp_walk(add(self.eye, delta)),
            Mode::Orbit => self.target = add(self.target, delta),
        }
    }

    /// The view matrix (world → eye).
    pub fn view(&self) -> [f32; 16] {
        let eye = self.position();
        let f = self.direction();
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

    /// The perspective projection for a viewport of `aspect` = width / height.
    pub fn projection(&self, aspect: f32) -> [f32; 16] {
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        let t = 1.0 / (self.fov_y * 0.5).tan();
        let (n, f) = (NEAR, FAR);
        let mut m = [0.0; 16];
        m[0] = t / aspect;
        m[5] = t;
        m[10] = (f + n) / (n - f);
        m[11] = -1.0;
        m[14] = 2.0 * f * n / (n - f);
        m
    }

    /// `projection · view`.
    pub fn view_projection(&self, aspect: f32) -> [f32; 16] {
        mat_mul(&self.projection(aspect), &self.view())
    }

    /// Where world point `p` lands in a `width × height` viewport, pixels from the top-left
    /// corner; `None` behind the eye or outside the near/far range.
    pub fn project(&self, p: [f32; 3], width: f32, height: f32) -> Option<[f32; 2]> {
        let m = self.view_projection(width / height);
        let c: [f32; 4] =
            std::array::from_fn(|r| m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r]);
        if c[3] <= 0.0 {
            return None;
        }
        let ndc = [c[0] / c[3], c[1] / c[3], c[2] / c[3]];
        if !(-1.0..=1.0).contains(&ndc[2]) {
            return None;
        }
        Some([(ndc[0] + 1.0) * 0.5 * width, (1.0 - ndc[1]) * 0.5 * height])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROOM: [f32; 3] = [5.0, 2.6, 4.0];

    fn close(a: [f32; 2], b: [f32; 2], tol: f32) -> bool {
        (a[0] - b[0]).abs() <= tol && (a[1] - b[1]).abs() <= tol
    }

    #[test]
    fn the_target_projects_to_the_centre_and_up_is_up() {
        let c = Camera::for_room(ROOM);
        let p = c.project(c.target, 800.0, 600.0).unwrap();
        assert!(close(p, [400.0, 300.0], 1e-3), "{p:?}");
        let above = c
            .project(add(c.target, [0.0, 0.5, 0.0]), 800.0, 600.0)
            .unwrap();
        assert!(above[1] < 300.0, "{above:?}");
        // Looking along −Z from +Z: +X is on the right.
        let right = c
            .project(add(c.target, [1.0, 0.0, 0.0]), 800.0, 600.0)
            .unwrap();
        assert!(right[0] > 400.0, "{right:?}");
    }

    #[test]
    fn the_default_view_sees_the_floor_under_the_lamp_and_the_far_corners() {
        let c = Camera::for_room(ROOM);
        for p in [[0.0, 0.0, 0.0], [2.4, 0.0, -1.9], [-2.4, 0.0, -1.9]] {
            let s = c.project(p, 800.0, 600.0).unwrap();
            assert!(
                (0.0..800.0).contains(&s[0]) && (0.0..600.0).contains(&s[1]),
                "{p:?} {s:?}"
            );
        }
        assert!(
            c.position()[2] > ROOM[2] / 2.0,
            "the orbit eye starts outside the +Z wall"
        );
    }

    #[test]
    fn points_behind_the_eye_do_not_project() {
        let c = Camera::for_room(ROOM);
        let behind = add(c.position(), scale(c.direction(), -1.0));
        assert_eq!(c.project(behind, 800.0, 600.0), None);
    }

    #[test]
    fn switching_modes_keeps_the_view_direction_and_walk_stays_inside() {
        let mut c = Camera::for_room(ROOM);
        c.set_mode(Mode::Walk);
        let e = c.position();
        assert!(
            e[2] < ROOM[2] / 2.0 && (e[1] - EYE_HEIGHT).abs() < 1e-6,
            "{e:?}"
        );
        c.walk(100.0, 0.0, 0.0);
        let (lo, hi) = c.walk_bounds;
        let e = c.position();
        assert!((0..3).all(|i| e[i] >= lo[i] && e[i] <= hi[i]), "{e:?}");
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
        assert!(c.yaw.is_finite() && c.target.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn projection_maps_near_and_far_to_the_clip_range() {
        let c = Camera::for_room(ROOM);
        let p = c.projection(1.0);
        let z = |d: f32| (p[10] * -d + p[14]) / d;
        assert!((z(NEAR) + 1.0).abs() < 1e-4 && (z(FAR) - 1.0).abs() < 1e-4);
    }
}
