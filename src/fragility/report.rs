//! Outputs of a study: outcomes.csv (the record x level x engine matrix), capacities.csv,
//! fits.csv, differences.csv, fragility.json (all of it with the settings and versions),
//! report.html (every engine's and limit state's curve on one plot, stripe fractions as
//! points, bootstrap bands; the paired differences of medians) and `--paper`.

use super::run::Stop;
use super::study::Study;
use super::{Method, Results, Row};
use crate::paper::{PaperDir, booktabs, latex_escape, tex_num};
use crate::report::svg::{Curve, Marker, Plot};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

const COLORS: [&str; 6] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
];
const DASHES: [&str; 5] = ["", "6,3", "2,3", "8,3,2,3", "1,2"];

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.6}")).unwrap_or_default()
}
fn ci(x: Option<(f64, f64)>) -> (String, String) {
    (opt(x.map(|c| c.0)), opt(x.map(|c| c.1)))
}
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
fn method(m: Method) -> &'static str {
    match m {
        Method::Stripes => "stripes",
        Method::Ida => "ida",
    }
}

/// The columns of outcomes.csv before one column per limit state (named after it).
pub const OUTCOME_COLUMNS: [&str; 15] = [
    "scene",
    "engine",
    "record",
    "pair",
    "method",
    "level",
    "scale",
    "ran",
    "stop",
    "t_end",
    "wall_s",
    "cached",
    "max_rotation_over_alpha",
    "overturned",
    "max_residual_sliding_m",
];

/// outcomes.csv: one row per run, a column per limit state (1 where exceeded).
pub fn outcomes_csv(study: &Study, res: &Results) -> String {
    let mut s = OUTCOME_COLUMNS.join(",");
    for ls in &study.limit_states {
        let _ = write!(s, ",{}", csv_field(&ls.name));
    }
    s.push('\n');
    for r in &res.rows {
        let o = &r.outcome;
        let rot = o.rotation.iter().copied().fold(0.0, f64::max);
        let slide = if o.any_overturned() {
            String::new()
        } else {
            format!(
                "{:.6e}",
                o.sliding.iter().flatten().copied().fold(0.0, f64::max)
            )
        };
        let _ = write!(
            s,
            "{},{},{},{},{},{},{},{},{},{:.4},{:.4},{},{:.6},{},{}",
            csv_field(&r.scene),
            r.engine,
            csv_field(&r.record),
            csv_field(&r.pair),
            method(r.method),
            r.level,
            r.scale,
            o.ran,
            o.stop.name(),
            o.t_end,
            o.wall_s,
            r.cached,
            rot,
            o.any_overturned(),
            slide
        );
        for e in &r.exceeded {
            let _ = write!(s, ",{}", u8::from(*e));
        }
        s.push('\n');
    }
    s
}

pub fn capacities_csv(res: &Results) -> String {
    let mut s =
        String::from("scene,engine,record,pair,limit_state,capacity,censored,resurrection,runs\n");
    for c in &res.capacities {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{}",
            csv_field(&c.scene),
            c.engine,
            csv_field(&c.record),
            csv_field(&c.pair),
            csv_field(&c.limit_state),
            c.capacity,
            c.censored,
            c.resurrection,
            c.runs
        );
    }
    s
}

pub fn fits_csv(res: &Results) -> String {
    let mut s = String::from(
        "scene,engine,limit_state,method,theta,beta,theta_lo95,theta_hi95,beta_lo95,beta_hi95,resamples,problem\n",
    );
    for f in &res.fits {
        let (tl, th) = ci(f.theta_ci);
        let (bl, bh) = ci(f.beta_ci);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{tl},{th},{bl},{bh},{},{}",
            csv_field(&f.scene),
            f.engine,
            csv_field(&f.limit_state),
            method(f.method),
            opt(f.fit.map(|x| x.theta)),
            opt(f.fit.map(|x| x.beta)),
            f.resamples,
            csv_field(f.problem.as_deref().unwrap_or(""))
        );
    }
    s
}

