//! Ctrl-C on long commands (`rockbench::interrupt`): a stability map, a spectrum, a
//! sensitivity study and accuracy gates stop with exit status 130 and one line saying what is
//! kept, write no output, keep only what they finished (whole entries in their run store or
//! cache, whole lines in runs.csv), and the same command then resumes from it; a run, a
//! comparison and a benchmark, which keep nothing, stop with nothing written, as do an
//! animation's video (ffmpeg killed) and the reference data's generation. The fragility
//! study's is `an_interrupted_study_leaves_whole_entries_and_resumes` (tests/fragility.rs).

mod common;

use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The lines of `from`, each signalled on `tx` as it comes.
fn watch<R: Read>(from: BufReader<R>, tx: Option<std::sync::mpsc::Sender<()>>) -> Vec<String> {
    let mut kept = Vec::new();
    for line in from.lines() {
        let line = line.unwrap();
        if let Some(tx) = &tx {
            let _ = tx.send(());
        }
        kept.push(line);
    }
    kept
}

/// Runs `cmd`, sends it SIGINT once it has printed its first line on `stdout` (or on stderr
/// when `on_stdout` is false), and gives its exit status and the lines of stderr.
fn interrupted(cmd: &mut Command, on_stdout: bool) -> (Option<i32>, Vec<String>) {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let stdout = BufReader::new(child.stdout.take().unwrap());
    let stderr = BufReader::new(child.stderr.take().unwrap());
    let (out_tx, err_tx) = if on_stdout {
        (Some(tx), None)
    } else {
        (None, Some(tx))
    };
    let out = std::thread::spawn(move || watch(stdout, out_tx));
    let err = std::thread::spawn(move || watch(stderr, err_tx));
    rx.recv().expect("a line before the command ends");
    // SAFETY: signals a child of this process, which has not been waited for.
    assert_eq!(
        unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) },
        0
    );
    let status = child.wait().unwrap();
    out.join().unwrap();
    (status.code(), err.join().unwrap())
}

/// The files under `dir`, recursively.
fn files(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        if e.path().is_dir() {
            v.extend(files(&e.path()));
        } else {
            v.push(e.path());
        }
    }
    v
}

/// Every file of a run store is a whole JSON entry (no temporary file left behind).
fn whole_entries(store: &Path) -> usize {
    let all = files(store);
    for p in &all {
        assert!(
            p.extension().is_some_and(|e| e == "json"),
            "not an entry: {}",
            p.display()
        );
        let text = std::fs::read_to_string(p).unwrap();
        serde_json::from_str::<serde_json::Value>(&text).expect("a whole entry");
    }
    all.len()
}

/// A CSV's rows without its `wall_s` column, the one thing two runs of the same work differ in.
fn without_wall_times(csv: &str) -> Vec<String> {
    let header: Vec<&str> = csv.lines().next().unwrap_or_default().split(',').collect();
    let wall = header.iter().position(|h| *h == "wall_s");
    csv.lines()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            if let Some(k) = wall {
                f.remove(k);
            }
            f.join(",")
        })
        .collect()
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The stability map's cells of two factors (some 2 s of runs): stopped after its first cell,
/// it keeps only the cells it finished, and resumes to the uninterrupted map.
#[test]
fn a_stability_map_stopped_by_ctrl_c_keeps_its_finished_cells_and_resumes() {
    const FACTORS: &str = "blocks,wall_courses";
    let dir = common::tmp("rb-interrupt", "stress");
    let store = dir.join("store");
    let map = |out: &str| {
        let mut c = common::bin();
        c.args(["stress", "--engines", "native", "--factors", FACTORS])
            .arg("--out")
            .arg(dir.join(out))
            .arg("--cache-dir")
            .arg(&store);
        c
    };
    let (code, err) = interrupted(&mut map("map"), true);
    assert_eq!(code, Some(130), "{err:?}");
    let last = err.last().unwrap();
    assert!(
        last.starts_with("error: interrupted after ")
            && last.contains(" cells; the cells run are kept in ")
            && last.ends_with("the same command resumes the map from them"),
        "{err:?}"
    );
    let words: Vec<&str> = last.split(' ').collect();
    let (done, cells): (usize, usize) = (words[3].parse().unwrap(), words[5].parse().unwrap());
    assert!(done >= 1 && done < cells, "{last}");
    // The cells finished, and no other: the one under way was stopped and not kept.
    assert_eq!(whole_entries(&store), done);
    assert!(
        files(&dir.join("map")).is_empty(),
        "an interrupted map wrote outputs"
    );

    let resumed = common::run_ok(&mut map("map"));
    assert_eq!(resumed.matches("(stored)").count(), done, "{resumed}");
    assert_eq!(whole_entries(&store), cells);
    let uninterrupted = common::run_ok(
        common::bin()
            .args(["stress", "--engines", "native", "--factors", FACTORS])
            .arg("--out")
            .arg(dir.join("whole"))
            .arg("--no-cache"),
    );
    assert!(
        uninterrupted.contains(&format!("{cells} finished")),
        "{uninterrupted}"
    );
    // The same cells, measured the same.
    assert_eq!(
        without_wall_times(&read(&dir.join("map/native.csv"))),
        without_wall_times(&read(&dir.join("whole/native.csv")))
    );
}

