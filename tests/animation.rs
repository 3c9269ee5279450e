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
    // (A summary without the trajectory's sha256, as written before it was recorded: the file's
    // own checks speak.)
    let bad = out.join("bad");
    std::fs::create_dir_all(&bad).unwrap();
    std::fs::copy(out.join("native/scene.json"), bad.join("scene.json")).unwrap();
    let mut summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("native/summary.json")).unwrap())
            .unwrap();
    summary
        .as_object_mut()
        .unwrap()
        .remove("trajectory_sha256")
        .unwrap();
    std::fs::write(bad.join("summary.json"), summary.to_string()).unwrap();
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

/// `rockbench animate` draws nothing it cannot tie to its runs: a run of other blocks, a scene
/// given or named that is not the run's, a summary beside another trajectory, runs of other
/// lengths, an ambiguous reference and a video over the page are each one line, and no page.
/// A run's end is a frame of its own.
#[test]
fn animate_refuses_what_it_would_draw_wrong() {
    let out = tmp("refuses");
    let two = std::fs::read_to_string(root().join("validation/scenes/two-block-free-rocking.toml"))
        .unwrap();
    let narrow = two.replace("width = 1.0\n", "width = 0.8\n");
    assert_ne!(two, narrow);
    let (two_file, narrow_file) = (out.join("two.toml"), out.join("narrow.toml"));
    std::fs::write(&two_file, &two).unwrap();
    std::fs::write(&narrow_file, &narrow).unwrap();
    let run = |scene: &Path, dir: &str, duration: &str| {
        run_ok(
            bin()
                .args([
                    "run",
                    scene.to_str().unwrap(),
                    "--engine",
                    "native",
                    "--quiet",
                ])
                .args(["--set", &format!("duration={duration}"), "--out"])
                .arg(out.join(dir)),
        );
        out.join(dir)
    };
    let r_two = run(&two_file, "two", "0.213");
    let r_narrow = run(&narrow_file, "narrow", "0.213");
    let r_short = run(&two_file, "short", "0.1");
    let page = out.join("a.html");
    let animate = |args: &[&Path], extra: &[&str]| {
        bin()
            .arg("animate")
            .args(args)
            .args(extra)
            .arg("--out")
            .arg(&page)
            .output()
            .unwrap()
    };
    let refused = |o: Output, says: &[&str]| {
        let err = common::one_error_line(&o);
        for s in says {
            assert!(err.contains(s), "{err} (expected `{s}`)");
        }
        assert!(!page.exists(), "a page was written: {err}");
    };
    refused(
        animate(&[&r_two, &r_narrow], &[]),
        &["narrow/scene.json", "blocks differ", "two/scene.json)"],
    );
    refused(
        animate(&[&r_two], &["--scene", narrow_file.to_str().unwrap()]),
        &["two/scene.json", "blocks differ"],
    );
    refused(
        animate(&[&r_two, &r_short], &[]),
        &["short/trajectory.csv: ends at t = 0.1 s", "at 0.213 s"],
    );
    // Without its scene.json, the run is drawn over the scene file its summary names only while
    // that file is still the run's scene.
    let bare = out.join("bare");
    std::fs::create_dir_all(&bare).unwrap();
    for f in ["summary.json", "trajectory.csv"] {
        std::fs::copy(r_two.join(f), bare.join(f)).unwrap();
    }
    let text = std::fs::read_to_string(r_two.join("summary.json")).unwrap();
    let summary: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(summary["scene_file"], two_file.to_str().unwrap());
    let mut rewritten = summary.clone();
    rewritten["scene_file"] = serde_json::Value::from(out.join("two-run.toml").to_str().unwrap());
    std::fs::write(bare.join("summary.json"), rewritten.to_string()).unwrap();
    std::fs::write(
        out.join("two-run.toml"),
        two.replace("duration = 6.0", "duration = 0.213"),
    )
    .unwrap();
    run_ok(
        bin()
            .args(["animate", bare.to_str().unwrap(), "--out"])
            .arg(&page),
    );
    std::fs::remove_file(&page).unwrap();
    std::fs::write(
        out.join("two-run.toml"),
        narrow.replace("duration = 6.0", "duration = 0.213"),
    )
    .unwrap();
    refused(
        animate(&[&bare], &[]),
        &["two-run.toml: not the scene of the run", "--scene"],
    );
    // A summary beside another run's trajectory.
    let swapped = out.join("swapped");
    std::fs::create_dir_all(&swapped).unwrap();
    std::fs::copy(
        r_narrow.join("trajectory.csv"),
        swapped.join("trajectory.csv"),
    )
    .unwrap();
    std::fs::copy(r_two.join("summary.json"), swapped.join("summary.json")).unwrap();
    refused(
        animate(&[&swapped], &["--scene", two_file.to_str().unwrap()]),
        &[
            "swapped/trajectory.csv: not the trajectory of",
            "swapped/summary.json",
        ],
    );
    // The reference: a directory however spelt; an engine name only when one run has it.
    let again = run(&two_file, "again", "0.213");
    let spelt = format!("{}/./", r_two.display());
    run_ok(
        bin()
            .args(["animate"])
            .arg(&again)
            .arg(&r_two)
            .args(["--reference", &spelt, "--out"])
            .arg(&page),
    );
    let html = std::fs::read_to_string(&page).unwrap();
    let reference = format!(
        "\"name\":\"native ({})\",\"color\":\"#3a3a3a\",\"ref\":true",
        r_two.display()
    );
    assert!(
        html.contains(&reference),
        "{}",
        &html[..400.min(html.len())]
    );
    // The run's end, 0.213 s, is the last of 12 frames (0, 0.02, ..., 0.2, 0.213).
    assert!(
        html.contains("\"fps\":50,\"n\":12,\"te\":0.213,"),
        "{}",
        &html[..200]
    );
    std::fs::remove_file(&page).unwrap();
    refused(
        animate(&[&again, &r_two], &["--reference", "native"]),
        &["--reference native: 2 runs are of that engine"],
    );
    let mp4 = out.join("same.mp4");
    let o = bin()
        .arg("animate")
        .arg(&r_two)
        .arg("--out")
        .arg(&mp4)
        .arg("--video")
        .arg(out.join(".").join("same.mp4"))
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("the page's own path"), "{err}");
    assert!(!mp4.exists());
    // An ffmpeg that ends well but writes no video: no "wrote", no page.
    let fake = out.join("fakebin");
    std::fs::create_dir_all(&fake).unwrap();
    let ffmpeg = fake.join("ffmpeg");
    std::fs::write(&ffmpeg, "#!/bin/sh\ncat > /dev/null\nexit 0\n").unwrap();
    let mut mode = std::fs::metadata(&ffmpeg).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut mode, 0o755);
    std::fs::set_permissions(&ffmpeg, mode).unwrap();
    let path = format!(
        "{}:{}",
        fake.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let o = bin()
        .env("PATH", path)
        .arg("animate")
        .arg(&r_two)
        .arg("--out")
        .arg(&page)
        .arg("--video")
        .arg(out.join("none.mp4"))
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(
        err.contains("ffmpeg reported success but wrote no"),
        "{err}"
    );
    assert!(String::from_utf8_lossy(&o.stdout).is_empty());
    assert!(!page.exists());
}

