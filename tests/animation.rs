//! The motion in the report, driven in headless Chromium: the player draws the blocks where
//! the trajectory says (pixel positions against the expected ones), two instants give two
//! different frames, it plays, the page logs no console error, and the verdict table is above
//! the fold on a 1280 x 800 screen. Also `--video` (ffprobe reads its duration) and
//! `rockbench animate`.

mod common;

use common::{bin, root, run_ok};
use rockbench::trajectory::Trajectory;
use std::path::Path;
use std::process::{Command, Output};

fn tmp(name: &str) -> common::TmpDir {
    common::tmp("rb-anim", name)
}

/// Chromium, or None (then the test is skipped, except under CI: `make test` installs it).
fn chromium() -> Option<&'static str> {
    let found = ["chromium", "chromium-browser"]
        .into_iter()
        .find(|c| Command::new(c).arg("--version").output().is_ok());
    if found.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "chromium is not installed (make test installs it)"
        );
        eprintln!("skipped: chromium not installed (make test installs it)");
    }
    found
}

/// Headless Chromium on a fresh profile, with the page's console on stderr.
fn chrome(exe: &str, dir: &Path, tag: &str, size: &str, extra: &[String], url: &str) -> Output {
    let profile = dir.join(format!("profile-{tag}"));
    let _ = std::fs::remove_dir_all(&profile);
    Command::new(exe)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
            "--enable-logging=stderr",
            "--v=0",
            "--virtual-time-budget=1500",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--window-size={size}"),
        ])
        .args(extra)
        .arg(url)
        .output()
        .unwrap()
}

/// Console errors the page raised (Chromium prints console messages as `CONSOLE` lines).
fn console_errors(o: &Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Uncaught"))
        .map(String::from)
        .collect()
}

struct Shot {
    w: usize,
    h: usize,
    rgb: Vec<[u8; 3]>,
}