/// A spectrum stopped after its first minimum writes nothing, keeps whole entries, and
/// resumes from them to the uninterrupted spectrum.
#[test]
fn a_spectrum_stopped_by_ctrl_c_writes_nothing_and_resumes() {
    let dir = common::tmp("rb-interrupt", "spectrum");
    let store = dir.join("store");
    let spectrum = |out: &str, store: Option<&Path>| {
        let mut c = common::bin();
        c.args([
            "spectrum",
            "0.4x4",
            "--pulse",
            "half-sine,one-sine,one-cosine",
            "--ratios",
            "0.5:10:10",
            "--amplitudes",
            "none",
            "--engines",
            "native",
        ])
        .arg("--out")
        .arg(dir.join(out));
        match store {
            Some(s) => c.arg("--cache-dir").arg(s),
            None => c.arg("--no-cache"),
        };
        c
    };
    let (code, err) = interrupted(&mut spectrum("spectrum", Some(&store)), false);
    assert_eq!(code, Some(130), "{err:?}");
    let last = err.last().unwrap();
    assert!(
        last.starts_with("error: interrupted; the runs finished are kept in ")
            && last.ends_with("the same command resumes the spectrum from them"),
        "{err:?}"
    );
    let kept = whole_entries(&store);
    assert!(kept > 0, "no run kept");
    assert!(
        !dir.join("spectrum").exists(),
        "an interrupted spectrum wrote outputs"
    );

    let mut cmd = spectrum("spectrum", Some(&store));
    let out = cmd.output().unwrap();
    let mut text = String::new();
    out.stderr.as_slice().read_to_string(&mut text).unwrap();
    assert!(out.status.success(), "{text}");
    let json: serde_json::Value =
        serde_json::from_str(&read(&dir.join("spectrum/spectrum.json"))).unwrap();
    assert_eq!(
        json["runs_from_store"].as_u64(),
        Some(kept as u64),
        "{text}"
    );
    common::run_ok(&mut spectrum("whole", None));
    for f in ["minimum.csv", "map.csv"] {
        assert_eq!(
            without_wall_times(&read(&dir.join("spectrum").join(f))),
            without_wall_times(&read(&dir.join("whole").join(f))),
            "{f}"
        );
    }
}

/// A sensitivity study stopped after its first member keeps that member's line in runs.csv and
/// no other, writes no sensitivity.md, and the same command resumes with the members left.
#[test]
fn a_sensitivity_study_stopped_by_ctrl_c_keeps_its_finished_runs_and_resumes() {
    let dir = common::tmp("rb-interrupt", "sensitivity");
    let out = dir.join("study");
    let study = || {
        let mut c = common::bin();
        c.arg("sensitivity")
            .arg(common::root().join("validation/scenes/wall-in-motion-pulse.toml"))
            .args([
                "--perturb",
                "excitation.horizontal.amplitude=4.905",
                "--configs",
                "native",
                "--members",
                "3",
                "--set",
                "duration=0.3",
            ])
            .arg("--out")
            .arg(&out);
        c
    };
    let (code, err) = interrupted(&mut study(), false);
    assert_eq!(code, Some(130), "{err:?}");
    let last = err.last().unwrap();
    assert!(
        last.starts_with("error: interrupted after 1 of 3 runs; they are kept in ")
            && last.ends_with("the same command resumes the study from them"),
        "{err:?}"
    );
    let runs = read(&out.join("runs.csv"));
    assert_eq!(runs.lines().count(), 2 + 1, "{runs}");
    assert!(!out.join("sensitivity.md").exists());

    let resumed = study().output().unwrap();
    let progress = String::from_utf8_lossy(&resumed.stderr).to_string();
    assert!(resumed.status.success(), "{progress}");
    assert_eq!(progress.matches("member").count(), 2, "{progress}");
    assert_eq!(read(&out.join("runs.csv")).lines().count(), 2 + 3);
    assert!(out.join("sensitivity.md").exists());
}

