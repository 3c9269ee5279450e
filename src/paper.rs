//! `paper/`: what a method-comparison paper takes unchanged from a comparison, a benchmark or a
//! convergence study.
//!
//! - Tables as LaTeX (`booktabs`: `\toprule`, `\midrule`, `\bottomrule`), one `tabular` per
//!   file, to `\input` into a `table` environment.
//! - Figures as standalone SVG, as vector PDF (converted by `rsvg-convert`, Debian's
//!   `librsvg2-bin`: a missing converter is a one-line error naming it), and their data as CSV
//!   with a header row (pgfplots' `\addplot table [x=..., y=...]` reads it).
//! - `README.md`: what each file is, the one command that regenerates the folder, and the
//!   provenance (commit, versions, machine).

use crate::bench::BenchRow;
use crate::compare::Comparison;
use crate::converge::{Convergence, QUANTITIES};
use crate::events::REST_THRESHOLDS;
use crate::metrics::series_of;
use crate::report::provenance::Provenance;
use crate::report::svg::{Curve, Plot};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The converter from SVG to PDF.
pub const SVG_TO_PDF: &str = "rsvg-convert";

/// Whether the tool the paper's figures need is here: checked before a command runs its
/// engines, so a missing one costs nothing and leaves no report behind.
pub fn check_tools() -> Result<(), String> {
    match Command::new(SVG_TO_PDF).arg("--version").output() {
        Ok(o) if o.status.success() => Ok(()),
        Ok(o) => Err(format!(
            "--paper: `{SVG_TO_PDF} --version` failed: {}",
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Err(e) => Err(format!(
            "--paper: {SVG_TO_PDF} (Debian package librsvg2-bin, `make paper-tools`) is needed for the PDF figures: {e}"
        )),
    }
}

/// Text safe in LaTeX's text mode.
pub fn latex_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\\' => out.push_str("\\textbackslash{}"),
            '&' | '%' | '$' | '#' | '_' | '{' | '}' => {
                out.push('\\');
                out.push(c);
            }
            '~' => out.push_str("\\textasciitilde{}"),
            '^' => out.push_str("\\textasciicircum{}"),
            '±' => out.push_str("$\\pm$"),
            _ => out.push(c),
        }
    }
    out
}

/// A booktabs `tabular`: a header row and body rows (cells already LaTeX; use
/// [`latex_escape`] for text).
pub fn booktabs(columns: &str, header: &[String], rows: &[Vec<String>]) -> String {
    let mut s = format!("\\begin{{tabular}}{{{columns}}}\n\\toprule\n");
    s += &header.join(" & ");
    s += " \\\\\n\\midrule\n";
    for r in rows {
        s += &r.join(" & ");
        s += " \\\\\n";
    }
    s += "\\bottomrule\n\\end{tabular}\n";
    s
}

/// A number in LaTeX math: `1.23 \times 10^{-4}`, or `--` when undefined.
pub fn tex_num(x: Option<f64>, digits: usize) -> String {
    match x {
        None => "--".into(),
        Some(v) if !v.is_finite() => "--".into(),
        Some(0.0) => "$0$".into(),
        Some(v) => {
            let e = v.abs().log10().floor() as i32;
            if (-2..=3).contains(&e) {
                format!("${v:.digits$}$")
            } else {
                let m = v / 10f64.powi(e);
                format!("${m:.digits$} \\times 10^{{{e}}}$")
            }
        }
    }
}

/// The folder being written: files are collected and written at the end, so that a failure
/// (a missing converter) leaves nothing half-written.
pub struct PaperDir {
    dir: PathBuf,
    files: Vec<(String, Vec<u8>, String)>,
    figures: Vec<String>,
}

impl PaperDir {
    pub fn new(dir: &Path) -> PaperDir {
        PaperDir {
            dir: dir.to_path_buf(),
            files: Vec::new(),
            figures: Vec::new(),
        }
    }

    /// A file and what it is (for the README).
    pub fn add(&mut self, name: &str, contents: impl Into<Vec<u8>>, what: &str) {
        self.files
            .push((name.to_string(), contents.into(), what.to_string()));
    }

    /// A LaTeX table.
    pub fn table(&mut self, name: &str, tabular: String, what: &str) {
        let name = self.unused(name);
        self.add(&format!("{name}.tex"), tabular, what);
    }

