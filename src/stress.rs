//! The stability map (`rockbench stress`): runs every engine over a grid of scenes and
//! records, per cell, whether the run finished (or failed, and why), its wall time and the
//! [`invariants`](crate::invariants).
//!
//! The grid is one-factor-at-a-time around a base case: each factor is varied over its range
//! with every other setting at the base value. The base case is a single block B = 1 m,
//! H = 2.5 m, density 2500 kg/m^3, released from a tilt of 0.15 rad, friction 0.7, theta 0.7,
//! dt 1e-3 s, 4 s (1 s in the quick grid), no excitation. Factors:
//!
//! | factor | varied | around |
//! |---|---|---|
//! | `dt` | time step 1e-5 .. 5e-3 s | base block, 1 s (quick: 0.5 s): 1e5 steps at 1e-5 |
//! | `theta` | 0.5 .. 1 | base block |
//! | `slenderness` | H/B 1 .. 20 (B = 1 m, tilt 0.4 atan(B/H)) | base block |
//! | `size` | H 0.05 .. 20 m (H/B = 2.5) | base block |
//! | `mass_ratio` | upper/lower density 1e-3 .. 1e3 | the paper's two-block stack |
//! | `friction` | 0.05 .. 2 | base block |
//! | `blocks` | a standing column of 1 .. 100 bricks 1.0 x 0.5 m | 2 s at rest |
//! | `wall_courses` | a standing running-bond wall of 2 .. 10 courses | 2 s at rest |
//! | `duration` | 1 .. 60 s | base block |
//! | `standing_time` | 1 .. 60 s | a standing column of 10 bricks (full map only) |
//! | `excitation` | half-sine pulse (period 0.5 s), amplitude k g tan(alpha), k 0.5 .. 20 | the base block upright |
//! | `eccentricity` | centre of a 1.53 x 4.9 m block offset by e = 0 .. 0.8 of a 0.105 m post's half-width | standing, 2 s (full map only) |
//!
//! Every third cell of the grid (in the order above) runs the native engine with
//! non-associative Coulomb friction (`native.friction_law = "coulomb"`); other engines ignore it.
//!
//! A cell's status: `finished`, `failed` (engine error, panic or timeout, with the reason),
//! `unsupported` (the engine refuses the scene by design, e.g. Housner on a stack) or
//! `skipped` (the engine is not built into this binary). Every finished cell's invariants are
//! measured against the strict (round-off) tolerances and judged against the engine's own
//! [contract](crate::contract); broken promises and failed runs are matched against a list of
//! known, explained cases (`validation/stress-known.toml`), and the command fails when any is
//! unexplained. Invariants beyond round-off but within the contract are reported, not failed.

use crate::contract::Contract;
use crate::engines::registry::{self, check_scene_str};
use crate::engines::{Engine, EngineError, Progress, RunOutput, engine_by_name};
use crate::invariants::{CHECK_NAMES, InvariantReport, Tolerances};
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;
use std::sync::Arc;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The factors of the grid and what each varies (the base case is in the module docs).
pub const FACTORS: [(&str, &str); 12] = [
    (
        "dt",
        "time step 1e-5 .. 5e-3 s, every engine's (`native.dt`, `rapier.dt`, ...); base block, 1 s (quick: 0.5 s)",
    ),
    ("theta", "theta 0.5 .. 1; base block"),
    (
        "slenderness",
        "H/B 1 .. 20 with B = 1 m, tilt 0.4 atan(B/H)",
    ),
    ("size", "H 0.05 .. 20 m with H/B = 2.5"),
    (
        "mass_ratio",
        "upper/lower density 1e-3 .. 1e3; the paper's two-block stack tilted 0.15 rad",
    ),
    ("friction", "friction coefficient 0.05 .. 2; base block"),
    (
        "blocks",
        "standing column of 1 .. 100 bricks 1.0 x 0.5 m, 2 s (quick: 0.2 s)",
    ),
    (
        "wall_courses",
        "standing running-bond wall of 2 .. 10 courses, 2 s (quick: 0.2 s)",
    ),
    ("duration", "1 .. 60 s; base block"),
    (
        "standing_time",
        "standing column of 10 bricks for 1 .. 60 s (full map only)",
    ),
    (
        "excitation",
        "base block upright under a half-sine pulse (period 0.5 s) of k g tan(alpha), k 0.5 .. 20",
    ),
    (
        "eccentricity",
        "standing 1.53 x 4.9 m block on a 0.105 x 0.34 m post, its centre offset by e times the post's half-width, e 0 .. 0.8, 2 s (full map only)",
    ),
];

/// The base case every factor varies around.
pub const BASE_CASE: &str = "one block B = 1 m, H = 2.5 m, density 2500 kg/m^3, tilt 0.15 rad, friction 0.7, theta 0.7, dt 1e-3 s, 4 s (quick: 1 s), no excitation";

/// One cell of the grid: a factor, its value and the scene that varies it.
#[derive(Debug, Clone)]
pub struct Cell {
    pub factor: &'static str,
    pub value: f64,
    pub label: String,
    pub scene: Result<Scene, String>,
}

/// A block of a generated scene.
#[derive(Debug, Clone)]
struct B {
    name: String,
    w: f64,
    h: f64,
    density: f64,
    place: Place,
}

#[derive(Debug, Clone, Copy)]
enum Place {
    Offset(f64),
    X(f64),
}

/// A generated scene, written as TOML and read through the ordinary checks.
#[derive(Debug, Clone)]
struct Spec {
    duration: f64,
    blocks: Vec<B>,
    tilt: f64,
    friction: f64,
    theta: f64,
    dt: f64,
    pulse: Option<f64>,
    /// The native engine with non-associative Coulomb friction (every third cell).
    coulomb: bool,
    /// `dt` is every engine's step (each one's step setting), not only the native engine's.
    every_step: bool,
}

impl Spec {
    fn base(quick: bool) -> Spec {
        Spec {
            duration: if quick { 1.0 } else { 4.0 },
            blocks: vec![B {
                name: "block".into(),
                w: 1.0,
                h: 2.5,
                density: 2500.0,
                place: Place::Offset(0.0),
            }],
            tilt: 0.15,
            friction: 0.7,
            theta: 0.7,
            dt: 1e-3,
            pulse: None,
            coulomb: false,
            every_step: false,
        }
    }

    fn toml(&self, name: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "name = {name:?}\nduration = {:e}\noutput_interval = {:e}",
            self.duration,
            1e-3f64.max(self.dt)
        );
        for b in &self.blocks {
            let _ = writeln!(
                s,
                "\n[[blocks]]\nname = {:?}\nwidth = {:e}\nheight = {:e}\ndensity = {:e}",
                b.name, b.w, b.h, b.density
            );
            match b.place {
                Place::Offset(o) => {
                    let _ = writeln!(s, "offset = {o:e}");
                }
                Place::X(x) => {
                    let _ = writeln!(s, "x = {x:e}");
                }
            }
        }
        let _ = writeln!(s, "\n[initial]\ntilt = {:e}", self.tilt);
        let _ = writeln!(s, "\n[contact]\nfriction = {:e}", self.friction);
        let _ = writeln!(
            s,
            "\n[native]\ntheta = {:e}\ndt = {:e}",
            self.theta, self.dt
        );
        if self.coulomb {
            let _ = writeln!(s, "friction_law = \"coulomb\"");
        }
        if self.every_step {
            let steps = registry::ENGINES
                .iter()
                .filter_map(|e| e.settings.as_ref()?.step)
                .filter_map(|k| k.split_once('.'))
                .filter(|(table, _)| *table != "native");
            for (table, key) in steps {
                let _ = writeln!(s, "\n[{table}]\n{key} = {:e}", self.dt);
            }
        }
        if let Some(a) = self.pulse {
            let _ = writeln!(
                s,
                "\n[excitation.horizontal]\nkind = \"half-sine\"\namplitude = {a:e}\nperiod = 0.5"
            );
        }
        s
    }

    fn scene(&self, name: &str) -> Result<Scene, String> {
        check_scene_str(&self.toml(name), false, name, &[], Path::new("."))
            .map_err(|e| e.to_string())
    }
}

