//! The motion, seen: every engine's blocks drawn to scale from the trajectories, overlaid (one
//! colour per engine, the reference solid), on a ground that moves when the scene moves it.
//!
//! - [`Animation::player_html`]: an SVG player (time slider, play / pause, speed, the time and
//!   the current rotations) driven by a small inline script, with the frames as compact JSON
//!   (decimated to at most 50 frames per second, positions rounded to 1e-5 of the largest
//!   block dimension, rotations to 1e-5 rad). The page stays self-contained.
//! - [`Animation::strip_svg`]: a static strip of key frames, which reads without scripts.
//! - [`Animation::write_video`]: the same animation as MP4 or GIF through ffmpeg (frames
//!   rasterised here and piped to it as raw RGB).
//!
//! Trajectories are relative to the ground; the ground's displacement comes from the scene's
//! excitation ([`GroundMotion::disp`]), whichever way an engine applied it (inertial forces or
//! a moving ground: the relative motion is the same). When the ground travels further than
//! twice the width of the scene (a pulse leaves it moving), the view follows the ground and
//! its tick marks show the travel.
//!
//! Page parameters (after `#`, joined by `&`): `t=SECONDS` shows that instant, `play` starts
//! playing, `only=ENGINE` draws one engine, `solo` shows the player alone at the top left at
//! its natural size (the rendering test uses these).

use super::esc;
use crate::excitation::GroundMotion;
use crate::scene::Scene;
use crate::trajectory::Trajectory;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// The program that encodes the videos.
const FFMPEG: &str = "ffmpeg";

/// Whether ffmpeg is here: checked before a command runs its engines or reads its runs.
pub fn check_ffmpeg() -> Result<(), String> {
    match std::process::Command::new(FFMPEG).arg("-version").output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(_) => Err(format!("--video: `{FFMPEG} -version` failed")),
        Err(e) => Err(format!(
            "--video: cannot start ffmpeg ({e}); `make ffmpeg` installs Debian's package"
        )),
    }
}

/// Width of the player's drawing, px (its height follows the scene's proportions).
pub const WIDTH: f64 = 800.0;
const MAX_HEIGHT: f64 = 320.0;
const BELOW: f64 = 34.0;
const ABOVE: f64 = 16.0;
/// Colour of the reference engine's (solid) blocks.
pub const REFERENCE_COLOR: &str = "#3a3a3a";

/// One engine's motion.
#[derive(Debug, Clone)]
pub struct Track {
    pub name: String,
    pub color: String,
    pub reference: bool,
    pub trajectory: Trajectory,
}

#[derive(Debug, Clone)]
struct Frames {
    name: String,
    color: String,
    reference: bool,
    /// Per frame, per block: (x, z, phi) relative to the ground.
    states: Vec<Vec<(f64, f64, f64)>>,
}

/// World to drawing: px = ox + s (X - camera), py = oy - s Z.
#[derive(Debug, Clone, Copy)]
pub struct View {
    pub s: f64,
    pub ox: f64,
    pub oy: f64,
    pub height: f64,
    pub follow: bool,
    pub tick: f64,
}

/// An animation ready to draw.
#[derive(Debug, Clone)]
pub struct Animation {
    pub fps: f64,
    pub times: Vec<f64>,
    /// (name, width, height) of each block.
    pub blocks: Vec<(String, f64, f64)>,
    /// Ground displacement (x, z) at each frame.
    pub ground: Vec<(f64, f64)>,
    pub moving_ground: bool,
    tracks: Vec<Frames>,
    pub view: View,
    /// Position quantum of the embedded data, m.
    q: f64,
}

/// Linear interpolation of `y(t)` at `x` (clamped to the ends), with a moving cursor.
fn interp(t: &[f64], y: &[f64], x: f64, cursor: &mut usize) -> f64 {
    if t.is_empty() {
        return 0.0;
    }
    if x <= t[0] {
        return y[0];
    }
    let n = t.len();
    if x >= t[n - 1] {
        return y[n - 1];
    }
    while *cursor + 1 < n && t[*cursor + 1] < x {
        *cursor += 1;
    }
    let (a, b) = (*cursor, (*cursor + 1).min(n - 1));
    if t[b] <= t[a] {
        return y[a];
    }
    let w = (x - t[a]) / (t[b] - t[a]);
    y[a] + w * (y[b] - y[a])
}

/// Vertices of a `w x h` rectangle centred at `(x, z)` rotated by `phi`.
pub fn corners(w: f64, h: f64, x: f64, z: f64, phi: f64) -> [(f64, f64); 4] {
    let (s, c) = phi.sin_cos();
    let (b, hh) = (w / 2.0, h / 2.0);
    [(-b, -hh), (b, -hh), (b, hh), (-b, hh)]
        .map(|(lx, lz)| (x + c * lx - s * lz, z + s * lx + c * lz))
}

fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag)
}

/// The kind of video `path` asks for by its extension: `mp4` or `gif` (checked before any
/// file is written).
pub fn video_kind(path: &Path) -> Result<&'static str, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "mp4" => Ok("mp4"),
        "gif" => Ok("gif"),
        _ => Err(format!(
            "{}: a video is .mp4 or .gif (got `{ext}`)",
            path.display()
        )),
    }
}