/// Accuracy gates stopped after their first run keep the runs finished in the run cache (whole
/// entries only), print no verdict and write no JUnit file; the same command resumes from them.
#[test]
fn gates_stopped_by_ctrl_c_keep_their_finished_runs_and_resume() {
    let dir = common::tmp("rb-interrupt", "gates");
    let cache = dir.join("cache");
    let junit = dir.join("junit.xml");
    let slender = common::root().join("validation/scenes/housner-slender.toml");
    // Three native runs of about a second each (a million steps and more) against Housner's.
    let text: String = [8, 12, 16]
        .iter()
        .map(|d| {
            format!(
                "[[gate]]\nname = \"slender-{d}\"\nscene = \"{}\"\nset = [\"duration={d}\", \"native.dt=1e-5\"]\n\
                 engine = \"native\"\nreference = \"housner\"\nmetric = \"impact_time_1\"\ntolerance = 1e-2\n\n",
                slender.display()
            )
        })
        .collect();
    let file = dir.join("gates.toml");
    std::fs::write(&file, text).unwrap();
    let gates = || {
        let mut c = common::bin();
        c.arg("gate")
            .arg(&file)
            .args(["--jobs", "1", "--cache-dir"])
            .arg(&cache)
            .arg("--junit")
            .arg(&junit);
        c
    };
    let (code, err) = interrupted(&mut gates(), false);
    assert_eq!(code, Some(130), "{err:?}");
    assert_eq!(
        err.last().unwrap(),
        &format!(
            "error: interrupted; the runs finished are kept in {}, and the same command resumes the gates from them",
            cache.display()
        )
    );
    assert!(
        !junit.exists(),
        "an interrupted gate file wrote its JUnit file"
    );
    let entries: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        entries.iter().all(|e| !e.starts_with(".tmp")),
        "{entries:?}"
    );
    let kept = entries.len();
    assert!((1..6).contains(&kept), "{entries:?}");

    let resumed = common::run_ok(&mut gates());
    assert!(
        resumed.contains(&format!("{kept} from the cache, {} run now", 6 - kept)),
        "{resumed}"
    );
    assert!(resumed.contains("3 of 3 gates as expected"), "{resumed}");
}

/// Whether process `pid` catches SIGINT (its `SigCgt` mask in /proc): the command has installed
/// its handler, so that a signal now asks it to stop rather than ending it.
fn catches_sigint(pid: u32) -> bool {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigCgt:"))
        .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        .is_some_and(|mask| mask & (1 << (libc::SIGINT - 1)) != 0)
}

/// Waits until `ready` (at most 60 s, then fails naming `what`).
fn wait_for(what: &str, mut ready: impl FnMut() -> bool) {
    let t0 = std::time::Instant::now();
    while !ready() {
        assert!(t0.elapsed().as_secs() < 60, "{what}: not after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
}

/// Sends `signal` to `child` and gives its exit status and stderr.
fn signalled(child: std::process::Child, signal: i32) -> (Option<i32>, String) {
    // SAFETY: signals a child of this process, which has not been waited for.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, signal) }, 0);
    let o = child.wait_with_output().unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).to_string(),
    )
}