fn column(n: usize, duration: f64) -> Spec {
    Spec {
        duration,
        blocks: (0..n)
            .map(|i| B {
                name: format!("b{i}"),
                w: 1.0,
                h: 0.5,
                density: 2500.0,
                place: Place::Offset(0.0),
            })
            .collect(),
        tilt: 0.0,
        ..Spec::base(false)
    }
}

/// A running-bond wall: even courses of 4 bricks 1.0 x 0.5 m, odd courses of 3 bricks
/// shifted by half a brick with a half brick at each end.
fn wall(courses: usize, duration: f64) -> Spec {
    let mut blocks = Vec::new();
    for c in 0..courses {
        // (centre, width): odd courses end in half bricks, so every brick rests on two.
        let bricks: &[(f64, f64)] = if c % 2 == 0 {
            &[(-1.5, 1.0), (-0.5, 1.0), (0.5, 1.0), (1.5, 1.0)]
        } else {
            &[
                (-1.75, 0.5),
                (-1.0, 1.0),
                (0.0, 1.0),
                (1.0, 1.0),
                (1.75, 0.5),
            ]
        };
        for (k, &(x, w)) in bricks.iter().enumerate() {
            blocks.push(B {
                name: format!("c{c}b{k}"),
                w,
                h: 0.5,
                density: 2500.0,
                place: Place::X(x),
            });
        }
    }
    Spec {
        duration,
        blocks,
        tilt: 0.0,
        ..Spec::base(false)
    }
}

fn label(v: f64) -> String {
    let s = format!("{v}");
    if s.len() <= 6 { s } else { format!("{v:e}") }
}

/// The grid: the full map, or the small `--quick` one for CI.
pub fn grid(quick: bool) -> Vec<Cell> {
    let base = Spec::base(quick);
    let pick =
        |full: &[f64], q: &[f64]| -> Vec<f64> { if quick { q.to_vec() } else { full.to_vec() } };
    let mut cells = Vec::new();
    let mut add = |factor: &'static str, value: f64, mut spec: Spec| {
        // Every third cell runs the native engine with Coulomb friction.
        spec.coulomb = cells.len() % 3 == 2;
        let label = label(value);
        let scene = spec.scene(&format!("stress {factor}={label}"));
        cells.push(Cell {
            factor,
            value,
            label,
            scene,
        });
    };
    for dt in pick(
        &[1e-5, 3e-5, 1e-4, 3e-4, 1e-3, 2e-3, 5e-3],
        &[1e-4, 1e-3, 5e-3],
    ) {
        let duration = if quick { 0.5 } else { 1.0 };
        add(
            "dt",
            dt,
            Spec {
                dt,
                duration,
                every_step: true,
                ..base.clone()
            },
        );
    }
    for theta in pick(&[0.5, 0.55, 0.6, 0.7, 0.8, 0.9, 1.0], &[0.5, 0.7, 1.0]) {
        add(
            "theta",
            theta,
            Spec {
                theta,
                ..base.clone()
            },
        );
    }
    for r in pick(&[1.0, 1.5, 2.5, 5.0, 10.0, 20.0], &[1.0, 20.0]) {
        let mut s = base.clone();
        s.blocks[0].h = r;
        s.tilt = 0.4 * (1.0 / r).atan();
        add("slenderness", r, s);
    }
    for h in pick(&[0.05, 0.2, 1.0, 2.5, 5.0, 20.0], &[0.05, 20.0]) {
        let mut s = base.clone();
        s.blocks[0].h = h;
        s.blocks[0].w = h / 2.5;
        add("size", h, s);
    }
    for ratio in pick(&[1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3], &[1e-3, 1e3]) {
        let mut s = base.clone();
        s.blocks = vec![
            B {
                name: "pedestal".into(),
                w: 1.25,
                h: 1.25,
                density: 2500.0,
                place: Place::Offset(0.0),
            },
            B {
                name: "statue".into(),
                w: 1.0,
                h: 2.5,
                density: 2500.0 * ratio,
                place: Place::Offset(0.0),
            },
        ];
        add("mass_ratio", ratio, s);
    }
    for mu in pick(&[0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 2.0], &[0.05, 2.0]) {
        add(
            "friction",
            mu,
            Spec {
                friction: mu,
                ..base.clone()
            },
        );
    }
    let stand = if quick { 0.2 } else { 2.0 };
    for n in pick(&[1.0, 2.0, 5.0, 10.0, 20.0, 50.0, 100.0], &[1.0, 5.0, 20.0]) {
        add("blocks", n, column(n as usize, stand));
    }
    for c in pick(&[2.0, 5.0, 10.0], &[3.0]) {
        add("wall_courses", c, wall(c as usize, stand));
    }
    for d in pick(&[1.0, 10.0, 60.0], &[2.0]) {
        add(
            "duration",
            d,
            Spec {
                duration: d,
                ..base.clone()
            },
        );
    }
    for d in pick(&[1.0, 10.0, 60.0], &[]) {
        add("standing_time", d, column(10, d));
    }
    let alpha = (1.0f64 / 2.5).atan();
    for k in pick(&[0.5, 1.5, 2.0, 3.0, 5.0, 10.0, 20.0], &[0.5, 3.0, 20.0]) {
        let mut s = base.clone();
        s.tilt = 0.0;
        s.pulse = Some(k * 9.81 * alpha.tan());
        if quick {
            s.duration = 2.0;
        }
        add("excitation", k, s);
    }
    for e in pick(&[0.0, 0.5, 0.8], &[]) {
        let post_b = 0.105;
        let mut s = base.clone();
        s.duration = 2.0;
        s.tilt = 0.0;
        s.blocks = vec![
            B {
                name: "post".into(),
                w: post_b,
                h: 0.34,
                density: 736.0,
                place: Place::Offset(0.0),
            },
            B {
                name: "block".into(),
                w: 1.53,
                h: 4.9,
                density: 2065.0,
                place: Place::Offset(e * post_b / 2.0),
            },
        ];
        add("eccentricity", e, s);
    }
    cells
}

/// Outcome of one cell for one engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    Finished,
    Failed,
    Unsupported,
    Skipped,
}

