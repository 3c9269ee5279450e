//! Provenance of a report: the program (version, commit, sources), the machine, the command.

use crate::build_info;
use serde::Serialize;
use std::process::Command;

#[derive(Debug, Clone, Serialize)]
pub struct Provenance {
    pub rockbench_version: String,
    /// The commit the program was built from ([`build_info::GIT_COMMIT`]), not that of the
    /// directory it runs in.
    pub git_commit: String,
    /// The hash of the program's sources ([`build_info::SOURCE_HASH`]).
    pub source_hash: String,
    pub hostname: String,
    pub cpu: String,
    pub cores: usize,
    pub os: String,
    /// UTC, ISO 8601.
    pub date: String,
    pub command: String,
}

fn cmd(program: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(program).args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

impl Provenance {
    /// `rockbench VERSION (commit C, sources S)`.
    pub fn program(&self) -> String {
        format!(
            "rockbench {} (commit {}, sources {})",
            self.rockbench_version, self.git_commit, self.source_hash
        )
    }

    /// `HOST (CPU, N cores), OS`.
    pub fn machine(&self) -> String {
        format!(
            "{} ({}, {} cores), {}",
            self.hostname, self.cpu, self.cores, self.os
        )
    }

    /// The `## Provenance` section of a table of timings: the program, each engine's version
    /// (`(engine, version)`, listed once each in order of name), the machine and the date.
    pub fn markdown<'a>(&self, engines: impl IntoIterator<Item = (&'a str, &'a str)>) -> String {
        let mut engines: Vec<(&str, &str)> = engines.into_iter().collect();
        engines.sort_unstable();
        engines.dedup();
        let mut md = format!("\n## Provenance\n\n- {}\n", self.program());
        for (engine, version) in engines {
            md += &format!("- engine `{engine}`: {version}\n");
        }
        md + &format!(
            "- machine: {}\n- date (UTC): {}\n",
            self.machine(),
            self.date
        )
    }

    /// The `provenance.json` beside a table of timings: this provenance and each engine's
    /// version (`engine_versions`, by name).
    pub fn json_with_engines<'a>(
        &self,
        engines: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> serde_json::Value {
        let by_engine: std::collections::BTreeMap<&str, &str> = engines.into_iter().collect();
        serde_json::json!({ "provenance": self, "engine_versions": by_engine })
    }

    pub fn collect(command: &str) -> Provenance {
        let hostname = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .or_else(|_| std::fs::read_to_string("/etc/hostname"))
            .map(|s| s.trim().to_string())
            .ok()
            .or_else(|| cmd("hostname", &[]))
            .unwrap_or_else(|| "unknown".into());
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        let os_name = std::fs::read_to_string("/etc/os-release")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("PRETTY_NAME="))
                    .map(|v| v.trim_matches('"').to_string())
            })
            .unwrap_or_else(|| std::env::consts::OS.to_string());
        let kernel = cmd("uname", &["-r"]).map(|k| format!(", kernel {k}"));
        Provenance {
            rockbench_version: build_info::VERSION.to_string(),
            git_commit: build_info::GIT_COMMIT.to_string(),
            source_hash: build_info::SOURCE_HASH.to_string(),
            hostname,
            cpu,
            cores: std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            os: format!("{os_name}{}", kernel.unwrap_or_default()),
            date: utc_now(),
            command: command.to_string(),
        }
    }
}

/// Current UTC time as `YYYY-MM-DDTHH:MM:SSZ`.
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_secs() as i64)
        .unwrap_or(0);
    iso_utc(secs)
}

/// Seconds since the Unix epoch as ISO 8601 UTC (civil-from-days).
pub fn iso_utc(secs: i64) -> String {
    let days = secs.div_euclid(86_400);
    let rem = secs.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn iso_dates() {
        assert_eq!(super::iso_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(super::iso_utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(super::iso_utc(1_700_000_000), "2023-11-14T22:13:20Z");
    }
}
