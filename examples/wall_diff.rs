use rockbench::native::stepper_for;
use rockbench::scene::load_scene_with_overrides;
fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let p = std::path::PathBuf::from(&a[0]);
    let sa: Vec<String> = a[1].split(';').filter(|s| !s.is_empty()).map(String::from).collect();
    let sb: Vec<String> = a[2].split(';').filter(|s| !s.is_empty()).map(String::from).collect();
    let (mut x, mut s1) = stepper_for(&load_scene_with_overrides(&p, &sa).unwrap()).unwrap();
    let (mut y, mut s2) = stepper_for(&load_scene_with_overrides(&p, &sb).unwrap()).unwrap();
    for k in 1..=a[3].parse::<usize>().unwrap() {
        x.step(&mut s1).unwrap();
        y.step(&mut s2).unwrap();
        let d = s1.q.iter().zip(&s2.q).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let dv = s1.v.iter().zip(&s2.v).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let vmax = s1.v.iter().map(|a| a.abs()).fold(0.0, f64::max);
        let iv = (0..s1.v.len()).max_by(|&i, &j| s1.v[i].abs().total_cmp(&s1.v[j].abs())).unwrap();
        let id = (0..s1.v.len()).max_by(|&i, &j| (s1.v[i]-s2.v[i]).abs().total_cmp(&(s1.v[j]-s2.v[j]).abs())).unwrap();
        if k % 10 == 0 || k < 4 { println!("{k} dq {d:.3e} dv {dv:.3e} vmax {vmax:.3e} at dof {iv} (v2 {:.3e}); worst dv dof {id}: {:.6e} {:.6e}", s2.v[iv], s1.v[id], s2.v[id]); }
        if k < 6 { println!("  q14 {:?} v14 {:?}", &s1.q[42..45], &s1.v[42..45]); for c in x.last_contacts.iter().filter(|c| c.b == 14 || c.a == Some(14)) { println!("   {:?}", c); } }
        if d > 1e-5 { break; }
    }
}
#[allow(dead_code)]
fn unused() {}