impl Status {
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Finished => "finished",
            Status::Failed => "failed",
            Status::Unsupported => "unsupported",
            Status::Skipped => "skipped",
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct CellResult {
    pub engine: String,
    pub factor: String,
    pub value: f64,
    pub label: String,
    pub status: Status,
    pub reason: String,
    pub wall_s: f64,
    pub steps: u64,
    /// The invariants measured against the strict (round-off) tolerances.
    pub invariants: InvariantReport,
    /// Each measured invariant judged against the engine's own contract.
    pub judged: Vec<Judged>,
    /// Broken promises of the engine's contract (and `run` for a failed run) with the known
    /// explanation, if any.
    pub issues: Vec<Issue>,
}

/// One invariant of one cell, judged against the engine's contract.
#[derive(Debug, Clone, Serialize)]
pub struct Judged {
    pub check: String,
    pub value: f64,
    /// The contract's limit for this scene, in the check's unit.
    pub limit: f64,
    pub holds: bool,
    /// The strict (round-off) limit and whether the value is within it.
    pub strict_limit: f64,
    pub within_strict: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct Issue {
    pub check: String,
    pub detail: String,
    pub explanation: Option<String>,
}

impl CellResult {
    /// A cell's result before its run: finished, nothing measured.
    fn blank(engine: &str, cell: &Cell) -> Self {
        CellResult {
            engine: engine.to_string(),
            factor: cell.factor.to_string(),
            value: cell.value,
            label: cell.label.clone(),
            status: Status::Finished,
            reason: String::new(),
            wall_s: 0.0,
            steps: 0,
            invariants: InvariantReport::default(),
            judged: Vec::new(),
            issues: Vec::new(),
        }
    }
    /// Checks beyond the strict tolerance but within the engine's contract.
    pub fn beyond_strict(&self) -> Vec<&Judged> {
        self.judged
            .iter()
            .filter(|j| j.holds && !j.within_strict)
            .collect()
    }

    pub fn unexplained(&self) -> usize {
        self.issues
            .iter()
            .filter(|i| i.explanation.is_none())
            .count()
    }
}

/// A known, explained violation or failure (`validation/stress-known.toml`).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Known {
    pub engine: String,
    pub factor: String,
    /// The cell's value label as printed in the map, or `*` for every value.
    pub value: String,
    /// An invariant name, or `run` for a failed run.
    pub check: String,
    pub reason: String,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnownList {
    #[serde(default)]
    pub known: Vec<Known>,
}

impl KnownList {
    /// Read a known list and check every entry: an entry that can match no cell (an engine,
    /// factor, value or check the map does not have) or explains nothing (an empty reason)
    /// is an error naming it, as is an entry given twice.
    pub fn load(path: &Path) -> Result<KnownList, String> {
        let at = |field: &str, m: String| format!("{}: {field}: {m}", path.display());
        let text = crate::input_file::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let table: toml::Table = toml::from_str(&text).map_err(|e| {
            let (line, message) = crate::scene::toml_error_at(&text, &e, "(file)");
            format!("{}: {line}: {message}", path.display())
        })?;
        let list: KnownList =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
                let p = e.path().to_string();
                let field = if p == "." { "(top level)".into() } else { p };
                at(
                    &field,
                    e.inner().message().lines().next().unwrap_or("").into(),
                )
            })?;
        let grid = grid(false);
        for (i, k) in list.known.iter().enumerate() {
            let field = |f: &str| format!("known[{i}].{f}");
            if registry::find(&k.engine).is_none() {
                return Err(at(
                    &field("engine"),
                    crate::engines::EngineError::Unknown(k.engine.clone()).to_string(),
                ));
            }
            if !FACTORS.iter().any(|(f, _)| *f == k.factor) {
                let names: Vec<&str> = FACTORS.iter().map(|(f, _)| *f).collect();
                return Err(at(
                    &field("factor"),
                    format!("no factor `{}` (factors: {})", k.factor, names.join(", ")),
                ));
            }
            let labels: Vec<&str> = grid
                .iter()
                .filter(|c| c.factor == k.factor)
                .map(|c| c.label.as_str())
                .collect();
            if k.value != "*" && !labels.contains(&k.value.as_str()) {
                return Err(at(
                    &field("value"),
                    format!(
                        "`{}` is no value of factor `{}` (`*`, or one of: {})",
                        k.value,
                        k.factor,
                        labels.join(", ")
                    ),
                ));
            }
            if k.check != "run" && !CHECK_NAMES.contains(&k.check.as_str()) {
                return Err(at(
                    &field("check"),
                    format!(
                        "no check `{}` (`run`, or one of: {})",
                        k.check,
                        CHECK_NAMES.join(", ")
                    ),
                ));
            }
            if k.reason.trim().is_empty() {
                return Err(at(&field("reason"), "must say why (not empty)".into()));
            }
            if list.known[..i].iter().any(|o| {
                (&o.engine, &o.factor, &o.value, &o.check)
                    == (&k.engine, &k.factor, &k.value, &k.check)
            }) {
                return Err(at(&field("check"), "this entry is given twice".into()));
            }
        }
        Ok(list)
    }
    fn explain(&self, engine: &str, factor: &str, label: &str, check: &str) -> Option<String> {
        self.known
            .iter()
            .find(|k| {
                k.engine == engine
                    && k.factor == factor
                    && (k.value == "*" || k.value == label)
                    && k.check == check
            })
            .map(|k| k.reason.clone())
    }
}

/// Every engine's contract ([`registry::contract`]), with command-line changes.
#[derive(Debug, Clone, Default)]
pub struct Contracts {
    changed: Vec<Contract>,
}

impl Contracts {
    /// Apply `ENGINE.CHECK=VALUE` assignments.
    pub fn with_changes(changes: &[String]) -> Result<Contracts, String> {
        let mut c = Contracts::default();
        for a in changes {
            let err = |m: String| format!("--contract {a}: {m}");
            let (key, value) = a
                .split_once('=')
                .ok_or_else(|| err("expected ENGINE.CHECK=VALUE".into()))?;
            let (engine, check) = key
                .split_once('.')
                .ok_or_else(|| err("expected ENGINE.CHECK=VALUE".into()))?;
            let v: f64 = value
                .trim()
                .parse()
                .map_err(|_| err(format!("`{value}` is not a number")))?;
            if registry::find(engine).is_none() {
                return Err(err(
                    crate::engines::EngineError::Unknown(engine.into()).to_string()
                ));
            }
            let k = match c.changed.iter().position(|x| x.engine == engine) {
                Some(k) => k,
                None => {
                    c.changed.push(registry::contract(engine));
                    c.changed.len() - 1
                }
            };
            c.changed[k].set(check.trim(), v).map_err(err)?;
        }
        Ok(c)
    }

    pub fn of(&self, engine: &str) -> Contract {
        self.changed
            .iter()
            .find(|c| c.engine == engine)
            .cloned()
            .unwrap_or_else(|| registry::contract(engine))
    }
}

/// How cells are judged: each engine's contract, and the known, explained exceptions.
#[derive(Debug, Clone, Default)]
pub struct Judge {
    pub contracts: Contracts,
    pub known: KnownList,
}

/// Run one engine on one cell, in a worker thread: a panic is a failed run with its message,
/// and a run that exceeds `timeout` is abandoned as failed.
pub fn run_cell(
    engine: &str,
    cell: &Cell,
    tol: &Tolerances,
    timeout: Duration,
    judge: &Judge,
) -> CellResult {
    run_cell_with(engine, Arc::new(engine_by_name), cell, tol, timeout, judge)
}

/// Makes the engine of a cell (in the worker thread).
pub type EngineFactory = Arc<dyn Fn(&str) -> Result<Box<dyn Engine>, EngineError> + Send + Sync>;

/// [`run_cell`] with the engine made by `make` (tests use it to inject faulty engines).
pub fn run_cell_with(
    engine: &str,
    make: EngineFactory,
    cell: &Cell,
    tol: &Tolerances,
    timeout: Duration,
    judge: &Judge,
) -> CellResult {
    let (r, _) = measure(engine, make, cell, tol, timeout);
    finish(r, judge, cell.scene.as_ref().ok())
}

