//! Random scenes: every one is either refused with a one-line scene error, or run by every
//! engine to a trajectory that passes the invariants (finite, penetration, energy, standing,
//! mirror, rerun), or ends in a typed engine error. Never a panic. The native engine runs on
//! the default back-end (`auto`: dense for these stacks of 1-4 blocks), or on the sparse one in
//! two scenes of seven, or on Clarabel (the reference, polished) in one of seven; a third of the
//! scenes (drawn independently) use non-associative Coulomb friction (`native.friction_law =
//! "coulomb"`) instead of the paper's law. (With the same seed, 10,000 cases, the polish of
//! least-squares working sets before 2026-12-01 gave seven Clarabel errors, its polish not
//! verifying, and then a stack that moved 3.8e-8 m where it should stand; now none.)
//!
//! `PROPTEST_CASES` sets the number of cases (default 200 in `make test`, with a fixed seed;
//! `make proptest` runs 10,000 with a new seed, or PROPTEST_RNG_SEED). Runs are kept short (at most 0.25 s and 400 steps) so a case costs
//! milliseconds.

mod common;

use proptest::prelude::*;
use rockbench::engines::registry::check_scene_str;
use rockbench::engines::{EngineError, engine_by_name, registry};
use rockbench::invariants::{Extra, Tolerances, run_checked};
use rockbench::scene::Scene;
use std::fmt::Write as _;
use std::path::Path;

#[derive(Debug, Clone)]
struct RBlock {
    width: f64,
    height: f64,
    density: f64,
    /// Offset as a fraction of the narrower of this block and the block below.
    offset_frac: f64,
    rotation: f64,
    omega: f64,
    vx: f64,
    friction: Option<f64>,
}

#[derive(Debug, Clone)]
enum RExcitation {
    None,
    Pulse {
        kind: &'static str,
        amplitude: f64,
        period: f64,
        start: f64,
    },
}

#[derive(Debug, Clone)]
struct RScene {
    blocks: Vec<RBlock>,
    tilt: f64,
    friction: f64,
    theta: f64,
    dt: f64,
    duration: f64,
    gravity: f64,
    moving_ground: bool,
    dual: bool,
    /// The contact back-end: `auto` (dense for these small stacks), `sparse` or `clarabel`.
    solver: &'static str,
    /// Non-associative (Coulomb) friction instead of the paper's associative law.
    coulomb: bool,
    excitation: RExcitation,
}

fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..hi.ln()).prop_map(f64::exp)
}

fn block() -> impl Strategy<Value = RBlock> {
    (
        log_uniform(0.05, 5.0),
        log_uniform(0.05, 5.0),
        log_uniform(10.0, 1e4),
        prop_oneof![4 => -0.45..0.45f64, 1 => -0.7..0.7f64],
        prop_oneof![2 => Just(0.0), 1 => -0.3..0.3f64],
        prop_oneof![2 => Just(0.0), 1 => -1.0..1.0f64],
        prop_oneof![3 => Just(0.0), 1 => -0.5..0.5f64],
        prop::option::weighted(0.2, 0.0..2.0f64),
    )
        .prop_map(
            |(width, height, density, offset_frac, rotation, omega, vx, friction)| RBlock {
                width,
                height,
                density,
                offset_frac,
                rotation,
                omega,
                vx,
                friction,
            },
        )
}

fn excitation() -> impl Strategy<Value = RExcitation> {
    prop_oneof![
        2 => Just(RExcitation::None),
        1 => (
            prop_oneof![Just("half-sine"), Just("one-sine"), Just("rectangular")],
            -30.0..30.0f64,
            0.02..1.0f64,
            0.0..0.1f64
        )
            .prop_map(|(kind, amplitude, period, start)| RExcitation::Pulse {
                kind,
                amplitude,
                period,
                start
            }),
    ]
}

