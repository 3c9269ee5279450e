//! Sensitivity studies: a scene run as ensembles, one per configuration, to tell whether two
//! settings (or engines) give different answers where the answer is decided at round-off (a
//! wall in motion; docs/walls.md, "A sliding wall's answer is decided at round-off").
//!
//! Each configuration runs the scene `members` times, member `k` with one scene value set to
//! `VALUE (1 + k epsilon)` (1e-12: a perturbation at round-off level). Per run: every block's
//! final horizontal displacement ([`crate::metrics::displacement`]), the blocks that
//! overturned, and the cost. Per configuration ([`crate::metrics::ensemble`]): the ensemble's
//! spread, how its mean differs from the first configuration's and from every other's, in mm
//! and in standard errors of that difference, and whether its members overturn the same blocks.
//!
//! A configuration is `ENGINE[:KEY=VALUE[;KEY=VALUE...]]` (scene overrides, as `--set`).
//! Every run is appended to `OUT/runs.csv` as it ends, and a run already there is not run
//! again: an interrupted study resumes where it stopped. `OUT/runs.csv` starts with the study's
//! parameters (the scene's text and its record files hashed); another study's directory is refused. Every
//! configuration's scene is checked before anything is written. Writes `OUT/sensitivity.md`.

use crate::bench::median;
use crate::engines::registry::load_scene_with_overrides;
use crate::engines::{engine_by_name, run_timed_reporting};
use crate::metrics::displacement;
use crate::metrics::ensemble::Ensemble;
use anyhow::{Context, bail};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// One configuration: an engine and the scene overrides it runs with.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// As given: `ENGINE[:KEY=VALUE[;KEY=VALUE...]]`.
    pub label: String,
    pub engine: String,
    pub sets: Vec<String>,
}

/// Configurations separated by commas, each an engine of the registry.
pub fn parse_configs(text: &str) -> anyhow::Result<Vec<Config>> {
    let mut configs: Vec<Config> = Vec::new();
    for label in text.split(',').map(str::trim) {
        let (engine, sets) = label.split_once(':').unwrap_or((label, ""));
        if engine.is_empty() {
            bail!("--configs: a configuration without an engine: {label:?}");
        }
        if let Err(e) = engine_by_name(engine) {
            bail!("--configs: {label:?}: {e}");
        }
        let sets: Vec<String> = sets
            .split(';')
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect();
        if let Some(s) = sets.iter().find(|s| !s.contains('=')) {
            bail!("--configs: {label:?}: {s:?} is not KEY=VALUE");
        }
        // A key given twice: the last would win without a word.
        if let Err(e) = crate::scene::check_override_keys(&sets) {
            bail!("--configs: {label:?}: {e}");
        }
        // Another engine's setting: this configuration's engine would not read it.
        if let Some(s) = sets
            .iter()
            .find(|s| other_engines_setting(s, engine).is_some())
        {
            bail!(
                "--configs: {label:?}: {s} is a setting of engine `{}`, not of `{engine}`",
                other_engines_setting(s, engine).unwrap_or_default()
            );
        }
        if configs.iter().any(|c| c.label == label) {
            bail!("--configs: {label:?} given twice");
        }
        let mut sorted = sets.clone();
        sorted.sort();
        if let Some(c) = configs.iter().find(|c| {
            let mut theirs = c.sets.clone();
            theirs.sort();
            c.engine == engine && theirs == sorted
        }) {
            bail!("--configs: {label:?} makes the same runs as {:?}", c.label);
        }
        configs.push(Config {
            label: label.to_string(),
            engine: engine.to_string(),
            sets,
        });
    }
    Ok(configs)
}

/// The engine whose table `set` (`KEY=VALUE` or `KEY`) writes, when `engine` does not read
/// that table (`auto` reads native's and Housner's).
fn other_engines_setting<'a>(set: &'a str, engine: &str) -> Option<&'a str> {
    let table = set.split(['=', '.']).next()?.trim();
    let read = table == engine || (engine == "auto" && ["native", "housner"].contains(&table));
    (!read && crate::engines::registry::names().contains(&table)).then_some(table)
}