/// One engine's run of one cell, not yet judged, and whether it is the run's own answer, to be
/// kept in a run store: a finished run, one the engine refused or one that failed with an
/// engine's error. A timeout, a panic or a thread that did not start depend on the machine.
fn measure(
    engine: &str,
    make: EngineFactory,
    cell: &Cell,
    tol: &Tolerances,
    timeout: Duration,
) -> (CellResult, bool) {
    let mut r = CellResult::blank(engine, cell);
    let scene = match &cell.scene {
        Ok(s) => s.clone(),
        Err(e) => {
            r.status = Status::Failed;
            r.reason = format!("the generated scene is invalid: {e}");
            return (r, false);
        }
    };
    if let Err(e) = make(engine) {
        r.status = Status::Skipped;
        r.reason = e.to_string();
        return (r, false);
    }
    let (tx, rx) = mpsc::channel::<CellMessage>();
    let name = engine.to_string();
    let tol = *tol;
    let start = Instant::now();
    let spawned = std::thread::Builder::new()
        .name(format!("stress {engine} {}={}", cell.factor, cell.label))
        .spawn(move || {
            let res = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                let e: Box<dyn Engine> = Box::new(Announced {
                    inner: make(&name)?,
                    starts: tx.clone(),
                });
                let t0 = Instant::now();
                let main = e.run_reporting(&scene, &crate::interrupt::go_on_unless_interrupted);
                let wall = t0.elapsed().as_secs_f64();
                let out = main?;
                // The invariant runs (mirror, rerun) are timed apart from the main run.
                let report = crate::invariants::check_single(&scene, &out.trajectory, &tol);
                let (_, extra) = run_checked_extra(e.as_ref(), &scene, &out, &tol)?;
                let mut report = report;
                report.checks.extend(extra.checks);
                Ok::<_, EngineError>((out.steps, wall, report))
            }));
            let _ = tx.send(CellMessage::Done(res.map_err(|p| {
                p.downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| p.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "unknown panic".into())
            })));
        });
    if let Err(e) = spawned {
        r.status = Status::Failed;
        r.reason = format!("cannot start a worker thread: {e}");
        return (r, false);
    }
    // Each of the cell's runs (the main run, the mirrored run, the rerun, the mirror's probes)
    // has `timeout` to itself: the wait starts again as each starts.
    let answer = loop {
        match rx.recv_timeout(timeout) {
            Ok(CellMessage::RunStarts) => continue,
            Ok(CellMessage::Done(answer)) => break Ok(answer),
            Err(e) => break Err(e),
        }
    };
    let keep = match answer {
        Ok(Ok(Ok((steps, wall, report)))) => {
            r.steps = steps;
            r.wall_s = wall;
            r.invariants = report;
            true
        }
        Ok(Ok(Err(e))) => {
            r.wall_s = start.elapsed().as_secs_f64();
            match e {
                EngineError::Unsupported { reason, .. } => {
                    r.status = Status::Unsupported;
                    r.reason = reason;
                }
                other => {
                    r.status = Status::Failed;
                    r.reason = other.to_string();
                }
            }
            true
        }
        Ok(Err(panic)) => {
            r.wall_s = start.elapsed().as_secs_f64();
            r.status = Status::Failed;
            r.reason = format!("panic: {panic}");
            false
        }
        Err(_) => {
            r.wall_s = start.elapsed().as_secs_f64();
            r.status = Status::Failed;
            r.reason = format!(
                "timed out after {} s (run abandoned)",
                timeout.as_secs_f64()
            );
            false
        }
    };
    (r, keep)
}

/// What a cell's thread tells the thread waiting for it: a run starts, or the cell's answer
/// (its main run's steps and wall time and the invariants' report, an engine's error, or a
/// panic's message).
enum CellMessage {
    RunStarts,
    Done(Result<Result<(u64, f64, InvariantReport), EngineError>, String>),
}

/// A cell's engine, each of whose runs is announced to the thread waiting for the cell.
struct Announced {
    inner: Box<dyn Engine>,
    starts: mpsc::Sender<CellMessage>,
}

impl Engine for Announced {
    fn name(&self) -> &'static str {
        self.inner.name()
    }
    fn run_reporting(&self, scene: &Scene, progress: Progress) -> Result<RunOutput, EngineError> {
        let _ = self.starts.send(CellMessage::RunStarts);
        self.inner.run_reporting(scene, progress)
    }
    fn cannot_model(&self, scene: &Scene) -> Option<String> {
        self.inner.cannot_model(scene)
    }
}

/// Bumped when the meaning of a stored stress run changes.
const STORE_FORMAT: u32 = 1;

/// A cell's run as kept in the run store ([`crate::run_store`]): what was measured, before it
/// is judged (the contracts and the known list are applied to it afresh).
#[derive(Serialize, Deserialize)]
struct StoredCell {
    status: Status,
    reason: String,
    wall_s: f64,
    steps: u64,
    checks: Vec<StoredCheck>,
}

/// An invariant check as stored: [`crate::invariants::Check`] with its name as a string.
#[derive(Serialize, Deserialize)]
struct StoredCheck {
    name: String,
    applies: bool,
    passed: bool,
    value: f64,
    limit: f64,
    detail: String,
}

impl StoredCell {
    fn of(r: &CellResult) -> Self {
        StoredCell {
            status: r.status,
            reason: r.reason.clone(),
            wall_s: r.wall_s,
            steps: r.steps,
            checks: r
                .invariants
                .checks
                .iter()
                .map(|c| StoredCheck {
                    name: c.name.to_string(),
                    applies: c.applies,
                    passed: c.passed,
                    value: c.value,
                    limit: c.limit,
                    detail: c.detail.clone(),
                })
                .collect(),
        }
    }

    /// Put the stored measurements in `r`; `None` if a check's name is not one of
    /// [`CHECK_NAMES`] (an entry of another program).
    fn into_result(self, mut r: CellResult) -> Option<CellResult> {
        let mut checks = Vec::new();
        for c in self.checks {
            let name = CHECK_NAMES.iter().find(|&&n| n == c.name)?;
            checks.push(crate::invariants::Check {
                name,
                applies: c.applies,
                passed: c.passed,
                value: c.value,
                limit: c.limit,
                detail: c.detail,
            });
        }
        r.status = self.status;
        r.reason = self.reason;
        r.wall_s = self.wall_s;
        r.steps = self.steps;
        r.invariants = InvariantReport { checks };
        Some(r)
    }
}

/// [`run_cell`] through the run store `dir`: the cell's run read back when the store has it (and
/// `true`), else made, and kept when it is the run's own answer (a finished run, one the engine
/// refused, or an engine's error; not a timeout, a panic or a run under way when an interrupt
/// came, [`crate::interrupt`]). A run that cannot be kept is an
/// error (a map that cannot resume is not run).
pub fn run_cell_stored(
    engine: &str,
    cell: &Cell,
    tol: &Tolerances,
    timeout: Duration,
    judge: &Judge,
    dir: &Path,
) -> Result<(CellResult, bool), String> {
    let Ok(scene) = &cell.scene else {
        return Ok((run_cell(engine, cell, tol, timeout, judge), false));
    };
    let key = crate::run_store::key(
        engine,
        serde_json::json!({
            "kind": "stress-cell",
            "format": STORE_FORMAT,
            "scene": scene.to_json(),
            "tolerances": tol,
        }),
    );
    if let Some(r) = crate::run_store::load::<StoredCell>(dir, &key)
        .and_then(|stored| stored.into_result(CellResult::blank(engine, cell)))
    {
        return Ok((finish(r, judge, Some(scene)), true));
    }
    let (r, keep) = measure(engine, Arc::new(engine_by_name), cell, tol, timeout);
    // A run stopped by an interrupt is not the cell's answer.
    if keep && !crate::interrupt::requested() {
        crate::run_store::store(dir, &key, &StoredCell::of(&r))
            .map_err(|e| format!("the run store: {e}"))?;
    }
    Ok((finish(r, judge, Some(scene)), false))
}

