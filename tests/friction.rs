//! The two friction laws on a block sliding to a stop: the stopping distance v^2 / (2 mu g) in
//! closed form, the associative law's dilatancy, and its absence under true Coulomb friction.

use rockbench::engines::{engine_by_name, run_timed};
use rockbench::scene::parse_scene_str;

fn slide(law: &str) -> rockbench::trajectory::BlockHistory {
    let text = format!(
        "name = \"slide\"\nduration = 0.5\n[[blocks]]\nname = \"b\"\nwidth = 1.0\nheight = 1.0\n\
         [initial.blocks.b]\nvx = 1.0\n[contact]\nfriction = 0.3\n[native]\nfriction_law = \"{law}\"\n"
    );
    let scene = parse_scene_str(&text, false, "slide", &[]).unwrap();
    let (out, _) = run_timed(engine_by_name("native").unwrap().as_ref(), &scene).unwrap();
    out.trajectory.blocks[0].clone()
}

#[test]
fn sliding_block_stops_at_the_closed_form_distance_under_both_laws() {
    let want = 1.0 / (2.0 * 0.3 * 9.81);
    for law in ["associative", "coulomb"] {
        let b = slide(law);
        let x = *b.x.last().unwrap();
        assert!(
            (x / want - 1.0).abs() < 5e-3,
            "{law}: stopped at {x} m, closed form {want} m"
        );
        assert!(b.vx.last().unwrap().abs() < 1e-9, "{law}: still moving");
    }
}

#[test]
fn associative_friction_dilates_and_coulomb_friction_does_not() {
    let lift =
        |b: &rockbench::trajectory::BlockHistory| b.z.iter().fold(0.0f64, |m, z| m.max(z - 0.5));
    let a = lift(&slide("associative"));
    let c = lift(&slide("coulomb"));
    // Associative: thrown up by about mu v dt per step while sliding (mm).
    assert!(a > 1e-3, "associative lift {a} m");
    assert!(c < 1e-9, "coulomb lift {c} m");
}