/// The page's quantum of length for `scene`: positions are written as whole multiples of it.
fn length_quantum(scene: &Scene) -> f64 {
    scene
        .blocks
        .iter()
        .map(|b| b.width.max(b.height))
        .fold(0.0, f64::max)
        .max(1e-9)
        * 1e-5
}

/// Quantum of the page's angles, rad.
const ANGLE_QUANTUM: f64 = 1e-5;

/// Whether every position and angle of `tr` can be written to the page over `scene`: as whole
/// multiples of the page's quanta that JavaScript holds exactly (below 2^53). A value past that
/// (of some 1e11 block sizes) is no motion the page could draw, and an error naming it.
pub fn check_drawable(scene: &Scene, tr: &crate::trajectory::Trajectory) -> Result<(), String> {
    const EXACT: f64 = 9_007_199_254_740_992.0;
    let q = length_quantum(scene);
    for b in &tr.blocks {
        for (column, values, quantum) in [
            ("x", &b.x, q),
            ("z", &b.z, q),
            ("phi", &b.phi, ANGLE_QUANTUM),
        ] {
            if let Some(k) = values.iter().position(|v| (v / quantum).abs() >= EXACT) {
                return Err(format!(
                    "{}_{column} = {:e} at t = {} s: beyond what the page can draw (|value| < {:e})",
                    b.name,
                    values[k],
                    tr.t[k],
                    EXACT * quantum
                ));
            }
        }
    }
    Ok(())
}

impl Animation {
    /// Frames at up to 50 per second (fewer for long runs or many blocks, at least 10), over
    /// the scene's duration, its end included.
    pub fn new(scene: &Scene, tracks: &[Track]) -> Animation {
        let nb = scene.blocks.len().max(1);
        let nt = tracks.len().max(1);
        let budget = 60_000.0;
        let fps = (budget / (scene.duration.max(1e-3) * (nb * nt) as f64))
            .clamp(10.0, 50.0)
            .floor();
        let n = (scene.duration * fps + 1e-9).floor() as usize + 1;
        let mut times: Vec<f64> = (0..n).map(|k| k as f64 / fps).collect();
        // The run's end is a frame of its own where the rate does not reach it.
        if scene.duration - times[n - 1] > 1e-9 * scene.duration.max(1.0) {
            times.push(scene.duration);
        }
        let gm = GroundMotion::from_scene(scene).unwrap_or_default();
        let moving_ground = !gm.is_none();
        let ground: Vec<(f64, f64)> = times
            .iter()
            .map(|&t| {
                if moving_ground {
                    let (x, z) = gm.disp(t);
                    (
                        if x.is_finite() { x } else { 0.0 },
                        if z.is_finite() { z } else { 0.0 },
                    )
                } else {
                    (0.0, 0.0)
                }
            })
            .collect();
        let frames: Vec<Frames> = tracks
            .iter()
            .map(|tr| {
                let traj = &tr.trajectory;
                let mut cursors = vec![0usize; traj.blocks.len()];
                let states = times
                    .iter()
                    .map(|&t| {
                        traj.blocks
                            .iter()
                            .zip(cursors.iter_mut())
                            .map(|(b, c)| {
                                let mut c2 = *c;
                                let mut c3 = *c;
                                let x = interp(&traj.t, &b.x, t, c);
                                let z = interp(&traj.t, &b.z, t, &mut c2);
                                let phi = interp(&traj.t, &b.phi, t, &mut c3);
                                (x, z, phi)
                            })
                            .collect()
                    })
                    .collect();
                Frames {
                    name: tr.name.clone(),
                    color: tr.color.clone(),
                    reference: tr.reference,
                    states,
                }
            })
            .collect();
        let blocks: Vec<(String, f64, f64)> = scene
            .blocks
            .iter()
            .map(|b| (b.name.clone(), b.width, b.height))
            .collect();
        let largest = blocks
            .iter()
            .map(|b| b.1.max(b.2))
            .fold(0.0, f64::max)
            .max(1e-9);
        // Extents, relative to the ground and absolute.
        let (mut rel, mut abs) = (
            (f64::INFINITY, f64::NEG_INFINITY),
            (f64::INFINITY, f64::NEG_INFINITY),
        );
        let mut top = 0.0f64;
        let layout = scene.layout();
        for (i, b) in blocks.iter().enumerate() {
            let (x, z) = layout.upright[i];
            rel = (rel.0.min(x - b.1 / 2.0), rel.1.max(x + b.1 / 2.0));
            top = top.max(z + b.2 / 2.0);
        }
        for f in &frames {
            for (k, st) in f.states.iter().enumerate() {
                for (i, &(x, z, phi)) in st.iter().enumerate() {
                    let (_, w, h) = &blocks[i.min(blocks.len() - 1)];
                    for (vx, vz) in corners(*w, *h, x, z, phi) {
                        if !(vx.is_finite() && vz.is_finite()) {
                            continue;
                        }
                        rel = (rel.0.min(vx), rel.1.max(vx));
                        abs = (abs.0.min(vx + ground[k].0), abs.1.max(vx + ground[k].0));
                        top = top.max(vz + ground[k].1);
                    }
                }
            }
        }
        if !abs.0.is_finite() {
            abs = rel;
        }
        let scene_width = (rel.1 - rel.0).max(1e-9);
        let follow = abs.1 - abs.0 > 3.0 * scene_width;
        let (lo, hi) = if follow { rel } else { abs };
        // Keep the view from being absurdly wide or tall: at most 6 times the scene's size.
        let (lo, hi) = if hi - lo > 0.0 && hi.is_finite() {
            (lo, hi)
        } else {
            (-1.0, 1.0)
        };
        let width = (hi - lo) * 1.12 + 0.1 * largest;
        let height = top.clamp(1e-9, 6.0 * largest.max(scene_width)) * 1.06;
        let s = ((WIDTH - 20.0) / width).min((MAX_HEIGHT - BELOW - ABOVE) / height);
        let draw_h = (height * s + BELOW + ABOVE).ceil();
        let view = View {
            s,
            ox: WIDTH / 2.0 - s * (lo + hi) / 2.0,
            oy: draw_h - BELOW,
            height: draw_h,
            follow,
            tick: nice_step(width / 12.0),
        };
        Animation {
            fps,
            times,
            blocks,
            ground,
            moving_ground,
            tracks: frames,
            view,
            q: length_quantum(scene),
        }
    }