pub fn differences_csv(res: &Results) -> String {
    let mut s = String::from(
        "scene,limit_state,method,engine,reference,theta_difference,difference_lo95,difference_hi95,theta_ratio,ratio_lo95,ratio_hi95,resamples\n",
    );
    for d in &res.differences {
        let (dl, dh) = ci(d.difference_ci);
        let (rl, rh) = ci(d.ratio_ci);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:.6},{dl},{dh},{:.6},{rl},{rh},{}",
            csv_field(&d.scene),
            csv_field(&d.limit_state),
            method(d.method),
            d.engine,
            d.reference,
            d.difference,
            d.ratio,
            d.resamples
        );
    }
    s
}

/// Each scene's settings of each engine of the study as the engine uses them (defaults filled
/// in), keyed by scene name and engine: `[native] dt`, its stepper, theta, Housner's
/// restitution, ... (the outputs named the engines' versions, not the settings that made them).
pub fn engine_settings(study: &Study) -> serde_json::Value {
    let per_scene = study.scenes.iter().map(|scene| {
        let tables = crate::engines::registry::settings(scene).unwrap_or_default();
        let engines = study.file.engines.iter().map(|e| {
            let table = crate::engines::registry::ENGINES
                .iter()
                .find(|x| x.name == e)
                .and_then(|x| x.settings)
                .and_then(|t| tables.get(t.table).cloned())
                .unwrap_or(serde_json::Value::Null);
            (e.clone(), table)
        });
        (
            scene.name.clone(),
            serde_json::Value::Object(engines.collect()),
        )
    });
    serde_json::Value::Object(per_scene.collect())
}

/// fragility.json: the study as read, the suite, the settings, versions, counts, every row,
/// capacity, fit and difference.
pub fn json(study: &Study, res: &Results, command: &str) -> serde_json::Value {
    serde_json::json!({
        "command": command,
        "rockbench_version": crate::build_info::VERSION,
        "rockbench_git_commit": crate::build_info::GIT_COMMIT,
        "rockbench_source_hash": crate::build_info::SOURCE_HASH,
        "study": study.file,
        "study_file": study.path.display().to_string(),
        "cache_dir": std::path::absolute(&study.cache_dir)
            .unwrap_or_else(|_| study.cache_dir.clone())
            .display()
            .to_string(),
        "limit_states": study.limit_states,
        "suite": {
            "name": study.suite.header.name,
            "manifest": study.suite.manifest.display().to_string(),
            "records": study.suite.records,
        },
        "scenes": study.scenes,
        "engine_versions": res.engine_versions,
        "engine_settings": engine_settings(study),
        "counts": res.counts,
        "grid": res.grid,
        "fits": res.fits,
        "differences": res.differences,
        "capacities": res.capacities,
        "rows": res.rows,
    })
}

