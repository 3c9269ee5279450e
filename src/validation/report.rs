//! The validation suite's report: `report.html` and `report.md` (twins) with the summary
//! matrix (case x engine), the paper's two-block section and one section per case; each
//! comparison's own report is linked from its case.

use super::{CaseResult, Cell};
use crate::compare::{Comparison, Status};
use crate::events::REST_THRESHOLDS;
use crate::gates::{Expect, Outcome};
use crate::metrics::{MetricSettings, Run, run_events};
use crate::report::provenance::Provenance;
use crate::report::svg::{Curve, Plot, decimate};
use crate::report::verdict::{VCell, Verdict};
use crate::report::{CSS, Doc, PALETTE, num};
use crate::trajectory::Trajectory;
use std::path::Path;

/// What the paper says about its two-block case, read from its reference data.
#[derive(Debug, Clone, Default)]
pub struct PaperClaims {
    pub claim: String,
    pub rest_time_s: Option<f64>,
    pub rest_threshold: String,
    pub upper_block_curve: String,
    /// The converged native run (reference-data trajectory.csv), if present.
    pub converged: Option<Trajectory>,
}

impl PaperClaims {
    /// Read `reference.toml` (`[paper]`) and `trajectory.csv` (if there is one) of a
    /// reference-data directory; a problem is one line naming the file and the field.
    pub fn read(dir: &Path) -> Result<PaperClaims, String> {
        let p = dir.join("reference.toml");
        let text = std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
        let v: toml::Table = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            let at = line.map(|l| format!("line {l}: ")).unwrap_or_default();
            format!("{}: {at}invalid TOML: {}", p.display(), e.message())
        })?;
        let paper = v
            .get("paper")
            .and_then(|x| x.as_table())
            .ok_or_else(|| format!("{}: [paper]: missing", p.display()))?;
        let s = |k: &str| {
            paper
                .get(k)
                .and_then(|x| x.as_str())
                .unwrap_or("")
                .to_string()
        };
        let rest_time_s = match paper.get("rest_time_s") {
            None => None,
            Some(x) => Some(
                x.as_float()
                    .or(x.as_integer().map(|i| i as f64))
                    .filter(|t| t.is_finite() && *t >= 0.0)
                    .ok_or_else(|| {
                        format!(
                            "{}: paper.rest_time_s: must be a time >= 0 in s (got {x})",
                            p.display()
                        )
                    })?,
            ),
        };
        let tp = dir.join("trajectory.csv");
        let converged = if tp.exists() {
            Some(Trajectory::read_csv(&tp).map_err(|e| e.to_string())?)
        } else {
            None
        };
        Ok(PaperClaims {
            claim: s("claim"),
            rest_time_s,
            rest_threshold: s("rest_threshold"),
            upper_block_curve: s("upper_block_curve"),
            converged,
        })
    }
}

/// Events of the two-block case for one run: first ground impact, the upper block's first
/// crossing on the lower one, and the rest time of the whole stack (every block's absolute
/// rotation and the interface's relative rotation below the threshold for good) at each
/// threshold.
#[derive(Debug, Clone)]
pub struct StackEvents {
    pub name: String,
    pub first_ground_impact: Option<f64>,
    pub first_upper_crossing: Option<f64>,
    pub rest: Vec<(String, Option<f64>)>,
}