/// A study: the scene, what is perturbed, and the configurations.
#[derive(Debug, Clone)]
pub struct Study {
    /// The scene file (its records are read beside it).
    pub scene: PathBuf,
    /// What the report says the scene is.
    pub about: String,
    /// The perturbed scene value (`KEY`) and its value.
    pub perturb: (String, f64),
    pub epsilon: f64,
    pub members: usize,
    pub configs: Vec<Config>,
    /// Overrides of every run, before the perturbation and the configuration's own.
    pub sets: Vec<String>,
}

/// One run of a study.
#[derive(Debug, Clone)]
pub struct Run {
    pub config: String,
    pub member: usize,
    pub wall_s: f64,
    pub steps: u64,
    pub engine_version: String,
    /// The overturned blocks' indices.
    pub overturned: Vec<usize>,
    pub final_dx: Vec<f64>,
}

/// The most members of a configuration.
pub const MAX_MEMBERS: usize = 1000;
/// The smallest relative perturbation between neighbouring members.
pub const MIN_EPSILON: f64 = 1e-14;

impl Study {
    /// Check the study: its numbers, every configuration's scene, and the runs already in
    /// `out` (refused if they are another study's). Returns the blocks' names and those runs.
    pub fn check(&self, out: &Path) -> anyhow::Result<(Vec<String>, Vec<Run>)> {
        if !(2..=MAX_MEMBERS).contains(&self.members) {
            bail!(
                "--members: from 2 to {MAX_MEMBERS} (got {}): each is a run of every configuration",
                self.members
            );
        }
        if !(self.epsilon >= MIN_EPSILON && self.epsilon < 1e-3) {
            bail!(
                "--epsilon: must be from {MIN_EPSILON:e} (some 45 units in the last place: below it the members' values round to the same number) to below 1e-3 (got {})",
                crate::scene::num(self.epsilon)
            );
        }
        let (key, value) = &self.perturb;
        if !(value.is_finite() && *value != 0.0) {
            bail!(
                "--perturb: {key} must be finite and non-zero (got {})",
                crate::scene::num(*value)
            );
        }
        if self.configs.is_empty() {
            bail!("--configs: none given");
        }
        // A `--set` of the perturbed value (or of a table holding it) is replaced by the
        // perturbation without a word.
        if let Some(s) = self
            .sets
            .iter()
            .find(|s| crate::scene::override_covers(s, key))
        {
            bail!("--set {s}: sets {key}, the perturbed value, which --perturb replaces");
        }
        // A perturbation too small to change the value (a subnormal value times 1 + epsilon
        // rounds to itself) gives every member the same scene, whatever the configuration.
        let member = |k: usize| {
            let value = value * (1.0 + k as f64 * self.epsilon);
            let mut sets = self.sets.clone();
            sets.push(format!("{key}={value:?}"));
            load_scene_with_overrides(&self.scene, &sets).map(|s| s.to_json())
        };
        if member(0)? == member(1)? {
            bail!(
                "--perturb: {key} = {} and the next member's value round to the same scene: \
                 perturb a larger value",
                crate::scene::num(*value)
            );
        }
        // A perturbed setting of another engine's table: the configuration's engine does not
        // read it, and its members would not differ.
        if let Some(c) = self
            .configs
            .iter()
            .find(|c| other_engines_setting(key, &c.engine).is_some())
        {
            bail!(
                "--perturb: {key} is a setting of engine `{}`, which configuration {:?} does not read",
                other_engines_setting(key, &c.engine).unwrap_or_default(),
                c.label
            );
        }
        // A configuration that sets the perturbed value, however written (a key or a table),
        // gives every member the same scene; two configurations of one engine whose scenes
        // are the same (`dt=5e-4` and `dt=0.0005`) make the same runs.
        let mut firsts: Vec<(&Config, serde_json::Value)> = Vec::new();
        for c in &self.configs {
            let first = load_scene_with_overrides(&self.scene, &self.run_sets(c, 0))
                .with_context(|| c.label.clone())?;
            let second = load_scene_with_overrides(&self.scene, &self.run_sets(c, 1))
                .with_context(|| c.label.clone())?;
            if first.to_json() == second.to_json() {
                bail!(
                    "--configs: {:?} sets {key}, the perturbed value: its members would not be perturbed",
                    c.label
                );
            }
            let first = first.to_json();
            if let Some((same, _)) = firsts
                .iter()
                .find(|(o, scene)| o.engine == c.engine && *scene == first)
            {
                bail!(
                    "--configs: {:?} makes the same runs as {:?}",
                    c.label,
                    same.label
                );
            }
            firsts.push((c, first));
        }
        let base = load_scene_with_overrides(&self.scene, &self.sets)?;
        let names: Vec<String> = base.blocks.iter().map(|b| b.name.clone()).collect();
        let runs = read_runs(&out.join("runs.csv"), &self.parameters()?, names.len())?;
        // Runs of members or configurations this study does not ask for stay in the file
        // but not in its ensembles.
        let runs = runs
            .into_iter()
            .filter(|r| r.member < self.members && self.configs.iter().any(|c| c.label == r.config))
            .collect();
        Ok((names, runs))
    }