/// One SVG: every engine (colour) and limit state (dash) of a scene and method: the fitted
/// curves, their 95 % bands (shaded), and the stripe fractions (points).
pub fn svg(study: &Study, res: &Results, scene: &str, m: Method) -> String {
    let (w, h, l, r, t, b) = (960.0, 420.0, 70.0, 290.0, 30.0, 50.0);
    let grid = &res.grid;
    let (x0, x1) = (grid[0].ln(), grid[grid.len() - 1].ln());
    let px = |x: f64| l + (x.ln() - x0) / (x1 - x0) * (w - l - r);
    let py = |p: f64| t + (1.0 - p) * (h - t - b);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"{w}\" height=\"{h}\" fill=\"white\"/>\n"
    );
    let _ = writeln!(
        s,
        "<text x=\"{l}\" y=\"18\" font-size=\"14\">{} - {} ({})</text>",
        esc(&study.file.name),
        esc(scene),
        method(m)
    );
    // Axes: log x with decade and 1-2-5 ticks, p from 0 to 1.
    for k in 0..=5 {
        let p = k as f64 / 5.0;
        let _ = writeln!(
            s,
            "<line x1=\"{l}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{p:.1}</text>",
            w - r,
            l - 6.0,
            py(p) + 4.0,
            y = py(p)
        );
    }
    let mut tick = 10f64.powf(x0.exp().log10().floor());
    while tick <= x1.exp() * 1.0001 {
        for m in [1.0, 2.0, 5.0] {
            let v = tick * m;
            if v.ln() >= x0 && v.ln() <= x1 {
                let _ = writeln!(
                    s,
                    "<line x1=\"{x:.1}\" x2=\"{x:.1}\" y1=\"{t}\" y2=\"{}\" stroke=\"#eee\"/><text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
                    h - b,
                    h - b + 16.0,
                    crate::scene::num((v * 1e6).round() / 1e6),
                    x = px(v)
                );
            }
        }
        tick *= 10.0;
    }
    let _ = writeln!(
        s,
        "<rect x=\"{l}\" y=\"{t}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/><text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text><text x=\"16\" y=\"{}\" transform=\"rotate(-90 16 {})\" text-anchor=\"middle\">P(limit state exceeded)</text>",
        w - l - r,
        h - t - b,
        l + 0.5 * (w - l - r),
        h - 10.0,
        esc(study.file.intensity.measure.label()),
        t + 0.5 * (h - t - b),
        t + 0.5 * (h - t - b)
    );
    let mut legend = 0;
    for (ei, e) in study.file.engines.iter().enumerate() {
        let col = COLORS[ei % COLORS.len()];
        for (k, ls) in study.limit_states.iter().enumerate() {
            let dash = DASHES[k % DASHES.len()];
            let Some(f) = res.fits.iter().find(|f| {
                f.scene == scene && &f.engine == e && f.limit_state == ls.name && f.method == m
            }) else {
                continue;
            };
            if let Some((lo, hi)) = &f.band {
                let mut pts: Vec<String> = grid
                    .iter()
                    .zip(hi)
                    .map(|(x, p)| format!("{:.1},{:.1}", px(*x), py(*p)))
                    .collect();
                pts.extend(
                    grid.iter()
                        .zip(lo)
                        .rev()
                        .map(|(x, p)| format!("{:.1},{:.1}", px(*x), py(*p))),
                );
                let _ = writeln!(
                    s,
                    "<polygon points=\"{}\" fill=\"{col}\" fill-opacity=\"0.08\" stroke=\"none\"/>",
                    pts.join(" ")
                );
            }
            if let Some(fit) = f.fit {
                let pts: Vec<String> = grid
                    .iter()
                    .map(|&x| format!("{:.1},{:.1}", px(x), py(fit.p(x))))
                    .collect();
                let _ = writeln!(
                    s,
                    "<polyline points=\"{}\" fill=\"none\" stroke=\"{col}\" stroke-width=\"1.8\" stroke-dasharray=\"{dash}\"/>",
                    pts.join(" ")
                );
            }
            // Stripe fractions.
            if m == Method::Stripes {
                let mut by: BTreeMap<u64, (f64, usize, usize)> = BTreeMap::new();
                for rw in res.rows.iter().filter(|rw| {
                    rw.method == Method::Stripes && rw.scene == scene && &rw.engine == e
                }) {
                    let x = by.entry(rw.level.to_bits()).or_insert((rw.level, 0, 0));
                    x.1 += 1;
                    x.2 += usize::from(rw.exceeded[k]);
                }
                for (lv, n, z) in by.values() {
                    let _ = writeln!(
                        s,
                        "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"{col}\" fill-opacity=\"0.7\"><title>{e} {} at {lv}: {z}/{n}</title></circle>",
                        px(*lv),
                        py(*z as f64 / *n as f64),
                        esc(&ls.name)
                    );
                }
            }
            let ly = t + 8.0 + 16.0 * legend as f64;
            let label = match f.fit {
                Some(fit) => format!(
                    "{e} {}: theta {:.3}, beta {:.2}",
                    ls.name, fit.theta, fit.beta
                ),
                None => format!("{e} {}: no fit", ls.name),
            };
            let _ = writeln!(
                s,
                "<line x1=\"{}\" x2=\"{}\" y1=\"{ly}\" y2=\"{ly}\" stroke=\"{col}\" stroke-width=\"2\" stroke-dasharray=\"{dash}\"/><text x=\"{}\" y=\"{}\" font-size=\"10\">{}</text>",
                w - r + 8.0,
                w - r + 30.0,
                w - r + 34.0,
                ly + 4.0,
                esc(&label)
            );
            legend += 1;
        }
    }
    s.push_str("</svg>\n");
    s
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Runs per engine: how they ended and what they cost when computed (a cached run keeps the
/// wall time of the run that computed it).
fn engine_table(study: &Study, res: &Results) -> String {
    let mut s = String::from(
        "<h2>Runs per engine</h2>\n<table><tr><th>engine</th><th>runs</th><th>from the cache</th><th>overturned (stopped)</th><th>at rest (stopped)</th><th>below tipping energy (stopped)</th><th>full length</th><th>simulated, s</th><th>run wall time, s</th><th>per run, s</th></tr>\n",
    );
    for e in &study.file.engines {
        let rows: Vec<&Row> = res.rows.iter().filter(|r| &r.engine == e).collect();
        let count = |stop: Stop| rows.iter().filter(|r| r.outcome.stop == stop).count();
        let wall: f64 = rows.iter().map(|r| r.outcome.wall_s).sum();
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.0}</td><td>{wall:.0}</td><td>{:.2}</td></tr>",
            esc(e),
            rows.len(),
            rows.iter().filter(|r| r.cached).count(),
            count(Stop::Overturned),
            count(Stop::AtRest),
            count(Stop::BelowTippingEnergy),
            count(Stop::End),
            rows.iter().map(|r| r.outcome.t_end).sum::<f64>(),
            wall / rows.len().max(1) as f64
        );
    }
    s += "</table>\n";
    s
}

