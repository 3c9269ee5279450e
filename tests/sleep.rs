//! Sleeping islands (`native.sleep`): the interval of ground accelerations that keeps blocks at
//! rest against the closed forms, and runs with sleeping against the same runs without it.

mod common;

use rockbench::native::stepper_for;
use rockbench::scene::{Scene, parse_scene_str};
use rockbench::walls::WallSpec;

const G: f64 = 9.81;

fn scene(text: &str, set: &[&str]) -> Scene {
    let set: Vec<String> = set.iter().map(|s| s.to_string()).collect();
    parse_scene_str(text, false, "sleep-test", &set).unwrap()
}

/// The interval of horizontal ground accelerations that keeps every block of the scene at rest
/// where it starts (all blocks one island), in units of g.
fn interval(text: &str) -> (f64, f64) {
    let s = scene(text, &[]);
    let (stepper, state) = stepper_for(&s).unwrap();
    let (lo, hi) = stepper.rest_interval_of(&state).unwrap();
    (lo / s.gravity, hi / s.gravity)
}

fn block(width: f64, height: f64, friction: f64) -> String {
    format!(
        "name = \"b\"\nduration = 1\n[[blocks]]\nname = \"b\"\nwidth = {width}\nheight = {height}\n[contact]\nfriction = {friction}\n"
    )
}

/// A block on the ground stays at rest while `|a| <= g min(mu, B/H)` (rocking or sliding); a
/// column of two equal blocks while `|a| <= g min(mu, B/(2H))` (the whole column rocks first):
/// the static theorem on the vertex contact points gives exactly these.
#[test]
fn the_rest_interval_is_the_rocking_or_sliding_threshold() {
    let cases = [
        (block(0.5, 2.0, 0.7), 0.25),
        (block(1.0, 1.0, 0.4), 0.4),
        (block(2.0, 1.0, 0.9), 0.9),
        (
            "name = \"c\"\nduration = 1\n[[blocks]]\nname = \"a\"\nwidth = 0.4\nheight = 1\n[[blocks]]\nname = \"b\"\nwidth = 0.4\nheight = 1\n[contact]\nfriction = 0.7\n".to_string(),
            0.2,
        ),
    ];
    for (text, expected) in cases {
        let (lo, hi) = interval(&text);
        assert!(
            (hi - expected).abs() < 1e-6 * expected && (lo + expected).abs() < 1e-6 * expected,
            "interval [{lo}, {hi}] g, expected +-{expected} g for\n{text}"
        );
    }
}

/// Positions of every step, and the sleep counters (fallen asleep, woken by the excitation,
/// woken by a contact, block-steps asleep).
fn run(s: &Scene) -> (Vec<Vec<f64>>, [u64; 4]) {
    let (mut stepper, mut state) = stepper_for(s).unwrap();
    let steps = (s.duration / stepper.settings.dt).round() as usize;
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        stepper.step(&mut state).unwrap();
        out.push(state.q.clone());
    }
    let counts = stepper.sleep.as_ref().map_or([0; 4], |sl| {
        [
            sl.fallen_asleep,
            sl.woken_by_excitation,
            sl.woken_by_contact,
            sl.block_steps_asleep,
        ]
    });
    (out, counts)
}

fn largest_difference(a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
        .fold(0.0, f64::max)
}

/// Runs `text` with and without sleeping under each stepper; returns the counters of the
/// sleeping runs after checking that both give the same positions at every step to the bound
/// sleeping promises: the speeds it zeroes (below `native.rest_velocity`, 1e-9 m/s) times the
/// run's duration.
fn same_with_and_without_sleep(text: &str) -> Vec<[u64; 4]> {
    ["impact", "paper"]
        .iter()
        .map(|stepper| {
            let stepper = format!("native.stepper=\"{stepper}\"");
            let (awake, none) = run(&scene(text, &[&stepper, "native.sleep=false"]));
            assert_eq!(none, [0; 4]);
            let s = scene(text, &[&stepper, "native.sleep=true"]);
            let bound = 1e-9 * s.duration;
            let (sleeping, counts) = run(&s);
            let d = largest_difference(&awake, &sleeping);
            eprintln!("{stepper}: largest difference {d:e}, counters {counts:?}");
            assert!(
                d <= bound,
                "{stepper}: sleeping moved the answer by {d:e} (bound {bound:e}); counters {counts:?}"
            );
            let moved = awake
                .iter()
                .flat_map(|q| q.iter().zip(&awake[0]).map(|(a, b)| (a - b).abs()))
                .fold(0.0, f64::max);
            assert!(moved > 1e-3, "{stepper}: nothing moved ({moved:e})");
            counts
        })
        .collect()
}

/// A slender block (tan alpha = 0.4) at rest sleeps; a half-sine pulse of 1.5 times its rocking
/// threshold starting at 0.3 s wakes it when its acceleration reaches the threshold, and the
/// rocking that follows is the one of the run without sleeping.
#[test]
fn a_pulse_wakes_a_sleeping_block_when_it_can_move_it() {
    let text = format!(
        "{}[excitation.horizontal]\nkind = \"half-sine\"\namplitude = {}\nduration = 0.6\nstart = 0.3\n",
        block(1.0, 2.5, 0.7).replace("duration = 1", "duration = 1.5"),
        1.5 * 0.4 * G
    );
    for counts in same_with_and_without_sleep(&text) {
        assert!(counts[0] >= 1 && counts[1] >= 1, "counters {counts:?}");
        // Asleep from 0.05 s until the pulse reaches the threshold (after 0.3 s).
        assert!(counts[3] >= 250, "counters {counts:?}");
    }
}

