//! Reading ground-motion records: two-column CSV and PEER NGA `.AT2`.
//!
//! Errors are plain strings naming the line; the caller prefixes the file and scene field.

use crate::scene::RecordFormat;

/// Standard gravity used to convert `.AT2` accelerations (in g) to m/s^2.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// An acceleration record of `format`: its samples, and the factor that makes its values
/// m/s^2 (a CSV record is in m/s^2; an `.AT2` record in the units its third line states).
pub fn parse_acceleration(format: RecordFormat, text: &str) -> Result<(Samples, f64), String> {
    match format {
        RecordFormat::Csv => Ok((parse_two_column(text, Quantity::Acceleration)?, 1.0)),
        RecordFormat::At2 => {
            let unit = at2_unit(text)?;
            Ok((parse_at2(text)?, unit))
        }
    }
}

/// The factor to m/s^2 of the values of an `.AT2` record, from its third line (`ACCELERATION
/// TIME SERIES IN UNITS OF G`, or units named otherwise: `IN CM/SEC/SEC`, `(GAL)`): g where it
/// names no units; cm/s^2 and m/s^2 read as such; a velocity or displacement series, other
/// units, or several, an error.
fn at2_unit(text: &str) -> Result<f64, String> {
    let Some(line) = text.trim_start_matches('\u{feff}').lines().nth(2) else {
        return Ok(STANDARD_GRAVITY); // too short: parse_at2 says so
    };
    let up = line.to_ascii_uppercase();
    for kind in ["VELOCITY", "DISPLACEMENT"] {
        if up.contains(kind) {
            return Err(format!(
                "line 3: `{}`: a {} series; an .AT2 record must be accelerations",
                line.trim(),
                kind.to_ascii_lowercase()
            ));
        }
    }
    let normalise = |token: &str| {
        token
            .trim_matches(['.', ',', ';', ':', '(', ')', '[', ']'])
            .replace("SEC", "S")
            .replace("**", "^")
    };
    let factor = |unit: &str| match unit {
        "G" => Some(STANDARD_GRAVITY),
        "CM/S/S" | "CM/S2" | "CM/S^2" | "GAL" | "GALS" => Some(0.01),
        "MM/S/S" | "MM/S2" | "MM/S^2" => Some(0.001),
        "M/S/S" | "M/S2" | "M/S^2" => Some(1.0),
        _ => None,
    };
    let unknown = |unit: &str| {
        format!("line 3: units `{unit}`: expected an acceleration in G, CM/S/S, MM/S/S or M/S/S")
    };
    if let Some(at) = up.find("UNITS OF") {
        let unit = normalise(
            up[at + "UNITS OF".len()..]
                .split_whitespace()
                .next()
                .unwrap_or(""),
        );
        return factor(&unit).ok_or_else(|| unknown(&unit));
    }
    // Units named otherwise (`IN CM/SEC/SEC`, `UNITS: GAL`, `(GAL)`): every word that reads
    // as units; g only where none does (a line in cm/s^2 read as g is 980 times too strong).
    let words: Vec<String> = up
        .split(|c: char| c.is_whitespace() || matches!(c, ':' | '(' | ')' | ',' | '='))
        .map(normalise)
        .filter(|w| !w.is_empty())
        .collect();
    let named: Vec<&String> = words
        .iter()
        .filter(|w| factor(w).is_some() || w.contains('/') || w.ends_with("^2"))
        .collect();
    match named.as_slice() {
        [] => Ok(STANDARD_GRAVITY),
        [unit] => factor(unit).ok_or_else(|| unknown(unit)),
        several => Err(format!(
            "line 3: `{}`: names several units ({}): write one, `UNITS OF G` for instance",
            line.trim(),
            several
                .iter()
                .map(|w| w.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// A sampled history: strictly increasing times and one value per time.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    pub t: Vec<f64>,
    pub v: Vec<f64>,
}

/// What the values of a two-column record are, in SI units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// m/s^2.
    Acceleration,
    /// m.
    Displacement,
}

impl Quantity {
    fn unit(self) -> &'static str {
        match self {
            Quantity::Acceleration => "m/s^2",
            Quantity::Displacement => "m",
        }
    }
}

/// The units a header field names, if it names any this module knows: in brackets
/// (`acc (g)`, `t [s]`), after the last `_`, `-` or blank (`acc_g`), or the whole field (`s`);
/// normalised (`M/SEC/SEC` is `m/s^2`). Other words (`acc (EW)`) name none.
fn header_unit(field: &str) -> Option<&'static str> {
    let known = |w: &str| -> Option<&'static str> {
        let w = w
            .trim()
            .to_ascii_lowercase()
            .replace(' ', "")
            .replace("sec", "s")
            .replace("**", "^")
            .replace('\u{b2}', "^2");
        Some(match w.as_str() {
            "s" | "seconds" | "second" => "s",
            "ms" | "millis" | "milliseconds" => "ms",
            "min" | "minutes" => "min",
            "m/s^2" | "m/s2" | "m/s/s" => "m/s^2",
            "g" | "gs" => "g",
            "cm/s^2" | "cm/s2" | "cm/s/s" | "gal" | "gals" => "cm/s^2",
            "mm/s^2" | "mm/s2" | "mm/s/s" => "mm/s^2",
            "in/s^2" | "in/s2" | "in/s/s" => "in/s^2",
            "ft/s^2" | "ft/s2" | "ft/s/s" => "ft/s^2",
            "m/s" => "m/s",
            "cm/s" => "cm/s",
            "m" | "metres" | "meters" => "m",
            "cm" => "cm",
            "mm" => "mm",
            "in" | "inches" => "in",
            "ft" | "feet" => "ft",
            _ => return None,
        })
    };
    let bracketed = field
        .split(['(', '[', '{'])
        .skip(1)
        .filter_map(|rest| rest.split([')', ']', '}']).next());
    let suffix = field.rsplit(['_', '-', ' ']).next().filter(|w| *w != field);
    bracketed
        .chain(suffix)
        .chain(std::iter::once(field))
        .find_map(known)
}