    /// Run what is not in `out` yet, then write `out/sensitivity.md`; returns its text.
    /// `progress` receives a line after each run.
    pub fn run(&self, out: &Path, progress: &dyn Fn(&str)) -> anyhow::Result<String> {
        let (names, mut runs) = self.check(out)?;
        std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
        let runs_path = out.join("runs.csv");
        drop_unfinished_line(&runs_path)?;
        if std::fs::metadata(&runs_path).map_or(true, |m| m.len() == 0) {
            let header: String = names.iter().map(|n| format!(",{n}")).collect();
            std::fs::write(
                &runs_path,
                format!(
                    "{}\nconfig,member,wall_s,steps,engine_version,overturned{header}\n",
                    self.parameters()?
                ),
            )
            .with_context(|| format!("cannot write {}", runs_path.display()))?;
        }
        let mut file = std::fs::OpenOptions::new()
            .append(true)
            .open(&runs_path)
            .with_context(|| format!("cannot append to {}", runs_path.display()))?;
        let total = self.configs.len() * self.members;
        for c in &self.configs {
            for k in 0..self.members {
                if runs.iter().any(|r| r.config == c.label && r.member == k) {
                    continue;
                }
                // A Ctrl-C (`rockbench sensitivity`) starts no run after it and stops the one
                // under way, which is not written; the lines written resume the study.
                let stopped = || {
                    crate::interrupt::Stopped(format!(
                        "interrupted after {} of {total} runs; they are kept in {}, and the same command resumes the study from them",
                        self.done(&runs),
                        runs_path.display()
                    ))
                };
                if crate::interrupt::requested() {
                    return Err(stopped().into());
                }
                let scene = load_scene_with_overrides(&self.scene, &self.run_sets(c, k))?;
                let engine = engine_by_name(&c.engine)?;
                let made = run_timed_reporting(
                    engine.as_ref(),
                    &scene,
                    &crate::interrupt::go_on_unless_interrupted,
                );
                if crate::interrupt::requested() {
                    return Err(stopped().into());
                }
                let (o, s) = made.with_context(|| format!("{}, member {k}", c.label))?;
                let window = (0.0, scene.duration);
                let run = Run {
                    config: c.label.clone(),
                    member: k,
                    wall_s: s.wall_time_s,
                    steps: s.steps,
                    engine_version: s.engine_version.replace(',', ";"),
                    overturned: (0..names.len())
                        .filter(|&i| s.blocks[i].overturned)
                        .collect(),
                    final_dx: (0..names.len())
                        .map(|i| displacement(&o.trajectory, i, window).0.unwrap_or(f64::NAN))
                        .collect(),
                };
                // One engine version a configuration: a resumed study whose engine changed
                // would mix two engines' runs in one ensemble.
                if let Some(earlier) = runs
                    .iter()
                    .find(|r| r.config == c.label && r.engine_version != run.engine_version)
                {
                    bail!(
                        "{}: configuration {:?}'s runs were made with {} {}, its member {k} now \
                         with {}: one study is one engine version (remove the file, or give \
                         another --out)",
                        runs_path.display(),
                        c.label,
                        c.engine,
                        earlier.engine_version,
                        run.engine_version
                    );
                }
                let overturned: Vec<String> =
                    run.overturned.iter().map(|i| i.to_string()).collect();
                let dx: String = run.final_dx.iter().map(|x| format!(",{x:?}")).collect();
                // One write a line: an interruption leaves whole lines and at most one
                // unfinished last line, which the next run drops.
                let line = format!(
                    "{},{},{},{},{},{}{dx}\n",
                    run.config,
                    run.member,
                    run.wall_s,
                    run.steps,
                    run.engine_version,
                    overturned.join(";")
                );
                file.write_all(line.as_bytes())?;
                file.flush()?;
                runs.push(run);
                progress(&format!(
                    "[{}/{total}] {}, member {k}: {:.1} s, {:.2} ms a step",
                    self.done(&runs),
                    c.label,
                    s.wall_time_s,
                    1e3 * s.wall_time_s / s.steps.max(1) as f64
                ));
            }
        }
        let md = self.render(out, &names, &runs)?;
        let md_path = out.join("sensitivity.md");
        std::fs::write(&md_path, &md)
            .with_context(|| format!("cannot write {}", md_path.display()))?;
        Ok(md)
    }

