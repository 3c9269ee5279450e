//! Diagnostics: the interval of horizontal ground accelerations (in g) under which a scene's
//! blocks stay at rest where they start, by the static theorem on its closed points
//! (`Stepper::rest_interval_of`; exact for the associative law).
//! `cargo run --release --example wall_rest_interval -- SCENE...`
use rockbench::native::stepper_for;
use rockbench::scene::load_scene_with_overrides;

fn main() {
    for path in std::env::args().skip(1) {
        let loaded = load_scene_with_overrides(std::path::Path::new(&path), &[])
            .map_err(|e| e.to_string())
            .and_then(|scene| {
                stepper_for(&scene)
                    .map(|(stepper, state)| (scene, stepper, state))
                    .map_err(|e| e.to_string())
            });
        let (scene, stepper, state) = match loaded {
            Ok(x) => x,
            Err(e) => {
                eprintln!("{path}: {e}");
                std::process::exit(2);
            }
        };
        let t = std::time::Instant::now();
        match stepper.rest_interval_of(&state) {
            Some((lo, hi)) => println!(
                "{path}: {} blocks, rest for a in [{:.4}, {:.4}] g ({:.1} s)",
                stepper.bodies.len(),
                lo / scene.gravity,
                hi / scene.gravity,
                t.elapsed().as_secs_f64()
            ),
            None => println!("{path}: no interval"),
        }
    }
}