/// A header that names units other than a record's own (seconds, and `quantity`'s SI unit):
/// its values would be read in the wrong units without a word (`acc (g)` read as m/s^2 is 9.8
/// times too weak).
fn check_header_units(cols: &[&str], quantity: Quantity, line: &str) -> Result<(), String> {
    for (k, (col, want)) in cols.iter().zip(["s", quantity.unit()]).enumerate() {
        if let Some(unit) = header_unit(col)
            && unit != want
        {
            let what = if k == 0 { "times" } else { "values" };
            return Err(format!(
                "header `{line}` names {what} in {unit}: a CSV record's times are in s and its \
                 values in {}; convert them (an acceleration may be scaled with `scale`)",
                quantity.unit()
            ));
        }
    }
    Ok(())
}

/// Two columns `time, value` separated by a comma, semicolon, tab or spaces. One header line
/// (the first line that is not blank or a `#` comment, its first field not a number) and `#`
/// comment lines are skipped; any other line that is not two numbers is an error, never dropped.
/// A header naming units other than s and `quantity`'s (`acc (g)`, `time (ms)`) is an error:
/// they are not read as SI.
pub fn parse_two_column(text: &str, quantity: Quantity) -> Result<Samples, String> {
    // A byte-order mark (some spreadsheets write one) is not part of the first field.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut t = Vec::new();
    let mut v = Vec::new();
    let mut first = true;
    for (ln, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let may_be_header = std::mem::replace(&mut first, false);
        // Comma- or semicolon-separated fields may be padded with blanks; a field left empty
        // between two values (`0,,0.1`) is a missing value, not a separator.
        let cols: Vec<&str> = if line.contains([',', ';']) {
            let mut cols: Vec<&str> = line.split([',', ';']).map(str::trim).collect();
            while cols.last() == Some(&"") {
                cols.pop();
            }
            cols
        } else {
            line.split_whitespace().collect()
        };
        // A line of separators alone (`,` or `;;`) holds no field, not even a header's.
        let Some(first_field) = cols.first() else {
            return Err(format!("line {}: no values: `{line}`", ln + 1));
        };
        let header = may_be_header && first_field.parse::<f64>().is_err();
        if !header && cols.contains(&"") {
            return Err(format!("line {}: an empty field: `{line}`", ln + 1));
        }
        if header {
            check_header_units(&cols, quantity, line)
                .map_err(|e| format!("line {}: {e}", ln + 1))?;
        }
        let nums: Result<Vec<f64>, _> = cols.iter().map(|c| c.parse::<f64>()).collect();
        match nums {
            Err(_) if header => continue,
            Err(_) => return Err(format!("line {}: not two numbers: `{line}`", ln + 1)),
            Ok(n) if n.len() != 2 => {
                return Err(format!(
                    "line {}: expected 2 columns (time, value), found {}",
                    ln + 1,
                    n.len()
                ));
            }
            Ok(n) => {
                if !n[0].is_finite() || !n[1].is_finite() {
                    return Err(format!("line {}: value is not finite", ln + 1));
                }
                if t.is_empty() && n[0] < 0.0 {
                    return Err(format!(
                        "line {}: time {} is before 0 (a record starts at t >= 0, the start of the run)",
                        ln + 1,
                        n[0]
                    ));
                }
                if let Some(&last) = t.last()
                    && n[0] <= last
                {
                    return Err(format!(
                        "line {}: time {} does not increase (previous {last})",
                        ln + 1,
                        n[0]
                    ));
                }
                t.push(n[0]);
                v.push(n[1]);
            }
        }
    }
    if t.len() < 2 {
        return Err("needs at least two samples".into());
    }
    Ok(Samples { t, v })
}

