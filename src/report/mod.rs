//! The verification report of a comparison: one self-contained HTML file (inline SVG plots,
//! one small inline script for the animation, no network) and its Markdown twin (`report.md`,
//! with the same plots as files under `plots/`). Both are built from the same calls, so they
//! say the same things. The report opens with the verdict table ([`verdict`]), then the motion
//! ([`animate`]), then a short summary and the tables and plots behind the verdict.

pub mod animate;
pub mod provenance;
pub mod svg;
pub mod verdict;

use crate::compare::{Comparison, Status};
use crate::events::REST_THRESHOLDS;
use crate::metrics::{self, MetricRow, Series};
use provenance::Provenance;
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;
use svg::{Curve, Marker, Plot};

/// Colours: the reference is black and dashed, engines take these in order.
pub(crate) const PALETTE: [&str; 7] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf",
];

/// Tolerances of the verdict table (and the wording of the summary): a history agrees when
/// its RMS error before the first impact is at most 1 % of the reference's largest rotation,
/// impact instants when every impact is matched within 5 ms, rest times within 10 %.
pub const WORDING_NORMALISED_RMS: f64 = 0.01;
pub const WORDING_IMPACT_TIME_S: f64 = 5e-3;
pub const WORDING_REST_RELATIVE: f64 = 0.10;
/// Peaks agree when the first three peak amplitudes after impacts (or the one before the
/// first impact, if there is none) are within 5 % of the reference's.
pub const VERDICT_PEAK_RELATIVE: f64 = 0.05;
/// How many peaks after impacts the verdict compares.
pub const VERDICT_PEAKS: usize = 3;

/// HTML and Markdown written side by side (also used by the validation suite's report).
pub(crate) struct Doc {
    pub(crate) html: String,
    pub(crate) md: String,
    pub(crate) plots: Vec<(String, String)>,
}

pub(crate) fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// `code` spans in plain text become `<code>` in HTML.
fn inline_html(s: &str) -> String {
    let mut out = String::new();
    for (k, part) in esc(s).split('`').enumerate() {
        if k % 2 == 1 {
            let _ = write!(out, "<code>{part}</code>");
        } else {
            out.push_str(part);
        }
    }
    out
}

pub(crate) fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

impl Doc {
    pub(crate) fn new() -> Doc {
        Doc {
            html: String::new(),
            md: String::new(),
            plots: Vec::new(),
        }
    }
    /// A link to a relative path, as its own paragraph.
    pub(crate) fn link(&mut self, text: &str, href: &str) {
        let _ = writeln!(
            self.html,
            "<p><a href=\"{}\">{}</a></p>",
            esc(href),
            inline_html(text)
        );
        let _ = writeln!(self.md, "[{text}]({href})\n");
    }
    pub(crate) fn h(&mut self, level: usize, text: &str) {
        let _ = writeln!(self.html, "<h{level}>{}</h{level}>", inline_html(text));
        let _ = writeln!(self.md, "{} {text}\n", "#".repeat(level));
    }
    pub(crate) fn p(&mut self, text: &str) {
        let _ = writeln!(self.html, "<p>{}</p>", inline_html(text));
        let _ = writeln!(self.md, "{text}\n");
    }
    pub(crate) fn table(&mut self, head: &[String], rows: &[Vec<String>]) {
        self.html.push_str("<table><thead><tr>");
        for h in head {
            let _ = write!(self.html, "<th>{}</th>", inline_html(h));
        }
        self.html.push_str("</tr></thead><tbody>\n");
        for r in rows {
            self.html.push_str("<tr>");
            for c in r {
                let _ = write!(self.html, "<td>{}</td>", inline_html(c));
            }
            self.html.push_str("</tr>\n");
        }
        self.html.push_str("</tbody></table>\n");
        let _ = writeln!(
            self.md,
            "| {} |",
            head.iter()
                .map(|h| md_cell(h))
                .collect::<Vec<_>>()
                .join(" | ")
        );
        let _ = writeln!(self.md, "|{}", "---|".repeat(head.len()));
        for r in rows {
            let _ = writeln!(
                self.md,
                "| {} |",
                r.iter().map(|c| md_cell(c)).collect::<Vec<_>>().join(" | ")
            );
        }
        self.md.push('\n');
    }
    /// The same content written differently in each twin.
    pub(crate) fn raw(&mut self, html: &str, md: &str) {
        self.html.push_str(html);
        self.md.push_str(md);
    }
    pub(crate) fn pre(&mut self, text: &str) {
        let _ = writeln!(self.html, "<pre>{}</pre>", esc(text));
        let _ = writeln!(self.md, "```\n{text}\n```\n");
    }
    pub(crate) fn plot(&mut self, file: &str, plot: &Plot) {
        let svg = plot.render();
        let _ = writeln!(self.html, "<figure>{svg}</figure>");
        let _ = writeln!(self.md, "![{}](plots/{file})\n", plot.title);
        self.plots.push((file.to_string(), svg));
    }
}

/// Number with 4 significant digits (scientific below 1e-3).
pub fn num(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if !x.is_finite() {
        x.to_string()
    } else if x.abs() < 1e-3 || x.abs() >= 1e5 {
        format!("{x:.3e}")
    } else {
        let d = (3 - x.abs().log10().floor() as i32).clamp(0, 8) as usize;
        format!("{x:.d$}")
    }
}

fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_else(|| "-".into())
}

fn secs(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.4}")).unwrap_or_else(|| "-".into())
}

/// Lookup of metric rows: (engine, block, metric) -> row.
struct Rows<'a> {
    map: BTreeMap<(&'a str, &'a str, &'a str), &'a MetricRow>,
    /// The reference compared with itself: its own values in `reference`.
    own: BTreeMap<(&'a str, &'a str), Option<f64>>,
}

impl<'a> Rows<'a> {
    fn new(rows: &'a [MetricRow], own: &'a [MetricRow]) -> Self {
        Rows {
            map: rows
                .iter()
                .map(|r| ((r.engine.as_str(), r.block.as_str(), r.metric.as_str()), r))
                .collect(),
            own: own
                .iter()
                .map(|r| ((r.block.as_str(), r.metric.as_str()), r.reference))
                .collect(),
        }
    }
    fn v(&self, engine: &str, block: &str, metric: &str) -> Option<f64> {
        self.map.get(&(engine, block, metric)).and_then(|r| r.value)
    }
    fn r(&self, block: &str, metric: &str) -> Option<f64> {
        self.own.get(&(block, metric)).copied().flatten()
    }
    fn count(&self, engine: Option<&str>, block: &str, prefix: &str) -> usize {
        let mut k = 1;
        loop {
            let m = format!("{prefix}{k}");
            let present = match engine {
                Some(e) => self.v(e, block, &m).is_some(),
                None => self.r(block, &m).is_some(),
            };
            if !present {
                return k - 1;
            }
            k += 1;
        }
    }
}

