//! Grab, rotate and scale the selected tips with a polygon modeller's habits (Blender's): press
//! G, R or S over the viewport, move the pointer, optionally press X, Y or Z to constrain to
//! that axis, or Shift+X/Y/Z to the plane across it (again to free it), and type a value (a distance, degrees or a factor); Enter or a
//! click confirms, Escape or a right click cancels. Rotation and scaling pivot on the selected
//! tips' median point.
//!
//! UI-free: it turns the pointer, the keys typed and the camera into the transform of the tips
//! ([`ModalTransform::transform`]), which [`crate::sculpt::TipDrag::moves_with`] applies to the
//! hair mesh; tested without a window.

use glam::{DAffine3, DQuat, DVec3, Vec2};

use crate::camera::{OrbitCamera, Projection};

/// What the modal operation does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransformKind {
    Grab,
    Rotate,
    Scale,
}

/// An axis of the file (world) to constrain to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn vector(self) -> DVec3 {
        match self {
            Self::X => DVec3::X,
            Self::Y => DVec3::Y,
            Self::Z => DVec3::Z,
        }
    }
}

/// A grab, rotation or scale in progress.
#[derive(Clone, Debug)]
pub struct ModalTransform {
    pub kind: TransformKind,
    pub axis: Option<Axis>,
    /// The constraint is the plane across `axis`, not the axis (Shift+X/Y/Z).
    pub plane: bool,
    /// The value typed so far (digits, `.`, a leading `-`); empty when the pointer decides.
    pub typed: String,
    /// The median point of the selected tips.
    pub pivot: DVec3,
    /// The pointer when the operation started (viewport pixels).
    start: Vec2,
}

impl ModalTransform {
    /// Starts `kind` on tips whose median point is `pivot`, with the pointer at `start`.
    pub fn new(kind: TransformKind, pivot: DVec3, start: Vec2) -> Self {
        Self { kind, axis: None, plane: false, typed: String::new(), pivot, start }
    }

    /// Constrains to `axis`, or frees it when it already is.
    pub fn toggle_axis(&mut self, axis: Axis) {
        self.axis = if self.axis == Some(axis) && !self.plane { None } else { Some(axis) };
        self.plane = false;
    }

    /// Constrains to the plane across `axis` (a grab in it, a scale of its two directions, a
    /// rotation about `axis`), or frees it when it already is.
    pub fn toggle_plane(&mut self, axis: Axis) {
        let again = self.axis == Some(axis) && self.plane;
        self.axis = (!again).then_some(axis);
        self.plane = !again;
    }

    /// Adds a typed character (digits, `.`, `-` to negate); others are ignored. `true` when it
    /// was taken.
    pub fn type_char(&mut self, c: char) -> bool {
        match c {
            '0'..='9' => self.typed.push(c),
            '.' if !self.typed.contains('.') => self.typed.push(c),
            '-' => {
                if let Some(rest) = self.typed.strip_prefix('-') {
                    self.typed = rest.to_owned();
                } else {
                    self.typed.insert(0, '-');
                }
            }
            _ => return false,
        }
        true
    }

    /// Removes the last typed character.
    pub fn backspace(&mut self) {
        self.typed.pop();
    }

    /// The typed value, if one is typed (a lone `-` or `.` is none yet).
    pub fn typed_value(&self) -> Option<f64> {
        self.typed.parse::<f64>().ok().filter(|v| v.is_finite())
    }

