//! `rockbench spectrum SCENE_OR_BLOCK --pulse P --ratios ... --engines ... --out DIR`: overturning
//! spectra (see `crate::spectrum`). Writes DIR/minimum.csv, DIR/map.csv, one SVG per pulse
//! (DIR/spectrum-<pulse>.svg) and DIR/spectrum.json (settings, versions, the command).

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
    #[arg(long, default_value = "housner,native", value_delimiter = ',')]
    engines: Vec<String>,
    /// Also find the lowest amplitude that overturns without an impact first.
    #[arg(long)]
    no_impact: bool,
    /// Friction coefficient of a `BxH` block on the ground (high: pure rocking).
    #[arg(long, default_value_t = 2.0)]
    friction: f64,
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
    /// Run every native run to its end (no early stop at overturning, rest or low energy).
    #[arg(long)]
    no_early_stop: bool,
    #[arg(long, default_value = "out/spectrum")]
    out: PathBuf,
}

pub fn run(a: SpectrumArgs) -> Result<()> {
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
    let base = match spectrum::parse_block(&a.target) {
        Some((b, h)) => {
            if !(a.friction.is_finite() && a.friction >= 0.0) {
                return Err(anyhow!(
                    "--friction must be a non-negative number (got {})",
                    a.friction
                ));
            }
            spectrum::block_scene(b, h, a.friction, &a.set).map_err(|e| anyhow!(e))?
        }
        None => {
            let path = PathBuf::from(&a.target);
            if !path.exists() {
                return Err(anyhow!(
                    "{}: neither a scene file nor a block BxH (e.g. 0.2x4)",
                    a.target
                ));
            }
            let s = crate::scene::load_scene_with_overrides(&path, &a.set)?;
            s.check()?;
            s
        }
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
    };
    let res = spectrum::compute(&base, &req, &|l| eprintln!("{l}")).map_err(|e| anyhow!(e))?;
    let out = &a.out;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
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
        "search": "upward scan from scan_from by factors (1 + scan_step) to the first overturning amplitude (down first if that one overturns), then bisection to a relative width `tolerance`; the minimum is the bracket's upper end",
        "early_stop": if req.settings.early_stop {
            format!("native runs stop after the pulse when a block is beyond its critical angle turning outwards (overturned), when every block is still for {} s (at rest), or when a single block inside its critical angle has less than {} of its tipping energy m g (R - H/2); each map cell's `stop` says which", crate::engines::native::REST_WINDOW, spectrum::SAFE_ENERGY_FRACTION)
        } else {
            "off: every run lasts its full duration".into()
        },
        "ratios": req.ratios,
        "map_ratios": req.map_ratios,
        "map_amplitudes": req.map_amplitudes,
        "engines": res.engines,
        "minima": res.minima,
        "wall_s": res.wall_s,
    });
    write(
        "spectrum.json",
        serde_json::to_string_pretty(&json).expect("json") + "\n",
    )?;
    println!(
        "{} minima, {} map cells in {:.1} s; wrote {}",
        res.minima.len(),
        res.map.len(),
        res.wall_s,
        out.display()
    );
    Ok(())
}
