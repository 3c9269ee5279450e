//! Field-by-field checks of a parsed scene. Each failure is one line naming the field.

use super::layout::{Layout, overlap};
use super::{MotionSpec, Scene, SceneError};
use std::collections::BTreeSet;

/// Every check of the scene's own fields, then `tables` (the engine tables' check, from the
/// engine registry), which also runs [`check_samples`] where it orders it; without `tables`
/// the sample count is checked last.
pub(crate) fn validate(scene: &Scene, tables: Option<super::TableCheck>) -> Result<(), SceneError> {
    let file = scene.source.as_str();
    let err = |field: String, msg: String| Err(SceneError::new(file, field, msg));
    let positive = |field: &str, v: f64| -> Result<(), SceneError> {
        if !v.is_finite() || v <= 0.0 {
            return Err(SceneError::new(
                file,
                field,
                format!("must be a positive number (got {})", num(v)),
            ));
        }
        Ok(())
    };
    let finite = |field: &str, v: f64| -> Result<(), SceneError> {
        if !v.is_finite() {
            return Err(SceneError::new(
                file,
                field,
                format!("must be finite (got {})", num(v)),
            ));
        }
        Ok(())
    };

    if scene.name.trim().is_empty() {
        return err("name".into(), "must not be empty".into());
    }
    positive("duration", scene.duration)?;
    positive("gravity", scene.gravity)?;
    // Named as documented (`[output] interval`; the older top-level spelling is still read).
    positive("output.interval", scene.output_interval)?;
    if scene.output_interval > scene.duration {
        return err(
            "output.interval".into(),
            format!(
                "{} s is longer than the run, {} s: its events would be located from its first and last samples alone",
                num(scene.output_interval),
                num(scene.duration)
            ),
        );
    }
    if scene.blocks.is_empty() {
        return err(
            "blocks".into(),
            "at least one [[blocks]] entry is required".into(),
        );
    }
    let mut names = BTreeSet::new();
    for (i, b) in scene.blocks.iter().enumerate() {
        let f = |k: &str| format!("blocks[{i}].{k}");
        if b.name.trim().is_empty() {
            return err(f("name"), "must not be empty".into());
        }
        if let Some(c) = b
            .name
            .chars()
            .find(|&c| c.is_control() || c == ',' || c == '"')
        {
            return err(
                f("name"),
                format!(
                    "`{}` contains {:?}; block names become trajectory.csv column names",
                    b.name, c
                ),
            );
        }
        // `lower/upper` names an interface series of the outputs, `(run)` their run-level rows:
        // a block of either name made two rows of one key in metrics.csv.
        if b.name.contains('/') || b.name == super::RUN_ROW {
            return err(
                f("name"),
                format!(
                    "`{}` is a label of the outputs (`lower/upper` names an interface, `{}` the run's rows); give the block another name",
                    b.name,
                    super::RUN_ROW
                ),
            );
        }
        if b.name.trim() != b.name {
            return err(
                f("name"),
                format!(
                    "`{}` has leading or trailing spaces (a CSV reader may drop them, and two blocks differ by them)",
                    b.name
                ),
            );
        }
        if !names.insert(b.name.as_str()) {
            return err(f("name"), format!("duplicate block name `{}`", b.name));
        }
        positive(&f("width"), b.width)?;
        positive(&f("height"), b.height)?;
        positive(&f("density"), b.density)?;
        if !(MIN_DENSITY..=MAX_DENSITY).contains(&b.density) {
            return err(
                f("density"),
                format!(
                    "{} kg/m^3 is outside {MIN_DENSITY:e} to {MAX_DENSITY:e} (rapier and PyBullet froze blocks of 1e20 and 1e-300)",
                    num(b.density)
                ),
            );
        }
        if !(b.mass().is_finite() && b.mass() > 0.0 && b.inertia().is_finite() && b.inertia() > 0.0)
        {
            return err(
                format!("blocks[{i}]"),
                format!(
                    "mass {} kg/m and moment of inertia {} kg m^2/m of `{}` must be finite and positive (sizes or density out of range)",
                    num(b.mass()),
                    num(b.inertia()),
                    b.name
                ),
            );
        }
        finite(&f("offset"), b.offset)?;
        // Far from the origin a position keeps too few digits for a block's motion (a block at
        // x = 1e15 m rocked to another answer, and rapier's not at all).
        for (k, v) in [("offset", b.offset), ("x", b.x.unwrap_or(0.0))] {
            if v.abs() > MAX_POSITION {
                return err(
                    f(k),
                    format!(
                        "{} m is farther than {MAX_POSITION:e} m from the origin: positions there keep too few digits for a block's motion",
                        num(v)
                    ),
                );
            }
        }
        if let Some(x) = b.x {
            finite(&f("x"), x)?;
            if b.offset != 0.0 {
                return err(f("offset"), "give either `x` or `offset`, not both".into());
            }
        }
    }

    // Initial state.
    finite("initial.tilt", scene.initial.tilt)?;
    for (name, s) in &scene.initial.blocks {
        let f = |k: &str| format!("initial.blocks.{name}.{k}");
        if scene.index_of(name).is_none() {
            return err(
                format!("initial.blocks.{name}"),
                format!("there is no block named `{name}`"),
            );
        }
        finite(&f("rotation"), s.rotation)?;
        finite(&f("omega"), s.omega)?;
        finite(&f("vx"), s.vx)?;
        if s.rotation.abs() >= std::f64::consts::FRAC_PI_2 {
            return err(
                f("rotation"),
                format!("|rotation| must be below pi/2 (got {})", num(s.rotation)),
            );
        }
        // Speeds beyond MAX_INITIAL_SPEED are a slip; rapier clamped them (to 400 m/s) and the
        // native engine's first contact problem lost its scale.
        let b = &scene.blocks[scene.index_of(name).expect("checked above")];
        let rim = s.omega.abs() * b.width.hypot(b.height);
        for (k, speed, what) in [
            ("vx", s.vx.abs(), "a sliding speed"),
            ("omega", rim, "a rim speed"),
        ] {
            if speed > MAX_INITIAL_SPEED {
                return err(
                    f(k),
                    format!(
                        "{what} of {} m/s is above {MAX_INITIAL_SPEED} m/s",
                        num(speed)
                    ),
                );
            }
        }
    }
    if scene.initial.tilt.abs() >= std::f64::consts::FRAC_PI_2 {
        return err(
            "initial.tilt".into(),
            format!(
                "|tilt| must be below pi/2 (got {})",
                num(scene.initial.tilt)
            ),
        );
    }

    // Contact.
    let friction_ok = |field: &str, mu: f64| -> Result<(), SceneError> {
        if !mu.is_finite() || mu < 0.0 {
            return Err(SceneError::new(
                file,
                field,
                format!("must be a non-negative number (got {})", num(mu)),
            ));
        }
        if mu > MAX_FRICTION {
            return Err(SceneError::new(
                file,
                field,
                format!(
                    "{} is above {MAX_FRICTION:e}: a contact that must not slide needs a friction above its blocks' B/H only, and larger ones leave the contact problems ill-scaled",
                    num(mu)
                ),
            ));
        }
        Ok(())
    };
    friction_ok("contact.friction", scene.contact.friction)?;
    for (name, s) in &scene.contact.interfaces {
        if scene.index_of(name).is_none() {
            return err(
                format!("contact.interfaces.{name}"),
                format!(
                    "there is no block named `{name}` (interfaces are keyed by their upper block)"
                ),
            );
        }
        friction_ok(&format!("contact.interfaces.{name}.friction"), s.friction)?;
    }

    // Geometry: every block rests on something, nothing overlaps, nothing starts past
    // overturning.
    let layout = Layout::of(scene);
    for (i, b) in layout.blocks.iter().enumerate() {
        let (ux, uz) = layout.upright[i];
        if ![b.x, b.z, b.phi, b.vx, b.vz, b.omega, ux, uz]
            .iter()
            .all(|v| v.is_finite())
        {
            return err(
                format!("blocks[{i}]"),
                format!(
                    "the initial position or velocity of `{}` is not finite (offsets, sizes or initial state out of range)",
                    scene.blocks[i].name
                ),
            );
        }
    }
    for i in 1..scene.blocks.len() {
        let b = &scene.blocks[i];
        if b.x.is_none() {
            let below = &scene.blocks[i - 1];
            let (xb, _) = layout.upright[i - 1];
            let (x, _) = layout.upright[i];
            let ov = overlap(
                (x - b.width / 2.0, x + b.width / 2.0),
                (xb - below.width / 2.0, xb + below.width / 2.0),
            );
            if ov <= 1e-9 * b.width.max(below.width) {
                return err(
                    format!("blocks[{i}].offset"),
                    format!(
                        "block `{}` does not rest on block `{}` (offset {} leaves no overlap)",
                        b.name,
                        below.name,
                        num(b.offset)
                    ),
                );
            }
        }
    }
    for i in 0..scene.blocks.len() {
        for j in 0..i {
            let (bi, bj) = (&scene.blocks[i], &scene.blocks[j]);
            let (xi, zi) = layout.upright[i];
            let (xj, zj) = layout.upright[j];
            let ox = overlap(
                (xi - bi.width / 2.0, xi + bi.width / 2.0),
                (xj - bj.width / 2.0, xj + bj.width / 2.0),
            );
            let oz = overlap(
                (zi - bi.height / 2.0, zi + bi.height / 2.0),
                (zj - bj.height / 2.0, zj + bj.height / 2.0),
            );
            let tol = 1e-9 * (bi.width + bi.height + bj.width + bj.height);
            if ox > tol && oz > tol {
                return err(
                    format!("blocks[{i}]"),
                    format!("block `{}` overlaps block `{}`", bi.name, bj.name),
                );
            }
        }
    }
    check_overturning(scene, &layout)?;
    check_initial_overlaps(scene, &layout)?;

    // Excitation.
    if let Some(exc) = &scene.excitation {
        for (comp, m) in [("horizontal", &exc.horizontal), ("vertical", &exc.vertical)] {
            let Some(m) = m else { continue };
            let f = |k: &str| format!("excitation.{comp}.{k}");
            match m {
                MotionSpec::HalfSine {
                    amplitude,
                    duration,
                    period,
                    start,
                }
                | MotionSpec::OneSine {
                    amplitude,
                    duration,
                    period,
                    start,
                }
                | MotionSpec::OneCosine {
                    amplitude,
                    duration,
                    period,
                    start,
                } => {
                    finite(&f("amplitude"), *amplitude)?;
                    finite(&f("start"), *start)?;
                    match (duration, period) {
                        (Some(d), None) => positive(&f("duration"), *d)?,
                        (None, Some(p)) => positive(&f("period"), *p)?,
                        _ => {
                            return err(
                                format!("excitation.{comp}"),
                                "give exactly one of `duration` or `period`".into(),
                            );
                        }
                    }
                }
                MotionSpec::Ricker {
                    amplitude,
                    period,
                    start,
                } => {
                    finite(&f("amplitude"), *amplitude)?;
                    finite(&f("start"), *start)?;
                    positive(&f("period"), *period)?;
                }
                MotionSpec::Rectangular {
                    amplitude,
                    duration,
                    start,
                } => {
                    finite(&f("amplitude"), *amplitude)?;
                    finite(&f("start"), *start)?;
                    positive(&f("duration"), *duration)?;
                }
                MotionSpec::Record { scale, .. } | MotionSpec::Displacement { scale, .. } => {
                    finite(&f("scale"), *scale)?;
                }
            }
        }
        // A pulse acts from its `start` on: one that starts before the run would be cut (the
        // ground's motion before 0 s missing), one that starts after it would never act.
        for (comp, m) in [("horizontal", &exc.horizontal), ("vertical", &exc.vertical)] {
            let Some((_, start)) = m.as_ref().and_then(pulse_amplitude_and_start) else {
                continue;
            };
            let field = format!("excitation.{comp}.start");
            if start < 0.0 {
                return err(
                    field,
                    format!("must be >= 0: the run starts at 0 s (got {})", num(start)),
                );
            }
            if start >= scene.duration {
                return err(
                    field,
                    format!(
                        "the pulse starts at {} s, when the run of {} s has ended",
                        num(start),
                        num(scene.duration)
                    ),
                );
            }
        }
        // A pulse's amplitude or a scaled record's peak beyond MAX_PEAK_G is a slip (a unit, an
        // exponent): engines would clamp or overflow it.
        let limit = MAX_PEAK_G * crate::excitation::records::STANDARD_GRAVITY;
        for (comp, m) in [("horizontal", &exc.horizontal), ("vertical", &exc.vertical)] {
            let Some((amplitude, _)) = m.as_ref().and_then(pulse_amplitude_and_start) else {
                continue;
            };
            if amplitude.abs() > limit {
                return err(
                    format!("excitation.{comp}.amplitude"),
                    format!(
                        "{} m/s^2 is above {MAX_PEAK_G} g ({} m/s^2): the strongest recorded ground motions are a few g",
                        num(amplitude),
                        num(limit)
                    ),
                );
            }
        }
        // Loading checks the record files themselves; a record that starts after the run
        // would never act, as such a pulse.
        let motion = crate::excitation::GroundMotion::from_scene(scene)?;
        for (comp, c) in [
            ("horizontal", &motion.horizontal),
            ("vertical", &motion.vertical),
        ] {
            // A displacement record's acceleration is impulses at its samples: its velocity
            // steps are what it imposes (1e8 m/s made a solver fail, not a field named).
            if let Some(crate::excitation::Component::DisplacementRecord { t, d }) = c {
                let peak = t
                    .windows(2)
                    .zip(d.windows(2))
                    .map(|(t, d)| ((d[1] - d[0]) / (t[1] - t[0])).abs())
                    .fold(0.0_f64, f64::max);
                if peak.is_nan() || peak > MAX_GROUND_VELOCITY {
                    return err(
                        format!("excitation.{comp}.scale"),
                        format!(
                            "the scaled displacement record moves the ground at up to {} m/s, above {MAX_GROUND_VELOCITY} m/s: the strongest recorded ground velocities are a few m/s",
                            num(peak)
                        ),
                    );
                }
            }
            if let Some(crate::excitation::Component::AccelerationRecord { a, .. }) = c {
                let peak = a.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
                if peak.is_nan() || peak > limit {
                    return err(
                        format!("excitation.{comp}.scale"),
                        format!(
                            "the scaled record peaks at {} m/s^2, above {MAX_PEAK_G} g ({} m/s^2): the strongest recorded ground motions are a few g",
                            num(peak),
                            num(limit)
                        ),
                    );
                }
            }
        }
        for (comp, c) in [
            ("horizontal", &motion.horizontal),
            ("vertical", &motion.vertical),
        ] {
            use crate::excitation::Component::{AccelerationRecord, DisplacementRecord};
            if let Some(AccelerationRecord { t, .. } | DisplacementRecord { t, .. }) = c
                && t[0] >= scene.duration
            {
                return err(
                    format!("excitation.{comp}"),
                    format!(
                        "the record starts at {} s, when the run of {} s has ended",
                        num(t[0]),
                        num(scene.duration)
                    ),
                );
            }
        }
    }

    match tables {
        Some(t) => t(scene)?,
        None => check_samples(scene)?,
    }
    Ok(())
}

