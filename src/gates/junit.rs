//! JUnit XML of a gate run (one `<testcase>` per gate): failures for failing gates and for
//! known failures that now pass, `<skipped>` for known failures that still fail; the suite's
//! properties name the program (version, commit, sources).

use super::{GateResult, Outcome};
use std::fmt::Write;

fn attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\n', "&#10;")
}

pub fn junit_xml(results: &[GateResult], suite: &str) -> String {
    let failures = results.iter().filter(|r| r.outcome.is_bad()).count();
    let skipped = results
        .iter()
        .filter(|r| r.outcome == Outcome::KnownFailure)
        .count();
    let time: f64 = results.iter().map(|r| r.time_s).sum();
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        x,
        "<testsuites name=\"rockbench gates\" tests=\"{}\" failures=\"{failures}\" errors=\"0\" skipped=\"{skipped}\" time=\"{time:.3}\">",
        results.len()
    );
    let _ = writeln!(
        x,
        "  <testsuite name=\"{}\" tests=\"{}\" failures=\"{failures}\" errors=\"0\" skipped=\"{skipped}\" time=\"{time:.3}\">",
        attr(suite),
        results.len()
    );
    // The program that judged the gates.
    let _ = writeln!(x, "    <properties>");
    for (name, value) in [
        ("rockbench_version", crate::build_info::VERSION),
        ("rockbench_git_commit", crate::build_info::GIT_COMMIT),
        ("rockbench_source_hash", crate::build_info::SOURCE_HASH),
    ] {
        let _ = writeln!(
            x,
            "      <property name=\"{name}\" value=\"{}\"/>",
            attr(value)
        );
    }
    let _ = writeln!(x, "    </properties>");
    for r in results {
        let g = &r.gate;
        let _ = write!(
            x,
            "    <testcase name=\"{}\" classname=\"rockbench.gates.{}.{}\" time=\"{:.3}\"",
            attr(&g.name),
            attr(&g.scene.name),
            attr(&g.engine),
            r.time_s
        );
        let detail = format!(
            "scene {} ({}), engine {}, reference {}, block {}, metric {}, value {}, reference value {}, tolerance {}{}",
            g.scene.name,
            g.scene_path.display(),
            g.engine,
            g.reference_label(),
            r.block.as_deref().unwrap_or("-"),
            g.metric,
            r.value
                .map(|v| format!("{v:e}"))
                .unwrap_or_else(|| "none".into()),
            r.reference
                .map(|v| format!("{v:e}"))
                .unwrap_or_else(|| "none".into()),
            g.tolerance,
            if r.cached {
                ", run served from the cache"
            } else {
                ""
            }
        );
        match r.outcome {
            Outcome::Pass => {
                let _ = writeln!(
                    x,
                    ">\n      <system-out>{}</system-out>\n    </testcase>",
                    attr(&detail)
                );
            }
            Outcome::Fail | Outcome::UnexpectedPass => {
                let _ = writeln!(
                    x,
                    ">\n      <failure message=\"{}\" type=\"{}\">{}</failure>\n    </testcase>",
                    attr(&r.message),
                    if r.outcome == Outcome::Fail {
                        "gate-failed"
                    } else {
                        "known-failure-passes"
                    },
                    attr(&detail)
                );
            }
            Outcome::KnownFailure => {
                let _ = writeln!(
                    x,
                    ">\n      <skipped message=\"{}\"/>\n      <system-out>{}</system-out>\n    </testcase>",
                    attr(&r.message),
                    attr(&detail)
                );
            }
        }
    }
    x.push_str("  </testsuite>\n</testsuites>\n");
    x
}