    pub fn frames(&self) -> usize {
        self.times.len()
    }

    /// Camera position at frame k (m).
    fn camera(&self, k: usize) -> f64 {
        if self.view.follow {
            self.ground[k].0
        } else {
            0.0
        }
    }

    /// Drawing coordinates of a world point (absolute) at frame k.
    pub fn to_px(&self, k: usize, x: f64, z: f64) -> (f64, f64) {
        (
            self.view.ox + self.view.s * (x - self.camera(k)),
            self.view.oy - self.view.s * z,
        )
    }

    /// Where block `i` of track `track` is drawn at frame k: its corners, px.
    pub fn block_px(&self, track: usize, k: usize, i: usize) -> [(f64, f64); 4] {
        let (x, z, phi) = self.tracks[track].states[k][i];
        let (_, w, h) = &self.blocks[i];
        let (gx, gz) = self.ground[k];
        corners(*w, *h, x + gx, z + gz, phi).map(|(a, b)| self.to_px(k, a, b))
    }

    pub fn track_names(&self) -> Vec<String> {
        self.tracks.iter().map(|t| t.name.clone()).collect()
    }

    /// Frame index nearest to time t.
    pub fn frame_at(&self, t: f64) -> usize {
        let last = self.frames() - 1;
        if t >= self.times[last] {
            return last;
        }
        ((t * self.fps).round().max(0.0) as usize).min(last)
    }

    /// The SVG elements of frame k: ground, ticks, blocks (reference first, solid).
    fn frame_elements(&self, k: usize, ids: bool) -> String {
        let v = &self.view;
        let mut s = String::new();
        let (gx, gz) = self.ground[k];
        let gy = v.oy - v.s * gz;
        let _ = write!(
            s,
            "<rect{} x=\"0\" y=\"{:.1}\" width=\"{WIDTH}\" height=\"{:.1}\" fill=\"#e9e1cf\"/>",
            if ids { " id=\"a-ground\"" } else { "" },
            gy,
            (v.height - gy).max(0.0) + 400.0
        );
        s.push_str(&self.ticks(k, ids));
        let mut order: Vec<usize> = (0..self.tracks.len()).collect();
        order.sort_by_key(|&t| !self.tracks[t].reference);
        for t in order {
            let tr = &self.tracks[t];
            let _ = write!(
                s,
                "<g data-engine=\"{}\"{}>",
                esc(&tr.name),
                if ids {
                    format!(" id=\"a-track-{t}\"")
                } else {
                    String::new()
                }
            );
            for i in 0..self.blocks.len() {
                let pts: Vec<String> = self
                    .block_px(t, k, i)
                    .iter()
                    .map(|(a, b)| format!("{a:.1},{b:.1}"))
                    .collect();
                let style = if tr.reference {
                    format!(
                        "fill=\"{REFERENCE_COLOR}\" stroke=\"{REFERENCE_COLOR}\" stroke-width=\"0.5\""
                    )
                } else {
                    format!(
                        "fill=\"none\" stroke=\"{}\" stroke-width=\"2\" stroke-linejoin=\"round\"",
                        tr.color
                    )
                };
                let _ = write!(
                    s,
                    "<polygon{} points=\"{}\" {style}/>",
                    if ids {
                        format!(" id=\"a-{t}-{i}\"")
                    } else {
                        String::new()
                    },
                    pts.join(" ")
                );
            }
            s.push_str("</g>");
        }
        let _ = gx;
        s
    }

    /// Tick marks fixed to the ground (they travel with it).
    fn ticks(&self, k: usize, ids: bool) -> String {
        let v = &self.view;
        let (gx, gz) = self.ground[k];
        let gy = v.oy - v.s * gz;
        let cam = self.camera(k);
        // World x range visible.
        let x0 = (0.0 - v.ox) / v.s + cam;
        let x1 = (WIDTH - v.ox) / v.s + cam;
        let mut s = format!(
            "<g{} stroke=\"#8a7a5a\" stroke-width=\"1\">",
            if ids { " id=\"a-ticks\"" } else { "" }
        );
        let first = ((x0 - gx) / v.tick).floor() as i64;
        let last = ((x1 - gx) / v.tick).ceil() as i64;
        for j in first..=last.min(first + 400) {
            let px = v.ox + v.s * (j as f64 * v.tick + gx - cam);
            let _ = write!(
                s,
                "<line x1=\"{px:.1}\" y1=\"{gy:.1}\" x2=\"{:.1}\" y2=\"{:.1}\"/>",
                px - 6.0,
                gy + 8.0
            );
        }
        s.push_str("</g>");
        s
    }