/// A pulse's amplitude (m/s^2) and start (s); `None` for a record.
fn pulse_amplitude_and_start(m: &MotionSpec) -> Option<(f64, f64)> {
    match m {
        MotionSpec::HalfSine {
            amplitude, start, ..
        }
        | MotionSpec::OneSine {
            amplitude, start, ..
        }
        | MotionSpec::OneCosine {
            amplitude, start, ..
        }
        | MotionSpec::Ricker {
            amplitude, start, ..
        }
        | MotionSpec::Rectangular {
            amplitude, start, ..
        } => Some((*amplitude, *start)),
        MotionSpec::Record { .. } | MotionSpec::Displacement { .. } => None,
    }
}

/// A number as written in messages: plain when short, otherwise in scientific notation
/// (`1e300`, not three hundred digits).
pub(crate) fn num(v: f64) -> String {
    let plain = format!("{v}");
    if plain.len() <= 12 {
        plain
    } else {
        format!("{v:e}")
    }
}

/// The largest friction coefficient a scene may give. The native engine's cone rows
/// `n +- mu t` lose their scale above it (the solver fails on a block's first step from 1e5 on;
/// a rocking block's history is the same within 7e-8 m from 0.7 to 3e4).
pub const MAX_FRICTION: f64 = 1e4;