pub fn stack_events(c: &Comparison, name: &str, tr: &Trajectory) -> StackEvents {
    let run = Run {
        name: name.into(),
        trajectory: tr.clone(),
        exact_impacts: None,
        cost: Default::default(),
    };
    let t1 = tr.t.last().copied().unwrap_or(0.0);
    let ev = run_events(&c.scene, &run, &MetricSettings::default(), (0.0, t1));
    let first = |label: &str| {
        ev.iter()
            .find(|e| e.label == label && e.measured)
            .and_then(|e| e.impacts.first().copied())
    };
    let bottom = c
        .scene
        .blocks
        .first()
        .map(|b| b.name.clone())
        .unwrap_or_default();
    let iface = if c.scene.blocks.len() >= 2 {
        format!("{}/{}", c.scene.blocks[0].name, c.scene.blocks[1].name)
    } else {
        String::new()
    };
    let rest = REST_THRESHOLDS
        .iter()
        .map(|(k, _)| {
            let mut worst: Option<f64> = Some(0.0);
            for e in &ev {
                let r = e
                    .rest_times
                    .iter()
                    .find(|(kk, _)| kk == k)
                    .and_then(|x| x.1);
                worst = match (worst, r) {
                    (Some(a), Some(b)) => Some(a.max(b)),
                    _ => None,
                };
            }
            (k.to_string(), worst)
        })
        .collect();
    StackEvents {
        name: name.into(),
        first_ground_impact: first(&bottom),
        first_upper_crossing: first(&iface),
        rest,
    }
}

/// "About" the paper's rest time: within this many seconds (the tolerance of the paper's
/// gates in validation/gates.toml).
pub const ABOUT_S: f64 = 0.25;

fn secs(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.3}"))
        .unwrap_or_else(|| "not at rest".into())
}

fn cell_text(c: &Cell) -> String {
    match c {
        Cell::Pass {
            gates,
            known,
            worst,
        } => {
            let mut s = format!("pass ({gates} gate{}", if *gates == 1 { "" } else { "s" });
            if *known > 0 {
                s += &format!(
                    ", {known} known failure{}",
                    if *known == 1 { "" } else { "s" }
                );
            }
            s += ")";
            if let Some(w) = worst {
                s += &format!("; worst: {w}");
            }
            s
        }
        Cell::Fail { bad, worst } => format!(
            "FAIL ({bad} gate{}){}",
            if *bad == 1 { "" } else { "s" },
            worst
                .as_ref()
                .map(|w| format!("; worst: {w}"))
                .unwrap_or_default()
        ),
        Cell::Skipped(r) => format!("skipped: {r}"),
        Cell::NoGate(r) => format!("no gate ({r})"),
        Cell::Reference => "reference".into(),
        Cell::NotRun => "not run".into(),
    }
}

/// The summary matrix as rows of text (first column the case).
pub fn matrix(results: &[CaseResult], engines: &[String]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut head = vec!["case".to_string()];
    head.extend(engines.iter().cloned());
    let rows = results
        .iter()
        .map(|r| {
            let mut row = vec![r.case.name.clone()];
            row.extend(engines.iter().map(|e| cell_text(&r.cell(e))));
            row
        })
        .collect();
    (head, rows)
}

/// The summary matrix in the verdict style shared with the comparison report and the stress
/// map: each cell coloured, its word (pass / FAIL / ...) and the worst gate.
pub fn matrix_verdict(
    results: &[CaseResult],
    engines: &[String],
) -> (Vec<String>, crate::report::verdict::Rows) {
    let mut head = vec!["case".to_string()];
    head.extend(engines.iter().cloned());
    let rows = results
        .iter()
        .map(|r| {
            let cells = engines
                .iter()
                .map(|e| {
                    let c = r.cell(e);
                    let text = cell_text(&c);
                    let (word, detail) = match text.split_once("; worst: ") {
                        Some((w, d)) => (w.to_string(), format!("worst: {d}")),
                        None => (text.clone(), String::new()),
                    };
                    let v = match c {
                        Cell::Pass { known, .. } if known > 0 => Verdict::Known,
                        Cell::Pass { .. } => Verdict::Agree,
                        Cell::Fail { .. } => Verdict::Differs,
                        _ => Verdict::Info,
                    };
                    VCell::new(v, &word, detail)
                })
                .collect();
            (vec![r.case.name.clone()], cells)
        })
        .collect();
    (head, rows)
}