    /// The compact data the script animates.
    fn data_json(&self) -> String {
        let mut s = format!(
            "{{\"fps\":{},\"n\":{},\"te\":{},\"q\":{:e},\"qa\":{ANGLE_QUANTUM:e},\"s\":{},\"ox\":{},\"oy\":{},\"follow\":{},\"tick\":{},\"width\":{WIDTH},\"blocks\":[",
            self.fps,
            self.frames(),
            self.times.last().copied().unwrap_or(0.0),
            self.q,
            self.view.s,
            self.view.ox,
            self.view.oy,
            self.view.follow,
            self.view.tick
        );
        for (k, (name, w, h)) in self.blocks.iter().enumerate() {
            let _ = write!(
                s,
                "{}[{},{w},{h}]",
                if k > 0 { "," } else { "" },
                serde_json::to_string(name).unwrap_or_default()
            );
        }
        s.push_str("],\"g\":");
        if self.moving_ground {
            s.push('[');
            for (k, (x, z)) in self.ground.iter().enumerate() {
                let _ = write!(
                    s,
                    "{}{},{}",
                    if k > 0 { "," } else { "" },
                    (x / self.q).round() as i64,
                    (z / self.q).round() as i64
                );
            }
            s.push(']');
        } else {
            s.push_str("null");
        }
        s.push_str(",\"tracks\":[");
        for (ti, tr) in self.tracks.iter().enumerate() {
            let _ = write!(
                s,
                "{}{{\"name\":{},\"color\":\"{}\",\"ref\":{},\"d\":[",
                if ti > 0 { "," } else { "" },
                serde_json::to_string(&tr.name).unwrap_or_default(),
                tr.color,
                tr.reference
            );
            let mut first = true;
            for st in &tr.states {
                for &(x, z, phi) in st {
                    let qi = |v: f64, q: f64| -> i64 {
                        if v.is_finite() {
                            (v / q).round() as i64
                        } else {
                            0
                        }
                    };
                    let _ = write!(
                        s,
                        "{}{},{},{}",
                        if first { "" } else { "," },
                        qi(x, self.q),
                        qi(z, self.q),
                        qi(phi, ANGLE_QUANTUM)
                    );
                    first = false;
                }
            }
            s.push_str("]}");
        }
        s.push_str("]}");
        s
    }

    fn legend_html(&self) -> String {
        let mut s = String::from("<div class=\"anim-legend\">");
        for tr in &self.tracks {
            if tr.reference {
                let _ = write!(
                    s,
                    "<span><i style=\"background:{REFERENCE_COLOR}\"></i>{} (reference, solid)</span>",
                    esc(&tr.name)
                );
            } else {
                let _ = write!(
                    s,
                    "<span><i style=\"border:2px solid {};background:none\"></i>{}</span>",
                    tr.color,
                    esc(&tr.name)
                );
            }
        }
        if self.moving_ground {
            s.push_str(if self.view.follow {
                "<span>the ground moves (the view follows it; its tick marks travel)</span>"
            } else {
                "<span>the ground moves (shaded; its tick marks travel with it)</span>"
            });
        }
        s.push_str("</div>");
        s
    }

    /// The player: an SVG at t = 0 (what shows without scripts), its controls and the script.
    pub fn player_html(&self) -> String {
        let v = &self.view;
        let mut s = String::new();
        let _ = write!(
            s,
            "<div id=\"anim\" class=\"anim\"><svg id=\"anim-svg\" xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{h}\" viewBox=\"0 0 {WIDTH} {h}\" data-s=\"{}\" data-ox=\"{}\" data-oy=\"{}\" data-fps=\"{}\" data-follow=\"{}\"><rect width=\"{WIDTH}\" height=\"{h}\" fill=\"#fbfbfd\"/>{}</svg>",
            v.s,
            v.ox,
            v.oy,
            self.fps,
            v.follow,
            self.frame_elements(0, true),
            h = v.height
        );
        s.push_str(&self.legend_html());
        let _ = write!(
            s,
            "<div id=\"anim-controls\" hidden><button id=\"anim-play\" type=\"button\">▶ play</button> \
             <input id=\"anim-slider\" type=\"range\" min=\"0\" max=\"{}\" value=\"0\" step=\"1\" aria-label=\"time\"> \
             <label>speed <select id=\"anim-speed\"><option value=\"0.1\">0.1×</option><option value=\"0.25\">0.25×</option><option value=\"0.5\">0.5×</option><option value=\"1\" selected>1×</option><option value=\"2\">2×</option><option value=\"4\">4×</option></select></label> \
             <output id=\"anim-time\">t = 0.000 s</output></div><div id=\"anim-readout\"></div>",
            self.frames() - 1
        );
        let _ = writeln!(
            s,
            "<script type=\"application/json\" id=\"anim-data\">{}</script><script>{}</script></div>",
            self.data_json(),
            SCRIPT
        );
        s
    }

