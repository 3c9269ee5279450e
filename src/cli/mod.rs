//! The `rockbench` command line: one file per subcommand.

mod animate;
mod bench;
mod check;
mod compare;
mod converge;
mod fragility;
mod gate;
mod references;
mod run;
mod sensitivity;
mod spectrum;
mod stress;
mod validate;

use anyhow::Result;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "rockbench",
    version = crate::build_info::LONG_VERSION,
    about = "Rigid-block rocking: native theta-method QP solver and cross-validation harness"
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run one engine on a scene; writes DIR/trajectory.csv and DIR/summary.json.
    Run(run::RunArgs),
    /// Check a scene file without running it.
    Check(check::CheckArgs),
    /// Run several engines on a scene and compare them with a reference; writes metrics and
    /// a report (DIR/report.html, DIR/report.md).
    Compare(compare::CompareArgs),
    /// Evaluate accuracy gates (GATES.toml); exits 1 when a gate fails or a known failure
    /// starts passing.
    Gate(gate::GateArgs),
    /// Work-precision benchmark: every engine at every step size, median wall time against
    /// the error; writes DIR/work_precision.{csv,md,svg}.
    Bench(bench::BenchArgs),
    /// Observed order of accuracy: every engine at a series of step sizes against a
    /// reference; writes DIR/converge.{csv,md,json}, orders.csv and log-log SVGs.
    Converge(converge::ConvergeArgs),
    /// Run the validation suite on every engine with its gates; writes DIR/report.html with
    /// the summary matrix (case x engine).
    Validate(validate::ValidateArgs),
    /// Regenerate the generated validation scenes and reference-data/ (or check them).
    References(references::ReferencesArgs),
    /// Stability map: every engine over a grid of scenes, each judged against its contract.
    Stress(stress::StressArgs),
    /// Animate runs made with `rockbench run` (RUN_DIR/trajectory.csv, summary.json and the
    /// scene): one self-contained HTML page, optionally a video.
    Animate(animate::AnimateArgs),
    /// Overturning spectra of a block (or stack) under pulse families: minimum overturning
    /// amplitude per frequency ratio and the overturn/safe map, every engine; writes
    /// DIR/minimum.csv, map.csv, `spectrum-<pulse>.svg` and spectrum.json.
    Spectrum(spectrum::SpectrumArgs),
    /// Fragility study (STUDY.toml): scenes x record suite x intensity levels x engines, by
    /// stripes and IDA, fitted curves with bootstrap intervals; writes DIR/report.html,
    /// outcomes.csv, fits.csv, differences.csv, capacities.csv and fragility.json.
    Fragility(fragility::FragilityArgs),
    /// A scene run as ensembles perturbed at round-off, one per configuration: the spread of
    /// each, and whether two configurations differ beyond it; writes DIR/runs.csv and
    /// DIR/sensitivity.md (resumes an interrupted study).
    Sensitivity(sensitivity::SensitivityArgs),
}

/// The options of the commands that run engines through the run cache (`gate`, `validate`).
#[derive(clap::Args)]
pub(crate) struct RunCacheArgs {
    /// Run cache directory (also $ROCKBENCH_CACHE_DIR).
    #[arg(long, env = "ROCKBENCH_CACHE_DIR", default_value = ".cache/rockbench")]
    cache_dir: std::path::PathBuf,
    /// Run every engine again (the cache is neither read nor written).
    #[arg(long)]
    no_cache: bool,
    /// Engines run at once (default: the number of cores, at most 2).
    #[arg(long)]
    jobs: Option<usize>,
    /// No progress indicator on stderr.
    #[arg(long)]
    quiet: bool,
}

impl RunCacheArgs {
    /// The cache directory, made if need be, or `None` with `--no-cache`. A directory that
    /// cannot be made is an error (runs would silently go uncached).
    pub(crate) fn cache_dir(&self) -> Result<Option<std::path::PathBuf>> {
        if self.no_cache {
            return Ok(None);
        }
        std::fs::create_dir_all(&self.cache_dir)
            .map_err(|e| anyhow::anyhow!("--cache-dir: {}: {e}", self.cache_dir.display()))?;
        Ok(Some(self.cache_dir.clone()))
    }
    /// Engines run at once ([`check_jobs`] first).
    pub(crate) fn jobs(&self) -> Result<usize> {
        check_jobs(self.jobs)?;
        Ok(self.jobs.unwrap_or_else(crate::compare::default_jobs))
    }
    pub(crate) fn progress(&self) -> bool {
        !self.quiet
    }
}

/// The `--help` text of an engine option: its own line, then every engine of the registry and
/// whether it runs here.
pub(crate) fn engines_help(first: &str) -> String {
    format!("{first}\n\n{}", crate::engines::registry::help())
}