/// The matrix as a plain-text table (printed by `rockbench validate`).
pub fn matrix_text(results: &[CaseResult], engines: &[String]) -> String {
    let mut head = vec!["case".to_string()];
    head.extend(engines.iter().cloned());
    let rows: Vec<Vec<String>> = results
        .iter()
        .map(|r| {
            let mut row = vec![r.case.name.clone()];
            row.extend(engines.iter().map(|e| {
                let c = r.cell(e);
                match &c {
                    Cell::Pass { known, .. } if *known > 0 => format!("pass ({known} known)"),
                    Cell::Fail { bad, .. } => format!("FAIL ({bad})"),
                    other => other.word().to_string(),
                }
            }));
            row
        })
        .collect();
    crate::text_table::aligned(&head, &rows)
}

fn paper_section(d: &mut Doc, r: &CaseResult, claims: &PaperClaims) {
    d.h(2, "The paper's two-block case");
    d.p(&format!(
        "The paper's claim: {}. Rest time stated: {} (threshold: {}). The upper block's curve: {}.",
        claims.claim,
        claims
            .rest_time_s
            .map(|t| format!("about {t} s"))
            .unwrap_or_else(|| "none".into()),
        claims.rest_threshold,
        claims.upper_block_curve
    ));
    let Some(c) = r.runs.first().and_then(|x| x.comparison.as_ref().ok()) else {
        d.p("The comparison of this case did not run.");
        return;
    };
    let mut evs: Vec<StackEvents> = c
        .ok_runs()
        .filter_map(|er| {
            er.output
                .as_ref()
                .map(|o| stack_events(c, &er.engine, &o.trajectory))
        })
        .collect();
    if let Some(tr) = &claims.converged {
        evs.push(stack_events(
            c,
            &format!(
                "native, dt = {:e} s (reference-data)",
                crate::validation::references::CONVERGED_DT
            ),
            tr,
        ));
    }
    let mut head = vec![
        "engine".to_string(),
        "first ground impact (s)".into(),
        "upper block's first crossing (s)".into(),
    ];
    for (k, _) in REST_THRESHOLDS {
        head.push(format!("stack at rest, |φ| < {k} rad (s)"));
    }
    let mut rows: Vec<Vec<String>> = Vec::new();
    for e in &evs {
        let mut row = vec![
            format!("`{}`", e.name),
            e.first_ground_impact.map(num).unwrap_or_else(|| "-".into()),
            e.first_upper_crossing
                .map(num)
                .unwrap_or_else(|| "-".into()),
        ];
        row.extend(e.rest.iter().map(|(_, t)| secs(*t)));
        rows.push(row);
    }
    let mut paper = vec!["the paper".to_string(), "-".into(), "-".into()];
    paper.extend(REST_THRESHOLDS.iter().map(|_| {
        claims
            .rest_time_s
            .map(|t| format!("about {t} (threshold not stated)"))
            .unwrap_or_else(|| "-".into())
    }));
    rows.push(paper);
    d.table(&head, &rows);
    // Plain statement.
    let at =
        |e: &StackEvents, key: &str| e.rest.iter().find(|(k, _)| k == key).and_then(|(_, t)| *t);
    let span = |key: &str| {
        let v: Vec<f64> = evs.iter().filter_map(|e| at(e, key)).collect();
        if v.is_empty() {
            "no engine comes to rest".to_string()
        } else {
            let (lo, hi) = v
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                    (a.min(*x), b.max(*x))
                });
            format!("{lo:.2}-{hi:.2} s")
        }
    };
    // Thresholds at which every engine's rest time is within ABOUT_S of the paper's number.
    let close: Vec<&str> = match claims.rest_time_s {
        Some(claim) => REST_THRESHOLDS
            .iter()
            .map(|(k, _)| *k)
            .filter(|k| {
                !evs.is_empty()
                    && evs
                        .iter()
                        .all(|e| at(e, k).is_some_and(|t| (t - claim).abs() <= ABOUT_S))
            })
            .collect(),
        None => Vec::new(),
    };
    d.p(&format!(
        "Stated plainly: at |φ| < 1e-4 rad the engines put the stack at rest at {}; at 1e-3 rad \
         at {}; at 1e-2 rad at {}; at 3e-2 rad at {}. {} The rest time depends strongly on the \
         threshold, which the paper does not state. No engine is tuned toward the paper's \
         number.",
        span("1e-4"),
        span("1e-3"),
        span("1e-2"),
        span("3e-2"),
        match (claims.rest_time_s, close.is_empty()) {
            (None, _) => "The paper states no rest time.".to_string(),
            (Some(c), true) =>
                format!("At no threshold are all engines within {ABOUT_S} s of the paper's {c} s."),
            (Some(c), false) => format!(
                "All engines are within {ABOUT_S} s of the paper's \"about {c} s\" only at {} rad.",
                close.join(" and ")
            ),
        }
    ));
    // The upper block's absolute rotation.
    let statue = c.scene.blocks.len().saturating_sub(1);
    let mut plot = Plot {
        title: format!(
            "Upper block `{}`: absolute rotation (compare with the paper's figure)",
            c.scene.blocks[statue].name
        ),
        x_label: "t (s)".into(),
        y_label: "rotation (rad)".into(),
        ..Default::default()
    };
    let mut k = 0;
    for er in c.ok_runs() {
        if let Some(o) = &er.output {
            let (x, y) = decimate(&o.trajectory.t, &o.trajectory.blocks[statue].phi, 1200);
            plot.curves.push(Curve {
                name: er.engine.clone(),
                color: PALETTE[k % PALETTE.len()].into(),
                dashed: false,
                x,
                y,
            });
            k += 1;
        }
    }
    if let Some(tr) = &claims.converged {
        let (x, y) = decimate(&tr.t, &tr.blocks[statue].phi, 1200);
        plot.curves.push(Curve {
            name: "native dt 1e-4 (reference-data)".into(),
            color: "#000000".into(),
            dashed: true,
            x,
            y,
        });
    }
    d.plot("paper-two-block-upper-rotation.svg", &plot);
}

