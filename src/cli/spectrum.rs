//! `rockbench spectrum SCENE_OR_BLOCK --pulse P --ratios ... --engines ... --out DIR`: overturning
//! spectra (see `crate::spectrum`). Writes DIR/minimum.csv, DIR/map.csv, one SVG per pulse
//! (`DIR/spectrum-<pulse>.svg`) and DIR/spectrum.json (settings, versions, the command).

use crate::spectrum::{self, Pulse, Request, Settings};
use anyhow::{Context, Result, anyhow};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct SpectrumArgs {
    /// A scene file (its blocks, contact and engine settings; its excitation is replaced by the
    /// pulse) or a single block `BxH` in metres, e.g. `0.2x4`.
    target: String,
    /// Pulse families, comma-separated: rectangular, half-sine, one-sine, one-cosine, ricker.
    #[arg(long, default_value = "half-sine", value_delimiter = ',')]
    pulse: Vec<String>,
    /// Frequency ratios omega_p / p of the minimum search: `a,b,c` or `from:to:n`.
    #[arg(long, default_value = "1:10:10", allow_hyphen_values = true)]
    ratios: String,
    /// Ratios of the overturn/safe map (default: those of --ratios).
    #[arg(long, allow_hyphen_values = true)]
    map_ratios: Option<String>,
    /// Amplitudes a_p / (g tan alpha) of the map: `a,b,c` or `from:to:n`; `none`: no map.
    #[arg(long, default_value = "1:10:19", allow_hyphen_values = true)]
    amplitudes: String,
    /// Engines, comma-separated.
    #[arg(long, default_value = "housner,native", value_delimiter = ',', long_help = super::engines_help("Engines, comma-separated."))]
    engines: Vec<String>,
    /// Also find the lowest amplitude that overturns without an impact first.
    #[arg(long)]
    no_impact: bool,
    /// Friction coefficient of a `BxH` block on the ground (high: pure rocking) [default: 2];
    /// a scene file gives its own.
    #[arg(long)]
    friction: Option<f64>,
    /// Override a scene field (repeatable), e.g. --set native.dt=5e-4.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Run length after the pulse, in units of 1/p.
    #[arg(long, default_value_t = 30.0)]
    tail: f64,
    /// Relative width of the bisection bracket of a minimum.
    #[arg(long, default_value_t = 1e-4)]
    tolerance: f64,
    /// First amplitude of the upward scan.
    #[arg(long, default_value_t = 1.0)]
    scan_from: f64,
    /// Relative step of the upward scan.
    #[arg(long, default_value_t = 0.05)]
    scan_step: f64,
    /// Largest amplitude scanned.
    #[arg(long, default_value_t = 100.0)]
    scan_to: f64,
    /// The similarity law: also run this second block `BxH` (same friction and --set) at
    /// --similarity-at and write DIR/similarity.{csv,svg} (phi/alpha against p t, every engine).
    #[arg(long)]
    similarity: Option<String>,
    /// `RATIO,AMPLITUDE` of the similarity runs (the first pulse of --pulse) [default: 3,2.2].
    #[arg(long)]
    similarity_at: Option<String>,
    /// Run every native run to its end (no early stop at overturning, rest or low energy).
    #[arg(long)]
    no_early_stop: bool,
    /// Run store: each run's outcome is kept here under the content hash of its scene, engine
    /// and program, and read back by a later spectrum, so an interrupted spectrum resumes and an
    /// unchanged one costs nothing.
    #[arg(long, default_value = ".cache/rockbench/spectrum")]
    cache_dir: PathBuf,
    /// Make every run again (the store is neither read nor written).
    #[arg(long)]
    no_cache: bool,
    #[arg(long, default_value = "out/spectrum")]
    out: PathBuf,
}