    /// The overrides of member `k` of configuration `c`.
    fn run_sets(&self, c: &Config, k: usize) -> Vec<String> {
        let (key, value) = &self.perturb;
        let mut sets = self.sets.clone();
        sets.push(format!(
            "{key}={:?}",
            value * (1.0 + k as f64 * self.epsilon)
        ));
        sets.extend(c.sets.iter().cloned());
        sets
    }

    /// The first line of `runs.csv`: what makes two studies' runs comparable (the scene's
    /// text and the record files it reads, hashed).
    fn parameters(&self) -> anyhow::Result<String> {
        let text = crate::input_file::read_to_string(&self.scene)
            .with_context(|| format!("cannot read {}", self.scene.display()))?;
        let base = load_scene_with_overrides(&self.scene, &self.sets)?;
        let records = serde_json::to_string(&base.record_hashes()).expect("hashes serialise");
        let (key, value) = &self.perturb;
        Ok(format!(
            "# sensitivity: scene {:016x}, records {:016x}, {key} = {value:?} x (1 + k {:e}), sets [{}], rockbench {} (sources {})",
            text_hash(&text),
            text_hash(&records),
            self.epsilon,
            self.sets.join(" "),
            crate::build_info::VERSION,
            crate::build_info::SOURCE_HASH
        ))
    }

    /// Runs of this study's configurations and members done.
    fn done(&self, runs: &[Run]) -> usize {
        self.configs
            .iter()
            .map(|c| {
                (0..self.members)
                    .filter(|&m| runs.iter().any(|r| r.config == c.label && r.member == m))
                    .count()
            })
            .sum()
    }