/// PEER NGA `.AT2`: three free header lines, then either `NPTS=  N, DT=  .005 SEC` (current
/// form) or `N  DT` followed by words (older form), then NPTS values in g, several per line.
/// Returns accelerations in g at `t_i = i * DT`.
pub fn parse_at2(text: &str) -> Result<Samples, String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() < 4 {
        return Err(format!(
            "has {} lines; a PEER .AT2 file has 4 header lines before the data",
            lines.len()
        ));
    }
    let header = lines[3];
    let (npts, dt) = parse_at2_header(header)
        .ok_or_else(|| format!("line 4: cannot read NPTS and DT from `{}`", header.trim()))?;
    if npts < 2 {
        return Err(format!(
            "line 4: NPTS = {npts}; at least 2 samples are needed"
        ));
    }
    if let Some(unit) = at2_dt_unit(header)
        && !matches!(unit.as_str(), "SEC" | "SECS" | "S" | "SECOND" | "SECONDS")
    {
        return Err(format!("line 4: DT in `{unit}`: expected seconds (SEC)"));
    }
    if !(dt.is_finite() && dt > 0.0) {
        return Err(format!(
            "line 4: DT = {} must be positive",
            crate::scene::num(dt)
        ));
    }
    let span = (npts - 1) as f64 * dt;
    if !span.is_finite() {
        return Err(format!(
            "line 4: NPTS = {npts} samples at DT = {} s span a time that is not finite",
            crate::scene::num(dt)
        ));
    }
    // The header is not trusted for the allocation: a value takes at least two bytes.
    let mut v = Vec::with_capacity(npts.min(text.len() / 2 + 1));
    for (k, line) in lines.iter().enumerate().skip(4) {
        for tok in line.split_whitespace() {
            let x: f64 = tok
                .parse()
                .map_err(|_| format!("line {}: `{tok}` is not a number", k + 1))?;
            if !x.is_finite() {
                return Err(format!("line {}: value is not finite", k + 1));
            }
            v.push(x);
        }
    }
    if v.len() < npts {
        return Err(format!(
            "header says NPTS = {npts} but the file has only {} values (truncated?)",
            v.len()
        ));
    }
    if v.len() > npts {
        return Err(format!(
            "header says NPTS = {npts} but the file has {} values",
            v.len()
        ));
    }
    let t = (0..npts).map(|i| i as f64 * dt).collect();
    Ok(Samples { t, v })
}

