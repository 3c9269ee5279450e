//! Print a running-bond wall scene (rockbench::walls) on stdout:
//! `cargo run --release --example wall_scene -- COURSES PER_COURSE WIDTH HEIGHT DURATION
//! [RECORD SCALE]`. benches/walls/wall-in-motion.toml is
//! `wall_scene 5 8 0.3 0.45 6 ../../validation/records/elcentro-1940.AT2 2` (tests/walls.rs checks it).
use rockbench::walls::WallSpec;

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() < 5 {
        eprintln!("usage: wall_scene COURSES PER_COURSE WIDTH HEIGHT DURATION [RECORD SCALE]");
        std::process::exit(2);
    }
    let num = |i: usize| -> f64 {
        a[i].parse().unwrap_or_else(|_| {
            eprintln!("argument {}: `{}` is not a number", i + 1, a[i]);
            std::process::exit(2)
        })
    };
    let mut w = WallSpec::running_bond(num(0) as usize, num(1) as usize);
    w.width = num(2);
    w.height = num(3);
    w.duration = num(4);
    if a.len() >= 7 {
        w.record = Some((a[5].clone(), num(6)));
    }
    print!("{}", w.to_toml());
}