/// The mirror and rerun checks of an already finished run.
fn run_checked_extra(
    engine: &dyn crate::engines::Engine,
    scene: &Scene,
    out: &crate::engines::RunOutput,
    tol: &Tolerances,
) -> Result<((), InvariantReport), EngineError> {
    let mut report = InvariantReport::default();
    let mirrored = crate::invariants::mirror_scene(scene);
    let go_on = &crate::interrupt::go_on_unless_interrupted;
    report
        .checks
        .push(match engine.run_reporting(&mirrored, go_on) {
            Ok(m) => crate::invariants::mirror_check_run(
                engine,
                scene,
                &out.trajectory,
                &m.trajectory,
                tol,
            ),
            Err(e) => crate::invariants::Check::run_failed("mirror", e),
        });
    report
        .checks
        .push(match engine.run_reporting(scene, go_on) {
            Ok(again) => crate::invariants::check_rerun(&out.trajectory, &again.trajectory),
            Err(e) => crate::invariants::Check::run_failed("rerun", e),
        });
    Ok(((), report))
}

fn finish(mut r: CellResult, judge: &Judge, scene: Option<&Scene>) -> CellResult {
    let explain = |check: &str| judge.known.explain(&r.engine, &r.factor, &r.label, check);
    let contract = judge.contracts.of(&r.engine);
    let mut issues = Vec::new();
    let mut judged = Vec::new();
    if r.status == Status::Failed {
        issues.push(Issue {
            check: "run".into(),
            detail: r.reason.clone(),
            explanation: explain("run"),
        });
    }
    for c in r.invariants.checks.iter().filter(|c| c.applies) {
        let (limit, holds) = match scene {
            Some(s) => contract.judge(s, c),
            None => (c.limit, c.passed),
        };
        if !holds {
            issues.push(Issue {
                check: c.name.to_string(),
                detail: format!(
                    "{} (contract of `{}`: at most {})",
                    c.detail,
                    r.engine,
                    crate::report::num(limit)
                ),
                explanation: explain(c.name),
            });
        }
        judged.push(Judged {
            check: c.name.to_string(),
            value: c.value,
            limit,
            holds,
            strict_limit: c.limit,
            within_strict: c.passed,
        });
    }
    r.issues = issues;
    r.judged = judged;
    r
}

/// Per-engine totals.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Totals {
    pub cells: usize,
    pub finished: usize,
    pub failed: usize,
    pub unsupported: usize,
    pub skipped: usize,
    /// Broken promises of the engine's contract.
    pub violations: usize,
    /// Invariants beyond the strict (round-off) tolerances, within the contract.
    pub beyond_strict: usize,
    pub unexplained: usize,
    pub wall_s: f64,
}

pub fn totals(results: &[CellResult]) -> Totals {
    let mut t = Totals::default();
    for r in results {
        t.cells += 1;
        match r.status {
            Status::Finished => t.finished += 1,
            Status::Failed => t.failed += 1,
            Status::Unsupported => t.unsupported += 1,
            Status::Skipped => t.skipped += 1,
        }
        t.violations += r.issues.iter().filter(|i| i.check != "run").count();
        t.beyond_strict += r.beyond_strict().len();
        t.unexplained += r.unexplained();
        t.wall_s += r.wall_s;
    }
    t
}

const CSV_HEADER: &str = "engine,factor,value,status,wall_s,steps,finite,complete,penetration_m,penetration_limit_m,energy_growth_rel,standing_drift_m,mirror_diff,rerun_bit_diffs,contract_broken,beyond_round_off,unexplained,reason";

fn csv_escape(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\"").replace('\n', " "))
    } else {
        s.to_string()
    }
}

fn check_value(r: &CellResult, name: &str) -> String {
    match r.invariants.get(name) {
        Some(c) if c.applies => format!("{:e}", c.value),
        Some(_) => "n/a".into(),
        None => String::new(),
    }
}