/// The strongest ground acceleration a scene may give, in g: a pulse's amplitude or a scaled
/// record's peak beyond it is taken for a slip, as a unit or an exponent.
pub const MAX_PEAK_G: f64 = 1000.0;

/// The fastest initial motion a block may be given, m/s: a sliding speed, or a rotation rate
/// times the block's diagonal (its rim speed about its pivot).
pub const MAX_INITIAL_SPEED: f64 = 100.0;

/// The lightest and heaviest block material a scene may give, kg/m^3 (the stress map's stacks
/// reach 2.5e6).
pub const MIN_DENSITY: f64 = 1e-3;
/// See [`MIN_DENSITY`].
pub const MAX_DENSITY: f64 = 1e7;
/// The farthest from the origin a block may be placed, m.
pub const MAX_POSITION: f64 = 1e4;

/// The fastest ground a displacement record may move, m/s.
pub const MAX_GROUND_VELOCITY: f64 = 10.0;

/// Most time steps a run may take (duration / dt): beyond this a scene is almost surely a
/// unit slip (ms for s) and would run for days.
pub const MAX_STEPS: f64 = 1e9;
/// Most trajectory samples a run may write (duration / output_interval): 1e7 samples are
/// about 0.5 GB per block in memory.
pub const MAX_SAMPLES: f64 = 1e7;
/// Smallest Housner event tolerance relative to max(duration, 1 s).
pub const MIN_EVENT_TOLERANCE_REL: f64 = 1e-13;

