//! Instructions an engine's steps execute, counted by callgrind (`valgrind --tool=callgrind`).
//!
//! Wall time a step depends on the machine and on whatever else it runs: on the 2-core machines
//! of docs/walls.md the same binary's step on the same wall moved by up to 50 % between runs of
//! a day. The instructions executed do not: callgrind counts them for a given binary, input and
//! environment, whatever the load (tests/instructions.rs: a run counted twice gives the same
//! count). A count is not a time: instructions a second differ between programs and machines
//! (on those machines the native engine's wall steps ran at 7-10 thousand million a second,
//! rapier's at 6.6-9.0; docs/walls.md, "The walls' figures in instructions"). But two engines'
//! counts on one scene, and one engine's counts over a series of scenes, compare their work
//! independently of the machine.
//!
//! The count is the instructions executed inside one function and everything it calls
//! (`--toggle-collect`): an engine's step (see [`step_function`]), so that loading the scene and
//! writing the outputs are left out.

use std::path::Path;
use std::process::Command;

/// The function one step of `engine` runs, for the engines whose steps are Rust code in this
/// process: the native engine's `Stepper::step_by` (through which `Stepper::step` goes too) and
/// rapier's `RapierSim::step`, both kept out of line for it. The others (Housner's model, the
/// Python workers) have none.
pub fn step_function(engine: &str) -> Option<&'static str> {
    match engine {
        "native" => Some("rockbench::native::stepper::Stepper::step_by"),
        "rapier" => Some("rockbench::engines::rapier::RapierSim::step"),
        _ => None,
    }
}

/// `program` run under callgrind, counting the instructions executed in `function` (and what it
/// calls), its counts written to `counts` (read them with [`collected`]). Add the program's
/// arguments to the command returned.
pub fn under_callgrind(program: &Path, function: &str, counts: &Path) -> Command {
    let mut command = Command::new("valgrind");
    command
        .arg("--tool=callgrind")
        .arg(format!("--toggle-collect={function}"))
        .arg(format!("--callgrind-out-file={}", counts.display()))
        .arg(program);
    command
}

/// The instructions counted in a callgrind counts file's text: its `summary:` line (`totals:`
/// in older files).
pub fn parse_summary(text: &str) -> Option<u64> {
    text.lines()
        .find_map(|l| l.strip_prefix("summary:").or(l.strip_prefix("totals:")))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

/// The instructions counted in `function` by a run of [`under_callgrind`] that wrote `counts`.
/// None counted is an error: the function was not called, or was inlined into its callers
/// (callgrind then sees no such function).
pub fn collected(counts: &Path, function: &str) -> Result<u64, String> {
    let text = std::fs::read_to_string(counts)
        .map_err(|e| format!("{}: cannot read callgrind's counts: {e}", counts.display()))?;
    match parse_summary(&text) {
        None => Err(format!(
            "{}: no summary line: not a callgrind counts file",
            counts.display()
        )),
        Some(0) => Err(format!(
            "{}: no instruction counted in {function} (not called, or inlined into its callers)",
            counts.display()
        )),
        Some(n) => Ok(n),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_line_is_the_count() {
        let text = "# callgrind format\nversion: 1\ncreator: callgrind-3.19.0\n\
                    events: Ir\nsummary: 212616806\n\nfn=(1) main\n5 12\ntotals: 212616806\n";
        assert_eq!(parse_summary(text), Some(212_616_806));
        assert_eq!(parse_summary("events: Ir\ntotals: 17\n"), Some(17));
        assert_eq!(parse_summary("events: Ir\nfn=(1) main\n"), None);
        assert_eq!(parse_summary("summary: many\n"), None);
    }

    #[test]
    fn steps_of_engines_in_this_process_have_a_function() {
        assert!(step_function("native").is_some_and(|f| f.ends_with("Stepper::step_by")));
        assert!(step_function("rapier").is_some_and(|f| f.ends_with("RapierSim::step")));
        for engine in ["housner", "mujoco", "pybullet", "siconos", "auto"] {
            assert_eq!(step_function(engine), None, "{engine}");
        }
    }
}