pub fn html(study: &Study, res: &Results, command: &str) -> String {
    let mut s = format!(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>fragility: {n}</title><style>body{{font-family:sans-serif;max-width:1000px;margin:1em auto}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:2px 6px;font-size:13px}}</style></head><body>\n<h1>Fragility: {n}</h1>\n<p>Suite <b>{suite}</b> ({nrec} components), intensity {im}, levels {lv}; engines {eng}; {runs} runs ({cached} from the cache, {early} stopped early) in {wall:.1} s.</p>\n",
        n = esc(&study.file.name),
        suite = esc(&study.suite.header.name),
        nrec = study.suite.records.len(),
        im = esc(study.file.intensity.measure.label()),
        lv = study
            .file
            .intensity
            .levels
            .iter()
            .map(|x| crate::scene::num(*x))
            .collect::<Vec<_>>()
            .join(", "),
        eng = study.file.engines.join(", "),
        runs = res.counts.runs,
        cached = res.counts.cached,
        early = res.counts.early_stopped,
        wall = res.counts.wall_s,
    );
    s += &engine_table(study, res);
    s += "<p>Curves: P = Phi(ln(IM/theta)/beta) fitted by maximum likelihood (probit on ln IM for stripes, censored lognormal for IDA capacities); shaded: pointwise 95 % bootstrap band over record pairs; points: fraction of records exceeding at each stripe. An overturn exceeds every limit state.</p>\n";
    for scene in &study.scenes {
        for m in [Method::Stripes, Method::Ida] {
            if !res
                .fits
                .iter()
                .any(|f| f.scene == scene.name && f.method == m)
            {
                continue;
            }
            let _ = writeln!(s, "<h2>{} - {}</h2>", esc(&scene.name), method(m));
            s += &svg(study, res, &scene.name, m);
        }
    }
    s += "<h2>Fits</h2>\n<table><tr><th>scene</th><th>engine</th><th>limit state</th><th>method</th><th>theta</th><th>95 %</th><th>beta</th><th>95 %</th><th>note</th></tr>\n";
    for f in &res.fits {
        let (tl, th) = ci(f.theta_ci);
        let (bl, bh) = ci(f.beta_ci);
        let _ = writeln!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{tl} - {th}</td><td>{}</td><td>{bl} - {bh}</td><td>{}</td></tr>",
            esc(&f.scene),
            f.engine,
            esc(&f.limit_state),
            method(f.method),
            opt(f.fit.map(|x| x.theta)),
            opt(f.fit.map(|x| x.beta)),
            esc(&f
                .problem
                .clone()
                .or(f.resample_note(study.file.fit.bootstrap))
                .unwrap_or_default())
        );
    }
    s += "</table>\n";
    if !res.differences.is_empty() {
        s += "<h2>Engines' medians against the reference (paired bootstrap)</h2>\n<table><tr><th>scene</th><th>limit state</th><th>method</th><th>engine - reference</th><th>theta difference</th><th>95 %</th><th>ratio</th><th>95 %</th></tr>\n";
        for d in &res.differences {
            let (dl, dh) = ci(d.difference_ci);
            let (rl, rh) = ci(d.ratio_ci);
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{} - {}</td><td>{:.4}</td><td>{dl} - {dh}</td><td>{:.4}</td><td>{rl} - {rh}</td></tr>",
                esc(&d.scene),
                esc(&d.limit_state),
                method(d.method),
                d.engine,
                d.reference,
                d.difference,
                d.ratio
            );
        }
        s += "</table>\n";
    }
    let _ = writeln!(
        s,
        "<h2>Settings and versions</h2><pre>{}</pre><p>Versions: {}</p><p>Command: <code>{}</code></p><p>Data: <a href=\"outcomes.csv\">outcomes.csv</a>, <a href=\"capacities.csv\">capacities.csv</a>, <a href=\"fits.csv\">fits.csv</a>, <a href=\"differences.csv\">differences.csv</a>, <a href=\"fragility.json\">fragility.json</a>.</p></body></html>",
        esc(&toml::to_string(&study.file).unwrap_or_default()),
        esc(&res
            .engine_versions
            .iter()
            .map(|(k, v)| format!("{k}: {v}"))
            .collect::<Vec<_>>()
            .join("; ")),
        esc(command)
    );
    s
}