    /// A static strip of key frames (six instants, every engine overlaid), readable without
    /// scripts.
    pub fn strip_svg(&self) -> String {
        let n = 6usize;
        let v = &self.view;
        let cell_w = 250.0;
        let sc = cell_w / WIDTH;
        let cell_h = v.height * sc;
        let cols = 3usize;
        let rows = n.div_ceil(cols);
        let w = cell_w * cols as f64 + 10.0 * (cols as f64 - 1.0);
        let h = (cell_h + 22.0) * rows as f64;
        let mut s = format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w:.0}\" height=\"{h:.0}\" viewBox=\"0 0 {w:.0} {h:.0}\" font-family=\"Helvetica,Arial,sans-serif\" font-size=\"12\" role=\"img\" aria-label=\"key frames of the motion\">"
        );
        for j in 0..n {
            let t = self.times.last().copied().unwrap_or(0.0) * j as f64 / (n - 1) as f64;
            let k = self.frame_at(t);
            let (cx, cy) = (
                (j % cols) as f64 * (cell_w + 10.0),
                (j / cols) as f64 * (cell_h + 22.0),
            );
            let _ = write!(
                s,
                "<text x=\"{:.1}\" y=\"{:.1}\">t = {:.3} s</text><g transform=\"translate({cx:.1},{:.1}) scale({sc:.5})\"><rect width=\"{WIDTH}\" height=\"{}\" fill=\"#fbfbfd\" stroke=\"#ccc\"/>{}</g>",
                cx + 2.0,
                cy + 14.0,
                self.times[k],
                cy + 18.0,
                v.height,
                self.frame_elements(k, false)
            );
        }
        s.push_str("</svg>");
        s
    }

    /// Rasterise every frame (at `fps`, at most the animation's rate) and encode with ffmpeg:
    /// MP4 (H.264) or GIF, by the extension of `path`. The reference is solid, the engines are
    /// outlined in their colours; a bar along the bottom shows the time. Once `stopped` answers
    /// true (asked before each frame) ffmpeg is killed, the file removed and an error returned.
    pub fn write_video(&self, path: &Path, stopped: &dyn Fn() -> bool) -> Result<(), String> {
        let ext = video_kind(path)?;
        let codec: Vec<&str> = match ext {
            "mp4" => vec![
                "-c:v",
                "libx264",
                "-pix_fmt",
                "yuv420p",
                "-movflags",
                "+faststart",
            ],
            "gif" => vec![
                "-vf",
                "split[a][b];[a]palettegen=max_colors=64[p];[b][p]paletteuse",
            ],
            _ => unreachable!("video_kind gives mp4 or gif"),
        };
        let vfps = self.fps.min(if ext == "gif" { 20.0 } else { 25.0 });
        let scale = 640.0 / WIDTH;
        let (w, h) = (
            640usize,
            ((self.view.height * scale / 2.0).ceil() as usize * 2).max(2),
        );
        let duration = self.times.last().copied().unwrap_or(0.0);
        let whole = (duration * vfps + 1e-9).floor() as usize + 1;
        // The run's end gets a frame of its own where the video's rate does not reach it.
        let video_times: Vec<f64> = (0..whole)
            .map(|f| f as f64 / vfps)
            .chain(
                (duration - (whole - 1) as f64 / vfps > 1e-9 * duration.max(1.0))
                    .then_some(duration),
            )
            .collect();
        let mut child = std::process::Command::new(FFMPEG)
            .args([
                "-y",
                "-loglevel",
                "error",
                "-f",
                "rawvideo",
                "-pix_fmt",
                "rgb24",
            ])
            .args([
                "-s",
                &format!("{w}x{h}"),
                "-r",
                &format!("{vfps}"),
                "-i",
                "-",
            ])
            .args(&codec)
            .arg(path)
            .stdin(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .map_err(|e| {
                format!(
                    "--video: cannot start ffmpeg ({e}); `make ffmpeg` installs Debian's package"
                )
            })?;
        let mut stdin = child.stdin.take().expect("piped stdin");
        // An ffmpeg that stops early closes the pipe: a write error here, not a SIGPIPE that
        // would end rockbench without a word (the binary restores SIGPIPE's default).
        let _ignore_sigpipe = IgnoreSigpipe::new();
        let mut buf = vec![0u8; w * h * 3];
        for &t in &video_times {
            if stopped() {
                drop(stdin);
                let _ = child.kill();
                let _ = child.wait();
                let _ = std::fs::remove_file(path);
                return Err(format!("--video: {} not written: stopped", path.display()));
            }
            let k = self.frame_at(t);
            self.rasterise(k, scale, w, h, &mut buf);
            // Time bar.
            let bw = ((w as f64) * self.times[k] / duration.max(1e-9)) as usize;
            for y in h.saturating_sub(4)..h {
                for x in 0..bw.min(w) {
                    let p = 3 * (y * w + x);
                    buf[p..p + 3].copy_from_slice(&[0x1f, 0x77, 0xb4]);
                }
            }
            if stdin.write_all(&buf).is_err() {
                break;
            }
        }
        drop(stdin);
        let out = child
            .wait_with_output()
            .map_err(|e| format!("--video: ffmpeg: {e}"))?;
        if !out.status.success() {
            // Nothing half-written (an ffmpeg stopped by the terminal's Ctrl-C, or failed).
            let _ = std::fs::remove_file(path);
            return Err(format!(
                "--video: ffmpeg failed writing {}: {}",
                path.display(),
                String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .next()
                    .unwrap_or("")
            ));
        }
        Ok(())
    }

    fn rasterise(&self, k: usize, scale: f64, w: usize, h: usize, buf: &mut [u8]) {
        buf.fill(0xfb);
        let v = &self.view;
        let gy = ((v.oy - v.s * self.ground[k].1) * scale).max(0.0);
        for y in (gy.round() as usize).min(h)..h {
            for x in 0..w {
                let p = 3 * (y * w + x);
                buf[p..p + 3].copy_from_slice(&[0xe9, 0xe1, 0xcf]);
            }
        }
        // Ticks travelling with the ground.
        let cam = self.camera(k);
        let gx = self.ground[k].0;
        let x0 = -v.ox / v.s + cam;
        let first = ((x0 - gx) / v.tick).floor() as i64;
        for j in first..first + 400 {
            let px = (v.ox + v.s * (j as f64 * v.tick + gx - cam)) * scale;
            if px > w as f64 + 10.0 {
                break;
            }
            fill_quad(
                buf,
                w,
                h,
                &[
                    (px, gy),
                    (px + 1.2, gy),
                    (px - 4.0, gy + 6.0),
                    (px - 5.2, gy + 6.0),
                ],
                [0x8a, 0x7a, 0x5a],
            );
        }
        let mut order: Vec<usize> = (0..self.tracks.len()).collect();
        order.sort_by_key(|&t| !self.tracks[t].reference);
        for t in order {
            let tr = &self.tracks[t];
            let rgb = if tr.reference {
                hex(REFERENCE_COLOR)
            } else {
                hex(&tr.color)
            };
            for i in 0..self.blocks.len() {
                let c = self.block_px(t, k, i).map(|(a, b)| (a * scale, b * scale));
                if tr.reference {
                    fill_quad(buf, w, h, &c, rgb);
                } else {
                    for e in 0..4 {
                        let (p, q) = (c[e], c[(e + 1) % 4]);
                        let (dx, dy) = (q.0 - p.0, q.1 - p.1);
                        let len = dx.hypot(dy).max(1e-9);
                        let (nx, ny) = (-dy / len, dx / len);
                        fill_quad(
                            buf,
                            w,
                            h,
                            &[
                                (p.0 - nx, p.1 - ny),
                                (q.0 - nx, q.1 - ny),
                                (q.0 + nx, q.1 + ny),
                                (p.0 + nx, p.1 + ny),
                            ],
                            rgb,
                        );
                    }
                }
            }
        }
    }
}