fn scene() -> impl Strategy<Value = RScene> {
    (
        prop::collection::vec(block(), 1..5),
        prop_oneof![2 => Just(0.0), 3 => -0.6..0.6f64],
        0.0..2.0f64,
        prop_oneof![1 => Just(0.5), 1 => Just(1.0), 3 => 0.5..=1.0f64],
        log_uniform(5e-4, 5e-3),
        0.01..0.25f64,
        prop_oneof![4 => Just(9.81), 1 => 0.5..30.0f64],
        any::<bool>(),
        any::<bool>(),
        prop_oneof![4 => Just("auto"), 2 => Just("sparse"), 1 => Just("clarabel")],
        excitation(),
        prop_oneof![2 => Just(false), 1 => Just(true)],
    )
        .prop_map(
            |(
                blocks,
                tilt,
                friction,
                theta,
                dt,
                duration,
                gravity,
                moving_ground,
                dual,
                solver,
                excitation,
                coulomb,
            )| {
                RScene {
                    blocks,
                    tilt,
                    friction,
                    theta,
                    dt,
                    duration,
                    gravity,
                    moving_ground,
                    dual,
                    solver,
                    excitation,
                    coulomb,
                }
            },
        )
}

impl RScene {
    fn toml(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "name = \"random\"\nduration = {:e}\ngravity = {:e}\noutput_interval = {:e}",
            self.duration, self.gravity, self.dt
        );
        for (i, b) in self.blocks.iter().enumerate() {
            let below = if i == 0 {
                b.width
            } else {
                self.blocks[i - 1].width
            };
            let offset = b.offset_frac * b.width.min(below);
            let _ = writeln!(
                s,
                "\n[[blocks]]\nname = \"b{i}\"\nwidth = {:e}\nheight = {:e}\ndensity = {:e}\noffset = {:e}",
                b.width, b.height, b.density, offset
            );
        }
        let _ = writeln!(s, "\n[initial]\ntilt = {:e}", self.tilt);
        for (i, b) in self.blocks.iter().enumerate() {
            let _ = writeln!(
                s,
                "\n[initial.blocks.b{i}]\nrotation = {:e}\nomega = {:e}\nvx = {:e}",
                if i == 0 { 0.0 } else { b.rotation },
                b.omega,
                b.vx
            );
        }
        let _ = writeln!(s, "\n[contact]\nfriction = {:e}", self.friction);
        for (i, b) in self.blocks.iter().enumerate() {
            if let Some(mu) = b.friction {
                let _ = writeln!(s, "\n[contact.interfaces.b{i}]\nfriction = {mu:e}");
            }
        }
        let _ = writeln!(
            s,
            "\n[native]\nsolver = \"{}\"\ntheta = {:e}\ndt = {:e}\nformulation = \"{}\"\nfriction_law = \"{}\"",
            self.solver,
            self.theta,
            self.dt,
            if self.dual { "dual" } else { "primal" },
            if self.coulomb {
                "coulomb"
            } else {
                "associative"
            }
        );
        if let RExcitation::Pulse {
            kind,
            amplitude,
            period,
            start,
        } = &self.excitation
        {
            let _ = writeln!(
                s,
                "\n[excitation]\napplied_as = \"{}\"\n\n[excitation.horizontal]\nkind = \"{kind}\"\namplitude = {amplitude:e}\nduration = {period:e}\nstart = {start:e}",
                if self.moving_ground {
                    "moving-ground"
                } else {
                    "inertial-forces"
                }
            );
        }
        s
    }
}

/// Known engine defects, each measured and reported, to remove when fixed. A violation is
/// excused only if it matches one of these exactly (engine, check, and below a bound).
struct KnownDefect {
    engine: &'static str,
    check: &'static str,
    /// Largest measured value excused.
    below: f64,
    /// The scenes it applies to.
    applies: fn(&Scene) -> bool,
    reason: &'static str,
}