/// The word after DT's value in the `NPTS= N, DT= .005 SEC` form (`SEC`), if any.
fn at2_dt_unit(line: &str) -> Option<String> {
    let up = line.to_ascii_uppercase();
    if !up.contains("NPTS") {
        return None;
    }
    let rest = up[up.find("DT")? + 2..]
        .trim_start()
        .strip_prefix('=')?
        .trim_start();
    let rest =
        rest.trim_start_matches(|c: char| c.is_ascii_digit() || matches!(c, '.' | 'E' | '-' | '+'));
    let word: String = rest
        .trim_start()
        .chars()
        .take_while(|c| c.is_ascii_alphabetic())
        .collect();
    (!word.is_empty()).then_some(word)
}

fn parse_at2_header(line: &str) -> Option<(usize, f64)> {
    let up = line.to_ascii_uppercase();
    if up.contains("NPTS") && up.contains("DT") && up.contains('=') {
        let after = |key: &str| -> Option<String> {
            let i = up.find(key)? + key.len();
            let rest = up[i..].trim_start().strip_prefix('=')?.trim_start();
            Some(
                rest.chars()
                    .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'E' | '-' | '+'))
                    .collect(),
            )
        };
        let n: usize = after("NPTS")?.parse().ok()?;
        let dt: f64 = after("DT")?.parse().ok()?;
        return Some((n, dt));
    }
    let mut it = line.split_whitespace();
    let n: usize = it.next()?.trim_end_matches(',').parse().ok()?;
    let dt: f64 = it.next()?.trim_end_matches(',').parse().ok()?;
    Some((n, dt))
}

#[cfg(test)]
mod tests {
    use super::*;

    const ACC: Quantity = Quantity::Acceleration;

    const NEW: &str = "PEER NGA STRONG MOTION DATABASE RECORD\nTest 1940\nACCELERATION TIME SERIES IN UNITS OF G\nNPTS=    5, DT=   .0100 SEC\n 0.1 0.2 0.3\n 0.4 0.5\n";
    const OLD: &str = "PEER STRONG MOTION DATABASE RECORD\nTest\nACCELERATION TIME HISTORY IN UNITS OF G\n   5    0.0100    NPTS, DT\n 1.0E-01 2.0E-01 3.0E-01 4.0E-01 5.0E-01\n";

    #[test]
    fn at2_both_header_forms_read_the_same_samples() {
        let a = parse_at2(NEW).unwrap();
        let b = parse_at2(OLD).unwrap();
        assert_eq!(a, b);
        assert_eq!(a.v, vec![0.1, 0.2, 0.3, 0.4, 0.5]);
        assert!((a.t[4] - 0.04).abs() < 1e-15);
    }

    #[test]
    fn at2_fewer_values_than_npts_is_an_error() {
        let text = NEW.replace(" 0.4 0.5\n", "");
        let e = parse_at2(&text).unwrap_err();
        assert!(e.contains("NPTS = 5") && e.contains("only 3"), "{e}");
    }

    /// A header claiming 1e18 samples must not reserve memory for them.
    #[test]
    fn at2_huge_npts_is_an_error_not_an_allocation() {
        let text = NEW.replace("NPTS=    5", "NPTS=1000000000000000000");
        let e = parse_at2(&text).unwrap_err();
        assert!(
            e.contains("NPTS = 1000000000000000000") && e.contains("only 5"),
            "{e}"
        );
    }

    #[test]
    fn at2_time_span_overflow_is_an_error() {
        let text = NEW.replace("DT=   .0100", "DT=  1E308");
        let e = parse_at2(&text).unwrap_err();
        assert!(e.contains("not finite"), "{e}");
    }