/// The file that marks a folder as a study's output, which a new run may replace whole.
const MARKER: &str = "fragility.json";

/// Check that `out` can take a study's outputs, before the study runs: the outputs replace the
/// folder whole, so it must be new, empty or a study's output (it holds `fragility.json`), and
/// neither the working directory nor one that holds it. Gives `out` made absolute.
pub fn replaceable_out(out: &Path) -> Result<PathBuf, String> {
    let abs = std::path::absolute(out).map_err(|e| format!("--out: {}: {e}", out.display()))?;
    if !abs.exists() {
        return Ok(abs);
    }
    let shown = out.display();
    if !abs.is_dir() {
        return Err(format!("--out: {shown} is a file, not a directory"));
    }
    let real = abs
        .canonicalize()
        .map_err(|e| format!("--out: {shown}: {e}"))?;
    if let Ok(cwd) = std::env::current_dir().and_then(|c| c.canonicalize())
        && cwd.starts_with(&real)
    {
        return Err(format!(
            "--out: {shown} is the working directory or holds it; the outputs replace their folder whole"
        ));
    }
    let empty = std::fs::read_dir(&real)
        .map_err(|e| format!("--out: {shown}: {e}"))?
        .next()
        .is_none();
    if !empty && !real.join(MARKER).is_file() {
        return Err(format!(
            "--out: {shown} holds files and no {MARKER}: not a study's output, which would replace it whole; give a new or empty folder"
        ));
    }
    Ok(abs)
}

