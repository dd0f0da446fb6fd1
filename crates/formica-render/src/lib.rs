//! Draws a Formica world top-down with tiny-skia: walls, objects and their path, the goal
//! light and its radius, robots with heading and LED colour. Pure Rust, no system libraries.

use formica::geometry::Vec2;
use formica::ops;
use formica::world::World;
pub use tiny_skia::Pixmap;
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Stroke, Transform};

pub mod video;

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

    /// As [`Frame::fit`], with both sides even (as H.264 video needs).
    pub fn fit_even(world: &World, width_px: u32) -> Frame {
        let mut f = Frame::fit(world, width_px & !1);
        f.width_px &= !1;
        f.height_px += f.height_px % 2;
        f
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
        if let Some(p) = polygon(frame, w.outline()) {
            pm.fill_path(&p, &rgb([110, 110, 110]), FillRule::Winding, id, None);
        }
    }

    // Objects.
    for (i, o) in world.objects.iter().enumerate() {
        let fill = rgb(o.color.rgb());
        for outline in world.object_outlines(i) {
            if let Some(p) = polygon(frame, outline) {
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
        let tip = c + ops::unit(pose.theta) * rad;
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

/// The floor zones where robots' light sensors cannot see the goal light because an object
/// hides it, as polygons (counter-clockwise, world coordinates; their union is the zone).
///
/// Uses the occlusion rule of [`formica::sensors::light_blocked`]: a sensor at `sensor_height`
/// behind an object of height `h` is in shadow out to `1 / (1 - k)` times the object's
/// distance from the light, with `k = (h - sensor_height) / (light_height - sensor_height)`;
/// an object at least as tall as the light casts a shadow to the arena's edge. The zone of
/// each object is its outline plus one quadrilateral per outline edge.
pub fn occlusion_zones(world: &World, sensor_height: f32) -> Vec<Vec<Vec2>> {
    let mut out = Vec::new();
    let Some(gi) = world.goal_light else {
        return out;
    };
    let Some(light) = world.lights.get(gi) else {
        return out;
    };
    let l = light.position;
    let (_, size) = world.arena;
    let far = 2.0 * size.length() + 1.0;
    for (i, o) in world.objects.iter().enumerate() {
        if o.height <= sensor_height {
            continue;
        }
        // How far (as a multiple of the distance from the light) the shadow reaches.
        let stretch = if o.height >= light.height || light.height <= sensor_height {
            None
        } else {
            let k = (o.height - sensor_height) / (light.height - sensor_height);
            Some(1.0 / (1.0 - k).max(1e-3))
        };
        let project = |p: Vec2| -> Vec2 {
            let d = p - l;
            let len = d.length();
            if len < 1e-6 {
                return p;
            }
            match stretch {
                Some(s) => l + d * s.min(far / len).max(1.0),
                None => l + d * (far / len).max(1.0),
            }
        };
        for pts in world.object_outlines(i) {
            if pts.len() < 3 {
                continue;
            }
            out.push(ccw(pts.clone()));
            for k in 0..pts.len() {
                let a = pts[k];
                let b = pts[(k + 1) % pts.len()];
                out.push(ccw(vec![a, b, project(b), project(a)]));
            }
        }
    }
    // Keep to the arena.
    let (c, size) = world.arena;
    let (lo, hi) = (c - size / 2.0, c + size / 2.0);
    out.into_iter()
        .map(|z| clip_to_box(z, lo, hi))
        .filter(|z| z.len() >= 3)
        .collect()
}

/// Sutherland-Hodgman clipping of a polygon to the box `lo`..`hi` (keeps orientation).
fn clip_to_box(poly: Vec<Vec2>, lo: Vec2, hi: Vec2) -> Vec<Vec2> {
    // Each edge of the box as (axis, bound, keep-below).
    let edges = [
        (0, lo.x, false),
        (0, hi.x, true),
        (1, lo.y, false),
        (1, hi.y, true),
    ];
    let mut pts = poly;
    for (axis, bound, below) in edges {
        if pts.is_empty() {
            break;
        }
        let coord = |p: Vec2| if axis == 0 { p.x } else { p.y };
        let inside = |p: Vec2| {
            if below {
                coord(p) <= bound
            } else {
                coord(p) >= bound
            }
        };
        let mut out = Vec::with_capacity(pts.len() + 2);
        for k in 0..pts.len() {
            let cur = pts[k];
            let prev = pts[(k + pts.len() - 1) % pts.len()];
            let cross = |a: Vec2, b: Vec2| {
                let t = (bound - coord(a)) / (coord(b) - coord(a));
                a + (b - a) * t
            };
            match (inside(prev), inside(cur)) {
                (true, true) => out.push(cur),
                (true, false) => out.push(cross(prev, cur)),
                (false, true) => {
                    out.push(cross(prev, cur));
                    out.push(cur);
                }
                (false, false) => {}
            }
        }
        pts = out;
    }
    pts
}

fn ccw(mut pts: Vec<Vec2>) -> Vec<Vec2> {
    if formica::geometry::signed_area(&pts) < 0.0 {
        pts.reverse();
    }
    pts
}

/// Light-sensor height of the first robot group (0 without robots), the height at which
/// [`occlusion_zones`] is usually asked for.
pub fn light_sensor_height(world: &World) -> f32 {
    world.groups.first().map_or(0.0, |g| g.model.light_height)
}

/// Shades `zones` (from [`occlusion_zones`]) translucent grey onto `pm`.
pub fn draw_zones(pm: &mut Pixmap, frame: &Frame, zones: &[Vec<Vec2>]) {
    let mut pb = PathBuilder::new();
    for z in zones {
        for (i, p) in z.iter().enumerate() {
            let (x, y) = frame.px(*p);
            if i == 0 {
                pb.move_to(x, y);
            } else {
                pb.line_to(x, y);
            }
        }
        pb.close();
    }
    if let Some(p) = pb.finish() {
        let mut paint = Paint::default();
        paint.set_color_rgba8(60, 60, 90, 60);
        paint.anti_alias = true;
        pm.fill_path(&p, &paint, FillRule::Winding, Transform::identity(), None);
    }
}

/// Streams frames into an animated GIF (looping forever). Frames are quantised one by one,
/// so memory stays that of one frame whatever the length; the last frame is held longer.
pub struct GifWriter<W: std::io::Write> {
    enc: gif::Encoder<W>,
    width: u16,
    height: u16,
    delay_cs: u16,
    hold_cs: u16,
    pending: Option<Vec<u8>>,
    frames: usize,
}

impl<W: std::io::Write> GifWriter<W> {
    /// A writer of `width` x `height` frames shown `delay_cs` hundredths of a second each;
    /// the last one is shown `hold_cs`.
    pub fn new(
        out: W,
        width: u32,
        height: u32,
        delay_cs: u16,
        hold_cs: u16,
    ) -> Result<Self, String> {
        let w = u16::try_from(width).map_err(|_| format!("GIF width {width} exceeds 65535"))?;
        let h = u16::try_from(height).map_err(|_| format!("GIF height {height} exceeds 65535"))?;
        let mut enc = gif::Encoder::new(out, w, h, &[]).map_err(|e| format!("GIF: {e}"))?;
        enc.set_repeat(gif::Repeat::Infinite)
            .map_err(|e| format!("GIF: {e}"))?;
        Ok(Self {
            enc,
            width: w,
            height: h,
            delay_cs,
            hold_cs,
            pending: None,
            frames: 0,
        })
    }

    /// Adds one frame; it must be the size given to [`GifWriter::new`].
    pub fn push(&mut self, pm: &Pixmap) -> Result<(), String> {
        if pm.width() != u32::from(self.width) || pm.height() != u32::from(self.height) {
            return Err(format!(
                "GIF frame is {}x{}, expected {}x{}",
                pm.width(),
                pm.height(),
                self.width,
                self.height
            ));
        }
        let mut rgba = Vec::with_capacity(pm.data().len());
        for p in pm.pixels() {
            let c = p.demultiply();
            rgba.extend_from_slice(&[c.red(), c.green(), c.blue(), c.alpha()]);
        }
        if let Some(prev) = self.pending.replace(rgba) {
            self.write(prev, self.delay_cs)?;
        }
        Ok(())
    }

    fn write(&mut self, mut rgba: Vec<u8>, delay: u16) -> Result<(), String> {
        let mut f = gif::Frame::from_rgba_speed(self.width, self.height, &mut rgba, 10);
        f.delay = delay;
        self.enc.write_frame(&f).map_err(|e| format!("GIF: {e}"))?;
        self.frames += 1;
        Ok(())
    }

    /// Frames added so far.
    pub fn frames(&self) -> usize {
        self.frames + usize::from(self.pending.is_some())
    }

    /// Writes the last frame and the trailer; returns the output.
    pub fn finish(mut self) -> Result<W, String> {
        if let Some(last) = self.pending.take() {
            let hold = self.hold_cs.max(self.delay_cs);
            self.write(last, hold)?;
        }
        self.enc.into_inner().map_err(|e| format!("GIF: {e}"))
    }
}

/// How [`record_gif`] samples a run.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordOptions {
    /// Image width (px); the height follows the arena.
    pub width_px: u32,
    /// One frame every this many control ticks (at least 1).
    pub every_ticks: u64,
    /// Display time of each frame (1/100 s).
    pub delay_cs: u16,
    /// Display time of the last frame (1/100 s).
    pub hold_cs: u16,
    /// Shade the zone where the object hides the goal light.
    pub occlusion: bool,
    /// Stop after this many frames even if the run goes on.
    pub max_frames: usize,
}

impl Default for RecordOptions {
    fn default() -> Self {
        Self {
            width_px: 640,
            every_ticks: 10,
            delay_cs: 10,
            hold_cs: 200,
            occlusion: false,
            max_frames: 3000,
        }
    }
}

/// What [`record_gif`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSummary {
    /// Frames in the file.
    pub frames: usize,
    /// The run's outcome (`None` if `max_frames` cut it short).
    pub outcome: Option<formica::Outcome>,
    /// Simulated seconds recorded.
    pub sim_time_s: f64,
    /// Control ticks recorded.
    pub ticks: u64,
}

/// Where [`record`] sends its frames: a GIF or a video.
pub trait FrameSink {
    /// Adds one frame.
    fn push(&mut self, pm: &Pixmap) -> Result<(), String>;
    /// Frames added so far.
    fn frames(&self) -> usize;
}

impl<W: std::io::Write> FrameSink for GifWriter<W> {
    fn push(&mut self, pm: &Pixmap) -> Result<(), String> {
        GifWriter::push(self, pm)
    }
    fn frames(&self) -> usize {
        GifWriter::frames(self)
    }
}

impl<W: std::io::Write + std::io::Seek> FrameSink for video::Mp4Writer<W> {
    fn push(&mut self, pm: &Pixmap) -> Result<(), String> {
        video::Mp4Writer::push(self, pm)
    }
    fn frames(&self) -> usize {
        video::Mp4Writer::frames(self)
    }
}

/// Steps `run` to its end (or `max_frames`) and sends one frame of `frame`'s size every
/// `every_ticks` ticks, plus the first and last, to `sink`. Frames show the object's path and the
/// goal radius, as `formica run --out` pictures do. Only the frame being drawn is held.
pub fn record(
    run: &mut formica::experiment::Run,
    opts: &RecordOptions,
    frame: &Frame,
    sink: &mut dyn FrameSink,
) -> Result<RecordSummary, String> {
    let target = run.world.target;
    let mut path: Vec<Vec2> = target
        .map(|t| run.world.object_center(t))
        .into_iter()
        .collect();
    let every = opts.every_ticks.max(1);
    let max_frames = opts.max_frames.max(1);
    let draw_now = |run: &formica::experiment::Run, path: &[Vec2]| {
        let overlay = Overlay {
            path,
            goal_radius: run.goal_radius(),
        };
        let mut pm = draw(&run.world, frame, &overlay);
        if opts.occlusion {
            let zones = occlusion_zones(&run.world, light_sensor_height(&run.world));
            draw_zones(&mut pm, frame, &zones);
        }
        pm
    };
    sink.push(&draw_now(run, &path))?;
    let mut outcome = run.outcome();
    while outcome.is_none() && sink.frames() < max_frames {
        outcome = run.step();
        if let Some(t) = target {
            // The path is thinned as it grows, so that a long run holds a bounded path.
            if path.len() >= 8192 {
                let mut k = 0;
                path.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
            }
            path.push(run.world.object_center(t));
        }
        if outcome.is_some() || run.world.tick.is_multiple_of(every) {
            sink.push(&draw_now(run, &path))?;
        }
    }
    Ok(RecordSummary {
        frames: sink.frames(),
        outcome,
        sim_time_s: run.world.time_s,
        ticks: run.world.tick,
    })
}

/// [`record`] into an animated GIF written to `out`, with frames `opts.width_px` wide.
pub fn record_gif<W: std::io::Write>(
    run: &mut formica::experiment::Run,
    opts: &RecordOptions,
    out: W,
) -> Result<(RecordSummary, W), String> {
    let frame = Frame::fit(&run.world, opts.width_px);
    let mut gif = GifWriter::new(
        out,
        frame.width_px,
        frame.height_px,
        opts.delay_cs,
        opts.hold_cs,
    )?;
    let summary = record(run, opts, &frame, &mut gif)?;
    Ok((summary, gif.finish()?))
}

/// [`record`] into an H.264 MP4 video written to `out` at `fps` frames per second, with frames
/// `opts.width_px` wide (rounded down to even; the height rounded up to even).
pub fn record_mp4<W: std::io::Write + std::io::Seek>(
    run: &mut formica::experiment::Run,
    opts: &RecordOptions,
    fps: u32,
    out: W,
) -> Result<(RecordSummary, W), String> {
    let frame = Frame::fit_even(&run.world, opts.width_px);
    let mut mp4 = video::Mp4Writer::new(
        out,
        frame.width_px,
        frame.height_px,
        fps,
        f32::from(opts.hold_cs) / 100.0,
    )?;
    let summary = record(run, opts, &frame, &mut mp4)?;
    Ok((summary, mp4.finish()?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use formica::experiment::{Run, RunOptions};
    use formica::Scenario;

    const SCENE: &str = r#"
[arena]
size = [3.0, 2.0]
[[lights]]
at = [1.2, 0.0]
height = 0.5
[[objects]]
at = [-0.5, 0.0]
shape = { box = [0.3, 0.3] }
height = 0.3
mass = 5.0
[[robots]]
count = 3
controller = "constant"
params = { left = 0.1, right = 0.1, led = "red" }
placement = { poses = [[-1.0, 0.6, 0.0], [-1.0, -0.6, 0.0], [0.5, 0.5, 90.0]] }
[run]
duration_s = 2
"#;

    fn run() -> Run {
        let sc = Scenario::parse(SCENE, "test.toml").expect("scenario parses");
        Run::new(&sc, &RunOptions::default()).expect("world builds")
    }

    #[test]
    fn gif_has_frames_and_decodes() {
        let mut r = run();
        let opts = RecordOptions {
            width_px: 200,
            every_ticks: 5,
            occlusion: true,
            ..RecordOptions::default()
        };
        let (summary, bytes) = record_gif(&mut r, &opts, Vec::new()).expect("records");
        assert_eq!(summary.outcome, Some(formica::Outcome::Timeout));
        assert_eq!(summary.ticks, 20);
        // First frame, one every 5 ticks (4), the last coincides with tick 20.
        assert_eq!(summary.frames, 5);
        let mut dec = gif::DecodeOptions::new()
            .read_info(bytes.as_slice())
            .expect("valid GIF");
        let mut n = 0;
        while dec.read_next_frame().expect("frame decodes").is_some() {
            n += 1;
        }
        assert_eq!(n, 5);
        assert_eq!(u32::from(dec.width()), 200);
    }

    #[test]
    fn max_frames_cuts_a_run_short() {
        let mut r = run();
        let opts = RecordOptions {
            width_px: 100,
            every_ticks: 1,
            max_frames: 3,
            ..RecordOptions::default()
        };
        let (summary, _) = record_gif(&mut r, &opts, Vec::new()).expect("records");
        assert_eq!(summary.frames, 3);
        assert_eq!(summary.outcome, None);
    }

    #[test]
    fn shadow_lies_behind_the_object() {
        let r = run();
        let zones = occlusion_zones(&r.world, light_sensor_height(&r.world));
        assert!(!zones.is_empty());
        let pts: Vec<Vec2> = zones.iter().flatten().copied().collect();
        // The light is at x = 1.2, the box at x = -0.5: the shadow reaches further left,
        // and not right of the box.
        let min_x = pts.iter().map(|p| p.x).fold(f32::MAX, f32::min);
        let max_x = pts.iter().map(|p| p.x).fold(f32::MIN, f32::max);
        assert!(min_x < -0.7, "shadow reaches {min_x}");
        assert!(max_x <= -0.34, "shadow starts at the box, max x {max_x}");
        for z in &zones {
            assert!(formica::geometry::signed_area(z) >= 0.0);
        }
        // Clipped to the arena (3 x 2 m around the origin).
        assert!(pts
            .iter()
            .all(|p| p.x.abs() <= 1.5001 && p.y.abs() <= 1.0001));
        assert!(
            min_x < -1.49,
            "the 0.3 m box under a 0.5 m light shades to the wall: {min_x}"
        );
    }
}