    /// `name`, or `name-2`, `name-3`, ... where files of that name are already in the folder:
    /// names made from user text (scene and limit-state names, with the characters a file
    /// name cannot take replaced) may coincide, and one file must not replace another.
    fn unused(&self, name: &str) -> String {
        let taken = |n: &str| {
            self.files
                .iter()
                .any(|(f, _, _)| f.rsplit_once('.').is_some_and(|(stem, _)| stem == n))
        };
        let mut k = 1;
        let mut out = name.to_string();
        while taken(&out) {
            k += 1;
            out = format!("{name}-{k}");
        }
        out
    }

    /// A figure: `name.svg`, `name.pdf` (at [`PaperDir::finish`]) and `name.csv` with its data.
    pub fn figure(&mut self, name: &str, plot: &Plot, what: &str) {
        let name = self.unused(name);
        self.add(&format!("{name}.svg"), plot.render(), what);
        self.add(
            &format!("{name}.csv"),
            curves_csv(&plot.curves),
            &format!("data of {name}"),
        );
        self.figures.push(name);
    }

    /// Convert the figures, write every file and the README.
    pub fn finish(mut self, command: &str, regenerate: &str) -> Result<(), String> {
        let tmp = self.dir.with_extension("partial");
        let _ = std::fs::remove_dir_all(&tmp);
        std::fs::create_dir_all(&tmp).map_err(|e| format!("{}: {e}", tmp.display()))?;
        let write = |name: &str, data: &[u8]| {
            std::fs::write(tmp.join(name), data)
                .map_err(|e| format!("{}: {e}", tmp.join(name).display()))
        };
        for (name, data, _) in &self.files {
            write(name, data)?;
        }
        for f in &self.figures {
            let svg = tmp.join(format!("{f}.svg"));
            let pdf = tmp.join(format!("{f}.pdf"));
            let out = Command::new(SVG_TO_PDF)
                .args(["-f", "pdf", "-o"])
                .arg(&pdf)
                .arg(&svg)
                .output();
            match out {
                Ok(o) if o.status.success() => {}
                Ok(o) => {
                    let _ = std::fs::remove_dir_all(&tmp);
                    return Err(format!(
                        "{}: {SVG_TO_PDF} failed: {}",
                        svg.display(),
                        String::from_utf8_lossy(&o.stderr).trim()
                    ));
                }
                Err(e) => {
                    let _ = std::fs::remove_dir_all(&tmp);
                    return Err(format!(
                        "--paper: {SVG_TO_PDF} (Debian package librsvg2-bin, `make paper-tools`) is needed for the PDF figures: {e}"
                    ));
                }
            }
            self.files.push((
                format!("{f}.pdf"),
                Vec::new(),
                format!("{f}.svg as vector PDF"),
            ));
        }
        let prov = Provenance::collect(command);
        let mut readme = format!(
            "# Paper outputs\n\nRegenerate this folder with:\n\n```sh\n{regenerate}\n```\n\nTables are booktabs `tabular`s: `\\usepackage{{booktabs}}`, then `\\input{{paper/NAME.tex}}` inside a `table`. Figures come as SVG, vector PDF (`\\includegraphics{{paper/NAME.pdf}}`) and CSV data with a header row (`\\addplot table [x=x, y=ENGINE, col sep=comma] {{paper/NAME.csv}}` in pgfplots; empty cells where a curve has no point).\n\n| file | what it is |\n|---|---|\n"
        );
        let mut names: Vec<&(String, Vec<u8>, String)> = self.files.iter().collect();
        names.sort_by(|a, b| a.0.cmp(&b.0));
        for (name, _, what) in names {
            let _ = writeln!(readme, "| `{name}` | {what} |");
        }
        let _ = write!(
            readme,
            "\n## Provenance\n\n- {}\n- machine: {}\n- date: {}\n- command: `{}`\n",
            prov.program(),
            prov.machine(),
            prov.date,
            prov.command
        );
        write("README.md", readme.as_bytes())?;
        let _ = std::fs::remove_dir_all(&self.dir);
        std::fs::rename(&tmp, &self.dir).map_err(|e| format!("{}: {e}", self.dir.display()))
    }
}

/// The curves of a plot as one CSV: a column `x` per curve would not align, so the data are
/// long-form per curve in wide columns `x_<k>`, `<name>`.
fn curves_csv(curves: &[Curve]) -> String {
    let n = curves.iter().map(|c| c.x.len()).max().unwrap_or(0);
    let name = |c: &Curve| c.name.replace([',', '"', ' '], "_");
    let mut s = String::new();
    let header: Vec<String> = curves
        .iter()
        .flat_map(|c| [format!("x_{}", name(c)), name(c)])
        .collect();
    s += &header.join(",");
    s.push('\n');
    for k in 0..n {
        let cells: Vec<String> = curves
            .iter()
            .flat_map(|c| match (c.x.get(k), c.y.get(k)) {
                (Some(x), Some(y)) => [format!("{x:e}"), format!("{y:e}")],
                _ => [String::new(), String::new()],
            })
            .collect();
        s += &cells.join(",");
        s.push('\n');
    }
    s
}