    /// The transform of the tips for the pointer at `pointer` (viewport pixels) in a viewport
    /// of `size` seen through `camera`, or for the typed value when there is one.
    pub fn transform(&self, camera: &OrbitCamera, size: Vec2, pointer: Vec2) -> DAffine3 {
        let about_pivot = |a: DAffine3| {
            DAffine3::from_translation(self.pivot) * a * DAffine3::from_translation(-self.pivot)
        };
        let eye = camera.eye().as_dvec3();
        let toward_eye = (eye - self.pivot).normalize_or(DVec3::Z);
        let screen_pivot = Projection::new(camera, size)
            .project(self.pivot.as_vec3())
            .map_or(size / 2.0, |(pixel, _)| pixel);
        match self.kind {
            TransformKind::Grab => {
                let delta = match (self.typed_value(), self.axis, self.plane) {
                    // Blender: a typed distance without an axis moves along X; in a plane, along
                    // its first axis.
                    (Some(v), Some(Axis::X), true) => DVec3::Y * v,
                    (Some(v), Some(_), true) | (Some(v), None, _) => DVec3::X * v,
                    (Some(v), Some(a), false) => a.vector() * v,
                    (None, axis, plane) => {
                        let moved = camera.drag_point(self.pivot.as_vec3(), pointer - self.start, size.y);
                        let d = moved.as_dvec3() - self.pivot;
                        match axis {
                            Some(a) if plane => d - a.vector() * d.dot(a.vector()),
                            Some(a) => a.vector() * d.dot(a.vector()),
                            None => d,
                        }
                    }
                };
                DAffine3::from_translation(delta)
            }
            TransformKind::Rotate => {
                // About the axis, or the line of sight (counter-clockwise on the screen is
                // counter-clockwise seen from the eye).
                let axis = self.axis.map_or(toward_eye, Axis::vector);
                let angle = match self.typed_value() {
                    Some(degrees) => degrees.to_radians(),
                    None => {
                        let (a, b) = (self.start - screen_pivot, pointer - screen_pivot);
                        // Screen y points down: the angle on the screen is the negated one.
                        let on_screen = -f64::from(a.perp_dot(b)).atan2(f64::from(a.dot(b)));
                        // Seen from behind the axis, the turn is the other way.
                        if axis.dot(toward_eye) < 0.0 { -on_screen } else { on_screen }
                    }
                };
                about_pivot(DAffine3::from_quat(DQuat::from_axis_angle(axis, angle)))
            }
            TransformKind::Scale => {
                let factor = match self.typed_value() {
                    Some(f) => f,
                    None => {
                        let from = (self.start - screen_pivot).length().max(1.0);
                        f64::from((pointer - screen_pivot).length() / from)
                    }
                };
                let scale = match self.axis {
                    Some(a) if self.plane => DVec3::ONE + (DVec3::ONE - a.vector()) * (factor - 1.0),
                    Some(a) => DVec3::ONE + a.vector() * (factor - 1.0),
                    None => DVec3::splat(factor),
                };
                about_pivot(DAffine3::from_scale(scale))
            }
        }
    }

    /// What the status bar says while it runs.
    pub fn describe(&self, transform: &DAffine3) -> String {
        let axis = match self.axis {
            Some(a) if self.plane => format!(" across {a:?}"),
            Some(a) => format!(" along {a:?}"),
            None => String::new(),
        };
        let value = match self.kind {
            TransformKind::Grab => {
                let d = transform.translation;
                format!("Grab{axis}: {:.4}, {:.4}, {:.4}", d.x, d.y, d.z)
            }
            TransformKind::Rotate => {
                let (_, angle) = DQuat::from_mat3(&transform.matrix3).to_axis_angle();
                format!("Rotate{axis}: {:.1}°", angle.to_degrees())
            }
            TransformKind::Scale => {
                let s = transform
                    .matrix3
                    .x_axis
                    .x
                    .max(transform.matrix3.y_axis.y)
                    .max(transform.matrix3.z_axis.z);
                let s = match self.axis {
                    None => transform.matrix3.x_axis.x,
                    Some(a) if self.plane => {
                        let d = DVec3::new(
                            transform.matrix3.x_axis.x,
                            transform.matrix3.y_axis.y,
                            transform.matrix3.z_axis.z,
                        );
                        // One of the plane's two directions (both scale alike).
                        if a == Axis::X { d.y } else { d.x }
                    }
                    Some(_) => s,
                };
                format!("Scale{axis}: {s:.3}")
            }
        };
        let typed = if self.typed.is_empty() { String::new() } else { format!(" [typed {}]", self.typed) };
        format!(
            "{value}{typed} — X/Y/Z constrain (Shift: the plane across), type a value, Enter or click to confirm, Esc to cancel"
        )
    }
}