fn case_section(d: &mut Doc, r: &CaseResult, root_rel: &dyn Fn(&Path) -> String) {
    d.h(2, &format!("{}: {}", r.case.name, r.case.title));
    if !r.case.description.is_empty() {
        d.p(&r.case.description);
    }
    d.p(&format!(
        "Reference: `{}`.{}",
        r.case.reference.label(),
        r.case
            .references
            .as_ref()
            .map(|p| format!(
                " Reference data and provenance: `{}`.",
                root_rel(&p.join("PROVENANCE.md"))
            ))
            .unwrap_or_default()
    ));
    for run in &r.runs {
        match &run.comparison {
            Ok(c) => {
                let sts: Vec<String> = c
                    .runs
                    .iter()
                    .map(|x| match &x.status {
                        Status::Ok => format!(
                            "{} ok ({:.2} s{})",
                            x.engine,
                            x.summary.as_ref().map(|s| s.wall_time_s).unwrap_or(0.0),
                            if x.cached { ", cached" } else { "" }
                        ),
                        s => format!("{} {}: {}", x.engine, s.word(), s.reason().unwrap_or("")),
                    })
                    .collect();
                d.link(
                    &format!("Run `{}`: comparison report", run.label),
                    &format!("{}/report.html", run.dir),
                );
                d.p(&format!("Engines: {}.", sts.join("; ")));
            }
            Err(e) => d.p(&format!("Run `{}`: no comparison: {e}", run.label)),
        }
    }
    if r.gates.is_empty() {
        d.p("No gate on this case.");
        return;
    }
    let head: Vec<String> = [
        "gate",
        "engine",
        "block",
        "metric",
        "value",
        "reference",
        "checked",
        "tolerance",
        "expected",
        "result",
    ]
    .map(String::from)
    .to_vec();
    let f = |x: Option<f64>| x.map(num).unwrap_or_else(|| "-".into());
    let rows: Vec<Vec<String>> = r
        .gates
        .iter()
        .map(|g| {
            vec![
                g.gate.name.clone(),
                g.gate.engine.clone(),
                g.block.clone().unwrap_or_else(|| "-".into()),
                g.gate.metric.clone(),
                f(g.value),
                f(g.reference),
                f(g.checked),
                format!("{:e}", g.gate.tolerance),
                match g.gate.expect {
                    Expect::Pass => "pass".into(),
                    Expect::KnownFailure => "known failure".into(),
                },
                match g.outcome {
                    Outcome::Pass => "pass".into(),
                    o => o.word().to_string(),
                },
            ]
        })
        .collect();
    d.table(&head, &rows);
    let known: Vec<String> = r
        .gates
        .iter()
        .filter(|g| g.gate.expect == Expect::KnownFailure)
        .map(|g| {
            format!(
                "`{}` ({}): {}",
                g.gate.name,
                g.gate.engine,
                g.gate.reason.as_deref().unwrap_or("")
            )
        })
        .collect();
    if !known.is_empty() {
        d.p(&format!("Known failures: {}", known.join(" — ")));
    }
    for g in r.gates.iter().filter(|g| g.outcome.is_bad()) {
        d.p(&format!(
            "{}: `{}`: {}",
            g.outcome.word(),
            g.gate.name,
            g.message
        ));
    }
}