/// A time step (the setting `field`, e.g. `native.dt`) against the duration, the number of
/// steps and the fastest block's time scale `1/p` (Housner's `p = sqrt(3 g / (4 R))`): a step
/// longer than that steps over the block's motion (a 4 s rocking run at `dt = 1` took 4 steps
/// and put the first impact at 0.76 s where it is at 0.47 s), most likely ms given for s. For
/// the engines' checks of their own tables (`bench --dt` checks [`steps_over_motion`]).
pub fn check_step(scene: &Scene, field: &str, dt: f64) -> Result<(), SceneError> {
    let file = scene.source.as_str();
    if dt > scene.duration {
        return Err(SceneError::new(
            file,
            field,
            format!(
                "{} s is larger than the duration ({} s): not a single step fits",
                num(dt),
                num(scene.duration)
            ),
        ));
    }
    let steps = scene.duration / dt;
    if steps > MAX_STEPS {
        return Err(SceneError::new(
            file,
            field,
            format!(
                "duration / dt = {steps:e} steps; at most {MAX_STEPS:e} are allowed (a unit slip?)"
            ),
        ));
    }
    if let Some(problem) = steps_over_motion(scene, dt) {
        return Err(SceneError::new(file, field, problem));
    }
    Ok(())
}

/// Whether a step of `dt` is longer than the time scale `1/p` of the scene's fastest block (see
/// [`check_step`]), and then the problem as one line.
pub fn steps_over_motion(scene: &Scene, dt: f64) -> Option<String> {
    let (name, p) = fastest_block(scene)?;
    (p * dt > 1.0).then(|| {
        format!(
            "{} s is longer than the time scale 1/p = {} s of block `{name}` (p = sqrt(3 g / 4R)): a step would step over its motion (ms given for s?)",
            num(dt),
            four_digits(1.0 / p)
        )
    })
}