    #[test]
    fn csv_with_header_and_comments() {
        let s = parse_two_column("# comment\ntime,acc\n0,0\n0.1,1.5\n0.2,-1\n", ACC).unwrap();
        assert_eq!(s.t, vec![0.0, 0.1, 0.2]);
        assert_eq!(s.v, vec![0.0, 1.5, -1.0]);
    }

    /// A header naming units other than s and the record's SI unit is refused, naming them
    /// (the values were read as m/s^2 or m whatever the header said); units it does not name,
    /// or words that are no units, are read as before.
    #[test]
    fn csv_header_units_other_than_si_are_refused() {
        let data = "\n0,0\n0.1,0.5\n0.2,0\n";
        for (header, named) in [
            ("time(s),acc(g)", "values in g"),
            ("t [s], a [cm/s^2]", "values in cm/s^2"),
            ("time_s,acc_gal", "values in cm/s^2"),
            ("time (ms),acc (m/s2)", "times in ms"),
            ("t,a [m/s]", "values in m/s"),
        ] {
            let e = parse_two_column(&format!("{header}{data}"), ACC).unwrap_err();
            assert!(
                e.starts_with(&format!("line 1: header `{header}` names {named}")),
                "{e}"
            );
        }
        for header in [
            "time,acc",
            "t [s],a [m/s^2]",
            "time_s,acc (EW)",
            "T (SEC),A (M/SEC/SEC)",
        ] {
            let s = parse_two_column(&format!("{header}{data}"), ACC).unwrap();
            assert_eq!(s.v, vec![0.0, 0.5, 0.0], "{header}");
        }
        let disp = Quantity::Displacement;
        let e = parse_two_column(&format!("t (s),d (cm){data}"), disp).unwrap_err();
        assert!(
            e.contains("names values in cm") && e.contains("values in m;"),
            "{e}"
        );
        assert!(parse_two_column(&format!("t (s),d (m){data}"), disp).is_ok());
    }

    /// Only the first line may be a header: a first sample with a unit (`5.0g`) is an error
    /// naming its line, not a second header dropped with its acceleration.
    #[test]
    fn csv_only_the_first_line_is_a_header() {
        let e = parse_two_column("0.00,5.0g\n0.05,6.0g\n0.10,0\n", ACC).unwrap_err();
        assert_eq!(e, "line 1: not two numbers: `0.00,5.0g`");
        let e = parse_two_column("time,acc\ns,m/s2\n0,0\n0.1,1\n", ACC).unwrap_err();
        assert!(e.starts_with("line 2: not two numbers"), "{e}");
    }

    /// The third line's units are read: cm/s^2 and m/s^2 converted, g by default, a velocity
    /// series or units that are not an acceleration refused; DT must be in seconds.
    #[test]
    fn at2_units_are_read_from_the_third_line() {
        let unit = |line: &str| {
            let text = NEW.replace("ACCELERATION TIME SERIES IN UNITS OF G", line);
            parse_acceleration(RecordFormat::At2, &text).map(|(s, u)| (s.v, u))
        };
        let (v, g) = unit("ACCELERATION TIME SERIES IN UNITS OF G").unwrap();
        assert_eq!((v[0], g), (0.1, STANDARD_GRAVITY));
        assert_eq!(unit("Test record").unwrap().1, STANDARD_GRAVITY);
        for (line, factor) in [
            ("ACCELERATION TIME SERIES IN UNITS OF CM/S/S", 0.01),
            ("ACCELERATION TIME SERIES IN UNITS OF cm/sec^2", 0.01),
            ("ACCELERATION IN UNITS OF GAL", 0.01),
            ("ACCELERATION TIME SERIES IN UNITS OF M/S2", 1.0),
            ("ACCELERATION TIME SERIES IN UNITS OF MM/S/S", 0.001),
        ] {
            assert_eq!(unit(line).unwrap().1, factor, "{line}");
        }
        // Units named without `UNITS OF` are read too (they were taken for g).
        for (line, factor) in [
            ("ACCELERATION TIME SERIES IN CM/SEC/SEC", 0.01),
            ("ACCELERATION TIME SERIES, UNITS: CM/S/S", 0.01),
            ("ACCELERATION (GAL)", 0.01),
            ("ACCELERATION IN M/S^2", 1.0),
            ("ACCELERATION TIME SERIES", STANDARD_GRAVITY),
        ] {
            assert_eq!(unit(line).unwrap().1, factor, "{line}");
        }
        let e = unit("ACCELERATION TIME SERIES IN FT/S/S").unwrap_err();
        assert!(e.contains("units `FT/S/S`"), "{e}");
        let e = unit("ACCELERATION IN G (CM/S/S)").unwrap_err();
        assert!(e.contains("names several units (G, CM/S/S)"), "{e}");
        let e = unit("VELOCITY TIME SERIES IN UNITS OF CM/S").unwrap_err();
        assert!(e.contains("a velocity series"), "{e}");
        let e = unit("DISPLACEMENT TIME SERIES IN UNITS OF CM").unwrap_err();
        assert!(e.contains("a displacement series"), "{e}");
        let e = unit("ACCELERATION TIME SERIES IN UNITS OF FT/S/S").unwrap_err();
        assert_eq!(
            e,
            "line 3: units `FT/S/S`: expected an acceleration in G, CM/S/S, MM/S/S or M/S/S"
        );
        let e = parse_at2(&NEW.replace(".0100 SEC", ".0100 MSEC")).unwrap_err();
        assert_eq!(e, "line 4: DT in `MSEC`: expected seconds (SEC)");
        assert!(parse_at2(&NEW.replace(".0100 SEC", ".0100")).is_ok());
    }

