//! Shared by the integration tests that run the binary and render reports.
#![allow(dead_code)] // each test binary uses some of these

use std::path::{Path, PathBuf};
use std::process::Command;

/// The rockbench binary built for these tests.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_rockbench"))
}

/// The project's root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The fields of `/proc/PID/stat` after the command's name (the first is the state, field 3
/// of proc(5)); empty when the process has gone.
pub fn proc_stat(pid: u32) -> Vec<String> {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|s| {
            s.rsplit_once(')')
                .map(|(_, rest)| rest.split_whitespace().map(String::from).collect())
        })
        .unwrap_or_default()
}

/// A scratch directory, removed when dropped; a test that panics keeps it for inspection
/// (its path is printed). Derefs to its [`Path`].
pub struct TmpDir(tempfile::TempDir);

impl std::ops::Deref for TmpDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        self.0.path()
    }
}

impl AsRef<Path> for TmpDir {
    fn as_ref(&self) -> &Path {
        self
    }
}

impl AsRef<std::ffi::OsStr> for TmpDir {
    fn as_ref(&self) -> &std::ffi::OsStr {
        self.as_os_str()
    }
}

impl Drop for TmpDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            self.0.disable_cleanup(true);
            eprintln!("scratch directory kept: {}", self.0.path().display());
        }
    }
}

/// A fresh scratch directory `<prefix>-<name>-XXXXXX` under the system's temporary directory.
pub fn tmp(prefix: &str, name: &str) -> TmpDir {
    TmpDir(
        tempfile::Builder::new()
            .prefix(&format!("{prefix}-{name}-"))
            .tempdir()
            .expect("a scratch directory"),
    )
}

/// Run a command that must succeed; its stdout.
pub fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout).to_string(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    );
    assert!(out.status.success(), "failed: {so}\n{se}");
    so
}

/// The stderr of a run that must fail with exit code 1 and one line on stderr.
pub fn one_error_line(out: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    err
}

/// Open `out/report.html` in headless Chromium and check that the screenshot is not blank and
/// shows the first engine's curve colour (#1f77b4), i.e. the plots rendered, not only the text.
/// Without Chromium the check is skipped, except under CI (`make test` installs it).
pub fn assert_report_renders(out: &Path) {
    let Some(chromium) = ["chromium", "chromium-browser"]
        .into_iter()
        .find(|c| Command::new(c).arg("--version").output().is_ok())
    else {
        assert!(
            std::env::var_os("CI").is_none(),
            "chromium is not installed (make test installs it)"
        );
        eprintln!("skipped: chromium not installed (make test installs it)");
        return;
    };
    let png = out.join("shot.png");
    let profile = out.join("profile");
    let url = format!("file://{}", out.join("report.html").display());
    let o = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--screenshot={}", png.display()),
            "--window-size=1200,2400",
            &url,
        ])
        .output()
        .unwrap();
    assert!(
        png.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let ch = info.color_type.samples();
    assert!(ch >= 3, "unexpected colour type {:?}", info.color_type);
    let px: Vec<&[u8]> = buf[..info.buffer_size()].chunks(ch).collect();
    let lum: Vec<f64> = px
        .iter()
        .map(|p| 0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64)
        .collect();
    let mean = lum.iter().sum::<f64>() / lum.len() as f64;
    let var = lum.iter().map(|l| (l - mean).powi(2)).sum::<f64>() / lum.len() as f64;
    assert!(
        var > 100.0,
        "screenshot looks blank (luminance variance {var})"
    );
    // The paper section's plot: the first engine's curve in the palette's blue (#1f77b4).
    let blue = px
        .iter()
        .filter(|p| {
            (p[0] as i32 - 0x1f).abs() < 40
                && (p[1] as i32 - 0x77).abs() < 40
                && (p[2] as i32 - 0xb4).abs() < 40
        })
        .count();
    assert!(
        blue > 200,
        "no plotted curve in the screenshot ({blue} blue pixels)"
    );
}

/// The two-block case (`validation/scenes/two-block-free-rocking.toml`) on the native engine with
/// the settings `set`: the pedestal's ground impact, then the statue's first `crossings` zero
/// crossings, s (the events of the run's summary).
pub fn two_block_events(set: &[String], crossings: usize) -> Vec<f64> {
    use rockbench::engines::{engine_by_name, run_timed};
    let path = root().join("validation/scenes/two-block-free-rocking.toml");
    let scene = rockbench::scene::load_scene_with_overrides(&path, set).unwrap();
    let (_, summary) = run_timed(engine_by_name("native").unwrap().as_ref(), &scene).unwrap();
    let mut events = vec![summary.blocks[0].impacts[0]];
    events.extend(&summary.blocks[1].impacts[..crossings]);
    events
}

/// The seed of a property test: `make test` (no PROPTEST_CASES) runs `fixed`, so CI is
/// reproducible; a make target that sets PROPTEST_CASES draws a new seed each run unless
/// PROPTEST_RNG_SEED is set.
pub fn proptest_seed(fixed: u64) -> proptest::test_runner::RngSeed {
    use proptest::test_runner::RngSeed;
    match std::env::var("PROPTEST_RNG_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
    {
        Some(s) => RngSeed::Fixed(s),
        None if std::env::var("PROPTEST_CASES").is_err() => RngSeed::Fixed(fixed),
        None => RngSeed::Random,
    }
}

/// The potential energy a native run's projections of a penetration gained, J/m, as its notes
/// give it (`Stepper::projected_energy`); `None` if no note gives it.
pub fn projected_energy(notes: &[String]) -> Option<f64> {
    const BEFORE: &str = "position projections after impacts (gaining ";
    notes.iter().find_map(|n| {
        let rest = &n[n.find(BEFORE)? + BEFORE.len()..];
        rest[..rest.find(' ')?].parse().ok()
    })
}

/// The number of cases of a property test: PROPTEST_CASES, or `default` (`make test`).
pub fn proptest_cases(default: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// A back-end whose solutions carry an error: every displacement moved by `eps`, the sign
/// alternating from solve to solve (as the sparse back-end's round-off does on a large wall, by
/// a few 1e-13 m), so that an iteration of solves cannot settle below it.
pub struct AlternatingError {
    inner: Box<dyn rockbench::native::solver::ContactSolver>,
    eps: f64,
    sign: f64,
}

impl AlternatingError {
    pub fn new(inner: Box<dyn rockbench::native::solver::ContactSolver>, eps: f64) -> Self {
        AlternatingError {
            inner,
            eps,
            sign: 1.0,
        }
    }
}

impl rockbench::native::solver::ContactSolver for AlternatingError {
    fn name(&self) -> &'static str {
        "a back-end with an alternating error"
    }
    fn solve_into(
        &mut self,
        p: &rockbench::native::StepProblem,
        out: &mut rockbench::native::StepSolution,
    ) -> Result<(), rockbench::native::solver::SolveFailure> {
        self.inner.solve_into(p, out)?;
        self.sign = -self.sign;
        for d in &mut out.dq {
            *d += self.sign * self.eps;
        }
        Ok(())
    }
    fn save(&self) -> Vec<u8> {
        self.inner.save()
    }
    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        self.inner.restore(state)
    }
}

/// A two-column acceleration record, `scale * sin(omega t)` m/s^2 every millisecond over
/// `samples` samples.
pub fn sine_record(scale: f64, omega: f64, samples: usize) -> String {
    let mut csv = String::from("time,acceleration\n");
    for k in 0..samples {
        let t = k as f64 * 1e-3;
        csv += &format!("{t},{}\n", scale * (omega * t).sin());
    }
    csv
}
