//! The step problems of a scene's native run written out, with the native back-end's solutions
//! of them and what each cost, for independent solvers to solve again
//! (`benches/walls/external_qp.py`, `make bench-walls-external-qp`).
//! `cargo run --release --example wall_problems -- SCENE STEPS DIR [--set K=V ...]`
//!
//! Before each step `k` the problem the step starts with (`Stepper::next_problem`: detection at
//! the step's start, the displacement problem of its first sub-step) goes to
//! `DIR/step-KKKK.json` as `{"step", "problem", "native"}`. `native` is that problem solved by
//! a back-end of the scene's settings (`solver_for`) that has solved the earlier steps' problems
//! in turn, so it starts warm as the engine's does: `dq`, `normal`, `tangential`, the wall time
//! `ms`, and its `factorisations` and `rescues`; `native.cold` is the same problem solved by a
//! back-end that has solved nothing (`dq`, `ms`, `factorisations`, `rescues`), as the
//! independent solvers solve it. The engine's own step then advances the state.
//! `DIR/provenance.json` records the command, versions and machine, the scene and the native
//! settings that produced the files.
use anyhow::{Context, bail};
use rockbench::native::solver::{ContactSolver, solver_for};
use rockbench::native::{StepProblem, StepSolution, stepper_for};
use rockbench::report::provenance::Provenance;
use rockbench::scene::load_scene_with_overrides;
use std::path::PathBuf;
use std::time::Instant;

#[path = "common/step_count.rs"]
mod step_count;
use step_count::whole_steps;

const USAGE: &str = "usage: wall_problems SCENE STEPS DIR [--set K=V ...]";

fn main() {
    if let Err(e) = write_problems() {
        // One line: the error and its causes.
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn write_problems() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, steps, dir, flags @ ..] = &args[..] else {
        bail!("{USAGE}");
    };
    let steps = whole_steps(steps)?;
    let mut sets = Vec::new();
    let mut rest = flags.iter();
    while let Some(flag) = rest.next() {
        let value = rest
            .next()
            .with_context(|| format!("{flag}: needs a value; {USAGE}"))?;
        match flag.as_str() {
            "--set" => sets.push(value.clone()),
            _ => bail!("unknown argument {flag:?}; {USAGE}"),
        }
    }
    let scene_path = scene;
    let scene = load_scene_with_overrides(std::path::Path::new(scene_path), &sets)?;
    let (mut st, mut s) = stepper_for(&scene)?;
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    write_whole(
        &dir.join("provenance.json"),
        &serde_json::json!({
            "provenance": Provenance::collect(&std::env::args().collect::<Vec<_>>().join(" ")),
            "scene": scene_path,
            "native_settings": st.settings,
        }),
    )?;
    let mut solver = solver_for(&st.settings);
    let dt = st.settings.dt;
    for k in 1..=steps {
        let problem = st.next_problem(&s);
        let (f0, r0) = (solver.factorisations(), solver.rescues());
        let (solution, ms) = solve_timed(solver.as_mut(), &problem, k, "")?;
        // The same problem from a back-end that has solved nothing: the cold solve, as the
        // independent solvers make it.
        let mut cold = solver_for(&st.settings);
        let (cold_solution, cold_ms) = solve_timed(cold.as_mut(), &problem, k, ", cold,")?;
        let record = serde_json::json!({
            "step": k,
            "problem": problem,
            "native": {
                "backend": solver.name(),
                "dq": solution.dq,
                "normal": solution.normal,
                "tangential": solution.tangential,
                "ms": ms,
                "factorisations": solver.factorisations() - f0,
                "rescues": solver.rescues() - r0,
                "cold": {
                    "dq": cold_solution.dq,
                    "ms": cold_ms,
                    "factorisations": cold.factorisations(),
                    "rescues": cold.rescues(),
                },
            },
        });
        write_whole(&dir.join(format!("step-{k:04}.json")), &record)?;
        st.step(&mut s)?;
        // Step k ends at k dt exactly, as in the engine's runs (the same path at round-off).
        s.t = k as f64 * dt;
        println!(
            "step {k}: {} contact points, native {ms:.2} ms, {} factorisations",
            problem.contacts.len(),
            solver.factorisations() - f0
        );
    }
    Ok(())
}

/// `problem` solved by `solver`, and the wall time it took in ms; a failure names step `k`
/// (`how`: which solve).
fn solve_timed(
    solver: &mut dyn ContactSolver,
    problem: &StepProblem,
    k: u64,
    how: &str,
) -> anyhow::Result<(StepSolution, f64)> {
    let t0 = Instant::now();
    let solution = solver.solve(problem).map_err(|e| {
        anyhow::anyhow!(
            "step {k}: the native back-end ({}){how} failed: {}",
            e.solver,
            e.status
        )
    })?;
    Ok((solution, t0.elapsed().as_secs_f64() * 1e3))
}

/// `value` as JSON at `path`, written whole and then renamed: a file of DIR is never
/// half-written.
fn write_whole(path: &std::path::Path, value: &serde_json::Value) -> anyhow::Result<()> {
    let partial = path.with_extension("json.partial");
    std::fs::write(&partial, serde_json::to_vec(value)?)
        .with_context(|| format!("{}: cannot write", partial.display()))?;
    std::fs::rename(&partial, path).with_context(|| format!("{}: cannot write", path.display()))
}
