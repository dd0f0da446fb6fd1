//! Draws a Formica world top-down with tiny-skia: walls, objects and their path, the goal
//! light and its radius, robots with heading and LED colour. Pure Rust, no system libraries.

use formica::geometry::Vec2;
use formica::world::World;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// What to draw besides the world itself.
#[derive(Debug, Clone, Default)]
pub struct Overlay<'a> {
    /// The object's path so far (world coordinates).
    pub path: &'a [Vec2],
    /// Goal radius to draw around the goal (m).
    pub goal_radius: Option<f32>,
}

/// Maps world metres to pixels (y up in the world, down in the image).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Pixels per metre.
    pub scale: f32,
    /// World point at the image's lower-left corner.
    pub min: Vec2,
    /// Image width.
    pub width_px: u32,
    /// Image height.
    pub height_px: u32,
}

impl Frame {
    /// A frame fitting the arena of `world` (plus a margin) into `width_px` pixels.
    pub fn fit(world: &World, width_px: u32) -> Frame {
        let (c, size) = world.arena;
        let span = size + Vec2::splat(0.4);
        let width_px = width_px.max(16);
        let scale = width_px as f32 / span.x;
        Frame {
            scale,
            min: c - span / 2.0,
            width_px,
            height_px: ((span.y * scale).ceil() as u32).max(16),
        }
    }

    /// Pixel position of a world point.
    pub fn px(&self, p: Vec2) -> (f32, f32) {
        (
            (p.x - self.min.x) * self.scale,
            self.height_px as f32 - (p.y - self.min.y) * self.scale,
        )
    }
}

fn rgb(c: [u8; 3]) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color_rgba8(c[0], c[1], c[2], 255);
    p.anti_alias = true;
    p
}

fn polygon(f: &Frame, pts: impl IntoIterator<Item = Vec2>) -> Option<tiny_skia::Path> {
    let mut pb = PathBuilder::new();
    for (i, p) in pts.into_iter().enumerate() {
        let (x, y) = f.px(p);
        if i == 0 {
            pb.move_to(x, y);
        } else {
            pb.line_to(x, y);
        }
    }
    pb.close();
    pb.finish()
}

fn circle(f: &Frame, c: Vec2, r: f32) -> Option<tiny_skia::Path> {
    let (x, y) = f.px(c);
    PathBuilder::from_circle(x, y, (r * f.scale).max(0.5))
}

/// Draws the world into a new image `frame` wide.
pub fn draw(world: &World, frame: &Frame, overlay: &Overlay<'_>) -> Pixmap {
    let mut pm = Pixmap::new(frame.width_px, frame.height_px).unwrap_or_else(|| {
        Pixmap::new(16, 16).unwrap_or_else(|| unreachable!("16x16 pixmap always allocates"))
    });
    pm.fill(Color::from_rgba8(250, 250, 247, 255));
    let id = Transform::identity();
    let thin = Stroke {
        width: 1.0,
        ..Stroke::default()
    };

    // Goal light and radius.
    if let Some(g) = world.goal() {
        if let Some(r) = overlay.goal_radius {
            if let Some(p) = circle(frame, g, r) {
                pm.fill_path(&p, &rgb([255, 244, 190]), FillRule::Winding, id, None);
                pm.stroke_path(&p, &rgb([220, 190, 60]), &thin, id, None);
            }
        }
    }
    for l in &world.lights {
        if let Some(p) = circle(frame, l.position, 0.05) {
            pm.fill_path(&p, &rgb([250, 200, 0]), FillRule::Winding, id, None);
        }
    }

    // Walls.
    for w in &world.walls {
        let (s, c) = w.yaw.sin_cos();
        let h = w.size / 2.0;
        let corners = [(-h.x, -h.y), (h.x, -h.y), (h.x, h.y), (-h.x, h.y)]
            .map(|(x, y)| w.center + Vec2::new(c * x - s * y, s * x + c * y));
        if let Some(p) = polygon(frame, corners) {
            pm.fill_path(&p, &rgb([110, 110, 110]), FillRule::Winding, id, None);
        }
    }

    // Objects.
    for (i, o) in world.objects.iter().enumerate() {
        let pose = world.object_pose(i);
        let fill = rgb(o.color.rgb());
        for outline in o.outlines() {
            if let Some(p) = polygon(frame, outline.into_iter().map(|v| pose.world_from_local(v))) {
                pm.fill_path(&p, &fill, FillRule::Winding, id, None);
                pm.stroke_path(&p, &rgb([20, 60, 20]), &thin, id, None);
            }
        }
    }

    // Object path.
    if overlay.path.len() >= 2 {
        let mut pb = PathBuilder::new();
        for (i, p) in overlay.path.iter().enumerate() {
            let (x, y) = frame.px(*p);
            if i == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        if let Some(p) = pb.finish() {
            let s = Stroke {
                width: 2.0,
                ..Stroke::default()
            };
            pm.stroke_path(&p, &rgb([200, 30, 30]), &s, id, None);
        }
    }

    // Robots.
    for (i, r) in world.robots.iter().enumerate() {
        if r.body.is_none() {
            continue;
        }
        let pose = world.robot_pose(i);
        let rad = world.robot_model(i).radius;
        let c = pose.position();
        let body_color = match r.led {
            formica::scenario::Color::Off => [200, 200, 205],
            led => led.rgb(),
        };
        if let Some(p) = circle(frame, c, rad) {
            pm.fill_path(&p, &rgb(body_color), FillRule::Winding, id, None);
            pm.stroke_path(&p, &rgb([30, 30, 30]), &thin, id, None);
        }
        let tip = c + Vec2::new(pose.theta.cos(), pose.theta.sin()) * rad;
        let mut pb = PathBuilder::new();
        let (x0, y0) = frame.px(c);
        let (x1, y1) = frame.px(tip);
        pb.move_to(x0, y0);
        pb.line_to(x1, y1);
        if let Some(p) = pb.finish() {
            pm.stroke_path(&p, &rgb([0, 0, 0]), &thin, id, None);
        }
    }
    pm
}

/// Draws the world and writes it as a PNG file.
pub fn save_png(
    world: &World,
    width_px: u32,
    overlay: &Overlay<'_>,
    path: &std::path::Path,
) -> Result<(), String> {
    let frame = Frame::fit(world, width_px);
    let pm = draw(world, &frame, overlay);
    pm.save_png(path)
        .map_err(|e| format!("{}: cannot write PNG: {e}", path.display()))
}
