//! Plain-text tables for the terminal: columns left-aligned to their widest cell (in
//! characters), two spaces apart, each line's trailing spaces trimmed.

/// The header line and one line per row, each ending in a newline.
pub fn aligned<H: AsRef<str>, C: AsRef<str>>(head: &[H], rows: &[Vec<C>]) -> String {
    let mut widths: Vec<usize> = head.iter().map(|h| h.as_ref().chars().count()).collect();
    for row in rows {
        for (k, cell) in row.iter().enumerate() {
            if k == widths.len() {
                widths.push(0);
            }
            widths[k] = widths[k].max(cell.as_ref().chars().count());
        }
    }
    let line = |cells: &mut dyn Iterator<Item = &str>| {
        let padded: Vec<String> = cells
            .enumerate()
            .map(|(k, c)| format!("{c:<width$}", width = widths[k]))
            .collect();
        padded.join("  ").trim_end().to_string() + "\n"
    };
    let mut out = line(&mut head.iter().map(AsRef::as_ref));
    for row in rows {
        out += &line(&mut row.iter().map(AsRef::as_ref));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::aligned;

    #[test]
    fn columns_align_on_their_widest_cell_counted_in_characters() {
        let s = |v: &[&str]| v.iter().map(|c| c.to_string()).collect::<Vec<_>>();
        let table = aligned(
            &s(&["case", "phi"]),
            &[s(&["two-block", "1e-3"]), s(&["µ-test", ""])],
        );
        assert_eq!(
            table, "case       phi\ntwo-block  1e-3\nµ-test\n",
            "{table}"
        );
    }
}