const KNOWN_DEFECTS: &[KnownDefect] = &[
    KnownDefect {
        engine: "native",
        check: "mirror",
        below: 2e-1,
        applies: |s| {
            rockbench::native::settings_of(s)
                .is_ok_and(|n| n.stepper == rockbench::native::StepperKind::Impact)
                && s.blocks.len() > 1
        },
        reason: "impact-consistent stepper (the default; measured when it was an option forced \
                 on): the earlier loss of mirror symmetry on stacks (1e-3 to \
                 4e-2 rad) came from the choice between the velocity- and position-level law, \
                 decided by round-off for a persistent contact (gap and normal velocity \
                 ~1e-16), where for a sliding contact the two laws differ; fixed (a gap within \
                 1e-9 m counts as closed; test impact_consistent_stepper_keeps_a_sliding_stack_\
                 mirror_symmetric). Open, 1 in ~1500 random stacks: with midpoint kinematics a \
                 4-block stack (theta 0.70, dt 1.17e-3) jumps to 7e-4 rad from its mirror in \
                 one step with identical step inputs (1.4e-3 rad by the end; theta kinematics \
                 1.6e-7, the position stepper 9e-14), cause not found; at theta 0.5 round-off \
                 grows through chatter: a 3.2 x 0.05 m plank under a 1e5 kg block reaches \
                 0.124 rad at 0.17 s with either kinematics (the position stepper 8.4e-3)",
    },
    KnownDefect {
        engine: "native",
        check: "mirror",
        below: 1e-4,
        applies: |_| true,
        reason: "block-block contacts break corner-corner and face ties by block and face index \
                 (src/geometry.rs), which mirroring does not preserve; at such a tie, and at \
                 stick-slip switches of a small block on a tilted stack, round-off differences \
                 grow before any impact (measured: 1.5e-6 rad in 38 steps for a 7 cm block on a \
                 stack tilted 0.58 rad; 2.6e-6 for a single 0.23 x 0.066 m block whose pivot \
                 corner slips, tilted 0.6 rad, theta 0.5, two steps before its first impact)",
    },
    KnownDefect {
        engine: "native",
        check: "energy",
        below: 1e-5,
        applies: |s| rockbench::native::settings_of(s).is_ok_and(|n| n.theta == 0.5),
        reason: "at theta = 0.5 the scheme has no numerical damping and a closing contact \
                 rebounds with e = (1 - theta)/theta = 1, so a block lifted by associative \
                 friction (a slab sliding at 0.055 m/s is lifted 0.15 mm) bounces for ever and \
                 solver-tolerance errors accumulate: energy grows by 2.2e-9 of m g H (dual), \
                 3.4e-10 (primal); at theta 0.55 and above at most 2.2e-13. With a heavy \
                 block rocking on a light plank (mass ratio 3700, no friction, dt 5e-3) the \
                 growth reaches 6.1e-6 (3.6e-7 at dt 1e-3; none at theta 0.7)",
    },
    KnownDefect {
        engine: "native",
        check: "energy",
        below: 1e-4,
        applies: |s| {
            rockbench::native::settings_of(s).is_ok_and(|n| {
                n.theta == 0.5 && n.friction_law == rockbench::native::FrictionLaw::Coulomb
            })
        },
        reason: "Coulomb friction at theta = 0.5 (no numerical damping): a block rotating on a \
                 sliding corner penetrates by O((omega dt)^2 r) (the linearised rows, defect \
                 below), which the associative law's dilatancy hides and Coulomb's does not; the \
                 next step pushes the corner out under load, doing work N |g|: measured on a \
                 0.38 x 0.06 m slab tilted on a 6 x 7 cm block (g 27.6, dt 5.7e-4), a 3.25e-7 m \
                 penetration under 6.7 kN/m adds 2.2e-3 J/m, 4.15e-5 of m g H, identical with \
                 the dense, sparse and Clarabel back-ends; none at dt 2e-4 or theta 0.55",
    },
    KnownDefect {
        engine: "native",
        check: "penetration",
        below: 1e-3,
        applies: |s| {
            s.blocks.len() > 1
                && rockbench::native::settings_of(s)
                    .is_ok_and(|n| n.stepper == rockbench::native::StepperKind::Paper)
        },
        reason: "the paper's stepper: the step's contact rows are linear in the rotation \
                 increment, so a corner of a fast-rotating block overshoots the face by \
                 O((omega dt)^2 r) before the next re-detection: a 1 x 1 m block of 4428 kg/m^3 \
                 rotated 0.2 rad on a 0.12 m plank on a 0.32 m post sinks the plank 0.55 mm into \
                 the post at theta 0.5, dt 5e-3 (0.21 mm at theta 0.7; 15 um at dt 1e-3), against \
                 a limit of 12 um. The impact stepper (the default, which the random scenes use) \
                 is no longer excused (2026-11-29): its discrete-gradient rows hold every point \
                 exactly since an unconverged iteration halves the step and every contact point \
                 is a vertex on a face; 0 penetrations in 200,000 random scenes, against 4 in \
                 270,000 before (5.5e-6 to 1.0e-5 m)",
    },
];