/// A run, a comparison and a work-precision benchmark (none keeps a store) stopped by SIGINT or
/// SIGTERM (a batch system's) in the middle of their runs, and the reference data's generation
/// before it writes: exit status 130, one line, nothing written.
#[test]
fn commands_that_keep_no_runs_stopped_by_a_signal_write_nothing() {
    let dir = common::tmp("rb-interrupt", "run");
    let root = common::root();
    let wall = root.join("validation/scenes/wall-in-motion-pulse.toml");
    let slender = root.join("validation/scenes/housner-slender.toml");
    let nothing = "error: interrupted; nothing is written";
    let cases: [(&str, &Path, &[&str], i32, String); 4] = [
        (
            "run",
            &wall,
            &["--engine", "native"],
            libc::SIGINT,
            format!("{nothing} (`--checkpoint FILE` makes a native run that resumes)"),
        ),
        (
            "compare",
            &wall,
            &["--engines", "native", "--reference", "native"],
            libc::SIGTERM,
            nothing.to_string(),
        ),
        // Six million steps a run.
        (
            "bench",
            &slender,
            &[
                "--engines",
                "native",
                "--dt",
                "1e-5",
                "--set",
                "duration=60",
            ],
            libc::SIGINT,
            nothing.to_string(),
        ),
        // Signalled as its handler is installed, before its runs end.
        ("references", &root, &[], libc::SIGTERM, nothing.to_string()),
    ];
    for (command, path, args, signal, line) in cases {
        let out = dir.join(command);
        let child = common::bin()
            .arg(command)
            .args(if command == "references" {
                &["--root"][..]
            } else {
                &[]
            })
            .arg(path)
            .args(args)
            .arg("--out")
            .arg(&out)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let pid = child.id();
        wait_for(command, || catches_sigint(pid));
        let (code, err) = signalled(child, signal);
        assert_eq!(code, Some(130), "{command}: {err}");
        // Progress lines may come before it; the command's last line says it stopped.
        assert_eq!(err.lines().last(), Some(line.as_str()), "{command}: {err}");
        assert_eq!(err.matches("error:").count(), 1, "{command}: {err}");
        assert!(
            !out.exists(),
            "{command}: an interrupted {command} wrote outputs"
        );
    }
}

/// The child of `parent` whose command line has `needle` (its pid), if one runs.
fn child_running(parent: u32, needle: &str) -> Option<u32> {
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: u32 = e.file_name().to_str()?.parse().ok()?;
        let status = std::fs::read_to_string(e.path().join("status")).ok()?;
        let ppid = status.lines().find_map(|l| l.strip_prefix("PPid:"))?.trim();
        let cmdline = std::fs::read(e.path().join("cmdline")).ok()?;
        (ppid == parent.to_string() && String::from_utf8_lossy(&cmdline).contains(needle))
            .then_some(pid)
    })
}

/// Whether `pid` is a process that has not ended (a zombie has).
fn alive(pid: u32) -> bool {
    common::proc_stat(pid)
        .first()
        .is_some_and(|state| state != "Z")
}

/// An animation and a comparison stopped while ffmpeg encodes their video (ten minutes of
/// rocking, some 15000 frames): ffmpeg killed and the video removed, exit status 130, one
/// line; the animation writes no page, the comparison keeps the files it wrote before.
#[test]
fn videos_stopped_while_encoded_are_removed_and_ffmpeg_killed() {
    let dir = common::tmp("rb-interrupt", "animate");
    let slender = common::root().join("validation/scenes/housner-slender.toml");
    let run = dir.join("run");
    common::run_ok(
        common::bin()
            .arg("run")
            .arg(&slender)
            .args(["--engine", "housner", "--set", "duration=600", "--quiet"])
            .arg("--out")
            .arg(&run),
    );
    let (page, video) = (dir.join("a.html"), dir.join("a.mp4"));
    let compared = dir.join("compare");
    let mut animate = common::bin();
    animate
        .arg("animate")
        .arg(&run)
        .arg("--out")
        .arg(&page)
        .arg("--video")
        .arg(&video);
    let mut compare = common::bin();
    compare
        .arg("compare")
        .arg(&slender)
        .args(["--engines", "housner", "--reference", "housner"])
        .args(["--set", "duration=600", "--quiet", "--video", "--out"])
        .arg(&compared);
    let kept = format!(
        "error: interrupted; {} is written without its video (the same command with --video \
         writes it again)",
        compared.display()
    );
    for (mut cmd, line) in [
        (animate, "error: interrupted; nothing is written"),
        (compare, kept.as_str()),
    ] {
        let child = cmd
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // The encoder (`ffmpeg -f rawvideo ...`), not the check that ffmpeg runs at all.
        let mut ffmpeg = None;
        wait_for("ffmpeg", || {
            ffmpeg = child_running(child.id(), "rawvideo");
            ffmpeg.is_some()
        });
        let (code, err) = signalled(child, libc::SIGINT);
        assert_eq!(code, Some(130), "{line}: {err}");
        assert_eq!(err.trim(), line);
        assert!(!ffmpeg.is_some_and(alive), "ffmpeg was left running");
    }
    assert!(
        !video.exists() && !page.exists(),
        "an interrupted animation wrote files"
    );
    assert!(compared.join("report.html").is_file() && compared.join("metrics.csv").is_file());
    assert!(
        !compared.join("animation.mp4").exists(),
        "a partial video was left"
    );
}