fn hex(c: &str) -> [u8; 3] {
    let c = c.trim_start_matches('#');
    let p = |i: usize| u8::from_str_radix(c.get(i..i + 2).unwrap_or("00"), 16).unwrap_or(0);
    [p(0), p(2), p(4)]
}

/// Fill a convex quadrilateral (pixel centres inside all four edges, either orientation).
fn fill_quad(buf: &mut [u8], w: usize, h: usize, q: &[(f64, f64); 4], rgb: [u8; 3]) {
    if q.iter().any(|p| !(p.0.is_finite() && p.1.is_finite())) {
        return;
    }
    let xmin = q
        .iter()
        .map(|p| p.0)
        .fold(f64::INFINITY, f64::min)
        .floor()
        .max(0.0) as usize;
    let xmax = q
        .iter()
        .map(|p| p.0)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil()
        .min(w as f64) as usize;
    let ymin = q
        .iter()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min)
        .floor()
        .max(0.0) as usize;
    let ymax = q
        .iter()
        .map(|p| p.1)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil()
        .min(h as f64) as usize;
    let area: f64 = (0..4)
        .map(|e| q[e].0 * q[(e + 1) % 4].1 - q[(e + 1) % 4].0 * q[e].1)
        .sum();
    let sign = if area >= 0.0 { 1.0 } else { -1.0 };
    for y in ymin..ymax {
        for x in xmin..xmax {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let inside = (0..4).all(|e| {
                let (a, b) = (q[e], q[(e + 1) % 4]);
                sign * ((b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0)) >= 0.0
            });
            if inside {
                let p = 3 * (y * w + x);
                buf[p..p + 3].copy_from_slice(&rgb);
            }
        }
    }
}

/// Write a stand-alone page with the player and the key frames (`rockbench animate`).
pub fn page(title: &str, intro: &str, anim: &Animation) -> String {
    format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title><style>{}{}</style></head><body>\n<h1>{t}</h1>\n<p>{}</p>\n{}<h2>Key frames</h2>\n<figure>{}</figure>\n</body></html>\n",
        super::CSS,
        CSS,
        esc(intro),
        anim.player_html(),
        anim.strip_svg(),
        t = esc(title)
    )
}

/// Styles of the player (the `solo` class shows it alone, at its natural size, top left).
pub const CSS: &str = ".anim svg{max-width:100%;height:auto;border:1px solid #ddd}\
#anim-controls{margin:0.3em 0;font-size:0.9em}#anim-slider{width:420px;vertical-align:middle}\
#anim-readout{font-size:0.82em;color:#333;min-height:1.2em}.anim-legend span{margin-right:14px;font-size:0.85em}\
.anim-legend i{display:inline-block;width:14px;height:10px;margin-right:4px;vertical-align:middle}\
body.solo{margin:0;padding:0;max-width:none}body.solo>*:not(#anim){display:none}\
body.solo #anim svg{border:0;max-width:none;width:800px;display:block}";