    fn render(&self, out: &Path, names: &[String], runs: &[Run]) -> anyhow::Result<String> {
        let (key, value) = &self.perturb;
        let mut md = String::new();
        let _ = writeln!(
            md,
            "# A scene's answer as an ensemble\n\n{}; {} members a configuration, member k with \
             `{key}` = {value:?} x (1 + k {:e}){}. Final horizontal displacements of every \
             block, relative to the ground (the scene `{}`; the runs in `{}`). Spread: RMS over \
             the blocks of the members' sample deviation (largest in brackets). Difference: of \
             each ensemble's mean from the first configuration's, RMS over the blocks (largest \
             in brackets), and over its standard error (docs/quantities.md, \"Ensembles\"). \
             Overturned: each member's count, and the blocks that some members overturn and \
             others do not.\n",
            self.about,
            self.members,
            self.epsilon,
            if self.sets.is_empty() {
                String::new()
            } else {
                format!(", every run with `{}`", self.sets.join(" "))
            },
            self.scene.display(),
            out.join("runs.csv").display()
        );
        let _ = writeln!(
            md,
            "| configuration | engine version | ms a step (median) | s a run (median) | mean shift, mm (largest) | spread, mm | difference, mm | in standard errors | overturned | not in every member |\n|---|---|---|---|---|---|---|---|---|---|"
        );
        let mut ensembles: Vec<Ensemble> = Vec::new();
        for c in &self.configs {
            let mine: Vec<&Run> = runs.iter().filter(|r| r.config == c.label).collect();
            let e = Ensemble::of(&mine.iter().map(|r| r.final_dx.clone()).collect::<Vec<_>>())
                .map_err(|e| anyhow::anyhow!("{}: {e}", c.label))?;
            let step_ms = median(
                mine.iter()
                    .map(|r| 1e3 * r.wall_s / r.steps.max(1) as f64)
                    .collect(),
            );
            let run_s = median(mine.iter().map(|r| r.wall_s).collect());
            let shift = e.mean.iter().sum::<f64>() / e.mean.len().max(1) as f64;
            let largest = e.mean.iter().fold(0.0f64, |a, x| a.max(x.abs()));
            let difference = match ensembles.first() {
                None => "(reference) | -".to_string(),
                Some(f) => difference_cells(&e, f)?,
            };
            let counts: Vec<String> = mine
                .iter()
                .map(|r| r.overturned.len().to_string())
                .collect();
            let split: Vec<&str> = (0..names.len())
                .filter(|i| {
                    let n = mine.iter().filter(|r| r.overturned.contains(i)).count();
                    n > 0 && n < mine.len()
                })
                .map(|i| names[i].as_str())
                .collect();
            let _ = writeln!(
                md,
                "| `{}` | {} | {step_ms:.3} | {run_s:.2} | {:.2} ({:.2}) | {:.3} ({:.3}) | {difference} | {} | {} |",
                c.label,
                mine[0].engine_version,
                1e3 * shift,
                1e3 * largest,
                1e3 * e.spread(),
                1e3 * e.largest_spread(),
                counts.join(" / "),
                if split.is_empty() {
                    "-".to_string()
                } else {
                    split.join(", ")
                }
            );
            ensembles.push(e);
        }
        let _ = writeln!(
            md,
            "\nEvery pair of configurations: the difference of their means, RMS over the blocks \
             (largest in brackets), and over its standard error.\n\n| configuration | against | \
             difference, mm | in standard errors |\n|---|---|---|---|"
        );
        for (i, a) in ensembles.iter().enumerate() {
            for (j, b) in ensembles.iter().enumerate().skip(i + 1) {
                let _ = writeln!(
                    md,
                    "| `{}` | `{}` | {} |",
                    self.configs[j].label,
                    self.configs[i].label,
                    difference_cells(b, a)?
                );
            }
        }
        let prov = crate::report::provenance::Provenance::collect("");
        let _ = writeln!(
            md,
            "\nRuns by {} on {}; a study resumes only with the same sources.",
            prov.program(),
            prov.machine()
        );
        Ok(md)
    }
}

/// `mm rms (largest) | ratio to the standard error` of `a` against `b`.
fn difference_cells(a: &Ensemble, b: &Ensemble) -> anyhow::Result<String> {
    let d = a.difference(b).map_err(|e| anyhow::anyhow!(e))?;
    Ok(format!(
        "{:.3} ({:.3}) | {}",
        1e3 * d.rms,
        1e3 * d.max,
        in_standard_errors(d.rms, d.standard_error)
    ))
}

/// A difference over its standard error. Ensembles without spread (deterministic runs: every
/// member the same) have none: their difference is none or infinitely many (0/0 read "NaN").
fn in_standard_errors(rms: f64, standard_error: f64) -> String {
    if standard_error == 0.0 {
        return if rms == 0.0 {
            "none (no spread, no difference)"
        } else {
            "inf (no spread)"
        }
        .into();
    }
    let ratio = rms / standard_error;
    if ratio < 1e3 {
        format!("{ratio:.1}")
    } else {
        format!("{ratio:.1e}")
    }
}