/// The median point (mean) of `points`; `None` for none.
pub fn median_point(points: impl IntoIterator<Item = DVec3>) -> Option<DVec3> {
    let (sum, n) = points.into_iter().fold((DVec3::ZERO, 0usize), |(s, n), p| (s + p, n + 1));
    (n > 0).then(|| sum / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> OrbitCamera {
        OrbitCamera {
            target: DVec3::ZERO.as_vec3(),
            yaw: 0.0,
            pitch: 0.0,
            distance: 3.0,
            fov_y_degrees: 35.0,
        }
    }

    const SIZE: Vec2 = Vec2::new(400.0, 300.0);

    #[test]
    fn a_typed_grab_along_an_axis_moves_exactly_that_far() {
        let mut g = ModalTransform::new(TransformKind::Grab, DVec3::new(0.1, 0.2, 0.3), SIZE / 2.0);
        g.toggle_axis(Axis::Z);
        for c in "-0.25".chars() {
            assert!(g.type_char(c));
        }
        let t = g.transform(&camera(), SIZE, SIZE);
        assert_eq!(t.translation, DVec3::new(0.0, 0.0, -0.25));
        g.toggle_axis(Axis::Z);
        assert_eq!(g.axis, None);
    }

    #[test]
    fn a_pointer_grab_constrained_to_y_moves_only_along_y() {
        let g = {
            let mut g = ModalTransform::new(TransformKind::Grab, DVec3::ZERO, SIZE / 2.0);
            g.toggle_axis(Axis::Y);
            g
        };
        // The camera looks along −Z: moving the pointer up and right moves along +Y only.
        let t = g.transform(&camera(), SIZE, SIZE / 2.0 + Vec2::new(30.0, -40.0));
        assert!(t.translation.y > 0.0 && t.translation.x == 0.0 && t.translation.z == 0.0, "{t:?}");
    }

    #[test]
    fn rotation_keeps_the_pivot_and_follows_the_pointer_around_it() {
        let pivot = DVec3::ZERO;
        let r = ModalTransform::new(TransformKind::Rotate, pivot, SIZE / 2.0 + Vec2::new(50.0, 0.0));
        // A quarter turn counter-clockwise on the screen (from the right of the pivot to above
        // it) turns a point on the right of the pivot to above it.
        let t = r.transform(&camera(), SIZE, SIZE / 2.0 + Vec2::new(0.0, -50.0));
        assert!(t.transform_point3(pivot).distance(pivot) < 1e-9);
        let p = t.transform_point3(DVec3::X);
        assert!(p.distance(DVec3::Y) < 1e-6, "{p}");
        // Typed degrees about Y.
        let mut r = r;
        r.toggle_axis(Axis::Y);
        "90".chars().for_each(|c| {
            r.type_char(c);
        });
        let p = r.transform(&camera(), SIZE, SIZE).transform_point3(DVec3::X);
        assert!(p.distance(DVec3::NEG_Z) < 1e-9, "{p}");
    }

    #[test]
    fn a_plane_constraint_scales_and_grabs_across_its_axis() {
        let camera = OrbitCamera::default();
        let size = Vec2::new(800.0, 600.0);
        let mut s =
            ModalTransform::new(TransformKind::Scale, DVec3::new(0.0, 1.0, 0.0), Vec2::new(500.0, 300.0));
        s.toggle_plane(Axis::Y);
        for c in "0.5".chars() {
            s.type_char(c);
        }
        let t = s.transform(&camera, size, Vec2::new(500.0, 300.0));
        let diagonal = DVec3::new(t.matrix3.x_axis.x, t.matrix3.y_axis.y, t.matrix3.z_axis.z);
        assert!(diagonal.distance(DVec3::new(0.5, 1.0, 0.5)) < 1e-12, "{diagonal}");
        assert!(s.describe(&t).contains("across Y"), "{}", s.describe(&t));
        // The pivot stays; again frees it; an axis replaces it.
        assert!(t.transform_point3(s.pivot).distance(s.pivot) < 1e-12);
        s.toggle_plane(Axis::Y);
        assert_eq!((s.axis, s.plane), (None, false));
        s.toggle_plane(Axis::Y);
        s.toggle_axis(Axis::Y);
        assert_eq!((s.axis, s.plane), (Some(Axis::Y), false));
        // A pointer grab in the plane across Z keeps z.
        let mut g = ModalTransform::new(TransformKind::Grab, DVec3::ZERO, Vec2::new(400.0, 300.0));
        g.toggle_plane(Axis::Z);
        let t = g.transform(&camera, size, Vec2::new(470.0, 260.0));
        assert!(t.translation.z.abs() < 1e-12 && t.translation.length() > 0.0, "{}", t.translation);
    }

    #[test]
    fn scaling_follows_the_distance_to_the_pivot_and_can_be_typed_per_axis() {
        let pivot = DVec3::new(0.0, 1.0, 0.0);
        let mut s = ModalTransform::new(TransformKind::Scale, DVec3::ZERO, SIZE / 2.0 + Vec2::new(40.0, 0.0));
        let t = s.transform(&camera(), SIZE, SIZE / 2.0 + Vec2::new(0.0, 20.0));
        assert!((t.matrix3.x_axis.x - 0.5).abs() < 1e-6, "{t:?}");
        s.pivot = pivot;
        s.toggle_axis(Axis::X);
        s.type_char('2');
        let t = s.transform(&camera(), SIZE, SIZE);
        assert!(t.transform_point3(DVec3::new(1.0, 2.0, 3.0)).distance(DVec3::new(2.0, 2.0, 3.0)) < 1e-12);
        assert!(s.describe(&t).starts_with("Scale along X: 2.000"));
    }

    #[test]
    fn typing_keeps_a_number() {
        let mut g = ModalTransform::new(TransformKind::Grab, DVec3::ZERO, Vec2::ZERO);
        for c in "1.2.5x".chars() {
            g.type_char(c);
        }
        assert_eq!(g.typed, "1.25");
        g.type_char('-');
        assert_eq!(g.typed_value(), Some(-1.25));
        g.type_char('-');
        g.backspace();
        assert_eq!(g.typed_value(), Some(1.2));
        assert_eq!(median_point([DVec3::ZERO, DVec3::X * 2.0]), Some(DVec3::X));
        assert_eq!(median_point([]), None);
    }
}