/// The player's script: reads the JSON, sets the polygons of each frame, runs the controls.
const SCRIPT: &str = r#"(function(){
var errs=[];window.addEventListener('error',function(e){errs.push(String(e.message));document.body.setAttribute('data-anim-errors',errs.join(' | '));});
var D=JSON.parse(document.getElementById('anim-data').textContent);
var svg=document.getElementById('anim-svg'),sl=document.getElementById('anim-slider'),btn=document.getElementById('anim-play'),sp=document.getElementById('anim-speed'),out=document.getElementById('anim-time'),ro=document.getElementById('anim-readout'),ticks=document.getElementById('a-ticks'),gr=document.getElementById('a-ground');
var nb=D.blocks.length,k=0,playing=false,timer=null,t=0;
function cam(f){return (D.follow&&D.g)?D.g[2*f]*D.q:0;}
function gnd(f){return D.g?[D.g[2*f]*D.q,D.g[2*f+1]*D.q]:[0,0];}
function px(f,x,z){return [D.ox+D.s*(x-cam(f)),D.oy-D.s*z];}
function tof(f){return f>=D.n-1?D.te:f/D.fps;}
function fat(t){return t>=D.te?D.n-1:Math.min(D.n-1,Math.round(t*D.fps));}
function draw(f){
 k=f;var g=gnd(f),c=cam(f),gy=D.oy-D.s*g[1];
 gr.setAttribute('y',gy.toFixed(1));
 var x0=-D.ox/D.s+c,x1=(D.width-D.ox)/D.s+c,j0=Math.floor((x0-g[0])/D.tick),j1=Math.ceil((x1-g[0])/D.tick),h='';
 for(var j=j0;j<=Math.min(j1,j0+400);j++){var p=D.ox+D.s*(j*D.tick+g[0]-c);h+='<line x1="'+p.toFixed(1)+'" y1="'+gy.toFixed(1)+'" x2="'+(p-6).toFixed(1)+'" y2="'+(gy+8).toFixed(1)+'"/>';}
 ticks.innerHTML=h;
 var txt=[];
 D.tracks.forEach(function(tr,ti){
  var rot=[];
  for(var i=0;i<nb;i++){
   var o=3*(f*nb+i),x=tr.d[o]*D.q+g[0],z=tr.d[o+1]*D.q+g[1],a=tr.d[o+2]*D.qa,w=D.blocks[i][1]/2,hh=D.blocks[i][2]/2,s=Math.sin(a),co=Math.cos(a),pts=[];
   [[-w,-hh],[w,-hh],[w,hh],[-w,hh]].forEach(function(v){var q=px(f,x+co*v[0]-s*v[1],z+s*v[0]+co*v[1]);pts.push(q[0].toFixed(1)+','+q[1].toFixed(1));});
   document.getElementById('a-'+ti+'-'+i).setAttribute('points',pts.join(' '));
   if(i<3)rot.push(D.blocks[i][0]+' '+a.toFixed(4));
  }
  if(nb>3){var m=0;for(var i=0;i<nb;i++)m=Math.max(m,Math.abs(tr.d[3*(f*nb+i)+2]*D.qa));rot.push('max |φ| '+m.toFixed(4));}
  txt.push('<b style="color:'+(tr.ref?'#3a3a3a':tr.color)+'">'+tr.name.replace(/[<&]/g,'')+'</b> φ (rad): '+rot.join(', '));
 });
 out.textContent='t = '+tof(f).toFixed(3)+' s';
 ro.innerHTML=txt.join(' · ');
 sl.value=f;
}
function stop(){playing=false;btn.textContent='▶ play';if(timer){clearInterval(timer);timer=null;}}
function play(){if(k>=D.n-1){t=0;}playing=true;btn.textContent='❚❚ pause';var dt=1/Math.min(D.fps,30);timer=setInterval(function(){t+=dt*parseFloat(sp.value);var f=fat(t);draw(f);if(f>=D.n-1)stop();},1000*dt);}
btn.addEventListener('click',function(){playing?stop():play();});
sl.addEventListener('input',function(){stop();t=tof(parseInt(sl.value,10));draw(parseInt(sl.value,10));});
document.getElementById('anim-controls').hidden=false;
var P={};location.hash.replace(/^#/,'').split('&').forEach(function(p){if(!p)return;var kv=p.split('=');P[decodeURIComponent(kv[0])]=kv.length>1?decodeURIComponent(kv[1]):'';});
if('solo' in P)document.body.classList.add('solo');
if('only' in P)D.tracks.forEach(function(tr,ti){if(tr.name!==P.only)document.getElementById('a-track-'+ti).setAttribute('display','none');});
if('t' in P){t=parseFloat(P.t)||0;}
draw(fat(Math.max(0,t)));
if('play' in P)play();
document.body.setAttribute('data-anim-ready','1');
})();"#;

/// SIGPIPE ignored while it lives; the previous disposition restored when dropped.
struct IgnoreSigpipe(libc::sighandler_t);

impl IgnoreSigpipe {
    fn new() -> Self {
        // SAFETY: `signal` only swaps the process's disposition of SIGPIPE.
        IgnoreSigpipe(unsafe { libc::signal(libc::SIGPIPE, libc::SIG_IGN) })
    }
}