/// The regenerating command: the command as run, `--paper` included.
fn regenerate(command: &str) -> String {
    if command.contains("--paper") {
        command.to_string()
    } else {
        format!("{command} --paper")
    }
}

/// `paper/` of a convergence study: observed orders, errors, one figure per quantity.
pub fn write_converge(dir: &Path, c: &Convergence, command: &str) -> Result<(), String> {
    let mut p = PaperDir::new(dir);
    let mut header = vec!["Engine".to_string(), "Series".to_string()];
    header.extend(QUANTITIES.iter().map(|(_, what, _)| latex_escape(what)));
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for o in &c.orders {
        if !keys.contains(&(o.engine.as_str(), o.series.as_str())) {
            keys.push((o.engine.as_str(), o.series.as_str()));
        }
    }
    let rows: Vec<Vec<String>> = keys
        .iter()
        .map(|(e, s)| {
            let mut r = vec![latex_escape(e), latex_escape(s)];
            for (q, _, _) in QUANTITIES {
                let o = c
                    .orders
                    .iter()
                    .find(|o| o.engine == *e && o.series == *s && o.quantity == q);
                r.push(match o.and_then(|o| Some((o.order?, o.std_error))) {
                    Some((v, Some(se))) => format!("${v:.2} \\pm {se:.2}$"),
                    Some((v, None)) => format!("${v:.2}$"),
                    None => "--".into(),
                });
            }
            r
        })
        .collect();
    p.table(
        "orders",
        booktabs(
            &format!("ll{}", "r".repeat(QUANTITIES.len())),
            &header,
            &rows,
        ),
        &format!(
            "observed orders (slope of ln error against ln dt ± its standard error), reference {}",
            c.reference
        ),
    );
    let mut header = vec![
        "Engine".to_string(),
        "$\\Delta t$ (s)".to_string(),
        "Series".to_string(),
    ];
    header.extend(
        QUANTITIES
            .iter()
            .map(|(_, what, unit)| format!("{} ({unit})", latex_escape(what))),
    );
    let mut keys: Vec<(&str, f64, &str)> = Vec::new();
    for pt in &c.points {
        let k = (pt.engine.as_str(), pt.dt, pt.series.as_str());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    let rows: Vec<Vec<String>> =
        keys.iter()
            .map(|(e, dt, s)| {
                let mut r = vec![latex_escape(e), tex_num(Some(*dt), 2), latex_escape(s)];
                for (q, _, _) in QUANTITIES {
                    let pt = c.points.iter().find(|p| {
                        p.engine == *e && p.dt == *dt && p.series == *s && p.quantity == q
                    });
                    r.push(match pt {
                        Some(pt) if pt.error.is_none() && pt.value.is_some() => "ref.".into(),
                        Some(pt) => tex_num(pt.error, 2),
                        None => "--".into(),
                    });
                }
                r
            })
            .collect();
    p.table(
        "errors",
        booktabs(
            &format!("lrl{}", "r".repeat(QUANTITIES.len())),
            &header,
            &rows,
        ),
        "errors at every step size",
    );
    for (q, what, unit) in QUANTITIES {
        let plot = crate::converge::plot(c, q, what, unit);
        if !plot.curves.is_empty() {
            p.figure(
                &format!("converge-{q}"),
                &plot,
                &format!("log10 error of the {what} against log10 dt"),
            );
        }
    }
    p.finish(command, &regenerate(command))
}

/// `paper/` of a work-precision benchmark: the table and the work-precision figure.
pub fn write_bench(
    dir: &Path,
    rows: &[BenchRow],
    plot: &Plot,
    command: &str,
) -> Result<(), String> {
    let mut p = PaperDir::new(dir);
    let header: Vec<String> = [
        "Engine",
        "Variant",
        "$\\Delta t$ (s)",
        "Status",
        "Wall (s)",
        "$\\mu$s/step",
        "RMS error (rad)",
        "RMS to impact 1 (rad)",
        "First impact diff. (s)",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let body: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                latex_escape(&r.engine),
                latex_escape(&r.variant),
                tex_num(r.dt, 2),
                latex_escape(&r.status),
                tex_num(r.median_wall_s, 3),
                tex_num(r.us_per_step, 2),
                tex_num(r.rms_error, 2),
                tex_num(r.rms_error_to_impact_1, 2),
                tex_num(r.first_impact_diff, 2),
            ]
        })
        .collect();
    p.table(
        "work-precision",
        booktabs("llrlrrrrr", &header, &body),
        "work-precision: median wall time and errors of every engine at every step size",
    );
    p.figure(
        "work-precision",
        plot,
        "log10 RMS rotation error against log10 median wall time",
    );
    p.finish(command, &regenerate(command))
}