/// A scene given by a relative path names its record in the run's scene.json by an absolute
/// path: the run directory animates, and its scene.json runs again to the same trajectory,
/// from anywhere (the path was relative to where the run was started).
#[test]
fn a_runs_scene_names_its_record_from_anywhere() {
    let dir = tmp("relative");
    std::fs::create_dir_all(dir.join("s")).unwrap();
    std::fs::write(dir.join("s/rec.csv"), common::sine_record(3.0, 20.0, 301)).unwrap();
    std::fs::write(
        dir.join("s/scene.toml"),
        "name = \"r\"\nduration = 0.3\n[[blocks]]\nname = \"b\"\nwidth = 0.5\nheight = 2.0\n\
         [excitation.horizontal]\nkind = \"record\"\nfile = \"rec.csv\"\n",
    )
    .unwrap();
    run_ok(bin().current_dir(&dir).args([
        "run",
        "s/scene.toml",
        "--engine",
        "native",
        "--quiet",
        "--out",
        "o",
    ]));
    let scene: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("o/scene.json")).unwrap()).unwrap();
    let file = scene["excitation"]["horizontal"]["file"].as_str().unwrap();
    assert!(Path::new(file).is_absolute(), "{file}");
    run_ok(
        bin()
            .arg("animate")
            .arg(dir.join("o"))
            .arg("--out")
            .arg(dir.join("a.html")),
    );
    run_ok(
        bin()
            .args(["run"])
            .arg(dir.join("o/scene.json"))
            .args(["--engine", "native", "--quiet", "--out"])
            .arg(dir.join("again")),
    );
    let sha = |p: &str| {
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join(p)).unwrap()).unwrap();
        s["trajectory_sha256"].as_str().unwrap().to_string()
    };
    assert_eq!(sha("o/summary.json"), sha("again/summary.json"));
    // The record changed since the run: its ground is not the run's.
    std::fs::write(dir.join("s/rec.csv"), "time,acceleration\n0,0\n0.3,1\n").unwrap();
    let o = bin()
        .arg("animate")
        .arg(dir.join("o"))
        .arg("--out")
        .arg(dir.join("b.html"))
        .output()
        .unwrap();
    let err = common::one_error_line(&o);
    assert!(err.contains("rec.csv: not the record the run in"), "{err}");
    assert!(!dir.join("b.html").exists());
}