pub fn csv(results: &[CellResult]) -> String {
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for r in results {
        let viol: Vec<String> = r.issues.iter().map(|i| i.check.clone()).collect();
        let _ = writeln!(
            s,
            "{},{},{},{},{:.4},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.engine,
            r.factor,
            r.label,
            r.status.as_str(),
            r.wall_s,
            r.steps,
            check_value(r, "finite"),
            check_value(r, "complete"),
            check_value(r, "penetration"),
            r.invariants
                .get("penetration")
                .map(|c| format!("{:e}", c.limit))
                .unwrap_or_default(),
            check_value(r, "energy"),
            check_value(r, "standing"),
            check_value(r, "mirror"),
            check_value(r, "rerun"),
            viol.join(" "),
            r.beyond_strict()
                .iter()
                .map(|j| j.check.as_str())
                .collect::<Vec<_>>()
                .join(" "),
            r.unexplained(),
            csv_escape(&r.reason)
        );
    }
    s
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn colour(r: &CellResult) -> (&'static str, &'static str) {
    use crate::report::verdict::Verdict;
    match r.status {
        Status::Skipped => ("#d0d0d0", "skipped"),
        Status::Unsupported => ("#e8eaee", "unsupported"),
        _ if r.unexplained() > 0 => (Verdict::Differs.fill(), "contract broken or run failed"),
        Status::Failed => (Verdict::Known.fill(), "failed, known"),
        Status::Finished if !r.issues.is_empty() => {
            (Verdict::Known.fill(), "contract broken, known")
        }
        Status::Finished => (Verdict::Agree.fill(), "contract holds"),
    }
}

/// The contract's verdict over a set of cells: per invariant, the promise, the worst
/// measurement, holds / broken, and how many cells were beyond round-off.
fn contract_rows(
    results: &[&CellResult],
    contract: &crate::contract::Contract,
) -> crate::report::verdict::Rows {
    use crate::report::verdict::{VCell, Verdict};
    let mut rows = Vec::new();
    for name in CHECK_NAMES {
        let promise = contract.promise(name);
        let js: Vec<(&CellResult, &Judged)> = results
            .iter()
            .flat_map(|r| {
                r.judged
                    .iter()
                    .filter(|j| j.check == name)
                    .map(move |j| (*r, j))
            })
            .collect();
        let worst = js.iter().max_by(|a, b| {
            (a.1.value / a.1.limit.max(f64::MIN_POSITIVE))
                .total_cmp(&(b.1.value / b.1.limit.max(f64::MIN_POSITIVE)))
        });
        let broken: Vec<&(&CellResult, &Judged)> = js.iter().filter(|(_, j)| !j.holds).collect();
        let unexplained = broken
            .iter()
            .filter(|(r, _)| {
                r.issues
                    .iter()
                    .any(|i| i.check == name && i.explanation.is_none())
            })
            .count();
        let beyond = js.iter().filter(|(_, j)| !j.within_strict).count();
        let verdict = if js.is_empty() {
            VCell::new(Verdict::Info, "not measured", "")
        } else if unexplained > 0 {
            VCell::new(
                Verdict::Differs,
                "broken",
                format!("{} of {} cells beyond the contract", broken.len(), js.len()),
            )
        } else if !broken.is_empty() {
            VCell::new(
                Verdict::Known,
                "holds except known cases",
                format!("{} known cells, explained in the known list", broken.len()),
            )
        } else {
            VCell::new(Verdict::Agree, "holds", format!("{} cells", js.len()))
        };
        let worst_cell = match worst {
            Some((r, j)) => VCell::new(
                if j.holds {
                    Verdict::Info
                } else {
                    verdict.verdict
                },
                &format!("{:.3e}", j.value),
                format!("{}={}, limit there {:.3e}", r.factor, r.label, j.limit),
            ),
            None => VCell::new(Verdict::Info, "-", ""),
        };
        let strict = VCell::new(
            if beyond == 0 {
                Verdict::Agree
            } else {
                Verdict::Info
            },
            &format!("{beyond} of {} cells beyond", js.len()),
            "measured, not judged",
        );
        rows.push((
            vec![
                name.to_string(),
                promise.map(|p| p.describe()).unwrap_or_default(),
                promise.map(|p| p.measured.clone()).unwrap_or_default(),
            ],
            vec![verdict, worst_cell, strict],
        ));
    }
    rows
}

const CONTRACT_HEAD: [&str; 6] = [
    "invariant",
    "promised limit",
    "measurement behind it",
    "verdict",
    "worst cell (measured)",
    "round-off (strict) invariant",
];

/// `index.html`: every engine's contract verdict, one table per engine.
pub fn index_html(all: &[CellResult], contracts: &[crate::contract::Contract]) -> String {
    use crate::report::verdict;
    let mut body = String::new();
    for c in contracts {
        let rs: Vec<&CellResult> = all.iter().filter(|r| r.engine == c.engine).collect();
        let t = totals(&rs.iter().map(|r| (*r).clone()).collect::<Vec<_>>());
        let _ = writeln!(
            body,
            "<h2><a href=\"{0}.html\">{0}</a>: {1}</h2>\n<p>{2} cells: {3} finished, {4} failed, {5} unsupported, {6} skipped; {7} broken promises, {8} unexplained issues; {9} measurements beyond round-off within the contract.</p>",
            html_escape(&c.engine),
            html_escape(&c.kind),
            t.cells,
            t.finished,
            t.failed,
            t.unsupported,
            t.skipped,
            t.violations,
            t.unexplained,
            t.beyond_strict
        );
        body.push_str(&verdict::table_html(
            &format!("contract-{}", c.engine),
            &CONTRACT_HEAD.map(String::from),
            &contract_rows(&rs, c),
        ));
    }
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>rockbench stress: contracts</title>\n<style>body{{font-family:sans-serif;margin:1.5em;max-width:1200px}}{}</style></head><body>\n<h1>Stability map: every engine against its own contract</h1>\n{}{}</body></html>\n",
        verdict::CSS,
        verdict::legend_html(&[
            (verdict::Verdict::Agree, "holds"),
            (verdict::Verdict::Known, "broken in known, explained cases"),
            (verdict::Verdict::Differs, "broken"),
            (verdict::Verdict::Info, "measurement"),
        ]),
        body
    )
}

