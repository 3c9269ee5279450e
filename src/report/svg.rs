//! Line plots as self-contained SVG (no scripts, no fonts fetched, no external files).

use std::fmt::Write;

/// One curve.
#[derive(Debug, Clone)]
pub struct Curve {
    pub name: String,
    pub color: String,
    pub dashed: bool,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
}

/// A marker (an impact) drawn as a small circle.
#[derive(Debug, Clone)]
pub struct Marker {
    pub x: f64,
    pub y: f64,
    pub color: String,
}

/// A plot: curves, markers, axis labels (with units), title and legend.
#[derive(Debug, Clone, Default)]
pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub curves: Vec<Curve>,
    pub markers: Vec<Marker>,
    /// Legend entry for the markers, if any.
    pub marker_label: Option<String>,
}

const W: f64 = 860.0;
const H: f64 = 330.0;
const LEFT: f64 = 78.0;
const RIGHT: f64 = 16.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 50.0;

/// "Nice" tick positions covering `[lo, hi]`.
pub fn ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    if !lo.is_finite() || !hi.is_finite() || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil();
    let mut out = Vec::new();
    let mut k = first;
    while k * step <= hi + 1e-9 * step {
        let v = k * step;
        out.push(if v.abs() < 1e-12 * step { 0.0 } else { v });
        k += 1.0;
    }
    out
}

fn fmt_tick(v: f64, step: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e4).contains(&a) {
        return format!("{v:.1e}");
    }
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
            + usize::from(step * 10f64.powf(-step.log10().floor()) % 1.0 > 1e-6)
    };
    format!("{v:.decimals$}")
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// At most about `2 * buckets` points, keeping each bucket's min and max (so peaks survive).
pub fn decimate(x: &[f64], y: &[f64], buckets: usize) -> (Vec<f64>, Vec<f64>) {
    let n = x.len().min(y.len());
    if n <= 2 * buckets || buckets == 0 {
        return (x[..n].to_vec(), y[..n].to_vec());
    }
    let size = n.div_ceil(buckets);
    let (mut ox, mut oy) = (Vec::new(), Vec::new());
    for start in (0..n).step_by(size) {
        let end = (start + size).min(n);
        let (mut imin, mut imax) = (start, start);
        for k in start..end {
            if y[k] < y[imin] {
                imin = k;
            }
            if y[k] > y[imax] {
                imax = k;
            }
        }
        for k in if imin <= imax {
            [imin, imax]
        } else {
            [imax, imin]
        } {
            if ox.last() != Some(&x[k]) {
                ox.push(x[k]);
                oy.push(y[k]);
            }
        }
    }
    (ox, oy)
}