/// `paper/` of a comparison: impact times side by side, rest times at every threshold, each
/// engine's settings, and the rotation history of every measured series.
pub fn write_compare(dir: &Path, c: &Comparison, command: &str) -> Result<(), String> {
    let mut p = PaperDir::new(dir);
    add_compare(&mut p, c, "");
    p.finish(command, &regenerate(command))
}

/// `paper/` of a validation run: the summary matrix (case x engine), and the tables and
/// figures of the paper's own case (`paper = true` in the suite), prefixed with its name.
pub fn write_validation(
    dir: &Path,
    head: &[String],
    rows: &[Vec<String>],
    paper_case: Option<(&str, &Comparison)>,
    command: &str,
) -> Result<(), String> {
    let mut p = PaperDir::new(dir);
    let header: Vec<String> = head.iter().map(|h| latex_escape(h)).collect();
    let body: Vec<Vec<String>> = rows
        .iter()
        .map(|r| r.iter().map(|c| latex_escape(c)).collect())
        .collect();
    p.table(
        "validation-matrix",
        booktabs(&format!("l{}", "l".repeat(head.len().saturating_sub(1))), &header, &body),
        "the validation summary matrix: each case on each engine (pass / FAIL / skipped, worst gate)",
    );
    if let Some((name, c)) = paper_case {
        add_compare(&mut p, c, &format!("{name}-"));
    }
    p.finish(command, &regenerate(command))
}