/// A self-contained HTML page with an inline SVG map (one row per factor, one cell per
/// value) and the table of every cell.
pub fn html(
    engine: &str,
    results: &[CellResult],
    contract: &crate::contract::Contract,
    meta: &serde_json::Value,
) -> String {
    use crate::report::verdict;
    let mut factors: Vec<&str> = Vec::new();
    for r in results {
        if !factors.contains(&r.factor.as_str()) {
            factors.push(&r.factor);
        }
    }
    let cols = factors
        .iter()
        .map(|f| results.iter().filter(|r| r.factor == *f).count())
        .max()
        .unwrap_or(1);
    let (cw, ch, lw) = (92.0, 40.0, 130.0);
    let width = lw + cw * cols as f64 + 10.0;
    let height = ch * factors.len() as f64 + 10.0;
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" font-family=\"sans-serif\" font-size=\"12\">\n"
    );
    for (row, f) in factors.iter().enumerate() {
        let y = 5.0 + ch * row as f64;
        let _ = writeln!(
            svg,
            "<text x=\"4\" y=\"{}\" font-weight=\"bold\">{f}</text>",
            y + ch / 2.0 + 4.0
        );
        for (col, r) in results.iter().filter(|r| r.factor == *f).enumerate() {
            let x = lw + cw * col as f64;
            let (fill, what) = colour(r);
            let mut tip = format!(
                "{}={}: {} ({what}), {:.2} s wall",
                r.factor,
                r.label,
                r.status.as_str(),
                r.wall_s
            );
            if !r.reason.is_empty() {
                let _ = write!(tip, "\n{}", r.reason);
            }
            for c in &r.invariants.checks {
                if c.applies {
                    let _ = write!(
                        tip,
                        "\n{}: {} ({})",
                        c.name,
                        if r.judged.iter().any(|j| j.check == c.name && !j.holds) {
                            "BROKEN (contract)"
                        } else if c.passed {
                            "ok"
                        } else {
                            "beyond round-off, within the contract"
                        },
                        c.detail
                    );
                }
            }
            for i in &r.issues {
                if let Some(e) = &i.explanation {
                    let _ = write!(tip, "\nknown ({}): {e}", i.check);
                }
            }
            let _ = writeln!(
                svg,
                "<g><title>{}</title><rect x=\"{x}\" y=\"{y}\" width=\"{}\" height=\"{}\" rx=\"4\" fill=\"{fill}\" stroke=\"#555\"/><text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text><text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"10\">{}</text></g>",
                html_escape(&tip),
                cw - 4.0,
                ch - 4.0,
                x + (cw - 4.0) / 2.0,
                y + 15.0,
                html_escape(&r.label),
                x + (cw - 4.0) / 2.0,
                y + 29.0,
                if r.status == Status::Finished {
                    format!("{:.2} s", r.wall_s)
                } else {
                    r.status.as_str().to_string()
                }
            );
        }
    }
    svg.push_str("</svg>\n");
    let t = totals(results);
    let mut rows = String::new();
    for r in results {
        let checks: Vec<String> = CHECK_NAMES
            .iter()
            .map(|n| match r.invariants.get(n) {
                Some(c) if !c.applies => "n/a".to_string(),
                Some(c) => {
                    let broken = r.judged.iter().any(|j| j.check == c.name && !j.holds);
                    let mark = if broken {
                        "✗ "
                    } else if !c.passed {
                        "~ "
                    } else {
                        ""
                    };
                    format!("{mark}{:.2e}", c.value)
                }
                None => "".to_string(),
            })
            .collect();
        let issues: Vec<String> = r
            .issues
            .iter()
            .map(|i| match &i.explanation {
                Some(e) => format!("{} (known: {})", i.check, e),
                None => format!("{} UNEXPLAINED: {}", i.check, i.detail),
            })
            .collect();
        let _ = writeln!(
            rows,
            "<tr style=\"background:{}\"><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{}</td>{}<td>{}</td></tr>",
            colour(r).0,
            html_escape(&r.factor),
            html_escape(&r.label),
            r.status.as_str(),
            r.wall_s,
            r.steps,
            checks
                .iter()
                .map(|c| format!("<td>{}</td>", html_escape(c)))
                .collect::<String>(),
            html_escape(&format!("{} {}", r.reason, issues.join("; ")))
        );
    }
    let legend = verdict::legend_html(&[
        (verdict::Verdict::Agree, "finished, the contract holds"),
        (
            verdict::Verdict::Known,
            "broken or failed, known and explained",
        ),
        (
            verdict::Verdict::Differs,
            "contract broken or run failed, unexplained",
        ),
        (
            verdict::Verdict::Info,
            "unsupported by the engine / not built",
        ),
    ]);
    let refs: Vec<&CellResult> = results.iter().collect();
    let contract_table = verdict::table_html(
        "contract",
        &CONTRACT_HEAD.map(String::from),
        &contract_rows(&refs, contract),
    );
    format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>rockbench stress: {engine}</title>\n<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse;font-size:12px}}td,th{{border:1px solid #999;padding:2px 6px}}pre{{font-size:11px}}{}</style></head><body>\n<h1>Stability map: {engine}</h1>\n<h2>Verdict: the contract of {engine} ({})</h2>\n{legend}{contract_table}<p>{} cells: {} finished, {} failed, {} unsupported, {} skipped; {} broken promises of the contract, {} unexplained issues; {} measurements beyond round-off within the contract. One factor at a time around the base case: {}. Hover a cell for its details.</p>\n<ul>{}</ul>\n{svg}\n<h2>Cells</h2>\n<table><tr><th>factor</th><th>value</th><th>status</th><th>wall s</th><th>steps</th><th>finite</th><th>complete</th><th>penetration m</th><th>energy growth</th><th>standing drift m</th><th>mirror diff</th><th>rerun diffs</th><th>reason / broken promises</th></tr>\n{rows}</table>\n<h2>Settings and versions</h2>\n<pre>{}</pre>\n</body></html>\n",
        verdict::CSS,
        html_escape(&contract.kind),
        t.cells,
        t.finished,
        t.failed,
        t.unsupported,
        t.skipped,
        t.violations,
        t.unexplained,
        t.beyond_strict,
        html_escape(BASE_CASE),
        FACTORS
            .iter()
            .map(|(f, d)| format!("<li><b>{f}</b>: {}</li>", html_escape(d)))
            .collect::<String>(),
        html_escape(&serde_json::to_string_pretty(meta).unwrap_or_default())
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_generated_scene_is_valid() {
        for quick in [true, false] {
            for c in grid(quick) {
                assert!(
                    c.scene.is_ok(),
                    "{}={}: {:?}",
                    c.factor,
                    c.label,
                    c.scene.err()
                );
            }
        }
    }

    /// The time-step factor sets every engine's step (it set the native engine's alone, and
    /// the map showed rapier at its default 1 ms across 1e-5 .. 5e-3 s).
    #[test]
    fn the_time_step_factor_is_every_engines_step() {
        for c in grid(false).iter().filter(|c| c.factor == "dt") {
            let scene = c.scene.as_ref().unwrap();
            let steps = registry::ENGINES
                .iter()
                .filter_map(|e| e.settings.as_ref()?.step)
                .filter_map(|k| k.split_once('.'));
            let mut n = 0;
            for (table, key) in steps {
                let v = scene.engines.get(table).and_then(|t| t.get(key));
                assert_eq!(v.and_then(|v| v.as_f64()), Some(c.value), "{table}.{key}");
                n += 1;
            }
            assert!(n >= 4, "{n} engines with a step");
        }
    }

    #[test]
    fn the_full_grid_spans_the_stated_ranges() {
        let g = grid(false);
        let range = |f: &str| {
            let v: Vec<f64> = g
                .iter()
                .filter(|c| c.factor == f)
                .map(|c| c.value)
                .collect();
            (
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            )
        };
        assert_eq!(range("dt"), (1e-5, 5e-3));
        assert_eq!(range("theta"), (0.5, 1.0));
        assert_eq!(range("slenderness"), (1.0, 20.0));
        assert_eq!(range("size"), (0.05, 20.0));
        assert_eq!(range("mass_ratio"), (1e-3, 1e3));
        assert_eq!(range("friction"), (0.05, 2.0));
        assert_eq!(range("blocks"), (1.0, 100.0));
        assert_eq!(range("duration").1, 60.0);
        let mut in_grid: Vec<&str> = g.iter().map(|c| c.factor).collect();
        in_grid.dedup();
        let listed: Vec<&str> = FACTORS.iter().map(|f| f.0).collect();
        assert_eq!(in_grid, listed, "FACTORS must describe the grid, in order");
        let col = g
            .iter()
            .find(|c| c.factor == "blocks" && c.value == 100.0)
            .unwrap();
        assert_eq!(col.scene.as_ref().unwrap().blocks.len(), 100);
        let wall = g
            .iter()
            .find(|c| c.factor == "wall_courses" && c.value == 2.0)
            .unwrap();
        let w = wall.scene.as_ref().unwrap();
        // Second course rests on the first.
        let lay = w.layout();
        assert!(lay.supports[4].is_some());
        assert!((lay.blocks[4].z - 0.75).abs() < 1e-12);
        assert_eq!(w.blocks.len(), 9);
    }

    #[test]
    fn known_list_matches_engine_factor_value_and_check() {
        let k: KnownList = toml::from_str(
            "[[known]]\nengine = \"native\"\nfactor = \"theta\"\nvalue = \"0.5\"\ncheck = \"energy\"\nreason = \"r\"\n",
        )
        .unwrap();
        assert!(k.explain("native", "theta", "0.5", "energy").is_some());
        assert!(k.explain("native", "theta", "0.6", "energy").is_none());
        assert!(k.explain("housner", "theta", "0.5", "energy").is_none());
        assert!(k.explain("native", "theta", "0.5", "mirror").is_none());
    }

    /// An entry of a known list that can match no cell, explains nothing or is given twice
    /// is an error naming it (such entries silently never matched).
    #[test]
    fn known_entries_that_match_no_cell_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("known.toml");
        let entry = |engine: &str, factor: &str, value: &str, check: &str, reason: &str| {
            format!(
                "[[known]]\nengine = \"{engine}\"\nfactor = \"{factor}\"\nvalue = \"{value}\"\ncheck = \"{check}\"\nreason = \"{reason}\"\n"
            )
        };
        let good = entry("native", "theta", "0.5", "energy", "r");
        std::fs::write(&p, &good).unwrap();
        assert_eq!(KnownList::load(&p).unwrap().known.len(), 1);
        for (text, says) in [
            (
                entry("natve", "theta", "0.5", "energy", "r"),
                "known[0].engine: unknown engine `natve`",
            ),
            (
                entry("native", "thta", "0.5", "energy", "r"),
                "known[0].factor: no factor `thta`",
            ),
            (
                entry("native", "theta", "0.50", "energy", "r"),
                "known[0].value: `0.50` is no value of factor `theta`",
            ),
            (
                entry("native", "theta", "*", "energi", "r"),
                "known[0].check: no check `energi`",
            ),
            (
                entry("native", "theta", "0.5", "run", " "),
                "known[0].reason: must say why",
            ),
            (
                format!("{good}{good}"),
                "known[1].check: this entry is given twice",
            ),
            (
                good.replace("value = \"0.5\"", "value = 0.5"),
                "known[0].value: invalid type",
            ),
        ] {
            std::fs::write(&p, &text).unwrap();
            let e = KnownList::load(&p).unwrap_err();
            assert!(e.starts_with(&format!("{}: {says}", p.display())), "{e}");
        }
    }

    #[test]
    fn an_unknown_engine_is_skipped_not_failed() {
        let cell = &grid(true)[0];
        let r = run_cell(
            "no-such-engine",
            cell,
            &Tolerances::default(),
            Duration::from_secs(5),
            &Judge::default(),
        );
        assert_eq!(r.status, Status::Skipped);
        assert_eq!(r.unexplained(), 0);
    }
}

