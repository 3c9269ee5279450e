//! Record suites: a manifest (TOML) listing ground-motion records (PEER `.AT2` or two-column
//! CSV files) with their metadata. `make records` writes the FEMA P695 sets as suites
//! (validation/records/p695/*.toml); a user writes one for a folder of records. The format is
//! in docs/fragility.md.
//!
//! Loading reads every record file and checks it against the manifest: a problem is one
//! [`SceneError`] line `manifest: record[k].field: problem`. The values the manifest states
//! (dt, npts, PGA, PGV) must match the file; the ones it leaves out are computed.

use super::records::{self, STANDARD_GRAVITY};
use crate::scene::{RecordFormat, SceneError, num};
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Relative agreement required between a manifest's PGA and PGV and the file's.
pub const METADATA_TOLERANCE: f64 = 1e-3;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ManifestFile {
    suite: SuiteHeader,
    #[serde(default)]
    record: Vec<RecordEntry>,
}

/// `[suite]`: name and description.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuiteHeader {
    pub name: String,
    #[serde(default)]
    pub description: String,
    #[serde(default)]
    pub source: String,
}

/// One `[[record]]` as written.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecordEntry {
    id: String,
    file: String,
    #[serde(default)]
    format: Option<RecordFormat>,
    #[serde(default)]
    record: Option<i64>,
    #[serde(default)]
    pair: Option<String>,
    #[serde(default)]
    event: String,
    #[serde(default)]
    year: Option<i64>,
    #[serde(default)]
    station: String,
    #[serde(default)]
    component: String,
    #[serde(default)]
    dt: Option<f64>,
    #[serde(default)]
    npts: Option<usize>,
    #[serde(default)]
    pga: Option<f64>,
    #[serde(default)]
    pgv: Option<f64>,
    #[serde(default)]
    p695_factor: Option<f64>,
}

/// One component of a suite, read and checked.
#[derive(Debug, Clone, Serialize)]
pub struct SuiteRecord {
    pub id: String,
    /// The record file, absolute (relative paths are taken from the manifest's folder).
    pub file: PathBuf,
    pub format: RecordFormat,
    /// Components of one recording share a pair: the bootstrap resamples pairs.
    pub pair: String,
    pub event: String,
    pub year: Option<i64>,
    pub station: String,
    pub component: String,
    /// Time step (the first one for a CSV), s.
    pub dt: f64,
    pub npts: usize,
    /// Peak ground acceleration, g.
    pub pga: f64,
    /// Peak ground velocity of the piecewise-linear acceleration from rest, m/s.
    pub pgv: f64,
    /// Duration of the record (last sample time), s.
    pub duration: f64,
    /// The FEMA P695 normalisation factor of the record (both components share it).
    pub p695_factor: Option<f64>,
    /// sha256 of the file's bytes.
    pub sha256: String,
}

/// A suite: header and its records.
#[derive(Debug, Clone, Serialize)]
pub struct Suite {
    pub header: SuiteHeader,
    pub manifest: PathBuf,
    pub records: Vec<SuiteRecord>,
}

/// Peak |a| (in the file's unit) and peak |v| (m/s, exact for piecewise-linear acceleration
/// from rest) of samples, with `unit` converting values to m/s^2.
pub fn peaks(s: &records::Samples, unit: f64) -> (f64, f64) {
    let mut v: f64 = 0.0;
    let mut pv: f64 = 0.0;
    let mut pa: f64 = 0.0;
    for k in 0..s.t.len() {
        pa = pa.max(s.v[k].abs());
        if k > 0 {
            let h = s.t[k] - s.t[k - 1];
            let (a0, a1) = (s.v[k - 1] * unit, s.v[k] * unit);
            // Within a segment where a changes sign, |v| peaks where a = 0.
            if a0 * a1 < 0.0 {
                let f = a0 / (a0 - a1);
                pv = pv.max((v + 0.5 * a0 * f * h).abs());
            }
            v += 0.5 * h * (a0 + a1);
            pv = pv.max(v.abs());
        }
    }
    (pa, pv)
}