/// [`replaceable_out`], the study's run cache (`cache`) outside `out` (the outputs replace the
/// folder whole, and a cache inside it was deleted with it: every run made again on the next
/// study), and the folder `out` is in one this process can write in (the outputs are written
/// beside `out`, then renamed: found at the end, a whole study's runs were done for nothing).
/// Gives `out` made absolute.
pub fn check_study_out(out: &Path, cache: &Path) -> Result<PathBuf, String> {
    let abs = replaceable_out(out)?;
    crate::writable::check_can_write_in(abs.parent().unwrap_or(Path::new("/")))
        .map_err(|e| format!("--out: {}: {e}", out.display()))?;
    let cache_abs = std::path::absolute(cache).unwrap_or_else(|_| cache.to_path_buf());
    // Compared through the folders that exist (symbolic links resolved), then lexically.
    let real = |p: &Path| {
        let mut head = p.to_path_buf();
        let mut tail = Vec::new();
        while !head.exists() {
            match (head.file_name().map(|n| n.to_os_string()), head.parent()) {
                (Some(n), Some(parent)) => {
                    tail.push(n);
                    head = parent.to_path_buf();
                }
                _ => break,
            }
        }
        let mut r = head.canonicalize().unwrap_or(head);
        r.extend(tail.iter().rev());
        r
    };
    if real(&cache_abs).starts_with(real(&abs)) {
        return Err(format!(
            "--out: {} holds the run cache {}, which the outputs would replace: give another folder or another cache",
            out.display(),
            cache.display()
        ));
    }
    Ok(abs)
}