/// The tables and figures of one comparison, file names prefixed with `prefix`.
fn add_compare(p: &mut PaperDir, c: &Comparison, prefix: &str) {
    let engines: Vec<&str> = c.ok_runs().map(|r| r.engine.as_str()).collect();
    let measured: Vec<_> = series_of(&c.scene)
        .into_iter()
        .filter(|s| s.measured)
        .collect();
    // Impact times side by side: one row per series and impact, one column per engine.
    let mut header = vec!["Series".to_string(), "Impact".to_string()];
    header.extend(engines.iter().map(|e| latex_escape(e)));
    let mut rows = Vec::new();
    for s in &measured {
        let impacts: Vec<Vec<f64>> = c
            .ok_runs()
            .map(|r| {
                r.summary
                    .as_ref()
                    .map(|sm| sm.blocks[s.block].impacts.clone())
                    .unwrap_or_default()
            })
            .collect();
        let n = impacts.iter().map(Vec::len).max().unwrap_or(0).min(10);
        for k in 0..n {
            let mut r = vec![latex_escape(&s.label), (k + 1).to_string()];
            r.extend(
                impacts
                    .iter()
                    .map(|v| v.get(k).map(|t| format!("${t:.5}$")).unwrap_or("--".into())),
            );
            rows.push(r);
        }
    }
    p.table(
        &format!("{prefix}impact-times"),
        booktabs(&format!("lr{}", "r".repeat(engines.len())), &header, &rows),
        "impact instants (s) of every measured series, engines side by side (first 10)",
    );
    // Rest times at every threshold.
    let mut header = vec!["Block".to_string(), "Threshold (rad)".to_string()];
    header.extend(engines.iter().map(|e| latex_escape(e)));
    let mut rows = Vec::new();
    for (i, b) in c.scene.blocks.iter().enumerate() {
        for (key, _) in REST_THRESHOLDS {
            let threshold = format!("${} \\times 10^{{-{}}}$", &key[..1], &key[3..]);
            let mut r = vec![latex_escape(&b.name), threshold];
            r.extend(c.ok_runs().map(|run| {
                let t = run
                    .summary
                    .as_ref()
                    .and_then(|sm| sm.blocks[i].rest_times.get(key).copied().flatten());
                t.map(|t| format!("${t:.3}$"))
                    .unwrap_or("not at rest".into())
            }));
            rows.push(r);
        }
    }
    p.table(
        &format!("{prefix}rest-times"),
        booktabs(&format!("lr{}", "r".repeat(engines.len())), &header, &rows),
        "rest times (s): the earliest time after which |phi| stays below the threshold",
    );
    // Settings of every engine, one row per setting.
    let mut rows = Vec::new();
    for r in c.ok_runs() {
        let Some(sm) = &r.summary else { continue };
        let version = format!("{} {}", sm.engine, sm.engine_version);
        rows.push(vec![
            latex_escape(&r.engine),
            "version".into(),
            latex_escape(&version),
        ]);
        if let Some(obj) = sm.settings.as_object() {
            for (k, v) in obj {
                rows.push(vec![
                    latex_escape(&r.engine),
                    latex_escape(k),
                    latex_escape(&v.to_string().replace('"', "")),
                ]);
            }
        }
    }
    p.table(
        &format!("{prefix}settings"),
        booktabs(
            "lll",
            &["Engine".into(), "Setting".into(), "Value".into()],
            &rows,
        ),
        "every engine's version and the settings it ran with",
    );
    // Rotation histories.
    let palette = [
        "#000000", "#d62728", "#1f77b4", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b",
    ];
    for s in &measured {
        let mut plot = Plot {
            title: format!("Rotation of {}", s.label),
            x_label: "t (s)".into(),
            y_label: "rotation (rad)".into(),
            ..Default::default()
        };
        for (k, r) in c.ok_runs().enumerate() {
            let Some(out) = &r.output else { continue };
            let (phi, _) = s.rotation_and_rate(&out.trajectory);
            let (x, y) = crate::report::svg::decimate(&out.trajectory.t, &phi, 2000);
            plot.curves.push(Curve {
                name: r.engine.clone(),
                color: palette[k % palette.len()].into(),
                dashed: k > 0 && r.engine != c.reference,
                x,
                y,
            });
        }
        let name = format!("{prefix}rotation-{}", s.label.replace('/', "-"));
        p.figure(
            &name,
            &plot,
            &format!("rotation history of {}, every engine", s.label),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two figures or tables whose names coincide (limit states `r/0.5` and `r_0.5` both
    /// become `r_0_5`) are kept as two files, the second under `-2`.
    #[test]
    fn coinciding_names_do_not_replace_each_other() {
        let mut p = PaperDir::new(Path::new("unused"));
        let plot = Plot::default();
        p.figure("fragility-b-stripes-r_0_5", &plot, "first");
        p.figure("fragility-b-stripes-r_0_5", &plot, "second");
        p.table("fragility-b-stripes-r_0_5", "x".into(), "a table");
        let names: Vec<&str> = p.files.iter().map(|(n, _, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "fragility-b-stripes-r_0_5.svg",
                "fragility-b-stripes-r_0_5.csv",
                "fragility-b-stripes-r_0_5-2.svg",
                "fragility-b-stripes-r_0_5-2.csv",
                "fragility-b-stripes-r_0_5-3.tex",
            ]
        );
        assert_eq!(
            p.figures,
            ["fragility-b-stripes-r_0_5", "fragility-b-stripes-r_0_5-2"]
        );
    }

    #[test]
    fn latex_specials_are_escaped() {
        assert_eq!(latex_escape("a_b & 50% #1"), "a\\_b \\& 50\\% \\#1");
        assert_eq!(
            latex_escape("x~y^z\\"),
            "x\\textasciitilde{}y\\textasciicircum{}z\\textbackslash{}"
        );
    }

    #[test]
    fn numbers_become_latex_math() {
        assert_eq!(tex_num(Some(2.5e-4), 2), "$2.50 \\times 10^{-4}$");
        assert_eq!(tex_num(Some(0.2425), 4), "$0.2425$");
        assert_eq!(tex_num(None, 2), "--");
        assert_eq!(tex_num(Some(f64::NAN), 2), "--");
    }

    #[test]
    fn a_booktabs_table_has_its_rules_and_rows() {
        let t = booktabs(
            "lr",
            &["A".into(), "B".into()],
            &[vec!["x".into(), "1".into()], vec!["y".into(), "2".into()]],
        );
        assert!(t.starts_with("\\begin{tabular}{lr}\n\\toprule\nA & B \\\\\n\\midrule\n"));
        assert!(t.contains("x & 1 \\\\\ny & 2 \\\\\n\\bottomrule\n\\end{tabular}"));
    }

    #[test]
    fn curve_data_is_one_column_pair_per_curve() {
        let c = |n: &str, k: usize| Curve {
            name: n.into(),
            color: "#000".into(),
            dashed: false,
            x: (0..k).map(|i| i as f64).collect(),
            y: (0..k).map(|i| 2.0 * i as f64).collect(),
        };
        let csv = curves_csv(&[c("native", 3), c("rapier x", 2)]);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "x_native,native,x_rapier_x,rapier_x");
        assert_eq!(lines[2], "1e0,2e0,1e0,2e0");
        assert_eq!(lines[3], "2e0,4e0,,");
    }
}
