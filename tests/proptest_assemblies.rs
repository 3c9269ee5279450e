//! Random large assemblies on the native engine: running-bond walls and colonnades of 19 to 430
//! blocks, on the sparse back-end (forced, or picked by `auto` for the wide islands), struck by a
//! pulse or set moving, for a few tens of steps. Every run either ends in a trajectory that keeps
//! the invariants (finite, complete, no penetration beyond `PENETRATION_LIMIT`, no energy
//! gained without excitation, an assembly at rest left at rest, the same to the bit when run
//! again) or fails the test: an engine error on such a scene is a defect of the back-end's wide
//! path, not an outcome. `tests/proptest_scenes.rs` covers stacks of one to four blocks; the
//! wide-envelope path (interior-point rescues, held rows, stagnation exits) is only taken by
//! islands of hundreds of DOFs, which only these scenes reach.
//!
//! `PROPTEST_CASES` sets the number of cases (default 32 in `make test`, with a fixed seed; `make
//! proptest-assemblies` runs 600 with a new seed, or PROPTEST_RNG_SEED). A failing case prints its
//! scene's text; shrinking is off (a large scene shrinks for hours).

mod common;

use proptest::prelude::*;
use rockbench::engines::engine_by_name;
use rockbench::engines::registry::check_scene_str;
use rockbench::invariants::{Extra, Tolerances, energy_scale, run_checked, smallest_dimension};
use std::fmt::Write as _;
use std::path::Path;

/// Largest penetration of a native run, m: the impact stepper's rows hold every point to
/// `PENETRATION_TOLERANCE` (1e-9 m), and impacts left to the end of their step are projected
/// out to it.
const PENETRATION_LIMIT: f64 = 1e-8;

/// With impacts at the end of their step (`native.locate_impacts = false`) the velocity-level
/// law of such an impact lets its point penetrate by up to `dt |v_n| / 2`, and projecting the
/// penetration out lifts blocks (`Stepper::project_out_penetration`), a first-order error in
/// `dt` like the impact's instant: the one way the impact stepper gains energy without
/// excitation. With impacts located, the impacts left over by `native.located_per_step` that
/// close early in their step take the same law and the same projection. A run's energy growth
/// is excused up to what its projections gained (with the round-off allowance of every run);
/// a run that projects nothing is excused nothing.
fn projected_energy(notes: &[String]) -> Result<f64, TestCaseError> {
    common::projected_energy(notes).ok_or_else(|| {
        TestCaseError::fail(format!(
            "the native run's notes do not give its projections' energy: {notes:?}"
        ))
    })
}

#[derive(Debug, Clone)]
enum Layout {
    /// A running-bond wall (`rockbench::walls`' layout): `courses` courses of `per_course`
    /// blocks of `width x height`, half blocks at the ends of odd courses; each course's
    /// density drawn apart.
    Wall {
        courses: usize,
        per_course: usize,
        width: f64,
        height: f64,
        densities: Vec<f64>,
    },
    /// `posts` posts of `post_width x post_height`, `spacing` apart, under `posts - 1` lintels
    /// of `lintel_height`, each spanning two posts; `touching` lintels meet end to end above a
    /// post's centre, otherwise they stop `gap` short of each other.
    Colonnade {
        posts: usize,
        spacing: f64,
        post_width: f64,
        post_height: f64,
        post_density: f64,
        lintel_height: f64,
        lintel_density: f64,
        touching: bool,
    },
}

#[derive(Debug, Clone)]
enum Loading {
    /// No excitation: the top blocks (the top course, the lintels) start at `vx` m/s.
    Push { vx: f64 },
    /// No excitation and no initial motion: the assembly must stay where it is.
    AtRest,
    /// A horizontal pulse of ground acceleration from 0 s.
    Pulse {
        kind: &'static str,
        amplitude: f64,
        duration: f64,
    },
}

#[derive(Debug, Clone)]
struct Assembly {
    layout: Layout,
    loading: Loading,
    friction: f64,
    dt: f64,
    steps: usize,
    solver: &'static str,
    locate_impacts: bool,
}

fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..hi.ln()).prop_map(f64::exp)
}

