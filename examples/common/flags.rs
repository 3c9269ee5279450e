//! The command lines of the benchmark programs: `--flag value` pairs.

use anyhow::bail;

/// Every argument is a known flag of `flags` followed by its value, each flag given once: a
/// mistyped flag is an error (with `usage`), not a default run of the whole study.
pub fn check_flags(args: &[String], flags: &[&str], usage: &str) -> anyhow::Result<()> {
    let mut seen: Vec<&str> = Vec::new();
    let mut rest = args.iter();
    while let Some(flag) = rest.next() {
        if !flags.contains(&flag.as_str()) {
            bail!("unknown argument {flag:?}; usage: {usage}");
        }
        if seen.contains(&flag.as_str()) {
            bail!("{flag}: given twice");
        }
        seen.push(flag);
        if rest.next().is_none() {
            bail!("{flag}: needs a value");
        }
    }
    Ok(())
}

/// The value of flag `name` (checked by [`check_flags`]), or `default`.
pub fn arg<'a>(args: &'a [String], name: &str, default: &'a str) -> &'a str {
    args.windows(2)
        .find(|w| w[0] == name)
        .map_or(default, |w| w[1].as_str())
}
