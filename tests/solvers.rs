//! The fast back-ends against the reference (Clarabel) on whole runs.

use rockbench::engines::{RunOutput, engine_by_name, run_timed};
use rockbench::native::problem::ContactRows;
use rockbench::native::solver::{ActiveSetSolver, ClarabelSolver, ContactSolver};
use rockbench::native::{NativeSettings, StepProblem};
use rockbench::scene::load_scene_with_overrides;
use rockbench::summary::Summary;
use std::path::Path;

fn run(scene: &str, solver: &str) -> (RunOutput, Summary) {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("validation/scenes")
        .join(scene);
    let s = load_scene_with_overrides(&p, &[format!("native.solver=\"{solver}\"")]).unwrap();
    run_timed(engine_by_name("native").unwrap().as_ref(), &s).unwrap()
}

#[test]
fn active_set_matches_clarabel_up_to_the_first_impact_and_in_impact_times() {
    for scene in [
        "two-block-free-rocking.toml",
        "housner-slender.toml",
        "housner-square.toml",
    ] {
        let (a, sa) = run(scene, "clarabel");
        let (b, sb) = run(scene, "active-set");
        let first = sa.blocks[0].impacts[0];
        for (ba, bb) in a.trajectory.blocks.iter().zip(&b.trajectory.blocks) {
            let worst = a
                .trajectory
                .t
                .iter()
                .zip(ba.phi.iter().zip(&bb.phi))
                .filter(|(t, _)| **t <= first)
                .fold(0.0f64, |m, (_, (x, y))| m.max((x - y).abs()));
            assert!(
                worst < 1e-6,
                "{scene} {}: rotation difference {worst:e} rad before the first impact",
                ba.name
            );
        }
        for (x, y) in sa.blocks.iter().zip(&sb.blocks) {
            let n = x.impacts.len().min(y.impacts.len()).min(4);
            assert!(n >= 1, "{scene}: impacts");
            for k in 0..n {
                assert!(
                    (x.impacts[k] - y.impacts[k]).abs() <= 1e-3,
                    "{scene} {} impact {k}: clarabel {} active-set {}",
                    x.name,
                    x.impacts[k],
                    y.impacts[k]
                );
            }
        }
    }
}

/// A point mass on the ground with a sideways push above the friction limit: both back-ends
/// give the same increment and the friction force mu N.
#[test]
fn tiny_problem_with_known_answer() {
    let pr = StepProblem {
        theta: 0.7,
        dt: 1e-3,
        mass: vec![2.0, 2.0, 1.0],
        force: vec![3.0 * 2.0 * 9.81, -2.0 * 9.81, 0.0],
        v0: vec![0.0; 3],
        contacts: vec![ContactRows {
            key: 1,
            mu: 0.5,
            g_n: 0.0,
            g_t: 0.0,
            nrow: vec![(0, 0.0), (1, 1.0), (2, 0.0)],
            trow: vec![(0, 1.0), (1, 0.0), (2, 0.0)],
        }],
    };
    let a = ClarabelSolver::new(&NativeSettings::default())
        .solve(&pr)
        .unwrap();
    let b = ActiveSetSolver::new().solve(&pr).unwrap();
    for (x, y) in a.dq.iter().zip(&b.dq) {
        assert!((x - y).abs() < 1e-12, "{:?} vs {:?}", a.dq, b.dq);
    }
    // Sliding on the cone edge: dz = mu dx and T = -mu N.
    assert!((b.dq[1] - 0.5 * b.dq[0]).abs() < 1e-14);
    assert!((b.tangential[0] + 0.5 * b.normal[0]).abs() < 1e-9 * b.normal[0]);
}