fn wall(max_blocks: usize) -> impl Strategy<Value = Layout> {
    (3usize..12, 0.2..1.0f64, 0.1..0.5f64)
        .prop_flat_map(move |(courses, width, height)| {
            // `per_course` whole blocks a course, a half block more on every odd course.
            let most = (max_blocks - courses / 2) / courses;
            (
                Just(courses),
                6usize..=most.clamp(6, 35),
                Just(width),
                Just(height),
            )
        })
        .prop_flat_map(|(courses, per_course, width, height)| {
            (
                Just((courses, per_course, width, height)),
                prop_oneof![
                    3 => log_uniform(300.0, 3000.0).prop_map(move |d| vec![d; courses]),
                    1 => prop::collection::vec(log_uniform(10.0, 1e4), courses),
                ],
            )
        })
        .prop_map(
            |((courses, per_course, width, height), densities)| Layout::Wall {
                courses,
                per_course,
                width,
                height,
                densities,
            },
        )
}

fn colonnade(max_blocks: usize) -> impl Strategy<Value = Layout> {
    (
        10usize..=max_blocks.div_ceil(2).min(89),
        0.5..2.0f64,
        0.03..0.3f64,
        0.5..2.5f64,
        log_uniform(10.0, 3000.0),
        0.03..0.3f64,
        log_uniform(10.0, 3000.0),
        any::<bool>(),
    )
        .prop_map(
            |(
                posts,
                spacing,
                post_frac,
                post_height,
                post_density,
                lintel_height,
                lintel_density,
                touching,
            )| Layout::Colonnade {
                posts,
                spacing,
                post_width: post_frac * spacing,
                post_height,
                post_density,
                lintel_height,
                lintel_density,
                touching,
            },
        )
}

fn loading() -> impl Strategy<Value = Loading> {
    prop_oneof![
        2 => (-0.5..0.5f64).prop_map(|vx| Loading::Push { vx }),
        1 => Just(Loading::AtRest),
        3 => (
            prop_oneof![Just("half-sine"), Just("one-sine"), Just("rectangular")],
            2.0..15.0f64,
            0.01..0.3f64,
        )
            .prop_map(|(kind, amplitude, duration)| Loading::Pulse {
                kind,
                amplitude,
                duration
            }),
    ]
}

fn assembly(max_blocks: usize) -> impl Strategy<Value = Assembly> {
    (
        prop_oneof![2 => wall(max_blocks), 1 => colonnade(max_blocks)],
        loading(),
        0.3..1.5f64,
        log_uniform(5e-4, 2e-3),
        10usize..40,
        prop_oneof![Just("auto"), Just("sparse")],
        prop_oneof![1 => Just(true), 2 => Just(false)],
    )
        .prop_map(
            |(layout, loading, friction, dt, steps, solver, locate_impacts)| Assembly {
                layout,
                loading,
                friction,
                dt,
                steps,
                solver,
                locate_impacts,
            },
        )
}

impl Assembly {
    fn n_blocks(&self) -> usize {
        match &self.layout {
            Layout::Wall {
                courses,
                per_course,
                ..
            } => courses * per_course + courses / 2,
            Layout::Colonnade { posts, .. } => 2 * posts - 1,
        }
    }