/// Render the suite report: (HTML, Markdown, plots).
pub fn render(
    results: &[CaseResult],
    engines: &[String],
    claims: Option<&PaperClaims>,
    prov: &Provenance,
    root_rel: &dyn Fn(&Path) -> String,
) -> (String, String, Vec<(String, String)>) {
    let mut d = Doc::new();
    d.h(1, "rockbench validation report");
    d.p(&format!(
        "The validation cases of VALIDATION.md on the engines {}, with their accuracy gates. \
         Generated {} by {}. Command: `{}`.",
        engines
            .iter()
            .map(|e| format!("`{e}`"))
            .collect::<Vec<_>>()
            .join(", "),
        prov.date,
        prov.program(),
        prov.command
    ));
    d.h(2, "Summary matrix");
    d.p(
        "Each cell: pass (every gate of the engine on the case as expected, known failures \
         included and counted), FAIL (a gate failed, or a known failure passes), skipped (the \
         engine cannot model the case, or is not built), no gate (ran, nothing checked), \
         reference (the case's reference engine); worst: the gate whose checked error is \
         largest relative to its tolerance.",
    );
    let (head, rows) = matrix_verdict(results, engines);
    d.raw(
        &(crate::report::verdict::legend_html(&[
            (Verdict::Agree, "pass"),
            (Verdict::Known, "pass with known failures"),
            (Verdict::Differs, "FAIL"),
            (Verdict::Info, "skipped / reference / no gate"),
        ]) + &crate::report::verdict::table_html("matrix", &head, &rows)),
        &crate::report::verdict::table_md(&head, &rows),
    );
    let total: usize = results.iter().map(|r| r.gates.len()).sum();
    let bad: usize = results
        .iter()
        .flat_map(|r| &r.gates)
        .filter(|g| g.outcome.is_bad())
        .count();
    let known: usize = results
        .iter()
        .flat_map(|r| &r.gates)
        .filter(|g| g.outcome == Outcome::KnownFailure)
        .count();
    d.p(&format!(
        "{} of {total} gates as expected ({known} of them known failures); {bad} not.",
        total - bad
    ));
    if let (Some(r), Some(cl)) = (results.iter().find(|r| r.case.paper), claims) {
        paper_section(&mut d, r, cl);
    }
    for r in results {
        case_section(&mut d, r, root_rel);
    }
    let html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <title>rockbench validation report</title><style>{CSS}{}</style></head><body>\n{}</body></html>\n",
        crate::report::verdict::CSS,
        d.html
    );
    (html, d.md, d.plots)
}