/// Read and check a suite manifest and every record it names.
pub fn load_suite(path: &Path) -> Result<Suite, SceneError> {
    let file = path.display().to_string();
    let text = crate::input_file::read_to_string(path)
        .map_err(|e| SceneError::new(&file, "suite", format!("cannot read the manifest: {e}")))?;
    let m: ManifestFile = crate::scene::toml_fields(&file, &text, "suite")?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    if m.suite.name.trim().is_empty() {
        return Err(SceneError::new(&file, "suite.name", "must not be empty"));
    }
    if m.record.is_empty() {
        return Err(SceneError::new(
            &file,
            "record",
            "the suite lists no records (`[[record]]` tables)",
        ));
    }
    let mut seen = BTreeSet::new();
    let mut out = Vec::new();
    // Each record's motion: its samples, in m/s^2 (the same motion in other bytes: other
    // line ends, a header, comments, blanks).
    let mut motions: Vec<String> = Vec::new();
    for (k, r) in m.record.iter().enumerate() {
        let field = |f: &str| format!("record[{k}].{f}");
        let err = |f: &str, msg: String| SceneError::new(&file, field(f), msg);
        if r.id.trim().is_empty() {
            return Err(err("id", "must not be empty".into()));
        }
        if !seen.insert(r.id.trim().to_string()) {
            return Err(err("id", format!("`{}` is listed twice", r.id)));
        }
        let fpath = base.join(&r.file);
        let fmt = r.format.unwrap_or_else(|| {
            if r.file.to_ascii_lowercase().ends_with(".at2") {
                RecordFormat::At2
            } else {
                RecordFormat::Csv
            }
        });
        let bytes = crate::input_file::read(&fpath)
            .map_err(|e| err("file", format!("cannot read {}: {e}", fpath.display())))?;
        let text = String::from_utf8(bytes.clone())
            .map_err(|_| err("file", format!("{} is not UTF-8 text", fpath.display())))?;
        if text.trim().is_empty() {
            return Err(err("file", format!("{} is empty", fpath.display())));
        }
        let (s, unit) = records::parse_acceleration(fmt, &text)
            .map_err(|e| err("file", format!("{}: {e}", fpath.display())))?;
        motions.push({
            let samples: Vec<u8> = (s.t.iter())
                .chain(s.v.iter().map(|v| v * unit).collect::<Vec<_>>().iter())
                .flat_map(|x| x.to_le_bytes())
                .collect();
            crate::digest::sha256_hex(&samples)
        });
        let npts = s.t.len();
        let dt = s.t[1] - s.t[0];
        let (pa, pgv) = peaks(&s, unit);
        let pga = pa * unit / STANDARD_GRAVITY;
        if pga <= 0.0 {
            return Err(err(
                "file",
                format!("{}: every acceleration is zero", fpath.display()),
            ));
        }
        if let Some(n) = r.npts
            && n != npts
        {
            return Err(err(
                "npts",
                format!("{n}, but {} has {npts} samples", fpath.display()),
            ));
        }
        if let Some(d) = r.dt
            && !(d.is_finite() && (d - dt).abs() <= 1e-9 * dt.max(1.0))
        {
            return Err(err(
                "dt",
                format!(
                    "{} s, but {} has DT = {} s",
                    num(d),
                    fpath.display(),
                    num(dt)
                ),
            ));
        }
        let close = |a: f64, b: f64| (a - b).abs() <= METADATA_TOLERANCE * b.abs();
        if let Some(p) = r.pga
            && !(p.is_finite() && close(p, pga))
        {
            return Err(err(
                "pga",
                format!(
                    "{} g, but the peak of {} is {pga:.6} g",
                    num(p),
                    fpath.display()
                ),
            ));
        }
        if let Some(p) = r.pgv
            && !(p.is_finite() && close(p, pgv))
        {
            return Err(err(
                "pgv",
                format!(
                    "{} m/s, but the peak velocity of {} is {pgv:.6} m/s",
                    num(p),
                    fpath.display()
                ),
            ));
        }
        if let Some(f) = r.p695_factor
            && !(f.is_finite() && f > 0.0)
        {
            return Err(err("p695_factor", format!("must be > 0 (got {})", num(f))));
        }
        out.push(SuiteRecord {
            id: r.id.clone(),
            file: std::path::absolute(&fpath).unwrap_or(fpath.clone()),
            format: fmt,
            pair: r
                .pair
                .clone()
                .or(r.record.map(|x| x.to_string()))
                .unwrap_or_else(|| r.id.clone()),
            event: r.event.clone(),
            year: r.year,
            station: r.station.clone(),
            component: r.component.clone(),
            dt,
            npts,
            pga,
            pgv,
            duration: *s.t.last().expect("two samples"),
            p695_factor: r.p695_factor,
            sha256: crate::digest::sha256_hex(&bytes),
        });
        // The same motion under two ids would count as two independent records in a fit.
        let new = out.last().expect("just pushed");
        let motion = motions.last().expect("just pushed");
        if let Some(j) = (0..out.len() - 1).find(|&j| &motions[j] == motion) {
            let same = if out[j].sha256 == new.sha256 {
                "the same bytes"
            } else {
                "the same samples"
            };
            return Err(err(
                "file",
                format!(
                    "{} has {same} as record[{j}] (`{}`): one motion counted twice",
                    fpath.display(),
                    out[j].id
                ),
            ));
        }
    }
    Ok(Suite {
        header: m.suite,
        manifest: std::path::absolute(path).unwrap_or(path.to_path_buf()),
        records: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peak_velocity_is_exact_between_samples() {
        // a = 1, -1 m/s^2 at t = 0, 1: v peaks at t = 0.5 with 0.25 m/s, ends at 0.
        let s = records::Samples {
            t: vec![0.0, 1.0],
            v: vec![1.0, -1.0],
        };
        let (pa, pv) = peaks(&s, 1.0);
        assert_eq!(pa, 1.0);
        assert!((pv - 0.25).abs() < 1e-15, "{pv}");
    }
}