/// A positive number to four significant digits (`0.4278`).
fn four_digits(v: f64) -> String {
    let decimals = (3 - v.log10().floor() as i32).clamp(0, 12) as usize;
    format!("{v:.decimals$}")
}

/// The block with the largest frequency parameter `p` (the smallest), and its `p`.
pub fn fastest_block(scene: &Scene) -> Option<(&str, f64)> {
    scene
        .blocks
        .iter()
        .map(|b| (b.name.as_str(), b.frequency_parameter(scene.gravity)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

/// The number of samples (`duration / output_interval`).
pub fn check_samples(scene: &Scene) -> Result<(), SceneError> {
    let samples = scene.duration / scene.output_interval;
    if samples > MAX_SAMPLES {
        return Err(SceneError::new(
            &scene.source,
            "output.interval",
            format!(
                "duration / output.interval = {samples:e} samples; at most {MAX_SAMPLES:e} are allowed"
            ),
        ));
    }
    Ok(())
}

/// The scene field that rotates block `i` initially: the nearest block down its support
/// chain with a relative rotation, else the tilt.
fn rotation_field(scene: &Scene, layout: &Layout, i: usize) -> String {
    let mut k = Some(i);
    while let Some(j) = k {
        let name = &scene.blocks[j].name;
        if scene
            .initial
            .blocks
            .get(name)
            .is_some_and(|s| s.rotation != 0.0)
        {
            return format!("initial.blocks.{name}.rotation");
        }
        k = layout.supports[j];
    }
    "initial.tilt".to_string()
}

/// In the initial (rotated) position no block may reach into the ground or another block.
fn check_initial_overlaps(scene: &Scene, layout: &Layout) -> Result<(), SceneError> {
    let n = scene.blocks.len();
    let verts: Vec<[(f64, f64); 4]> = (0..n)
        .map(|i| {
            let b = &scene.blocks[i];
            let st = &layout.blocks[i];
            let (sn, cs) = st.phi.sin_cos();
            let (hb, hh) = (b.width / 2.0, b.height / 2.0);
            [(-hb, -hh), (hb, -hh), (hb, hh), (-hb, hh)]
                .map(|(lx, lz)| (st.x + cs * lx - sn * lz, st.z + sn * lx + cs * lz))
        })
        .collect();
    let size = |i: usize| scene.blocks[i].width + scene.blocks[i].height;
    for (i, v) in verts.iter().enumerate() {
        let low = v.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
        if -low > 1e-9 * size(i) {
            return Err(SceneError::new(
                &scene.source,
                rotation_field(scene, layout, i),
                format!(
                    "the initial rotation puts a corner of `{}` {:.3e} m into the ground",
                    scene.blocks[i].name, -low
                ),
            ));
        }
    }
    for i in 0..n {
        for j in 0..i {
            let d = crate::invariants::overlap_depth(&verts[i], &verts[j]);
            if d > 1e-9 * (size(i) + size(j)) {
                let mut field = rotation_field(scene, layout, i);
                if field == "initial.tilt" {
                    field = rotation_field(scene, layout, j);
                }
                return Err(SceneError::new(
                    &scene.source,
                    field,
                    format!(
                        "in its initial position `{}` overlaps `{}` by {d:.3e} m",
                        scene.blocks[i].name, scene.blocks[j].name,
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// A block (with everything it carries) whose centre of mass lies beyond its pivot corner
/// would overturn at once: refuse the initial rotation that puts it there.
fn check_overturning(scene: &Scene, layout: &Layout) -> Result<(), SceneError> {
    let n = scene.blocks.len();
    // Blocks carried by block i: i and everything whose support chain reaches i.
    let carried = |i: usize| -> Vec<usize> {
        (0..n)
            .filter(|&j| {
                let mut k = Some(j);
                while let Some(kk) = k {
                    if kk == i {
                        return true;
                    }
                    k = layout.supports[kk];
                }
                false
            })
            .collect()
    };
    for i in 0..n {
        let rel = scene
            .initial
            .blocks
            .get(&scene.blocks[i].name)
            .map(|s| s.rotation)
            .unwrap_or(0.0)
            + if i == 0 { scene.initial.tilt } else { 0.0 };
        if rel == 0.0 {
            continue;
        }
        // In the support's frame the block is rotated by `rel` about its pivot; compare the
        // carried centre of mass with the pivot, both in final coordinates rotated back by the
        // support's angle.
        let support_angle = layout.supports[i]
            .map(|s| layout.blocks[s].phi)
            .unwrap_or(0.0);
        let group = carried(i);
        let mass: f64 = group.iter().map(|&j| scene.blocks[j].mass()).sum();
        let com_x: f64 = group
            .iter()
            .map(|&j| scene.blocks[j].mass() * layout.blocks[j].x)
            .sum::<f64>()
            / mass;
        let com_z: f64 = group
            .iter()
            .map(|&j| scene.blocks[j].mass() * layout.blocks[j].z)
            .sum::<f64>()
            / mass;
        // Pivot in final coordinates: the block's pivot corner moved with the block.
        let b = &scene.blocks[i];
        let (ux, uz) = layout.upright[i];
        let (px, pz) = layout.pivots[i];
        let (s, c) = layout.blocks[i].phi.sin_cos();
        let (dx, dz) = (px - ux, pz - uz);
        let pivot = (
            layout.blocks[i].x + c * dx - s * dz,
            layout.blocks[i].z + s * dx + c * dz,
        );
        let (ss, cs) = support_angle.sin_cos();
        let arm = cs * (com_x - pivot.0) + ss * (com_z - pivot.1);
        if arm * rel.signum() <= 0.0 {
            let field = if i == 0 && scene.initial.tilt != 0.0 {
                "initial.tilt".to_string()
            } else {
                format!("initial.blocks.{}.rotation", b.name)
            };
            return Err(SceneError::new(
                &scene.source,
                field,
                format!(
                    "rotation {} rad puts the centre of mass of `{}` and what it carries past its pivot corner: the stack would start overturning",
                    num(rel),
                    b.name
                ),
            ));
        }
    }
    Ok(())
}
