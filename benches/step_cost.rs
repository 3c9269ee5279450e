//! Per-step cost of the native engine for 1, 2, 10, 50 and 210 blocks, for every contact
//! solver back-end. Stacks are measured while rocking (a snapshot taken a little after
//! release, every sample starting from it); the 210-block running-bond wall at rest.
//! A second group, `wall_at_rest`, is the series for the sparse back-end: running-bond walls
//! of 21 blocks per course and 2 to 40 courses (42 to 840 blocks), whose cost per step should
//! grow linearly with the number of courses (and of contacts).
//!
//! A third group, `friction_law`, compares Coulomb friction with the associative law on the
//! two-block case and the 210-block wall (`cargo bench --bench step_cost -- friction_law`), and
//! a fourth, `stepper`, the impact stepper (the default) with the paper's.
//!
//! `cargo bench --bench step_cost` (or `make bench-steps`). The dense active-set back-end is
//! not run on the 210-block wall (see below).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use rockbench::native::stepper::{NativeState, Stepper};
use rockbench::native::stepper_for;
use rockbench::scene::{Scene, parse_scene_str};
use std::hint::black_box;
use std::time::Duration;

/// A column of `n` blocks (1.0 x 0.5 m; the 2-block case is the paper's stack), tilted.
fn stack(n: usize) -> Scene {
    let mut s = String::from("name = \"stack\"\nduration = 10.0\n");
    if n == 2 {
        s += "[[blocks]]\nname = \"b0\"\nwidth = 1.25\nheight = 1.25\n[[blocks]]\nname = \"b1\"\nwidth = 1.0\nheight = 2.5\n[initial]\ntilt = 0.15\n";
    } else if n == 1 {
        s += "[[blocks]]\nname = \"b0\"\nwidth = 1.0\nheight = 2.5\n[initial]\ntilt = 0.15\n";
    } else {
        for i in 0..n {
            s += &format!("[[blocks]]\nname = \"b{i}\"\nwidth = 1.0\nheight = 0.5\n");
        }
        s += &format!(
            "[initial]\ntilt = {}\n",
            0.5 * (1.0f64 / (0.5 * n as f64)).atan()
        );
    }
    parse_scene_str(&s, false, "bench", &[]).unwrap()
}

/// A running-bond wall of `courses` courses of 21 blocks (1.0 x 0.5 m), every other course
/// shifted by half a block.
fn wall(courses: usize) -> Scene {
    let mut s = String::from("name = \"wall\"\nduration = 10.0\n");
    for c in 0..courses {
        for i in 0..21 {
            let x = i as f64 + if c % 2 == 1 { 0.5 } else { 0.0 };
            s += &format!("[[blocks]]\nname = \"c{c}b{i}\"\nwidth = 1.0\nheight = 0.5\nx = {x}\n");
        }
    }
    parse_scene_str(&s, false, "bench", &[]).unwrap()
}

/// One step from `state`, every sample starting from the same snapshot.
fn bench_step(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: BenchmarkId,
    stepper: &mut Stepper,
    state: &NativeState,
) {
    g.bench_function(id, |b| {
        b.iter_batched(
            || state.clone(),
            |mut s| {
                stepper.step(&mut s).unwrap();
                black_box(s)
            },
            criterion::BatchSize::SmallInput,
        )
    });
}

fn step_cost(c: &mut Criterion) {
    rockbench::allocator::keep_freed_memory();
    let mut g = c.benchmark_group("native_step");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(20);
    for solver in ["active-set", "sparse", "clarabel", "auto"] {
        for n in [1usize, 2, 10, 50, 210] {
            if solver == "active-set" && n == 210 {
                // The dense working-set factorisation is O(m^3) in the ~1700 rows of the wall
                // (measured: tens of seconds per step); `auto` hands such problems to Clarabel.
                continue;
            }
            let mut scene = if n == 210 { wall(10) } else { stack(n) };
            scene.set_setting("native", "solver", solver);
            let (mut stepper, mut state) = stepper_for(&scene).unwrap();
            // Into the motion: 0.1 s for stacks (rocking), one step for the wall.
            let warm = if n == 210 { 1 } else { 100 };
            for _ in 0..warm {
                stepper.step(&mut state).unwrap();
            }
            bench_step(&mut g, BenchmarkId::new(solver, n), &mut stepper, &state);
        }
    }
    g.finish();
}

/// The sparse back-end on walls at rest of growing height.
fn wall_at_rest(c: &mut Criterion) {
    rockbench::allocator::keep_freed_memory();
    let mut g = c.benchmark_group("wall_at_rest");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(20);
    for courses in [2usize, 5, 10, 20, 40] {
        let mut scene = wall(courses);
        scene.set_setting("native", "solver", "sparse");
        let (mut stepper, mut state) = stepper_for(&scene).unwrap();
        // Past the first steps, in which the tallest walls settle by round-off amounts.
        for _ in 0..100 {
            stepper.step(&mut state).unwrap();
        }
        let contacts = stepper.last_contacts.len();
        let id = BenchmarkId::new(format!("sparse/{contacts}-contacts"), 21 * courses);
        bench_step(&mut g, id, &mut stepper, &state);
    }
    g.finish();
}

/// The impact stepper (the default) against the paper's, `auto` back-end: one block and the
/// two-block case rocking, the 210-block wall at rest
/// (`cargo bench --bench step_cost -- stepper`).
fn stepper(c: &mut Criterion) {
    rockbench::allocator::keep_freed_memory();
    let mut g = c.benchmark_group("stepper");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(20);
    for (name, n) in [("one-block", 1usize), ("two-block", 2), ("wall-210", 210)] {
        for kind in ["paper", "impact"] {
            let mut scene = if n == 210 { wall(10) } else { stack(n) };
            scene.set_setting("native", "stepper", kind);
            let (mut stepper, mut state) = stepper_for(&scene).unwrap();
            for _ in 0..100 {
                stepper.step(&mut state).unwrap();
            }
            bench_step(&mut g, BenchmarkId::new(kind, name), &mut stepper, &state);
        }
    }
    g.finish();
}

/// Non-associative Coulomb friction against the paper's associative law (default `auto`
/// back-end, default stepper): the two-block case rocking and the 210-block wall at rest.
fn coulomb(c: &mut Criterion) {
    rockbench::allocator::keep_freed_memory();
    let mut g = c.benchmark_group("friction_law");
    g.measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500))
        .sample_size(20);
    for (name, n) in [("two-block", 2usize), ("wall-210", 210)] {
        for law in ["associative", "coulomb"] {
            let mut scene = if n == 210 { wall(10) } else { stack(n) };
            scene.set_setting("native", "friction_law", law);
            let (mut stepper, mut state) = stepper_for(&scene).unwrap();
            for _ in 0..100 {
                stepper.step(&mut state).unwrap();
            }
            bench_step(&mut g, BenchmarkId::new(law, name), &mut stepper, &state);
        }
    }
    g.finish();
}

criterion_group!(benches, step_cost, wall_at_rest, coulomb, stepper);
criterion_main!(benches);