/// Cut an unfinished last line (a run interrupted while it was written) from `path`, so that
/// the next run's line starts on a line of its own. Its run is made again. Only the file's
/// tail is read, back to its last line end.
fn drop_unfinished_line(path: &Path) -> anyhow::Result<()> {
    use std::io::{Read as _, Seek as _, SeekFrom};
    const CHUNK: u64 = 64 * 1024;
    let cannot = || format!("cannot cut the unfinished last line of {}", path.display());
    let mut file = match std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
    {
        Ok(file) => file,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e).with_context(cannot),
    };
    let mut end = file.metadata().with_context(cannot)?.len();
    let mut chunk = vec![0u8; CHUNK as usize];
    let mut last = true;
    while end > 0 {
        let start = end.saturating_sub(CHUNK);
        let part = &mut chunk[..(end - start) as usize];
        file.seek(SeekFrom::Start(start)).with_context(cannot)?;
        file.read_exact(part).with_context(cannot)?;
        if last && part.last() == Some(&b'\n') {
            return Ok(());
        }
        last = false;
        if let Some(i) = part.iter().rposition(|&b| b == b'\n') {
            return file.set_len(start + i as u64 + 1).with_context(cannot);
        }
        end = start;
    }
    file.set_len(0).with_context(cannot)
}

/// The runs already in `path` (made with `parameters`, for `n_blocks` blocks). An unfinished
/// last line (no line end) is not a run; a run given twice, a block index beyond the scene's or
/// a displacement that is not finite is an error naming the line.
fn read_runs(path: &Path, parameters: &str, n_blocks: usize) -> anyhow::Result<Vec<Run>> {
    let text = match crate::input_file::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => bail!("cannot read {}: {e}", path.display()),
    };
    let mut lines = text.lines();
    let first = lines.next();
    if first != Some(parameters) {
        // The same study made by another program: its line differs only after `rockbench`.
        let study_and_program = |line: &str| {
            line.rsplit_once(", rockbench ")
                .map(|(s, p)| (s.to_string(), p.to_string()))
        };
        if let (Some((study, program)), Some((this_study, this_program))) = (
            first.and_then(study_and_program),
            study_and_program(parameters),
        ) && study == this_study
        {
            bail!(
                "{}: holds runs made by another build, rockbench {program}, which this one \
                 (rockbench {this_program}) does not resume: remove it or give another --out",
                path.display()
            );
        }
        bail!(
            "{}: holds the runs of another study (its first line is not {parameters:?}): remove \
             it or give another --out",
            path.display()
        );
    }
    lines.next(); // The header.
    let mut runs: Vec<Run> = Vec::new();
    let finished = if text.ends_with('\n') {
        usize::MAX
    } else {
        text.lines().count().saturating_sub(3)
    };
    for (k, line) in lines.enumerate() {
        if k >= finished {
            break;
        }
        let bad = || {
            format!(
                "{}: line {}: not a run of this study",
                path.display(),
                k + 3
            )
        };
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 + n_blocks {
            bail!("{}", bad());
        }
        let overturned = f[5]
            .split(';')
            .filter(|x| !x.is_empty())
            .map(|x| x.parse::<usize>())
            .collect::<Result<Vec<_>, _>>()
            .with_context(bad)?;
        let final_dx = f[6..]
            .iter()
            .map(|x| x.parse::<f64>())
            .collect::<Result<Vec<_>, _>>()
            .with_context(bad)?;
        let at = |what: String| format!("{}: line {}: {what}", path.display(), k + 3);
        if let Some(i) = overturned.iter().find(|&&i| i >= n_blocks) {
            bail!(
                "{}",
                at(format!("overturned block {i} of a scene of {n_blocks}"))
            );
        }
        if let Some(i) = final_dx.iter().position(|x| !x.is_finite()) {
            bail!(
                "{}",
                at(format!("the final displacement of block {i} is not finite"))
            );
        }
        let run = Run {
            config: f[0].to_string(),
            member: f[1].parse().with_context(bad)?,
            wall_s: f[2].parse().with_context(bad)?,
            steps: f[3].parse().with_context(bad)?,
            engine_version: f[4].to_string(),
            overturned,
            final_dx,
        };
        if runs
            .iter()
            .any(|r| r.config == run.config && r.member == run.member)
        {
            bail!(
                "{}",
                at(format!(
                    "a second run of {}, member {}",
                    run.config, run.member
                ))
            );
        }
        runs.push(run);
    }
    Ok(runs)
}