/// Write every output into `out` (a temporary folder renamed at the end: an interrupted or
/// failed write leaves the old folder or none). `out` must pass [`replaceable_out`].
pub fn write_all(
    out: &Path,
    study: &Study,
    res: &Results,
    command: &str,
    paper: bool,
) -> Result<(), String> {
    let out = &replaceable_out(out)?;
    let name = out
        .file_name()
        .ok_or_else(|| format!("--out: {}: no folder name", out.display()))?;
    // A folder of this write's own beside `out` (`DIR.partial`, fixed, removed whatever a
    // folder of that name held).
    let parent = out.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let tmp = out.with_file_name(format!(
        ".{}.partial-{}-{nanos}",
        name.to_string_lossy(),
        std::process::id()
    ));
    std::fs::create_dir(&tmp).map_err(|e| format!("{}: {e}", tmp.display()))?;
    let w = |name: &str, text: String| {
        std::fs::write(tmp.join(name), text)
            .map_err(|e| format!("{}: {e}", tmp.join(name).display()))
    };
    let written = (|| {
        w("outcomes.csv", outcomes_csv(study, res))?;
        w("capacities.csv", capacities_csv(res))?;
        w("fits.csv", fits_csv(res))?;
        w("differences.csv", differences_csv(res))?;
        w(
            MARKER,
            serde_json::to_string_pretty(&json(study, res, command)).expect("serialises") + "\n",
        )?;
        w("report.html", html(study, res, command))?;
        if paper {
            write_paper(&tmp.join("paper"), study, res, command)?;
        }
        Ok(())
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    let _ = std::fs::remove_dir_all(out);
    std::fs::rename(&tmp, out).map_err(|e| {
        let _ = std::fs::remove_dir_all(&tmp);
        format!("{}: {e}", out.display())
    })
}

/// `paper/`: the fits and the differences as booktabs tables, one figure per scene, method
/// and limit state (every engine's curve, the stripe fractions as markers).
fn write_paper(dir: &Path, study: &Study, res: &Results, command: &str) -> Result<(), String> {
    let mut p = PaperDir::new(dir);
    let header: Vec<String> = [
        "Scene",
        "Engine",
        "Limit state",
        "Method",
        "$\\theta$",
        "95\\,\\%",
        "$\\beta$",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let rows: Vec<Vec<String>> = res
        .fits
        .iter()
        .map(|f| {
            vec![
                latex_escape(&f.scene),
                latex_escape(&f.engine),
                latex_escape(&f.limit_state),
                method(f.method).into(),
                tex_num(f.fit.map(|x| x.theta), 3),
                f.theta_ci
                    .map(|(a, b)| format!("{}--{}", tex_num(Some(a), 3), tex_num(Some(b), 3)))
                    .unwrap_or_else(|| "--".into()),
                tex_num(f.fit.map(|x| x.beta), 2),
            ]
        })
        .collect();
    p.table(
        "fits",
        booktabs("lllllll", &header, &rows),
        "fitted medians and dispersions with 95 % bootstrap intervals",
    );
    let header: Vec<String> = [
        "Scene",
        "Limit state",
        "Method",
        "Engine",
        "$\\theta/\\theta_{\\mathrm{ref}}$",
        "95\\,\\%",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let rows: Vec<Vec<String>> = res
        .differences
        .iter()
        .map(|d| {
            vec![
                latex_escape(&d.scene),
                latex_escape(&d.limit_state),
                method(d.method).into(),
                latex_escape(&format!("{} / {}", d.engine, d.reference)),
                tex_num(Some(d.ratio), 3),
                d.ratio_ci
                    .map(|(a, b)| format!("{}--{}", tex_num(Some(a), 3), tex_num(Some(b), 3)))
                    .unwrap_or_else(|| "--".into()),
            ]
        })
        .collect();
    p.table(
        "differences",
        booktabs("llllll", &header, &rows),
        "medians of each engine over the reference engine's, paired bootstrap 95 % intervals",
    );
    for scene in &study.scenes {
        for m in [Method::Stripes, Method::Ida] {
            for (k, ls) in study.limit_states.iter().enumerate() {
                let mut plot = Plot {
                    title: format!("{} {} {}", scene.name, ls.name, method(m)),
                    x_label: study.file.intensity.measure.label().into(),
                    y_label: "P(exceeded)".into(),
                    ..Default::default()
                };
                for (ei, e) in study.file.engines.iter().enumerate() {
                    let col = COLORS[ei % COLORS.len()].to_string();
                    let Some(f) = res.fits.iter().find(|f| {
                        f.scene == scene.name
                            && &f.engine == e
                            && f.limit_state == ls.name
                            && f.method == m
                    }) else {
                        continue;
                    };
                    if let Some(fit) = f.fit {
                        plot.curves.push(Curve {
                            name: e.clone(),
                            color: col.clone(),
                            dashed: false,
                            x: res.grid.clone(),
                            y: res.grid.iter().map(|&x| fit.p(x)).collect(),
                        });
                    }
                    if m == Method::Stripes {
                        let mut by: BTreeMap<u64, (f64, usize, usize)> = BTreeMap::new();
                        for rw in res.rows.iter().filter(|rw| {
                            rw.method == Method::Stripes
                                && rw.scene == scene.name
                                && &rw.engine == e
                        }) {
                            let x = by.entry(rw.level.to_bits()).or_insert((rw.level, 0, 0));
                            x.1 += 1;
                            x.2 += usize::from(rw.exceeded[k]);
                        }
                        for (lv, n, z) in by.values() {
                            plot.markers.push(Marker {
                                x: *lv,
                                y: *z as f64 / *n as f64,
                                color: col.clone(),
                            });
                        }
                        plot.marker_label = Some("fraction of records exceeding".into());
                    }
                }
                if plot.curves.is_empty() {
                    continue;
                }
                let name = format!(
                    "fragility-{}-{}-{}",
                    slug(&scene.name),
                    method(m),
                    slug(&ls.name)
                );
                p.figure(
                    &name,
                    &plot,
                    &format!(
                        "fragility curves of every engine, {} ({})",
                        ls.name,
                        method(m)
                    ),
                );
            }
        }
    }
    let regen = if command.contains("--paper") {
        command.to_string()
    } else {
        format!("{command} --paper")
    };
    p.finish(command, &regen)
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}