    /// The scene's text.
    fn toml(&self) -> String {
        let mut s = String::new();
        let duration = self.dt * self.steps as f64;
        let _ = writeln!(
            s,
            "name = \"random-assembly\"\nduration = {duration:e}\noutput_interval = {:e}\n",
            self.dt
        );
        let mut top = Vec::new();
        match &self.layout {
            Layout::Wall {
                courses,
                per_course,
                width,
                height,
                densities,
            } => {
                let mut spec = rockbench::walls::WallSpec::running_bond(*courses, *per_course);
                spec.width = *width;
                for (name, course, x, w) in spec.blocks() {
                    let _ = writeln!(
                        s,
                        "[[blocks]]\nname = \"{name}\"\nwidth = {w:e}\nheight = {height:e}\n\
                         density = {:e}\nx = {x:e}\n",
                        densities[course]
                    );
                    if course + 1 == *courses {
                        top.push(name);
                    }
                }
            }
            Layout::Colonnade {
                posts,
                spacing,
                post_width,
                post_height,
                post_density,
                lintel_height,
                lintel_density,
                touching,
            } => {
                for i in 0..*posts {
                    let _ = writeln!(
                        s,
                        "[[blocks]]\nname = \"p{i}\"\nwidth = {post_width:e}\n\
                         height = {post_height:e}\ndensity = {post_density:e}\nx = {:e}\n",
                        i as f64 * spacing
                    );
                }
                // A lintel spans two posts' centres, or stops a tenth of a post short of the
                // next lintel (it still rests on both posts).
                let lintel = if *touching {
                    *spacing
                } else {
                    spacing - 0.1 * post_width
                };
                for i in 0..posts - 1 {
                    let name = format!("l{i}");
                    let _ = writeln!(
                        s,
                        "[[blocks]]\nname = \"{name}\"\nwidth = {lintel:e}\n\
                         height = {lintel_height:e}\ndensity = {lintel_density:e}\nx = {:e}\n",
                        (i as f64 + 0.5) * spacing
                    );
                    top.push(name);
                }
            }
        }
        let _ = writeln!(s, "[contact]\nfriction = {:e}\n", self.friction);
        match &self.loading {
            Loading::Push { vx } => {
                for name in &top {
                    let _ = writeln!(s, "[initial.blocks.{name}]\nvx = {vx:e}\n");
                }
            }
            Loading::AtRest => {}
            Loading::Pulse {
                kind,
                amplitude,
                duration,
            } => {
                let _ = writeln!(
                    s,
                    "[excitation.horizontal]\nkind = \"{kind}\"\namplitude = {amplitude:e}\n\
                     duration = {duration:e}\nstart = 0\n"
                );
            }
        }
        let _ = writeln!(
            s,
            "[native]\nsolver = \"{}\"\ndt = {:e}\nlocate_impacts = {}",
            self.solver, self.dt, self.locate_impacts
        );
        s
    }
}

/// The largest assembly: 150 blocks in `make test` (450 DOFs, past the sparse back-end's
/// `LARGE_PROBLEM`, so its wide path is taken; a 236-block wall under a 0.87 g pulse with its
/// impacts located costs 31 s a run), 430 in `make proptest-assemblies`.
fn max_blocks() -> usize {
    if std::env::var("PROPTEST_CASES").is_err() {
        150
    } else {
        430
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: common::proptest_cases(32),
        max_shrink_iters: 0,
        failure_persistence: None,
        rng_seed: common::proptest_seed(20_261_129),
        ..ProptestConfig::default()
    })]

    #[test]
    fn a_random_assembly_keeps_every_invariant(a in assembly(max_blocks())) {
        let text = a.toml();
        let scene = check_scene_str(&text, false, "random-assembly.toml", &[], Path::new("."))
            .map_err(|e| TestCaseError::fail(format!("the scene is refused: {e}\n<<<\n{text}>>>")))?;
        prop_assert_eq!(scene.blocks.len(), a.n_blocks());
        prop_assert!(a.n_blocks() <= max_blocks());
        let tol = Tolerances {
            penetration_rel: PENETRATION_LIMIT / smallest_dimension(&scene),
            ..Tolerances::default()
        };
        let native = engine_by_name("native").unwrap();
        let started = std::time::Instant::now();
        let (out, report) = run_checked(native.as_ref(), &scene, &tol, Extra { mirror: false, rerun: true })
            .map_err(|e| TestCaseError::fail(format!("native: {e}\n<<<\n{text}>>>")))?;
        let projected = projected_energy(&out.notes)? / energy_scale(&scene);
        let excused = |name: &str, value: f64| {
            let projecting = projected > 0.0
                && name == "energy"
                && value <= projected + tol.energy_rel;
            if projecting {
                // Counted with `-- --nocapture`.
                eprintln!(
                    "excused: energy growth {value:.3e} (located {}), its projections gaining {projected:.3e} (of sum m g H)",
                    a.locate_impacts
                );
            }
            projecting
        };
        let violations: Vec<String> = report
            .violations()
            .iter()
            .filter(|c| !excused(c.name, c.value))
            .map(|c| format!("{}: {}", c.name, c.detail))
            .collect();
        // Counted with `-- --nocapture`: the cases run and what they cost.
        eprintln!(
            "case: {} blocks, {} steps, {:?}, {}, located {}: {:.2} s (two runs)",
            a.n_blocks(), a.steps, a.loading, a.solver, a.locate_impacts,
            started.elapsed().as_secs_f64()
        );
        prop_assert!(out.trajectory.is_finite());
        prop_assert!(
            violations.is_empty(),
            "native: invariants violated: {}\n<<<\n{text}>>>",
            violations.join("; ")
        );
    }
}