/// Most parallel runs `--jobs` may ask for: each is a thread with its own engine, and far more
/// threads than cores only cost memory and time.
const MAX_JOBS: usize = 256;

/// `--jobs` checked before any work: at least 1, at most [`MAX_JOBS`].
pub(crate) fn check_jobs(jobs: Option<usize>) -> Result<()> {
    match jobs {
        Some(0) => anyhow::bail!("--jobs: at least 1 (got 0)"),
        Some(j) if j > MAX_JOBS => anyhow::bail!("--jobs: at most {MAX_JOBS} (got {j})"),
        _ => Ok(()),
    }
}

/// `--out` checked before any work: a path that exists and is not a directory cannot take
/// the command's files, and saying so after the runs would waste them.
/// The longest number of seconds a flag may give (some 30 years: a larger one is a slip).
const MAX_SECONDS: f64 = 1e9;

/// A flag's number of seconds as a duration: finite, below [`MAX_SECONDS`], and positive (or
/// also zero, with `zero_ok`).
pub(crate) fn seconds(flag: &str, value: f64, zero_ok: bool) -> Result<std::time::Duration> {
    let low_ok = value > 0.0 || (zero_ok && value == 0.0);
    if !(value.is_finite() && low_ok && value <= MAX_SECONDS) {
        let least = if zero_ok { ">= 0" } else { "> 0" };
        anyhow::bail!(
            "{flag}: must be a number of seconds {least} and at most {MAX_SECONDS:e} (got {})",
            crate::scene::num(value)
        );
    }
    Ok(std::time::Duration::from_secs_f64(value))
}

/// `--set` overrides checked before any work: a key given twice is refused (the last one
/// would win without a word).
pub(crate) fn check_sets(sets: &[String]) -> Result<()> {
    crate::scene::check_override_keys(sets).map_err(|e| anyhow::anyhow!("--set: {e}"))
}

/// An input of a command that its outputs would write over or remove: an input file inside
/// `out`, or `out` itself an input's folder where `files` would land on the input.
pub(crate) fn check_input_outside(
    out: &std::path::Path,
    flag: &str,
    input: &std::path::Path,
    files: &[&str],
) -> Result<()> {
    let (Ok(input_real), true) = (input.canonicalize(), out.exists()) else {
        return Ok(());
    };
    let out_real = out.canonicalize()?;
    let written = files
        .iter()
        .any(|f| out.join(f).canonicalize().is_ok_and(|p| p == input_real));
    if written || (files.is_empty() && input_real.starts_with(&out_real)) {
        anyhow::bail!(
            "--out: {} would write over {flag} {}: give another folder",
            out.display(),
            input.display()
        );
    }
    Ok(())
}

/// Whether two paths name one file or directory (spelt alike, or resolving to one).
pub(crate) fn same_file(a: &std::path::Path, b: &std::path::Path) -> bool {
    if a == b {
        return true;
    }
    let resolved = |p: &std::path::Path| {
        p.canonicalize().ok().or_else(|| {
            // A file not written yet: its folder resolved, its name kept.
            let parent = p.parent().filter(|q| !q.as_os_str().is_empty());
            let folder = parent.map_or_else(std::env::current_dir, |q| q.canonicalize());
            Some(folder.ok()?.join(p.file_name()?))
        })
    };
    matches!((resolved(a), resolved(b)), (Some(x), Some(y)) if x == y)
}

/// An output file (`flag`, e.g. `--junit`) that would write over one of a command's inputs,
/// each named by what it is (`the gate file`, a run's `trajectory.csv`, ...).
pub(crate) fn check_not_an_input(
    out: &std::path::Path,
    flag: &str,
    inputs: &[(String, std::path::PathBuf)],
) -> Result<()> {
    if let Some((what, _)) = inputs.iter().find(|(_, p)| same_file(out, p)) {
        anyhow::bail!(
            "{flag} {}: is {what}, an input: give another file",
            out.display()
        );
    }
    Ok(())
}

/// Remove from `out` the files a previous run of the same command wrote and this one does
/// not (`stale`): names, or `prefix*suffix` patterns. Files a command does not write are
/// left alone.
pub(crate) fn remove_stale(out: &std::path::Path, stale: &[&str]) -> Result<()> {
    let Ok(entries) = std::fs::read_dir(out) else {
        return Ok(());
    };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let matches = stale.iter().any(|p| match p.split_once('*') {
            Some((pre, suf)) => name.starts_with(pre) && name.ends_with(suf),
            None => name == *p,
        });
        if matches {
            let path = e.path();
            let gone = if path.is_dir() {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
            gone.map_err(|err| anyhow::anyhow!("{}: {err}", path.display()))?;
        }
    }
    Ok(())
}

