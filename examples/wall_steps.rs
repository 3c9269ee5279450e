//! Diagnostics: step a scene with the native engine and print per-step cost and counters.
//! `cargo run --release --example wall_steps -- SCENE [STEPS] [--every N] [--set K=V ...]`
//! (a line every `N` steps, 100 by default). Each line ends with the islands of the step's
//! contact points: how many, the blocks of the largest, and the blocks with no point at all
//! (docs/method.md, "Blocks out of reach").
use anyhow::{Context, bail};
use rockbench::native::islands::{components_of_points, members};
use rockbench::native::stepper_for;
use rockbench::scene::load_scene_with_overrides;
use std::time::Instant;

#[path = "common/step_count.rs"]
mod step_count;
use step_count::whole_steps;

const USAGE: &str = "usage: wall_steps SCENE [STEPS] [--every N] [--set K=V ...]";

fn main() {
    if let Err(e) = steps() {
        // One line: the error and its causes.
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn steps() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first().map(std::path::PathBuf::from) else {
        bail!("{USAGE}");
    };
    let steps = match args.get(1).filter(|a| !a.starts_with("--")) {
        Some(a) => whole_steps(a)?,
        None => 1000,
    };
    // The flags after SCENE [STEPS]: `--set K=V` (repeatable) and `--every N`.
    let first_flag = if args.len() > 1 && !args[1].starts_with("--") {
        2
    } else {
        1
    };
    let (mut sets, mut every) = (Vec::new(), 100u64);
    let mut rest = args[first_flag..].iter();
    while let Some(flag) = rest.next() {
        let value = rest
            .next()
            .with_context(|| format!("{flag}: needs a value; {USAGE}"))?;
        match flag.as_str() {
            "--set" => sets.push(value.clone()),
            "--every" => {
                every = value.parse().ok().filter(|&n| n > 0).with_context(|| {
                    format!("--every: {value:?} is not a whole number of steps, 1 or more")
                })?
            }
            _ => bail!("unknown argument {flag:?}; {USAGE}"),
        }
    }
    let scene = load_scene_with_overrides(&path, &sets)?;
    let (mut st, mut s) = stepper_for(&scene)?;
    let dt = st.settings.dt;
    let t0 = Instant::now();
    let mut last = (0u64, 0u64, 0u64, Instant::now());
    for k in 1..=steps {
        st.step(&mut s)?;
        // Step k ends at k dt exactly, as in the engine's runs (the same path at round-off).
        s.t = k as f64 * dt;
        if k % every == 0 {
            let now = Instant::now();
            let islands = Islands::of(s.q.len() / 3, &st.last_contacts);
            println!(
                "{:5} t={:.2} {:7.3} ms/step it/step {:6.1} fact/step {:5.2} fallbacks {} rescues {} vmax {:.3e} islands {} largest {} free {}",
                k,
                s.t,
                (now - last.3).as_secs_f64() * 1e3 / every as f64,
                (st.iterations - last.0) as f64 / every as f64,
                (st.solver_factorisations() - last.1) as f64 / every as f64,
                st.solver_fallbacks() - last.2,
                st.solver_rescues(),
                s.v.iter().fold(0.0f64, |m, v| m.max(v.abs())),
                islands.count,
                islands.largest,
                islands.free
            );
            last = (
                st.iterations,
                st.solver_factorisations(),
                st.solver_fallbacks(),
                now,
            );
        }
    }
    println!(
        "total {:.3} s, {:.3} ms/step, {} fallbacks, {} factorisations ({} of velocity problems), {:.2} discrete-gradient solves and {:.2} end velocities settled a step, {} split steps, {} rescues, {} rows updated into or out of a factor",
        t0.elapsed().as_secs_f64(),
        t0.elapsed().as_secs_f64() * 1e3 / steps as f64,
        st.solver_fallbacks(),
        st.solver_factorisations(),
        st.velocity_factorisations(),
        st.gradient_solves as f64 / steps as f64,
        st.settled_velocities as f64 / steps as f64,
        st.split_steps,
        st.solver_rescues(),
        st.solver_factor_updates()
    );
    Ok(())
}

/// The islands of a step's contact points, counted.
struct Islands {
    count: usize,
    /// Blocks in the largest island.
    largest: usize,
    /// Blocks with no contact point (moving freely).
    free: usize,
}

impl Islands {
    fn of(blocks: usize, points: &[rockbench::geometry::ContactPoint]) -> Self {
        let island = components_of_points(blocks, points);
        let sets = members(&island);
        Islands {
            count: sets.len(),
            largest: sets.iter().map(Vec::len).max().unwrap_or(0),
            free: island.iter().filter(|i| i.is_none()).count(),
        }
    }
}