/// The engines compared with the reference (that ran and are not the reference).
fn compared(c: &Comparison) -> Vec<String> {
    c.ok_runs()
        .filter(|r| c.reference_is_file || r.engine != c.reference)
        .map(|r| r.engine.clone())
        .collect()
}

fn pct(x: Option<f64>) -> String {
    x.map(|v| format!("{:.3} %", 100.0 * v))
        .unwrap_or_else(|| "-".into())
}

/// The one-paragraph summary, in words, generated from the metrics.
pub fn summary_paragraphs(c: &Comparison, own: &[MetricRow]) -> Vec<String> {
    let rows = Rows::new(&c.rows, own);
    let series = metrics::series_of(&c.scene);
    let mut out = Vec::new();
    let engines = compared(c);
    let mut first = format!(
        "Scene `{}` ({} block{}, {} s{}). Reference: `{}`{}.",
        c.scene.name,
        c.scene.blocks.len(),
        if c.scene.blocks.len() == 1 { "" } else { "s" },
        c.scene.duration,
        if c.scene.has_excitation() {
            ", ground excitation"
        } else {
            ", free rocking"
        },
        c.reference,
        if c.reference_is_file {
            " (a trajectory file)"
        } else {
            ""
        }
    );
    let not_run: Vec<String> = c
        .runs
        .iter()
        .filter(|r| r.status != Status::Ok)
        .map(|r| {
            format!(
                "`{}` {} ({})",
                r.engine,
                r.status.word(),
                r.status.reason().unwrap_or("")
            )
        })
        .collect();
    if !not_run.is_empty() {
        let _ = write!(first, " Not compared: {}.", not_run.join("; "));
    }
    if engines.is_empty() {
        first.push_str(" No engine other than the reference ran, so nothing is compared.");
    }
    out.push(first);
    // What the reference itself shows.
    let mut facts = Vec::new();
    for s in &series {
        let b = s.label.as_str();
        let kind = if s.is_interface() {
            "interface"
        } else {
            "block"
        };
        let mut f = Vec::new();
        if s.measured {
            let n = rows.count(None, b, "impact_time_");
            match rows.r(b, "impact_time_1") {
                Some(t1) => f.push(format!("{n} impacts, the first at {t1:.4} s")),
                None => f.push("no impact".into()),
            }
        }
        let rest: Vec<String> = REST_THRESHOLDS
            .iter()
            .map(|(key, _)| {
                format!(
                    "{} s at {key} rad",
                    secs(rows.r(b, &format!("rest_time_{key}")))
                )
            })
            .collect();
        f.push(format!("at rest from {}", rest.join(", ")));
        if rows.r(b, "overturned") == Some(1.0) {
            f.push(format!(
                "overturns at {} s",
                secs(rows.r(b, "overturn_time"))
            ));
        }
        facts.push(format!("{kind} `{b}`: {}", f.join("; ")));
    }
    out.push(format!(
        "The reference `{}` shows: {}. A rest time is the time after which |φ| stays below the \
         threshold; it depends strongly on the threshold.",
        c.reference,
        facts.join("; ")
    ));
    if engines.is_empty() {
        return out;
    }
    for e in &engines {
        let mut agree = Vec::new();
        let mut differ = Vec::new();
        for s in series.iter().filter(|s| s.measured) {
            let b = s.label.as_str();
            let what = if s.is_interface() {
                format!("interface `{b}`")
            } else {
                format!("block `{b}`")
            };
            if let Some(n1) = rows.v(e, b, "rotation_rms_error_normalised_to_impact_1") {
                let txt = format!(
                    "{what} before the first impact (RMS rotation error {} of the reference's largest rotation)",
                    pct(Some(n1))
                );
                if n1 <= WORDING_NORMALISED_RMS {
                    agree.push(txt);
                } else {
                    differ.push(txt);
                }
            }
            let (ni, nr) = (
                rows.v(e, b, "impact_count").unwrap_or(0.0),
                rows.map
                    .get(&(e.as_str(), b, "impact_count"))
                    .and_then(|r| r.reference)
                    .unwrap_or(0.0),
            );
            let dmax = 1e3 * rows.v(e, b, "impact_time_max_abs_diff").unwrap_or(0.0);
            let first = match (rows.v(e, b, "impact_time_1"), rows.r(b, "impact_time_1")) {
                (Some(x), Some(y)) => format!("; first impact {x:.4} s vs {y:.4} s"),
                _ => String::new(),
            };
            if ni == nr && ni > 0.0 {
                if dmax <= 1e3 * WORDING_IMPACT_TIME_S {
                    agree.push(format!(
                        "the impact times of {what} (all {ni:.0} matched within {dmax:.1} ms{first})"
                    ));
                } else {
                    differ.push(format!(
                        "the impact times of {what} (all {ni:.0} matched, but up to {dmax:.1} ms apart{first})"
                    ));
                }
            } else if ni != nr {
                differ.push(format!(
                    "the number of impacts of {what} ({ni:.0} against the reference's {nr:.0}; \
                     the first {:.0} in order up to {dmax:.1} ms apart{first})",
                    ni.min(nr)
                ));
            }
        }
        for s in &series {
            let b = s.label.as_str();
            let mut rest_bad = Vec::new();
            let mut rest_ok = Vec::new();
            for (key, _) in REST_THRESHOLDS {
                let m = format!("rest_time_{key}");
                let (x, y) = (rows.v(e, b, &m), rows.r(b, &m));
                let txt = format!("{} s vs {} s at {key} rad", secs(x), secs(y));
                match (x, y) {
                    (Some(x), Some(y)) if (x - y).abs() <= WORDING_REST_RELATIVE * y.abs() => {
                        rest_ok.push(txt)
                    }
                    (None, None) => {}
                    _ => rest_bad.push(txt),
                }
            }
            let kind = if s.is_interface() {
                "interface"
            } else {
                "block"
            };
            if !rest_ok.is_empty() {
                agree.push(format!(
                    "rest times of {kind} `{b}` ({})",
                    rest_ok.join(", ")
                ));
            }
            if !rest_bad.is_empty() {
                differ.push(format!(
                    "rest times of {kind} `{b}` ({})",
                    rest_bad.join(", ")
                ));
            }
            if rows.v(e, b, "overturning_agrees") == Some(0.0) {
                differ.push(format!("whether {kind} `{b}` overturns"));
            }
        }
        let mut p = format!("`{e}` against `{}`: ", c.reference);
        if agree.is_empty() {
            p.push_str("nothing agrees within the thresholds below");
        } else {
            let _ = write!(p, "agrees on {}", agree.join("; "));
        }
        if differ.is_empty() {
            p.push_str(". Nothing differs beyond the thresholds.");
        } else {
            let _ = write!(p, ". It differs on {}.", differ.join("; "));
        }
        out.push(p);
    }
    out.push(format!(
        "Wording thresholds (for this paragraph only; the tables give the numbers): histories \
         agree when the RMS rotation error before the first impact is at most {} % of the \
         reference's largest rotation; impact times when all impacts match within {} ms; rest \
         times when within {} %.{}",
        100.0 * WORDING_NORMALISED_RMS,
        1e3 * WORDING_IMPACT_TIME_S,
        100.0 * WORDING_REST_RELATIVE,
        if c.scene.blocks.len() > 1 {
            " For a stack, pointwise errors after the first impact grow from any perturbation \
             (chaotic sensitivity): compare impact times, peaks and rest times there rather than \
             the histories."
        } else {
            ""
        }
    ));
    out
}