/// A block at rest sleeps; another slides into it and wakes it by contact; both runs agree.
#[test]
fn a_block_sliding_into_a_sleeping_one_wakes_it() {
    let text = "name = \"s\"\nduration = 0.8\n[[blocks]]\nname = \"still\"\nwidth = 0.5\nheight = 0.5\nx = 0\n[[blocks]]\nname = \"slider\"\nwidth = 0.5\nheight = 0.5\nx = -1.0\n[initial.blocks.slider]\nvx = 2.0\n[contact]\nfriction = 0.3\n";
    for counts in same_with_and_without_sleep(text) {
        assert!(counts[0] >= 1 && counts[2] >= 1, "counters {counts:?}");
    }
}

/// A running-bond wall of 3 courses of 6 blocks under a one-sine pulse that rocks part of it:
/// every block sleeps at first, the pulse wakes the wall, the blocks that end at rest sleep
/// again, and the positions are those of the run without sleeping.
#[test]
fn a_wall_woken_by_a_pulse_moves_as_without_sleeping() {
    let mut w = WallSpec::running_bond(3, 6);
    w.duration = 1.5;
    let text = format!(
        "{}\n[excitation.horizontal]\nkind = \"one-sine\"\namplitude = {}\nduration = 0.5\nstart = 0.2\n",
        w.to_toml(),
        0.8 * G
    );
    for counts in same_with_and_without_sleep(&text) {
        assert!(counts[0] >= 1 && counts[1] >= 1, "counters {counts:?}");
    }
}

/// Open defect (docs/method.md, "Sleeping islands"): three courses of the wall-in-motion scene
/// (0.3 x 0.45 m blocks) have a static collapse acceleration of 0.4232 g, yet awake under a
/// rectangular pulse of 0.38 g their velocities grow from round-off by a factor of about 2 a
/// step and the wall collapses: a closed point's positive round-off gap lets the end pieces'
/// separating face slip more than the associative cone allows at zero gap, with a gain of
/// 1 + x / (mu l - x) a step. The associative law's own answer is rest, as asleep.
#[test]
#[ignore = "open defect: the awake native engine collapses a wall below its static collapse acceleration"]
fn a_wall_loaded_below_its_static_collapse_acceleration_stays_at_rest() {
    let path = common::root().join("benches/walls/wall-in-motion.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let (head, blocks) = text.split_once("[[blocks]]").unwrap();
    let mut kept = head.replace("duration = 6", "duration = 0.5");
    for b in blocks.split("[[blocks]]") {
        let b = b.split("[excitation").next().unwrap();
        let course: usize = b
            .split("name = \"c")
            .nth(1)
            .unwrap()
            .split('b')
            .next()
            .unwrap()
            .parse()
            .unwrap();
        if course < 3 {
            kept.push_str("[[blocks]]");
            kept.push_str(b.split("[contact]").next().unwrap());
        }
    }
    kept.push_str(&format!(
        "[contact]\nfriction = 0.7\n[excitation.horizontal]\nkind = \"rectangular\"\namplitude = {}\nduration = 1.0\nstart = 0.1\n",
        0.38 * G
    ));
    let (lo, hi) = interval(&kept);
    assert!(hi > 0.42 && lo < -0.42, "interval [{lo}, {hi}] g");
    let (positions, _) = run(&scene(&kept, &["native.sleep=false"]));
    let moved = largest_difference(&positions, &vec![positions[0].clone(); positions.len()]);
    assert!(moved < 1e-9, "the wall moved by {moved:e} under 0.38 g");
}

/// `rockbench check --collapse` prints the rest interval of a scene and where its loading leaves
/// it: a block of B/H = 0.25 (friction 0.7) rests while `|a| <= 0.25 g`, and a rectangular pulse
/// of 0.3 g from 0.2 s leaves that at its start.
#[test]
fn check_prints_the_rest_interval_and_the_onset() {
    let dir = common::tmp("rb-collapse", "block");
    let file = dir.join("block.toml");
    let text = format!(
        "{}[excitation.horizontal]\nkind = \"rectangular\"\namplitude = {}\nduration = 0.5\nstart = 0.2\n",
        block(0.5, 2.0, 0.7),
        0.3 * G
    );
    std::fs::write(&file, text).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .args(["check", "--collapse"])
        .arg(&file)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{out:?}");
    assert!(
        stdout.contains("rest interval [-0.2500, 0.2500] g")
            && stdout.contains("peaks at 0.3000 g")
            && stdout.contains("leaves the interval at 0.2000 s"),
        "{stdout}"
    );
}

/// Sleep needs the excitation as horizontal inertial forces: under a moving ground it is off,
/// and the run says so (the summary's settings still record `sleep = true` as given).
#[test]
fn sleep_asked_for_where_it_cannot_be_is_off_and_noted() {
    use rockbench::engines::Engine;
    let text = format!(
        "{}[excitation.horizontal]\nkind = \"half-sine\"\namplitude = {}\nduration = 0.6\nstart = 0.3\n",
        block(1.0, 2.5, 0.7),
        0.2 * G
    );
    let note = "native.sleep: off for this scene";
    for (applied_as, off) in [("moving-ground", true), ("inertial-forces", false)] {
        let s = scene(
            &text,
            &[
                "native.sleep=true",
                &format!("excitation.applied_as=\"{applied_as}\""),
            ],
        );
        let out = rockbench::engines::native::NativeEngine.run(&s).unwrap();
        assert_eq!(
            out.notes.iter().any(|n| n.starts_with(note)),
            off,
            "{applied_as}: {:?}",
            out.notes
        );
    }
}