impl Drop for IgnoreSigpipe {
    fn drop(&mut self) {
        // SAFETY: as above, restoring the disposition `new` replaced.
        unsafe {
            libc::signal(libc::SIGPIPE, self.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::parse_scene_str;

    fn slender() -> (Scene, Trajectory) {
        let scene = parse_scene_str(
            "name = \"s\"\nduration = 2.0\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[initial]\ntilt = 0.15\n",
            false,
            "s.toml",
            &[],
        )
        .unwrap();
        let out = crate::engines::engine_by_name("housner")
            .unwrap()
            .run(&scene)
            .unwrap();
        (scene, out.trajectory)
    }

    #[test]
    fn frames_follow_the_trajectory_and_the_page_is_compact() {
        let (scene, tr) = slender();
        let a = Animation::new(
            &scene,
            &[Track {
                name: "housner".into(),
                color: "#000".into(),
                reference: true,
                trajectory: tr.clone(),
            }],
        );
        assert_eq!(a.fps, 50.0);
        assert_eq!(a.frames(), 101);
        // Frame 25 is t = 0.5 s: the block's corners where the trajectory puts them.
        let k = tr.t.iter().position(|&t| (t - 0.5).abs() < 1e-9).unwrap();
        let b = &tr.blocks[0];
        let want = corners(1.0, 2.5, b.x[k], b.z[k], b.phi[k]);
        let got = a.block_px(0, 25, 0);
        for (w, g) in want.iter().zip(got) {
            let p = a.to_px(25, w.0, w.1);
            assert!((p.0 - g.0).abs() < 1e-9 && (p.1 - g.1).abs() < 1e-9);
        }
        // The block stands on the ground line: its lowest corner at oy (within a pixel).
        let low = got.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
        assert!((low - a.view.oy).abs() < 1.0, "{low} vs {}", a.view.oy);
        let html = a.player_html();
        assert!(html.len() < 20_000, "{} bytes", html.len());
        assert!(html.contains("id=\"a-0-0\""));
        let strip = a.strip_svg();
        assert_eq!(strip.matches("t = ").count(), 6);
        assert!(strip.contains("t = 2.000 s"));
    }

    #[test]
    fn the_ground_moves_with_the_excitation() {
        let scene = parse_scene_str(
            "name = \"p\"\nduration = 1.0\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[excitation.horizontal]\nkind = \"one-sine\"\namplitude = 2.0\nperiod = 0.5\n",
            false,
            "p.toml",
            &[],
        )
        .unwrap();
        let out = crate::engines::engine_by_name("native")
            .unwrap()
            .run(&scene)
            .unwrap();
        let a = Animation::new(
            &scene,
            &[Track {
                name: "native".into(),
                color: "#1f77b4".into(),
                reference: true,
                trajectory: out.trajectory,
            }],
        );
        assert!(a.moving_ground);
        // One-sine acceleration: the ground ends displaced by A T^2 / (2 pi) to +x.
        let (gx, _) = a.ground[a.frame_at(0.5)];
        let want = 2.0 * 0.5 * 0.5 / (2.0 * std::f64::consts::PI);
        assert!((gx - want).abs() < 1e-6, "{gx} vs {want}");
        // The block is drawn carried by the ground.
        let c0 = a.block_px(0, 0, 0);
        let c1 = a.block_px(0, a.frame_at(0.5), 0);
        assert!((c1[0].0 - c0[0].0 - a.view.s * want).abs() < 0.5);
    }

    /// A position the page cannot hold exactly (here 1e30 m, past 2^53 quanta of 2.5e-5 m) is an
    /// error naming the block, the column and the instant; one just inside is drawn.
    #[test]
    fn a_position_past_the_pages_quanta_is_refused() {
        let (scene, mut tr) = slender();
        assert!(check_drawable(&scene, &tr).is_ok());
        let limit = 9_007_199_254_740_992.0 * 2.5 * 1e-5;
        tr.blocks[0].x[7] = 0.999 * limit;
        assert!(check_drawable(&scene, &tr).is_ok());
        tr.blocks[0].x[7] = 1e30;
        let e = check_drawable(&scene, &tr).unwrap_err();
        assert!(
            e.starts_with(&format!("block_x = 1e30 at t = {} s", tr.t[7])),
            "{e}"
        );
        tr.blocks[0].x[7] = 0.0;
        tr.blocks[0].phi[3] = -1e12;
        let e = check_drawable(&scene, &tr).unwrap_err();
        assert!(e.starts_with("block_phi = -1e12"), "{e}");
    }

    /// The run's end is the last frame where the frame rate does not reach it.
    #[test]
    fn the_runs_end_is_a_frame() {
        let (mut scene, tr) = slender();
        scene.duration = 1.013;
        let a = Animation::new(
            &scene,
            &[Track {
                name: "h".into(),
                color: REFERENCE_COLOR.into(),
                reference: true,
                trajectory: tr,
            }],
        );
        assert_eq!(a.fps, 50.0);
        assert_eq!(a.frames(), 52);
        assert_eq!(a.times[50], 1.0);
        assert_eq!(a.times[51], 1.013);
        assert_eq!(a.frame_at(1.013), 51);
        assert_eq!(a.frame_at(2.0), 51);
        assert_eq!(a.frame_at(0.99), 50);
    }
}