pub fn run(a: SpectrumArgs) -> Result<()> {
    super::check_sets(&a.set)?;
    super::check_out_dir(&a.out)?;
    let pulses = a
        .pulse
        .iter()
        .map(|p| Pulse::parse(p))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| anyhow!("--pulse: {e}"))?;
    let ratios = spectrum::parse_list(&a.ratios, "--ratios").map_err(|e| anyhow!(e))?;
    let map_ratios = match &a.map_ratios {
        Some(r) => spectrum::parse_list(r, "--map-ratios").map_err(|e| anyhow!(e))?,
        None => ratios.clone(),
    };
    let amplitudes = if a.amplitudes == "none" {
        if a.map_ratios.is_some() {
            return Err(anyhow!(
                "--map-ratios: there is no map with --amplitudes none (give the map's amplitudes)"
            ));
        }
        Vec::new()
    } else {
        spectrum::parse_list(&a.amplitudes, "--amplitudes").map_err(|e| anyhow!(e))?
    };
    for e in &a.engines {
        spectrum::engine(e).map_err(|e| anyhow!("--engines: {e}"))?;
    }
    let settings = Settings {
        tail: a.tail,
        tolerance: a.tolerance,
        scan_from: a.scan_from,
        scan_step: a.scan_step,
        scan_to: a.scan_to,
        early_stop: !a.no_early_stop,
    };
    settings.check().map_err(|e| anyhow!(e))?;
    // Each run lasts the pulse and the tail: a duration of the scene's own is not used.
    if let Some(s) = a.set.iter().find(|s| {
        s.split_once('=')
            .is_some_and(|(k, _)| k.trim() == "duration")
    }) {
        return Err(anyhow!(
            "--set {s}: a spectrum's runs last their pulse plus --tail, whatever the duration"
        ));
    }
    if a.similarity_at.is_some() && a.similarity.is_none() {
        return Err(anyhow!(
            "--similarity-at: only with --similarity (the second block)"
        ));
    }
    let scene_file = spectrum::parse_block(&a.target).is_none();
    if scene_file && a.friction.is_some() {
        return Err(anyhow!(
            "--friction: {} gives its own friction (--set contact.friction=... changes it)",
            a.target
        ));
    }
    let friction = a.friction.unwrap_or(2.0);
    if !(friction.is_finite() && friction >= 0.0) {
        return Err(anyhow!(
            "--friction must be a non-negative number (got {})",
            crate::scene::num(friction)
        ));
    }
    if friction > crate::scene::MAX_FRICTION {
        return Err(anyhow!(
            "--friction {} is above {:e}: a block that must not slide needs a friction above its B/H only, and larger ones leave the contact problems ill-scaled",
            crate::scene::num(friction),
            crate::scene::MAX_FRICTION
        ));
    }
    let base = match spectrum::parse_block(&a.target) {
        Some((b, h)) => spectrum::block_scene(b, h, friction, &a.set).map_err(|e| anyhow!(e))?,
        None => {
            let path = PathBuf::from(&a.target);
            if !path.exists() {
                return Err(anyhow!(
                    "{}: neither a scene file nor a block BxH (e.g. 0.2x4)",
                    a.target
                ));
            }
            crate::engines::registry::load_scene_with_overrides(&path, &a.set)?
        }
    };
    let similar = match &a.similarity {
        Some(bh) => {
            let (b, h) = spectrum::parse_block(bh)
                .ok_or_else(|| anyhow!("--similarity: `{bh}` is not a block BxH (e.g. 0.12x6)"))?;
            let at = spectrum::parse_list(
                a.similarity_at.as_deref().unwrap_or("3,2.2"),
                "--similarity-at",
            )
            .map_err(|e| anyhow!(e))?;
            if at.len() != 2 {
                return Err(anyhow!(
                    "--similarity-at: give RATIO,AMPLITUDE (got {} numbers)",
                    at.len()
                ));
            }
            let other = spectrum::block_scene(b, h, friction, &a.set)
                .map_err(|e| anyhow!("--similarity {bh}: {e}"))?;
            // The amplitude is in units of g tan(alpha), alpha the second block's.
            let peak = at[1] * other.gravity * b / h;
            let limit = crate::scene::MAX_PEAK_G * crate::excitation::records::STANDARD_GRAVITY;
            if peak.abs() > limit {
                return Err(anyhow!(
                    "--similarity-at: the amplitude {} g tan(alpha) of {bh} is a ground acceleration of {} m/s^2, above {} g",
                    crate::scene::num(at[1]),
                    crate::scene::num(peak),
                    crate::scene::MAX_PEAK_G
                ));
            }
            Some((other, at[0], at[1]))
        }
        None => None,
    };
    let req = Request {
        pulses: pulses.clone(),
        engines: a.engines.clone(),
        ratios,
        map_ratios: if amplitudes.is_empty() {
            Vec::new()
        } else {
            map_ratios
        },
        map_amplitudes: amplitudes,
        no_impact: a.no_impact,
        settings,
        store: if a.no_cache {
            None
        } else {
            std::fs::create_dir_all(&a.cache_dir)
                .map_err(|e| anyhow!("--cache-dir: {}: {e}", a.cache_dir.display()))?;
            Some(a.cache_dir.clone())
        },
    };
    if let (Some((other, ratio, _)), Some(first)) = (&similar, a.engines.first()) {
        let eng = spectrum::engine(first).map_err(|e| anyhow!(e))?;
        let sp = spectrum::Spectrum::new(other, eng.as_ref(), pulses[0], &req.settings);
        sp.check_step()
            .and_then(|()| sp.check_longest_run([*ratio].iter()))
            .map_err(|e| anyhow!("--similarity: {e}"))?;
    }
    // A Ctrl-C starts no run after it and stops those under way; nothing is written, and the
    // same command resumes from the runs kept in the store.
    let interrupt = crate::interrupt::Interrupt::install();
    let stopped = || -> anyhow::Error {
        crate::interrupt::Stopped::kept_in(req.store.as_deref(), "the spectrum").into()
    };
    let res = spectrum::compute(&base, &req, &|l| eprintln!("{l}"));
    if interrupt.requested() {
        return Err(stopped());
    }
    let res = res.map_err(|e| anyhow!(e))?;
    // The similarity runs are made before anything is written: a failed one leaves no outputs.
    let mut similarity_files = None;
    if let Some((other, ratio, amp)) = &similar {
        let st = Settings {
            early_stop: false,
            ..req.settings.clone()
        };
        let mut plot = crate::report::svg::Plot {
            title: format!(
                "Similarity: {} pulse, omega_p/p = {ratio}, a_p/(g tan alpha) = {amp}",
                pulses[0].name()
            ),
            x_label: "p t".into(),
            y_label: "phi / alpha".into(),
            ..Default::default()
        };
        let mut csv = String::from("engine,p_t,phi_over_alpha_a,phi_over_alpha_b\n");
        let colors = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];
        let name = |s: &crate::scene::Scene| {
            let b = &s.blocks[0];
            let (_, al) = spectrum::p_alpha(s);
            format!("{}x{} m (alpha {al:.3})", b.width, b.height)
        };
        for (k, e) in a.engines.iter().enumerate() {
            let eng = spectrum::engine(e).map_err(|e| anyhow!(e))?;
            let similar = spectrum::similarity(
                &base,
                other,
                eng.as_ref(),
                (pulses[0], *ratio, *amp),
                &st,
                2001,
            );
            if interrupt.requested() {
                return Err(stopped());
            }
            let (pt, ya, yb) = similar.map_err(|err| anyhow!("--similarity: {e}: {err}"))?;
            let diff = ya
                .iter()
                .zip(&yb)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            eprintln!("similarity {e}: max |difference| of phi/alpha {diff:.5}");
            for i in 0..pt.len() {
                csv += &format!("{e},{:.6},{:.8},{:.8}\n", pt[i], ya[i], yb[i]);
            }
            let c = colors[k % colors.len()].to_string();
            plot.curves.push(crate::report::svg::Curve {
                name: format!("{e}: {}", name(&base)),
                color: c.clone(),
                dashed: false,
                x: pt.clone(),
                y: ya,
            });
            plot.curves.push(crate::report::svg::Curve {
                name: format!("{e}: {} (max diff {diff:.4})", name(other)),
                color: c,
                dashed: true,
                x: pt,
                y: yb,
            });
        }
        similarity_files = Some((csv, plot.render()));
    }
    drop(interrupt);
    let out = &a.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    // The figures and similarity files of an earlier spectrum here (its spectrum.json says
    // so) that this one does not write would sit beside its outputs.
    if out.join("spectrum.json").is_file() {
        super::remove_stale(out, &["spectrum-*.svg", "similarity.csv", "similarity.svg"])?;
    }
    let write = |name: &str, text: String| -> Result<()> {
        let p = out.join(name);
        std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))
    };
    write("minimum.csv", spectrum::minimum_csv(&res))?;
    write("map.csv", spectrum::map_csv(&res))?;
    for &p in &pulses {
        write(
            &format!("spectrum-{}.svg", p.name()),
            spectrum::svg(&res, p, &a.engines),
        )?;
    }
    if let Some((csv, svg)) = similarity_files {
        write("similarity.csv", csv)?;
        write("similarity.svg", svg)?;
    }
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let b0 = &base.blocks[0];
    let json = serde_json::json!({
        "command": command,
        "provenance": crate::report::provenance::Provenance::collect(&command),
        "scene": base.to_json(),
        "normalisation": {
            "block": b0.name,
            "width_m": b0.width,
            "height_m": b0.height,
            "gravity": base.gravity,
            "p_per_s": res.p,
            "alpha_rad": res.alpha,
            "g_tan_alpha_m_per_s2": base.gravity * res.alpha.tan(),
            "ratio": "omega_p / p",
            "amplitude": "a_p / (g tan alpha)",
        },
        "pulses": pulses.iter().map(|p| serde_json::json!({
            "pulse": p.name(),
            "duration_times_omega_p": p.duration(1.0),
        })).collect::<Vec<_>>(),
        "settings": req.settings,
        "search": "upward scan from scan_from by factors (1 + scan_step) to the first overturning amplitude (down first if that one overturns, through safe amplitudes to 1 when it starts above 1), then bisection to a relative width `tolerance`; the minimum is the bracket's upper end",
        "early_stop": if req.settings.early_stop {
            format!("native runs stop after the pulse when a block lies on its side (overturned), when every block is still for {} s (at rest), or when a single block inside its critical angle has less than {} of its tipping energy m g (R - H/2); each map cell's `stop` says which", crate::engines::native::REST_WINDOW, spectrum::SAFE_ENERGY_FRACTION)
        } else {
            "off: every run lasts its full duration".into()
        },
        "ratios": req.ratios,
        "map_ratios": req.map_ratios,
        "map_amplitudes": req.map_amplitudes,
        "engines": res.engines,
        "minima": res.minima,
        "wall_s": res.wall_s,
        "runs_from_store": res.from_store,
        "store": req.store.as_ref().map(|d| d.display().to_string()),
    });
    write(
        "spectrum.json",
        serde_json::to_string_pretty(&json).expect("json") + "\n",
    )?;
    println!(
        "{} minima, {} map cells in {:.1} s ({} runs from the store); wrote {}",
        res.minima.len(),
        res.map.len(),
        res.wall_s,
        res.from_store,
        out.display()
    );
    Ok(())
}