/// `--out` is a folder that can be made and written in (checked before any run).
pub(crate) fn check_out_dir(out: &std::path::Path) -> Result<()> {
    if out.exists() && !out.is_dir() {
        anyhow::bail!("--out: {} is a file, not a directory", out.display());
    }
    crate::writable::check_can_write_in(out)
        .map_err(|e| anyhow::anyhow!("--out: {}: {e}", out.display()))
}

/// A command line clap refuses, as one line: its message, its tips and the usage of the
/// command it was parsing (clap's own text spreads these over several lines).
fn parse_error_line(rendered: &str) -> String {
    let mut message = String::new();
    let mut usage = None;
    for line in rendered.lines().map(str::trim).filter(|l| !l.is_empty()) {
        if let Some(u) = line.strip_prefix("Usage:") {
            usage = Some(u.trim().to_string());
        } else if line.starts_with("For more information") {
            continue;
        } else if message.is_empty() {
            message = line.to_string();
        } else if message.ends_with(':') {
            message = format!("{message} {line}");
        } else {
            message = format!("{message}; {line}");
        }
    }
    match usage {
        Some(u) => format!("{message} (usage: {u}; see --help)"),
        None => format!("{message} (see --help)"),
    }
}

/// The environment variable of the run cache's folder (`--cache-dir`).
const CACHE_DIR_ENV: &str = "ROCKBENCH_CACHE_DIR";

/// clap reads an empty `$ROCKBENCH_CACHE_DIR` as `--cache-dir` given without its value: the
/// line that says so names the variable, not a flag that is not on the command line.
fn empty_env_line(rendered: &str, cache_env_empty: bool) -> Option<String> {
    (cache_env_empty && rendered.contains("a value is required for '--cache-dir")).then(|| {
        format!(
            "error: ${CACHE_DIR_ENV} is set but empty: unset it, or name a folder in it or in --cache-dir"
        )
    })
}

/// Parse the command line and run it.
pub fn main() -> Result<()> {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // `--help` and `--version` print to standard output and succeed; a command line
        // without its subcommand prints the help (and fails) as clap does.
        Err(e)
            if !e.use_stderr()
                || e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        Err(e) => {
            let rendered = e.render().to_string();
            let empty_cache_env = std::env::var_os(CACHE_DIR_ENV).is_some_and(|v| v.is_empty());
            match empty_env_line(&rendered, empty_cache_env) {
                Some(line) => eprintln!("{line}"),
                None => eprintln!("{}", parse_error_line(&rendered)),
            }
            std::process::exit(e.exit_code());
        }
    };
    match cli.command {
        Command::Run(a) => run::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Sensitivity(a) => sensitivity::run(a),
        Command::Converge(a) => converge::run(a),
        Command::Check(a) => check::check(a),
        Command::Compare(a) => compare::compare_cmd(a),
        Command::Gate(a) => gate::gate_cmd(a),
        Command::Validate(a) => validate::validate_cmd(a),
        Command::References(a) => references::references_cmd(a),
        Command::Stress(a) => stress::stress(a),
        Command::Animate(a) => animate::animate(a),
        Command::Spectrum(a) => spectrum::run(a),
        Command::Fragility(a) => fragility::run(a),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_command_line_is_one_line_with_its_tip_and_usage() {
        let e = match Cli::try_parse_from(["rockbench", "run", "--dt", "1e-3", "s.toml"]) {
            Err(e) => e,
            Ok(_) => panic!("`run --dt` parsed"),
        };
        let line = parse_error_line(&e.render().to_string());
        assert!(!line.contains('\n'), "{line}");
        assert!(
            line.starts_with("error: unexpected argument '--dt' found"),
            "{line}"
        );
        assert!(line.contains("tip: to pass '--dt' as a value"), "{line}");
        assert!(
            line.ends_with("(usage: rockbench run [OPTIONS] <SCENE>; see --help)"),
            "{line}"
        );
    }

    /// An empty `$ROCKBENCH_CACHE_DIR` is named as such (clap's own line names `--cache-dir`,
    /// which the command line does not hold); a `--cache-dir` given empty is clap's.
    #[test]
    fn an_empty_cache_dir_variable_is_named() {
        let e = match Cli::try_parse_from(["rockbench", "gate", "g.toml", "--cache-dir", ""]) {
            Err(e) => e,
            Ok(_) => panic!("an empty --cache-dir parsed"),
        };
        let rendered = e.render().to_string();
        let line = empty_env_line(&rendered, true).unwrap();
        assert!(
            line.contains("$ROCKBENCH_CACHE_DIR is set but empty"),
            "{line}"
        );
        assert_eq!(empty_env_line(&rendered, false), None);
    }

    #[test]
    fn help_is_not_an_error() {
        let e = match Cli::try_parse_from(["rockbench", "--help"]) {
            Err(e) => e,
            Ok(_) => panic!("`--help` ran a command"),
        };
        assert!(!e.use_stderr());
        assert_eq!(e.exit_code(), 0);
    }
}