    /// A byte-order mark does not turn the first sample into a header; a record starts at
    /// t >= 0 (a part before the run would be dropped while its peak still scaled the record).
    #[test]
    fn csv_byte_order_mark_and_negative_times() {
        let s = parse_two_column("\u{feff}0,5.0\n0.02,0.2\n0.04,0.3\n", ACC).unwrap();
        assert_eq!(s.v, vec![5.0, 0.2, 0.3]);
        let e = parse_two_column("-1,5.0\n-0.5,5\n0,0.3\n0.1,0.3\n", ACC).unwrap_err();
        assert_eq!(
            e,
            "line 1: time -1 is before 0 (a record starts at t >= 0, the start of the run)"
        );
        assert_eq!(
            parse_at2(&format!("\u{feff}{NEW}")).unwrap(),
            parse_at2(NEW).unwrap()
        );
    }

    /// Separators: commas or semicolons padded with blanks, tabs or spaces; an empty field
    /// between two values is refused (it was read as two columns).
    #[test]
    fn csv_separators_and_empty_fields() {
        for text in [
            "0,1\n0.1,2\n",
            "0 ; 1\n0.1;2;\n",
            "0\t1\n0.1  2\n",
            "0,\t1\n0.1 ,2\n",
        ] {
            let s = parse_two_column(text, Quantity::Acceleration).unwrap();
            assert_eq!((s.t, s.v), (vec![0.0, 0.1], vec![1.0, 2.0]), "{text:?}");
        }
        assert!(parse_two_column("time,,acc\n0,0\n0.1,1\n", ACC).is_ok());
        let e = parse_two_column("0,0\n0.1,,0.2\n", ACC).unwrap_err();
        assert_eq!(e, "line 2: an empty field: `0.1,,0.2`");
        // A line of separators alone, where a header or the first samples may stand.
        for (text, line) in [
            (",\n0,0\n0.1,1\n", "line 1: no values: `,`"),
            ("# acc\n ; ;\n0,0\n", "line 2: no values: `; ;`"),
            ("0,0\n,,\n0.1,1\n", "line 2: no values: `,,`"),
        ] {
            assert_eq!(parse_two_column(text, ACC).unwrap_err(), line, "{text:?}");
        }
    }

    #[test]
    fn csv_non_increasing_time_names_the_line() {
        let e = parse_two_column("0,0\n0.1,1\n0.1,2\n", ACC).unwrap_err();
        assert!(e.starts_with("line 3"), "{e}");
    }
}
