//! The common output of every engine: sampled block states.
//!
//! `trajectory.csv` has a column `t` (s), then for every block `<name>_x`, `<name>_z`
//! (centroid, m, relative to the ground's current position), `<name>_phi` (rad,
//! counter-clockwise), `<name>_vx`, `<name>_vz` (m/s) and `<name>_omega` (rad/s).

use std::io::Write;
use std::path::Path;

/// The sampled history of one block.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BlockHistory {
    pub name: String,
    pub x: Vec<f64>,
    pub z: Vec<f64>,
    pub phi: Vec<f64>,
    pub vx: Vec<f64>,
    pub vz: Vec<f64>,
    pub omega: Vec<f64>,
}

/// Sample times and block histories.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Trajectory {
    pub t: Vec<f64>,
    pub blocks: Vec<BlockHistory>,
}

pub const FIELDS: [&str; 6] = ["x", "z", "phi", "vx", "vz", "omega"];

impl Trajectory {
    /// The median spacing of the sample times (`None` for fewer than two samples).
    pub fn sample_interval(&self) -> Option<f64> {
        let mut gaps: Vec<f64> = self.t.windows(2).map(|w| w[1] - w[0]).collect();
        if gaps.is_empty() {
            return None;
        }
        gaps.sort_by(f64::total_cmp);
        Some(gaps[gaps.len() / 2])
    }

    pub fn new(names: &[String]) -> Self {
        Trajectory {
            t: Vec::new(),
            blocks: names
                .iter()
                .map(|n| BlockHistory {
                    name: n.clone(),
                    ..Default::default()
                })
                .collect(),
        }
    }

    /// Append one sample: `(x, z, phi, vx, vz, omega)` per block.
    pub fn push(&mut self, t: f64, states: &[[f64; 6]]) {
        self.t.push(t);
        for (b, s) in self.blocks.iter_mut().zip(states) {
            b.x.push(s[0]);
            b.z.push(s[1]);
            b.phi.push(s[2]);
            b.vx.push(s[3]);
            b.vz.push(s[4]);
            b.omega.push(s[5]);
        }
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// The samples before `t` (at least the first).
    pub fn before(&self, t: f64) -> Trajectory {
        let n = self.t.partition_point(|&s| s < t).max(1).min(self.t.len());
        let cut = |v: &Vec<f64>| v[..n.min(v.len())].to_vec();
        Trajectory {
            t: cut(&self.t),
            blocks: self
                .blocks
                .iter()
                .map(|b| BlockHistory {
                    name: b.name.clone(),
                    x: cut(&b.x),
                    z: cut(&b.z),
                    phi: cut(&b.phi),
                    vx: cut(&b.vx),
                    vz: cut(&b.vz),
                    omega: cut(&b.omega),
                })
                .collect(),
        }
    }
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Rotation and rate of block `i`, absolute (`relative_to` `None`) or relative to block
    /// `relative_to` (what rocks on the interface of a block standing on another).
    pub fn rotation(&self, i: usize, relative_to: Option<usize>) -> (Vec<f64>, Vec<f64>) {
        let b = &self.blocks[i];
        match relative_to {
            None => (b.phi.clone(), b.omega.clone()),
            Some(l) => {
                let base = &self.blocks[l];
                let diff = |a: &[f64], c: &[f64]| a.iter().zip(c).map(|(x, y)| x - y).collect();
                (diff(&b.phi, &base.phi), diff(&b.omega, &base.omega))
            }
        }
    }

    pub fn block(&self, name: &str) -> Option<&BlockHistory> {
        self.blocks.iter().find(|b| b.name == name)
    }

    /// True when every value is finite.
    pub fn is_finite(&self) -> bool {
        self.t.iter().all(|x| x.is_finite())
            && self.blocks.iter().all(|b| {
                [&b.x, &b.z, &b.phi, &b.vx, &b.vz, &b.omega]
                    .iter()
                    .all(|v| v.iter().all(|x| x.is_finite()))
            })
    }

    pub fn header(&self) -> Vec<String> {
        let mut h = vec!["t".to_string()];
        for b in &self.blocks {
            for f in FIELDS {
                h.push(format!("{}_{f}", b.name));
            }
        }
        h
    }

    pub fn write_csv(&self, path: &Path) -> std::io::Result<()> {
        self.write_csv_to(std::io::BufWriter::new(std::fs::File::create(path)?))
    }

    /// The CSV of [`Trajectory::write_csv`], written to `w`.
    pub fn write_csv_to(&self, mut w: impl Write) -> std::io::Result<()> {
        writeln!(w, "{}", self.header().join(","))?;
        for k in 0..self.t.len() {
            write!(w, "{:e}", self.t[k])?;
            for b in &self.blocks {
                for v in [b.x[k], b.z[k], b.phi[k], b.vx[k], b.vz[k], b.omega[k]] {
                    write!(w, ",{v:e}")?;
                }
            }
            writeln!(w)?;
        }
        w.flush()
    }

    /// Read a `trajectory.csv` (as written by any engine). Errors name the line.
    pub fn read_csv(path: &Path) -> Result<Trajectory, String> {
        let text = crate::input_file::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        Self::parse_csv(&text).map_err(|e| format!("{}: {e}", path.display()))
    }

    pub fn parse_csv(text: &str) -> Result<Trajectory, String> {
        let mut lines = text.lines();
        let header: Vec<&str> = lines
            .next()
            .ok_or("empty trajectory file")?
            .split(',')
            .map(str::trim)
            .collect();
        if header.first() != Some(&"t") || !(header.len() - 1).is_multiple_of(6) || header.len() < 7
        {
            return Err("header must be `t` then six columns per block".into());
        }
        let mut names = Vec::new();
        for chunk in header[1..].chunks(6) {
            let name = chunk[0]
                .strip_suffix("_x")
                .ok_or_else(|| format!("column `{}` should end in _x", chunk[0]))?;
            for (c, f) in chunk.iter().zip(FIELDS) {
                if *c != format!("{name}_{f}") {
                    return Err(format!("column `{c}` should be `{name}_{f}`"));
                }
            }
            names.push(name.to_string());
        }
        let mut tr = Trajectory::new(&names);
        for (ln, line) in lines.enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let vals: Result<Vec<f64>, _> =
                line.split(',').map(|s| s.trim().parse::<f64>()).collect();
            let vals = vals.map_err(|e| format!("line {}: {e}", ln + 2))?;
            if vals.len() != header.len() {
                return Err(format!(
                    "line {}: {} values, header has {}",
                    ln + 2,
                    vals.len(),
                    header.len()
                ));
            }
            let states: Vec<[f64; 6]> = vals[1..]
                .chunks(6)
                .map(|c| [c[0], c[1], c[2], c[3], c[4], c[5]])
                .collect();
            tr.push(vals[0], &states);
        }
        if tr.is_empty() {
            return Err("no samples".into());
        }
        Ok(tr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trip_is_exact() {
        let mut tr = Trajectory::new(&["a".to_string(), "b".to_string()]);
        tr.push(
            0.0,
            &[
                [1.0, 2.0, 0.1, 0.0, 0.0, 0.0],
                [0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
            ],
        );
        tr.push(
            1e-3,
            &[
                [1.0 / 3.0, 2.0, -0.1, 1e-300, 0.0, 3.0],
                [0.1, 0.2, 0.3, 0.4, 0.5, 0.6],
            ],
        );
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.csv");
        tr.write_csv(&p).unwrap();
        assert_eq!(Trajectory::read_csv(&p).unwrap(), tr);
    }
}