fn screenshot(exe: &str, dir: &Path, tag: &str, size: &str, url: &str) -> Shot {
    let png = dir.join(format!("{tag}.png"));
    let o = chrome(
        exe,
        dir,
        tag,
        size,
        &[format!("--screenshot={}", png.display())],
        url,
    );
    assert!(
        png.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let errors = console_errors(&o);
    assert!(errors.is_empty(), "console errors at {url}: {errors:?}");
    let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let ch = info.color_type.samples();
    let rgb = buf[..info.buffer_size()]
        .chunks(ch)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    Shot {
        w: info.width as usize,
        h: info.height as usize,
        rgb,
    }
}

fn near(p: [u8; 3], c: [u8; 3], tol: i32) -> bool {
    (0..3).all(|k| (p[k] as i32 - c[k] as i32).abs() <= tol)
}

/// Centroid and orientation (of the long axis, from the vertical, counter-clockwise as the
/// world sees it) of the pixels of one colour above row `below` (the drawing, not the legend).
fn blob(s: &Shot, c: [u8; 3], below: usize) -> (usize, f64, f64, f64) {
    let (mut n, mut sx, mut sy) = (0usize, 0.0, 0.0);
    let mut pts = Vec::new();
    for y in 0..s.h.min(below) {
        for x in 0..s.w {
            if near(s.rgb[y * s.w + x], c, 6) {
                n += 1;
                sx += x as f64 + 0.5;
                sy += y as f64 + 0.5;
                pts.push((x as f64 + 0.5, y as f64 + 0.5));
            }
        }
    }
    let (cx, cy) = (sx / n.max(1) as f64, sy / n.max(1) as f64);
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (x, y) in pts {
        sxx += (x - cx).powi(2);
        syy += (y - cy).powi(2);
        sxy += (x - cx) * (y - cy);
    }
    // Long-axis angle from the image's x axis, then from the vertical; image y points down,
    // so a counter-clockwise world rotation phi tilts the long axis by -phi in the image.
    let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let from_vertical = theta - std::f64::consts::FRAC_PI_2 * theta.signum();
    (n, cx, cy, -from_vertical)
}

fn attr(html: &str, name: &str) -> f64 {
    let key = format!("{name}=\"");
    let at = html.find(&key).unwrap_or_else(|| panic!("no {name}")) + key.len();
    html[at..at + html[at..].find('"').unwrap()]
        .parse()
        .unwrap()
}

fn at(tr: &Trajectory, t: f64) -> (f64, f64, f64) {
    let k = tr.t.iter().position(|&s| s >= t - 1e-12).unwrap();
    let b = &tr.blocks[0];
    if (tr.t[k] - t).abs() < 1e-12 || k == 0 {
        return (b.x[k], b.z[k], b.phi[k]);
    }
    let w = (t - tr.t[k - 1]) / (tr.t[k] - tr.t[k - 1]);
    let l = |v: &[f64]| v[k - 1] + w * (v[k] - v[k - 1]);
    (l(&b.x), l(&b.z), l(&b.phi))
}

/// The slender block, Housner (reference, solid) against native and rapier.
#[test]
fn the_report_animates_the_blocks_where_the_trajectory_puts_them() {
    let out = tmp("report");
    run_ok(
        bin().args([
            "compare",
            root()
                .join("validation/scenes/housner-slender.toml")
                .to_str()
                .unwrap(),
            "--engines",
            "native,rapier,housner",
            "--reference",
            "housner",
            "--set",
            "duration=2.0",
            "--video",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ]),
    );
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    // Self-contained: no network, one player, a static key-frame strip for readers without
    // scripts, the verdict as the first table of both twins.
    assert!(!html.contains("http://") || !html.contains("src=\"http"));
    assert!(!html.contains("https://"));
    assert_eq!(html.matches("id=\"anim-svg\"").count(), 1);
    assert!(html.contains("class=\"strip\""));
    let first_table = html.find("<table").unwrap();
    assert_eq!(first_table, html.find("<table class=\"verdict\"").unwrap());
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    let md_table = md.find("\n| ").unwrap();
    assert!(md[md_table..].starts_with("\n| engine | history before the 1st impact"));
    assert!(out.join("plots/keyframes.svg").is_file());

    // The video: ffprobe reads a duration of about the scene's 2 s.
    if Command::new("ffprobe").arg("-version").output().is_ok() {
        let o = Command::new("ffprobe")
            .args([
                "-v",
                "error",
                "-show_entries",
                "format=duration",
                "-of",
                "csv=p=0",
            ])
            .arg(out.join("animation.mp4"))
            .output()
            .unwrap();
        let d: f64 = String::from_utf8_lossy(&o.stdout).trim().parse().unwrap();
        assert!((d - 2.0).abs() < 0.1, "video duration {d}");
    } else {
        assert!(
            std::env::var_os("CI").is_none(),
            "ffprobe missing (make ffmpeg)"
        );
    }

    let Some(exe) = chromium() else { return };
    let url = format!("file://{}", out.join("report.html").display());
    let t0 = std::time::Instant::now();

    // Pixel positions: the reference alone, at two instants.
    let (s, ox, oy) = (
        attr(&html, "data-s"),
        attr(&html, "data-ox"),
        attr(&html, "data-oy"),
    );
    let housner = Trajectory::read_csv(&out.join("housner/trajectory.csv")).unwrap();
    let mut shots = Vec::new();
    for (tag, t) in [("a", 0.3), ("b", 1.0)] {
        let shot = screenshot(
            exe,
            &out,
            tag,
            "900,500",
            &format!("{url}#solo&only=housner&t={t}"),
        );
        let (n, cx, cy, angle) = blob(&shot, [0x3a, 0x3a, 0x3a], oy as usize + 2);
        let (x, z, phi) = at(&housner, t);
        let (ex, ey) = (ox + s * x, oy - s * z);
        // The block is 1 x 2.5 m: s * s * 2.5 pixels.
        let area = s * s * 2.5;
        assert!(
            (n as f64 - area).abs() < 0.06 * area,
            "t = {t}: {n} block pixels, {area:.0} expected"
        );
        assert!(
            (cx - ex).abs() < 1.5 && (cy - ey).abs() < 1.5,
            "t = {t}: block centre drawn at ({cx:.1}, {cy:.1}) px, the trajectory puts it at ({ex:.1}, {ey:.1})"
        );
        assert!(
            (angle - phi).abs() < 0.01,
            "t = {t}: drawn at {angle:.4} rad, the trajectory says {phi:.4}"
        );
        shots.push(shot);
    }
    let differ = shots[0]
        .rgb
        .iter()
        .zip(&shots[1].rgb)
        .filter(|(a, b)| !near(**a, **b, 10))
        .count();
    assert!(
        differ > 500,
        "frames at 0.3 s and 1.0 s differ by {differ} pixels"
    );

    // It plays: from t = 0, 1.5 s of (virtual) time later the clock has moved on.
    let o = chrome(
        exe,
        &out,
        "play",
        "1280,800",
        &["--dump-dom".into()],
        &format!("{url}#play"),
    );
    let dom = String::from_utf8_lossy(&o.stdout);
    assert!(
        dom.contains("data-anim-ready=\"1\""),
        "the script did not finish"
    );
    assert!(!dom.contains("data-anim-errors=\""), "script errors");
    let tstr = dom
        .split("<output id=\"anim-time\">t = ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .unwrap();
    let t: f64 = tstr.parse().unwrap();
    assert!(t > 0.2, "after playing, t = {t}");
    assert!(dom.contains("φ (rad): block "), "no rotation read-out");
    let errors = console_errors(&o);
    assert!(errors.is_empty(), "console errors: {errors:?}");

    // The verdict table is above the fold on 1280 x 800: its green and red cells are in the
    // first screen.
    let shot = screenshot(exe, &out, "fold", "1280,800", &url);
    let cells = shot
        .rgb
        .iter()
        .filter(|p| near(**p, [0xcd, 0xec, 0xcd], 3) || near(**p, [0xf6, 0xc5, 0xc5], 3))
        .count();
    assert!(
        cells > 20_000,
        "verdict cells above the fold: {cells} pixels"
    );
    eprintln!("chromium checks: {:.1} s", t0.elapsed().as_secs_f64());
}

/// `rockbench animate` on two `rockbench run` outputs: one page, the first run solid, a GIF.
#[test]
fn animate_draws_runs_made_with_run() {
    let out = tmp("runs");
    let scene = root().join("validation/scenes/housner-square.toml");
    for e in ["housner", "native"] {
        run_ok(bin().args([
            "run",
            scene.to_str().unwrap(),
            "--engine",
            e,
            "--set",
            "duration=1.0",
            "--out",
            out.join(e).to_str().unwrap(),
        ]));
    }
    let page = out.join("a.html");
    let gif = out.join("a.gif");
    run_ok(bin().args([
        "animate",
        out.join("housner").to_str().unwrap(),
        out.join("native").to_str().unwrap(),
        "--out",
        page.to_str().unwrap(),
        "--video",
        gif.to_str().unwrap(),
    ]));
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(html.contains("\"name\":\"housner\",\"color\":\"#3a3a3a\",\"ref\":true"));
    assert!(html.contains("\"name\":\"native\",\"color\":\"#1f77b4\",\"ref\":false"));
    // 1 s at 50 frames per second.
    assert!(html.contains("\"fps\":50,\"n\":51,"), "{}", &html[..200]);
    if Command::new("ffprobe").arg("-version").output().is_ok() {
        let o = Command::new("ffprobe")
            .args([
                "-v",
                "error",
                "-show_entries",
                "format=duration",
                "-of",
                "csv=p=0",
            ])
            .arg(&gif)
            .output()
            .unwrap();
        let d: f64 = String::from_utf8_lossy(&o.stdout).trim().parse().unwrap();
        assert!((d - 1.0).abs() < 0.1, "gif duration {d}");
    }
    // Bad input: one line naming the directory.
    let o = bin()
        .args([
            "animate",
            out.join("nope").to_str().unwrap(),
            "--out",
            page.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("nope/summary.json"), "{err}");
    // A run whose trajectory has a time that does not increase, or a value that is not finite:
    // one line naming the file (it was drawn as given).
    let bad = out.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    std::fs::copy(out.join("native/summary.json"), bad.join("summary.json")).unwrap();
    let text = std::fs::read_to_string(out.join("native/trajectory.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let with = |k: usize, col: usize, value: &str| {
        let mut c: Vec<&str> = lines[k].split(',').collect();
        c[col] = value;
        c.join(",")
    };
    let earlier = lines[2].split(',').next().unwrap().to_string();
    for (k, edit, says) in [
        (3, with(3, 0, &earlier), "is repeated"),
        (4, with(4, 2, "NaN"), "not finite"),
    ] {
        let keep = std::mem::replace(&mut lines[k], edit);
        std::fs::write(bad.join("trajectory.csv"), lines.join("\n") + "\n").unwrap();
        lines[k] = keep;
        let o = bin()
            .args(["animate", bad.to_str().unwrap(), "--out"])
            .arg(out.join("bad.html"))
            .output()
            .unwrap();
        let err = common::one_error_line(&o);
        assert!(
            err.contains("bad/trajectory.csv") && err.contains(says),
            "{err}"
        );
        assert_eq!(err.matches("bad/trajectory.csv").count(), 1, "{err}");
        assert!(!out.join("bad.html").exists());
    }
    // A video of a kind it cannot write, or where nothing can be written: refused before the
    // page is written (in the second case it was written, and rockbench ended on SIGPIPE
    // without a word when ffmpeg could not open the video).
    let other = out.join("other.html");
    let avi = out.join("a.avi").to_str().unwrap().to_string();
    for (video, said) in [
        (avi.as_str(), "a.avi: a video is .mp4 or .gif (got `avi`)"),
        (
            "/proc/rockbench-test/a.mp4",
            "--video: /proc/rockbench-test/a.mp4: ",
        ),
    ] {
        let o = bin()
            .args(["animate", out.join("housner").to_str().unwrap(), "--out"])
            .arg(&other)
            .args(["--video", video])
            .output()
            .unwrap();
        let err = common::one_error_line(&o);
        assert!(err.contains(said), "{err}");
        assert!(!other.exists(), "the page was written");
    }
    let o = bin()
        .args([
            "compare",
            scene.to_str().unwrap(),
            "--engines",
            "housner",
            "--reference",
            "housner",
            "--video",
            "avi",
            "--out",
            out.join("c").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("--video"), "{err}");
}