/// Engine faults: a panic, a hang past the timeout, NaN and a truncated trajectory are each a
/// failed cell or a violated invariant with its reason, and the map goes on.
#[cfg(test)]
mod fault_tests {
    use super::*;
    use crate::engines::{Progress, RunOutput};

    #[derive(Clone, Copy)]
    enum Fault {
        /// Every block sinks into the ground by this much (m) for the whole run.
        Sink(f64),
        Panic,
        Hang,
        NaN,
        Truncated,
        Error,
        /// Every run takes this long (ms) and answers right.
        Slow(u64),
    }

    struct Faulty(Fault);

    impl Engine for Faulty {
        fn name(&self) -> &'static str {
            "faulty"
        }
        fn run_reporting(
            &self,
            scene: &Scene,
            _progress: Progress,
        ) -> Result<RunOutput, EngineError> {
            let mut out = engine_by_name("housner").unwrap().run(scene)?;
            match self.0 {
                Fault::Sink(d) => {
                    for b in &mut out.trajectory.blocks {
                        b.z.iter_mut().for_each(|z| *z -= d);
                    }
                }
                Fault::Panic => panic!("worker crashed"),
                Fault::Hang => loop {
                    std::thread::sleep(Duration::from_millis(50));
                },
                Fault::NaN => out.trajectory.blocks[0].phi[5] = f64::NAN,
                Fault::Slow(ms) => std::thread::sleep(Duration::from_millis(ms)),
                Fault::Truncated => {
                    let n = out.trajectory.len() / 2;
                    out.trajectory.t.truncate(n);
                    for b in &mut out.trajectory.blocks {
                        for v in [
                            &mut b.x,
                            &mut b.z,
                            &mut b.phi,
                            &mut b.vx,
                            &mut b.vz,
                            &mut b.omega,
                        ] {
                            v.truncate(n);
                        }
                    }
                }
                Fault::Error => {
                    return Err(EngineError::Failed {
                        engine: "faulty",
                        message: "worker exited with status 3".into(),
                    });
                }
            }
            Ok(out)
        }
    }

    fn run(fault: Fault) -> CellResult {
        run_as("faulty", fault, &Judge::default())
    }

    /// The faulty engine judged by the contract of `engine`.
    fn run_as(engine: &str, fault: Fault, judge: &Judge) -> CellResult {
        let cell = grid(true)
            .into_iter()
            .find(|c| c.factor == "theta")
            .unwrap();
        run_cell_with(
            engine,
            Arc::new(move |_: &str| Ok(Box::new(Faulty(fault)) as Box<dyn Engine>)),
            &cell,
            &Tolerances::default(),
            Duration::from_millis(1500),
            judge,
        )
    }

    /// A block 1 mm into the ground is beyond round-off (1e-4 of its 1 m width) but within a
    /// soft contact's contract (3e-2): measured, not failed, for rapier; broken for the native
    /// engine's round-off contract; broken for rapier at 10 cm, or once its contract is
    /// tightened.
    #[test]
    fn each_engine_is_held_to_its_own_contract_and_a_broken_one_fails() {
        let r = run_as("rapier", Fault::Sink(1e-3), &Judge::default());
        assert_eq!(r.unexplained(), 0, "{:?}", r.issues);
        let beyond: Vec<&str> = r.beyond_strict().iter().map(|j| j.check.as_str()).collect();
        assert_eq!(beyond, ["penetration"]);
        let r = run_as("native", Fault::Sink(1e-3), &Judge::default());
        assert_eq!(r.unexplained(), 1);
        assert_eq!(r.issues[0].check, "penetration");
        assert!(
            r.issues[0].detail.contains("contract of `native`"),
            "{}",
            r.issues[0].detail
        );
        let r = run_as("rapier", Fault::Sink(0.1), &Judge::default());
        assert_eq!(r.unexplained(), 1, "{:?}", r.issues);
        let tight = Judge {
            contracts: Contracts::with_changes(&["rapier.penetration=1e-4".into()]).unwrap(),
            known: KnownList::default(),
        };
        let r = run_as("rapier", Fault::Sink(1e-3), &tight);
        assert_eq!(r.unexplained(), 1);
        assert!(totals(&[r]).violations == 1);
    }

    #[test]
    fn a_panicking_engine_is_a_failed_cell_with_its_message() {
        let r = run(Fault::Panic);
        assert_eq!(r.status, Status::Failed);
        assert!(r.reason.contains("panic: worker crashed"), "{}", r.reason);
        assert_eq!(r.unexplained(), 1);
    }

    #[test]
    fn a_hanging_engine_is_abandoned_after_the_timeout() {
        let t0 = Instant::now();
        let r = run(Fault::Hang);
        assert!(t0.elapsed() < Duration::from_secs(10));
        assert_eq!(r.status, Status::Failed);
        assert!(r.reason.contains("timed out after 1.5 s"), "{}", r.reason);
    }

    /// The timeout is each run's, not the cell's: a cell makes three runs or more (the main
    /// run, the mirrored run, the rerun), and PyBullet's 10-brick column standing for 60 s
    /// (about 200 s a run, five runs with the mirror's probes) was abandoned at 600 s, its
    /// first timeout in the full map.
    #[test]
    fn a_cell_of_runs_each_within_the_timeout_finishes_however_long_it_takes() {
        let t0 = Instant::now();
        let r = run(Fault::Slow(600));
        assert!(
            t0.elapsed() > Duration::from_millis(1800),
            "{:?}",
            t0.elapsed()
        );
        assert_eq!(r.status, Status::Finished, "{}", r.reason);
        assert_eq!(r.unexplained(), 0, "{:?}", r.issues);
        let r = run(Fault::Slow(2000));
        assert_eq!(r.status, Status::Failed);
        assert!(r.reason.contains("timed out after 1.5 s"), "{}", r.reason);
    }

    #[test]
    fn nan_and_truncated_trajectories_violate_invariants() {
        let r = run(Fault::NaN);
        assert_eq!(r.status, Status::Finished);
        assert!(r.invariants.get("finite").unwrap().violated());
        let r = run(Fault::Truncated);
        assert!(
            r.invariants.get("complete").unwrap().violated(),
            "{:?}",
            r.invariants.get("complete")
        );
        assert!(r.unexplained() >= 1);
    }

    #[test]
    fn an_engine_error_is_a_failed_cell_with_its_reason() {
        let r = run(Fault::Error);
        assert_eq!(r.status, Status::Failed);
        assert!(
            r.reason.contains("worker exited with status 3"),
            "{}",
            r.reason
        );
    }

    #[test]
    fn command_line_changes_are_checked() {
        let c = Contracts::with_changes(&["rapier.standing=1e-9".into()]).unwrap();
        assert_eq!(c.of("rapier").promise("standing").unwrap().limit, 1e-9);
        assert_eq!(c.of("native").promise("standing").unwrap().limit, 1e-9);
        for bad in [
            "rapier",
            "rapier.nope=1",
            "rapier.energy=x",
            "rapier.energy=-1",
        ] {
            let e = Contracts::with_changes(&[bad.into()]).unwrap_err();
            assert!(e.starts_with(&format!("--contract {bad}: ")), "{e}");
            assert!(!e.contains('\n'));
        }
    }
}
