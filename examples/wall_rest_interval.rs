//! Diagnostics: the interval of horizontal ground accelerations (in g) under which a scene's
//! blocks stay at rest where they start, by the static theorem on its closed points
//! (`native::sleep::rest_interval`; exact for the associative law).
//! `cargo run --release --example wall_rest_interval -- SCENE...`
use rockbench::native::assembly::{contact_rows, poses};
use rockbench::native::sleep::rest_interval;
use rockbench::native::stepper::CLOSED_GAP;
use rockbench::native::stepper_for;
use rockbench::scene::load_scene_with_overrides;

fn main() {
    for path in std::env::args().skip(1) {
        let scene = load_scene_with_overrides(std::path::Path::new(&path), &[]).unwrap();
        let (stepper, state) = stepper_for(&scene).unwrap();
        let ps = poses(&state.q);
        let rows: Vec<_> = stepper
            .detect(&state)
            .iter()
            .filter(|c| c.gap <= CLOSED_GAP)
            .map(|c| contact_rows(c, &ps, stepper.bodies.friction(c), (0.0, 0.0)))
            .collect();
        let blocks: Vec<usize> = (0..stepper.bodies.len()).collect();
        let t = std::time::Instant::now();
        match rest_interval(&blocks, &rows, &stepper.bodies.mass, scene.gravity) {
            Some((lo, hi)) => println!(
                "{path}: {} blocks, {} closed points, rest for a in [{:.4}, {:.4}] g ({:.1} s)",
                blocks.len(),
                rows.len(),
                lo / scene.gravity,
                hi / scene.gravity,
                t.elapsed().as_secs_f64()
            ),
            None => println!("{path}: no interval"),
        }
    }
}