/// The known defect that excuses a violation, if any. Each use is printed (`excused: ...`,
/// shown with `-- --nocapture`, with the scene's text) so that a run's excused classes can be
/// counted and each one run again.
fn excused(
    engine: &str,
    check: &str,
    value: f64,
    scene: &Scene,
    text: &str,
) -> Option<&'static str> {
    let k = KNOWN_DEFECTS.iter().position(|k| {
        k.engine == engine && k.check == check && value < k.below && (k.applies)(scene)
    })?;
    eprintln!("excused: known defect {k} ({engine} {check}) value {value:.3e}\n<<<\n{text}>>>");
    Some(KNOWN_DEFECTS[k].reason)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: common::proptest_cases(200),
        max_shrink_iters: 200,
        failure_persistence: None,
        rng_seed: common::proptest_seed(20_261_121),
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_scene_gives_valid_trajectory_or_typed_error(r in scene()) {
        let text = r.toml();
        let scene = match check_scene_str(&text, false, "random.toml", &[], Path::new(".")) {
            Ok(s) => s,
            Err(e) => {
                // A refused scene: one line naming the file and the field.
                let line = e.to_string();
                prop_assert!(!line.contains('\n'), "multi-line error: {line}");
                prop_assert!(line.starts_with("random.toml: "), "{line}");
                prop_assert!(!e.field.is_empty() && !e.message.is_empty(), "{line}");
                return Ok(());
            }
        };
        let tol = Tolerances::default();
        // In-process engines only: the external (Python worker) engines cost a process start
        // per run; their faults are covered by tests/external_engine.rs and the stress map.
        for name in registry::names().iter().filter(|n| !["mujoco", "pybullet", "siconos"].contains(n)) {
            let engine = engine_by_name(name).unwrap();
            let res = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                run_checked(engine.as_ref(), &scene, &tol, Extra { mirror: true, rerun: true })
            }));
            let res = match res {
                Ok(r) => r,
                Err(p) => {
                    let msg = p
                        .downcast_ref::<&str>()
                        .map(|s| s.to_string())
                        .or_else(|| p.downcast_ref::<String>().cloned())
                        .unwrap_or_default();
                    prop_assert!(false, "{name} panicked: {msg}\n{text}");
                    continue;
                }
            };
            match res {
                Ok((out, report)) => {
                    prop_assert!(out.trajectory.is_finite(), "{name}: non-finite trajectory\n{text}");
                    prop_assert!(!out.trajectory.is_empty());
                    let last = *out.trajectory.t.last().unwrap();
                    // The native engine shortens its last step and Housner lands on every
                    // output time: both end exactly at the duration. Rapier takes whole steps:
                    // its last sample may pass the duration by less than one step.
                    if ["native", "housner"].contains(name) {
                        prop_assert_eq!(last, scene.duration, "{}: last sample", name);
                    }
                    let slack = 1e-9 * scene.duration.max(1.0);
                    prop_assert!(
                        last >= scene.duration - slack && last < scene.duration + rockbench::native::settings_of(&scene).unwrap().dt.max(rockbench::engines::rapier_settings::RapierSettings::of(&scene).unwrap().dt) + slack,
                        "{name}: trajectory ends at {last}, duration {}", scene.duration
                    );
                    let v: Vec<String> = report
                        .violations()
                        .iter()
                        .filter(|c| excused(name, c.name, c.value, &scene, &text).is_none())
                        // Rapier's contacts are soft by design (it settles, sinks and is not
                        // mirror-symmetric at round-off): here it is held to the contract
                        // (finite, complete, deterministic, typed errors); its accuracy is
                        // measured in the validation gates.
                        .filter(|c| *name != "rapier" || ["finite", "complete", "rerun"].contains(&c.name))
                        .map(|c| format!("{}: {}", c.name, c.detail))
                        .collect();
                    prop_assert!(v.is_empty(), "{name}: invariants violated: {}\n{text}", v.join("; "));
                }
                // Typed errors are acceptable outcomes; their messages are single lines.
                Err(e @ (EngineError::Unsupported { .. } | EngineError::Failed { .. } | EngineError::Scene(_))) => {
                    prop_assert!(!e.to_string().contains('\n'), "{name}: {e}");
                    if *name == "native" {
                        // Counted with `-- --nocapture`.
                        eprintln!("native error ({:?} friction): {e}\n<<<\n{text}>>>", rockbench::native::settings_of(&scene).map(|n| n.friction_law));
                    }
                }
                Err(e) => prop_assert!(false, "{name}: unexpected error kind: {e}\n{text}"),
            }
        }
    }
}
