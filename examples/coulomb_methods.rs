//! Measure the two ways of solving a step under Coulomb friction on a scene: the fixed point
//! on the slip offsets with Lemke's method behind it (the default) and Lemke's method alone.
//! Prints wall time per step and the largest state difference between the two.
//!
//! `cargo run --release --example coulomb_methods -- SCENE [KEY=VALUE ...]`

use rockbench::native::coulomb::CoulombMethod;
use rockbench::native::stepper_for;
use rockbench::scene::load_scene_with_overrides;
use std::time::Instant;

fn main() {
    if let Err(e) = compare() {
        // One line: the error and its causes.
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn compare() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        anyhow::bail!("usage: coulomb_methods SCENE [KEY=VALUE ...]");
    };
    let mut set: Vec<String> = vec!["native.friction_law=\"coulomb\"".into()];
    set.extend(args[1..].iter().cloned());
    let scene = load_scene_with_overrides(std::path::Path::new(path), &set)?;
    let dt = rockbench::native::settings_of(&scene)?.dt;
    let n = ((scene.duration / dt).ceil() as u64).max(1);
    let mut runs = Vec::new();
    for method in [CoulombMethod::FixedPointThenLemke, CoulombMethod::Lemke] {
        let (mut st, mut s) = stepper_for(&scene)?;
        st.coulomb.method = method;
        let mut states = Vec::new();
        let t = Instant::now();
        let mut err = None;
        for _ in 0..n {
            if let Err(e) = st.step(&mut s) {
                err = Some(e.to_string());
                break;
            }
            states.push(s.q.clone());
        }
        let el = t.elapsed().as_secs_f64();
        println!(
            "{method:?}: {} steps, {:.2} us a step, {} problems, {} back-end solves, {} by Lemke ({} pivots){}",
            states.len(),
            el / states.len().max(1) as f64 * 1e6,
            st.coulomb.problems,
            st.coulomb.iterations,
            st.coulomb.lemke_solves,
            st.coulomb.lemke_pivots,
            err.map(|e| format!(", FAILED: {e}")).unwrap_or_default()
        );
        runs.push(states);
    }
    let mut d = 0.0f64;
    let mut at = 0;
    for (k, (a, b)) in runs[0].iter().zip(&runs[1]).enumerate() {
        for (x, y) in a.iter().zip(b) {
            if (x - y).abs() > d {
                d = (x - y).abs();
                at = k + 1;
            }
        }
    }
    println!("largest position/rotation difference {d:.3e} (step {at})");
    Ok(())
}