/// FNV-1a of the scene's text: a study's runs belong to one scene.
fn text_hash(text: &str) -> u64 {
    text.bytes().fold(0xcbf29ce484222325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100000001b3)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unfinished_last_line_is_cut_back_to_the_last_line_end() {
        let dir = std::env::temp_dir().join(format!("rockbench-unfinished-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("runs.csv");
        let cut = |text: &[u8]| {
            std::fs::write(&path, text).unwrap();
            drop_unfinished_line(&path).unwrap();
            std::fs::read(&path).unwrap()
        };
        assert_eq!(cut(b"a\nb\n"), b"a\nb\n");
        assert_eq!(cut(b"a\nb\nhalf"), b"a\nb\n");
        assert_eq!(cut(b"half"), b"");
        assert_eq!(cut(b""), b"");
        // A last line longer than the chunks read from the end, and a line end at a chunk's
        // last byte.
        let long = [b"head\n".as_slice(), &vec![b'x'; 200_000]].concat();
        assert_eq!(cut(&long), b"head\n");
        let at_edge = [vec![b'y'; 65_535], b"\n".to_vec(), vec![b'z'; 65_536]].concat();
        assert_eq!(cut(&at_edge), [vec![b'y'; 65_535], b"\n".to_vec()].concat());
        std::fs::remove_dir_all(&dir).unwrap();
        // No file: nothing to cut.
        drop_unfinished_line(&path).unwrap();
        assert!(!path.exists());
    }

    /// Deterministic ensembles (every member the same: a spread of 0) differ by none or by
    /// infinitely many standard errors; the table said "NaN" for 0/0.
    #[test]
    fn ensembles_without_spread_are_read_as_such() {
        let same = |x: f64| Ensemble::of(&[vec![x, 1.0], vec![x, 1.0]]).unwrap();
        let cell = |a: &Ensemble, b: &Ensemble| difference_cells(a, b).unwrap();
        assert!(cell(&same(0.5), &same(0.5)).ends_with("| none (no spread, no difference)"));
        assert!(cell(&same(0.5), &same(0.7)).ends_with("| inf (no spread)"));
        let spread = Ensemble::of(&[vec![0.5, 1.0], vec![0.7, 1.0]]).unwrap();
        let c = cell(&spread, &same(0.6));
        let ratio: f64 = c.rsplit("| ").next().unwrap().parse().unwrap();
        assert!(ratio.is_finite() && ratio < 1.0, "{c}");
    }

    #[test]
    fn configurations_parse_or_say_what_is_wrong() {
        let c = parse_configs("native,native:native.dt=5e-4;native.locate_impacts=false").unwrap();
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].engine, "native");
        assert!(c[0].sets.is_empty());
        assert_eq!(
            c[1].label,
            "native:native.dt=5e-4;native.locate_impacts=false"
        );
        assert_eq!(
            c[1].sets,
            vec!["native.dt=5e-4", "native.locate_impacts=false"]
        );
        let e = parse_configs("bogus").unwrap_err().to_string();
        assert!(e.contains("unknown engine"), "{e}");
        let e = parse_configs("native:native.dt").unwrap_err().to_string();
        assert!(e.contains("is not KEY=VALUE"), "{e}");
        let e = parse_configs("native,native").unwrap_err().to_string();
        assert!(e.contains("given twice"), "{e}");
        let e = parse_configs("native:a=1;b=2,native:b=2;a=1")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("makes the same runs as \"native:a=1;b=2\""),
            "{e}"
        );
        let e = parse_configs(":native.dt=1e-3").unwrap_err().to_string();
        assert!(e.contains("without an engine"), "{e}");
    }
}