/// The verdict table: one row per compared engine, one cell per quantity (history before the
/// first impact, impact instants, peaks, rest times, overturning, cost), each with the number
/// that decided it and the tolerance.
fn verdict_rows(c: &Comparison, rows: &Rows, series: &[Series]) -> verdict::Rows {
    use verdict::{VCell, Verdict};
    let engines = compared(c);
    let measured: Vec<&Series> = series.iter().filter(|s| s.measured).collect();
    let ref_wall = c
        .reference_run
        .as_ref()
        .and_then(|r| r.cost.wall_time_s)
        .filter(|_| !c.reference_is_file);
    let mut out = Vec::new();
    for e in &engines {
        let mut cells = Vec::new();
        // History before the first impact; on a block whose reference does not rock (no
        // normalised error), the RMS error itself against the impacts' noise floor.
        let worst = measured
            .iter()
            .filter_map(|s| {
                let b = s.label.as_str();
                rows.v(e, b, "rotation_rms_error_normalised_to_impact_1")
                    .or_else(|| rows.v(e, b, "rotation_rms_error_normalised"))
                    .map(|v| (v, b))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let still = measured
            .iter()
            .filter(|s| {
                rows.v(e, &s.label, "rotation_rms_error_normalised")
                    .is_none()
            })
            .filter_map(|s| {
                let b = s.label.as_str();
                rows.v(e, b, "rotation_rms_error").map(|v| (v, b))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let floor = crate::events::NOISE_FLOOR;
        cells.push(match (worst, still) {
            (_, Some((v, b))) if v > floor => VCell::new(
                Verdict::Differs,
                "differs",
                format!("RMS {v:.3e} rad where the reference does not rock ({b}: max |φ| ≤ {floor:e} rad)"),
            ),
            (None, Some((v, b))) => VCell::new(
                Verdict::Agree,
                "agrees",
                format!("neither rocks: RMS {v:.1e} ≤ {floor:e} rad ({b})"),
            ),
            (Some((v, b)), _) => VCell::new(
                if v <= WORDING_NORMALISED_RMS {
                    Verdict::Agree
                } else {
                    Verdict::Differs
                },
                if v <= WORDING_NORMALISED_RMS {
                    "agrees"
                } else {
                    "differs"
                },
                format!(
                    "RMS {:.3} % {} 1 % of max |φ| ({b})",
                    100.0 * v,
                    if v <= WORDING_NORMALISED_RMS {
                        "≤"
                    } else {
                        ">"
                    }
                ),
            ),
            (None, None) => VCell::new(Verdict::Info, "not compared", ""),
        });
        // Impact instants.
        let mut counts_differ = Vec::new();
        let mut dmax = 0.0f64;
        let mut total = 0.0;
        for s in &measured {
            let b = s.label.as_str();
            let ni = rows.v(e, b, "impact_count").unwrap_or(0.0);
            let nr = rows
                .map
                .get(&(e.as_str(), b, "impact_count"))
                .and_then(|r| r.reference)
                .unwrap_or(0.0);
            total += nr;
            if ni != nr {
                counts_differ.push(format!("{ni:.0} vs {nr:.0} ({b})"));
            }
            dmax = dmax.max(rows.v(e, b, "impact_time_max_abs_diff").unwrap_or(0.0));
        }
        let tol = format!("{:.0} ms", 1e3 * WORDING_IMPACT_TIME_S);
        cells.push(if measured.is_empty() {
            VCell::new(Verdict::Info, "not compared", "")
        } else if !counts_differ.is_empty() {
            VCell::new(
                Verdict::Differs,
                "differs",
                format!(
                    "impacts {}; matched ones within {:.2} ms",
                    counts_differ.join(", "),
                    1e3 * dmax
                ),
            )
        } else if total == 0.0 {
            VCell::new(Verdict::Agree, "agrees", "no impact in either")
        } else if dmax <= WORDING_IMPACT_TIME_S {
            VCell::new(
                Verdict::Agree,
                "agrees",
                format!(
                    "all {total:.0} matched, |Δt| ≤ {:.2} ms (tol {tol})",
                    1e3 * dmax
                ),
            )
        } else {
            VCell::new(
                Verdict::Differs,
                "differs",
                format!(
                    "all {total:.0} matched, |Δt| up to {:.2} ms > {tol}",
                    1e3 * dmax
                ),
            )
        });
        // Peaks (relative to the reference's; a reference peak below the impacts' noise floor
        // is no rocking to compare with).
        let mut worst: Option<(f64, String)> = None;
        let mut not_rocking: Option<String> = None;
        for s in &measured {
            let b = s.label.as_str();
            let n = rows.count(None, b, "peak_amplitude_").min(VERDICT_PEAKS);
            let ks: Vec<usize> = if n == 0 { vec![0] } else { (1..=n).collect() };
            for k in ks {
                let m = format!("peak_amplitude_{k}");
                let Some(y) = rows.r(b, &m) else { continue };
                let d = match rows.v(e, b, &m) {
                    Some(x) if y.abs() > floor => (x - y).abs() / y.abs(),
                    Some(x) if x.abs() <= floor => 0.0,
                    Some(x) => {
                        not_rocking.get_or_insert(format!(
                            "peak {k} of {b}: {x:.3e} rad where the reference does not rock \
                             ({y:.1e} rad)"
                        ));
                        0.0
                    }
                    None => f64::INFINITY,
                };
                if worst.as_ref().is_none_or(|w| d > w.0) {
                    worst = Some((d, format!("peak {k} of {b}")));
                }
            }
        }
        let tol = format!("{:.0} %", 100.0 * VERDICT_PEAK_RELATIVE);
        cells.push(match worst {
            _ if not_rocking.is_some() => {
                VCell::new(Verdict::Differs, "differs", not_rocking.unwrap_or_default())
            }
            None => VCell::new(Verdict::Info, "not compared", "no peak in the reference"),
            Some((d, w)) if d.is_infinite() => {
                VCell::new(Verdict::Differs, "differs", format!("{w}: missing"))
            }
            Some((d, w)) if d <= VERDICT_PEAK_RELATIVE => VCell::new(
                Verdict::Agree,
                "agrees",
                format!("within {:.2} % ≤ {tol} (worst: {w})", 100.0 * d),
            ),
            Some((d, w)) => VCell::new(
                Verdict::Differs,
                "differs",
                format!("{w} off by {:.1} % > {tol}", 100.0 * d),
            ),
        });
        // Rest times.
        let mut worst: Option<(f64, String)> = None;
        let mut missing = Vec::new();
        for s in series {
            let b = s.label.as_str();
            for (key, _) in REST_THRESHOLDS {
                let m = format!("rest_time_{key}");
                match (rows.v(e, b, &m), rows.r(b, &m)) {
                    (Some(x), Some(y)) => {
                        let d = (x - y).abs() / y.abs().max(1e-9);
                        if worst.as_ref().is_none_or(|w| d > w.0) {
                            worst = Some((d, format!("{b} at {key} rad: {x:.3} vs {y:.3} s")));
                        }
                    }
                    (None, None) => {}
                    (x, _) => missing.push(format!(
                        "{b} at {key} rad: {}",
                        if x.is_some() {
                            "at rest, the reference not"
                        } else {
                            "not at rest, the reference is"
                        }
                    )),
                }
            }
        }
        let tol = format!("{:.0} %", 100.0 * WORDING_REST_RELATIVE);
        cells.push(if let Some(m) = missing.first() {
            VCell::new(Verdict::Differs, "differs", m.clone())
        } else {
            match worst {
                None => VCell::new(Verdict::Agree, "agrees", "neither comes to rest"),
                Some((d, w)) if d <= WORDING_REST_RELATIVE => VCell::new(
                    Verdict::Agree,
                    "agrees",
                    format!("within {:.1} % ≤ {tol} (worst: {w})", 100.0 * d),
                ),
                Some((d, w)) => VCell::new(
                    Verdict::Differs,
                    "differs",
                    format!("{:.1} % > {tol}: {w}", 100.0 * d),
                ),
            }
        });
        // Overturning.
        let disagree: Vec<&str> = series
            .iter()
            .filter(|s| rows.v(e, &s.label, "overturning_agrees") == Some(0.0))
            .map(|s| s.label.as_str())
            .collect();
        let over: Vec<String> = series
            .iter()
            .filter(|s| rows.r(&s.label, "overturned") == Some(1.0))
            .map(|s| {
                format!(
                    "{} at {} s vs {} s",
                    s.label,
                    secs(rows.v(e, &s.label, "overturn_time")),
                    secs(rows.r(&s.label, "overturn_time"))
                )
            })
            .collect();
        cells.push(if !disagree.is_empty() {
            VCell::new(
                Verdict::Differs,
                "differs",
                format!("whether {} overturns", disagree.join(", ")),
            )
        } else if over.is_empty() {
            VCell::new(Verdict::Agree, "agrees", "neither overturns")
        } else {
            VCell::new(
                Verdict::Agree,
                "agrees",
                format!("both overturn: {}", over.join("; ")),
            )
        });
        // Cost.
        let run = c.runs.iter().find(|r| &r.engine == e);
        let s = run.and_then(|r| r.summary.as_ref());
        cells.push(match s {
            Some(s) => VCell::new(
                Verdict::Info,
                &format!("{:.3} s", s.wall_time_s),
                format!(
                    "{} steps{}",
                    s.steps,
                    ref_wall
                        .filter(|w| *w > 0.0)
                        .map(|w| format!(", {:.2} × the reference's wall time", s.wall_time_s / w))
                        .unwrap_or_default()
                ),
            ),
            None => VCell::new(Verdict::Info, "-", ""),
        });
        out.push((vec![e.clone()], cells));
    }
    out
}

const VERDICT_HEAD: [&str; 7] = [
    "engine",
    "history before the 1st impact",
    "impact instants",
    "peaks",
    "rest times",
    "overturning",
    "cost (wall time)",
];

fn series_title(s: &Series) -> String {
    if s.is_interface() {
        format!(
            "Interface `{}`: rotation of the upper block relative to the lower one",
            s.label
        )
    } else {
        format!("Block `{}`: absolute rotation", s.label)
    }
}

/// The animation's tracks: every engine that ran, the reference solid.
pub fn animation_tracks(c: &Comparison) -> Vec<animate::Track> {
    let engines = compared(c);
    let mut tracks: Vec<animate::Track> = engines
        .iter()
        .enumerate()
        .filter_map(|(k, e)| {
            let run = c.runs.iter().find(|r| &r.engine == e)?;
            let out = run.output.as_ref()?;
            Some(animate::Track {
                name: e.clone(),
                color: PALETTE[k % PALETTE.len()].to_string(),
                reference: false,
                trajectory: out.trajectory.clone(),
            })
        })
        .collect();
    if let Some(r) = &c.reference_run {
        tracks.insert(
            0,
            animate::Track {
                name: c.reference.clone(),
                color: animate::REFERENCE_COLOR.into(),
                reference: true,
                trajectory: r.trajectory.clone(),
            },
        );
    }
    tracks
}

/// Write every file of a comparison into `dir`: the data files
/// ([`crate::compare::write_run_files`]: metrics, trajectories, summaries), then `report.md`,
/// `report.html` and the plots under `plots/`.
pub fn write_comparison(dir: &Path, c: &Comparison, command: &str) -> Result<(), String> {
    crate::compare::write_run_files(dir, c, command)?;
    write_report(dir, c, command)?;
    link_fragility(dir)
}

/// A fragility study written beside the comparison (`DIR/fragility/report.html`, as `make demo`
/// does) is linked at the top of the report.
fn link_fragility(dir: &Path) -> Result<(), String> {
    if !dir.join("fragility").join("report.html").is_file() {
        return Ok(());
    }
    let p = dir.join("report.html");
    let html = std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
    let link = "<p><b>Vulnerability:</b> how likely is the statue to rock, slide or overturn under the FEMA P695 far-field records? See the <a href=\"fragility/report.html\">fragility study</a> (fragility curves per limit state, with 95 % intervals).</p>\n";
    let html = html.replacen("<body>\n", &format!("<body>\n{link}"), 1);
    std::fs::write(&p, html).map_err(|e| format!("{}: {e}", p.display()))
}

/// The summary paragraphs of the report, as printed by `rockbench compare`.
pub fn summary_paragraphs_for(c: &Comparison) -> Vec<String> {
    let own = c
        .reference_run
        .as_ref()
        .and_then(|r| metrics::compare_runs(&c.scene, r, r, &c.settings).ok())
        .unwrap_or_default();
    summary_paragraphs(c, &own)
}

/// Build the report and write `report.html`, `report.md` and `plots/*.svg` into `dir`.
pub fn write_report(dir: &Path, c: &Comparison, command: &str) -> Result<(), String> {
    let prov = Provenance::collect(command);
    let (html, md, plots) = render(c, &prov);
    let io = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
    let pd = dir.join("plots");
    std::fs::create_dir_all(&pd).map_err(|e| io(&pd, e))?;
    for (name, svg) in plots {
        let p = pd.join(name);
        std::fs::write(&p, svg).map_err(|e| io(&p, e))?;
    }
    let p = dir.join("report.html");
    std::fs::write(&p, html).map_err(|e| io(&p, e))?;
    let p = dir.join("report.md");
    std::fs::write(&p, md).map_err(|e| io(&p, e))?;
    Ok(())
}

/// The report as (HTML, Markdown, plots).
pub fn render(c: &Comparison, prov: &Provenance) -> (String, String, Vec<(String, String)>) {
    let reference = c
        .reference_run
        .as_ref()
        .expect("a comparison has a reference");
    let own =
        metrics::compare_runs(&c.scene, reference, reference, &c.settings).unwrap_or_default();
    let rows = Rows::new(&c.rows, &own);
    let series = metrics::series_of(&c.scene);
    let engines = compared(c);
    let color = |e: &str| -> String {
        let k = engines.iter().position(|x| x == e).unwrap_or(0);
        PALETTE[k % PALETTE.len()].to_string()
    };
    let ref_name = format!("{} (reference)", c.reference);
    let mut d = Doc {
        html: String::new(),
        md: String::new(),
        plots: Vec::new(),
    };

    d.h(1, &format!("Cross-validation report: `{}`", c.scene.name));
    d.p(&format!(
        "Each engine against the reference `{}` ({} block{}, {} s{}): green agrees, red \
         differs, with the number that decided it and the tolerance.",
        c.reference,
        c.scene.blocks.len(),
        if c.scene.blocks.len() == 1 { "" } else { "s" },
        c.scene.duration,
        if c.scene.has_excitation() {
            ", ground excitation"
        } else {
            ", free rocking"
        },
    ));
    let vrows = verdict_rows(c, &rows, &series);
    let vhead: Vec<String> = VERDICT_HEAD.map(String::from).to_vec();
    if vrows.is_empty() {
        d.p("No engine other than the reference ran, so there is no verdict.");
    } else {
        d.raw(
            &verdict::table_html("verdict", &vhead, &vrows),
            &verdict::table_md(&vhead, &vrows),
        );
    }

    // The motion.
    let tracks = animation_tracks(c);
    if !tracks.is_empty() {
        let anim = animate::Animation::new(&c.scene, &tracks);
        d.h(2, "The motion");
        d.p(&format!(
            "Every engine's blocks drawn to scale from its trajectory, overlaid: the reference \
             solid, the others outlined in their colours{}. {} frames per second; the strip \
             below shows six instants.",
            if anim.moving_ground {
                "; the ground moves as the excitation moves it"
            } else {
                ""
            },
            anim.fps
        ));
        let strip = anim.strip_svg();
        d.raw(
            &format!(
                "{}<figure class=\"strip\">{}</figure>\n",
                anim.player_html(),
                strip
            ),
            "![Key frames of the motion (the animation is in report.html)](plots/keyframes.svg)\n\n",
        );
        d.plots.push(("keyframes.svg".into(), strip));
    }

    d.h(2, "Summary");
    let paragraphs = summary_paragraphs(c, &own);
    let n_engines = compared(c).len();
    for (k, p) in paragraphs.iter().enumerate() {
        // The per-engine paragraphs are the verdict table's rows, in words: left out here.
        if k >= 2 && k < 2 + n_engines {
            continue;
        }
        d.p(p);
    }
    for n in &c.notes {
        d.p(&format!("Note: {n}"));
    }

    // The scene.
    d.h(2, "Scene");
    let layout = c.scene.layout();
    let head: Vec<String> = [
        "block",
        "stands on",
        "width B (m)",
        "height H (m)",
        "density (kg/m³)",
        "mass (kg/m)",
        "critical angle atan(B/H) (rad)",
        "Housner r = 1 − 1.5 sin²α",
        "friction below",
    ]
    .map(String::from)
    .to_vec();
    let trs: Vec<Vec<String>> = c
        .scene
        .blocks
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let a = b.critical_angle();
            vec![
                format!("`{}`", b.name),
                layout.supports[i]
                    .map(|s| format!("`{}`", c.scene.blocks[s].name))
                    .unwrap_or_else(|| "ground".into()),
                num(b.width),
                num(b.height),
                num(b.density),
                num(b.mass()),
                num(a),
                num(1.0 - 1.5 * a.sin().powi(2)),
                num(c.scene.friction_below(i)),
            ]
        })
        .collect();
    d.table(&head, &trs);
    d.p(&format!(
        "Initial tilt of the stack {} rad; duration {} s; gravity {} m/s²; {}. Scene file: `{}`.",
        c.scene.initial.tilt,
        c.scene.duration,
        c.scene.gravity,
        if c.scene.has_excitation() {
            "ground excitation (see the scene file)"
        } else {
            "free rocking (no ground motion)"
        },
        c.scene.source
    ));

    // Engines and costs.
    d.h(2, "Engines and costs");
    let head: Vec<String> = [
        "engine",
        "status",
        "version",
        "steps",
        "wall time (s)",
        "µs per step",
        "solver iterations",
        "reason / notes",
    ]
    .map(String::from)
    .to_vec();
    let mut trs = Vec::new();
    for r in &c.runs {
        let s = r.summary.as_ref();
        let mut notes: Vec<String> = s.map(|s| s.notes.clone()).unwrap_or_default();
        if let Some(reason) = r.status.reason() {
            notes.insert(0, reason.to_string());
        }
        if r.cached {
            notes.push("served from the run cache".into());
        }
        trs.push(vec![
            if !c.reference_is_file && r.engine == c.reference {
                format!("`{}` (reference)", r.engine)
            } else {
                format!("`{}`", r.engine)
            },
            r.status.word().to_string(),
            s.map(|s| s.engine_version.clone()).unwrap_or_default(),
            s.map(|s| s.steps.to_string()).unwrap_or_default(),
            s.map(|s| format!("{:.3}", s.wall_time_s))
                .unwrap_or_default(),
            s.filter(|s| s.steps > 0)
                .map(|s| format!("{:.1}", 1e6 * s.wall_time_s / s.steps as f64))
                .unwrap_or_default(),
            s.and_then(|s| s.solver_iterations)
                .map(|n| n.to_string())
                .unwrap_or_default(),
            notes.join("; "),
        ]);
    }
    if c.reference_is_file {
        trs.push(vec![
            format!("`{}` (reference file)", c.reference),
            "read".into(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            String::new(),
            format!("{} samples", reference.trajectory.len()),
        ]);
    }
    d.table(&head, &trs);
    d.p(&if c.timing_runs > 1 {
        format!(
            "Wall times are medians of {} runs, with up to {} engine(s) running at once on {} \
             core(s).",
            c.timing_runs, c.jobs, prov.cores
        )
    } else {
        format!(
            "Wall times are single runs with up to {} engine(s) running at once on {} core(s): \
             indicative, not medians of repeated runs (see --timing-runs and --jobs 1).",
            c.jobs, prov.cores
        )
    });

    // Histories and errors.
    d.h(2, "Rotation histories");
    d.p(
        "Each plot overlays every engine's rotation; the reference is dashed black. Circles mark \
         impacts (zero crossings of the block's rocking rotation: the pivot changes corner). \
         Below each, the difference engine − reference on the common grid.",
    );
    let eh: Vec<(String, Option<metrics::ErrorHistory>)> = engines
        .iter()
        .map(|e| {
            let run = c
                .runs
                .iter()
                .find(|r| &r.engine == e)
                .and_then(|r| r.as_run());
            (
                e.clone(),
                run.and_then(|r| metrics::error_history(&c.scene, &r, reference, &c.settings).ok()),
            )
        })
        .collect();
    let runs_data: Vec<(String, metrics::Run)> = engines
        .iter()
        .filter_map(|e| {
            c.runs
                .iter()
                .find(|r| &r.engine == e)
                .and_then(|r| r.as_run())
                .map(|r| (e.clone(), r))
        })
        .collect();
    // Impacts of every series of every run, over each run's own time range.
    let all_events = |run: &metrics::Run| {
        let w = (
            run.trajectory.t.first().copied().unwrap_or(0.0),
            run.trajectory.t.last().copied().unwrap_or(0.0),
        );
        metrics::run_events(&c.scene, run, &c.settings, w)
    };
    let events: Vec<Vec<metrics::SeriesEvents>> =
        runs_data.iter().map(|(_, r)| all_events(r)).collect();
    let ref_events = all_events(reference);
    for (si, s) in series.iter().enumerate() {
        d.h(3, &series_title(s));
        let mut plot = Plot {
            title: series_title(s).replace('`', ""),
            x_label: "time t (s)".into(),
            y_label: if s.is_interface() {
                "relative rotation (rad)".into()
            } else {
                "rotation φ (rad)".into()
            },
            marker_label: Some("impacts".into()),
            ..Default::default()
        };
        let add = |plot: &mut Plot,
                   name: String,
                   col: String,
                   dashed: bool,
                   run: &metrics::Run,
                   ev: &[metrics::SeriesEvents]| {
            let rot = s.rotation(&run.trajectory);
            let imp = &ev[si].impacts;
            let ys = metrics::grid::interpolate(&run.trajectory.t, &rot, imp);
            for (x, y) in imp.iter().zip(ys) {
                plot.markers.push(Marker {
                    x: *x,
                    y,
                    color: col.clone(),
                });
            }
            plot.curves.push(Curve {
                name,
                color: col,
                dashed,
                x: run.trajectory.t.clone(),
                y: rot,
            });
        };
        for ((e, run), ev) in runs_data.iter().zip(&events) {
            add(&mut plot, e.clone(), color(e), false, run, ev);
        }
        add(
            &mut plot,
            ref_name.clone(),
            "#000000".into(),
            true,
            reference,
            &ref_events,
        );
        let slug = s.label.replace('/', "-on-");
        d.plot(&format!("rotation-{slug}.svg"), &plot);
        if eh.iter().any(|(_, h)| h.is_some()) {
            let mut ep = Plot {
                title: format!("{}: difference from {}", s.label, c.reference),
                x_label: "time t (s)".into(),
                y_label: "φ engine − φ reference (rad)".into(),
                ..Default::default()
            };
            for (e, h) in &eh {
                if let Some(h) = h {
                    ep.curves.push(Curve {
                        name: e.clone(),
                        color: color(e),
                        dashed: false,
                        x: h.t.clone(),
                        y: h.series[si].2.clone(),
                    });
                }
            }
            d.plot(&format!("error-{slug}.svg"), &ep);
        }
    }

    // Error table.
    d.h(2, "Rotation-history errors");
    d.p(&format!(
        "Both histories are interpolated linearly onto a uniform {} ms grid over the common \
         window. RMS and max of the difference, in rad and as a percentage of the reference's \
         largest |φ| on that series; \"to impact K\": up to the reference's K-th impact.",
        1e3 * c.settings.grid_dt
    ));
    let mut head: Vec<String> = vec!["engine".into(), "series".into()];
    let mut suffixes = vec![(String::new(), "whole window".to_string())];
    for k in &c.settings.up_to_impacts {
        suffixes.push((format!("_to_impact_{k}"), format!("to impact {k}")));
    }
    for (_, name) in &suffixes {
        head.push(format!("RMS {name} (rad)"));
        head.push(format!("max {name} (rad)"));
        head.push(format!("RMS {name} (%)"));
    }
    let mut trs = Vec::new();
    for e in &engines {
        for s in &series {
            let b = s.label.as_str();
            let mut row = vec![format!("`{e}`"), format!("`{b}`")];
            for (suf, _) in &suffixes {
                row.push(opt(rows.v(e, b, &format!("rotation_rms_error{suf}"))));
                row.push(opt(rows.v(e, b, &format!("rotation_max_error{suf}"))));
                row.push(pct(rows.v(
                    e,
                    b,
                    &format!("rotation_rms_error_normalised{suf}"),
                )));
            }
            trs.push(row);
        }
    }
    d.table(&head, &trs);

    // Impacts.
    d.h(2, "Impact times");
    d.p(
        "An impact is a zero crossing of the block's rocking rotation (relative to the block \
         below for a block on a block), extrapolated from the samples before it (never \
         interpolated across the velocity jump; docs/quantities.md); crossings while the \
         amplitude is below the noise floor are not counted. Impacts are matched in order; the \
         difference to the reference is given in milliseconds.",
    );
    const MAX_ROWS: usize = 40;
    for s in series.iter().filter(|s| s.measured) {
        let b = s.label.as_str();
        let n = engines
            .iter()
            .map(|e| rows.count(Some(e), b, "impact_time_"))
            .chain([rows.count(None, b, "impact_time_")])
            .max()
            .unwrap_or(0);
        let mut head = vec!["impact".to_string(), format!("{ref_name} t (s)")];
        for e in &engines {
            head.push(format!("{e} t (s)"));
            head.push(format!("{e} Δt (ms)"));
        }
        let mut trs = Vec::new();
        for k in 1..=n.min(MAX_ROWS) {
            let m = format!("impact_time_{k}");
            let y = rows.r(b, &m);
            let mut row = vec![k.to_string(), secs(y)];
            for e in &engines {
                let x = rows.v(e, b, &m);
                row.push(secs(x));
                row.push(match (x, y) {
                    (Some(x), Some(y)) => format!("{:+.2}", 1e3 * (x - y)),
                    _ => "unmatched".into(),
                });
            }
            trs.push(row);
        }
        let int = |x: Option<f64>| x.map(|v| format!("{v:.0}")).unwrap_or_else(|| "-".into());
        let mut count = vec!["count".to_string(), int(rows.r(b, "impact_count"))];
        for e in &engines {
            count.push(int(rows.v(e, b, "impact_count")));
            count.push(format!(
                "{} unmatched",
                int(rows.v(e, b, "impacts_unmatched"))
            ));
        }
        trs.push(count);
        d.h(3, &format!("`{b}`"));
        if n > MAX_ROWS {
            d.p(&format!(
                "First {MAX_ROWS} of {n} impacts shown (all are in metrics.csv)."
            ));
        }
        d.table(&head, &trs);
    }

    // Peaks.
    d.h(2, "Peak amplitudes and effective restitution");
    d.p(
        "Peak K is the largest |φ| after impact K (K = 0: before the first impact). The \
         effective restitution of impact K is the angular-velocity ratio implied by the peaks \
         before and after it through energy, sqrt(E(A_K)/E(A_{K−1})) with \
         E(A) = cos(α − A) − cos α; Housner's model gives r = 1 − 1.5 sin²α (α = atan(B/H)).",
    );
    for s in series.iter().filter(|s| s.measured) {
        let b = s.label.as_str();
        let n = engines
            .iter()
            .map(|e| rows.count(Some(e), b, "peak_amplitude_") + 1)
            .chain([rows.count(None, b, "peak_amplitude_") + 1])
            .max()
            .unwrap_or(0);
        let mut head = vec![
            "K".to_string(),
            format!("{ref_name} peak (rad)"),
            format!("{ref_name} restitution"),
        ];
        for e in &engines {
            head.push(format!("{e} peak (rad)"));
            head.push(format!("{e} restitution"));
        }
        let mut trs = Vec::new();
        for k in 0..n.min(MAX_ROWS) {
            let (pm, rm) = (format!("peak_amplitude_{k}"), format!("restitution_{k}"));
            let mut row = vec![k.to_string(), opt(rows.r(b, &pm)), opt(rows.r(b, &rm))];
            for e in &engines {
                row.push(opt(rows.v(e, b, &pm)));
                row.push(opt(rows.v(e, b, &rm)));
            }
            trs.push(row);
        }
        d.h(
            3,
            &format!(
                "`{b}` (Housner's r = {})",
                opt(rows.r(b, "housner_restitution"))
            ),
        );
        d.table(&head, &trs);
    }

    // Rest times.
    d.h(2, "Rest times");
    d.p(
        "Rest time at ε: the earliest time after which |φ| stays below ε until the end of the \
         run (\"-\": not at rest by the end). It depends strongly on ε, so it is given at four \
         thresholds.",
    );
    let mut head = vec![
        "series".to_string(),
        "ε (rad)".to_string(),
        format!("{ref_name} (s)"),
    ];
    for e in &engines {
        head.push(format!("{e} (s)"));
        head.push(format!("{e} Δ (s)"));
    }
    let mut trs = Vec::new();
    for s in &series {
        let b = s.label.as_str();
        for (key, _) in REST_THRESHOLDS {
            let m = format!("rest_time_{key}");
            let y = rows.r(b, &m);
            let mut row = vec![format!("`{b}`"), key.to_string(), secs(y)];
            for e in &engines {
                let x = rows.v(e, b, &m);
                row.push(secs(x));
                row.push(match (x, y) {
                    (Some(x), Some(y)) => format!("{:+.3}", x - y),
                    _ => "-".into(),
                });
            }
            trs.push(row);
        }
    }
    d.table(&head, &trs);

    // Overturning and energy.
    d.h(2, "Overturning and energy");
    let mut head = vec!["series".to_string(), format!("{ref_name}")];
    for e in &engines {
        head.push(e.clone());
    }
    let ot = |o: Option<f64>, t: Option<f64>| match o {
        Some(x) if x > 0.5 => format!("overturned at {} s", secs(t)),
        Some(_) => "no".into(),
        None => "-".into(),
    };
    let mut trs = Vec::new();
    for s in &series {
        let b = s.label.as_str();
        let mut row = vec![
            format!("`{b}`"),
            ot(rows.r(b, "overturned"), rows.r(b, "overturn_time")),
        ];
        for e in &engines {
            let mut t = ot(rows.v(e, b, "overturned"), rows.v(e, b, "overturn_time"));
            if rows.v(e, b, "overturning_agrees") == Some(0.0) {
                t.push_str(" (disagrees)");
            }
            row.push(t);
        }
        trs.push(row);
    }
    d.table(&head, &trs);
    d.p(
        "Mechanical energy of each block above its upright rest position, \
         E = m v²/2 + I ω²/2 + m g (z − z_rest), in J per metre of depth, at the start and at the \
         end of the window; RMS difference from the reference over the window.",
    );
    let mut head = vec![
        "block".to_string(),
        format!("{ref_name} initial"),
        format!("{ref_name} final"),
    ];
    for e in &engines {
        head.push(format!("{e} initial"));
        head.push(format!("{e} final"));
        head.push(format!("{e} RMS diff"));
    }
    let mut trs = Vec::new();
    for s in series.iter().filter(|s| !s.is_interface()) {
        let b = s.label.as_str();
        let mut row = vec![
            format!("`{b}`"),
            opt(rows.r(b, "energy_initial")),
            opt(rows.r(b, "energy_final")),
        ];
        for e in &engines {
            row.push(opt(rows.v(e, b, "energy_initial")));
            row.push(opt(rows.v(e, b, "energy_final")));
            row.push(opt(rows.v(e, b, "energy_rms_diff")));
        }
        trs.push(row);
    }
    d.table(&head, &trs);

    // Settings.
    d.h(2, "Engine settings");
    d.p("Every setting that changes the answer, as each engine ran with it.");
    for r in c.ok_runs() {
        if let Some(s) = &r.summary {
            d.h(3, &format!("`{}` ({})", r.engine, s.engine_version));
            d.pre(&serde_json::to_string_pretty(&s.settings).unwrap_or_default());
        }
    }
    d.h(3, "Comparison settings");
    d.pre(&serde_json::to_string_pretty(&c.settings).unwrap_or_default());

    // Provenance.
    d.h(2, "Provenance");
    let mut versions: Vec<Vec<String>> = vec![
        vec!["rockbench".into(), prov.rockbench_version.clone()],
        vec!["git commit".into(), prov.git_commit.clone()],
        vec!["sources".into(), prov.source_hash.clone()],
    ];
    for r in c.ok_runs() {
        if let Some(s) = &r.summary {
            versions.push(vec![
                format!("engine `{}`", r.engine),
                s.engine_version.clone(),
            ]);
        }
    }
    versions.push(vec!["machine".into(), prov.hostname.clone()]);
    versions.push(vec![
        "CPU".into(),
        format!("{} ({} cores)", prov.cpu, prov.cores),
    ]);
    versions.push(vec!["OS".into(), prov.os.clone()]);
    versions.push(vec!["date (UTC)".into(), prov.date.clone()]);
    versions.push(vec!["command".into(), format!("`{}`", prov.command)]);
    d.table(&["item".to_string(), "value".to_string()], &versions);

    let html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>rockbench report: {}</title><style>{CSS}{}{}</style></head><body>\n{}</body></html>\n",
        esc(&c.scene.name),
        verdict::CSS,
        animate::CSS,
        d.html
    );
    (html, d.md, d.plots)
}

pub(crate) const CSS: &str = "body{font-family:Helvetica,Arial,sans-serif;max-width:1100px;margin:1.5em auto;\
padding:0 1em;color:#222;line-height:1.4}table{border-collapse:collapse;margin:0.6em 0 1.2em;\
font-size:0.88em}th,td{border:1px solid #ccc;padding:3px 7px;text-align:right}\
th{background:#f2f2f2}td:first-child,th:first-child{text-align:left}code{background:#f4f4f4;\
padding:0 3px}pre{background:#f7f7f7;padding:0.6em;overflow-x:auto;font-size:0.85em}\
figure{margin:0.5em 0}h2{border-bottom:1px solid #ddd;padding-bottom:0.2em;margin-top:1.6em}";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::{CompareOptions, EngineRun, ReferenceSpec, compare_with, run_engine};
    use crate::scene::{Scene, parse_scene_str};

    const SLENDER: &str = "name = \"s\"\nduration = 3.0\n[[blocks]]\nname = \"block\"\nwidth = 1.0\nheight = 2.5\n[initial]\ntilt = 0.15\n";

    /// `housner` and `lossy` (Housner with restitution 0.6): identical until the first impact,
    /// then the lossy block loses more energy at every impact.
    fn comparison() -> Comparison {
        let scene = parse_scene_str(SLENDER, false, "s.toml", &[]).unwrap();
        let runner = |name: &str, sc: &Scene| -> EngineRun {
            if name == "lossy" {
                let mut s = sc.clone();
                s.set_setting("housner", "restitution", 0.6);
                let mut r = run_engine("housner", &s);
                r.engine = "lossy".into();
                r
            } else {
                run_engine(name, sc)
            }
        };
        let opts = CompareOptions::new(
            vec!["lossy".into(), "housner".into()],
            ReferenceSpec::Engine("housner".into()),
        );
        compare_with(&scene, &opts, &runner).unwrap()
    }

    #[test]
    fn the_summary_says_what_agrees_and_what_does_not() {
        let c = comparison();
        let text = summary_paragraphs_for(&c).join("\n");
        let lossy = text
            .lines()
            .find(|l| l.starts_with("`lossy` against `housner`"))
            .unwrap();
        let (agrees, differs) = lossy.split_once("It differs on").unwrap();
        assert!(
            agrees.contains("block `block` before the first impact"),
            "{lossy}"
        );
        // Rest at 1e-4 rad comes much earlier with restitution 0.6 than 0.79.
        assert!(differs.contains("rest times of block `block`"), "{lossy}");
        assert!(differs.contains("at 1e-4 rad"), "{lossy}");
    }

    /// A failed engine and an unknown one: the summary names the failure and says that
    /// nothing is compared.
    #[test]
    fn the_summary_names_failures_when_nothing_is_compared() {
        let scene = parse_scene_str(SLENDER, false, "s.toml", &[]).unwrap();
        let runner = |name: &str, sc: &Scene| {
            if name == "broken" {
                EngineRun {
                    engine: name.into(),
                    status: crate::compare::classify(&crate::engines::EngineError::Failed {
                        engine: "broken",
                        message: "diverged at step 7".into(),
                    }),
                    output: None,
                    summary: None,
                    cached: false,
                }
            } else {
                run_engine(name, sc)
            }
        };
        let opts = CompareOptions::new(
            vec!["broken".into(), "nosuch".into(), "housner".into()],
            ReferenceSpec::Engine("housner".into()),
        );
        let c = compare_with(&scene, &opts, &runner).unwrap();
        assert!(c.rows.is_empty());
        let text = summary_paragraphs_for(&c).join(" ");
        assert!(text.contains("diverged at step 7") && text.contains("nothing is compared"));
    }

    #[test]
    fn html_and_markdown_are_twins() {
        let c = comparison();
        let prov = Provenance::collect("rockbench compare s.toml");
        let (html, md, plots) = render(&c, &prov);
        // One inline SVG per plot file (the key-frame strip among them), each referenced
        // from the Markdown, and the animation's player.
        assert_eq!(html.matches("<svg").count(), plots.len() + 1);
        assert_eq!(plots.len(), 3);
        for (name, svg) in &plots {
            assert!(md.contains(&format!("(plots/{name})")));
            if name == "keyframes.svg" {
                assert_eq!(svg.matches("t = ").count(), 6);
                continue;
            }
            assert!(svg.contains("lossy"), "{name}");
            if name.starts_with("rotation-") {
                assert!(svg.contains("housner (reference)"), "{name}");
            }
        }
        // The same headings in both.
        let md_heads: Vec<String> = md
            .lines()
            .filter(|l| l.starts_with('#'))
            .map(|l| l.trim_start_matches('#').trim().replace('`', ""))
            .collect();
        let html_heads = html.matches("<h").count()
            - html.matches("<head").count()
            - html.matches("<html").count();
        assert_eq!(md_heads.len(), html_heads);
        // The verdict first, in both: the lossy engine agrees before the first impact, and
        // its peaks and rest times differ (restitution 0.6 against 0.79).
        let row = md
            .lines()
            .find(|l| l.starts_with("| lossy |"))
            .unwrap_or_else(|| panic!("{md}"));
        let cells: Vec<&str> = row.split(" | ").collect();
        assert!(cells[1].starts_with("✅ agrees: RMS 0.000 %"), "{row}");
        assert!(cells[3].starts_with("❌ differs: peak"), "{row}");
        assert!(cells[4].starts_with("❌ differs"), "{row}");
        assert!(
            cells[5].starts_with("✅ agrees: neither overturns"),
            "{row}"
        );
        assert!(md.find("| lossy |").unwrap() < md.find("## Summary").unwrap());
        let v = html.find("<table class=\"verdict\"").unwrap();
        assert_eq!(v, html.find("<table").unwrap());
        assert!(html[v..].contains("<td class=\"v v-differs\"><b>differs</b>"));
        // The per-engine paragraph is in the table, not repeated in the prose.
        assert!(!md.contains("`lossy` against `housner`"));
        // Restitution column: Housner's r for the reference, 0.6 for the lossy engine.
        assert!(md.contains("| 1 | 0.08560 | 0.7931 |"), "{md}");
        assert!(md.contains("| 0.6000 |"));
    }
}