impl Plot {
    /// Render to an `<svg>` element.
    pub fn render(&self) -> String {
        let finite = |v: &&f64| v.is_finite();
        let xs = self.curves.iter().flat_map(|c| c.x.iter()).filter(finite);
        let (mut x0, mut x1) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
        let ys = self
            .curves
            .iter()
            .flat_map(|c| c.y.iter())
            .chain(self.markers.iter().map(|m| &m.y))
            .filter(finite);
        let (mut y0, mut y1) = ys.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
        if !x0.is_finite() {
            (x0, x1) = (0.0, 1.0);
        }
        if !y0.is_finite() {
            (y0, y1) = (-1.0, 1.0);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if y1 <= y0 {
            let d = if y0 == 0.0 { 1e-6 } else { y0.abs() * 0.1 };
            y0 -= d;
            y1 += d;
        }
        let pad = 0.05 * (y1 - y0);
        y0 -= pad;
        y1 += pad;
        let (pw, ph) = (W - LEFT - RIGHT, H - TOP - BOTTOM);
        let sx = |x: f64| LEFT + (x - x0) / (x1 - x0) * pw;
        let sy = |y: f64| TOP + (y1 - y) / (y1 - y0) * ph;
        let mut s = String::new();
        let _ = write!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {H}" width="{W}" height="{H}" role="img" font-family="Helvetica, Arial, sans-serif" font-size="12"><title>{}</title>"#,
            esc(&self.title)
        );
        let _ = write!(
            s,
            r##"<rect x="0" y="0" width="{W}" height="{H}" fill="#ffffff"/><text x="{}" y="20" text-anchor="middle" font-size="14" font-weight="bold">{}</text>"##,
            W / 2.0,
            esc(&self.title)
        );
        // Grid and ticks.
        let xt = ticks(x0, x1, 10);
        let xstep = if xt.len() > 1 { xt[1] - xt[0] } else { 1.0 };
        for v in &xt {
            let px = sx(*v);
            let _ = write!(
                s,
                r##"<line x1="{px:.1}" y1="{TOP}" x2="{px:.1}" y2="{:.1}" stroke="#e3e3e3"/><text x="{px:.1}" y="{:.1}" text-anchor="middle">{}</text>"##,
                TOP + ph,
                TOP + ph + 16.0,
                fmt_tick(*v, xstep)
            );
        }
        let yt = ticks(y0, y1, 6);
        let ystep = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
        for v in &yt {
            let py = sy(*v);
            let _ = write!(
                s,
                r##"<line x1="{LEFT}" y1="{py:.1}" x2="{:.1}" y2="{py:.1}" stroke="{}"/><text x="{:.1}" y="{:.1}" text-anchor="end">{}</text>"##,
                LEFT + pw,
                if *v == 0.0 { "#9a9a9a" } else { "#e3e3e3" },
                LEFT - 6.0,
                py + 4.0,
                fmt_tick(*v, ystep)
            );
        }
        let _ = write!(
            s,
            r##"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="#444"/>"##
        );
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            LEFT + pw / 2.0,
            H - 10.0,
            esc(&self.x_label)
        );
        let _ = write!(
            s,
            r#"<text transform="translate(16 {:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            TOP + ph / 2.0,
            esc(&self.y_label)
        );
        // Curves: each one's decimated finite points, in pixels (drawn, and kept out of the
        // legend's way below).
        let pixels: Vec<Vec<(f64, f64)>> = self
            .curves
            .iter()
            .map(|c| {
                let (dx, dy) = decimate(&c.x, &c.y, 1200);
                dx.iter()
                    .zip(&dy)
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| (sx(*x), sy(*y)))
                    .collect()
            })
            .collect();
        for (c, curve_pixels) in self.curves.iter().zip(&pixels) {
            let mut pts = String::new();
            for (px, py) in curve_pixels {
                let _ = write!(pts, "{px:.1},{py:.1} ");
            }
            let _ = write!(
                s,
                r#"<polyline fill="none" stroke="{}" stroke-width="1.4"{} points="{}"/>"#,
                c.color,
                if c.dashed {
                    r#" stroke-dasharray="6 3""#
                } else {
                    ""
                },
                pts.trim_end()
            );
        }
        for m in &self.markers {
            if m.x.is_finite() && m.y.is_finite() {
                let _ = write!(
                    s,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="none" stroke="{}" stroke-width="1.2"/>"#,
                    sx(m.x),
                    sy(m.y),
                    m.color
                );
            }
        }
        // Legend (top right, inside the frame).
        let mut entries: Vec<(String, String, bool, bool)> = self
            .curves
            .iter()
            .map(|c| (c.name.clone(), c.color.clone(), c.dashed, false))
            .collect();
        if let Some(l) = &self.marker_label {
            entries.push((l.clone(), "#444".into(), false, true));
        }
        let lw = 12.0
            + entries
                .iter()
                .map(|e| e.0.chars().count() as f64 * 6.6 + 34.0)
                .fold(0.0, f64::max);
        let lh = 8.0 + 16.0 * entries.len() as f64;
        // The corner whose box covers the fewest drawn points (top right where it is free).
        let drawn: Vec<(f64, f64)> = pixels
            .iter()
            .flat_map(|pts| {
                // Every vertex, and points every 8 px along the segments between them.
                let mut along = pts.first().copied().into_iter().collect::<Vec<_>>();
                for w in pts.windows(2) {
                    let ((x0, y0), (x1, y1)) = (w[0], w[1]);
                    let steps = ((x1 - x0).hypot(y1 - y0) / 8.0).ceil().max(1.0) as usize;
                    along.extend((1..=steps).map(|k| {
                        let t = k as f64 / steps as f64;
                        (x0 + t * (x1 - x0), y0 + t * (y1 - y0))
                    }));
                }
                along
            })
            .chain(
                self.markers
                    .iter()
                    .filter(|m| m.x.is_finite() && m.y.is_finite())
                    .map(|m| (sx(m.x), sy(m.y))),
            )
            .collect();
        let corners = [
            (LEFT + pw - lw - 6.0, TOP + 6.0),
            (LEFT + 6.0, TOP + 6.0),
            (LEFT + pw - lw - 6.0, TOP + ph - lh - 6.0),
            (LEFT + 6.0, TOP + ph - lh - 6.0),
        ];
        let covered = |(x, y): (f64, f64)| {
            drawn
                .iter()
                .filter(|(px, py)| (x..=x + lw).contains(px) && (y..=y + lh).contains(py))
                .count()
        };
        let (lx, ly) = corners
            .iter()
            .copied()
            .min_by_key(|&c| covered(c))
            .unwrap_or(corners[0]);
        let _ = write!(
            s,
            r##"<rect x="{lx:.1}" y="{ly:.1}" width="{lw:.1}" height="{lh:.1}" fill="#ffffff" fill-opacity="0.9" stroke="#bbb"/>"##
        );
        for (k, (name, color, dashed, marker)) in entries.iter().enumerate() {
            let y = ly + 14.0 + 16.0 * k as f64;
            if *marker {
                let _ = write!(
                    s,
                    r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="none" stroke="{color}" stroke-width="1.2"/>"#,
                    lx + 19.0,
                    y - 4.0
                );
            } else {
                let _ = write!(
                    s,
                    r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{color}" stroke-width="2"{}/>"#,
                    lx + 8.0,
                    y - 4.0,
                    lx + 30.0,
                    y - 4.0,
                    if *dashed {
                        r#" stroke-dasharray="6 3""#
                    } else {
                        ""
                    }
                );
            }
            let _ = write!(
                s,
                r#"<text x="{:.1}" y="{y:.1}">{}</text>"#,
                lx + 36.0,
                esc(name)
            );
        }
        s.push_str("</svg>");
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(ticks(0.0, 6.0, 6), vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        // Range 0.304 / 6 = 0.051 per tick: the next round step is 0.1.
        assert_eq!(ticks(-0.153, 0.151, 6), vec![-0.1, 0.0, 0.1]);
        assert_eq!(ticks(0.0, 0.004, 4), vec![0.0, 0.001, 0.002, 0.003, 0.004]);
    }

    #[test]
    fn decimation_keeps_extremes() {
        let x: Vec<f64> = (0..10_000).map(|k| k as f64).collect();
        let mut y = vec![0.0; 10_000];
        y[4321] = 5.0;
        y[7000] = -3.0;
        let (dx, dy) = decimate(&x, &y, 100);
        assert!(dx.len() <= 200);
        assert!(dy.contains(&5.0) && dy.contains(&-3.0));
    }

    /// The legend's box: its x and y.
    fn legend_at(svg: &str) -> (f64, f64) {
        let at = svg.find(r#"fill-opacity="0.9""#).unwrap();
        let rect = &svg[svg[..at].rfind("<rect").unwrap()..at];
        let value = |name: &str| -> f64 {
            let from = rect.find(&format!(" {name}=\"")).unwrap() + name.len() + 3;
            rect[from..from + rect[from..].find('"').unwrap()]
                .parse()
                .unwrap()
        };
        (value("x"), value("y"))
    }

    #[test]
    fn the_legend_goes_to_the_corner_the_curves_leave_free() {
        let curve = |x: Vec<f64>, y: Vec<f64>| Curve {
            name: "a curve".into(),
            color: "#000".into(),
            dashed: false,
            x,
            y,
        };
        // Rising: the top right is taken, the top left free.
        let rising = Plot {
            curves: vec![curve(vec![0.0, 1.0], vec![0.0, 1.0])],
            ..Default::default()
        };
        let (x, y) = legend_at(&rising.render());
        assert_eq!((x, y), (LEFT + 6.0, TOP + 6.0));
        // Falling: the top right is free, as by default.
        let falling = Plot {
            curves: vec![curve(vec![0.0, 1.0], vec![1.0, 0.0])],
            ..Default::default()
        };
        let (x, y) = legend_at(&falling.render());
        assert!(x > W / 2.0 && y == TOP + 6.0, "{x} {y}");
        // A flat line along the top, a mark below it: the legend goes to the bottom.
        let top = Plot {
            curves: vec![curve(vec![0.0, 1.0], vec![1.0, 1.0])],
            markers: vec![Marker {
                x: 0.5,
                y: 0.0,
                color: "#000".into(),
            }],
            ..Default::default()
        };
        let (_, y) = legend_at(&top.render());
        assert!(y > H / 2.0, "{y}");
    }

    #[test]
    fn plot_is_one_svg_element_with_escaped_text() {
        let p = Plot {
            title: "a < b".into(),
            x_label: "time t (s)".into(),
            y_label: "rotation (rad)".into(),
            curves: vec![Curve {
                name: "native".into(),
                color: "#1f77b4".into(),
                dashed: false,
                x: vec![0.0, 1.0],
                y: vec![0.1, -0.1],
            }],
            markers: vec![],
            marker_label: None,
        };
        let s = p.render();
        assert!(s.starts_with("<svg") && s.ends_with("</svg>"));
        assert!(s.contains("a &lt; b") && s.contains("polyline"));
    }
}
